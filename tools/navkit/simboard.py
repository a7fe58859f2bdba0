"""`navkit simboard`: an Arduino Mega 2560 without the hardware.

    navkit simboard --link PATH [--flash FILE] [--bootloader HEX] [--speed X] [--quiet]

Runs the build's `navkit-simboard` program (firmware/avr/simboard/simboard.c): an
ATmega2560 at 16 MHz in simavr, starting in the real stk500v2 bootloader of the
Arduino Mega 2560, its UART0 on a pseudo-terminal reachable at PATH (a symlink), the
flash kept in FILE (256 KiB raw) across runs. Opening PATH resets the board into its
bootloader, standing in for the DTR line a pty cannot carry (docs/flash.md). Flash it
with `navkit flash --port PATH` or avrdude; Ctrl-C (or SIGTERM) ends it, writing FILE
and removing PATH.

`SimBoard` runs one from Python (tests, `navkit flash --bench`).
"""

from __future__ import annotations

import argparse
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

__all__ = ["add_arguments", "run", "program", "missing_message", "SimBoard", "SimBoardError"]


class SimBoardError(Exception):
    """The simulated board could not start; str() names the cause and the fix."""


def program() -> Path:
    """The simboard program in the build folder (navkit.paths.build_dir())."""
    from navkit.paths import build_dir
    return build_dir() / "firmware" / "avr-simboard" / "navkit-simboard"


def _simavr_installed() -> bool:
    """Whether pkg-config finds libsimavr (what the build needs to make the program)."""
    if shutil.which("pkg-config") is None:
        return False
    return subprocess.run(["pkg-config", "--exists", "simavr"], capture_output=True).returncode == 0


def missing_message(prog: Path) -> str:
    """Why `prog` is absent and the fix: simavr not installed, or not built yet."""
    if not _simavr_installed():
        return (f"{prog} is not built: simavr is missing (pkg-config simavr finds no libsimavr); "
                "run make, whose scripts/setup.sh installs libsimavr-dev, or as root "
                "`apt-get install libsimavr-dev`, then make")
    return f"{prog} is not built: run make"


def _command(link: Path, flash: Path | None, bootloader: Path | None, speed: float | None,
             quiet: bool) -> list[str]:
    prog = program()
    if not prog.exists():
        raise SimBoardError(missing_message(prog))
    cmd = [str(prog), "--link", str(link)]
    if flash is not None:
        cmd += ["--flash", str(flash)]
    if bootloader is not None:
        cmd += ["--bootloader", str(bootloader)]
    if speed is not None:
        cmd += ["--speed", repr(float(speed))]
    if quiet:
        cmd.append("--quiet")
    return cmd


class SimBoard:
    """A running simulated board, as a context manager: the program started with its
    output in `log` (default: beside the link, `<link>.log`); entering waits until the
    link exists (SimBoardError with the program's message if it exits first); leaving
    stops it with SIGINT (flash written, link removed)."""

    def __init__(self, link: Path, flash: Path | None = None, *, speed: float | None = None,
                 bootloader: Path | None = None, log: Path | None = None,
                 start_timeout: float = 10.0):
        self.link = Path(link)
        self.flash = flash
        self.log = Path(log) if log else self.link.with_name(self.link.name + ".log")
        self._cmd = _command(self.link, flash, bootloader, speed, quiet=False)
        self._timeout = start_timeout
        self.proc: subprocess.Popen | None = None

    def __enter__(self) -> "SimBoard":
        self.start()
        return self

    def __exit__(self, *exc) -> None:
        self.stop()

    def start(self) -> None:
        """Start the program and wait for its link."""
        with open(self.log, "wb") as out:
            self.proc = subprocess.Popen(self._cmd, stdout=out, stderr=subprocess.STDOUT)
        t_end = time.monotonic() + self._timeout
        while not self.link.is_symlink():
            if self.proc.poll() is not None:
                raise SimBoardError(self.output().strip() or f"navkit-simboard exited {self.proc.returncode}")
            if time.monotonic() > t_end:
                self.stop()
                raise SimBoardError(f"navkit-simboard made no link at {self.link} in {self._timeout} s")
            time.sleep(0.01)

    def stop(self, timeout: float = 10.0) -> int:
        """SIGINT, then wait; returns the exit status (SIGKILL after `timeout` s)."""
        if self.proc is None:
            return 0
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)
            try:
                self.proc.wait(timeout)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        return self.proc.returncode

    def output(self) -> str:
        """Everything the program printed so far."""
        try:
            return self.log.read_text(errors="replace")
        except OSError:
            return ""


def _speed(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not v >= 0.0:
        raise argparse.ArgumentTypeError(f"must be at least 0, not {text}")
    return v


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--link", required=True, type=Path, metavar="PATH",
                        help="symlink to create to the board's serial port (a pty), e.g. /tmp/mega")
    parser.add_argument("--flash", type=Path, metavar="FILE",
                        help="keep the flash in FILE across runs (256 KiB raw; default: erased each run)")
    parser.add_argument("--bootloader", type=Path, metavar="HEX",
                        help="stk500v2 bootloader HEX (default: arduino-core-avr's "
                             "stk500boot_v2_mega2560.hex)")
    parser.add_argument("--speed", type=_speed, metavar="X",
                        help="simulated seconds per wall second (default 1: real time; 0: as fast as it runs)")
    parser.add_argument("--quiet", action="store_true", help="no progress lines")


def run(args) -> int:
    if args.flash is not None and not args.flash.parent.is_dir():
        print(f"navkit simboard: --flash {args.flash}: folder {args.flash.parent} does not exist",
              file=sys.stderr)
        return 1
    try:
        cmd = _command(args.link, args.flash, args.bootloader, args.speed, args.quiet)
    except SimBoardError as e:
        print(f"navkit simboard: {e}", file=sys.stderr)
        return 1
    sys.stdout.flush()
    os.execv(cmd[0], cmd)  # the program handles SIGINT/SIGTERM itself
    return 1  # not reached
