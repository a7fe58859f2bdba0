"""`navkit sweep`: many deterministic co-simulations of one mission over plant parameters
and seeds, on Dask (a LocalCluster on this machine, or an existing cluster's scheduler).

Python API (what `navkit tune` uses for its Monte Carlo)::

    from navkit.sweep import RunSpec, run_sweep
    results = run_sweep(Path("config/missions/demo.toml"),
                        [RunSpec(plant={"mass_kg": 14.0}, seed=s) for s in (1, 2)],
                        Path("build/sweep/mass"), workers=2)
    results[0].status, results[0].figures["x_mm"], results[0].final_pose

Modules: `plan` (--vary ranges, grid and random points), `runner` (RunSpec, RunResult,
run_sweep on Dask), `table` (figures of a run, results.csv, summary.png), `cli`
(`navkit sweep`). See docs/sweep.md.
"""

from navkit.sweep.cli import add_arguments, run
from navkit.sweep.plan import SweepError, Vary, grid, parse_vary, sample
from navkit.sweep.runner import RunResult, RunSpec, SweepInterrupted, run_one, run_sweep

__all__ = ["RunSpec", "RunResult", "SweepError", "SweepInterrupted", "run_sweep", "run_one",
           "Vary", "parse_vary", "grid", "sample", "add_arguments", "run"]
