"""`navkit compare RUN_A RUN_B`: how far two co-simulation runs part.

    navkit compare build/sim/demo build/sim/demo-pil [--plot compare.png] [--json FILE]
        [--pos-tol MM] [--heading-tol DEG] [--speed-tol MM_S] [--check]

Both runs' /truth (the plant's pose and speed) and the micro's odometry (/micro/data x, y,
heading, fwd_speed, placed at the simulated time the micro sampled them: its micro_time)
are compared where the runs overlap at the simulated instants of the run sampled more
coarsely, the other interpolated linearly (runs with different frame or truth periods
compare on simulated time), and the
deviation of B from A is reported per signal: largest and RMS, when it was largest, and
where the runs part (the first instant it exceeds its threshold). Heading deviations are
clockwise B - A wrapped to -180..180 deg; position deviations the distance between the
two positions (mm). Legs are the mission's commands as run A's planner wrote them
(/planner/cmd): leg i runs from command i to command i + 1 (the last to the end of the
overlap), and the deviations at each leg's end are reported too.

Python API: `compare_runs(run_a, run_b) -> Comparison` (see Comparison.text(),
Comparison.worst_leg_end(), Comparison.to_dict()).
"""

from __future__ import annotations

import json
import sys
from dataclasses import dataclass, field
from pathlib import Path

__all__ = ["CompareError", "Deviation", "LegEnd", "Comparison", "compare_runs",
           "DEFAULT_TOLERANCES", "add_arguments", "run"]

# the thresholds where runs "part" (and of --check at leg ends): position mm, heading deg,
# speed mm/s. 5 mm and 0.5 deg are the SIL/PIL agreement asked of the demo mission.
DEFAULT_TOLERANCES = {"pos_mm": 5.0, "heading_deg": 0.5, "speed_mm_s": 10.0}
_TOPICS = ("/truth", "/micro/data", "/planner/cmd", "/events")
_SIGNALS = (("position", "mm", "pos_mm"), ("heading", "deg", "heading_deg"),
            ("speed", "mm/s", "speed_mm_s"))


class CompareError(ValueError):
    """Runs that cannot be compared; the text names the run folder or file."""


@dataclass
class Deviation:
    """One signal's deviation of run B from run A over the compared instants: `max` (of
    the absolute value) at simulated time `t_max` (s), `rms`, and `parted_at`, the first
    instant (s) it exceeded `threshold` (None: never). Units in `units`."""

    signal: str
    units: str
    max: float
    t_max: float
    rms: float
    threshold: float
    parted_at: float | None


@dataclass
class LegEnd:
    """The deviations of B from A at the end of leg `leg` (1-based: the run's n-th
    planner command, from `t_start` to `t_end`, s): /truth position (mm), heading (deg,
    clockwise B - A) and speed (mm/s), and the same of the micro's odometry (None when a
    run has no /micro/data there)."""

    leg: int
    t_start: float
    t_end: float
    pos_mm: float
    heading_deg: float
    speed_mm_s: float
    odo_pos_mm: float | None = None
    odo_heading_deg: float | None = None
    odo_speed_mm_s: float | None = None


@dataclass
class Comparison:
    """compare_runs' result: the runs (`run_a`, `run_b`: their folders), what each is
    (`info`: mission file, seed, frame period, time span), the compared span `t0`..`t1`
    (s), `truth` and `odometry` ({"position" | "heading" | "speed": Deviation};
    `odometry` empty when a run has no /micro/data), `legs` (LegEnd per leg), `warnings`
    (runs of different missions, legs left out) and `series` (the aligned arrays the plot
    draws: t, the deviations, both paths)."""

    run_a: Path
    run_b: Path
    info: dict
    t0: float
    t1: float
    truth: dict
    odometry: dict
    legs: list
    tolerances: dict
    warnings: list = field(default_factory=list)
    series: dict = field(default_factory=dict, repr=False)

    def worst_leg_end(self) -> tuple[float, float]:
        """(largest /truth position deviation in mm, largest |heading| deviation in deg)
        over the leg ends; (0, 0) without legs."""
        return (max((leg.pos_mm for leg in self.legs), default=0.0),
                max((abs(leg.heading_deg) for leg in self.legs), default=0.0))

    def legs_within(self, pos_mm: float, heading_deg: float) -> bool:
        """Whether every leg's end is within `pos_mm` (mm) and `heading_deg` (deg)."""
        pos, hdg = self.worst_leg_end()
        return pos <= pos_mm and hdg <= heading_deg

    def to_dict(self) -> dict:
        """Everything but the series, JSON-ready."""
        dev = lambda d: {k: v.__dict__ for k, v in d.items()}  # noqa: E731
        return {"run_a": str(self.run_a), "run_b": str(self.run_b), "info": self.info,
                "t0": self.t0, "t1": self.t1, "tolerances": self.tolerances,
                "truth": dev(self.truth), "odometry": dev(self.odometry),
                "legs": [leg.__dict__ for leg in self.legs], "warnings": self.warnings}

    def text(self) -> str:
        """The report as text: the runs, a line per signal, a line per leg end."""
        lines = []
        for tag, path in (("A", self.run_a), ("B", self.run_b)):
            i = self.info[tag]
            frame = f"frame {i['frame_s'] * 1000:g} ms" if i.get("frame_s") else "frame ?"
            lines.append(f"{tag}  {path}  {i.get('mission_file') or '?'}  seed {i.get('seed', '?')}  "
                         f"{frame}  {i['t_first']:.2f}..{i['t_last']:.2f} s")
        lines.append(f"compared over {self.t0:.2f}..{self.t1:.2f} s of simulated time "
                     f"({self.series['t'].size} instants)")
        lines.append("")
        lines.append(f"{'deviation B - A':<22}{'max':>14}{'at':>10}{'RMS':>14}   parts at (threshold)")
        for group, devs in (("/truth", self.truth), ("odometry", self.odometry)):
            for d in devs.values():
                part = f"{d.parted_at:.2f} s" if d.parted_at is not None else "never"
                lines.append(f"{group + ' ' + d.signal:<22}{_num(d.max):>9} {d.units:<4}"
                             f"{d.t_max:>8.2f} s{_num(d.rms):>9} {d.units:<4}  {part} "
                             f"(> {d.threshold:g} {d.units})")
        if not self.odometry:
            lines.append("odometry: not compared (a run has no /micro/data)")
        lines.append("")
        if self.legs:
            lines.append("at each leg's end (legs: run A's planner commands; /truth, then odometry):")
            lines.append(f"{'leg':>4}{'from s':>9}{'to s':>9}{'pos mm':>10}{'hdg deg':>10}"
                         f"{'v mm/s':>10}{'odo mm':>10}{'odo deg':>10}{'odo mm/s':>10}")
            for leg in self.legs:
                lines.append(f"{leg.leg:>4}{leg.t_start:>9.2f}{leg.t_end:>9.2f}{_num(leg.pos_mm):>10}"
                             f"{_num(leg.heading_deg):>10}{_num(leg.speed_mm_s):>10}"
                             f"{_num(leg.odo_pos_mm):>10}{_num(leg.odo_heading_deg):>10}"
                             f"{_num(leg.odo_speed_mm_s):>10}")
            pos, hdg = self.worst_leg_end()
            lines.append(f"worst leg end: {_num(pos)} mm, {_num(hdg)} deg")
        else:
            lines.append("no legs: run A's planner wrote no command")
        lines += [f"warning: {w}" for w in self.warnings]
        return "\n".join(lines)


def _num(v) -> str:
    """A deviation for the text: 3 significant digits, '-' for None."""
    if v is None:
        return "-"
    return f"{v:.3g}" if abs(v) >= 1e-3 or v == 0 else f"{v:.1e}"


class _Run:
    """One run's arrays: /truth t, x, y, yaw (deg, CCW, unwrapped), v; /micro/data t, x,
    y, heading (deg clockwise, unwrapped), speed; planner command times; metadata."""

    def __init__(self, path: Path, tag: str):
        import numpy as np
        from mcap.exceptions import McapError

        from navkit import protocol
        from navkit.sim.results import read_mcap

        path = Path(path)
        if not path.exists():
            raise CompareError(f"run {tag} {path}: no such run folder")
        mcap = path if path.is_file() else path / "run.mcap"
        self.folder = path.parent if path.is_file() else path
        if not mcap.is_file():
            raise CompareError(f"run {tag} {path}: no run.mcap in it (not an output folder of "
                               f"navkit sim)")
        try:
            mc = read_mcap(mcap, topics=_TOPICS)
        except (McapError, OSError) as e:
            raise CompareError(f"run {tag}: {e}") from None
        self.meta = mc.metadata
        self.mcap = mcap
        by = {t: [] for t in _TOPICS}
        for t_ns, topic, data in mc.messages:
            by[topic].append((t_ns / 1e9, data))
        truth = [json.loads(d) for _, d in by["/truth"]]
        if len(truth) < 2:
            raise CompareError(f"run {tag} {mcap}: {len(truth)} /truth messages, at least 2 "
                               f"needed (a plant without the truth outputs x_mm .. w_deg_s?)")
        try:
            self.t = np.array([m["t"] for m in truth])
            self.x = np.array([m["x_mm"] for m in truth])
            self.y = np.array([m["y_mm"] for m in truth])
            self.yaw = np.array([m["yaw_deg"] for m in truth])
            self.v = np.array([m["v_mm_s"] for m in truth])
        except KeyError as e:
            raise CompareError(f"run {tag} {mcap}: /truth without {e.args[0]} (a plant without "
                               f"that truth output)") from None
        scale = protocol.SPEC.messages["micro_data"].field("heading").scale
        micro = [(t, json.loads(d)) for t, d in by["/micro/data"]]
        resets = [t for t, d in by["/events"] if json.loads(d).get("kind") == "micro_reset"]
        self.has_micro = len(micro) >= 2
        if self.has_micro:
            self.mt = _micro_times(micro, resets)
            order = np.argsort(self.mt, kind="stable")
            micro = [micro[i] for i in order]
            self.mt = self.mt[order]
            self.mx = np.array([m["x"] for _, m in micro], dtype=float)
            self.my = np.array([m["y"] for _, m in micro], dtype=float)
            self.mhdg = np.unwrap(np.array([m["heading"] * scale for _, m in micro]), period=360.0)
            self.mv = np.array([m["fwd_speed"] for _, m in micro], dtype=float)
        self.commands = [t for t, _ in by["/planner/cmd"]]

    def info(self) -> dict:
        seed = self.meta.get("seed")
        frame = self.meta.get("frame_s")
        return {"mission_file": self.meta.get("mission_file"),
                "seed": int(seed) if seed is not None and str(seed).lstrip("-").isdigit() else seed,
                "frame_s": float(frame) if frame is not None else None,
                "t_first": float(self.t[0]), "t_last": float(self.t[-1]),
                "truth_rows": int(self.t.size), "commands": len(self.commands)}


def _micro_times(micro: list, resets: list):
    """Simulated time (s) at which each micro_data [(log time s, message), ...] was
    sampled, from the micro's own clock (micro_time, ms since its reset): its log time is
    only the end of the FMU call that carried it, up to a frame later and differently so
    for another frame period. The firmware starts with the simulation (epoch 0); after
    each restart (micro_time going back) the epoch is the harness's micro_reset event
    (`resets`, s, in order) or, without one, the log time minus micro_time."""
    import numpy as np

    out = np.empty(len(micro))
    epoch, last, restarts = 0.0, -1, iter(resets)
    for i, (t_log, m) in enumerate(micro):
        ms = m["micro_time"]
        if ms < last:
            epoch = next(restarts, t_log - ms / 1000.0)
        last = ms
        out[i] = epoch + ms / 1000.0
    return out


def _script(text: str | None):
    """What makes a mission the same mission, from the mission text a run records: the
    TOML without its [plant] and [expect] tables (a plant variant is the same mission);
    the text itself if it does not parse."""
    import tomllib

    try:
        doc = tomllib.loads(text or "")
    except tomllib.TOMLDecodeError:
        return text
    doc.pop("plant", None)
    doc.pop("expect", None)
    return doc


def _instants(ta, tb, t0: float, t1: float):
    """The instants (s) two series are compared at: those of the one with fewer samples
    in `t0`..`t1` (A's on a tie), so the other, finer one is the one interpolated (linear
    interpolation of the coarser would show its own error at every kink as a
    deviation)."""
    ta = ta[(ta >= t0) & (ta <= t1)]
    tb = tb[(tb >= t0) & (tb <= t1)]
    return ta if ta.size <= tb.size else tb


def _wrap180(a):
    """Degrees wrapped into -180..180 (array or float)."""
    return (a + 180.0) % 360.0 - 180.0


def _deviation(signal: str, units: str, t, d, threshold: float) -> Deviation:
    import numpy as np

    a = np.abs(d)
    i = int(np.argmax(a))
    over = np.nonzero(a > threshold)[0]
    return Deviation(signal, units, float(a[i]), float(t[i]), float(np.sqrt(np.mean(d * d))),
                     threshold, float(t[over[0]]) if over.size else None)


def _track_diff(ta, tb, t):
    """(position mm, clockwise heading deg wrapped to -180..180, speed mm/s) deviations of
    track `tb` from track `ta` at instants `t` (s); a track is (t, x, y, heading clockwise
    unwrapped, v) arrays, interpolated linearly. Rounded to 1e-9: float noise of the
    unwrapping is no deviation."""
    import numpy as np

    (a, b) = ([np.interp(t, tr[0], col) for col in tr[1:]] for tr in (ta, tb))
    return (np.round(np.hypot(b[0] - a[0], b[1] - a[1]), 9),
            np.round(_wrap180(b[2] - a[2]), 9), np.round(b[3] - a[3], 9))


def compare_runs(run_a: Path, run_b: Path, tolerances: dict | None = None) -> Comparison:
    """Compare run folders (or their run.mcap files) `run_a` and `run_b`; `tolerances`
    overrides DEFAULT_TOLERANCES' thresholds (pos_mm, heading_deg, speed_mm_s). Raises
    CompareError naming the run: a missing folder, no run.mcap, not an MCAP file, no
    /truth, runs that do not overlap in simulated time. Runs of different missions are
    compared with a warning (Comparison.warnings)."""
    import numpy as np

    tol = dict(DEFAULT_TOLERANCES, **(tolerances or {}))
    a, b = _Run(run_a, "A"), _Run(run_b, "B")
    warnings = []
    if _script(a.meta.get("mission")) != _script(b.meta.get("mission")):
        warnings.append(f"runs of different missions (A: {a.meta.get('mission_file')}, B: "
                        f"{b.meta.get('mission_file')}: their commands, keys, faults, world or "
                        f"duration differ); the legs are run A's")
    if len(a.commands) != len(b.commands):
        warnings.append(f"run A's planner wrote {len(a.commands)} commands, run B's "
                        f"{len(b.commands)}; the legs are run A's")
    t0, t1 = max(a.t[0], b.t[0]), min(a.t[-1], b.t[-1])
    if t1 <= t0:
        raise CompareError(f"runs {a.folder} ({a.t[0]:.2f}..{a.t[-1]:.2f} s) and {b.folder} "
                           f"({b.t[0]:.2f}..{b.t[-1]:.2f} s) do not overlap in simulated time")
    # tracks: (t, x, y, heading clockwise unwrapped, v); /truth's yaw is counter-clockwise
    truth_a, truth_b = ((r.t, r.x, r.y, -r.yaw, r.v) for r in (a, b))
    t = _instants(a.t, b.t, t0, t1)
    diffs = _track_diff(truth_a, truth_b, t)
    truth = {name: _deviation(name, units, t, d, tol[key])
             for (name, units, key), d in zip(_SIGNALS, diffs)}
    series = {"t": t, "pos": diffs[0], "heading": diffs[1], "speed": diffs[2],
              "a_xy": (a.x, a.y), "b_xy": (b.x, b.y)}
    odometry, mt = {}, None
    if a.has_micro and b.has_micro:
        odo_a, odo_b = ((r.mt, r.mx, r.my, r.mhdg, r.mv) for r in (a, b))
        mt = _instants(a.mt, b.mt, max(a.mt[0], b.mt[0]), min(a.mt[-1], b.mt[-1]))
    if mt is not None and mt.size:
        diffs = _track_diff(odo_a, odo_b, mt)
        odometry = {name: _deviation(name, units, mt, d, tol[key])
                    for (name, units, key), d in zip(_SIGNALS, diffs)}
        series.update(odo_t=mt, odo_pos=diffs[0], odo_heading=diffs[1], odo_speed=diffs[2])
    else:
        warnings.append("odometry not compared: "
                        + ("the runs' /micro/data do not overlap" if mt is not None
                           else "a run has no /micro/data"))
    legs = []
    starts = [c for c in a.commands if t0 <= c < t1]
    if len(starts) < len(a.commands):
        warnings.append(f"{len(a.commands) - len(starts)} of run A's commands fall outside "
                        f"the compared span; their legs are left out")
    for i, ts in enumerate(starts):
        te = starts[i + 1] if i + 1 < len(starts) else float(t1)
        pos, hdg, v = (float(d[0]) for d in _track_diff(truth_a, truth_b, np.array([te])))
        leg = LegEnd(a.commands.index(ts) + 1, float(ts), float(te), pos, hdg, v)
        if odometry and mt[0] <= te:
            # the last leg's end may follow the last micro_data: that one then
            one = np.array([min(te, mt[-1])])
            leg.odo_pos_mm, leg.odo_heading_deg, leg.odo_speed_mm_s = \
                (float(d[0]) for d in _track_diff(odo_a, odo_b, one))
        legs.append(leg)
    return Comparison(a.folder, b.folder, {"A": a.info(), "B": b.info()}, float(t0), float(t1),
                      truth, odometry, legs, tol, warnings, series)


def plot(c: Comparison, path: Path) -> Path:
    """compare.png: both paths, and the position, heading and speed deviations (/truth
    solid, odometry dotted) against simulated time with the thresholds and the legs'
    ends marked."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    s = c.series
    fig = plt.figure(figsize=(12, 7.5))
    gs = fig.add_gridspec(3, 2, width_ratios=(1, 1.6))
    ax = fig.add_subplot(gs[:, 0])
    ax.plot(*s["a_xy"], label=f"A {c.run_a.name}")
    ax.plot(*s["b_xy"], "--", label=f"B {c.run_b.name}")
    ax.set_xlabel("x, mm")
    ax.set_ylabel("y, mm")
    ax.set_title("/truth paths")
    ax.axis("equal")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best", fontsize=8)
    panels = (("pos", "position, mm", "pos_mm", True), ("heading", "heading B - A, deg",
                                                       "heading_deg", False),
              ("speed", "speed B - A, mm/s", "speed_mm_s", False))
    first = None
    for row, (key, label, tol_key, positive) in enumerate(panels):
        ax = fig.add_subplot(gs[row, 1], sharex=first)
        first = first or ax
        ax.plot(s["t"], s[key], label="/truth")
        if f"odo_{key}" in s:
            ax.plot(s["odo_t"], s[f"odo_{key}"], ":", label="odometry")
        tol = c.tolerances[tol_key]
        for sign in ((1,) if positive else (1, -1)):
            ax.axhline(sign * tol, color="r", lw=0.8, alpha=0.6)
        for leg in c.legs:
            ax.axvline(leg.t_end, color="k", lw=0.6, alpha=0.3)
        ax.set_ylabel(label)
        ax.grid(True, alpha=0.3)
        if row == 0:
            ax.set_title("deviation of B from A (red: thresholds, grey: leg ends)")
            ax.legend(loc="best", fontsize=8)
    ax.set_xlabel("simulated time, s")
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return Path(path)


def _nonneg(text: str) -> float:
    import argparse
    import math

    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not math.isfinite(v) or v < 0:
        raise argparse.ArgumentTypeError(f"{text!r}: a finite number of at least 0")
    return v


def add_arguments(parser) -> None:
    """Arguments of `navkit compare`."""
    parser.add_argument("run_a", type=Path, metavar="RUN_A",
                        help="a navkit sim output folder (or its run.mcap)")
    parser.add_argument("run_b", type=Path, metavar="RUN_B", help="the run compared with RUN_A")
    parser.add_argument("--plot", type=Path, default=Path("compare.png"), metavar="FILE",
                        help="the plot (default: compare.png in the current folder)")
    parser.add_argument("--no-plot", action="store_true", help="no plot")
    parser.add_argument("--json", type=Path, default=None, metavar="FILE",
                        help="also write the figures as JSON")
    t = DEFAULT_TOLERANCES
    parser.add_argument("--pos-tol", type=_nonneg, default=t["pos_mm"], metavar="MM",
                        help=f"position threshold, mm (default {t['pos_mm']:g})")
    parser.add_argument("--heading-tol", type=_nonneg, default=t["heading_deg"], metavar="DEG",
                        help=f"heading threshold, deg (default {t['heading_deg']:g})")
    parser.add_argument("--speed-tol", type=_nonneg, default=t["speed_mm_s"], metavar="MM_S",
                        help=f"speed threshold, mm/s (default {t['speed_mm_s']:g})")
    parser.add_argument("--check", action="store_true",
                        help="exit 1 unless every leg's end is within --pos-tol and --heading-tol")


def run(args) -> int:
    """Print the comparison, write the plot (and JSON); 0, or 1 for runs that cannot be
    compared (one line on stderr) and with --check for a leg's end beyond the thresholds."""
    tol = {"pos_mm": args.pos_tol, "heading_deg": args.heading_tol, "speed_mm_s": args.speed_tol}
    try:
        c = compare_runs(args.run_a, args.run_b, tol)
    except CompareError as e:
        print(f"navkit compare: {e}", file=sys.stderr)
        return 1
    try:
        print(c.text())
        if not args.no_plot:
            plot(c, args.plot)
            print(f"plot     {args.plot}")
        if args.json:
            args.json.write_text(json.dumps(c.to_dict(), indent=2) + "\n")
            print(f"json     {args.json}")
    except BrokenPipeError:             # e.g. | head: the reader has what it wanted
        return 0
    except OSError as e:
        print(f"navkit compare: {e.filename}: {e.strerror}", file=sys.stderr)
        return 1
    if args.check and not c.legs_within(args.pos_tol, args.heading_tol):
        pos, hdg = c.worst_leg_end()
        print(f"navkit compare: a leg's end is beyond {args.pos_tol:g} mm / {args.heading_tol:g} deg "
              f"(worst {pos:.3g} mm, {hdg:.3g} deg)", file=sys.stderr)
        return 1
    return 0
