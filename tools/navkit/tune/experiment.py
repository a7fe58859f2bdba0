"""Experiment data for the tuner: wheel duty and speed records from a co-simulation's
run.mcap or a robot's host datalog, and the co-simulation runs the tuner makes.

Both logs carry the micro's datalog words (micro_data.mc_datalog, selected by
mc_datalog_cmd; the spec's enum mc_datalog names the four words of each selection). The
selections the tuner reads: `wheels` (duty and speed of both wheels), `wheel_left` and
`wheel_right` (setpoint, speed, duty, integral of one wheel). A record is the stretch of
samples while an excitation runs (micro_status bit excite_active), with the sample before
it (the wheel at rest), resampled with a hold onto a uniform grid at the median sample
period.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

__all__ = ["ExperimentError", "Record", "records_from_mcap", "records_from_datalog", "records_from_log",
           "uniform", "mission_text", "run_cosim", "speed_series"]

WHEEL_SELECTIONS = ("wheels", "wheel_left", "wheel_right")


class ExperimentError(ValueError):
    """A log or mission that does not hold the experiment the tuner needs; names the file."""


@dataclass
class Record:
    """One wheel's excitation: t (s, uniform from 0), duty (1, -1..1), speed (mm/s, the
    firmware's measured wheel speed), ts (s, sample period), wheel ('left'/'right'), source."""

    t: np.ndarray
    duty: np.ndarray
    speed: np.ndarray
    ts: float
    wheel: str
    source: str


def _enum(name: str):
    from navkit import protocol

    return protocol.SPEC.enums.get(name)


def _word_names() -> dict:
    """{selection code: (word names)} of the wheel selections the spec knows."""
    e = _enum("mc_datalog")
    if e is None:
        return {}
    words = getattr(e, "words", {}) or {}
    return {e.values[k]: tuple(words[k]) for k in WHEEL_SELECTIONS if k in e.values and k in words}


def _excite_bit() -> int | None:
    f = _enum("micro_status")
    return f.values.get("excite_active") if f is not None else None


def _columns(words: tuple) -> dict:
    """{wheel: (duty word index, speed word index, duty scale)} of one selection's word names."""
    out = {}
    for wheel in ("left", "right"):
        duty = [i for i, n in enumerate(words) if n.startswith("duty") and (wheel in n or "_" not in n[5:])]
        speed = [i for i, n in enumerate(words) if n.startswith("speed") and (wheel in n or n == "speed_mm_s")]
        if duty and speed:
            d = words[duty[0]]
            scale = 1e-4 if d.endswith("_e4") else 1e-3 if d.endswith("_e3") else 1.0
            out[wheel] = (duty[0], speed[0], scale)
    return out


def uniform(t: np.ndarray, *cols: np.ndarray) -> tuple:
    """(ts, t_uniform from 0, cols held onto it): ts the median sample period (s)."""
    t = np.asarray(t, float)
    if len(t) < 2:
        raise ExperimentError("fewer than 2 samples")
    ts = float(np.median(np.diff(t)))
    if not ts > 0:
        raise ExperimentError("samples without increasing time")
    n = int(math.floor((t[-1] - t[0]) / ts + 1e-6)) + 1
    tu = t[0] + np.arange(n) * ts
    idx = np.clip(np.searchsorted(t, tu + 1e-9 * ts, side="right") - 1, 0, len(t) - 1)
    return (ts, tu - tu[0]) + tuple(np.asarray(c, float)[idx] for c in cols)


def _records(source: str, t, sel, status, words) -> list[Record]:
    """Records of both wheels from per-sample time (s), selection code, status bits and the
    four datalog words."""
    names = _word_names()
    bit = _excite_bit()
    t, sel, status = np.asarray(t, float), np.asarray(sel, int), np.asarray(status, int)
    words = np.asarray(words, float).reshape(len(t), -1)
    active = ((status >> bit) & 1).astype(bool) if bit is not None else np.isin(sel, list(names))
    if not active.any():
        raise ExperimentError(f"{source}: no excitation in the log (micro_status excite_active never set): "
                              f"run an experiment (excite_mode) with mc_datalog_cmd = wheels")
    # the longest run of active samples, plus the sample before it (at rest)
    edges = np.diff(np.concatenate([[0], active.astype(int), [0]]))
    starts, ends = np.nonzero(edges == 1)[0], np.nonzero(edges == -1)[0]
    k = int(np.argmax(ends - starts))
    a, b = max(starts[k] - 1, 0), ends[k]
    out = []
    for code, wnames in names.items():
        on = sel[a:b] == code
        if on.sum() < 0.9 * (b - a):
            continue
        for wheel, (di, si, scale) in _columns(wnames).items():
            ts, tu, duty, speed = uniform(t[a:b][on], words[a:b][on][:, di] * scale, words[a:b][on][:, si])
            if np.ptp(duty) > 0:
                out.append(Record(tu, duty, speed, ts, wheel, source))
    if not out:
        sels = sorted({int(s) for s in sel[a:b]})
        raise ExperimentError(f"{source}: the excitation was logged with mc_datalog selection {sels}, not one "
                              f"carrying duty and speed ({', '.join(WHEEL_SELECTIONS)})")
    return out


def records_from_mcap(path: Path) -> list[Record]:
    """Wheel records of a co-simulation's run.mcap (/micro/data)."""
    from navkit.sim.results import read_mcap

    path = Path(path)
    try:
        mc = read_mcap(path, topics={"/micro/data"})
    except Exception as e:  # a file that is not MCAP: one line naming it
        raise ExperimentError(f"{path}: not a readable run.mcap ({e})") from None
    import json

    t, sel, status, words = [], [], [], []
    for t_ns, _, data in mc.messages:
        m = json.loads(data)
        if "mc_datalog" not in m:
            raise ExperimentError(f"{path}: /micro/data has no mc_datalog words")
        t.append(t_ns / 1e9)
        sel.append(m.get("mc_datalog_sel", 0))
        status.append(m.get("status", 0))
        words.append(m["mc_datalog"])
    if not t:
        raise ExperimentError(f"{path}: no /micro/data messages")
    return _records(str(path), t, sel, status, words)


def records_from_datalog(path: Path) -> list[Record]:
    """Wheel records of a host datalog (seed format): columns time_s, micro_status, the
    selection and the four datalog words (names found by their spec names)."""
    from navkit.plot import read_datalog

    path = Path(path)
    try:
        params, rows = read_datalog(path)
    except (OSError, ValueError) as e:
        raise ExperimentError(f"{path}: {e}") from None
    names = [p[0] for p in params]
    arr = np.asarray(rows, float).reshape(len(rows), len(names))

    def col(*cands):
        for c in cands:
            if c in names:
                return names.index(c)
        return None

    it, ist = col("time_s"), col("micro_status")
    isel = col("mc_datalog_sel", "mc_datalog_cmd", "mc_datalog")
    iw = [col(f"mc_datalog{i}", f"mc_datalog_{i}", f"mc_datalog[{i}]") for i in range(4)]
    missing = [n for n, i in (("time_s", it), ("micro_status", ist), ("mc_datalog_sel", isel),
                              ("mc_datalog0..3", None if None in iw else 0)) if i is None]
    if missing:
        raise ExperimentError(f"{path}: the datalog lacks the column(s) {', '.join(missing)} "
                              f"(it has {', '.join(names)})")
    if len(arr) < 2:
        raise ExperimentError(f"{path}: fewer than 2 rows")
    return _records(str(path), arr[:, it], arr[:, isel], arr[:, ist], arr[:, iw])


def records_from_log(path: Path) -> list[Record]:
    """Records of a run.mcap (by its magic) or a host datalog."""
    path = Path(path)
    if not path.is_file():
        raise ExperimentError(f"{path}: no such file")
    with open(path, "rb") as f:
        head = f.read(8)
    if head == b"\x89MCAP0\r\n":
        return records_from_mcap(path)
    return records_from_datalog(path)


# ---------------------------------------------------------------- co-simulation runs

def _toml_value(v) -> str:
    import json

    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, float)):
        return repr(v)
    return json.dumps(str(v))


def mission_text(base, duration_s: float, commands: list[dict], plant: dict | None = None, note: str = "") -> str:
    """A mission file's text: `base` (a loaded Mission: its world and [plant] table, then
    `plant` overrides on top) with `commands` ([{t, field: raw value}, ...])."""
    lines = [f"# {note}" if note else "# written by navkit tune", f"duration_s = {duration_s!r}"]
    if base is not None and base.world is not None:
        lines.append(f"world = {_toml_value(str(Path(base.world).resolve()))}")
    table = dict(base.plant) if base is not None else {}
    table.update(plant or {})
    if table:
        lines.append("[plant]")
        lines += [f"{k} = {_toml_value(v)}" for k, v in table.items()]
    for c in commands:
        lines.append("[[command]]")
        lines += [f"{k} = {_toml_value(v)}" for k, v in c.items()]
    return "\n".join(lines) + "\n"


def run_cosim(mission_path: Path, out: Path, *, config_dir: Path | None, build: Path | None,
              frame_s: float | None = None, truth_hz: float = 50.0, seed: int = 1) -> Path:
    """Co-simulate mission file `mission_path` into `out` (no plot) and return `out`.
    Raises ExperimentError with the harness's one-line reason."""
    from navkit.sim.harness import SimError, SimOptions, run
    from navkit.sim.mission import MissionError, load

    try:
        m = load(Path(mission_path))
        run(SimOptions(mission=m, out=Path(out), seed=seed, config_dir=config_dir, build=build,
                       frame_s=frame_s, truth_hz=truth_hz, plot=False))
    except (MissionError, SimError) as e:
        raise ExperimentError(str(e)) from None
    return Path(out)


def speed_series(out: Path, t0: float, t1: float) -> tuple[np.ndarray, np.ndarray]:
    """(t s from t0, truth forward speed mm/s) of run folder `out` between t0 and t1 (s)."""
    from navkit.sim.results import read_mcap
    import json

    mc = read_mcap(Path(out) / "run.mcap", topics={"/truth"})
    rows = [json.loads(d) for _, _, d in mc.messages]
    t = np.array([r["t"] for r in rows])
    v = np.array([r["v_mm_s"] for r in rows])
    keep = (t >= t0) & (t <= t1)
    return t[keep] - t0, v[keep]


def _mission_plant(mission) -> dict:
    return dict(mission.plant) if mission is not None else {}


def load_mission(path: Path):
    """navkit.sim.mission.load, its MissionError as ExperimentError."""
    from navkit.sim.mission import MissionError, load

    try:
        return load(Path(path))
    except MissionError as e:
        raise ExperimentError(str(e)) from None


def mission_has_experiment(path: Path) -> bool:
    """True if the mission file commands an excitation (a [[command]] with excite_mode)."""
    with open(path, "rb") as f:
        doc = tomllib.load(f)
    return any(c.get("excite_mode") not in (None, 0, "none") for c in doc.get("command", []))
