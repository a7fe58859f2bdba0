"""Reading a run's outputs back: `load(out_dir)` -> RunResult with the summary and every
MCAP message by topic (for tests, notebooks and scripts).

Times are simulated seconds; message fields are as logged (raw spec values for decoded
frames, mm / deg / mm/s for /truth).

`read_mcap(path)` reads any run.mcap, also one whose run was killed: the file then ends
without its summary and footer (and maybe inside a record), so it is read record by record
up to the last whole record, with a warning on stderr naming the file, the byte where it
ends and the last log time read. `iter_mcap(path)` streams the messages of a file of any
size in bounded memory (one record at a time), in file order.
"""

from __future__ import annotations

import io
import json
import operator
import struct
import sys
from dataclasses import dataclass, field
from pathlib import Path

__all__ = ["RunResult", "McapContents", "load", "read_mcap", "iter_mcap"]

_MAGIC = b"\x89MCAP0\r\n"
_FOOTER_OPCODE = 0x02
_RECORD_HEAD = struct.Struct("<BQ")       # opcode, length of the record's content (bytes)


@dataclass
class McapContents:
    """What `read_mcap` found: `messages` [(log time ns, topic, JSON bytes), ...] in log-time
    order (file order among equal times), `metadata` (the metadata records' name -> value
    pairs) and `truncated`: None for a whole file, else {"size": file bytes, "read_bytes":
    bytes of whole records read, "last_log_time_s": the latest log time read (s, None if
    no message)}."""

    messages: list
    metadata: dict
    truncated: dict | None = None


def _whole_records(data: bytes) -> tuple[int, bool]:
    """(end offset of the last whole record after the leading magic, whether it is the
    footer followed by the closing magic: the file is whole)."""
    at, n = len(_MAGIC), len(data)
    while at + _RECORD_HEAD.size <= n:
        opcode, length = _RECORD_HEAD.unpack_from(data, at)
        nxt = at + _RECORD_HEAD.size + length
        if nxt > n:
            break
        at = nxt
        if opcode == _FOOTER_OPCODE:
            return at, data[at:at + len(_MAGIC)] == _MAGIC
    return at, False


def _messages(records, path: Path, metadata: dict | None = None):
    """(log time ns, topic, JSON bytes) of every Message among the mcap `records` of file
    `path`, in file order, then None at the Footer record (and no more); the Metadata
    records' name -> value pairs go into `metadata` if given. McapError naming the file
    for a message on a channel not announced yet."""
    from mcap.exceptions import McapError
    from mcap.records import Channel, Footer, Message, Metadata

    chans = {}
    for rec in records:
        cls = rec.__class__
        if cls is Message:
            topic = chans.get(rec.channel_id)
            if topic is None:
                raise McapError(f"{path}: a message on channel {rec.channel_id} before "
                                f"that channel's record")
            yield rec.log_time, topic, rec.data
        elif cls is Channel:
            chans[rec.id] = rec.topic
        elif cls is Metadata:
            if metadata is not None:
                metadata.update(rec.metadata)
        elif cls is Footer:
            yield None
            return


def _warn_truncated(path: Path, last_ns: int | None, read: str = "") -> None:
    """The warning on stderr for MCAP file `path` cut before its footer: its whole records
    were read (`read`: which bytes, if said), the last message at log time `last_ns` (ns;
    None: no message)."""
    upto = f"messages up to log time {last_ns / 1e9:.3f} s" if last_ns is not None else "no messages"
    print(f"warning: {path}: truncated (no summary or footer: the run did not finish); "
          f"read its whole records{read}: {upto}", file=sys.stderr)


def iter_mcap(path: str | Path, topics=None):
    """Messages of MCAP file `path` as (log time ns, topic, JSON bytes), in file order
    (log-time order but for a few ms in a real-time run), only the topics in `topics` (all
    if None); one record in memory at a time, whatever the file's size. A file without its
    footer (a killed run, or a record that does not decode) ends at its last whole record,
    with read_mcap's warning on stderr. McapError naming the file if it is not MCAP."""
    from mcap.exceptions import EndOfFile, McapError
    from mcap.stream_reader import StreamReader

    path = Path(path)
    want = None if topics is None else set(topics)
    last, footer = None, False
    with open(path, "rb") as f:
        if f.read(len(_MAGIC)) != _MAGIC:
            raise McapError(f"{path}: not an MCAP file (it does not start with the MCAP magic)")
        f.seek(0)
        try:
            for m in _messages(StreamReader(f).records, path):
                if m is None:   # every record is read; whole if the closing magic follows
                    footer = f.read(len(_MAGIC)) == _MAGIC
                    break
                last = m[0]
                if want is None or m[1] in want:
                    yield m
        except (EndOfFile, struct.error, RuntimeError, ValueError):
            pass            # cut inside a record: what was read before it stands
        if not footer:
            _warn_truncated(path, last)


def read_mcap(path: str | Path, topics=None) -> McapContents:
    """Messages and metadata of MCAP file `path` (only the topics in `topics`, all if None),
    read front to back with the mcap package's StreamReader. A file without its footer (a
    killed run) is read up to its last whole record (whole chunks: a chunk's messages come
    only with the whole chunk) and a warning goes to stderr. McapError (mcap.exceptions)
    naming the file if it is not an MCAP file or a record does not decode."""
    from mcap.exceptions import EndOfFile, McapError
    from mcap.stream_reader import StreamReader

    path = Path(path)
    data = path.read_bytes()
    if data[:len(_MAGIC)] != _MAGIC:
        raise McapError(f"{path}: not an MCAP file (it does not start with the MCAP magic; "
                        f"{len(data)} bytes)")
    end, whole = _whole_records(data)
    want = None if topics is None else set(topics)
    messages, metadata = [], {}
    try:
        for m in _messages(StreamReader(io.BytesIO(data if whole else data[:end])).records, path,
                           metadata):
            if m is not None and (want is None or m[1] in want):
                messages.append(m)
    except EndOfFile:
        if whole:
            raise McapError(f"{path}: ends inside its summary section") from None
    except (struct.error, RuntimeError, ValueError) as e:   # a record that does not decode
        raise McapError(f"{path}: a record does not decode: {e}") from None
    messages.sort(key=operator.itemgetter(0))       # stable: file order among equal times
    truncated = None
    if not whole:
        last_ns = messages[-1][0] if messages else None
        truncated = {"size": len(data), "read_bytes": end,
                     "last_log_time_s": last_ns / 1e9 if last_ns is not None else None}
        _warn_truncated(path, last_ns, f", bytes 0..{end} of {len(data)}")
    return McapContents(messages, metadata, truncated)


@dataclass
class RunResult:
    """One run: `summary` (summary.json), `topics` {topic: [(t_s, message dict), ...]}
    in log-time order, `metadata` (the MCAP metadata record) and `truncated` (None, or
    where run.mcap of a killed run ends: McapContents)."""

    out: Path
    summary: dict
    topics: dict = field(default_factory=dict)
    metadata: dict = field(default_factory=dict)
    truncated: dict | None = None     # see McapContents: run.mcap of a killed run

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
    """Read summary.json (empty if the run left none) and run.mcap (also a killed run's:
    see read_mcap) of the run in folder `out`."""
    out = Path(out)
    summary = json.loads((out / "summary.json").read_text()) \
        if (out / "summary.json").exists() else {}
    mc = read_mcap(out / "run.mcap")
    res = RunResult(out=out, summary=summary, metadata=mc.metadata, truncated=mc.truncated)
    loads, topics = json.loads, res.topics
    for t_ns, topic, data in mc.messages:
        msgs = topics.get(topic)
        if msgs is None:
            msgs = topics[topic] = []
        msgs.append((t_ns / 1e9, loads(data)))
    return res
