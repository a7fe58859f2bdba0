"""`navkit sim`: run a mission through the real host, the firmware FMU and the plant FMU.

    navkit sim --mission config/missions/demo.toml --out build/sim/demo [--seed N] [--realtime]
    navkit sim --plant my_robot.fmu ...     # a plant FMU of your own (FMI 3.0 co-simulation)
    navkit sim --firmware avr ...           # processor in the loop: the AVR image in simavr

Writes run.mcap, summary.json, host.log, plot.png and the host's datalogs (when recording
was on) into the output folder and prints where they are, the final pose and the speed of
the run.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

__all__ = ["add_arguments", "run", "DEFAULT_MISSION", "EXIT_AT_ONCE", "HOLDS_COLLECTOR"]

DEFAULT_MISSION = "config/missions/demo.toml"

# run() returns with every child ended (host, log worker) and every file it
# wrote closed, however it ends: the navkit command exits at once (navkit.cli.main),
# without tearing the harness's modules (numpy, fmpy) and objects down one by one
EXIT_AT_ONCE = True

# the collector stays off (navkit.cli.hold_collector) through the run's imports and set-up,
# whose objects live for the whole run: navkit.sim.rig.SimRig.start releases it when the
# set-up is done, run() when it ends before that
HOLDS_COLLECTOR = True


def add_arguments(parser) -> None:
    """Arguments of `navkit sim`."""
    parser.add_argument("--mission", "-m", type=Path, default=None,
                        help=f"mission TOML (default: {DEFAULT_MISSION})")
    parser.add_argument("--out", "-o", type=Path, default=None,
                        help="output folder (default: <build>/sim/<mission name>)")
    parser.add_argument("--seed", type=int, default=1, help="seed of the plant's noise and "
                        "the line noise (default 1): a value of the plant FMU's seed "
                        "parameter, -2147483648..2147483647 (Int32) for the built plant")
    parser.add_argument("--realtime", action="store_true",
                        help="pace to the wall clock, host on its own clock (not deterministic)")
    parser.add_argument("--config", type=Path, default=None,
                        help="host config folder (default: <repo>/config)")
    parser.add_argument("--build", type=Path, default=None,
                        help="build folder (default: $NAVKIT_BUILD_DIR or <repo>/build)")
    parser.add_argument("--plant", type=Path, default=None, metavar="FMU",
                        help="plant FMU to use instead of <build>/fmus/navkit_plant.fmu: FMI 3.0 "
                        "co-simulation with the variable names of docs/internals.md")
    parser.add_argument("--firmware", choices=("fmu", "avr"), default="fmu",
                        help="fmu: the firmware core compiled for this machine (navkit_firmware.fmu, "
                        "default); avr: the flashed ATmega2560 image executing in simavr "
                        "(navkit_firmware_avr.fmu, processor in the loop; control_rate at most "
                        "the image's 400 Hz: docs/pil.md)")
    parser.add_argument("--link", choices=("serial", "can"), default="serial",
                        help="serial: the host's frames on its port (default); can: the host on "
                        "[micro] link = slcan, the harness as its USB-CAN adapter (ISO-TP on a simulated "
                        "bus, every frame in can.log; docs/can.md)")
    parser.add_argument("--frame-ms", type=float, default=None,
                        help="host frame period in ms, a whole number; the micro's watchdog_timeout must "
                        "outlast two frames (default: from NavAndControl.ini)")
    parser.add_argument("--no-plot", action="store_true", help="skip plot.png")
    parser.add_argument("--no-progress", action="store_true",
                        help="no progress on stderr (by default a line redrawn in place on a terminal "
                        "after the first second, else a line every 10 s of wall time)")
    parser.add_argument("--stamps", type=Path, default=None, metavar="FILE",
                        help="write the time.monotonic() (s) at which each phase of this command "
                        "ended as JSON into FILE (navkit bench-sim times the whole command with it)")


def _out_refusal(out: Path) -> str:
    """Why the output folder `out` cannot be used (it is made by the run), or ""."""
    import os

    if out.exists():
        return "" if out.is_dir() else "not a folder"
    up = out.parent
    while not up.exists() and up != up.parent:
        up = up.parent
    if not up.is_dir():
        return f"cannot create it: {up} is not a folder"
    if not os.access(up, os.W_OK | os.X_OK):
        return f"cannot create it: no permission to create files in {up}"
    return ""


def _interrupt(signum, _frame):
    """A stop signal but SIGINT (navkit.sim.options.STOP_SIGNALS): stop the run as Ctrl-C
    does (navkit.sim.harness.run)."""
    raise KeyboardInterrupt(signum)


def run(args) -> int:
    """Run the mission; 0 on success; 1 (a bad mission, config or run) or 2 (a bad option)
    with one line on stderr; 128 + the signal's number (130 for Ctrl-C) when a signal
    stopped it: the outputs are closed and summary.json says `interrupted`."""
    import time

    stamps = {"cli": time.monotonic()}
    from navkit.cli import release_collector
    from navkit.sim.options import one_blas_thread

    one_blas_thread()

    try:
        return _run(args, stamps)
    finally:
        release_collector()     # a run that failed before its set-up was done


def _run(args, stamps: dict) -> int:
    """run(args) once the environment is set."""
    from navkit.hostconfig import forget_asks
    from navkit.sim.options import ask_host_config, config_folder, git_revision_started

    if args.frame_ms is not None and not (math.isfinite(args.frame_ms) and args.frame_ms > 0):
        print(f"navkit sim: --frame-ms {args.frame_ms:g}: not a positive number of ms", file=sys.stderr)
        return 2
    # the run's questions to git and to the host about its config, answered while the
    # mission loads and the FMU library imports (the run takes the answers)
    git = git_revision_started()
    frame_s = args.frame_ms / 1000 if args.frame_ms is not None else None
    ask_host_config(config_folder(args.config), args.build, frame_s)   # None: build_dir()
    try:
        return _run_asked(args, stamps, git, frame_s)
    finally:
        git()
        forget_asks()


def _run_asked(args, stamps: dict, git, frame_s: float | None) -> int:
    """_run once git (git_revision_started()) and the host's config have been asked."""
    import signal
    import time

    from navkit.paths import build_dir, repo_root
    from navkit.sim.harness import SimError, SimOptions
    from navkit.sim.harness import run as run_sim
    from navkit.sim.mission import MissionError, load

    mission_path = args.mission or repo_root() / DEFAULT_MISSION
    try:
        # the host judges the commands while the FMU library imports; its verdict before
        # anything else is said, so a rejected mission is one line
        mission = load(mission_path, build=args.build, judge_later=True)
        import fmpy.fmi3  # noqa: F401

        mission.judged()
    except MissionError as e:
        print(f"navkit sim: {e}", file=sys.stderr)
        return 1
    for w in mission.warnings:
        print(f"warning: {w}", file=sys.stderr)
    build = args.build or build_dir()
    out = args.out or build / "sim" / mission.name
    why = _out_refusal(out)
    if why:
        print(f"navkit sim: {'--out ' if args.out else 'output folder '}{out}: {why}", file=sys.stderr)
        return 1
    opts = SimOptions(mission=mission, out=out, seed=args.seed, realtime=args.realtime,
                      config_dir=args.config, build=build, plant_fmu=args.plant,
                      firmware=args.firmware, link=args.link,
                      frame_s=frame_s,
                      plot=not args.no_plot, progress=not args.no_progress)
    from navkit.sim.harness import SimInterrupted
    from navkit.sim.options import STOP_SIGNALS, stop_signal

    for sig in STOP_SIGNALS - {signal.SIGINT}:     # SIGINT: Python's own KeyboardInterrupt
        signal.signal(sig, _interrupt)
    try:
        s = run_sim(opts, stamps, git)
    except (MissionError, SimError) as e:
        print(f"navkit sim: {e}", file=sys.stderr)
        return 1
    except OSError as e:        # the outputs: a folder that cannot be made, a full disk
        print(f"navkit sim: {e.filename or out}: {e.strerror or e}", file=sys.stderr)
        return 1
    except SimInterrupted as e:
        print(f"navkit sim: {e}: outputs closed in {out}/ (summary.json says interrupted)", file=sys.stderr)
        return 128 + e.signum
    except KeyboardInterrupt as e:     # a stop signal outside the loop: before it, or held
        signum = stop_signal(e)
        when = (f"as the run ended: its outputs are closed in {out}/" if "stopped" in stamps
                else "before the run started")
        print(f"navkit sim: stopped by {signal.Signals(signum).name} {when}", file=sys.stderr)
        return 128 + signum
    t = s.get("truth") or {}
    print(f"mission   {mission.path}  (seed {args.seed}, {s['mode']})")
    if args.plant:
        print(f"plant     {s['plant_fmu']}")
    if args.firmware != "fmu":
        print(f"firmware  {s['firmware_fmu']}  (control_rate {s['control_rate_hz']} Hz)")
    if s.get("control_rate_note"):
        print(f"note      {s['control_rate_note']}: the run's config says {s['control_rate_hz']} Hz")
    print(f"outputs   {out}/  run.mcap  summary.json  host.log" + ("  plot.png" if opts.plot else ""))
    for name in s["datalogs"]:
        print(f"datalog   {Path(out) / name}")
    print(f"final     x {t.get('x_mm', 0):.0f} mm  y {t.get('y_mm', 0):.0f} mm  "
          f"heading {t.get('heading_deg', 0):.1f} deg  v {t.get('v_mm_s', 0):.0f} mm/s")
    print(f"speed     {s['sim_time_s']:.1f} s simulated in {s['wall_time_s']:.2f} s wall "
          f"= {s['realtime_factor']}x real time, {s['frames']} host frames")
    stamps["end"] = time.monotonic()
    whole = _process_wall_s()
    if whole:
        run_s = stamps["stopped"] - stamps["run"]
        out_s = stamps["end"] - stamps["stopped"]
        print(f"          the whole command: {whole:.2f} s wall = {s['sim_time_s'] / whole:.1f}x real time "
              f"(with Python's start-up and the outputs" + (", plot.png)" if opts.plot else ")"))
        print(f"          of it: start-up {max(0.0, whole - run_s - out_s):.2f} s, run {run_s:.2f} s "
              f"(set-up, loop, shutdown), outputs {out_s:.2f} s (summary.json"
              + (", plot.png)" if opts.plot else ")"))
    if args.stamps:
        import json

        args.stamps.write_text(json.dumps(stamps) + "\n")
    return 0


def _process_wall_s() -> float | None:
    """Wall time (s) since this process started (/proc: its start time and the uptime,
    10 ms ticks); None where /proc does not say."""
    import os

    try:
        with open("/proc/self/stat") as f:
            start = int(f.read().rsplit(")", 1)[1].split()[19])
        with open("/proc/uptime") as f:
            uptime = float(f.read().split()[0])
        return uptime - start / os.sysconf("SC_CLK_TCK")
    except (OSError, ValueError, IndexError):
        return None
