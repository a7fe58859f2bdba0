"""`navkit bench-pil`: processor-in-the-loop figures of a mission (default: the demo).

Runs the mission twice through the real host in lockstep: with the AVR firmware FMU (the
flashed ATmega2560 image executing in simavr, `navkit sim --firmware avr`) and with the SIL
firmware FMU. Prints what the board simulator measured from the running image (cycles of
fw_tick and fw_link_poll: worst and mean, their CPU share at the rate used, the deepest
stack), the PIL run's real-time factor beside the SIL run's, and how far the two runs part
(navkit.compare: worst deviation at a leg's end and over the run).
"""

from __future__ import annotations

import tempfile
from pathlib import Path

from navkit.sim_bench import add_run_arguments, run_or_report

__all__ = ["add_arguments", "run"]

F_CPU_HZ = 16_000_000  # the board's clock: cycles per second


def add_arguments(parser) -> None:
    """Arguments of `navkit bench-pil`."""
    parser.add_argument("--mission", "-m", type=Path, default=None,
                        help="mission TOML (default: config/missions/demo.toml)")
    add_run_arguments(parser, "keep both runs here (pil/ and sil/; default: a temporary folder)")


def _us(cycles: float) -> str:
    return f"{cycles / (F_CPU_HZ / 1e6):7.1f} us"


def run(args) -> int:
    """Run both and print the figures; 0 on success, 1 (one line on stderr) on a failed run."""
    import sys

    from navkit.compare import CompareError, compare_runs
    from navkit.paths import repo_root
    from navkit.sim.cli import DEFAULT_MISSION
    from navkit.sim.harness import SimOptions
    from navkit.sim.mission import MissionError, load

    try:
        mission = load(args.mission or repo_root() / DEFAULT_MISSION)
    except MissionError as e:
        print(f"navkit bench-pil: {e}", file=sys.stderr)
        return 1
    with tempfile.TemporaryDirectory(prefix="navkit-bench-pil-") as tmp:
        out = Path(args.out or tmp)
        runs = {}
        for fw in ("avr", "fmu"):
            opts = SimOptions(mission=mission, out=out / ("pil" if fw == "avr" else "sil"), seed=args.seed,
                              build=args.build, plot=False, firmware=fw)
            runs[fw] = run_or_report(opts, f"bench-pil: {'PIL' if fw == 'avr' else 'SIL'} run")
            if runs[fw] is None:
                return 1
        try:
            c = compare_runs(out / "sil", out / "pil")
        except CompareError as e:
            print(f"navkit bench-pil: {e}", file=sys.stderr)
            return 1
    pil, sil = runs["avr"], runs["fmu"]
    p = pil["firmware_profile"]
    rate = pil["control_rate_hz"]
    period = F_CPU_HZ / rate
    print(f"mission {mission.path}: {pil['sim_time_s']:.1f} s simulated, seed {args.seed}")
    print(f"AVR image in simavr at {F_CPU_HZ / 1e6:g} MHz, control_rate {rate} Hz "
          f"({period:.0f} cycles per tick); {p['avr_cycles']:,} cycles run")
    print(f"fw_tick      {p['prof_ticks']:6d} ticks  worst {p['prof_tick_worst_cycles']:6d} cycles "
          f"({_us(p['prof_tick_worst_cycles'])}, {100 * p['prof_tick_worst_cycles'] / period:.1f} % of a tick)  "
          f"mean {p['prof_tick_mean_cycles']:6d} cycles ({_us(p['prof_tick_mean_cycles'])})  "
          f"CPU {p['tick_cpu_share_pct']:.1f} %")
    print(f"fw_link_poll {p['prof_polls']:6d} polls  worst {p['prof_poll_worst_cycles']:6d} cycles "
          f"({_us(p['prof_poll_worst_cycles'])})  mean {p['prof_poll_mean_cycles']:6d} cycles "
          f"({_us(p['prof_poll_mean_cycles'])})  CPU {p['poll_cpu_share_pct']:.1f} %")
    print(f"stack        deepest {p['prof_stack_max_bytes']} B; resets {p['prof_resets']} "
          f"(watchdog {p['prof_watchdog_resets']})")
    print(f"real time    PIL {pil['realtime_factor']}x ({pil['wall_time_s']:.2f} s wall), "
          f"SIL {sil['realtime_factor']}x ({sil['wall_time_s']:.2f} s wall)")
    pos, hdg = c.worst_leg_end()
    print(f"SIL vs PIL   worst leg end {pos:.3f} mm, {hdg:.3f} deg ({len(c.legs)} legs); over the run: "
          f"position max {c.truth['position'].max:.3g} mm, heading max {c.truth['heading'].max:.3g} deg")
    return 0
