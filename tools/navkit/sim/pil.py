"""Processor in the loop: which firmware FMU `navkit sim --firmware fmu|avr` runs, the AVR
image's control_rate ceiling, and the profile the AVR firmware FMU measured.

`fmu` is navkit_firmware.fmu (the portable core compiled for this machine: software in the
loop); `avr` is navkit_firmware_avr.fmu (the flashed ATmega2560 image executing in simavr,
coupled at its pins: processor in the loop). Both have the same variables.

The AVR build runs the control tick at most at CONFIG_RATE_MAX (400 Hz; the FMU names it in
its org.navkit.board annotation) and refuses a micro_cfg_geometry asking more, as the real
board would. A PIL run whose host config asks more runs with a copy of the config folder
whose [micro_cfg_geometry] control_rate is the ceiling (the "PIL config", made in the
run's temporary folder; nothing else differs, line numbers included) and says so; the
summary records the rate used and where the config asked for another.
"""

from __future__ import annotations

import re
import shutil
import zipfile
from pathlib import Path
from xml.etree import ElementTree

__all__ = ["FIRMWARES", "firmware_fmu", "board_info", "control_rate", "rate_config", "profile"]

# --firmware choice -> model identifier of the FMU (<build>/fmus/<id>.fmu)
FIRMWARES = {"fmu": "navkit_firmware", "avr": "navkit_firmware_avr"}

_SECTION = "micro_cfg_geometry"
_KEY = "control_rate"
# the key's line as written (case as the host matches it): prefix, value, the rest
_KEY_RE = re.compile(rf"^(\s*{_KEY}\s*=\s*)([^;#\s]*)(.*)$", re.IGNORECASE)


def firmware_fmu(build: Path, firmware: str) -> Path:
    """The FMU file of firmware `firmware` ("fmu" or "avr") in build folder `build`."""
    return Path(build) / "fmus" / f"{FIRMWARES[firmware]}.fmu"


def board_info(fmu: Path) -> dict | None:
    """The org.navkit.board annotation of FMU file `fmu` as a dict of strings (mcu,
    f_cpu_hz, control_rate_max, image), or None when the FMU has none (the SIL firmware)."""
    with zipfile.ZipFile(fmu) as z:
        root = ElementTree.fromstring(z.read("modelDescription.xml"))
    board = root.find("./Annotations/Annotation[@type='org.navkit.board']/Board")
    return dict(board.attrib) if board is not None else None


def _config(config: Path | dict, build: Path | None) -> dict:
    """`config` when it is already the host's answer (navkit.hostconfig), else the host's
    answer for config folder `config`."""
    from navkit.hostconfig import effective_config

    return config if isinstance(config, dict) else effective_config(config, build=build)


def control_rate(config: Path | dict, build: Path | None = None) -> tuple[int, int | None]:
    """([micro_cfg_geometry] control_rate as the host sends it, its line number in
    NavAndControl.ini or None when the file leaves it out: the spec's default) of config
    folder `config` as navkit-host reads it (or of its answer, navkit.hostconfig);
    HostConfigError when the host refuses the config."""
    from navkit.hostconfig import origin_line, value

    cfg = _config(config, build)
    return value(cfg, _SECTION, _KEY), origin_line(cfg, _SECTION, _KEY)


def rate_config(config_dir: Path, ceiling: int, tmp: Path, config: dict | None = None,
                build: Path | None = None) -> tuple[Path, int, str | None]:
    """The config folder a run on a micro whose control_rate ceiling is `ceiling` (Hz) uses:
    (folder, control_rate the micro gets, why it differs from the config or None).
    `config`: the host's answer for `config_dir` when the caller has it (else asked).

    `config_dir` itself when its control_rate (or the spec default, without the key) is at
    most the ceiling; else a copy in `tmp`/config-pil with the key set to the ceiling on
    the same line (appended to the section, or the section to the file, when missing):
    the lines are the host's (file:line of the key, of the section's header)."""
    from navkit.hostconfig import header_line

    cfg = _config(config if config is not None else config_dir, build)
    ini = Path(config_dir) / "NavAndControl.ini"
    asked, line = control_rate(cfg)
    if asked <= ceiling:
        return Path(config_dir), asked, None
    copy = Path(tmp) / "config-pil"
    shutil.copytree(config_dir, copy)
    lines = ini.read_text().splitlines(keepends=True)
    if line is not None:
        m = _KEY_RE.match(lines[line - 1].rstrip("\n"))
        lines[line - 1] = f"{m.group(1)}{ceiling}{m.group(3)}\n"
        where = f"{ini}:{line}: [{_SECTION}] {_KEY} = {asked}"
    else:
        at = header_line(cfg, _SECTION)
        if at is None:
            lines.append(f"\n[{_SECTION}]\n")
            at = len(lines)
        lines.insert(at, f"{_KEY} = {ceiling}\n")
        where = f"{ini}: [{_SECTION}] has no {_KEY}: the spec default {asked}"
    (copy / "NavAndControl.ini").write_text("".join(lines))
    return copy, ceiling, f"{where} Hz is above the AVR image's ceiling of {ceiling} Hz"


def profile(slave, md) -> dict:
    """{name: value} of every UInt32 / UInt64 output of the firmware FMU `slave` (model
    description `md`): the AVR firmware FMU's cycle counts (prof_*, avr_cycles; none for
    the SIL firmware), plus the CPU shares of fw_tick and fw_link_poll (%, of all cycles)."""
    out = {}
    for v in md.modelVariables:
        if v.causality == "output" and v.type in ("UInt32", "UInt64"):
            out[v.name] = getattr(slave, f"get{v.type}")([v.valueReference])[0]
    cycles = out.get("avr_cycles")
    if cycles:
        for part in ("tick", "poll"):
            total = out.get(f"prof_{part}_total_cycles")
            if total is not None:
                out[f"{part}_cpu_share_pct"] = round(100.0 * total / cycles, 2)
    return out
