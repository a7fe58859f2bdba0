"""The host's config folder: reading the loop gains and writing a tuned copy.

`write_tuned(src, dst, values, provenance)` copies every file of `src` to `dst` byte for
byte, except that in NavAndControl.ini's [micro_cfg_motion] the values of the keys in
`values` are replaced (the rest of each line, and every other line, unchanged) and a
comment block (one per tuning kind: an older block of the same kind is replaced) states
where the values come from. Values are the raw config units of the spec (the INI holds
raw values, as on the wire).

The values, and the lines the copy rewrites, are navkit-host's answer
(navkit.hostconfig: `navkit-host --print-config`, the one reader of the INI); the copy
edits the text of those lines only.
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


def _ini(folder: Path) -> Path:
    ini = Path(folder) / INI_NAME
    if not ini.is_file():
        raise ConfigError(f"{ini}: no such file (a host config folder holds {INI_NAME})")
    return ini


def _host(folder: Path, build: Path | None = None) -> dict:
    """navkit-host's answer (the host of build folder `build`, default navkit.paths.build_dir())
    for the folder's NavAndControl.ini (navkit.hostconfig: the host is the one reader of the
    INI); ConfigError with its file:line message."""
    from navkit.hostconfig import HostConfigError, effective_config

    try:
        return effective_config(_ini(folder), build=build)
    except HostConfigError as e:
        raise ConfigError(str(e)) from None


def read_values(folder: Path, build: Path | None = None) -> dict:
    """{(section, key): (value, line number)} of the keys written in the folder's
    NavAndControl.ini, their values as navkit-host reads them."""
    from navkit.hostconfig import origin_line

    cfg = _host(folder, build)
    out = {}
    for section, keys in cfg["sections"].items():
        for key, v in keys.items():
            line = origin_line(cfg, section, key)
            if line is not None:
                out[(section, key)] = (v["value"], line)
    return out


def _number(folder: Path, section: str, key: str, build: Path | None) -> float:
    """[section] key as navkit-host reads the folder's INI (the spec default when it is not
    written), as a number."""
    from navkit.hostconfig import value

    cfg = _host(folder, build)
    try:
        return float(value(cfg, section, key))
    except KeyError:
        raise ConfigError(f"{_ini(folder)}: [{section}] {key}: not a key navkit-host knows") from None


def motion_value(folder: Path, key: str, build: Path | None = None) -> float:
    """[micro_cfg_motion] key as a raw number; the spec default when the INI leaves it out."""
    return _number(folder, _SECTION, key, build)


def geometry_value(folder: Path, key: str, build: Path | None = None) -> float:
    """[micro_cfg_geometry] key as a raw number; the spec default when the INI leaves it out."""
    return _number(folder, "micro_cfg_geometry", key, build)


def _marker(kind: str) -> tuple[str, str]:
    return f"; --- navkit tune {kind}: begin", f"; --- navkit tune {kind}: end"


def write_tuned(src: Path, dst: Path, values: dict, kind: str, provenance: list[str],
                build: Path | None = None) -> Path:
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
    from navkit.hostconfig import header_line, origin_line

    cfg = _host(src, build)
    lines = ini.read_text().splitlines(keepends=True)
    begin, end = _marker(kind)
    # the lines to change, where the host found each key and the section's header
    header_at = header_line(cfg, _SECTION)
    at = {k: origin_line(cfg, _SECTION, k) if k in cfg["sections"][_SECTION] else None for k in values}
    missing = sorted(k for k, n in at.items() if n is None)
    if header_at is None or missing:
        raise ConfigError(f"{ini}: [{_SECTION}] lacks {', '.join(missing) or 'the section'} "
                          f"(the tuned copy replaces existing keys only)")
    replace = {}
    for key, n in at.items():
        m = _KEY_RE.match(lines[n - 1])
        if not m:
            raise ConfigError(f"{ini}:{n}: {key}: not a 'key = value' line the tuned copy can rewrite")
        replace[n - 1] = f"{m.group(1)}{m.group(2)}{int(values[key])}{m.group(4)}{m.group(5)}"
    out, skipping = [], False
    for i, line in enumerate(lines):
        if line.startswith(begin):  # the older block of this kind: replaced
            skipping = True
            continue
        if skipping:
            skipping = not line.startswith(end)
            continue
        out.append(replace.get(i, line))
        if i == header_at - 1:
            block_at = len(out)
    nl = "\r\n" if lines and lines[0].endswith("\r\n") else "\n"
    block = [begin + nl] + [f"; {p}{nl}" for p in provenance] + [end + nl]
    out[block_at:block_at] = block
    (dst / INI_NAME).write_text("".join(out))
    return dst / INI_NAME
