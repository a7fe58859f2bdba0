"""`navkit bench-sim`: time a long lockstep co-simulation end to end.

Runs a generated mission (default 10 simulated minutes: out-and-back legs, heading
selects, servo scans, DIO) through the real host over the pty, and prints the real-time
factor (simulated s per wall s), the share of wall time in the FMUs (native coupler),
the pty, the host (tick to done) and the harness's own Python (mission events, queuing log
items for the worker that decodes and writes MCAP on the other CPU), and the peak memory
of the harness, the log worker and the host. Then it runs the whole command as a user
does, `python -m navkit sim` with every output (run.mcap, summary.json, host.log,
plot.png), and prints its wall time from start to exit and the parts of it (start-up,
set-up, loop, shutdown, outputs), from the command's --stamps.
"""

from __future__ import annotations

import json
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

__all__ = ["add_arguments", "run", "bench_mission", "add_run_arguments", "run_or_report",
           "whole_command", "PHASES"]


def add_run_arguments(parser, out_help: str) -> None:
    """The options of a co-simulation benchmark (bench-sim, bench-pil): --seed, --out
    (out_help says what it keeps), --build."""
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--out", type=Path, default=None, help=out_help)
    parser.add_argument("--build", type=Path, default=None,
                        help="build folder (default: $NAVKIT_BUILD_DIR or <repo>/build)")


def run_or_report(opts, what: str) -> dict | None:
    """navkit.sim.harness.run(opts): its summary, or None after one line on stderr,
    "navkit <what>: <error>", for a mission or run error."""
    from navkit.sim.harness import SimError
    from navkit.sim.harness import run as run_sim
    from navkit.sim.mission import MissionError

    try:
        return run_sim(opts)
    except (MissionError, SimError) as e:
        print(f"navkit {what}: {e}", file=sys.stderr)
        return None


def add_arguments(parser) -> None:
    """Arguments of `navkit bench-sim`."""
    parser.add_argument("--minutes", type=float, default=10.0,
                        help="simulated minutes (default 10)")
    add_run_arguments(parser, "keep the run's outputs here (default: a temporary folder)")
    parser.add_argument("--link", choices=("serial", "can"), default="serial",
                        help="the micro link: serial (default) or can (navkit sim --link can: "
                        "SLCAN and ISO-TP through the harness; docs/can.md)")
    parser.add_argument("--whole", type=int, default=1, metavar="N",
                        help="run the whole `navkit sim` command N times (default 1; 0: not at "
                        "all) and print the parts of the median run, with the best, median and "
                        "worst wall times")


def bench_mission(minutes: float) -> str:
    """Mission TOML text: `minutes` of 20-s cycles (1 m out, turn around by heading
    select, 1 m back, servo scan, DIO toggles)."""
    dur = minutes * 60.0
    lines = [f"duration_s = {dur}"]
    t, k = 1.0, 0
    while t + 20.0 <= dur:
        hdg = 1800 if k % 2 == 0 else 0
        lines += ["[[command]]", f"t = {t}", "fwd_cmd = 1", "speed = 400", "distance = 1000",
                  "rc_servo_num = 1", "rc_param0 = 900", "rc_param1 = 600", "rc_param2 = -600",
                  "dio_active = 15", f"dio_command = {k % 16}"]
        lines += ["[[command]]", f"t = {t + 5.0}", "turn_mode = 10", "turn_rate = 900",
                  f"turn_distance = {hdg}", "dio_active = 15", f"dio_command = {(k + 1) % 16}"]
        lines += ["[[command]]", f"t = {t + 10.0}", "fwd_cmd = 1", "speed = 300",
                  "distance = 1000", "turn_mode = 11", "turn_rate = 300"]
        t += 20.0
        k += 1
    return "\n".join(lines) + "\n"


def run(args) -> int:
    """Run the benchmark and print its figures; 0 on success."""
    from navkit.sim.options import one_blas_thread

    one_blas_thread()       # as navkit sim does, before the harness imports numpy
    from navkit.sim.harness import SimOptions
    from navkit.sim.mission import loads

    if args.whole < 0:
        print(f"navkit bench-sim: --whole {args.whole}: not a count of runs", file=sys.stderr)
        return 2
    with tempfile.TemporaryDirectory(prefix="navkit-bench-") as tmp:
        out = args.out or Path(tmp) / "out"
        mission_file = Path(tmp) / "bench.toml"
        text = bench_mission(args.minutes)
        mission_file.write_text(text)       # the whole command's --mission
        mission = loads(text, mission_file, build=args.build)
        opts = SimOptions(mission=mission, out=out, seed=args.seed, build=args.build,
                          plot=False, timing=True, link=args.link)
        s = run_or_report(opts, "bench-sim")
        if s is None:
            return 1
        _print_loop(s, args.link)
        runs = []
        for i in range(args.whole):
            parts = whole_command(mission_file, Path(tmp) / f"whole{i}", args.seed, args.build,
                                  args.link)
            if parts is None:
                return 1
            runs.append(parts)
    if runs:
        _print_whole(runs, s["sim_time_s"])
    return 0


# The phases of a `navkit sim` command, by the --stamps key that ends each (the bench's
# own spawn of the process starts the first, its exit ends the last), and what each holds.
PHASES = (
    ("cli", "start-up (Python, navkit CLI)"),
    ("run", "mission, harness imports"),
    ("started", "set-up (FMUs, host, log worker)"),
    ("loop", "loop"),
    ("stopped", "shutdown (host, log worker, FMUs)"),
    ("summary", "summary.json"),
    ("plot", "plot.png"),
    ("exit", "printing, exit"),
)


def whole_command(mission: Path, out: Path, seed: int, build: Path | None, link: str) -> dict | None:
    """Run `python -m navkit sim` on `mission` into `out` with every output, as a user
    does, and time it: {phase key: wall s} (PHASES) and "total" (s, from spawning the
    process to its exit); None after one line on stderr if the command failed."""
    stamps_file = out.with_suffix(".stamps.json")
    cmd = [sys.executable, "-m", "navkit", "sim", "--mission", str(mission), "--out", str(out),
           "--seed", str(seed), "--link", link, "--no-progress", "--stamps", str(stamps_file)]
    if build is not None:
        cmd += ["--build", str(build)]
    t0 = time.monotonic()
    done = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    t1 = time.monotonic()
    if done.returncode != 0:
        err = done.stderr.strip().splitlines()
        print(f"navkit bench-sim: the whole command failed (status {done.returncode}): "
              f"{err[-1] if err else ''}", file=sys.stderr)
        return None
    stamps = json.loads(stamps_file.read_text())
    stamps["exit"] = t1
    parts, last = {}, t0
    for key, _ in PHASES:
        at = stamps.get(key, last)      # a phase the run did not have takes no time
        parts[key] = at - last
        last = at
    parts["total"] = t1 - t0
    return parts


def _print_whole(runs: list, sim_s: float) -> None:
    """The whole command's figures: the parts of the median run (by total wall time),
    and the best, median and worst totals."""
    runs = sorted(runs, key=lambda p: p["total"])
    mid = runs[(len(runs) - 1) // 2]
    total = mid["total"]
    print(f"whole command (python -m navkit sim, every output: run.mcap, summary.json, host.log, "
          f"plot.png): {sim_s:.0f} s simulated in {total:.2f} s wall = {sim_s / total:.0f}x real time")
    for key, name in PHASES:
        print(f"  {name:36s} {mid[key]:7.3f} s  {100 * mid[key] / total:5.1f} %")
    if len(runs) > 1:
        totals = [p["total"] for p in runs]
        print(f"  {len(runs)} runs: best {totals[0]:.2f} s ({sim_s / totals[0]:.0f}x), median "
              f"{statistics.median(totals):.2f} s, worst {totals[-1]:.2f} s ({sim_s / totals[-1]:.0f}x)")


def _print_loop(s: dict, link: str) -> None:
    """The timed in-process run's figures: real-time factor, time shares, memory."""
    wall = s["wall_time_s"]
    share = s["time_share_s"]
    print(f"simulated {s['sim_time_s']:.0f} s in {wall:.2f} s wall: "
          f"real-time factor {s['realtime_factor']}x ({s['frames']} host frames of "
          f"{s['frame_s'] * 1000:.0f} ms, FMUs at 1 kHz, {link} link"
          + (f": {s['link']['can']['frames']} CAN frames" if link == "can" else "") + ")")
    rest = wall - sum(share.values())
    parts = dict(share, startup_and_shutdown=rest)
    names = {"fmus": "FMUs (native coupler)", "pty": "pty reads/writes",
             "host": "host frame (tick -> done)",
             "harness": "harness Python (events, log items)",
             "startup_and_shutdown": "start-up, shutdown, summary"}
    for k, v in parts.items():
        print(f"  {names.get(k, k):32s} {v:7.3f} s  {100 * v / wall:5.1f} %")
    fw, plant = s.get("fmu_split_s", (None, None))
    if fw is not None:
        print(f"  of the FMUs: firmware {fw:.3f} s, plant {plant:.3f} s")
    if s.get("log_worker_cpu_s") is not None:
        print(f"  log worker on the other CPU (decode + MCAP): {s['log_worker_cpu_s']:.3f} s of CPU")
    mem = s.get("memory_peak_mib", {})
    me = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"peak memory (resident): harness {me:.0f} MiB, log worker "
          f"{mem.get('log_worker')} MiB, host {mem.get('host')} MiB")
