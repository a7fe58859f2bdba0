"""Experiment data for the tuner: wheel duty and speed records from a co-simulation's
run.mcap or a robot's host datalog, and the co-simulation runs the tuner makes.

Both logs carry the micro's datalog words (micro_data.mc_datalog, selected by
mc_datalog_cmd; the spec's enum mc_datalog names the four words of each selection) and the
micro's clock (micro_time, ms) of each sample. The selections the tuner reads: `wheels`
(duty and speed of both wheels), `wheel_left` and `wheel_right` (setpoint, speed, duty,
integral of one wheel). An experiment is a stretch of samples while an excitation runs
(micro_status bit excite_active), with the sample before it (the wheel must be at rest)
and up to COAST_S after it (duty 0). Its duty goes on a 1 ms grid: a step experiment whose
command is in the log (run.mcap's /micro/cmd) is replayed at the micro's tick (excite.h:
offset, then offset + amplitude after excite_period) from the start tick that reproduces
every logged duty, so the fit knows when the step happened to the millisecond although the
log has a sample per host frame; otherwise (a datalog, a chirp or PRBS) each logged duty is
taken to start right after the sample before it: the dead time is then known to a sample
period only, and errs long (a slower, safer design).
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

__all__ = ["ExperimentError", "Record", "records_from_mcap", "records_from_datalog", "records_from_log",
           "mission_text", "run_cosim", "load_mission", "mission_has_experiment", "GRID_S"]

WHEEL_SELECTIONS = ("wheels", "wheel_left", "wheel_right")
GRID_S = 0.001          # s: the fit's grid, the resolution of the micro's clock (micro_time, ms)
REST_MM_S = 5.0         # mm/s: a wheel slower than this before an experiment is at rest
COAST_S = 0.5           # s: samples kept after an experiment ends (duty 0, the wheel coasting)
REPLAY_TOL = 0.0015     # duty: a replayed step must match every logged duty this closely


class ExperimentError(ValueError):
    """A log or mission that does not hold the experiment the tuner needs; names the file."""


@dataclass
class Record:
    """One wheel's experiments: `segments` (ident.Segment: duty on the GRID_S grid, the
    measured wheel speed samples, mm/s, at their grid indices), `replayed` per segment (True:
    the duty is the step experiment replayed at the micro's tick from its command; False:
    from the samples, its timing known to a sample period), `wheel`
    ('left'/'right'), `source` (the log) and `ts` (s, the grid)."""

    wheel: str
    segments: list
    replayed: list
    source: str
    ts: float = GRID_S

    @property
    def sample_period_s(self) -> float:
        """Median time between the speed samples (s)."""
        d = np.concatenate([np.diff(sg.at) for sg in self.segments if len(sg.at) > 1])
        return float(np.median(d)) * self.ts if len(d) else math.nan


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


def _columns(words: tuple) -> dict:
    """{wheel: (duty word index, speed word index, duty scale)} of one selection's word names
    (names end in their unit: duty_left_e4 is duty x 10000)."""
    out = {}
    for wheel in ("left", "right"):
        duty = [i for i, n in enumerate(words) if n.startswith("duty") and (wheel in n or n == "duty_e4")]
        speed = [i for i, n in enumerate(words) if n.startswith("speed") and (wheel in n or n == "speed_mm_s")]
        if duty and speed:
            d = words[duty[0]]
            scale = 1e-4 if d.endswith("_e4") else 1e-3 if d.endswith("_e3") else 1.0
            out[wheel] = (duty[0], speed[0], scale)
    return out


def _wheel_sign(wheels: int, wheel: str) -> float:
    """+1, -1 or 0: how a wheel's duty follows the experiment's (enum excite_wheels)."""
    e = _enum("excite_wheels").values
    if wheels == e["both"]:
        return 1.0
    if wheels == e["spin"]:
        return 1.0 if wheel == "left" else -1.0
    return 1.0 if wheels == e[wheel] else 0.0


def _replay_step(cmd: dict, wheel: str, t0_ms: int, ms: np.ndarray) -> np.ndarray:
    """Duty (1) at integer ms of a step experiment (excite.h: the offset for excite_period,
    then offset + amplitude, for excite_duration from tick 0 at t0_ms; 0 outside) on `wheel`,
    at the 1 kHz tick the fit's grid stands for."""
    k = ms - t0_ms
    on = (k >= 0) & (k < int(cmd["excite_duration"]))
    d = 0.001 * (int(cmd["excite_offset"]) + int(cmd["excite_amplitude"]) * (k >= int(cmd["excite_period"])))
    return np.where(on, d * _wheel_sign(int(cmd["excite_wheels"]), wheel), 0.0)


def _records(source: str, ms, sel, status, words, cmds=()) -> list[Record]:
    """Records of both wheels from per-sample micro time (ms), selection code, status bits,
    the four datalog words, and the excitation commands [(sample index before which it was
    sent, micro_cmd fields)] when the log has them."""
    from navkit.tune.ident import Segment

    names = _word_names()
    f = _enum("micro_status")
    bit = f.values.get("excite_active") if f is not None else None
    ms, sel, status = np.asarray(ms, np.int64), np.asarray(sel, int), np.asarray(status, int)
    words = np.asarray(words, float).reshape(len(ms), -1)
    if bit is None or not names:
        raise ExperimentError(f"{source}: this spec has no excitation experiments (micro_status excite_active)")
    active = ((status >> bit) & 1).astype(bool)
    if not active.any():
        raise ExperimentError(f"{source}: no excitation in the log (micro_status excite_active never set): "
                              f"run an experiment (excite_mode) with mc_datalog_cmd = wheels")
    edges = np.diff(np.concatenate([[0], active.astype(int), [0]]))
    runs = list(zip(np.nonzero(edges == 1)[0], np.nonzero(edges == -1)[0]))
    step = _enum("excite_mode").values["step"]
    by_wheel: dict = {}
    skipped = 0
    for k, (s, e) in enumerate(runs):
        a = s - 1
        nxt = runs[k + 1][0] if k + 1 < len(runs) else len(ms)
        b = e
        while b < nxt and ms[b] - ms[e - 1] <= COAST_S * 1000:
            b += 1
        if a < 0:
            skipped += 1
            continue
        cols = _columns(names.get(int(sel[s]), ()))
        if not cols or np.any(sel[a:b] != sel[s]):
            skipped += 1
            continue
        cmd = next((c for i, c in reversed(list(cmds)) if i <= s and int(c.get("excite_mode", 0)) != 0), None)
        grid = np.arange(ms[a], ms[b - 1] + 1)
        at = (ms[a:b] - ms[a]).astype(int)
        for wheel, (di, si, scale) in cols.items():
            duty = words[a:b, di] * scale
            speed = words[a:b, si]
            if np.ptp(duty) == 0 or abs(speed[0]) > REST_MM_S:
                continue
            u, replayed = None, False
            if cmd is not None and int(cmd["excite_mode"]) == step:
                # the logged duty of a sample is the tick's before it: find the start tick that
                # reproduces every logged duty
                for t0 in range(int(ms[s]) - 3, int(ms[s]) + 3):
                    cand = _replay_step(cmd, wheel, t0, grid)
                    if np.max(np.abs(_replay_step(cmd, wheel, t0, ms[a:b] - 1) - duty)) <= REPLAY_TOL:
                        u, replayed = cand, True
                        break
            if u is None:
                # a sample's duty is the one its tick applied; it may have changed any time
                # since the sample before: take it as changed right after that one (the
                # earliest time possible: the lag comes out at most a sample period too long,
                # which errs toward a slower, safer design)
                idx = np.clip(np.searchsorted(at, np.arange(len(grid)), side="left"), 0, len(at) - 1)
                u = duty[idx]
            by_wheel.setdefault(wheel, []).append((Segment(u, speed, at), replayed))
    out = []
    for wheel, segs in sorted(by_wheel.items()):
        if any(r for _, r in segs):  # a replayed step's timing beats a held record's
            segs = [x for x in segs if x[1]]
        out.append(Record(wheel, [sg for sg, _ in segs], [r for _, r in segs], source))
    if not out:
        raise ExperimentError(f"{source}: no usable experiment: each must start with the wheel at rest and "
                              f"be logged with mc_datalog selection {' or '.join(WHEEL_SELECTIONS)} "
                              f"({skipped} skipped)")
    return out


def records_from_mcap(path: Path) -> list[Record]:
    """Wheel records of a co-simulation's run.mcap (/micro/data, and /micro/cmd for the
    experiments' parameters)."""
    from navkit.sim.results import read_mcap

    path = Path(path)
    try:
        mc = read_mcap(path, topics={"/micro/data", "/micro/cmd"})
    except Exception as e:  # a file that is not MCAP: one line naming it
        raise ExperimentError(f"{path}: not a readable run.mcap ({e})") from None
    import json

    ms, sel, status, words, cmds = [], [], [], [], []
    for _, topic, data in mc.messages:
        m = json.loads(data)
        if topic == "/micro/cmd":
            if m.get("excite_mode"):
                cmds.append((len(ms), m))
            continue
        if "mc_datalog" not in m or "micro_time" not in m:
            raise ExperimentError(f"{path}: /micro/data has no mc_datalog words or micro_time")
        ms.append(m["micro_time"])
        sel.append(m.get("mc_datalog_sel", 0))
        status.append(m.get("status", 0))
        words.append(m["mc_datalog"])
    if not ms:
        raise ExperimentError(f"{path}: no /micro/data messages")
    return _records(str(path), ms, sel, status, words, cmds)


def records_from_datalog(path: Path) -> list[Record]:
    """Wheel records of a host datalog (seed format): columns micro_time_ms, micro_status,
    mc_datalog_sel and mc_datalog0..3. The datalog has no experiment parameters: the duty
    is held from sample to sample."""
    from navkit.plot import read_datalog

    path = Path(path)
    try:
        params, rows = read_datalog(path)
    except (OSError, ValueError) as e:
        raise ExperimentError(f"{path}: {e}") from None
    names = [p[0] for p in params]
    need = ["micro_time_ms", "micro_status", "mc_datalog_sel"] + [f"mc_datalog{i}" for i in range(4)]
    missing = [n for n in need if n not in names]
    if missing:
        raise ExperimentError(f"{path}: the datalog lacks the column(s) {', '.join(missing)} "
                              f"(it has {', '.join(names)})")
    if len(rows) < 2:
        raise ExperimentError(f"{path}: fewer than 2 rows")
    arr = np.asarray(rows, float)
    t = arr[:, names.index("micro_time_ms")]
    # a frame whose micro_data did not arrive repeats the last one: keep each sample once
    arr = arr[np.r_[True, np.diff(t) > 0]]
    col = {n: arr[:, names.index(n)] for n in need}
    return _records(str(path), col["micro_time_ms"], col["mc_datalog_sel"], col["micro_status"],
                    np.column_stack([col[f"mc_datalog{i}"] for i in range(4)]))


def records_from_log(path: Path) -> list[Record]:
    """Records of a run.mcap (by its magic) or a host datalog."""
    path = Path(path)
    if not path.exists():
        raise ExperimentError(f"{path}: no such file")
    if not path.is_file():
        raise ExperimentError(f"{path}: not a file (a run.mcap or a host datalog)")
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
              frame_s: float | None = None, truth_hz: float = 50.0, seed: int = 1,
              firmware: str = "fmu") -> dict:
    """Co-simulate mission file `mission_path` into `out` (no plot) with firmware "fmu"
    (SIL) or "avr" (PIL) and return its summary (summary.json: `control_rate_hz` is the
    rate the micro ran). Raises ExperimentError with the harness's one-line reason."""
    from navkit.sim.harness import SimError, SimOptions, run
    from navkit.sim.mission import MissionError, load

    try:
        m = load(Path(mission_path), build=build)
        return run(SimOptions(mission=m, out=Path(out), seed=seed, config_dir=config_dir, build=build,
                              frame_s=frame_s, truth_hz=truth_hz, plot=False, firmware=firmware))
    except (MissionError, SimError) as e:
        raise ExperimentError(str(e)) from None


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
