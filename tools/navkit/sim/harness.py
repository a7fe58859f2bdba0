"""One co-simulation run: the firmware FMU and the plant FMU stepped together by the native
coupler, the real `navkit-host` on a pseudo-terminal, the mission's planner on rcomm.

`run(opts)` sets up the run's parts (navkit.sim.rig), drives them in lockstep
(navkit.sim.lockstep, the default) or paced to the wall clock (navkit.sim.realtime)
while the mission's events and faults act (navkit.sim.faults), stops them, and writes
summary.json (navkit.sim.summary) and plot.png. A lockstep run is a pure function of
(mission, config, seed).

The names a caller needs live here: SimOptions, SimError, SimInterrupted and the build
and configuration helpers of navkit.sim.options.
"""

from __future__ import annotations

import json
import signal
import sys
import time
from pathlib import Path

from navkit.sim.faults import Faults
from navkit.sim.lockstep import run_lockstep
from navkit.sim.options import (STEP_S, SimError, SimInterrupted, SimOptions, check_frame, fmu_paths,
                                frame_period, git_revision, host_config, host_path)
from navkit.sim.realtime import run_realtime
from navkit.sim.rig import SimRig
from navkit.sim.summary import summary as run_summary

__all__ = ["SimOptions", "SimError", "SimInterrupted", "run", "host_path", "fmu_paths", "host_config",
           "frame_period", "check_frame", "git_revision", "STEP_S"]


def run(opts: SimOptions, stamps: dict | None = None, plotter=None, git=None) -> dict:
    """Do one run; write run.mcap, summary.json (and plot.png) into opts.out; return the
    summary. Raises MissionError for a mission that does not fit the FMUs, SimError if a
    part is missing or fails or the plant FMU does not fit the coupler (navkit.sim.plant).
    `stamps`, when given, gets the time.monotonic() (s) at which each phase ended: "run"
    (entered), "started" (set-up), "loop", "stopped" (host, log worker, FMUs closed),
    "summary" (summary.json written) and "plot" (plot.png written); and "plot_ready" when
    the plot process was ready to draw (imported and warmed up) before its job came. plot.png is drawn by
    `plotter`, a navkit.plot.PlotProcess the caller made earlier and closes (navkit sim
    makes it first thing), else by one made and closed here: its matplotlib import and
    warm-up run beside the set-up and the loop (navkit.sim.rig: on the log worker's CPU).
    `git`: the run's git_revision_started() when the caller started it earlier, else None."""
    def stamp(key: str, at: float | None = None) -> None:
        if stamps is not None:
            stamps[key] = time.monotonic() if at is None else at

    stamp("run")
    if plotter is not None or not opts.plot:
        return _run(opts, plotter if opts.plot else None, stamp, git)
    from navkit.plot import PlotProcess

    plotter = PlotProcess()
    try:
        return _run(opts, plotter, stamp, git)
    finally:
        plotter.close()


def _run(opts: SimOptions, plotter, stamp, git=None) -> dict:
    """run(opts) with plot.png drawn by `plotter` (a navkit.plot.PlotProcess, or None for
    no plot), each phase's end passed to `stamp` and the git revision from `git` (None:
    started here)."""
    # module imports are not part of a run's wall time (mcap's: the log worker's own, beside
    # the set-up)
    import fmpy.fmi3  # noqa: F401

    rig = SimRig(opts, plotter, git)
    faults = Faults(rig)
    wall0 = time.perf_counter()
    from navkit.sim.coupler import CouplerError
    from navkit.sim.links import LinkError

    interrupted = None
    try:
        rig.start()
        stamp("started")
        if opts.realtime:
            run_realtime(rig, faults)
        else:
            run_lockstep(rig, faults)
        stamp("loop")
    except (LinkError, CouplerError) as e:
        rig.stop()
        raise SimError(f"{e} (host log: {rig.out / 'host.log'})") from e
    except KeyboardInterrupt as e:
        interrupted = e.args[0] if e.args and isinstance(e.args[0], int) else int(signal.SIGINT)
    except BaseException:
        rig.stop()
        raise
    mcap_path, png = Path(opts.out) / "run.mcap", Path(opts.out) / "plot.png"
    if interrupted is not None:
        # a clean stop, then what there is: a second Ctrl-C waits until the outputs are closed
        held = {s: signal.signal(s, signal.SIG_IGN) for s in (signal.SIGINT, signal.SIGTERM)}
        try:
            rig.stop()
            summary = run_summary(rig, faults, time.perf_counter() - wall0)
            summary["interrupted"] = {"signal": signal.Signals(interrupted).name,
                                      "at_s": round(rig.t_ns / 1e9, 6)}
            if Path(opts.out).is_dir():
                (Path(opts.out) / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
            if plotter is not None and mcap_path.exists():
                plotter.plot_mcap(mcap_path, png, rig.results.get("plot"))
        finally:
            for s, h in held.items():
                signal.signal(s, h)
        raise SimInterrupted(summary, interrupted)
    # plot.png from the messages the log worker kept while writing run.mcap (read back from
    # the file only if the worker gave no results: it died), drawn while the coupler and
    # the FMUs end and summary.json is written
    plotting = []

    def plot(results: dict) -> None:
        plotter.start(mcap_path, png, results.get("plot"))
        plotting.append(True)
    rig.stop(None if plotter is None else plot)
    if plotter is not None and not plotting:
        plot(rig.results)
    stamp("stopped")
    wall = time.perf_counter() - wall0
    summary = run_summary(rig, faults, wall)
    (Path(opts.out) / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    stamp("summary")
    for ref in summary["planner"]["refused"]:
        verdict = ref["nav_result"].replace("_", " ")
        print(f"warning: {ref['where']} (t = {ref['t']:g} s): {verdict} by the host: "
              f"{ref['reason']} (lisp_data.nav_result = {ref['nav_result']})", file=sys.stderr)
    if plotter is not None:
        ready = plotter.wait()
        stamp("plot")
        if ready is not None:
            stamp("plot_ready", ready)
    return summary
