"""One co-simulation run: the firmware FMU and the plant FMU stepped together by the native
coupler, the real `navkit-host` on a pseudo-terminal, the mission's planner on rcomm.

Lockstep (the default) per host frame k at simulated time t = k * frame_s:

1. mission events due at t: planner commands (rcomm), console keys (host stdin), faults;
2. planner heartbeat; tick k to the host carrying the micro's bytes written since the last
   tick; wait for done; read exactly its tx_bytes from the pty;
3. the FMUs advance one frame (frame_s / 1 ms steps) in native code with the host's bytes
   arriving at the firmware with the first step; the firmware's bytes go to the pty;
4. everything decoded goes to run.mcap with log time = simulated time.

A run is a pure function of (mission, config, seed). Real-time mode (`realtime=True`)
runs the host on its own clock and paces the FMUs to the wall clock instead.
"""

from __future__ import annotations

import gc
import json
import math
import os
import random
import re
import resource
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

from navkit.sim.mission import COMMAND_FIELDS, Mission, MissionError

__all__ = ["SimOptions", "SimError", "SimInterrupted", "run", "host_path", "fmu_paths", "host_config",
           "frame_period", "check_frame", "git_revision"]

STEP_S = 0.001            # firmware control period: 1 kHz
_PLANT_NAME = "navkit_plant"   # the firmware FMUs: navkit.sim.pil.FIRMWARES


class SimError(RuntimeError):
    """A run that could not be done; the text says why."""


class SimInterrupted(Exception):
    """A run stopped by a signal (KeyboardInterrupt: Ctrl-C, or KeyboardInterrupt(signum)
    raised by a handler, as `navkit sim` does for SIGTERM, SIGHUP and SIGQUIT): it was
    stopped cleanly and its outputs closed; `summary` is what summary.json holds (with
    `interrupted`), `signum` the signal."""

    def __init__(self, summary: dict, signum: int):
        super().__init__(f"interrupted by {signal.Signals(signum).name} at t = "
                         f"{summary['interrupted']['at_s']:g} s")
        self.summary, self.signum = summary, signum


class _Progress:
    """How far a run is, on `stream` (stderr): on a terminal one line redrawn in place
    (after the first second of wall time, at most 4 times a second); otherwise a line
    every `every_s` s of wall time. Says simulated s done of the duration, the real-time
    factor so far and the wall time left at that pace."""

    def __init__(self, duration_s: float, stream=None, every_s: float = 10.0):
        self.stream = stream or sys.stderr
        self.tty = hasattr(self.stream, "isatty") and self.stream.isatty()
        self.duration_s, self.every_s = duration_s, every_s
        self.t0 = self.last = time.monotonic()
        self.shown = False

    def at(self, t_s: float) -> None:
        """The run has reached simulated time `t_s` (s)."""
        now = time.monotonic()
        wall = now - self.t0
        if (now - self.last < self.every_s) if not self.tty else (wall < 1.0 or now - self.last < 0.25):
            return
        self.last = now
        pace = t_s / wall if wall > 0 else 0.0
        left = f"~{(self.duration_s - t_s) / pace:.0f} s left" if pace > 0 else "starting"
        text = (f"{t_s:.0f} of {self.duration_s:g} s simulated ({100 * t_s / self.duration_s:.0f} %), "
                f"{pace:.0f}x real time, {left}; Ctrl-C stops it cleanly")
        if self.tty:
            self.stream.write(f"\r{text}\033[K")
            self.shown = True
        else:
            self.stream.write(f"navkit sim: {text}\n")
        self.stream.flush()

    def close(self) -> None:
        """Remove the terminal's progress line."""
        if self.shown:
            self.stream.write("\r\033[K")
            self.stream.flush()
            self.shown = False


def _end_with_parent():
    """A preexec_fn for a child: SIGTERM when the harness ends, however it ends (the host
    then shuts down as on SIGTERM: stop sent, region removed). libc's prctl is looked up
    here, in the harness, so the child between fork and exec only calls it (no dlopen)."""
    import ctypes

    prctl = ctypes.CDLL(None, use_errno=True).prctl
    return lambda: prctl(1, int(signal.SIGTERM))   # PR_SET_PDEATHSIG


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
    progress: bool = False             # how far the run is, on stderr (navkit sim: on; _Progress)
    log_inline: bool = False           # decode and write run.mcap in this process, no log
                                       # worker (a sweep's runs: one CPU each, no children)


def _build(opts: SimOptions) -> Path:
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


def host_config(config_dir: Path, build: Path | None = None, frame_s: float | None = None) -> dict:
    """The host's effective configuration of `config_dir` (navkit.hostconfig: navkit-host
    reads the INI files, the one reader) and its verdict on the frame: `frame_s` (s, the
    run's --frame-ms; None: the INI's frame_rate_hz) against the micro's watchdog, the
    host's one check of that rule. A config or frame the host refuses is a SimError with
    its message (file:line: key: reason, or --frame-ms: reason)."""
    from navkit.hostconfig import HostConfigError, effective_config

    try:
        return effective_config(config_dir, build=build, frame_ms=frame_s * 1000 if frame_s else None)
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
    from navkit.paths import repo_root

    git = ["git", "-C", str(root or repo_root())]
    try:
        head = subprocess.run(git + ["rev-parse", "--verify", "HEAD"], capture_output=True,
                              text=True, timeout=5)
        rev = head.stdout.strip()
        if head.returncode != 0 or not _REVISION.fullmatch(rev):
            return "unknown"
        status = subprocess.run(git + ["status", "--porcelain"], capture_output=True,
                                timeout=30)     # bytes: file names in any encoding
        if status.returncode != 0:
            return "unknown"
    except (OSError, subprocess.SubprocessError):
        return "unknown"
    return rev + ("+dirty" if status.stdout.strip() else "")


# ------------------------------------------------------------------ FMUs

def _set_start(slave, md, name: str, value, where: str, fmu: Path) -> None:
    """Set variable `name` of FMU file `fmu` (model description `md`) before initialisation,
    converting `value` to its type."""
    var = {v.name: v for v in md.modelVariables}.get(name)
    if var is None:
        raise MissionError(f"{where}: key {name!r}: the plant FMU ({fmu}) has no such variable")
    if var.causality not in ("parameter", "structuralParameter"):
        raise MissionError(f"{where}: key {name!r}: not a parameter of the plant FMU ({fmu}) "
                           f"(causality {var.causality})")
    vr = [var.valueReference]
    t = var.type
    try:
        if t in ("Float64", "Float32"):
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise TypeError
            getattr(slave, f"set{t}")(vr, [float(value)])
        elif t.startswith(("Int", "UInt")):
            if isinstance(value, bool) or not isinstance(value, int):
                raise TypeError
            getattr(slave, f"set{t}")(vr, [value])
        elif t == "Boolean":
            if not isinstance(value, bool):
                raise TypeError
            slave.setBoolean(vr, [value])
        elif t == "String":
            if not isinstance(value, str):
                raise TypeError
            slave.setString(vr, [value])
        else:
            raise MissionError(f"{where}: key {name!r}: cannot set a {t} variable")
    except TypeError:
        raise MissionError(f"{where}: key {name!r}: {value!r} does not fit its type {t}") from None


_PARAM_MSG = re.compile(r"\bparameter (\w+)\b")

# FMI integer types -> (least, greatest) value
_INT_RANGES = {f"{u}Int{n}": (0, (1 << n) - 1) if u else (-(1 << n - 1), (1 << n - 1) - 1)
               for u in ("", "U") for n in (8, 16, 32, 64)}


def _check_seed(seed: int, plant_md, plant_fmu: Path) -> None:
    """SimError unless `seed` fits the plant FMU's `seed` parameter (model description
    `plant_md`): its integer type's range (Int32 for the built plant), narrowed by its
    min / max when the FMU declares them. fmpy would wrap a seed outside it silently, so
    two seeds would give the same run while the outputs record different ones. A plant
    without a seed takes any (the line noise's generator is seeded with it as well)."""
    var = next((v for v in plant_md.modelVariables if v.name == "seed"), None)
    if var is None:
        return
    lo, hi = _INT_RANGES[var.type]
    lo = max(lo, int(var.min)) if var.min is not None else lo
    hi = min(hi, int(var.max)) if var.max is not None else hi
    if isinstance(seed, bool) or not isinstance(seed, int):
        raise SimError(f"--seed {seed!r}: not an integer")
    if not lo <= seed <= hi:
        raise SimError(f"--seed {seed!r}: outside {lo}..{hi}, the values of the plant FMU's "
                       f"seed parameter ({var.type}, {plant_fmu})")


class _Fmus:
    """Both FMUs (files checked to exist by the caller) extracted, instantiated and
    initialised. Their log messages are kept (`log`, newest last, at most 50) and name the
    cause when a call fails."""

    def __init__(self, fw_path: Path, plant_path: Path, tmp: Path, plant_params: dict,
                 mission: Mission):
        from fmpy import extract, read_model_description
        from fmpy.fmi3 import FMU3Slave

        self.slaves = []
        self.log = []
        self.fw_md = read_model_description(str(fw_path))
        self.plant_md = read_model_description(str(plant_path))
        fw_dir = extract(str(fw_path), unzipdir=str(tmp / "fw"))
        plant_dir = extract(str(plant_path), unzipdir=str(tmp / "plant"))
        self.fw = FMU3Slave(guid=self.fw_md.guid, unzipDirectory=fw_dir,
                            modelIdentifier=self.fw_md.coSimulation.modelIdentifier,
                            instanceName="firmware")
        self.plant = FMU3Slave(guid=self.plant_md.guid, unzipDirectory=plant_dir,
                               modelIdentifier=self.plant_md.coSimulation.modelIdentifier,
                               instanceName="plant")
        try:
            self.fw.instantiate(logMessage=self._logger("firmware"))
            self.slaves.append(self.fw)
            self.plant.instantiate(logMessage=self._logger("plant"))
            self.slaves.append(self.plant)
            for name, value in plant_params.items():
                _set_start(self.plant, self.plant_md, name, value, f"{mission.path}: [plant]",
                           plant_path)
            self._init(self.fw, "firmware", fw_path, 0.0)
            self._init_plant(plant_path, mission, plant_params)
        except BaseException:
            self.close()
            raise

    def _logger(self, who: str):
        """An fmi3LogMessageCallback that keeps the FMU `who`'s messages."""
        def log(_env, _status, _category, message) -> None:
            self.log.append((who, message.decode(errors="replace") if message else ""))
            del self.log[:-50]
        return log

    def _messages(self, who: str) -> str:
        return "; ".join(m for w, m in self.log if w == who) or "(the FMU logged nothing)"

    def _init(self, slave, who: str, path: Path, t: float) -> None:
        """Enter and exit initialisation mode at `t` (s); SimError with the FMU's log."""
        from fmpy.fmi1 import FMICallException

        try:
            slave.enterInitializationMode(startTime=t)
            slave.exitInitializationMode()
        except FMICallException as e:
            raise SimError(f"the {who} FMU ({path}) failed to initialise: {e} "
                           f"{self._messages(who)}") from None

    def _init_plant(self, path: Path, mission, params: dict) -> None:
        """Initialise the plant; a refusal is the mission's: MissionError naming the mission
        file and the [plant] key (from the FMU's message) or the world file and line."""
        from fmpy.fmi1 import FMICallException

        try:
            self.plant.enterInitializationMode(startTime=0.0)
            self.plant.exitInitializationMode()
        except FMICallException as e:
            text = self._messages("plant")
            keys = [k for k in _PARAM_MSG.findall(text) if k in mission.plant]
            world = params.get("world_file")
            if keys:
                where = f"{mission.path}: [plant]: key {keys[0]!r}"
            elif world and world in text:
                where = f"{mission.path}: key 'world'"
            elif mission.plant:
                where = f"{mission.path}: [plant] ({', '.join(mission.plant)})"
            else:
                where = f"{mission.path}"
            raise MissionError(f"{where}: the plant FMU ({path}) refused it: {text} "
                               f"({e.function} failed)") from None

    def reset_firmware(self, t: float) -> None:
        """fmi3Reset of the firmware, then initialise it again starting at `t` (s)."""
        self.fw.reset()
        self._init(self.fw, "firmware", Path(self.fw_md.modelName), t)

    def close(self) -> None:
        for s in self.slaves:
            try:
                s.terminate()
            except Exception:  # noqa: BLE001 - best effort at shutdown
                pass
            try:
                s.freeInstance()
            except Exception:  # noqa: BLE001
                pass
        self.slaves = []


# ------------------------------------------------------------------ planner

class _Planner:
    """The mission's planner on rcomm through the planner client navkit.rcomm: writes
    whole lisp_cmds, bumps the heartbeat, reads lisp_data."""

    def __init__(self, shm_name: str):
        self.shm_name = shm_name
        self.client = None
        self.time_tag = 0

    def _open(self):
        from navkit import rcomm

        return rcomm.Client(self.shm_name)

    def attach(self, timeout_s: float, alive=lambda: True) -> bool:
        """Open the host's region, waiting up to `timeout_s` (s) for it to appear while
        `alive()` says the host still runs."""
        deadline = time.monotonic() + timeout_s
        while True:
            try:
                self.client = self._open()
                return True
            except ConnectionError:          # navkit.rcomm.RcommError: not there (yet)
                if time.monotonic() >= deadline or not alive():
                    return False
                time.sleep(0.005)

    def command(self, fields: dict, t_ms: int) -> dict:
        """Write a whole lisp_cmd (unset fields 0) with a new time tag; returns it."""
        self.time_tag = max(self.time_tag + 1, t_ms)
        msg = dict.fromkeys(COMMAND_FIELDS, 0)
        msg.update(fields, time_tag=self.time_tag, msg_type=0)
        if self.client is not None:
            self.client.write_cmd(msg)
        return msg

    def beat(self) -> None:
        if self.client is not None:
            self.client.heartbeat()

    def read(self) -> dict | None:
        return self.client.read_data() if self.client is not None else None

    def close(self) -> None:
        if self.client is not None:
            self.client.close()
            self.client = None


# ------------------------------------------------------------------ run

def _datalogs(folder: Path) -> dict:
    """The host's datalog files in `folder` (seed names, "Data MM-DD-YY HH;MM;SS.txt"):
    name -> modification time (ns)."""
    return {p.name: p.stat().st_mtime_ns for p in folder.glob("Data *.txt")}


def _vm_hwm_kib(pid: int) -> int | None:
    """Peak resident memory (KiB) of a live process, from /proc; None if unknown."""
    try:
        with open(f"/proc/{pid}/status") as f:
            for line in f:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1])
    except (OSError, ValueError):
        pass
    return None


class _Run:
    def __init__(self, opts: SimOptions):
        from navkit import protocol
        from navkit.paths import repo_root

        self.opts = opts
        self.m = opts.mission
        self.command_index = {id(c): i + 1 for i, c in enumerate(self.m.commands)}  # [[command]] #
        self.git_revision = git_revision()      # before the run's wall clock starts
        self.build = _build(opts)
        # absolute: the host runs in the output folder
        self.config_dir = (Path(opts.config_dir) if opts.config_dir else repo_root() / "config").resolve()
        self.out = Path(opts.out)
        self.plant_fmu = Path(opts.plant_fmu) if opts.plant_fmu else fmu_paths(self.build)[1]
        self._check_built()
        self.host_config = host_config(self.config_dir, self.build, opts.frame_s)
        rate = self.host_config["sections"]["executive"]["frame_rate_hz"]
        self.frame_s = opts.frame_s or 1.0 / rate["value"]
        self.steps_per_frame = check_frame(self.frame_s, "--frame-ms" if opts.frame_s else f"{rate['from']}: frame_rate_hz")
        self.frame_s = self.steps_per_frame * STEP_S
        self.protocol = protocol
        self.noise_rng = random.Random(f"navkit-noise-{opts.seed}")
        self.tmp = Path(tempfile.mkdtemp(prefix="navkit-sim-"))
        self.shm = f"/navkit-sim-{os.getpid()}-{time.monotonic_ns() % 1_000_000_000}"
        self.proc = self.lock = self.port = self.fmus = self.coupler = None
        self.log = self.planner = self.host_log = None
        self.host_state = "running"
        self.silent_until = None
        self.noise = None
        self.noise_until = None
        self.noise_stats = {"flips": 0, "drops": 0, "inserts": 0}
        self.unplug_until = None
        self.gateway = self.can_log = None   # --link can: navkit.can_gateway, can.log's writer
        self.rx_count = 0
        self.frames = 0
        self.host_exit = None
        self.results = {}
        self.fmu_split = None
        self.fw_profile = {}
        self.control_rate = self.rate_note = None
        self.sim_time_s = 0.0
        self.times = {"fmus": 0.0, "pty": 0.0, "host": 0.0, "harness": 0.0}

    # -------------------------------------------------------------- set-up / tear-down
    def start(self) -> None:
        from navkit.sim.coupler import Coupler
        from navkit.sim.links import Lockstep, Port
        from navkit.sim.record import RunLog

        from navkit.sim.plant import PlantFmuError, check

        self._check_timeline()
        fw_fmu, plant_fmu = fmu_paths(self.build, self.opts.firmware)[0], self.plant_fmu
        if self.opts.link == "can" and self.opts.firmware == "fmu":   # its CAN build
            fw_fmu = fw_fmu.with_name("navkit_firmware_can.fmu")
        self.fw_fmu = fw_fmu
        self._firmware_rate(fw_fmu)
        try:
            plant_md = check(plant_fmu, fw_fmu)     # FMI 3.0 co-simulation, the contract
        except PlantFmuError as e:
            raise SimError(str(e)) from None
        _check_seed(self.opts.seed, plant_md, plant_fmu)
        plant_params = {"seed": self.opts.seed}
        if self.m.world is not None:
            plant_params["world_file"] = str(self.m.world)
        plant_params.update(self.m.plant)
        self.fmus = _Fmus(fw_fmu, plant_fmu, self.tmp, self._known_plant(plant_md, plant_params),
                          self.m)
        every = max(1, round(1.0 / (self.opts.truth_hz * STEP_S)))
        self.coupler = Coupler(self.fmus.fw, self.fmus.fw_md, self.fmus.plant,
                               self.fmus.plant_md, step_s=STEP_S, record_every=every,
                               build=self.build)
        if self.opts.timing:
            self.coupler.timing(True)
        host = host_path(self.build)
        self.out.mkdir(parents=True, exist_ok=True)
        self.old_datalogs = _datalogs(self.out)   # an earlier run's, kept but not this run's
        meta = {"mission": self.m.text, "mission_file": self.m.path.name,
                "seed": self.opts.seed, "spec_hash": f"0x{self.protocol.SPEC_HASH:08X}",
                "git_revision": self.git_revision, "frame_s": self.frame_s,
                "realtime": self.opts.realtime, "step_s": STEP_S,
                "plant_fmu": self.fmus.plant_md.modelName,
                "firmware_fmu": self.fmus.fw_md.modelName,
                "firmware": self.opts.firmware, "control_rate_hz": self.control_rate}
        # fork the log worker before any pty, socket or child process exists
        self.log = RunLog(self.out / "run.mcap", meta, self.coupler.columns, self.coupler.width,
                          inline=self.opts.log_inline, can=self.opts.link == "can")
        self.port = Port(self.tmp / "ttyNAVKIT")
        cmd = [str(host), "--port", str(self.port.link), "--shm", self.shm,
               "--config", str(self.config_dir), "--log-dir", str(self.out.resolve())]
        pass_fds = ()
        if self.opts.realtime:
            cmd[1:1] = ["--clock", "real"]
        else:
            self.lock = Lockstep()
            cmd[1:1] = ["--clock", "lockstep", "--lockstep-fd", str(self.lock.host_fd())]
            pass_fds = (self.lock.host_fd(),)
        if self.opts.frame_s and self.opts.realtime:
            cmd += ["--rate", f"{1.0 / self.frame_s:g}"]  # lockstep: the driver sets the time
        if self.opts.link == "can":
            import can

            from navkit.can_gateway import BusTap, CanGateway

            cmd += ["--link", "slcan"]
            # every bus frame to can.log (candump -L format) and run.mcap's /can
            self.can_log = BusTap(can.Logger(str(self.out / "can.log")), self.log.can_frame)
            self.gateway = CanGateway(listener=self.can_log,
                                      firmware_can=self.fmus.fw_md.coSimulation.modelIdentifier
                                      == "navkit_firmware_can")
        cmd += list(self.opts.host_args)
        self.host_log = open(self.out / "host.log", "wb")
        if not self.opts.realtime and self.opts.pin_cpu:
            self._pin()
        # its own process group: a terminal's Ctrl-C reaches the harness, which ends the
        # host in order (lockstep EOF, or SIGINT in real time). A harness that dies without
        # doing so ends it too: in lockstep the host sees the socket's EOF; in real time it
        # runs on its own clock, so it gets SIGTERM then (_end_with_parent; only there, as
        # code between fork and exec is best avoided in a threaded sweep worker)
        self.proc = subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=self.host_log,
                                     stderr=subprocess.STDOUT, pass_fds=pass_fds,
                                     cwd=str(self.out), process_group=0,
                                     preexec_fn=_end_with_parent() if self.opts.realtime else None)
        if self.lock:
            self.lock.started()
        self.planner = _Planner(self.shm)
        if not self.planner.attach(10.0, lambda: self.proc.poll() is None):
            self._host_died_check()
            raise SimError(f"the host did not create rcomm region {self.shm} within 10 s "
                           f"(see {self.out / 'host.log'})")

    def _pin(self) -> None:
        """Lockstep: the harness and the host never run at the same time, so put both on
        one CPU (the host inherits the mask), where a tick or a done wakes the other side
        without a cross-CPU wake-up; the log worker gets the other CPUs. On an otherwise
        idle machine the worker runs at idle priority and polls; when other processes
        already keep the CPUs busy (1-minute load average >= CPU count) it keeps normal
        priority and sleeps, since an idle-priority worker would starve and the harness
        would wait on it (measured under a load of ~4 on 2 CPUs: 87x real time with
        idle priority and polling, 240x without)."""
        try:
            cpus = sorted(os.sched_getaffinity(0))
        except (AttributeError, OSError):
            return
        if len(cpus) < 2:
            return
        self._saved_affinity = set(cpus)
        try:
            os.sched_setaffinity(0, {cpus[-1]})
            if self.log.pid:
                os.sched_setaffinity(self.log.pid, set(cpus[:-1]))
                if os.getloadavg()[0] >= len(cpus):
                    return
                # the worker yields at once to anything else (the kernel's pty work), and
                # polls rather than sleeps so its CPU never idles (wake-ups are slow on VMs)
                os.sched_setscheduler(self.log.pid, os.SCHED_IDLE, os.sched_param(0))
                self.log.spin(True)
        except (OSError, AttributeError):
            pass

    def _check_built(self) -> None:
        """The build's parts the run needs, before anything asks them (the host reads the
        config): SimError naming the first one missing (firmware FMU, plant FMU, host)."""
        fw_fmu = fmu_paths(self.build, self.opts.firmware)[0]
        built = [(fw_fmu, "firmware" if self.opts.firmware == "fmu" else "AVR firmware (needs avr-gcc and libsimavr: "
                  "scripts/setup.sh) FMU")]
        if self.opts.plant_fmu is None:         # a user's plant: check() names a missing file
            built.append((self.plant_fmu, "plant"))
        for path, name in built:
            if not path.exists():
                raise SimError(f"{path} not found: build the {name} FMU first "
                               f"(cmake --build <build>)")
        host = host_path(self.build)
        if not host.exists():
            raise SimError(f"{host} not found: build the host first")

    def _firmware_rate(self, fw_fmu: Path) -> None:
        """The control_rate the micro gets: the config's, or for a firmware with a lower
        ceiling (the AVR image) the ceiling, with a copy of the config folder saying so
        (navkit.sim.pil.rate_config; self.config_dir becomes the copy)."""
        from navkit.sim.pil import board_info, control_rate, rate_config

        board = board_info(fw_fmu)
        if board is None:
            self.control_rate = control_rate(self.host_config)[0]
            return
        self.config_dir, self.control_rate, self.rate_note = rate_config(
            self.config_dir, int(board["control_rate_max"]), self.tmp, self.host_config)

    def _known_plant(self, plant_md, params: dict) -> dict:
        """Drop harness defaults (seed, world_file) the plant FMU (model description
        `plant_md`) does not have; mission [plant] keys stay and are checked when set."""
        names = {v.name for v in plant_md.modelVariables}
        return {k: v for k, v in params.items() if k in names or k in self.m.plant}

    def _host_died_check(self) -> None:
        if self.proc is not None and self.proc.poll() is not None:
            if self.host_log:
                self.host_log.flush()
            tail = (self.out / "host.log").read_bytes()[-2000:].decode(errors="replace")
            raise SimError(f"navkit-host exited with status {self.proc.returncode}:\n{tail}")

    def stop(self) -> None:
        if getattr(self, "progress", None) is not None:
            self.progress.close()
        gc.unfreeze()             # lockstep() froze the objects of the set-up
        if getattr(self, "_saved_affinity", None):
            try:
                os.sched_setaffinity(0, self._saved_affinity)
            except OSError:
                pass
        self.host_peak_kib = _vm_hwm_kib(self.proc.pid) if self.proc is not None else None
        if self.lock is not None:
            self.lock.close()
        if self.proc is not None:
            try:
                if self.proc.stdin:
                    self.proc.stdin.close()
            except OSError:
                pass
            if self.opts.realtime and self.proc.poll() is None:
                self.proc.send_signal(signal.SIGINT)
            try:
                self.host_exit = self.proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.host_exit = self.proc.wait()
        if self.planner is not None:
            self.planner.close()
        try:
            os.unlink("/dev/shm" + self.shm)   # left behind if the host was killed
        except OSError:
            pass
        if self.port is not None:
            self.port.close()
        if self.can_log is not None:
            self.can_log.stop()
            self.can_log = None
        if self.log is not None:
            self.results = self.log.close()
            self.log = None
        if self.coupler is not None:
            if self.opts.timing:
                self.fmu_split = self.coupler.fmu_seconds()
            self.coupler.close()
        if self.fmus is not None:
            from navkit.sim.pil import profile

            try:
                self.fw_profile = profile(self.fmus.fw, self.fmus.fw_md)
            except Exception:  # noqa: BLE001 - a failed firmware has no profile to give
                self.fw_profile = {}
            self.fmus.close()
        if self.host_log:
            self.host_log.close()
        shutil.rmtree(self.tmp, ignore_errors=True)

    # -------------------------------------------------------------- events
    def n_frames(self) -> int:
        """Host frames in the run: round(duration_s / frame); frame k starts at k * frame."""
        return int(round(self.m.duration_s / self.frame_s))

    def _check_timeline(self) -> None:
        """Every event takes effect at the first host frame that starts at or after its t
        (lockstep; in real time at the first 5 ms chunk, which is never later): MissionError
        naming the entry if that frame is not in the run."""
        n, frame = self.n_frames(), self.frame_s
        last = (n - 1) * frame
        if n < 1:
            raise MissionError(f"{self.m.path}: key 'duration_s': {self.m.duration_s:g} s is less than "
                               f"half a host frame ({frame * 1000:g} ms): the run would have no frame")
        taken = {}              # host frame -> the [[command]] written in it
        for c in self.m.commands:
            k = math.ceil(c.t / frame - 1e-9)
            if k in taken:      # one lisp_cmd slot: the second would replace the first unread
                raise MissionError(
                    f"{c.where}: key 't': {c.t:g} s takes effect in the same host frame "
                    f"({k * frame:g} s) as {taken[k].where.rsplit(': ', 1)[1]} (t = {taken[k].t:g} s): "
                    f"the planner has one command slot a frame; put them at least one frame "
                    f"({frame * 1000:g} ms) apart")
            taken[k] = c
        for _t, _order, _what, e in self._timeline():
            k = math.ceil(e.t / frame - 1e-9)
            if k >= n:
                raise MissionError(
                    f"{e.where}: key 't': {e.t:g} s would take effect at the first host frame "
                    f"at or after it ({k * frame:g} s), but the last frame of the run starts "
                    f"at {last:g} s (duration_s = {self.m.duration_s:g} s, "
                    f"{frame * 1000:g} ms frames): use t <= {last:g} or a longer duration_s")

    def _timeline(self):
        ev = [(c.t, 0, "command", c) for c in self.m.commands]
        ev += [(k.t, 1, "key", k) for k in self.m.keys]
        ev += [(f.t, 2, "fault", f) for f in self.m.faults]
        ev.sort(key=lambda e: (e[0], e[1]))
        return ev

    def _event(self, t_ns: int, kind: str, detail: dict) -> None:
        self.log.event(t_ns, kind, detail)

    def _apply(self, t_ns: int, what: str, e) -> None:
        if what == "command":
            if self.silent_until is not None:
                return          # a silent planner writes nothing
            msg = self.planner.command(e.fields, t_ns // 1_000_000)
            self.log.command(t_ns, msg, (self.command_index[id(e)], e.t, e.where))
        elif what == "key":
            self._event(t_ns, "key", {"key": e.key})
            if self.proc is not None and self.host_state == "running":
                try:
                    self.proc.stdin.write(e.key.encode())
                    self.proc.stdin.flush()
                except OSError:
                    pass
        else:
            self._fault(t_ns, e)

    def _fault(self, t_ns: int, f) -> None:
        t = t_ns / 1e9
        self._event(t_ns, f.kind, dict(f.params))
        if f.kind == "kill_host":
            if self.proc is not None and self.proc.poll() is None:
                self.proc.send_signal(signal.SIGKILL)
                self.proc.wait()
            self.host_state = "killed"
            if self.lock is not None:
                self.lock.close()
        elif f.kind == "micro_reset":
            self.fmus.reset_firmware(t)
            self.coupler.firmware_restart(t)
            self.coupler.exchange()
            self.log.receiver_restart("h2m")     # the micro's frame parser starts afresh
        elif f.kind == "unplug":
            self.port.unplug()
            self.rx_count = 0       # bytes still in the pty are gone with it
            self.unplug_until = t + f.duration_s
        elif f.kind == "line_noise":
            from navkit.sim.links import LineNoise

            self._end_noise()
            self.noise = LineNoise(f.params["ber"], self.noise_rng)
            self.noise_until = t + f.duration_s
            if self.gateway is not None:
                self.gateway.noise(f.params["ber"], self.noise_rng)
        elif f.kind == "planner_silent":
            self.silent_until = t + f.duration_s if f.duration_s else float("inf")

    def _end_noise(self) -> None:
        if self.gateway is not None:
            self.gateway.noise(0.0)
        if self.noise is not None:
            for k in self.noise_stats:
                self.noise_stats[k] += getattr(self.noise, k)
            self.noise = None

    def _expire(self, t_ns: int) -> None:
        t = t_ns / 1e9
        if self.unplug_until is not None and t >= self.unplug_until - 1e-9:
            self.port.plug()
            self.log.receiver_restart("m2h")     # the host opens a new port
            self._event(t_ns, "plug", {})
            self.unplug_until = None
        if self.noise is not None and t >= self.noise_until - 1e-9:
            self._end_noise()
            self._event(t_ns, "line_noise_end", {})
        if self.silent_until is not None and t >= self.silent_until - 1e-9:
            self.silent_until = None
            self._event(t_ns, "planner_resumes", {})

    def _to_host(self, tx: bytes, micro: bytes | None = None) -> int:
        """The micro's bytes (after line noise) to the host's port; returns how many went.
        What the host receives goes to the log's receiver count ("m2h"). Over CAN `tx` is
        SLCAN lines and `micro` the chunk's serial bytes they carry (the log's count: the
        host gets those frames, or none of a chunk that had none)."""
        sent = tx
        if self.noise is not None and self.gateway is None:  # over CAN: the gateway's error frames
            tx = self.noise.apply(tx)
        if micro and self.host_state == "running" and self.port.plugged:
            # over CAN the chunk's bytes reach the host whole, as ISO-TP lets them go (its
            # frame may still be on the way when the chunk's lines are written)
            self.log.received("m2h", None)
        if not tx or self.host_state != "running" or not self.port.plugged:
            return 0
        t1 = time.perf_counter()
        n = self.port.write(tx)
        self.times["pty"] += time.perf_counter() - t1
        if micro is None:
            self.log.received("m2h", None if tx is sent and n == len(tx) else tx[:n])
        return n

    def _to_micro(self, host_bytes: bytes) -> bytes:
        """The host's bytes after line noise, as the micro receives them ("h2m")."""
        if not host_bytes:
            return host_bytes
        if self.noise is None or self.gateway is not None:
            self.log.received("h2m", None)
            return host_bytes
        rx = self.noise.apply(host_bytes)
        self.log.received("h2m", rx)
        return rx

    def _can_out(self, back: bytes, tx: bytes, t_ns: int) -> tuple:
        """_to_host's arguments for the micro's bytes `tx`: (tx,); over CAN (the adapter's
        answers and frames due, `back`, then the micro's frames as ISO-TP SLCAN lines, tx).
        The log keeps the micro's serial frames (log.micro): the host gets those either way."""
        if self.gateway is None:
            return (tx,)
        lines = back + self.gateway.from_micro(tx, t_ns / 1e9)
        # the firmware FMU's CAN build sends frame records: the log keeps what they carry
        return lines, (self.gateway.m2h_serial if self.gateway.firmware_can else tx)

    def _lisp_raw(self):
        c = self.planner.client
        return None if c is None else c.read_data_raw()

    # -------------------------------------------------------------- loops
    def lockstep(self) -> None:
        pc = time.perf_counter
        timeline = self._timeline()
        ei, n_ev = 0, len(timeline)
        n_frames = self.n_frames()
        frame_ns = self.steps_per_frame * 1_000_000
        self.rx_count = 0
        log, coupler, port = self.log, self.coupler, self.port
        spf = self.steps_per_frame
        split = min(spf, max(1, round(0.040 / STEP_S)))
        times = self.times
        row = coupler.sample()
        import array

        log.truth(array.array("d", row).tobytes())
        # between a frame's done and the next tick the host does not run: one copy
        client = self.planner.client
        lisp_raw = (lambda: None) if client is None else client.read_data_raw_still
        # The objects made so far (modules, FMU descriptions) never become garbage: keep
        # the collector from walking them again at every full collection of the loop.
        gc.freeze()
        gone = False            # the /host/frame saying the host is gone is written
        progress = self.progress = _Progress(self.m.duration_s) if self.opts.progress else None
        can_back = b""          # --link can: the adapter's answers and frames due for the host
        loop0 = pc()
        for k in range(n_frames):
            t_ns = k * frame_ns
            self.t_ns = t_ns        # where an interrupted run stopped
            if self.unplug_until is not None or self.noise is not None or \
                    self.silent_until is not None:
                self._expire(t_ns)
            while ei < n_ev and timeline[ei][0] * 1e9 <= t_ns + 1:
                self._apply(t_ns, timeline[ei][2], timeline[ei][3])
                ei += 1
            host_bytes = b""
            if self.host_state == "running":
                if self.silent_until is None:
                    self.planner.beat()
                t1 = pc()
                done = self.lock.frame(k, t_ns // 1000, self.rx_count)
                t2 = pc()
                times["host"] += t2 - t1
                if done is None:
                    self.host_state = "exited"
                    self.proc.wait()
                    self._event(t_ns, "host_exited", {"status": self.proc.returncode})
                    log.frame(k, t_ns, self.rx_count, 0, None, b"", None, "exited")
                    gone = True
                else:
                    tx_bytes, flags = done
                    host_bytes = port.read_exact(tx_bytes)
                    times["pty"] += pc() - t2
                    logged = host_bytes
                    if self.gateway is not None:  # SLCAN lines in; the micro's frames, back
                        back, host_bytes = self.gateway.from_host(host_bytes, t_ns / 1e9)
                        can_back += back
                        logged = self.gateway.h2m_serial if self.gateway.firmware_can else host_bytes
                    log.frame(k, t_ns, self.rx_count, tx_bytes, flags, logged,
                              lisp_raw(), "running" if self.unplug_until is None else "unplugged")
                    if flags & 1:
                        self.host_state = "exited"
                self.frames += 1
            elif not gone:             # the first frame without the host
                log.frame(k, t_ns, self.rx_count, 0, None, b"", None, self.host_state)
                gone = True
            host_bytes = self._to_micro(host_bytes)
            # The frame's FMU chunk runs in two calls: the micro answers within the first
            # tens of ms, so its bytes go to the pty while the rest of the chunk computes
            # and the kernel moves them meanwhile. All are written before the next tick
            # either way, so the split changes nothing the host sees; /micro/data is
            # stamped with the end of the call that completed each frame. Each call's truth
            # rows are logged before its micro bytes (log-time order), so the log can close
            # a chunk between the rows of a frame longer than a chunk's 1 s span.
            t1 = pc()
            tx, rows = coupler.run_raw(split, host_bytes)
            times["fmus"] += pc() - t1
            log.truth(rows)
            out = self._can_out(can_back, tx, t_ns + split * 1_000_000)
            log.micro(t_ns + split * 1_000_000, out[-1])
            self.rx_count = self._to_host(*out)
            can_back = b""
            if split < spf:
                t1 = pc()
                tx2, rows2 = coupler.run_raw(spf - split)
                times["fmus"] += pc() - t1
                log.truth(rows2)
                out = self._can_out(b"", tx2, t_ns + frame_ns)
                log.micro(t_ns + frame_ns, out[-1])
                self.rx_count += self._to_host(*out)
            log.end_frame(t_ns + 2 * frame_ns)      # the next frame ends there
            if progress is not None and k & 63 == 0:
                progress.at(t_ns / 1e9)
        self.sim_time_s = n_frames * self.frame_s
        times["harness"] = pc() - loop0 - times["fmus"] - times["pty"] - times["host"]

    def realtime(self) -> None:
        import array

        timeline = self._timeline()
        ei = 0
        chunk_steps = 5
        chunk_ns = chunk_steps * 1_000_000
        n_chunks = int(round(self.m.duration_s / (chunk_steps * STEP_S)))
        self.log.truth(array.array("d", self.coupler.sample()).tobytes())
        wall0 = time.monotonic()
        next_frame_ns = 0
        rx = tx_host = 0        # bytes to / from the host's port since the last /host/frame
        last_frame, gone = None, False
        progress = self.progress = _Progress(self.m.duration_s) if self.opts.progress else None
        for c in range(n_chunks):
            t_ns = c * chunk_ns
            self.t_ns = t_ns        # where an interrupted run stopped
            self._expire(t_ns)
            while ei < len(timeline) and timeline[ei][0] * 1e9 <= t_ns + 1:
                self._apply(t_ns, timeline[ei][2], timeline[ei][3])
                ei += 1
            if self.host_state == "running" and self.proc.poll() is not None:
                self.host_state = "exited"
            host_bytes = self.port.read_available()
            tx_host += len(host_bytes)
            back = b""
            logged = host_bytes
            if self.gateway is not None:  # SLCAN lines in; the micro's frames, back
                back, host_bytes = self.gateway.from_host(host_bytes, t_ns / 1e9)
                logged = self.gateway.h2m_serial if self.gateway.firmware_can else host_bytes
            self.log.host(t_ns, logged)
            host_bytes = self._to_micro(host_bytes)
            tx, rows = self.coupler.run_raw(chunk_steps, host_bytes)
            self.log.truth(rows)
            out = self._can_out(back, tx, t_ns + chunk_ns)
            self.log.micro(t_ns + chunk_ns, out[-1])
            rx += self._to_host(*out)
            if t_ns >= next_frame_ns:
                if self.host_state == "running":
                    if self.silent_until is None:
                        self.planner.beat()
                    raw = self._lisp_raw()
                    self.log.lisp(t_ns, raw)
                    if raw is not None:      # the host's own frame counter
                        frame = self.protocol.from_bytes("lisp_data", raw)["frame"]
                        self.frames = frame + 1
                        if frame != last_frame:
                            self.log.frame(frame, t_ns, rx, tx_host, None, b"", None,
                                           "running" if self.unplug_until is None
                                           else "unplugged")
                            rx = tx_host = 0
                            last_frame = frame
                elif not gone:           # the first frame without the host
                    self.log.frame(self.frames, t_ns, rx, tx_host, None, b"", None,
                                   self.host_state)
                    gone = True
                next_frame_ns += round(self.frame_s * 1e9)
                # the next frame's chunk ends about then (the log splits finer if need be)
                self.log.end_frame(next_frame_ns + chunk_ns)
            if progress is not None and c & 63 == 0:
                progress.at(t_ns / 1e9)
            sleep = wall0 + (t_ns + chunk_ns) / 1e9 - time.monotonic()
            if sleep > 0:
                time.sleep(sleep)
        self.sim_time_s = n_chunks * chunk_steps * STEP_S

    # -------------------------------------------------------------- summary
    def summary(self, wall_s: float) -> dict:
        res = self.results or {}
        micro = res.get("last_micro") or {}
        lisp = res.get("last_lisp") or {}
        link = res.get("link", {})
        h2m, m2h = link.get("h2m", {}), link.get("m2h", {})
        self._end_noise()
        out = {
            "mission": str(self.m.path),
            "seed": self.opts.seed,
            "plant_fmu": str(self.plant_fmu),
            "firmware": self.opts.firmware,
            "firmware_fmu": str(getattr(self, "fw_fmu", None) or fmu_paths(self.build, self.opts.firmware)[0]),
            "control_rate_hz": self.control_rate,
            "mode": "realtime" if self.opts.realtime else "lockstep",
            "sim_time_s": round(self.sim_time_s, 6),
            "wall_time_s": round(wall_s, 3),
            "realtime_factor": round(self.sim_time_s / wall_s, 1) if wall_s > 0 else None,
            "frames": self.frames,
            "frame_s": self.frame_s,
            "truth": res.get("last_truth"),
            "micro": micro,
            "planner_data": lisp,
            "link": {
                "host_to_micro": dict(h2m, micro_counters={
                    k: micro.get(k) for k in micro if k.startswith("rx_")}),
                "micro_to_host": dict(m2h, host_link_errors=lisp.get("link_errors")),
                "crc_errors": h2m.get("crc_errors", 0) + m2h.get("crc_errors", 0),
                "resyncs": h2m.get("resyncs", 0) + m2h.get("resyncs", 0),
                "line_noise": dict(self.noise_stats),
                "bytes_dropped_at_port": self.port.dropped if self.port else 0,
                "transport": self.opts.link,
            },
            "memory_peak_mib": {
                "harness": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1),
                "log_worker": round(res["peak_rss_kib"] / 1024, 1) if res.get("peak_rss_kib") else None,
                "host": round(self.host_peak_kib / 1024, 1) if getattr(self, "host_peak_kib", None) else None},
            "host": {"state": self.host_state, "exit_status": self.host_exit,
                     "overruns": lisp.get("overruns"),
                     "config_downloads": res.get("config_downloads"),
                     "host_status": lisp.get("host_status")},
            "watchdog_stops": res.get("watchdog_stops"),
            "planner": _planner_summary(res.get("planner")),
            "datalogs": sorted(name for name, mtime in _datalogs(self.out).items()
                               if self.old_datalogs.get(name) != mtime),
            "messages": res.get("counts", {}),
            "time_share_s": {k: round(v, 3) for k, v in self.times.items()},
            "log_worker_cpu_s": res.get("cpu_s"),
        }
        if self.gateway is not None:  # --link can: the simulated bus (can.log holds its frames)
            g = self.gateway
            out["link"]["can"] = {"frames": g.frames, "error_frames": g.error_frames,
                                  "micro_replies_skipped": g.skipped, "adapter": dict(g.adapter.stats),
                                  "micro_iso_tp_rx": dict(g.micro.rx.stats), "micro_iso_tp_tx": g.micro_tx_stats()}
        if self.fmu_split:
            out["fmu_split_s"] = [round(x, 3) for x in self.fmu_split]
        if self.rate_note:
            out["control_rate_note"] = self.rate_note
        if self.fw_profile:
            out["firmware_profile"] = self.fw_profile
        return out


def _refusal(cmd: dict, result: str) -> str:
    """Why the host refused planner command `cmd` (lisp_cmd fields) with lisp_data
    nav_result `result` (host/src/navigation.cpp, Navigation::convert)."""
    from navkit import protocol

    enums = protocol.SPEC.enums
    if result == "not_implemented":
        fwd = cmd["fwd_cmd"]
        name = {c: n for n, c in enums["fwd_cmd"].values.items()}.get(fwd, "?")
        return f"fwd_cmd {fwd} ({name}) is a high-level code; the rest of the command applies"
    if result == "rejected" and cmd["turn_mode"] == enums["turn_mode"].values["heading_hold"]:
        return ("heading hold (turn_mode 11) needs the micro's current heading and the host "
                "had none (no fresh micro_data: micro offline); the command was dropped")
    if result == "rejected":
        return ("the command was dropped: a value does not fit the micro command the host makes "
                "of it, or a console stop key (space) came in the same frame (see host.log)")
    return f"lisp_data.nav_result = {result}"


def _planner_summary(planner: dict | None) -> dict:
    """summary.json `planner` from the log's verdicts: commands written, how many the host
    accepted, rejected, did not implement or never acknowledged, and `refused`, one entry
    per command not accepted ([[command]] index, t in s, nav_result, reason). Each
    nav_result of the spec but ok has its count (rejected, not_implemented,
    planner_timeout)."""
    from navkit import protocol

    names = {c: n for n, c in protocol.SPEC.enums["nav_result"].values.items()}
    out = {"commands": 0, "accepted": 0, **{n: 0 for n in names.values() if n != "ok"},
           "unacknowledged": 0, "refused": []}
    if not planner:
        return out
    out["commands"] = planner["commands"]
    out["unacknowledged"] = len(planner["unacknowledged"])
    for (index, t, where), cmd, code in planner["verdicts"]:
        result = names.get(code, str(code))
        if result == "ok":
            out["accepted"] += 1
            continue
        out[result] = out.get(result, 0) + 1   # a code the spec does not name: under its number
        out["refused"].append({"command": index, "t": t, "where": where,
                               "nav_result": result, "reason": _refusal(cmd, result)})
    return out


def run(opts: SimOptions) -> dict:
    """Do one run; write run.mcap, summary.json (and plot.png) into opts.out; return the
    summary. Raises MissionError for a mission that does not fit the FMUs, SimError if a
    part is missing or fails or the plant FMU does not fit the coupler (navkit.sim.plant)."""
    # module imports are not part of a run's wall time
    import fmpy.fmi3  # noqa: F401
    import mcap.writer  # noqa: F401

    r = _Run(opts)
    wall0 = time.perf_counter()
    from navkit.sim.coupler import CouplerError
    from navkit.sim.links import LinkError

    interrupted = None
    try:
        r.start()
        if opts.realtime:
            r.realtime()
        else:
            r.lockstep()
    except (LinkError, CouplerError) as e:
        r.stop()
        raise SimError(f"{e} (host log: {r.out / 'host.log'})") from e
    except KeyboardInterrupt as e:
        interrupted = e.args[0] if e.args and isinstance(e.args[0], int) else int(signal.SIGINT)
    except BaseException:
        r.stop()
        raise
    if interrupted is not None:
        # a clean stop, then what there is: a second Ctrl-C waits until the outputs are closed
        held = {s: signal.signal(s, signal.SIG_IGN) for s in (signal.SIGINT, signal.SIGTERM)}
        try:
            r.stop()
            summary = r.summary(time.perf_counter() - wall0)
            summary["interrupted"] = {"signal": signal.Signals(interrupted).name,
                                      "at_s": round(getattr(r, "t_ns", 0) / 1e9, 6)}
            if Path(opts.out).is_dir():
                (Path(opts.out) / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
            if opts.plot and (Path(opts.out) / "run.mcap").exists():
                from navkit.plot import plot_mcap

                plot_mcap(Path(opts.out) / "run.mcap", Path(opts.out) / "plot.png")
        finally:
            for s, h in held.items():
                signal.signal(s, h)
        raise SimInterrupted(summary, interrupted)
    r.stop()
    wall = time.perf_counter() - wall0
    summary = r.summary(wall)
    (Path(opts.out) / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    for ref in summary["planner"]["refused"]:
        verdict = ref["nav_result"].replace("_", " ")
        print(f"warning: {ref['where']} (t = {ref['t']:g} s): {verdict} by the host: "
              f"{ref['reason']} (lisp_data.nav_result = {ref['nav_result']})", file=sys.stderr)
    if opts.plot:
        from navkit.plot import plot_mcap

        plot_mcap(Path(opts.out) / "run.mcap", Path(opts.out) / "plot.png")
    return summary
