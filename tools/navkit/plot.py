"""`navkit plot FILE`: plot a co-simulation run (run.mcap) or a seed-format datalog.

A run plot has the path (truth x/y in mm, and the micro's odometry), the forward speed
(mm/s) and the heading (deg, clockwise 0..360) against simulated time (s), with every
planner command marked. The file is streamed and each line thinned to about
PLOT_POINTS evenly spaced messages (a few per pixel of the figure), so any size of run.mcap
plots in bounded memory and time proportional to its size. A datalog ("Data MM-DD-YY HH;MM;SS.txt", the seed's Dataplot
input: the number of parameters, then one line per parameter with its name and default
plot range, then one row per host frame) gets one panel per parameter over its range.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

__all__ = ["add_arguments", "run", "plot_mcap", "mcap_figure", "plot_datalog", "read_datalog",
           "read_mcap", "PLOT_POINTS"]

# Messages a line of a run plot keeps at most, evenly spaced (the figure is ~1000 pixels
# wide): between PLOT_POINTS and 2 * PLOT_POINTS of a topic with more messages than that.
PLOT_POINTS = 2000


def add_arguments(parser) -> None:
    """Arguments of `navkit plot`."""
    parser.add_argument("file", type=Path, help="run.mcap of `navkit sim`, or a datalog .txt")
    parser.add_argument("--out", "-o", type=Path, default=None,
                        help="PNG to write (default: FILE with .png)")


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
        print(f"navkit plot: {text if text.startswith(str(path)) else f'{path}: {text}'}",
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
    evenly spaced, without knowing the count ahead. Only kept messages are decoded."""

    def __init__(self, cap: int):
        self.cap, self.stride, self.n, self.kept = cap, 1, 0, []

    def offer(self, t_ns: int, data: bytes) -> None:
        if self.n % self.stride == 0:
            self.kept.append((t_ns, json.loads(data)))
            if len(self.kept) > 2 * self.cap:
                self.kept = self.kept[::2]
                self.stride *= 2
        self.n += 1


def _read_thinned(path: Path, thin: tuple, whole: tuple, cap: int = PLOT_POINTS) -> dict:
    """{topic: [(log_time_ns, decoded JSON), ...]} of run `path`, streamed
    (navkit.sim.results.iter_mcap): the topics in `thin` thinned to about `cap` messages
    each (_Thinned), those in `whole` every message; each list in log-time order."""
    from navkit.sim.results import iter_mcap

    thinned = {t: _Thinned(cap) for t in thin}
    out: dict = {t: [] for t in whole}
    for t_ns, topic, data in iter_mcap(path, thin + whole):
        if topic in thinned:
            thinned[topic].offer(t_ns, data)
        else:
            out[topic].append((t_ns, json.loads(data)))
    out.update({t: th.kept for t, th in thinned.items()})
    for msgs in out.values():
        msgs.sort(key=lambda m: m[0])
    return out


def _figure(rows: int, height: float):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt, plt.subplots(rows, 1, figsize=(9, height))


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


def plot_mcap(path: Path, out: Path) -> None:
    """Plot run `path` (run.mcap) into PNG `out` (mcap_figure)."""
    fig = mcap_figure(path)
    try:
        fig.savefig(out, dpi=110)
    finally:
        import matplotlib.pyplot as plt

        plt.close(fig)


def mcap_figure(path: Path):
    """The plot of run `path` (run.mcap) as a matplotlib Figure (close it with
    matplotlib.pyplot.close): three panels, the path (truth y_mm across, x_mm up, mm),
    the speed (mm/s) and the heading (deg, clockwise 0..360) against simulated time (s);
    on the speed and heading panels one vertical line per /planner/cmd message (gid
    "command") and per /events message (gid "event") at its log time. /truth and
    /micro/data are thinned to about PLOT_POINTS messages each."""
    msgs = _read_thinned(path, ("/truth", "/micro/data"), ("/planner/cmd", "/events"))
    truth = [m for _, m in msgs.get("/truth", [])]
    if not truth:
        raise ValueError("no /truth messages")
    cmds = msgs.get("/planner/cmd", [])
    events = msgs.get("/events", [])
    micro = msgs.get("/micro/data", [])
    t = [m["t"] for m in truth]
    _plt, (fig, (ax_xy, ax_v, ax_h)) = _figure(3, 11)
    ax_xy.plot([m["y_mm"] for m in truth], [m["x_mm"] for m in truth], label="truth")
    if micro:
        # the micro's odometry uses the truth's axes (x forward, y left)
        ax_xy.plot([m["y"] for _, m in micro], [m["x"] for _, m in micro], "--", lw=0.8,
                   label="micro odometry")
    ax_xy.set_xlabel("y (left), mm")
    ax_xy.set_ylabel("x (forward), mm")
    ax_xy.invert_xaxis()
    ax_xy.set_aspect("equal", adjustable="datalim")
    ax_xy.set_title(f"{path.parent.name}/{path.name}: path")
    ax_xy.legend(loc="best", fontsize="small")
    ax_v.plot(t, [m["v_mm_s"] for m in truth], label="truth v")
    if micro:
        ax_v.plot([ns / 1e9 for ns, _ in micro], [m["fwd_speed"] for _, m in micro], lw=0.8,
                  label="micro fwd_speed")
    ax_v.set_ylabel("speed, mm/s")
    ax_v.legend(loc="best", fontsize="small")
    ax_h.plot(t, [m["heading_deg"] % 360 for m in truth], ".", ms=2, label="truth heading")
    if micro:
        ax_h.plot(*_wrapped([ns / 1e9 for ns, _ in micro], [m["heading"] / 10 for _, m in micro]),
                  lw=0.8, label="micro heading")
    ax_h.set_ylabel("heading, deg (cw)")
    ax_h.set_xlabel("simulated time, s")
    ax_h.set_ylim(-5, 365)
    ax_h.legend(loc="best", fontsize="small")
    for ns, cmd in cmds:
        for ax in (ax_v, ax_h):
            ax.axvline(ns / 1e9, color="tab:green", lw=0.8, alpha=0.7, gid="command")
        ax_v.annotate(_command_label(cmd), (ns / 1e9, 1.0), xycoords=("data", "axes fraction"),
                      rotation=90, va="top", ha="right", fontsize=6, color="tab:green")
    for ns, ev in events:
        for ax in (ax_v, ax_h):
            ax.axvline(ns / 1e9, color="tab:red", lw=0.8, ls=":", gid="event")
        ax_h.annotate(ev["kind"], (ns / 1e9, 0.0), xycoords=("data", "axes fraction"),
                      rotation=90, va="bottom", ha="right", fontsize=6, color="tab:red")
    fig.tight_layout()
    return fig


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
    """Plot datalog `path` into PNG `out`, one panel per parameter against row number
    (or against the first column when it is a time)."""
    params, rows = read_datalog(path)
    first = params[0][0].lower()
    timed = first in ("t", "time", "time_s", "time_ms", "timetag", "time_tag") or first.startswith("time")
    x = [r[0] for r in rows] if timed else list(range(len(rows)))
    shown = params[1:] if timed else params
    off = 1 if timed else 0
    plt, (fig, axes) = _figure(max(1, len(shown)), 1.6 * max(1, len(shown)) + 1)
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
    fig.savefig(out, dpi=100)
    plt.close(fig)
