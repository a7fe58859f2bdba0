"""Helpers of the spec tests (test_spec_validate, test_protocol; no tests here): a copy of
protocol/navkit.toml with one edit, and the line a text stands on in it."""

from __future__ import annotations

from pathlib import Path

from navkit.paths import spec_path

__all__ = ["edited_spec", "line_of"]


def edited_spec(tmp_path: Path, old: str, new: str, first: bool = False) -> Path:
    """A copy of the spec in `tmp_path` with `old` replaced by `new`: `old` must stand
    once, or with `first` at least once (its first place is edited)."""
    text = spec_path().read_text()
    assert (old in text) if first else (text.count(old) == 1), old
    path = tmp_path / "navkit.toml"
    path.write_text(text.replace(old, new, 1))
    return path


def line_of(path: Path, needle: str, after: str | None = None) -> int:
    """The line number (from 1) of the first line of `path` holding `needle`, after the
    first line holding `after` when given."""
    lines = path.read_text().splitlines()
    start = next(i for i, ln in enumerate(lines) if after in ln) if after else 0
    return next(i for i, ln in enumerate(lines[start:], start + 1) if needle in ln)
