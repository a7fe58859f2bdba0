"""`navkit sweep`: a mission over a grid or random samples of plant parameters and seeds.

    navkit sweep --mission FILE --vary KEY=LO:HI[:N] ... [--seeds N] --out DIR
    navkit sweep --mission FILE --vary KEY=LO:HI ... --samples N [--sampler lhs|uniform]
    navkit sweep ... --scheduler tcp://HOST:8786      # an existing Dask cluster
    navkit sweep --bench [--bench-runs N]             # runs per minute with 1 and 2 workers
"""

from __future__ import annotations

import os
import sys
import tempfile
from pathlib import Path

__all__ = ["add_arguments", "run", "bench", "BENCH_RUNS"]

BENCH_RUNS = 24          # runs of the benchmark per worker count (seeds 1..N)


def add_arguments(parser) -> None:
    """Arguments of `navkit sweep`."""
    from navkit.cli import positive_int
    from navkit.sim.cli import DEFAULT_MISSION
    from navkit.sweep.plan import DEFAULT_GRID_POINTS, SAMPLERS
    from navkit.sweep.runner import KEEP

    parser.add_argument("--mission", "-m", type=Path, default=None,
                        help=f"mission TOML (default: {DEFAULT_MISSION})")
    parser.add_argument("--vary", action="append", default=[], metavar="KEY=LO:HI[:N]",
                        help="a plant parameter (a [plant] key of the mission, the plant FMU's "
                        f"name) from LO to HI; N grid points (default {DEFAULT_GRID_POINTS}); "
                        "repeat for more keys (the grid is every combination)")
    parser.add_argument("--samples", type=positive_int, default=None, metavar="N",
                        help="N random points over the --vary ranges instead of a grid")
    parser.add_argument("--sampler", choices=SAMPLERS, default="lhs",
                        help="random points: a Latin hypercube (default) or uniform draws")
    parser.add_argument("--sample-seed", type=int, default=1,
                        help="seed of the random points (default 1)")
    parser.add_argument("--seeds", type=positive_int, default=1, metavar="N",
                        help="run each point with seeds 1..N (default 1)")
    parser.add_argument("--out", "-o", type=Path, default=None,
                        help="output folder (default: <build>/sweep/<mission name>)")
    parser.add_argument("--scheduler", default=None, metavar="ADDRESS",
                        help="an existing Dask scheduler (tcp://HOST:8786) instead of a "
                        "LocalCluster on this machine")
    parser.add_argument("--workers", type=positive_int, default=None, metavar="N",
                        help="worker processes of the LocalCluster (default: one per CPU)")
    parser.add_argument("--config", type=Path, default=None,
                        help="host config folder (default: <repo>/config)")
    parser.add_argument("--build", type=Path, default=None,
                        help="build folder (default: $NAVKIT_BUILD_DIR or <repo>/build)")
    parser.add_argument("--firmware", choices=("fmu", "avr"), default="fmu",
                        help="fmu: the firmware core compiled for this machine (software in the "
                        "loop, default); avr: the AVR image in simavr (processor in the loop), "
                        "as navkit sim --firmware")
    parser.add_argument("--keep", choices=KEEP, default="failed",
                        help="run folders kept in OUT/runs/NNNN (default: failed)")
    parser.add_argument("--no-plot", action="store_true", help="skip summary.png")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar or lines")
    parser.add_argument("--bench", action="store_true",
                        help="benchmark: the mission (default the demo) with seeds 1..N on "
                        "1 and then 2 workers; prints runs per minute and their ratio")
    parser.add_argument("--bench-runs", type=positive_int, default=BENCH_RUNS, metavar="N",
                        help=f"runs per worker count of --bench (default {BENCH_RUNS})")


def _err(text: str) -> None:
    print(f"navkit sweep: {text}", file=sys.stderr)


def plan_runs(args, plant_fmu: Path) -> tuple[list, list]:
    """(RunSpecs, varied keys) of the parsed options; SweepError naming the option."""
    from navkit.sweep.plan import (SweepError, check_varies, grid, parse_vary, plant_parameters,
                                   sample)
    from navkit.sweep.runner import RunSpec

    varies = [parse_vary(t) for t in args.vary]
    params = plant_parameters(plant_fmu)
    check_varies(varies, params, plant_fmu)
    if args.samples is not None:
        if not varies:
            raise SweepError("--samples: give the ranges to sample with --vary KEY=LO:HI")
        points = sample(varies, params, args.samples, args.sampler, args.sample_seed)
    else:
        points = grid(varies, params)
    config = args.config.resolve() if args.config else None
    runs = [RunSpec(plant=p, seed=s, config=config)
            for p in points for s in range(1, args.seeds + 1)]
    return runs, [v.key for v in varies]


def run(args) -> int:
    """Run the sweep; 0 when every run succeeded, 1 when some failed (the table has them)
    or the sweep could not start, 2 for a bad option, 130 on Ctrl-C (the table of what
    finished is written)."""
    from navkit.paths import build_dir, repo_root
    from navkit.sim.cli import DEFAULT_MISSION
    from navkit.sim.harness import fmu_paths
    from navkit.sim.mission import MissionError, load
    from navkit.sweep.plan import SweepError
    from navkit.sweep.runner import SweepInterrupted, sweep

    if args.workers is not None and args.scheduler:
        _err("--workers: only for the LocalCluster; the cluster at --scheduler has its own workers")
        return 2
    if args.scheduler:
        from distributed.comm import parse_address

        try:
            parse_address(args.scheduler, strict=True)
        except ValueError as e:
            _err(f"--scheduler {args.scheduler!r}: {e} (e.g. tcp://HOST:8786)")
            return 2
    build = (args.build or build_dir()).resolve()
    mission_path = args.mission or repo_root() / DEFAULT_MISSION
    if args.bench:
        return bench(mission_path, build, args.bench_runs, args.firmware)
    try:
        mission = load(mission_path, build=build)
    except MissionError as e:
        _err(str(e))
        return 1
    plant_fmu = fmu_paths(build, args.firmware)[1]
    if not plant_fmu.exists():
        _err(f"{plant_fmu} not found: build first (cmake --build {build})")
        return 1
    from navkit.hostconfig import HostConfigError, effective_config

    try:  # the host's verdict on the config once, before any run (each run's would be the same)
        effective_config(args.config or repo_root() / "config", build=build)
    except HostConfigError as e:
        _err(str(e))
        return 1
    try:
        runs, varied = plan_runs(args, plant_fmu)
    except SweepError as e:
        _err(str(e))
        return 2
    out = args.out or build / "sweep" / mission.name
    meta = {"vary": args.vary, "samples": args.samples, "sampler": args.sampler,
            "sample_seed": args.sample_seed, "seeds": args.seeds}
    print(f"sweep     {mission.path}: {len(runs)} run{'s' if len(runs) != 1 else ''}"
          f" ({'%d samples' % args.samples if args.samples else 'grid'}"
          f"{', ' + ', '.join(varied) if varied else ''}; seeds 1..{args.seeds})"
          f"{', PIL' if args.firmware == 'avr' else ''} on {args.scheduler or 'a LocalCluster'}",
          flush=True)
    try:
        results, stats = sweep(mission_path, runs, out, scheduler=args.scheduler,
                               workers=args.workers, progress=not args.no_progress,
                               keep=args.keep, build=build, plot=not args.no_plot, meta=meta,
                               firmware=args.firmware)
    except SweepInterrupted as e:
        done = e.results
        print(f"interrupted: {len(done)} of {len(runs)} runs finished; their table: "
              f"{Path(out) / 'results.csv'}", file=sys.stderr)
        return 130
    except (SweepError, MissionError) as e:
        _err(str(e))
        return 1
    except OSError as e:            # the output folder cannot be made or written
        _err(f"{e.filename}: {e.strerror}" if e.filename else str(e))
        return 1
    failed = [r for r in results if not r.ok]
    spread = _spread(results, mission.expect)
    files = "results.csv" + ("  summary.png" if not args.no_plot else "") + "  sweep.json"
    print(f"outputs   {out}/  {files}")
    print(f"runs      {len(results)} done, {len(failed)} failed, {stats['runs_wall_s']:.1f} s "
          f"on {stats['workers']} worker{'s' if stats['workers'] != 1 else ''} = "
          f"{stats['runs_per_minute']:.0f} runs/min")
    if spread:
        print(spread)
    if failed:
        from navkit.sweep.runner import describe

        for r in failed[:10]:
            print(f"failed    {describe(r.spec, r.index)}: {r.error.splitlines()[0]}",
                  file=sys.stderr)
        if len(failed) > 10:
            print(f"failed    ... and {len(failed) - 10} more (results.csv)", file=sys.stderr)
        return 1
    return 0


def _spread(results: list, expect: dict) -> str:
    """'figure    err_pos_mm: min .., median .., max .. (run i (seed, params))': the
    headline figure of the summary plot over the runs that finished; '' if none."""
    import statistics

    from navkit.sweep.runner import describe
    from navkit.sweep.table import headline

    key, _ = headline(expect)
    vals = [(r.figures[key], r) for r in results if r.ok and r.figures.get(key) is not None]
    if not vals:
        return ""
    worst = max(vals, key=lambda v: abs(v[0]))
    xs = [v for v, _ in vals]
    return (f"figure    {key}: min {min(xs):.4g}, median {statistics.median(xs):.4g}, "
            f"max {max(xs):.4g}; largest |{key}| {worst[0]:.4g} in "
            f"{describe(worst[1].spec, worst[1].index)}")


def bench(mission_path: Path, build: Path, n: int, firmware: str = "fmu") -> int:
    """Runs per minute of `n` runs (seeds 1..n) of the mission with the `firmware` FMU on a
    LocalCluster of 1 and of 2 workers (cluster start-up not counted), their ratio, and
    whether both gave the same table."""
    from navkit.sim.mission import MissionError
    from navkit.sweep.plan import SweepError
    from navkit.sweep.runner import RunSpec, default_workers, sweep

    runs = [RunSpec(seed=s) for s in range(1, n + 1)]
    rates, tables = {}, {}
    print(f"sweep benchmark: {mission_path}, {n} runs (seeds 1..{n}) per worker count, "
          f"firmware {firmware}, LocalCluster on this machine ({build})")
    print(f"  {default_workers()} CPUs, 1-minute load average before: {os.getloadavg()[0]:.2f} "
          f"(other work on the CPUs skews the figures)")
    for workers in (1, 2):
        with tempfile.TemporaryDirectory(prefix="navkit-sweep-bench-") as tmp:
            try:
                results, stats = sweep(mission_path, runs, Path(tmp), workers=workers,
                                       progress=False, keep="none", build=build, plot=False,
                                       firmware=firmware)
            except (SweepError, MissionError) as e:
                _err(str(e))
                return 1
            tables[workers] = (Path(tmp) / "results.csv").read_text()
        failed = sum(not r.ok for r in results)
        rates[workers] = stats["runs_per_minute"]
        mean_run = sum(r.wall_s for r in results) / len(results)
        print(f"  {workers} worker{'s' if workers > 1 else ' '}: {n} runs in "
              f"{stats['runs_wall_s']:6.2f} s = {stats['runs_per_minute']:7.1f} runs/min "
              f"(cluster start {stats['cluster_start_s']:.2f} s, mean run {mean_run:.3f} s"
              f"{f', {failed} failed' if failed else ''})")
    print(f"  ratio 2 workers / 1 worker: {rates[2] / rates[1]:.2f}")
    same = tables[1] == tables[2]
    print(f"  tables of 1 and 2 workers identical: {'yes' if same else 'NO'}")
    return 0 if same else 1
