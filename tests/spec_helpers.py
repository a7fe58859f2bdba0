"""Helpers of the spec tests (test_spec_validate, test_protocol; no tests here): a copy of
protocol/navkit.toml with one edit, and the line a text stands on in it. And the spec's
codes by name for every test that checks a coded field (`fwd_cmd == FWD_CMD["stop"]`,
never a bare 5)."""

from __future__ import annotations

from pathlib import Path

from navkit.paths import spec_path
from navkit.protocol import SPEC

__all__ = ["edited_spec", "line_of", "FWD_CMD", "TURN_CMD", "NAV_RESULT", "MSG_TYPE", "bit", "micro_cmd_field"]

FWD_CMD = SPEC.enums["fwd_cmd"].values          # fwd_cmd code by name
TURN_CMD = SPEC.enums["turn_cmd"].values        # turn_cmd code by name
NAV_RESULT = SPEC.enums["nav_result"].values    # lisp_data.nav_result code by name
MSG_TYPE = SPEC.enums["msg_type"].values        # frame type code by message name


def bit(flags: str, name: str) -> int:
    """The mask of flag `name` of the spec's flag set `flags` (micro_status, host_status,
    ...): bit values are never hard-coded in tests."""
    return 1 << SPEC.enums[flags].values[name]


def micro_cmd_field(name: str):
    """The spec's Field `name` of micro_cmd (its type, range min..max, ...)."""
    return SPEC.messages["micro_cmd"].field(name)


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
