"""`navkit plot FILE`: plot a co-simulation run (run.mcap) or a seed-format datalog.

A run plot has the path (truth x/y in mm, and the micro's odometry), the forward speed
(mm/s) and the heading (deg, clockwise 0..360) against simulated time (s), with every
planner command marked. The file is streamed and each line thinned to about
PLOT_POINTS evenly spaced messages (a few per pixel of the figure), so any size of run.mcap
plots in bounded memory and time proportional to its size. `navkit sim` draws the same
figure from the same thinned messages, which its log worker keeps as it writes them
(RunSeries), without reading run.mcap back. A datalog ("Data MM-DD-YY HH;MM;SS.txt", the
seed's Dataplot input: the number of parameters, then one line per parameter with its
name and default plot range, then one row per host frame) gets one panel per parameter
over its range.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

__all__ = ["add_arguments", "run", "plot_mcap", "mcap_figure", "run_figure", "RunSeries",
           "PlotProcess", "decoded", "plot_datalog", "read_datalog", "read_mcap", "PLOT_POINTS"]

# Messages a line of a run plot keeps at most, evenly spaced (the figure is ~1000 pixels
# wide): between PLOT_POINTS and 2 * PLOT_POINTS of a topic with more messages than that.
PLOT_POINTS = 2000


def add_arguments(parser) -> None:
    """Arguments of `navkit plot`."""
    parser.add_argument("file", type=Path, help="run.mcap of `navkit sim`, or a datalog .txt")
    parser.add_argument("--out", "-o", type=Path, default=None,
                        help="image to write, its format by its suffix: .png (default: FILE with "
                        ".png), or another matplotlib writes (.svg, .pdf, ...)")


def run(args) -> int:
    """Plot args.file into args.out; 0 on success, 1 with a message on error."""
    path: Path = args.file
    out = args.out or path.with_suffix(".png")
    from mcap.exceptions import McapError

    try:
        if path.suffix == ".mcap":
            plot_mcap(path, out)
        else:
            plot_datalog(path, out)
    except (OSError, ValueError, McapError) as e:
        text = str(e)
        print(f"navkit plot: {text if text.startswith((str(path), str(out))) else f'{path}: {text}'}",
              file=sys.stderr)
        return 1
    print(out)
    return 0


def read_mcap(path: Path, topics=None) -> dict:
    """Messages of a run: {topic: [(log_time_ns, decoded JSON), ...]} for `topics` (all
    if None). A killed run's file (no footer) is read up to its last whole chunk, with a
    warning on stderr (navkit.sim.results.read_mcap); McapError if it is not MCAP."""
    from navkit.sim.results import read_mcap as read

    out: dict = {}
    for t_ns, topic, data in read(path, topics).messages:
        out.setdefault(topic, []).append((t_ns, json.loads(data)))
    return out


class _Thinned:
    """Every `stride`-th message of a stream, the stride doubling (and every other kept
    message dropped) whenever more than 2 * `cap` are kept: at most 2 * `cap` in memory,
    evenly spaced, without knowing the count ahead. Messages are kept as their JSON bytes
    (decoded once, when drawn)."""

    __slots__ = ("cap", "stride", "n", "kept")

    def __init__(self, cap: int):
        self.cap, self.stride, self.n, self.kept = cap, 1, 0, []

    def offer(self, t_ns: int, data: bytes) -> None:
        if self.n % self.stride == 0:
            self.kept.append((t_ns, data))
            if len(self.kept) > 2 * self.cap:
                del self.kept[1::2]
                self.stride *= 2
        self.n += 1


# The topics a run plot draws: the first two thinned to about PLOT_POINTS messages each,
# the others whole (a mission's commands and events, few).
RUN_THINNED = ("/truth", "/micro/data")
RUN_WHOLE = ("/planner/cmd", "/events")


class RunSeries:
    """The messages a run plot draws, gathered while a run's messages stream by in file
    order: from run.mcap (navkit plot) or from the log worker as it writes them
    (navkit.sim.record.Recorder's tap), so the two give the same figure. `sink(topic)` is
    the function (t_ns, JSON bytes) -> None to call with each message of `topic` (None for
    a topic the plot does not draw); `raw()` what was kept, {topic: [(log time ns, JSON
    bytes), ...]} (picklable: the worker hands it over at close)."""

    def __init__(self, cap: int = PLOT_POINTS, thin: tuple = RUN_THINNED, whole: tuple = RUN_WHOLE):
        self._thin = {t: _Thinned(cap) for t in thin}
        self._whole = {t: [] for t in whole}
        self.topics = tuple(thin) + tuple(whole)

    def sink(self, topic: str):
        if topic in self._thin:
            return self._thin[topic].offer
        if topic in self._whole:
            append = self._whole[topic].append
            return lambda t_ns, data: append((t_ns, data))
        return None

    def raw(self) -> dict:
        out = {t: list(msgs) for t, msgs in self._whole.items()}
        out.update({t: list(th.kept) for t, th in self._thin.items()})
        return out


def decoded(raw: dict) -> dict:
    """RunSeries.raw() decoded: {topic: [(log_time_ns, decoded JSON), ...]}, each list in
    log-time order (file order among equal times). A topic's messages are parsed as one
    JSON array (one call instead of one a message); a message that is not one JSON value
    is then parsed alone, which names its error."""
    out = {}
    for topic, msgs in raw.items():
        try:
            objs = json.loads(b"[" + b",".join(data for _, data in msgs) + b"]")
        except ValueError:
            objs = []
        if len(objs) != len(msgs):
            objs = [json.loads(data) for _, data in msgs]
        out[topic] = sorted(zip((t_ns for t_ns, _ in msgs), objs), key=lambda m: m[0])
    return out


def _read_thinned(path: Path, thin: tuple = RUN_THINNED, whole: tuple = RUN_WHOLE,
                  cap: int = PLOT_POINTS) -> dict:
    """{topic: [(log_time_ns, decoded JSON), ...]} of run `path`, streamed
    (navkit.sim.results.iter_mcap) through a RunSeries: the topics in `thin` thinned to
    about `cap` messages each, those in `whole` every message; each list in log-time order."""
    from navkit.sim.results import iter_mcap

    series = RunSeries(cap, thin, whole)
    sinks = {t: series.sink(t) for t in series.topics}
    for t_ns, topic, data in iter_mcap(path, series.topics):
        sinks[topic](t_ns, data)
    return decoded(series.raw())


def _figure(rows: int, height: float):
    """A Figure of `rows` panels, 9 in wide and `height` in high, drawn by Agg (no
    pyplot: its import and figure manager are not needed to write a PNG)."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    fig = Figure(figsize=(9, height))
    return fig, fig.subplots(rows, 1)


def _command_label(cmd: dict) -> str:
    parts = []
    if cmd.get("fwd_cmd"):
        parts.append(f"fwd {cmd['fwd_cmd']} v{cmd.get('speed', 0)} d{cmd.get('distance', 0)}")
    if cmd.get("turn_mode"):
        parts.append(f"turn {cmd['turn_mode']} {cmd.get('turn_distance', 0) / 10:g}deg")
    if cmd.get("rc_param0"):
        parts.append(f"servo {cmd.get('rc_servo_num', 0)}")
    if cmd.get("dio_active"):
        parts.append(f"dio {cmd['dio_active']:#x}={cmd.get('dio_command', 0):#x}")
    return ", ".join(parts) or "none"


def _wrapped(t, h):
    """Break a 0..360 heading line where it wraps (NaN between the two sides)."""
    ts, hs = [], []
    for i, (a, b) in enumerate(zip(t, h)):
        if i and abs(b - hs[-1]) > 180:
            ts.append(a)
            hs.append(float("nan"))
        ts.append(a)
        hs.append(b)
    return ts, hs


def plot_mcap(path: Path, out: Path, series: dict | None = None) -> None:
    """Plot run `path` (run.mcap) into image `out` (its format by _format: PNG drawn by
    _draw_run, others by matplotlib's savefig), from `series` (RunSeries.raw() of the run's
    messages, as the log worker hands it over) when given, else streamed from the file:
    the same figure either way."""
    fmt = _format(out)
    msgs = decoded(series) if series is not None else _read_thinned(Path(path))
    fig = run_figure(msgs, _run_title(Path(path)))
    if fmt == "png":
        _write_png(_draw_run(fig), out)
    else:
        fig.savefig(out, dpi=_DPI, format=fmt)


def _format(out) -> str:
    """The image format of output `out` by its suffix: "png" for .png, no suffix or a binary
    file; else a format matplotlib writes (svg, pdf, ...). ValueError naming `out` and
    the formats there are for any other suffix (never a file whose bytes are not its name's
    format)."""
    suffix = Path(out).suffix.lower() if isinstance(out, (str, Path)) else ""
    if suffix in ("", ".png"):
        return "png"
    from matplotlib.backend_bases import FigureCanvasBase

    formats = FigureCanvasBase.get_supported_filetypes()
    if suffix[1:] not in formats:
        raise ValueError(f"{out}: cannot write a {suffix} image (the output's suffix names its "
                         f"format: {', '.join(f'.{f}' for f in sorted(formats))})")
    return suffix[1:]


# Resolution of a run plot (dots per inch): its 9 x 11 in are 990 x 1210 pixels.
_DPI = 110

# The panel (index in Figure.axes) a helper process draws beside the others: the speed
# panel, with most of the command labels, about half of the drawing's work.
_HELPER_PANELS = (1,)


def _pixels(fig, panels=None, dpi: float = _DPI):
    """`fig` drawn by Agg at `dpi`, only the axes whose indices are in `panels` (None: all):
    its RGBA pixels, a (height, width, 4) uint8 array, top row first (a view of the
    canvas's buffer)."""
    import numpy as np
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    if panels is not None:
        for i, ax in enumerate(fig.axes):
            ax.set_visible(i in panels)
    fig.set_dpi(dpi)
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    return np.asarray(canvas.buffer_rgba())


def _inked_rows(rgba):
    """The rows of RGBA pixels `rgba` holding anything but opaque white: bool per row."""
    return (rgba != 255).any(axis=(1, 2))


def _draw_run(fig):
    """The pixels of run plot `fig` (_pixels): the panels of _HELPER_PANELS drawn by a
    process forked here, the others by this one, at the same time. Each side starts from
    the white figure and draws only its own panels. Where no row holds ink of both sides,
    the helper's inked rows laid over this side's picture are the whole figure drawn at
    once, pixel for pixel: every pixel was painted by one side only (a panel paints white
    only inside its own frame, whose rows its spines ink). Where rows of both meet (labels
    longer than their panel is high), without fork(), on one CPU or when the helper fails,
    this process draws the whole figure."""
    import mmap
    import os

    import numpy as np

    h, w = round(fig.get_figheight() * _DPI), round(fig.get_figwidth() * _DPI)
    try:
        cpus = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        cpus = os.cpu_count() or 1
    if cpus < 2 or not hasattr(os, "fork"):
        return _pixels(fig)
    shared = mmap.mmap(-1, h + h * w * 4)    # the helper's inked rows (bool each), its pixels
    ready_r, ready_w = os.pipe()
    try:
        pid = os.fork()
    except OSError:                             # no process to spare
        os.close(ready_r)
        os.close(ready_w)
        return _pixels(fig)
    if pid == 0:        # the helper: draw, hand over, exit at once (no interpreter teardown)
        try:
            os.close(ready_r)
            side = _pixels(fig, _HELPER_PANELS)
            if side.shape == (h, w, 4):
                shared[:h] = _inked_rows(side).tobytes()
                shared[h:] = side.tobytes()
                os.write(ready_w, b"1")
        finally:
            os._exit(0)
    os.close(ready_w)
    try:
        main = _pixels(fig, [i for i in range(len(fig.axes)) if i not in _HELPER_PANELS])
        if os.read(ready_r, 1) == b"1" and main.shape == (h, w, 4):
            rows = np.frombuffer(shared, dtype=bool, count=h)
            if not (rows & _inked_rows(main)).any():
                out = main.copy()
                out[rows] = np.frombuffer(shared, dtype=np.uint8, offset=h).reshape(h, w, 4)[rows]
                return out
    finally:
        os.close(ready_r)
        os.waitpid(pid, 0)
    return _pixels(fig, range(len(fig.axes)))


def _write_png(rgba, out) -> None:
    """Write RGBA pixels `rgba` (a (height, width, 4) uint8 array, top row first) as PNG
    into `out`, a path or a binary file, marked _DPI dots per inch. Each row but the first
    is stored as its difference from the row above (PNG filter "Up": a plot's rows are
    mostly alike, so the differences are mostly zeros, which pack small even at zlib's
    fastest level), all at zlib level 1."""
    import struct
    import zlib

    import numpy as np

    h, w = rgba.shape[0], rgba.shape[1]
    rows = rgba.reshape(h, w * 4)
    data = np.empty((h, 1 + w * 4), dtype=np.uint8)
    data[:, 0] = 2                      # filter type of each row: Up
    data[0, 0] = 0                      # the first has no row above: None
    data[0, 1:] = rows[0]
    np.subtract(rows[1:], rows[:-1], out=data[1:, 1:])     # modulo 256, as PNG wants

    def chunk(kind: bytes, body: bytes) -> bytes:
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))

    per_m = round(_DPI / 0.0254)        # pixels per metre, pHYs's unit
    png = b"".join((b"\x89PNG\r\n\x1a\n",
                    chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 6, 0, 0, 0)),  # 8-bit RGBA
                    chunk(b"pHYs", struct.pack(">IIB", per_m, per_m, 1)),
                    chunk(b"IDAT", zlib.compress(data.tobytes(), 1)),
                    chunk(b"IEND", b"")))
    if hasattr(out, "write"):
        out.write(png)
    else:
        with open(out, "wb") as f:
            f.write(png)


# What the plot process imports before its first job: the Figure and Agg (no pyplot)
_IMPORTS = ("numpy", "zlib", "matplotlib", "matplotlib.figure", "matplotlib.collections",
            "matplotlib.backends.backend_agg")


def _warm_up() -> None:
    """Draw a throwaway 1-in figure into memory with the kinds of artist a run plot has
    (line, upright label, line collection, legend) and encode it as PNG: the lazy imports,
    the font and the encoder a first draw sets up are then ready for the real one, whose
    own cost is its artists'."""
    import io

    from matplotlib.collections import LineCollection
    from matplotlib.figure import Figure

    fig = Figure(figsize=(1, 1))
    ax = fig.subplots()
    ax.plot([0, 1], [0, 1], label="a")
    ax.annotate("a", (0.5, 0.5), rotation=90, fontsize=_LABEL_PT)
    ax.add_collection(LineCollection([((0, 0), (1, 1))]))
    _legend(ax)
    _write_png(_pixels(fig, dpi=20), io.BytesIO())


class PlotProcess:
    """A child process that imports matplotlib and draws a throwaway figure (_warm_up) at
    once, while its parent goes on (a run's set-up and loop), then draws the run plots
    the parent hands it (plot_mcap): the import and the first draw's set-up leave the
    parent's path. Forked: make it before the parent starts threads. The child runs at
    idle priority until it has a plot to draw, so its work takes only CPU time nothing
    else wants. keep_busy() pins it to given CPUs, where, once warm, it polls for its job
    instead of sleeping: a CPU it keeps from idling wakes a normal-priority process (the
    run's log worker) at once, which an idle virtual CPU does only slowly. It ends when
    close() is called or when the parent goes away (EOF on its pipe), however the parent
    ends; a terminal's signals to the process group are the parent's to act on."""

    def __init__(self):
        import multiprocessing as mp
        import os

        ctx = mp.get_context("fork")
        self._conn, child = ctx.Pipe()
        self._poll = ctx.Value("b", 0, lock=False)
        self._ready = ctx.Value("b", 0, lock=False)     # set by the child once warm
        self._wanted = ctx.Value("b", 0, lock=False)    # set by start(): no warm-up then
        self._job = None                                # a job start() left to wait()
        self._proc = ctx.Process(target=_plot_process, args=(child, self._conn, self._poll,
                                                             self._ready, self._wanted),
                                 name="navkit-plot", daemon=True)
        self._cpus = os.sched_getaffinity(0) if hasattr(os, "sched_getaffinity") else None
        self._proc.start()
        child.close()
        self._used = False
        # set here, not in the child: start()'s change back to normal priority then comes after
        self._priority(os.SCHED_IDLE if hasattr(os, "SCHED_IDLE") else None)

    def _priority(self, policy) -> None:
        """Put the child under scheduling `policy` (os.SCHED_IDLE or os.SCHED_OTHER; None:
        leave it), where the system allows it."""
        import os

        try:
            if policy is not None:
                os.sched_setscheduler(self._proc.pid, policy, os.sched_param(0))
        except (AttributeError, OSError):
            pass

    def keep_busy(self, cpus: set, poll: bool = True) -> bool:
        """Pin the child to `cpus` (CPU numbers) at idle priority and, with `poll`, let it
        poll for its job once warm; False if it could not be pinned (then it sleeps until
        its job wherever it runs)."""
        import os

        try:
            os.sched_setaffinity(self._proc.pid, cpus)
        except (AttributeError, OSError):
            return False
        self._poll.value = 1 if poll else 0
        return True

    def plot_mcap(self, path: Path, out: Path, series: dict | None = None) -> None:
        """plot_mcap(path, out, series) in the child: start() then wait()."""
        self.start(path, out, series)
        self.wait()

    def start(self, path: Path, out: Path, series: dict | None = None) -> None:
        """Hand the child plot_mcap(path, out, series) to do, at normal priority on the CPUs
        it was made with, and return at once (raising nothing); wait() waits for it. A
        child still importing takes the job in wait() (its pipe would block this call)."""
        import os

        self._used = True
        self._wanted.value = 1
        self._poll.value = 0
        # the parent waits for this plot: the child's import, if unfinished, too
        self._priority(getattr(os, "SCHED_OTHER", None))
        try:
            if self._cpus:
                os.sched_setaffinity(self._proc.pid, self._cpus)
        except OSError:
            pass
        self._out = Path(out)
        self._job = (Path(path), Path(out), series)
        if self._ready.value:
            self._send_job()

    def _send_job(self) -> None:
        """Send the job start() was given, if not sent yet."""
        job, self._job = self._job, None
        if job is not None:
            try:
                self._conn.send(job)
            except OSError:     # the child is gone: wait() says so
                pass

    def wait(self) -> float | None:
        """Wait for the plot start() handed over; its error (OSError, ValueError,
        McapError) is raised here. Returns the time.monotonic() (s) at which the child was
        ready to draw (imported and warmed up) before a job came, None if a job came first."""
        self._send_job()
        try:
            err, ready = self._conn.recv()
        except (EOFError, OSError):
            raise OSError(f"{self._out}: the plot process ended before it drew the plot") from None
        if err is not None:
            raise err
        return ready

    def close(self) -> None:
        """End the child and wait for it: once it has drawn what it was given; at once
        (SIGKILL, it holds no file) if it was given nothing, as after a failed run."""
        if self._conn is None:
            return
        if not self._used:
            self._proc.kill()
        try:
            self._conn.send(None)
        except OSError:
            pass
        self._conn.close()
        self._conn = None
        self._proc.join(5)
        if self._proc.exitcode is None:
            self._proc.kill()
            self._proc.join()


def _plot_process(conn, parent_end, poll, ready_flag, wanted) -> None:
    """PlotProcess's child (its parent sets its priority): import matplotlib (_IMPORTS) and
    _warm_up, then wait for each job (path, out, series), polling while `poll` is set, draw
    it and answer (None or the error, the time.monotonic() at which it was warm before any
    job, or None), until None or EOF, then exit at once (os._exit). It sets `ready_flag`
    once warm; it skips the warm-up when `wanted` is set (a job is on its way: it warms up
    the drawing itself).
    `parent_end`, the parent's end of the pipe that fork() copied here, is closed first,
    so a parent that dies is seen as EOF."""
    import importlib
    import os
    import signal
    import time

    parent_end.close()
    for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP, signal.SIGQUIT):
        signal.signal(sig, signal.SIG_IGN)
    for name in _IMPORTS:
        importlib.import_module(name)
        if name == "matplotlib":
            importlib.import_module(name).use("Agg")
    ready = None
    if not wanted.value and not conn.poll(0):
        _warm_up()
        ready = time.monotonic()
    ready_flag.value = 1
    while True:
        while poll.value and not conn.poll(0):  # a job, or EOF: the parent is gone
            pass
        try:
            job = conn.recv()
        except (EOFError, OSError):
            job = None
        if job is None:     # no interpreter teardown: its files are closed, and the parent
            os._exit(0)     # waits for this exit (PlotProcess.close)
        try:
            plot_mcap(*job)
            err = None
        except Exception as e:  # noqa: BLE001 - handed to the parent, which raises it
            err = e
        try:
            conn.send((err, ready))
        except (OSError, EOFError):         # the parent is gone
            return
        except Exception:  # noqa: BLE001 - an error that does not pickle: its text
            conn.send((ValueError(f"{job[1]}: {err}"), ready))


def _run_title(path: Path) -> str:
    return f"{path.parent.name}/{path.name}: path"


def mcap_figure(path: Path):
    """The plot of run `path` (run.mcap) as a matplotlib Figure (run_figure)."""
    return run_figure(_read_thinned(Path(path)), _run_title(Path(path)))


def _legend(ax) -> None:
    """The panel's legend above its top right corner, outside the data (a fixed place: no
    search for the emptiest corner, which costs a pass over every point)."""
    ax.legend(loc="lower right", bbox_to_anchor=(1.0, 1.0), ncols=2, fontsize="small",
              frameon=False, borderaxespad=0.2)


def run_figure(msgs: dict, title: str):
    """The plot of a run's messages `msgs` ({topic: [(log_time_ns, decoded JSON), ...]},
    _read_thinned or decoded(RunSeries.raw())) as a matplotlib Figure (close it with
    matplotlib.pyplot.close if pyplot is in use): three panels, the path (truth y_mm
    across, x_mm up, mm) titled `title`, the speed (mm/s) and the heading (deg, clockwise
    0..360) against simulated time (s); on the speed and heading panels one vertical line
    per /planner/cmd message (gid "command") and per /events message (gid "event") at its
    log time, in one LineCollection per gid and panel. Fixed margins for its 9 x 11 in (no
    tight_layout pass)."""
    truth = [m for _, m in msgs.get("/truth", [])]
    if not truth:
        raise ValueError("no /truth messages")
    cmds = msgs.get("/planner/cmd", [])
    events = msgs.get("/events", [])
    micro = msgs.get("/micro/data", [])
    t = [m["t"] for m in truth]
    fig, (ax_xy, ax_v, ax_h) = _figure(3, 11)
    fig.subplots_adjust(left=0.1, right=0.97, bottom=0.05, top=0.96, hspace=0.22)
    ax_xy.plot([m["y_mm"] for m in truth], [m["x_mm"] for m in truth], label="truth")
    if micro:
        # the micro's odometry uses the truth's axes (x forward, y left)
        ax_xy.plot([m["y"] for _, m in micro], [m["x"] for _, m in micro], "--", lw=0.8,
                   label="micro odometry")
    ax_xy.set_xlabel("y (left), mm")
    ax_xy.set_ylabel("x (forward), mm")
    ax_xy.invert_xaxis()
    ax_xy.set_aspect("equal", adjustable="datalim")
    ax_xy.set_title(title, loc="left")
    _legend(ax_xy)
    ax_v.plot(t, [m["v_mm_s"] for m in truth], label="truth v")
    if micro:
        ax_v.plot([ns / 1e9 for ns, _ in micro], [m["fwd_speed"] for _, m in micro], lw=0.8,
                  label="micro fwd_speed")
    ax_v.set_ylabel("speed, mm/s")
    _legend(ax_v)
    ax_h.plot(t, [m["heading_deg"] % 360 for m in truth], ".", ms=2, label="truth heading")
    if micro:
        ax_h.plot(*_wrapped([ns / 1e9 for ns, _ in micro], [m["heading"] / 10 for _, m in micro]),
                  lw=0.8, label="micro heading")
    ax_h.set_ylabel("heading, deg (cw)")
    ax_h.set_xlabel("simulated time, s")
    ax_h.set_ylim(-5, 365)
    _legend(ax_h)
    for ax in (ax_v, ax_h):
        _marks(ax, cmds, "command", color="tab:green", lw=0.8, alpha=0.7)
        _marks(ax, events, "event", color="tab:red", lw=0.8, ls=":")
    for ns, cmd in _apart(ax_v, cmds):
        ax_v.annotate(_command_label(cmd), (ns / 1e9, 1.0), xycoords=("data", "axes fraction"),
                      rotation=90, va="top", ha="right", fontsize=_LABEL_PT, color="tab:green")
    for ns, ev in _apart(ax_h, events):
        ax_h.annotate(ev["kind"], (ns / 1e9, 0.0), xycoords=("data", "axes fraction"),
                      rotation=90, va="bottom", ha="right", fontsize=_LABEL_PT, color="tab:red")
    return fig


def _marks(ax, marks: list, gid: str, **style) -> None:
    """One vertical line across `ax` at the log time (s) of each mark [(log_time_ns,
    msg), ...], all in one LineCollection with gid `gid` (one artist: a line per mark
    costs a Line2D and a data-limits update each); the axes' limits are left alone."""
    from matplotlib.collections import LineCollection

    if marks:
        segs = [((ns / 1e9, 0.0), (ns / 1e9, 1.0)) for ns, _ in marks]
        ax.add_collection(LineCollection(segs, transform=ax.get_xaxis_transform(), gid=gid,
                                         linestyles=style.pop("ls", "solid"),
                                         colors=style.pop("color"), linewidths=style.pop("lw"),
                                         **style), autolim=False)


# Font size (pt) of a command's or event's label, written upright beside its line.
_LABEL_PT = 6


def _apart(ax, marks: list) -> list:
    """The marks [(log_time_ns, msg), ...] (in time order) whose upright labels on `ax`
    stand apart: a mark is labelled when it lies at least two labels' heights
    (2 * _LABEL_PT) to the right of the last labelled one, in points of the figure at any
    dpi, so each label has a gap of its own height beside it. Every mark keeps its line;
    labels packed closer could not be read, and their glyphs are the largest part of the
    drawing's time."""
    x0, x1 = ax.get_xlim()
    width_pt = ax.get_position().width * ax.figure.get_figwidth() * 72
    per_s = width_pt / (x1 - x0) if x1 > x0 else 0.0
    out, last = [], None
    for ns, msg in marks:
        x = ns / 1e9 * per_s
        if last is None or x - last >= 2 * _LABEL_PT:
            out.append((ns, msg))
            last = x
    return out


def read_datalog(path: Path) -> tuple[list, list]:
    """A seed-format datalog: ([(name, lo, hi), ...], rows as lists of floats).
    ValueError naming the line if the file does not fit the format."""
    lines = [ln.strip() for ln in Path(path).read_text(errors="replace").splitlines()]
    it = iter(enumerate(lines, 1))
    params = []
    n = None
    for no, ln in it:
        if not ln:
            continue
        try:
            n = int(ln.split()[0])
        except ValueError:
            raise ValueError(f"line {no}: expected the number of parameters, got {ln!r}") from None
        break
    if n is None or n <= 0:
        raise ValueError("no parameter count")
    for no, ln in it:
        if not ln:
            continue
        parts = ln.replace(",", " ").replace("\t", " ").split()
        try:
            lo, hi = float(parts[-2]), float(parts[-1])
            name = " ".join(parts[:-2]) or f"p{len(params)}"
        except (ValueError, IndexError):
            name, lo, hi = ln, None, None
        params.append((name, lo, hi))
        if len(params) == n:
            break
    if len(params) != n:
        raise ValueError(f"header lists {len(params)} of {n} parameters")
    rows = []
    for no, ln in it:
        if not ln:
            continue
        parts = ln.replace(",", " ").replace("\t", " ").split()
        try:
            vals = [float(p) for p in parts]
        except ValueError:
            raise ValueError(f"line {no}: not numbers: {ln[:60]!r}") from None
        if len(vals) != n:
            raise ValueError(f"line {no}: {len(vals)} values, header has {n}")
        rows.append(vals)
    return params, rows


def plot_datalog(path: Path, out: Path) -> None:
    """Plot datalog `path` into image `out` (its format by _format), one panel per parameter
    against row number (or against the first column when it is a time)."""
    params, rows = read_datalog(path)
    first = params[0][0].lower()
    timed = first in ("t", "time", "time_s", "time_ms", "timetag", "time_tag") or first.startswith("time")
    x = [r[0] for r in rows] if timed else list(range(len(rows)))
    shown = params[1:] if timed else params
    off = 1 if timed else 0
    fig, axes = _figure(max(1, len(shown)), 1.6 * max(1, len(shown)) + 1)
    if len(shown) == 1:
        axes = [axes]
    for i, (ax, (name, lo, hi)) in enumerate(zip(axes, shown)):
        ax.plot(x, [r[i + off] for r in rows], lw=0.9)
        ax.set_ylabel(name, fontsize="small", rotation=0, ha="right")
        if lo is not None and hi is not None and hi > lo:
            ax.set_ylim(lo, hi)
    axes[0].set_title(Path(path).name)
    axes[-1].set_xlabel(params[0][0] if timed else "frame")
    fig.tight_layout()
    fig.savefig(out, dpi=100, format=_format(out))
