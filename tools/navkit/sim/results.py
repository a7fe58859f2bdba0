"""Reading a run's outputs back: `load(out_dir)` -> RunResult with the summary and every
MCAP message by topic (for tests, notebooks and scripts).

Times are simulated seconds; message fields are as logged (raw spec values for decoded
frames, mm / deg / mm/s for /truth).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

__all__ = ["RunResult", "load"]


@dataclass
class RunResult:
    """One run: `summary` (summary.json), `topics` {topic: [(t_s, message dict), ...]}
    in log-time order, and `metadata` (the MCAP metadata record)."""

    out: Path
    summary: dict
    topics: dict = field(default_factory=dict)
    metadata: dict = field(default_factory=dict)

    def messages(self, topic: str) -> list:
        """[(t_s, message), ...] of `topic` (empty if none)."""
        return self.topics.get(topic, [])

    @property
    def truth(self) -> list:
        """The /truth messages (dicts with t, x_mm, ...)."""
        return [m for _, m in self.messages("/truth")]

    def truth_between(self, t0: float, t1: float = float("inf")) -> list:
        """/truth rows with t0 <= t <= t1 (s)."""
        return [m for m in self.truth if t0 <= m["t"] <= t1]

    def truth_at(self, t: float) -> dict:
        """The last /truth row at or before t (s)."""
        best = None
        for m in self.truth:
            if m["t"] > t + 1e-9:
                break
            best = m
        if best is None:
            raise ValueError(f"no /truth row at or before {t} s")
        return best

    def micro_between(self, t0: float, t1: float = float("inf")) -> list:
        """/micro/data messages (decoded fields) logged with t0 <= t <= t1 (s)."""
        return [m for t, m in self.messages("/micro/data") if t0 <= t <= t1]

    def stopped_since(self, speed_mm_s: float = 1.0, w_deg_s: float = 0.5) -> float | None:
        """Simulated time (s) after which the robot stayed slower than `speed_mm_s` and
        `w_deg_s`; None if it was still moving at the end."""
        since = None
        for m in self.truth:
            if abs(m["v_mm_s"]) < speed_mm_s and abs(m["w_deg_s"]) < w_deg_s:
                if since is None:
                    since = m["t"]
            else:
                since = None
        return since


def load(out: str | Path) -> RunResult:
    """Read summary.json and run.mcap of the run in folder `out`."""
    from mcap.reader import make_reader

    out = Path(out)
    summary = json.loads((out / "summary.json").read_text()) \
        if (out / "summary.json").exists() else {}
    res = RunResult(out=out, summary=summary)
    with open(out / "run.mcap", "rb") as f:
        reader = make_reader(f)
        for _schema, channel, message in reader.iter_messages(log_time_order=True):
            res.topics.setdefault(channel.topic, []).append(
                (message.log_time / 1e9, json.loads(message.data)))
        for rec in reader.iter_metadata():
            res.metadata.update(rec.metadata)
    return res
