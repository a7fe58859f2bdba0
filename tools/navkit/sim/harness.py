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

from navkit.plot import plot_mcap
from navkit.sim.faults import Faults
from navkit.sim.lockstep import run_lockstep
from navkit.sim.options import (STEP_S, STOP_SIGNALS, SimError, SimInterrupted, SimOptions, check_frame,
                                fmu_paths, frame_period, git_revision, host_config, host_path, stop_signal)
from navkit.sim.realtime import run_realtime
from navkit.sim.rig import SimRig
from navkit.sim.stops import DeferredStops
from navkit.sim.summary import summary as run_summary

__all__ = ["SimOptions", "SimError", "SimInterrupted", "run", "host_path", "fmu_paths", "host_config",
           "frame_period", "check_frame", "git_revision", "STEP_S"]


def run(opts: SimOptions, stamps: dict | None = None, git=None) -> dict:
    """Do one run; write run.mcap, summary.json (and plot.png) into opts.out; return the
    summary. Raises MissionError for a mission that does not fit the FMUs, SimError if a
    part is missing or fails or the plant FMU does not fit the coupler (navkit.sim.plant).
    `stamps`, when given, gets the time.monotonic() (s) at which each phase ended: "run"
    (entered), "started" (set-up), "loop", "stopped" (host, log worker, FMUs closed),
    "summary" (summary.json written) and "plot" (plot.png written). plot.png is drawn
    by the log worker (navkit.plot.plot_mcap: Pillow, no matplotlib) from the messages
    it kept as it wrote run.mcap, once that is closed, while the run's other parts end
    and summary.json is written (_plot). `git`: the run's git_revision_started() when
    the caller started it earlier, else None."""
    def stamp(key: str) -> None:
        if stamps is not None:
            stamps[key] = time.monotonic()

    stamp("run")
    # module imports are not part of a run's wall time (mcap's: the log worker's own, beside
    # the set-up)
    import fmpy.fmi3  # noqa: F401

    rig = SimRig(opts, git=git)
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
        interrupted = stop_signal(e)
    except BaseException:
        rig.stop()
        raise
    mcap_path, png = Path(opts.out) / "run.mcap", Path(opts.out) / "plot.png"
    log = rig.log       # rig.stop drops it; its worker's plot.png is waited for after
    if opts.plot and log is not None:
        log.draw_plot()
    if interrupted is not None:
        # a clean stop, then what there is: a second stop signal is ignored until the outputs
        # are closed
        held = {s: signal.signal(s, signal.SIG_IGN) for s in STOP_SIGNALS}
        try:
            rig.stop()
            summary = run_summary(rig, faults, time.perf_counter() - wall0)
            summary["interrupted"] = {"signal": signal.Signals(interrupted).name,
                                      "at_s": round(rig.t_ns / 1e9, 6)}
            if Path(opts.out).is_dir():
                (Path(opts.out) / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
            if opts.plot and mcap_path.exists():
                try:
                    _plot(log, mcap_path, png, rig.results)
                except ValueError as e:     # stopped before its first /truth: nothing to draw
                    print(f"warning: {png}: not drawn: {e}", file=sys.stderr)
        finally:
            if log is not None:
                log.plot_done()
            for s, h in held.items():
                signal.signal(s, h)
        raise SimInterrupted(summary, interrupted)
    # the run is over: a stop signal now waits until the outputs are closed, then acts as
    # its handler says (navkit sim's raises KeyboardInterrupt), never cutting them short
    with DeferredStops():
        try:
            rig.stop()
            stamp("stopped")
            wall = time.perf_counter() - wall0
            summary = run_summary(rig, faults, wall)
            (Path(opts.out) / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
            stamp("summary")
            for ref in summary["planner"]["refused"]:
                verdict = ref["nav_result"].replace("_", " ")
                print(f"warning: {ref['where']} (t = {ref['t']:g} s): {verdict} by the host: "
                      f"{ref['reason']} (lisp_data.nav_result = {ref['nav_result']})", file=sys.stderr)
            if opts.plot:
                _plot(log, mcap_path, png, rig.results)
                stamp("plot")
        finally:
            if log is not None:
                log.plot_done()
    return summary


def _plot(log, mcap_path: Path, png: Path, results: dict) -> None:
    """plot.png `png` of run `mcap_path`: drawn by the log worker of `log` (RunLog, asked
    by draw_plot) and waited for here, the exception its drawing raised raised here; or
    drawn here (navkit.plot.plot_mcap) when the worker did not: an inline log (from the
    series in `results`), a worker that died (read back from the file)."""
    drawn, err = log.plot_done() if log is not None else (False, None)
    if err is not None:
        raise err
    if not drawn:
        plot_mcap(mcap_path, png, results.get("plot"))
