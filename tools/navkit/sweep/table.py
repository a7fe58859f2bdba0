"""A sweep's results: the figures of one run (from its summary.json), the table of all
runs (results.csv, and results.parquet when pyarrow is installed) and the summary plot.

The table holds only what the runs determine (no wall-clock values), one row per run in
run order, so a sweep gives the same table whatever its worker count and the order in
which runs finish.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

__all__ = ["FIGURES", "figures", "columns", "rows", "write_table", "summary_plot",
           "headline"]

# figure -> what it is (units). Failed runs leave these empty.
FIGURES = {
    "x_mm": "final x of /truth, mm (start pose frame, x forward)",
    "y_mm": "final y of /truth, mm (left)",
    "heading_deg": "final heading of /truth, deg clockwise, 0..360",
    "v_mm_s": "final forward speed of /truth, mm/s",
    "odo_x_mm": "the micro's odometry X in its last micro_data, mm",
    "odo_y_mm": "the micro's odometry Y in its last micro_data, mm",
    "odo_heading_deg": "the micro's gyro heading in its last micro_data, deg clockwise",
    "odo_err_mm": "distance from the micro's odometry X/Y to the /truth position, mm",
    "odo_err_deg": "micro heading minus /truth heading, deg, wrapped to -180..180",
    # err_<key> (and err_pos_mm) follow here when the mission has an [expect] table
    "watchdog_stops": "watchdog stops the micro reported (rising edges), count",
    "h2m_sent": "frames the host sent to the micro, count",
    "h2m_received": "frames the micro's parser accepted, count",
    "m2h_sent": "frames the micro sent to the host, count",
    "m2h_received": "frames the host's parser accepted, count",
    "crc_errors": "CRC errors, both directions, count",
    "resyncs": "rejected stretches of bytes, both directions, count",
    "planner_accepted": "planner commands the host accepted, count",
    "planner_refused": "planner commands not accepted (rejected, not implemented, timeout), count",
    "host_state": "the host at the end: running, exited, killed",
    "host_exit": "the host's exit status (0: it shut down normally at the end)",
    "frames": "host frames, count",
    "sim_time_s": "simulated time, s",
}
_ERR_AFTER = "odo_err_deg"       # expectation errors go after this figure


def _wrap180(deg: float) -> float:
    """`deg` wrapped into -180 (excluded) .. 180 (included)."""
    w = math.fmod(deg, 360.0)
    if w > 180.0:
        w -= 360.0
    elif w <= -180.0:
        w += 360.0
    return w


def figures(summary: dict, expect: dict | None = None) -> dict:
    """The table's figures of one run from its summary.json `summary`: the final /truth
    pose and speed, the micro's final odometry and its error from /truth, and for each key
    of the mission's [expect] table `expect` err_<key> = final /truth value minus the
    expected one (headings wrapped to -180..180 deg), plus err_pos_mm (the distance to the
    expected x_mm, y_mm) when both are expected; watchdog stops, link counts, the planner's
    verdicts, the host's state."""
    from navkit import protocol

    t = summary.get("truth") or {}
    micro = summary.get("micro") or {}
    link = summary.get("link") or {}
    h2m, m2h = link.get("host_to_micro") or {}, link.get("micro_to_host") or {}
    planner = summary.get("planner") or {}
    # derived figures rounded to 1e-6 mm or deg: no float noise in the table
    r6 = lambda v: None if v is None else round(v, 6)  # noqa: E731
    f = {k: t.get(k) for k in ("x_mm", "y_mm", "heading_deg", "v_mm_s")}
    scale = protocol.SPEC.messages["micro_data"].field("heading").scale
    f["odo_x_mm"] = micro.get("x")
    f["odo_y_mm"] = micro.get("y")
    f["odo_heading_deg"] = r6(micro["heading"] * scale) if "heading" in micro else None
    if None not in (f["x_mm"], f["y_mm"], f["odo_x_mm"], f["odo_y_mm"]):
        f["odo_err_mm"] = r6(math.hypot(f["odo_x_mm"] - f["x_mm"], f["odo_y_mm"] - f["y_mm"]))
    else:
        f["odo_err_mm"] = None
    f["odo_err_deg"] = (r6(_wrap180(f["odo_heading_deg"] - f["heading_deg"]))
                        if None not in (f["odo_heading_deg"], f["heading_deg"]) else None)
    for k, want in (expect or {}).items():
        got = t.get(k)
        d = None if got is None else got - want
        f[f"err_{k}"] = r6(_wrap180(d) if d is not None and k == "heading_deg" else d)
    if expect and "x_mm" in expect and "y_mm" in expect:
        dx, dy = f.get("err_x_mm"), f.get("err_y_mm")
        f["err_pos_mm"] = r6(math.hypot(dx, dy)) if None not in (dx, dy) else None
    f["watchdog_stops"] = summary.get("watchdog_stops")
    f["h2m_sent"] = h2m.get("frames_sent")
    f["h2m_received"] = h2m.get("frames_received")
    f["m2h_sent"] = m2h.get("frames_sent")
    f["m2h_received"] = m2h.get("frames_received")
    f["crc_errors"] = link.get("crc_errors")
    f["resyncs"] = link.get("resyncs")
    f["planner_accepted"] = planner.get("accepted")
    f["planner_refused"] = len(planner.get("refused") or [])
    f["host_state"] = (summary.get("host") or {}).get("state")
    f["host_exit"] = (summary.get("host") or {}).get("exit_status")
    f["frames"] = summary.get("frames")
    f["sim_time_s"] = summary.get("sim_time_s")
    return f


def _expect_columns(expect: dict | None) -> list:
    cols = [f"err_{k}" for k in (expect or {})]
    if expect and "x_mm" in expect and "y_mm" in expect:
        cols.append("err_pos_mm")
    return cols


def columns(varied: list, expect: dict | None = None, extra: list = ()) -> list:
    """The table's columns: run, seed, the varied keys, status, the FIGURES (with the
    expectation errors after the odometry's), `extra` (figures of an extract function),
    error (the failed run's message)."""
    figs = []
    for k in FIGURES:
        figs.append(k)
        if k == _ERR_AFTER:
            figs += _expect_columns(expect)
    return ["run", "seed", *varied, "status", *figs, *extra, "error"]


def rows(results: list, varied: list, expect: dict | None = None) -> tuple[list, list]:
    """(columns, rows) of RunResults `results` in run order; each row a list of values
    (None: empty)."""
    results = sorted(results, key=lambda r: r.index)
    base = set(columns(varied, expect))
    extra = list(dict.fromkeys(k for r in results for k in r.figures if k not in base))
    cols = columns(varied, expect, extra)
    out = []
    for r in results:
        row = {"run": r.index, "seed": r.spec.seed, "status": r.status, "error": r.error}
        row.update({k: r.spec.plant.get(k) for k in varied})
        row.update(r.figures)
        out.append([row.get(c) for c in cols])
    return cols, out


def write_table(results: list, varied: list, out: Path, expect: dict | None = None) -> list:
    """Write `out`/results.csv (and `out`/results.parquet when pyarrow is installed) of
    RunResults `results`; returns the files written. Floats are written in Python's
    shortest round-trip form, empty cells for missing values."""
    cols, data = rows(results, varied, expect)
    out = Path(out)
    path = out / "results.csv"
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh, lineterminator="\n")
        w.writerow(cols)
        for row in data:
            w.writerow("" if v is None else v for v in row)
    written = [path]
    try:
        import pyarrow
        import pyarrow.parquet
    except ImportError:
        return written
    table = pyarrow.Table.from_pylist([dict(zip(cols, row)) for row in data])
    pyarrow.parquet.write_table(table, out / "results.parquet")
    written.append(out / "results.parquet")
    return written


def headline(expect: dict | None) -> tuple[str, str]:
    """(figure, label) the summary plot shows against each varied key: the distance to
    the expected position when the mission expects x_mm and y_mm, else the first
    expectation's error, else the micro's odometry error."""
    if expect and "x_mm" in expect and "y_mm" in expect:
        return "err_pos_mm", "distance to the expected end, mm"
    if expect:
        k = next(iter(expect))
        return f"err_{k}", f"final {k} minus expected"
    return "odo_err_mm", "odometry error at the end, mm"


def summary_plot(results: list, varied: list, path: Path, expect: dict | None = None,
                 title: str = "") -> Path:
    """summary.png: the final /truth positions of the runs that finished (the expected
    end marked when the mission has one) and, for each varied key (at most 4), the
    headline figure against it; failed runs as red crosses on the key's axis."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ok = [r for r in results if r.status == "ok"]
    bad = [r for r in results if r.status != "ok"]
    keys = list(varied)[:4]
    fig, axes = plt.subplots(1, 1 + len(keys), figsize=(4.2 * (1 + len(keys)), 4.0),
                             squeeze=False)
    ax = axes[0][0]
    seeds = [r.spec.seed for r in ok]
    sc = ax.scatter([r.figures["x_mm"] for r in ok], [r.figures["y_mm"] for r in ok],
                    s=14, **({"c": seeds, "cmap": "viridis"} if seeds else {}))
    if expect and "x_mm" in expect and "y_mm" in expect:
        ax.plot([expect["x_mm"]], [expect["y_mm"]], "r+", ms=14, label="expected")
        ax.legend(loc="best", fontsize=8)
    if len(set(seeds)) > 1:
        fig.colorbar(sc, ax=ax, label="seed")
    ax.set_xlabel("final x, mm")
    ax.set_ylabel("final y, mm")
    ax.set_title("final /truth position")
    ax.axis("equal")
    ax.grid(True, alpha=0.3)
    fig_key, label = headline(expect)
    for ax, key in zip(axes[0][1:], keys):
        pts = [(r.spec.plant.get(key), r.figures.get(fig_key)) for r in ok]
        pts = [(x, y) for x, y in pts if x is not None and y is not None]
        ax.plot([x for x, _ in pts], [y for _, y in pts], "o", ms=4)
        xs = [r.spec.plant.get(key) for r in bad if r.spec.plant.get(key) is not None]
        if xs:
            ax.plot(xs, [0.0] * len(xs), "rx", ms=8, label="failed")
            ax.legend(loc="best", fontsize=8)
        ax.set_xlabel(key)
        ax.set_ylabel(label)
        ax.grid(True, alpha=0.3)
    fig.suptitle(title or f"{len(results)} runs, {len(bad)} failed")
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return Path(path)
