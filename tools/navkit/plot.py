"""`navkit plot FILE`: plot a co-simulation run (run.mcap) or a seed-format datalog.

A run plot has the path (truth x/y in mm, and the micro's odometry), the forward speed
(mm/s) and the heading (deg, clockwise 0..360) against simulated time (s), with every
planner command marked. The file is streamed and each line thinned to about
PLOT_POINTS evenly spaced messages (a few per pixel of the figure), so any size of run.mcap
plots in bounded memory and time proportional to its size. `navkit sim` draws the same
figure from the same thinned messages, which its log worker keeps as it writes them
(RunSeries), without reading run.mcap back. The run plot is a navkit.figure model
(run_figure: the layout) drawn to PNG by navkit.figure_png (Pillow) or to another format
by navkit.figure_mpl (matplotlib). A datalog ("Data MM-DD-YY HH;MM;SS.txt", the seed's
Dataplot input: the number of parameters, then one line per parameter with its name and
default plot range, then one row per host frame) gets one panel per parameter over its
range, drawn by matplotlib.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

__all__ = ["add_arguments", "run", "plot_mcap", "mcap_figure", "run_figure", "RunSeries",
           "decoded", "fields", "plot_datalog", "read_datalog", "warm_up", "PLOT_POINTS"]

# Messages a line of a run plot keeps at most, evenly spaced (the figure is ~1000 pixels
# wide): between PLOT_POINTS and 2 * PLOT_POINTS of a topic with more messages than that.
PLOT_POINTS = 2000


def add_arguments(parser) -> None:
    """Arguments of `navkit plot`."""
    parser.add_argument("file", type=Path, help="run.mcap of `navkit sim`, or a datalog .txt")
    parser.add_argument("--out", "-o", type=Path, default=None,
                        help="image to write, its format by its suffix: .png (default: FILE with "
                        ".png), or another matplotlib writes (.svg, .pdf, ...)")
    from navkit.cli import positive_int

    parser.add_argument("--repeat", type=positive_int, default=1, metavar="N",
                        help="a run: draw it N times from its messages read once, as navkit sim "
                        "draws plot.png, and print the best and median time of a drawing (s)")


def run(args) -> int:
    """Plot args.file into args.out; 0 on success, 1 with a message on error."""
    path: Path = args.file
    out = args.out or path.with_suffix(".png")
    from mcap.exceptions import McapError

    try:
        if path.suffix == ".mcap" and args.repeat > 1:
            _time_drawing(path, out, args.repeat)
        elif path.suffix == ".mcap":
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


def _time_drawing(path: Path, out: Path, repeat: int) -> None:
    """Draw run `path` into `out` `repeat` times from its series read once (the first
    drawing loads Pillow and the fonts) and print the best and median wall time (s)."""
    import statistics
    import time

    series = _read_series(path)
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        plot_mcap(path, out, series)
        times.append(time.perf_counter() - t0)
    print(f"drawn {repeat} times from the messages read once: first {times[0]:.3f} s, best "
          f"{min(times):.3f} s, median {statistics.median(times):.3f} s")


class _Thinned:
    """Every `stride`-th message of a stream, the stride doubling (and every other kept
    message dropped) whenever more than 2 * `cap` are kept: at most 2 * `cap` in memory,
    evenly spaced, without knowing the count ahead. Messages are kept as their JSON bytes
    (decoded once, when drawn). The numbers a plot draws of the first `found` kept
    messages may be found ahead (find_ahead): `cols` {key: float array}, thinned with
    them; `found` -1 once a search failed (fields() then decodes them all)."""

    __slots__ = ("cap", "stride", "n", "kept", "found", "cols")

    def __init__(self, cap: int):
        self.cap, self.stride, self.n, self.kept = cap, 1, 0, []
        self.found, self.cols = 0, {}

    def offer(self, t_ns: int, data: bytes) -> None:
        if self.n % self.stride == 0:
            self._keep((t_ns, data))
        self.n += 1

    def offer_run(self, count: int, message) -> None:
        """`count` messages in a row, as `count` offer() calls: `message(i)` -> (t_ns,
        data) of the i-th, called only for those kept."""
        i = -self.n % self.stride       # the first with (n + i) % stride == 0
        while i < count:
            self._keep(message(i))
            i += 1 + (-(self.n + i + 1) % self.stride)
        self.n += count

    def _keep(self, message: tuple) -> None:
        """Keep `message`; past 2 * cap kept, drop every other one and double the stride."""
        self.kept.append(message)
        if len(self.kept) > 2 * self.cap:
            del self.kept[1::2]
            self.stride *= 2
            if self.found > 0:      # the kept of even index stay, so do their numbers
                self.cols = {k: v[::2] for k, v in self.cols.items()}
                self.found = (self.found + 1) // 2

    def find_ahead(self, keys: tuple, least: int) -> None:
        """Find the numbers of `keys` (_numbers) in the kept messages not searched yet, if
        there are at least `least` of them, so that fields() searches only the rest."""
        n = self.found
        if n < 0 or len(self.kept) - n < least:
            return
        got = _numbers(self.kept, keys, (n, self.cols))
        if got is None:
            self.found, self.cols = -1, {}
            return
        self.found, self.cols = len(self.kept), got


# The topics a run plot draws: those of RUN_FIELDS thinned to about PLOT_POINTS messages
# each, with the fields drawn of them (run_figure), the others whole (a mission's commands
# and events, few).
RUN_FIELDS = {"/truth": ("t", "x_mm", "y_mm", "v_mm_s", "heading_deg"),
              "/micro/data": ("x", "y", "fwd_speed", "heading")}
RUN_THINNED = tuple(RUN_FIELDS)
RUN_WHOLE = ("/planner/cmd", "/events")

# Kept messages of a thinned topic searched at once by RunSeries.find_ahead: a search has
# a cost of its own, paid this many times fewer.
_FIND_AT_LEAST = 512


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

    def sink_run(self, topic: str):
        """The function (count, message) -> None taking `count` messages of `topic` at
        once (message(i) -> (t_ns, JSON bytes) of the i-th), as `count` calls of
        sink(topic); None for a topic the plot does not draw."""
        if topic in self._thin:
            return self._thin[topic].offer_run
        if topic in self._whole:
            extend = self._whole[topic].extend
            return lambda count, message: extend(map(message, range(count)))
        return None

    def raw(self) -> dict:
        out = {t: list(msgs) for t, msgs in self._whole.items()}
        out.update({t: list(th.kept) for t, th in self._thin.items()})
        return out

    def find_ahead(self) -> None:
        """Find the drawn fields (RUN_FIELDS) of the thinned messages kept since the last
        search, once there are _FIND_AT_LEAST of them: the work of fields() done while a
        run's messages come (the log worker between batches), not when it draws."""
        for topic, th in self._thin.items():
            if topic in RUN_FIELDS:
                th.find_ahead(RUN_FIELDS[topic], _FIND_AT_LEAST)

    def found(self) -> dict:
        """What find_ahead found, for run_figure: {topic: (n, {key: values of raw()[topic][:n]})}."""
        return {t: (th.found, dict(th.cols)) for t, th in self._thin.items() if th.found > 0}


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


def _read_series(path: Path, thin: tuple = RUN_THINNED, whole: tuple = RUN_WHOLE,
                 cap: int = PLOT_POINTS) -> dict:
    """RunSeries.raw() of run `path`, streamed (navkit.sim.results.iter_mcap) through a
    RunSeries: the topics in `thin` thinned to about `cap` messages each, those in `whole`
    every message, as their JSON bytes."""
    from navkit.sim.results import iter_mcap

    series = RunSeries(cap, thin, whole)
    sinks = {t: series.sink(t) for t in series.topics}
    for t_ns, topic, data in iter_mcap(path, series.topics):
        sinks[topic](t_ns, data)
    return series.raw()


def _numbers(msgs: list, keys: tuple, ahead: tuple = (0, {})) -> dict | None:
    """{key: numpy float array} of top-level fields `keys` of JSON messages `msgs`
    [(log_time_ns, JSON bytes), ...], in their order, each found by its text `"key":`
    without decoding the messages; None where that does not give one plain number per
    message (a key missing, nested, or a value that is not a plain number). `ahead`:
    (n, {key: values}) of the first n messages, found earlier: only the rest are searched."""
    import re

    import numpy as np

    n, before = ahead
    msgs = msgs[n:] if n else msgs
    blob = b"\n".join(data for _, data in msgs)
    out = {}
    for key in keys:
        found = re.findall(b'"' + re.escape(key.encode()) + rb'":(-?[0-9][0-9.eE+-]*)', blob)
        if len(found) != len(msgs):
            return None
        try:
            out[key] = np.fromiter(map(float, found), float, len(found))
        except ValueError:
            return None
        if n:
            out[key] = np.concatenate((before[key], out[key]))
    return out


def fields(topic: str, msgs: list, keys: tuple, ahead: tuple | None = None) -> tuple:
    """The numeric top-level fields `keys` of messages `msgs` [(log_time_ns, JSON bytes),
    ...] of `topic`, in log-time order (file order among equal times): (log times in s,
    {key: values}), numpy float arrays. Each key's values are found by its text `"key":`
    in the messages (_numbers), without decoding them whole (most of a /micro/data
    message is fields a plot does not draw); where that does not give one number per
    message, the messages are decoded whole. `ahead`: (n, {key: values}) of the first n
    messages, found earlier (RunSeries.found). ValueError naming the topic and key if a
    message lacks one."""
    import numpy as np

    t_ns = np.array([t for t, _ in msgs], dtype=np.int64)
    out = _numbers(msgs, keys, ahead or (0, {}))
    if out is None:
        objs = [obj for _, obj in decoded({topic: msgs})[topic]]
        t_ns = np.sort(t_ns, kind="stable")
        try:
            return t_ns / 1e9, {k: np.array([float(m[k]) for m in objs]) for k in keys}
        except (KeyError, TypeError, ValueError) as e:
            raise ValueError(f"{topic}: a message without a number in {e}") from None
    if t_ns.size > 1 and (np.diff(t_ns) < 0).any():
        order = np.argsort(t_ns, kind="stable")
        t_ns = t_ns[order]
        out = {k: v[order] for k, v in out.items()}
    return t_ns / 1e9, out


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
    """A 0..360 heading line (numpy arrays `t`, `h`) broken where it wraps: a NaN inserted
    between two points more than 180 apart."""
    import numpy as np

    at = np.flatnonzero(np.abs(np.diff(h)) > 180) + 1
    return np.insert(t, at, t[at]), np.insert(h, at, np.nan)


def plot_mcap(path: Path, out: Path, series: dict | None = None, found: dict | None = None) -> None:
    """Plot run `path` (run.mcap) into image `out` (its format by _format: PNG drawn by
    navkit.figure_png, others by matplotlib), from `series` (RunSeries.raw() of the run's
    messages, as the log worker keeps them, with `found`: its RunSeries.found()) when
    given, else streamed from the file: the same figure either way."""
    fmt = _format(out)
    fig = run_figure(series if series is not None else _read_series(Path(path)),
                     _run_title(Path(path)), found)
    if fmt == "png":
        from navkit.figure_png import write_png

        write_png(fig, out)
    else:
        from navkit.figure_mpl import save

        save(fig, out, fmt)


def warm_up() -> None:
    """Load once what drawing a run's plot.png loads on its first drawing: Pillow, the
    PNG emitter and its fonts at the run plot's sizes (navkit.figure_png.load_fonts), so
    that a later plot_mcap into a .png draws at its warm speed. For a process with time
    to spare before it draws (the log worker early in a run)."""
    from navkit.figure_png import load_fonts

    load_fonts(_DPI, (_LABEL_PT,))


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


# Size of a run plot: 9 x 11 in at 110 dots per inch, 990 x 1210 pixels.
_SIZE_IN = (9.0, 11.0)
_DPI = 110

# tab10 colours: the truth, the micro's view, commands, events
_TRUTH, _MICRO, _COMMAND, _EVENT = "#1f77b4", "#ff7f0e", "#2ca02c", "#d62728"


def _run_title(path: Path) -> str:
    return f"{path.parent.name}/{path.name}: path"


def mcap_figure(path: Path):
    """The plot of run `path` (run.mcap) as a matplotlib Figure (run_figure drawn by
    navkit.figure_mpl; close it with matplotlib.pyplot.close if pyplot is in use)."""
    from navkit.figure_mpl import to_matplotlib

    return to_matplotlib(run_figure(_read_series(Path(path)), _run_title(Path(path))))


def _panels(rows: int, left: float = 0.1, right: float = 0.97, bottom: float = 0.05,
            top: float = 0.96, gap: float = 0.22) -> list:
    """Rects (left, bottom, width, height; figure fractions) of `rows` panels stacked top
    to bottom between the margins, `gap` times a panel's height between two."""
    h = (top - bottom) / (rows + gap * (rows - 1))
    return [(left, top - i * h * (1 + gap) - h, right - left, h) for i in range(rows)]


def run_figure(series: dict, title: str, found: dict | None = None):
    """The plot of a run's messages `series` (RunSeries.raw(): {topic: [(log_time_ns, JSON
    bytes), ...]}) as a finished navkit.figure.Figure, 9 x 11 in: three panels, the path
    (truth y_mm across, growing to the left, x_mm up, mm, equal aspect) titled `title`,
    the speed (mm/s) and the heading (deg, clockwise 0..360) against simulated time (s);
    on the speed and heading panels a vertical mark per /planner/cmd message (gid
    "command") and per /events message (gid "event") at its log time, labelled where
    labels stand apart (_apart). `found`: the fields of series' first messages found
    ahead (RunSeries.found()), the same figure. ValueError without /truth, or naming the
    topic of a command or event its label cannot be made of (_labels)."""
    import numpy as np

    from navkit.figure import Figure, Line, Marks, Panel

    if not series.get("/truth"):
        raise ValueError("no /truth messages")
    found = found or {}
    _, truth = fields("/truth", series["/truth"], RUN_FIELDS["/truth"], found.get("/truth"))
    micro_t, micro = fields("/micro/data", series.get("/micro/data", []), RUN_FIELDS["/micro/data"],
                            found.get("/micro/data"))
    marks = decoded({k: series.get(k, []) for k in ("/planner/cmd", "/events")})
    cmds, events = marks["/planner/cmd"], marks["/events"]
    r_xy, r_v, r_h = _panels(3)
    xy = Panel(r_xy, xlabel="y (left), mm", ylabel="x (forward), mm", title=title, invert_x=True,
               equal=True)
    xy.lines.append(Line(truth["y_mm"], truth["x_mm"], _TRUTH, label="truth"))
    v = Panel(r_v, ylabel="speed, mm/s")
    v.lines.append(Line(truth["t"], truth["v_mm_s"], _TRUTH, label="truth v"))
    h = Panel(r_h, ylabel="heading, deg (cw)", xlabel="simulated time, s", ylim=(-5.0, 365.0))
    h.lines.append(Line(truth["t"], truth["heading_deg"] % 360, _TRUTH, width=2.0, style="points",
                        label="truth heading"))
    if micro_t.size:
        # the micro's odometry uses the truth's axes (x forward, y left)
        xy.lines.append(Line(micro["y"], micro["x"], _MICRO, 0.8, "dashed", "micro odometry"))
        v.lines.append(Line(micro_t, micro["fwd_speed"], _MICRO, 0.8, label="micro fwd_speed"))
        h.lines.append(Line(*_wrapped(micro_t, micro["heading"] / 10), _MICRO, 0.8,
                            label="micro heading"))
    for p in (v, h):
        if cmds:
            p.marks.append(Marks(np.array([ns for ns, _ in cmds]) / 1e9, _COMMAND, 0.8, alpha=0.7,
                                 gid="command"))
        if events:
            p.marks.append(Marks(np.array([ns for ns, _ in events]) / 1e9, _EVENT, 0.8, "dotted",
                                 gid="event"))
    fig = Figure(*_SIZE_IN, _DPI, [xy, v, h]).finish()
    v.labels = _labels(fig, v, "/planner/cmd", cmds, _command_label, _COMMAND, "top")
    h.labels = _labels(fig, h, "/events", events, lambda ev: str(ev["kind"]), _EVENT, "bottom")
    return fig


def _labels(fig, panel, topic: str, marks: list, text, color: str, at: str) -> list:
    """Upright labels text(msg) in `color` at the top or bottom (`at`) of finished `panel`
    for the marks [(log_time_ns, msg), ...] of `topic` that stand apart (_apart).
    ValueError naming `topic` for a message without what its label says (not a JSON
    object, a field missing or of another type)."""
    from navkit.figure import Upright

    try:
        return [Upright(ns / 1e9, text(msg), color, _LABEL_PT, at) for ns, msg in _apart(fig, panel, marks)]
    except (AttributeError, KeyError, TypeError, ValueError) as e:
        raise ValueError(f"{topic}: a message the plot cannot label ({type(e).__name__}: {e})") from None


# Font size (pt) of a command's or event's label, written upright beside its line.
_LABEL_PT = 6


def _apart(fig, panel, marks: list) -> list:
    """The marks [(log_time_ns, msg), ...] (in time order) whose upright labels on finished
    `panel` of `fig` stand apart: a mark is labelled when it lies at least two labels'
    heights (2 * _LABEL_PT, pt) to the right of the last labelled one, so each label has
    a gap of its own height beside it. Every mark keeps its line; labels packed closer
    could not be read. Marks outside the panel's time limits get no label (it would lie
    off the panel): at most one label per two label heights of the panel's width."""
    x0, x1 = sorted(panel.xlim)
    per_s = panel.size_pt(fig)[0] / (x1 - x0) if x1 > x0 else 0.0
    out, last = [], None
    for ns, msg in marks:
        if not x0 <= ns / 1e9 <= x1:
            continue
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
    fmt = _format(out)
    params, rows = read_datalog(path)
    first = params[0][0].lower()
    timed = first in ("t", "time", "time_s", "time_ms", "timetag", "time_tag") or first.startswith("time")
    x = [r[0] for r in rows] if timed else list(range(len(rows)))
    shown = params[1:] if timed else params
    off = 1 if timed else 0
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    fig = Figure(figsize=(9, 1.6 * max(1, len(shown)) + 1))
    axes = fig.subplots(max(1, len(shown)), 1, squeeze=False)[:, 0]
    for i, (ax, (name, lo, hi)) in enumerate(zip(axes, shown)):
        ax.plot(x, [r[i + off] for r in rows], lw=0.9)
        ax.set_ylabel(name, fontsize="small", rotation=0, ha="right")
        if lo is not None and hi is not None and hi > lo:
            ax.set_ylim(lo, hi)
    axes[0].set_title(Path(path).name)
    axes[-1].set_xlabel(params[0][0] if timed else "frame")
    fig.tight_layout()
    fig.savefig(out, dpi=100, format=fmt)
