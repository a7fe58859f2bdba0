"""Running many co-simulations on Dask: `run_sweep(mission, runs, out)`.

Each run is the same deterministic lockstep co-simulation as `navkit sim`
(navkit.sim.harness.run) without its plot, executed as one Dask task: the task catches
every error of its run and returns it as a failed RunResult, so one bad run never loses
the others. The run's log is written in the task's own process (`log_inline`) and the
harness is not pinned to a CPU: each Dask worker (one thread) is one CPU's worth of work.

By default a `distributed.LocalCluster` of one single-threaded worker process per CPU of
this machine runs the tasks; `scheduler="tcp://HOST:8786"` sends them to an existing
cluster instead, whose workers must see the same checkout and build folder at the same
paths (the mission, its world file, the build's host and FMUs).
"""

from __future__ import annotations

import contextlib
import dataclasses
import io
import json
import os
import shutil
import signal
import sys
import tempfile
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

from navkit.sweep.plan import SweepError

__all__ = ["RunSpec", "RunResult", "SweepInterrupted", "run_sweep", "run_one", "KEEP",
           "describe"]

KEEP = ("none", "failed", "all")     # which runs' output folders stay in OUT/runs/NNNN


@dataclass
class RunSpec:
    """One run of a sweep: `plant` overrides of the mission's [plant] table (parameter
    name -> value in the plant's units), the `seed` of the plant's noise and the line
    noise, and `config`, a host config folder (None: <repo>/config)."""

    plant: dict = field(default_factory=dict)
    seed: int = 1
    config: Path | None = None


@dataclass
class RunResult:
    """What one run gave: its position `index` in the sweep's runs, its `spec`, `status`
    "ok" or "failed" with `error` (the message, empty when ok), `figures` (the table's
    columns, navkit.sweep.table.FIGURES, plus an extract function's), `out` (its output
    folder when kept, else None), `warnings` (what the run wrote to stderr) and `wall_s`
    (its wall time, s: not part of the table)."""

    index: int
    spec: RunSpec
    status: str
    error: str = ""
    figures: dict = field(default_factory=dict)
    out: Path | None = None
    warnings: str = ""
    wall_s: float = 0.0

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    @property
    def final_pose(self) -> tuple | None:
        """(x_mm, y_mm, heading_deg) of the final /truth row; None for a failed run."""
        if not self.ok:
            return None
        return self.figures["x_mm"], self.figures["y_mm"], self.figures["heading_deg"]


class SweepInterrupted(KeyboardInterrupt):
    """Ctrl-C during a sweep: `results` holds the runs that finished (in run order); their
    table is written."""

    def __init__(self, results: list):
        super().__init__(f"sweep interrupted after {len(results)} runs")
        self.results = results


def describe(spec: RunSpec, index: int | None = None) -> str:
    """'run 3 (seed 2, mass_kg=10.5)': a run by its parameters, for messages."""
    params = ", ".join([f"seed {spec.seed}"] + [f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}"
                                                for k, v in spec.plant.items()])
    return (f"run {index} " if index is not None else "run ") + f"({params})"


def run_one(mission, spec: RunSpec, index: int, *, build: Path, out: Path,
            keep: str = "failed", extract=None, marker: Path | None = None,
            firmware: str = "fmu") -> RunResult:
    """Do run `index` of a sweep: Mission `mission` with `spec`'s plant overrides (they
    win over the mission's [plant] table), seed and config, build folder `build`, the
    `firmware` FMU ("fmu": SIL, "avr": PIL, as `navkit sim --firmware`). Its
    outputs go to `out`/runs/NNNN when `keep` says to keep them ("all", or "failed" and
    it failed), else to a temporary folder removed afterwards. `extract(run_dir,
    summary) -> dict` (a module-level function, so it can be sent to the workers) adds
    figures of its own while the run's outputs exist. `marker`, a file that exists while
    the run executes and names its output folder, tells whose run a worker process died
    in and where its outputs are. Never raises for a failed run."""
    if marker is not None:
        Path(marker).parent.mkdir(parents=True, exist_ok=True)
        Path(marker).touch()
    try:
        return _run_one(mission, spec, index, build, Path(out), keep, extract, firmware, marker)
    finally:
        if marker is not None:
            Path(marker).unlink(missing_ok=True)


def _run_one(mission, spec: RunSpec, index: int, build: Path, out: Path, keep: str,
             extract, firmware: str, marker: Path | None) -> RunResult:
    from navkit.sim.harness import SimError, SimOptions, run
    from navkit.sim.mission import MissionError
    from navkit.sweep.table import figures

    kept = out / "runs" / f"{index:04d}"
    if keep == "all":
        shutil.rmtree(kept, ignore_errors=True)     # a first attempt's (see _drive)
        work = kept
    else:
        work = Path(tempfile.mkdtemp(prefix=f"navkit-sweep-{index:04d}-"))
    if marker is not None:
        Path(marker).write_text(str(work))
    m = dataclasses.replace(mission, plant={**mission.plant, **spec.plant})
    err = io.StringIO()
    status, error, figs = "ok", "", {}
    t0 = time.perf_counter()
    try:
        with contextlib.redirect_stderr(err), _fd_captured(1) as native:
            summary = run(SimOptions(mission=m, out=work, seed=spec.seed, config_dir=spec.config,
                                     build=build, firmware=firmware, plot=False, pin_cpu=False,
                                     log_inline=True))
            figs = figures(summary, mission.expect)
            if extract is not None:
                figs.update(extract(work, summary))
    except (MissionError, SimError) as e:
        status, error = "failed", str(e)
    except Exception as e:  # noqa: BLE001 - any failure of one run is that run's result
        status, error = "failed", f"{type(e).__name__}: {e}"
    wall = time.perf_counter() - t0
    result = RunResult(index, spec, status, error, figs, None,
                       err.getvalue() + native.getvalue(), wall)
    if keep == "all" or (keep == "failed" and status != "ok"):
        if work != kept:
            shutil.rmtree(kept, ignore_errors=True)
            kept.parent.mkdir(parents=True, exist_ok=True)
            shutil.move(str(work), str(kept))
            result.error = result.error.replace(str(work), str(kept))   # e.g. its host.log
        result.out = kept
    else:
        shutil.rmtree(work, ignore_errors=True)
    return result


class _Captured:
    """What a file descriptor received while captured (text, after the capture)."""

    def __init__(self):
        self.text = ""

    def getvalue(self) -> str:
        return self.text


@contextlib.contextmanager
def _fd_captured(fd: int):
    """Capture what native code writes to file descriptor `fd` (1: stdout) in the block,
    e.g. simavr's "Loaded ... .text" lines of a PIL run, which would otherwise land on the
    sweep's terminal from a worker process; yields a _Captured filled at the end."""
    cap = _Captured()
    sys.stdout.flush()
    with tempfile.TemporaryFile() as tmp:
        saved = os.dup(fd)
        os.dup2(tmp.fileno(), fd)
        try:
            yield cap
        finally:
            sys.stdout.flush()
            os.dup2(saved, fd)
            os.close(saved)
            tmp.seek(0)
            cap.text = tmp.read().decode(errors="replace")


class _Progress:
    """Progress on `stream`: on a terminal one bar redrawn in place; otherwise a line
    every `every_s` s (and at the end). Failed runs get a line of their own at once."""

    def __init__(self, total: int, enabled: bool, stream=None, every_s: float = 10.0):
        self.stream = stream or sys.stderr
        self.enabled = enabled
        self.tty = enabled and hasattr(self.stream, "isatty") and self.stream.isatty()
        self.total, self.done, self.failed = total, 0, 0
        self.t0 = self.last = time.monotonic()
        self.every_s = every_s

    def _line(self) -> str:
        el = time.monotonic() - self.t0
        left = el / self.done * (self.total - self.done) if self.done else 0.0
        return (f"{self.done}/{self.total} runs, {self.failed} failed, {el:.0f} s"
                + (f", ~{left:.0f} s left" if self.done < self.total else ""))

    def update(self, r: RunResult) -> None:
        self.done += 1
        if r.status != "ok":
            self.failed += 1
        if not self.enabled:
            return
        if r.status != "ok":
            first = r.error.splitlines()[0] if r.error else "(no message)"
            self._clear()
            print(f"sweep: {describe(r.spec, r.index)} failed: {first}", file=self.stream)
        if self.tty:
            width = 30
            n = round(width * self.done / self.total) if self.total else width
            self.stream.write(f"\r[{'#' * n}{'.' * (width - n)}] {self._line()}\033[K")
            self.stream.flush()
        elif time.monotonic() - self.last >= self.every_s or self.done == self.total:
            self.last = time.monotonic()
            print(f"sweep: {self._line()}", file=self.stream, flush=True)

    def _clear(self) -> None:
        if self.tty:
            self.stream.write("\r\033[K")

    def close(self) -> None:
        if self.tty:
            self.stream.write("\n")
            self.stream.flush()


@contextlib.contextmanager
def _ctrl_c():
    """A threading.Event set by Ctrl-C (SIGINT) while in the block, in place of a
    KeyboardInterrupt: one raised inside a distributed client call can leave that call
    half done (and a traceback from its event loop). Outside the main thread, an event
    nothing sets."""
    stop = threading.Event()
    if threading.current_thread() is not threading.main_thread():
        yield stop
        return
    old = signal.signal(signal.SIGINT, lambda _sig, _frame: stop.set())
    try:
        yield stop
    finally:
        signal.signal(signal.SIGINT, old)


def default_workers() -> int:
    """The CPUs this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


@contextlib.contextmanager
def _client(scheduler: str | None, workers: int | None):
    """A distributed Client: of a new LocalCluster (`workers` single-threaded worker
    processes, default one per CPU) or connected to `scheduler`. SweepError when the
    scheduler cannot be reached."""
    import logging

    import dask
    from distributed import Client, LocalCluster

    if scheduler:
        try:
            client = Client(scheduler, timeout="10s")
        except (OSError, TimeoutError, ValueError) as e:
            raise SweepError(f"--scheduler {scheduler}: cannot connect: {e}") from None
        try:
            yield client
        finally:
            client.close()
        return
    # - The workers start with Ctrl-C ignored (a started Python keeps an ignored SIGINT
    #   ignored): on a terminal it reaches the whole process group, and the client alone
    #   stops the sweep, cancelling their tasks and closing them.
    # - A worker that dies under a run fails its runs at once (allowed-failures 0): _drive
    #   submits again those it only held, rather than Dask running a crashing run on
    #   three more workers.
    # - The scheduler runs in this process: its log line on such a death would only repeat
    #   the run's failed row. The workers log nothing below CRITICAL: what goes wrong in a
    #   run is in its row, and their shutdown races (a heartbeat to a scheduler closing)
    #   are no news.
    sched_log = logging.getLogger("distributed.scheduler")
    level = sched_log.level
    sched_log.setLevel(logging.CRITICAL)
    main = threading.current_thread() is threading.main_thread()
    try:
        old = signal.signal(signal.SIGINT, signal.SIG_IGN) if main else None
        try:
            with dask.config.set({"distributed.scheduler.allowed-failures": 0}):
                # the scheduler's HTTP server (health, metrics; the dashboard needs bokeh)
                # on a free loopback port, not 8787: that may be another cluster's
                cluster = LocalCluster(n_workers=workers or default_workers(),
                                       threads_per_worker=1, processes=True,
                                       dashboard_address="127.0.0.1:0",
                                       silence_logs=logging.CRITICAL)
        finally:
            if main:
                signal.signal(signal.SIGINT, old)
        client = Client(cluster)
        try:
            yield client
        finally:
            with contextlib.suppress(Exception):
                client.close(timeout=10)
            with contextlib.suppress(Exception):
                cluster.close(timeout=10)
    finally:
        sched_log.setLevel(level)


def _drive(client, submit, runs: list, results: list, bar: _Progress, stop,
           markers: Path | None, salvage) -> bool:
    """Run every RunSpec of `runs` through `submit(i, spec, attempt) -> Future`, appending
    each RunResult to `results` as it comes, until done or `stop` (a threading.Event) is
    set; then cancel what is in flight and return True.

    Two runs per worker thread are in flight (the count is read from the scheduler again
    every second, so workers that join are used): each worker has its next run at hand
    when one ends. With `markers` (a folder where run i's file `i` exists while it
    executes, on this machine: a LocalCluster, whose scheduler allows no retries), a
    worker process that dies takes the runs it held (KilledWorker): the one it executed
    fails (`salvage(i, folder)` keeps or removes the output folder its marker names and
    returns the kept one or None), the others are submitted again. Without, a KilledWorker
    is the cluster's verdict after its own retries: a failed run."""
    from distributed import as_completed

    todo = iter(enumerate(runs))
    index, inflight = {}, {}
    attempts = [0] * len(runs)
    pending = as_completed()
    slots, checked = 2, -1.0

    def add(i: int) -> None:
        fut = submit(i, runs[i], attempts[i])
        index[fut.key], inflight[fut.key] = i, fut
        pending.add(fut)

    def fill() -> None:
        nonlocal slots, checked
        if time.monotonic() - checked >= 1.0:
            slots = 2 * max(1, sum(client.nthreads().values()))
            checked = time.monotonic()
        while len(inflight) < slots:
            nxt = next(todo, None)
            if nxt is None:
                return
            add(nxt[0])

    fill()
    while inflight and not stop.is_set():
        if not pending.has_ready():
            time.sleep(0.002)
            continue
        for fut in pending.next_batch(block=False):
            del inflight[fut.key]
            i = index[fut.key]
            try:
                r = fut.result()
            except Exception as e:  # noqa: BLE001 - e.g. KilledWorker
                killed = type(e).__name__ == "KilledWorker"
                marker = markers / f"{i:06d}" if markers is not None else None
                if killed and marker is not None and not marker.exists():
                    attempts[i] += 1        # held, not executed, by the worker that died
                    add(i)
                    continue
                folder = None
                if marker is not None and marker.exists():
                    folder = salvage(i, Path(marker.read_text()) if marker.read_text() else None)
                    marker.unlink()
                why = ("the worker process running it died (a crash in the run? see the "
                       "worker's log" + (f" and {folder}" if folder else "") + ")"
                       if killed else str(e))
                r = RunResult(i, runs[i], "failed", f"{type(e).__name__}: {why}", out=folder)
            results.append(r)
            bar.update(r)
        fill()
    if stop.is_set():
        client.cancel(list(inflight.values()), force=True)
        return True
    return False


def _salvage(out: Path, index: int, folder: Path | None, keep: str) -> Path | None:
    """The output folder `folder` of run `index`, whose worker process died under it:
    moved to `out`/runs/NNNN (returned) unless `keep` is "none" (removed)."""
    if folder is None or not folder.exists():
        return None
    kept = out / "runs" / f"{index:04d}"
    if keep == "none":
        shutil.rmtree(folder, ignore_errors=True)
        return None
    if folder != kept:
        shutil.rmtree(kept, ignore_errors=True)
        kept.parent.mkdir(parents=True, exist_ok=True)
        shutil.move(str(folder), str(kept))
    return kept


def _check_local(build: Path, runs: list, firmware: str = "fmu") -> list:
    """The plant parameters the runs vary, in first-use order; SweepError for a key the
    built plant FMU lacks or the harness sets (naming runs[i]) and for a build without
    the host, the `firmware` FMU or the plant FMU."""
    from navkit.sim.harness import fmu_paths, host_path
    from navkit.sim.mission import RESERVED_PLANT_KEYS
    from navkit.sweep.plan import plant_parameters

    from navkit.sim.pil import FIRMWARES

    if firmware not in FIRMWARES:
        raise SweepError(f"firmware {firmware!r}: one of {', '.join(FIRMWARES)}")
    for p in (host_path(build), *fmu_paths(build, firmware)):
        if not p.exists():
            raise SweepError(f"{p} not found: build first (cmake --build {build})")
    params = plant_parameters(fmu_paths(build)[1])
    varied = []
    for i, spec in enumerate(runs):
        for k in spec.plant:
            if k in RESERVED_PLANT_KEYS:
                raise SweepError(f"runs[{i}].plant: key {k!r} is set by the harness: "
                                 f"{RESERVED_PLANT_KEYS[k]}")
            if k not in params:
                raise SweepError(f"runs[{i}].plant: key {k!r} is not a numeric parameter of "
                                 f"the plant FMU {fmu_paths(build)[1]}")
            if k not in varied:
                varied.append(k)
    return varied


def sweep(mission: Path, runs: list, out: Path, *, scheduler: str | None = None,
          workers: int | None = None, progress: bool = True, keep: str = "failed",
          extract=None, build: Path | None = None, plot: bool = True,
          meta: dict | None = None, firmware: str = "fmu") -> tuple[list, dict]:
    """run_sweep, also returning its timing: {"cluster_start_s", "runs_wall_s" (first
    submission to last result), "runs_per_minute", "workers"}."""
    from navkit.paths import build_dir
    from navkit.sim.mission import load
    from navkit.sweep.table import summary_plot, write_table

    if keep not in KEEP:
        raise SweepError(f"keep {keep!r}: one of {', '.join(KEEP)}")
    if not runs:
        raise SweepError("no runs to do")
    m = load(mission, build=build)      # MissionError names the file
    m = dataclasses.replace(m, path=m.path.resolve())     # the workers' cwd may differ
    build = Path(build or build_dir()).resolve()
    runs = [dataclasses.replace(r, config=Path(r.config).resolve() if r.config else None)
            for r in runs]
    varied = _check_local(build, runs, firmware)
    out = Path(out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    shutil.rmtree(out / "runs", ignore_errors=True)     # an earlier sweep's kept runs
    results, stats = [], {}
    bar = None
    t0 = time.perf_counter()
    interrupted = False
    try:
        with _client(scheduler, workers) as client:
            from distributed import as_completed

            stats["cluster_start_s"] = round(time.perf_counter() - t0, 3)
            stats["workers"] = len(client.nthreads())
            bar = _Progress(len(runs), progress)
            t1 = time.perf_counter()
            token = f"{os.getpid()}-{time.monotonic_ns()}"

            markers = None if scheduler else Path(tempfile.mkdtemp(prefix="navkit-sweep-"))

            def submit(i, spec, attempt):
                return client.submit(run_one, m, spec, i, build=build, out=out, keep=keep,
                                     extract=extract, pure=False, retries=0,
                                     marker=markers / f"{i:06d}" if markers else None,
                                     firmware=firmware,
                                     key=f"navkit-run-{token}-{i:06d}-{attempt}")

            try:
                with _ctrl_c() as stop:
                    interrupted = _drive(client, submit, runs, results, bar, stop, markers,
                                         lambda i, folder: _salvage(out, i, folder, keep))
            finally:
                if markers is not None:
                    shutil.rmtree(markers, ignore_errors=True)
            stats["runs_wall_s"] = round(time.perf_counter() - t1, 3)
    except KeyboardInterrupt:
        interrupted = True
    finally:
        if bar is not None:
            bar.close()
    results.sort(key=lambda r: r.index)
    wall = stats.get("runs_wall_s")
    stats["runs_per_minute"] = round(len(results) / wall * 60, 1) if wall else None
    write_table(results, varied, out, m.expect)
    if plot and results:
        summary_plot(results, varied, out / "summary.png", m.expect,
                     f"{m.path.name}: {len(results)} runs, "
                     f"{sum(not r.ok for r in results)} failed")
    doc = {"mission": str(m.path), "build": str(build), "runs": len(runs),
           "finished": len(results), "failed": sum(not r.ok for r in results),
           "interrupted": interrupted, "varied": varied, "expect": m.expect,
           "scheduler": scheduler or "LocalCluster", "firmware": firmware, **stats, **(meta or {}),
           "run_wall_s": {r.index: round(r.wall_s, 3) for r in results}}
    (out / "sweep.json").write_text(json.dumps(doc, indent=2, default=str) + "\n")
    if interrupted:
        raise SweepInterrupted(results)
    return results, stats


def run_sweep(mission: Path, runs: list, out: Path, *, scheduler: str | None = None,
              workers: int | None = None, progress: bool = True, keep: str = "failed",
              extract=None, build: Path | None = None, plot: bool = True,
              firmware: str = "fmu") -> list:
    """Run mission file `mission` once per RunSpec of `runs` on Dask; return their
    RunResults in the order of `runs` (deterministic per spec: the same figures whatever
    the workers and the order runs finish in). Writes `out`/results.csv (+ .parquet with
    pyarrow), summary.png (unless `plot` is False), sweep.json (timing, not
    deterministic) and the kept runs' folders `out`/runs/NNNN (`keep`: none, failed,
    all). `firmware` "fmu" runs the SIL firmware FMU, "avr" the AVR image in simavr (PIL).
    `scheduler` "tcp://HOST:PORT" uses an existing cluster, else a LocalCluster of
    `workers` processes (default: one per CPU). `progress` shows a bar on a terminal
    (lines otherwise) on stderr. Raises SweepError (bad runs, no build, no scheduler),
    MissionError (the mission file), SweepInterrupted on Ctrl-C (after writing the table
    of the runs that finished). An earlier sweep's `out`/runs is removed first. Workers
    run one thread each (a run redirects sys.stderr while it runs)."""
    return sweep(mission, runs, out, scheduler=scheduler, workers=workers, progress=progress,
                 keep=keep, extract=extract, build=build, plot=plot, firmware=firmware)[0]
