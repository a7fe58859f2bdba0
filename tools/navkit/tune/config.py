"""The host's config folder: reading the loop gains and writing a tuned copy.

`write_tuned(src, dst, values, provenance)` copies every file of `src` to `dst` byte for
byte, except that in NavAndControl.ini's [micro_cfg_motion] the values of the keys in
`values` are replaced (the rest of each line, and every other line, unchanged) and a
comment block (one per tuning kind: an older block of the same kind is replaced) states
where the values come from. Values are the raw config units of the spec (the INI holds
raw values, as on the wire).
"""

from __future__ import annotations

import re
import shutil
from pathlib import Path

__all__ = ["ConfigError", "INI_NAME", "read_values", "write_tuned", "motion_value", "geometry_value"]

INI_NAME = "NavAndControl.ini"
_SECTION = "micro_cfg_motion"


class ConfigError(ValueError):
    """A config folder or INI that cannot be used; the text names file:line."""


_KEY_RE = re.compile(r"^([A-Za-z_][A-Za-z0-9_]*)(\s*=\s*)([^;#\r\n]*?)(\s*(?:[;#].*)?)(\r?\n?)$")
_SEC_RE = re.compile(r"^\[([^\]]+)\]")


def _ini(folder: Path) -> Path:
    ini = Path(folder) / INI_NAME
    if not ini.is_file():
        raise ConfigError(f"{ini}: no such file (a host config folder holds {INI_NAME})")
    return ini


def read_values(folder: Path) -> dict:
    """{(section, key): (value text, line number)} of the folder's NavAndControl.ini."""
    ini = _ini(folder)
    out, section = {}, None
    for n, line in enumerate(ini.read_text().splitlines(keepends=True), 1):
        m = _SEC_RE.match(line)
        if m:
            section = m.group(1).strip()
            continue
        m = _KEY_RE.match(line)
        if m and section:
            out[(section, m.group(1))] = (m.group(3).strip(), n)
    return out


def _number(folder: Path, section: str, key: str, default: float | None = None) -> float:
    vals = read_values(folder)
    if (section, key) not in vals:
        if default is not None:
            return default
        raise ConfigError(f"{_ini(folder)}: [{section}] {key}: missing")
    text, line = vals[(section, key)]
    try:
        return float(text)
    except ValueError:
        raise ConfigError(f"{_ini(folder)}:{line}: {key}: {text!r} is not a number") from None


def motion_value(folder: Path, key: str) -> float:
    """[micro_cfg_motion] key as a raw number; the spec default when the INI leaves it out."""
    from navkit import protocol

    return _number(folder, _SECTION, key, float(protocol.defaults("micro_cfg_motion")[key]))


def geometry_value(folder: Path, key: str) -> float:
    """[micro_cfg_geometry] key as a raw number; the spec default when the INI leaves it out."""
    from navkit import protocol

    return _number(folder, "micro_cfg_geometry", key, float(protocol.defaults("micro_cfg_geometry")[key]))


def _marker(kind: str) -> tuple[str, str]:
    return f"; --- navkit tune {kind}: begin", f"; --- navkit tune {kind}: end"


def write_tuned(src: Path, dst: Path, values: dict, kind: str, provenance: list[str]) -> Path:
    """Copy config folder src to dst (created; files in dst of the same names are replaced)
    with [micro_cfg_motion] `values` {key: raw int} and the provenance comment lines (without
    their '; ') in a block for `kind` ('wheel' or 'heading'). Returns dst's INI path.
    Raises ConfigError for a missing folder or a key the INI does not have."""
    src, dst = Path(src), Path(dst)
    ini = _ini(src)
    if src.resolve() == dst.resolve():
        raise ConfigError(f"{dst}: the output config folder is the input one (choose another --out)")
    dst.mkdir(parents=True, exist_ok=True)
    for f in sorted(src.iterdir()):
        if f.is_file():
            shutil.copy2(f, dst / f.name)
        elif f.is_dir():
            shutil.copytree(f, dst / f.name, dirs_exist_ok=True)
    lines = ini.read_text().splitlines(keepends=True)
    begin, end = _marker(kind)
    out, section, skipping, found, header_at = [], None, False, set(), None
    for line in lines:
        if line.startswith(begin):
            skipping = True
            continue
        if skipping:
            if line.startswith(end):
                skipping = False
            continue
        m = _SEC_RE.match(line)
        if m:
            section = m.group(1).strip()
            out.append(line)
            if section == _SECTION:
                header_at = len(out)
            continue
        m = _KEY_RE.match(line)
        if m and section == _SECTION and m.group(1) in values:
            key = m.group(1)
            found.add(key)
            line = f"{key}{m.group(2)}{int(values[key])}{m.group(4)}{m.group(5)}"
        out.append(line)
    missing = sorted(set(values) - found)
    if header_at is None or missing:
        raise ConfigError(f"{ini}: [{_SECTION}] lacks {', '.join(missing) or 'the section'} "
                          f"(the tuned copy replaces existing keys only)")
    nl = "\r\n" if lines and lines[0].endswith("\r\n") else "\n"
    block = [begin + nl] + [f"; {p}{nl}" for p in provenance] + [end + nl]
    out[header_at:header_at] = block
    (dst / INI_NAME).write_text("".join(out))
    return dst / INI_NAME
