"""The parts of one co-simulation run, set up and torn down (SimRig): the paths and the
host's configuration resolved from SimOptions, the two FMUs and the native coupler, the
log worker writing run.mcap, the pty port, the lockstep channel, the `navkit-host`
process and the scripted planner on its rcomm region; and what their tear-down reports
(the host's exit status and peak memory, the log's results, the firmware's profile).

The run's counters live here as well, written by the loop that drives the parts
(navkit.sim.lockstep or navkit.sim.realtime) and read by the summary (navkit.sim.summary):
`host_state`, `rx_count`, `frames`, `t_ns`, `sim_time_s`, `times`."""

from __future__ import annotations

import gc
import os
import shutil
import signal
import subprocess
import tempfile
import time
from pathlib import Path

from navkit.sim.faults import check_timeline
from navkit.sim.fmus import FmuPair, check_seed
from navkit.sim.host_console import HostConsole
from navkit.sim.options import (STEP_S, SimError, SimOptions, build_folder, check_frame, config_folder,
                                fmu_paths, git_revision_started, host_config, host_path)
from navkit.sim.planner import ScriptedPlanner

__all__ = ["SimRig", "datalogs"]


def _end_with_parent():
    """A preexec_fn for a child: SIGTERM when the harness ends, however it ends (the host
    then shuts down as on SIGTERM: stop sent, region removed). libc's prctl is looked up
    here, in the harness, so the child between fork and exec only calls it (no dlopen)."""
    import ctypes

    prctl = ctypes.CDLL(None, use_errno=True).prctl
    return lambda: prctl(1, int(signal.SIGTERM))   # PR_SET_PDEATHSIG


def datalogs(folder: Path) -> dict:
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


class SimRig:
    """One run's parts: resolved and checked on construction (SimError for a missing build
    product or a config or frame the host refuses), started by start(), ended by stop()
    (which is safe after a failed or partial start). Times in s, `t_ns` in ns."""

    def __init__(self, opts: SimOptions, git=None):
        """`git`: the run's git_revision_started() when the caller started it earlier, else
        None. A mission loaded with judge_later is judged first (MissionError)."""
        opts.mission.judged()
        self.opts = opts
        self.m = opts.mission
        # its git commands run beside the checks and the set-up; start() takes the answer
        self._git = git or git_revision_started()
        self.git_revision = None
        try:
            self._resolve(opts)
        except BaseException:
            self._git()
            raise

    def _resolve(self, opts: SimOptions) -> None:
        """The paths and the host's configuration of `opts`, checked, and the run's state."""
        from navkit import protocol

        self.build = build_folder(opts)
        self.config_dir = config_folder(opts.config_dir)
        self.out = Path(opts.out)
        self.plant_fmu = Path(opts.plant_fmu) if opts.plant_fmu else fmu_paths(self.build)[1]
        self._check_built()
        self.host_config = host_config(self.config_dir, self.build, opts.frame_s)
        rate = self.host_config["sections"]["executive"]["frame_rate_hz"]
        self.frame_s = opts.frame_s or 1.0 / rate["value"]
        self.steps_per_frame = check_frame(self.frame_s, "--frame-ms" if opts.frame_s else f"{rate['from']}: frame_rate_hz")
        self.frame_s = self.steps_per_frame * STEP_S
        self.protocol = protocol
        self.tmp = Path(tempfile.mkdtemp(prefix="navkit-sim-"))
        self.shm = f"/navkit-sim-{os.getpid()}-{time.monotonic_ns() % 1_000_000_000}"
        self.proc = self.lock = self.port = self.fmus = self.coupler = None
        self.log = self.planner = self.host_log = None
        self.progress = None                 # navkit.sim.progress.Progress while a loop runs
        self.host_state = "running"          # "running", "exited" or "killed"
        self.gateway = self.can_log = None   # --link can: navkit.can_gateway, can.log's writer
        self.rx_count = 0       # the micro's bytes written to the pty since the last tick
        self.frames = 0         # host frames run
        self.t_ns = 0           # where the loop is (an interrupted run stopped there)
        self.console = None     # navkit.sim.host_console.HostConsole of host.log
        self.host_exit = self.host_peak_kib = None   # the host's exit status, peak memory (KiB)
        self.fw_fmu = None                   # the firmware FMU file start() chose
        self.old_datalogs = {}               # datalogs() of the output folder before the run
        self._saved_affinity = None          # the CPUs before _pin
        self.results = {}
        self.fmu_split = None
        self.fw_profile = {}
        self.control_rate = self.rate_note = None
        self.sim_time_s = 0.0
        self.times = {"fmus": 0.0, "pty": 0.0, "host": 0.0, "harness": 0.0}

    def start(self) -> None:
        """Check the mission's timeline, then set up every part and start the host; SimError
        (or MissionError) naming what failed. The log worker is forked first."""
        from navkit.sim.coupler import Coupler
        from navkit.sim.links import Lockstep, Port
        from navkit.sim.record import RunLog

        from navkit.sim.plant import PlantFmuError, check

        self.git_revision = self._git()
        check_timeline(self.m, self.frame_s)
        fw_fmu, plant_fmu = fmu_paths(self.build, self.opts.firmware)[0], self.plant_fmu
        if self.opts.link == "can":   # the firmware's CAN build (the AVR's: the CAN image)
            fw_fmu = fw_fmu.with_name(f"{fw_fmu.stem}_can.fmu")
        self.fw_fmu = fw_fmu
        self._firmware_rate(fw_fmu)
        # a plant of the user's is checked against the FMI schemas; the build's own FMUs
        # are by their tests (navkit.sim.plant.check)
        validate = self.opts.plant_fmu is not None
        try:
            plant_md = check(plant_fmu, fw_fmu, validate)   # FMI 3.0 co-simulation, the contract
        except PlantFmuError as e:
            raise SimError(str(e)) from None
        check_seed(self.opts.seed, plant_md, plant_fmu)
        plant_params = {"seed": self.opts.seed}
        if self.m.world is not None:
            plant_params["world_file"] = str(self.m.world)
        plant_params.update(self.m.plant)
        self.fmus = FmuPair(fw_fmu, plant_fmu, self.tmp, self._known_plant(plant_md, plant_params),
                            self.m, validate)
        every = max(1, round(1.0 / (self.opts.truth_hz * STEP_S)))
        self.coupler = Coupler(self.fmus.fw, self.fmus.fw_md, self.fmus.plant,
                               self.fmus.plant_md, step_s=STEP_S, record_every=every,
                               build=self.build)
        if self.opts.timing:
            self.coupler.timing(True)
        host = host_path(self.build)
        self.out.mkdir(parents=True, exist_ok=True)
        self.old_datalogs = datalogs(self.out)   # an earlier run's, kept but not this run's
        meta = {"mission": self.m.text, "mission_file": self.m.path.name,
                "seed": self.opts.seed, "spec_hash": f"0x{self.protocol.SPEC_HASH:08X}",
                "git_revision": self.git_revision, "frame_s": self.frame_s,
                "realtime": self.opts.realtime, "step_s": STEP_S,
                "plant_fmu": self.fmus.plant_md.modelName,
                "firmware_fmu": self.fmus.fw_md.modelName,
                "firmware": self.opts.firmware, "control_rate_hz": self.control_rate}
        # fork the log worker before any pty, socket or child process exists
        self.log = RunLog(self.out / "run.mcap", meta, self.coupler.columns, self.coupler.width,
                          inline=self.opts.log_inline, can=self.opts.link == "can",
                          build=self.build, plot=self.out / "plot.png" if self.opts.plot else None)
        walls = self.fmus.walls(plant_fmu)
        if walls is not None:
            self.log.walls(walls)
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
                                      in ("navkit_firmware_can", "navkit_firmware_avr_can"))
        cmd += list(self.opts.host_args)
        self.host_log = open(self.out / "host.log", "wb")
        # what the host prints, to run.mcap: the names of this run only as placeholders
        self.console = HostConsole(self.out / "host.log", {
            str(self.tmp): "<tmp>", self.shm: "<rcomm>", str(self.out.resolve()): "<out>",
            str(self.config_dir): "<config>"}, self.out.resolve())
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
        self.planner = ScriptedPlanner(self.shm)
        if not self.planner.attach(10.0, lambda: self.proc.poll() is None):
            self._host_died_check()
            raise SimError(f"the host did not create rcomm region {self.shm} within 10 s "
                           f"(see {self.out / 'host.log'})")
        from navkit.cli import release_collector

        release_collector()     # navkit sim's hold (navkit.cli.hold_collector) ends with the set-up

    def _pin(self) -> None:
        """Lockstep: the harness and the host never run at the same time, so put both on
        one CPU (the host inherits the mask), where a tick or a done wakes the other side
        without a cross-CPU wake-up; the log worker gets the other CPUs. On an otherwise
        idle machine the worker keeps its CPU from idling (wake-ups from idle are slow on
        VMs): at idle priority, it polls for its work. When other processes already keep
        the CPUs busy (1-minute load average >= CPU count) the worker keeps normal priority
        and sleeps, since an idle-priority worker would starve and the harness would wait
        on it (docs/cosim.md, Speed)."""
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
        """SimError with the tail of host.log if the host has exited."""
        if self.proc is not None and self.proc.poll() is not None:
            if self.host_log:
                self.host_log.flush()
            tail = (self.out / "host.log").read_bytes()[-2000:].decode(errors="replace")
            raise SimError(f"navkit-host exited with status {self.proc.returncode}:\n{tail}")

    def stop(self) -> None:
        """End every part that was started, in order (host, with the bus played out until it
        has exited: navkit.sim.playout; planner, port, CAN log, log worker, coupler, FMUs),
        keeping what each reports; remove the temporary folder."""
        self._git()
        if self.progress is not None:
            self.progress.close()
        gc.unfreeze()             # the lockstep loop froze the objects of the set-up
        if self._saved_affinity:
            try:
                os.sched_setaffinity(0, self._saved_affinity)
                if self.log is not None and self.log.pid:
                    # the worker's last batches and the file's end at normal priority, asleep
                    # when idle: at idle priority any other process would hold them up, and
                    # the run waits for them
                    self.log.spin(False)
                    os.sched_setscheduler(self.log.pid, os.SCHED_OTHER, os.sched_param(0))
            except (OSError, AttributeError):
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
            # over CAN the host's last message, a stop, needs the bus (and the micro's flow
            # control) while it shuts down
            from navkit.sim.playout import play_out

            play_out(self)
            try:
                self.host_exit = self.proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.host_exit = self.proc.wait()
        if self.console is not None:     # the host's last lines: at the run's end
            if self.log is not None:
                end_ns = max(self.t_ns, round(self.sim_time_s * 1e9))
                self.log.console(end_ns, self.console.rest())
            self.console.close()
            self.console = None
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
