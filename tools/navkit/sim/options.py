"""What a co-simulation run is asked to do and where its parts are: SimOptions, the run's
errors, the build's host and FMU files, the host's configuration and frame period (s),
the FMUs' step (STEP_S, s) and the checkout's git revision."""

from __future__ import annotations

import functools
import re
import signal
import subprocess
from dataclasses import dataclass, field
from pathlib import Path

from navkit.sim.mission import Mission

__all__ = ["STEP_S", "STOP_SIGNALS", "SimOptions", "SimError", "SimInterrupted", "stop_signal",
           "one_blas_thread", "build_folder", "host_path", "fmu_paths", "host_config", "frame_period",
           "check_frame", "git_revision", "git_revision_started", "config_folder", "ask_host_config"]

STEP_S = 0.001            # firmware control period: 1 kHz
_PLANT_NAME = "navkit_plant"   # the firmware FMUs: navkit.sim.pil.FIRMWARES


class SimError(RuntimeError):
    """A run that could not be done; the text says why."""


# The signals navkit sim turns into KeyboardInterrupt (navkit.sim.cli, Ctrl-C): held off
# while a frame or a message to the log worker is half done, delivered between them.
STOP_SIGNALS = frozenset({signal.SIGINT, signal.SIGTERM, signal.SIGHUP, signal.SIGQUIT})


def stop_signal(stop: KeyboardInterrupt) -> int:
    """The number of the stop signal `stop` stands for: KeyboardInterrupt(signum) as navkit
    sim's handler raises it, else Ctrl-C's SIGINT."""
    return stop.args[0] if stop.args and isinstance(stop.args[0], int) else int(signal.SIGINT)


class SimInterrupted(Exception):
    """A run stopped by a signal (KeyboardInterrupt: Ctrl-C, or KeyboardInterrupt(signum)
    raised by a handler, as `navkit sim` does for SIGTERM, SIGHUP and SIGQUIT): it was
    stopped cleanly and its outputs closed; `summary` is what summary.json holds (with
    `interrupted`), `signum` the signal."""

    def __init__(self, summary: dict, signum: int):
        super().__init__(f"interrupted by {signal.Signals(signum).name} at t = "
                         f"{summary['interrupted']['at_s']:g} s")
        self.summary, self.signum = summary, signum


@dataclass
class SimOptions:
    """What to run and where. Times in s of simulated time."""

    mission: Mission
    out: Path
    seed: int = 1
    realtime: bool = False
    config_dir: Path | None = None     # default: <repo>/config
    build: Path | None = None          # default: navkit.paths.build_dir()
    plant_fmu: Path | None = None      # default: <build>/fmus/navkit_plant.fmu; see plant.check
    firmware: str = "fmu"              # "fmu" (SIL) or "avr" (PIL: the AVR image in simavr); navkit.sim.pil
    link: str = "serial"               # "serial", or "can": the host on [micro] link = slcan, the
                                       # harness as the USB-CAN adapter (navkit.can_gateway)
    frame_s: float | None = None       # host frame period; default: from the config
    truth_hz: float = 50.0
    plot: bool = True
    timing: bool = False               # measure time per part (benchmark)
    pin_cpu: bool = True               # lockstep: harness and host share one CPU
    host_args: list = field(default_factory=list)
    progress: bool = False             # how far the run is, on stderr (navkit sim: on;
                                       # navkit.sim.progress)
    log_inline: bool = False           # decode and write run.mcap in this process, no log
                                       # worker (a sweep's runs: one CPU each, no children)


def one_blas_thread() -> None:
    """Have numpy (fmpy's) use one BLAS thread when it is imported after this call: a run
    does no linear algebra, and a thread pool would start and spin on the other CPUs at
    numpy's import (beside the log worker), and the log worker, forked after that import,
    would be forked from a threaded process. A value the user set is kept."""
    import os

    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")


def build_folder(opts: SimOptions) -> Path:
    """The build folder of `opts`: opts.build, else navkit.paths.build_dir()."""
    from navkit.paths import build_dir

    return Path(opts.build) if opts.build else build_dir()


def host_path(build: Path) -> Path:
    """The host binary of build folder `build`."""
    return build / "host" / "navkit-host"


def fmu_paths(build: Path, firmware: str = "fmu") -> tuple[Path, Path]:
    """(firmware FMU, plant FMU) of build folder `build`; `firmware` "fmu" (navkit_firmware)
    or "avr" (navkit_firmware_avr, navkit.sim.pil)."""
    from navkit.sim.pil import firmware_fmu

    return firmware_fmu(build, firmware), build / "fmus" / f"{_PLANT_NAME}.fmu"


def config_folder(config_dir: Path | None) -> Path:
    """The host's config folder of a run, absolute (the host runs in the output folder):
    `config_dir`, else the repository's config/."""
    from navkit.paths import repo_root

    return (Path(config_dir) if config_dir else repo_root() / "config").resolve()


def _frame_ms(frame_s: float | None) -> float | None:
    """The frame (ms) a run's host_config asks the host about: `frame_s` (s), else None."""
    return frame_s * 1000 if frame_s else None


def ask_host_config(config_dir: Path, build: Path | None = None, frame_s: float | None = None) -> None:
    """Start the host reading `config_dir` for host_config (same arguments), which takes
    its answer; returns at once (navkit.hostconfig.ask_config: forget_asks ends it if no
    host_config comes)."""
    from navkit.hostconfig import ask_config

    ask_config(config_dir, build=build, frame_ms=_frame_ms(frame_s))


def host_config(config_dir: Path, build: Path | None = None, frame_s: float | None = None) -> dict:
    """The host's effective configuration of `config_dir` (navkit.hostconfig: navkit-host
    reads the INI files, the one reader) and its verdict on the frame: `frame_s` (s, the
    run's --frame-ms; None: the INI's frame_rate_hz) against the micro's watchdog, the
    host's one check of that rule. A config or frame the host refuses is a SimError with
    its message (file:line: key: reason, or --frame-ms: reason)."""
    from navkit.hostconfig import HostConfigError, effective_config

    try:
        return effective_config(config_dir, build=build, frame_ms=_frame_ms(frame_s))
    except HostConfigError as e:
        raise SimError(str(e)) from None


def frame_period(config_dir: Path, build: Path | None = None) -> float:
    """The host frame period (s): 1 / `[executive] frame_rate_hz` as navkit-host reads
    `config_dir` (its default: 10 Hz, the seed's 100 ms frame)."""
    from navkit.hostconfig import value

    return 1.0 / value(host_config(config_dir, build), "executive", "frame_rate_hz")


def check_frame(frame_s: float, source: str) -> int:
    """The FMU steps (of STEP_S) in a host frame of `frame_s` s, which must be a whole
    number of them; else SimError naming `source` (the option or the INI key the period
    came from). The watchdog's demand on the frame is the host's (host_config)."""
    steps = round(frame_s / STEP_S)
    if steps < 1 or abs(steps * STEP_S - frame_s) > 1e-9:
        raise SimError(f"{source}: a frame of {frame_s * 1000:g} ms is not a whole number of the "
                       f"FMUs' {STEP_S * 1000:g} ms steps")
    return steps


_REVISION = re.compile(r"[0-9a-f]{40}")


def git_revision(root: Path | None = None) -> str:
    """The git revision of checkout `root` (default: the repository's): the 40 hex digits
    of HEAD, with "+dirty" appended when `git status --porcelain` lists anything (modified,
    staged or untracked files), or "unknown" when `root` is not a git checkout (or git is
    missing)."""
    return git_revision_started(root)()


def git_revision_started(root: Path | None = None):
    """Start git_revision(root)'s two git commands side by side and return at once a
    function that waits for them and returns git_revision's answer (the same on every
    call; the first call reaps both commands)."""
    from navkit.paths import repo_root

    git = ["git", "-C", str(root or repo_root())]
    procs = []
    try:
        for args in (["rev-parse", "--verify", "HEAD"], ["status", "--porcelain"]):
            procs.append(subprocess.Popen(git + args, stdin=subprocess.DEVNULL,
                                          stdout=subprocess.PIPE, stderr=subprocess.DEVNULL))
    except OSError:
        pass

    @functools.cache
    def result() -> str:
        answer = _git_answer(procs) if len(procs) == 2 else "unknown"
        for p in procs:         # after a timeout or a failed start
            if p.poll() is None:
                p.kill()
            p.wait()
        return answer
    return result


def _git_answer(procs: list) -> str:
    """git_revision's answer from its running (rev-parse, status) commands: HEAD's output
    within 5 s, the status (bytes: file names in any encoding) within 30 s."""
    head, status = procs
    try:
        rev = head.communicate(timeout=5)[0].decode(errors="replace").strip()
        if head.returncode != 0 or not _REVISION.fullmatch(rev):
            return "unknown"
        dirty = status.communicate(timeout=30)[0].strip()
    except subprocess.SubprocessError:
        return "unknown"
    if status.returncode != 0:
        return "unknown"
    return rev + ("+dirty" if dirty else "")
