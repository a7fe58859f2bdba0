"""The run log: an MCAP file of JSON messages with JSON-schema schemas.

Log time (and publish time) of every message is the simulated time in ns, never the wall
clock, so two runs of the same (mission, config, seed) give identical message contents.
Foxglove's timeline shows it as 1970-01-01 00:00:00 UTC plus the simulated time.
Beside the navkit topics (TOPICS), the same run in Foxglove's well-known schemas
(navkit.sim.foxglove: poses, transforms, path, log; SI units).
No chunk spans more than `flush_every_s` (1 s) of simulated time (latest minus earliest log
time in it), whatever the frame period, so a run that is killed keeps everything before its
last second: chunks are closed at frame ends before a frame that would pass that span, and
within a frame (between its truth rows) when one frame is longer than it.
"""

from __future__ import annotations

import json
import operator
import pickle
import resource
import struct
from pathlib import Path

from navkit.sim import foxglove
from navkit.sim.options import STOP_SIGNALS
from navkit.sim.stops import DeferredStops

__all__ = ["Recorder", "RunLog", "message_schema", "log_ns", "TRUTH_SCHEMA", "FRAME_SCHEMA",
           "CAN_SCHEMA", "TOPICS", "HOST_STATES"]

TRUTH_SCHEMA = {
    "title": "navkit.truth",
    "description": "Ground truth of the plant FMU (start pose is the origin, x forward, y left).",
    "type": "object",
    "properties": {
        "t": {"type": "number", "description": "simulated time, s"},
        "x_mm": {"type": "number", "description": "x, mm"},
        "y_mm": {"type": "number", "description": "y (left), mm"},
        "yaw_deg": {"type": "number", "description": "yaw, deg, counter-clockwise positive, unwrapped"},
        "heading_deg": {"type": "number", "description": "heading, deg, clockwise, 0..360"},
        "distance_mm": {"type": "number", "description": "signed path length along the body axis, mm"},
        "v_mm_s": {"type": "number", "description": "forward speed, mm/s"},
        "w_deg_s": {"type": "number", "description": "yaw rate, deg/s, counter-clockwise positive"},
        "servo_deg": {"type": "array", "items": {"type": "number"}, "description": "servo angles, deg"},
        "dio_out": {"type": "integer", "description": "DIO output levels, 12-bit mask"},
    },
}

HOST_STATES = ("running", "unplugged", "killed", "exited")

FRAME_SCHEMA = {
    "title": "navkit.host_frame",
    "description": "One host frame as the harness saw it. Lockstep: every tick the host "
                   "answered (tick sent, done received). Real time: every new host frame "
                   "counter the harness saw in lisp_data at its once-per-frame read (the "
                   "host runs on its own clock, so a frame between two reads is not seen). "
                   "Once the host is gone: one message (host killed or exited, no flags) at "
                   "the first frame without it.",
    "type": "object",
    "properties": {
        "frame": {"type": "integer", "description": "host frame number: the tick's k in "
                  "lockstep, lisp_data.frame in real time; the first frame without the "
                  "host once it is gone"},
        "t": {"type": "number", "description": "simulated time of the frame, s"},
        "rx_bytes": {"type": "integer", "description": "bytes written to the host's port "
                     "since the previous message (lockstep: before the tick)"},
        "tx_bytes": {"type": "integer", "description": "bytes the host wrote since the "
                     "previous message (lockstep: in the frame)"},
        "flags": {"type": "integer", "description": "the done message's flags, bit 0 "
                  "quitting, bit 1 port closed (lockstep frames the host answered only)"},
        "host": {"type": "string", "enum": list(HOST_STATES),
                 "description": "running; unplugged: running, its port unplugged (fault "
                 "unplug); killed: by the fault kill_host; exited: ended on its own"},
    },
}

EVENT_SCHEMA = {
    "title": "navkit.event",
    "description": "A mission event applied by the harness (key typed, fault injected or ended).",
    "type": "object",
    "properties": {"t": {"type": "number"}, "kind": {"type": "string"}, "detail": {"type": "object"}},
}

CAN_SCHEMA = {
    "title": "navkit.can_frame",
    "description": "One frame on the simulated CAN bus of a `navkit sim --link can` run (only "
                   "there), as can.log has it: both directions, flow controls included, and "
                   "each error frame that destroyed a try of the frame after it (line noise). "
                   "Log time: the simulated time the frame went on the bus.",
    "type": "object",
    "properties": {
        "t": {"type": "number", "description": "simulated time, s"},
        "id": {"type": "integer", "description": "11-bit CAN identifier (spec [can.ids]); an "
               "error frame carries the identifier of the frame it destroyed"},
        "dlc": {"type": "integer", "description": "data length code, bytes (0 for an error frame)"},
        "data": {"type": "string", "description": "the data bytes, lowercase hex, 2 digits a byte"},
        "direction": {"type": "string", "enum": ["to_micro", "to_host"],
                      "description": "to_micro: sent by the host's USB-CAN adapter (candump T); "
                                     "to_host: sent by the micro, received by the adapter (R)"},
        "error_frame": {"type": "boolean", "description": "an error frame (a bit error "
                        "destroyed the frame; the controller sends it again)"},
    },
}


def _datalog_schema() -> dict:
    from navkit import protocol

    sel = protocol.SPEC.enums["mc_datalog"]
    names = "; ".join(f"{k}: {', '.join(v)}" for k, v in sel.words.items())
    return {"title": "navkit.micro_datalog",
            "description": "micro_data's four mc_datalog words named by the selection that "
                           "filled them (micro_data.mc_datalog_sel, spec enum mc_datalog and its "
                           "words; each name ends in its unit), one message per micro_data "
                           f"whose selection is not none. Words by selection: {names}.",
            "type": "object",
            "properties": {"selection": {"type": "string", "enum": list(sel.values),
                                         "description": "the selection (enum mc_datalog)"},
                           "micro_time_ms": {"type": "integer",
                                             "description": "micro_data.micro_time: the micro's "
                                                            "clock at the sample, ms"}},
            "additionalProperties": {"type": "integer"}}


# topic -> spec message whose fields it carries (None: a schema above)
TOPICS = {
    "/truth": None,
    "/micro/cmd": "micro_cmd",
    "/micro/config": None,
    "/micro/data": "micro_data",
    "/micro/datalog": None,
    "/planner/cmd": "lisp_cmd",
    "/planner/data": "lisp_data",
    "/host/frame": None,
    "/events": None,
}


def log_ns(t_s: float) -> int:
    """The log time (ns) of simulated time `t_s` (s): the whole ms nearest to it, ties to even,
    as the native row formatter (fmu/record/rowtext.h) times a row; the coupler's steps lie on
    that 1 ms grid."""
    return round(t_s * 1e3) * 1_000_000


def message_schema(name: str) -> dict:
    """JSON schema of spec message `name`: one property per field (raw integer values,
    units and scale in the description). The log time is the simulated time."""
    from navkit import protocol

    m = protocol.SPEC.messages[name]
    props = {}
    for f in m.fields:
        desc = f.doc
        if f.units:
            desc += f" Units: {f.units}" + (f" (raw x {f.scale})" if f.scale != 1 else "") + "."
        item = {"type": "integer"}
        props[f.name] = ({"type": "array", "items": item, "minItems": f.count,
                          "maxItems": f.count, "description": desc}
                         if f.count > 1 else dict(item, description=desc))
    return {"title": f"navkit.{name}", "description": m.doc, "type": "object",
            "properties": props}


def _config_schema() -> dict:
    return {"title": "navkit.micro_config",
            "description": "A config message sent to the micro (micro_cfg_geometry, "
                           "micro_cfg_motion or micro_cfg_io) with its decoded fields.",
            "type": "object",
            "properties": {"message": {"type": "string"},
                           "fields": {"type": "object"}}}


# /truth's heading_deg is written with 4 decimals and lies in 0 <= h < 360: a plant heading
# within half a last digit below 360 would print as 360.0000, so it is written as 0.
_HEADING_ROUNDS_TO_360 = 359.99995


def row_library(build: Path | None = None) -> Path:
    """The built row formatter, `<build>/fmu/record/libnavkit_record.so` (fmu/record,
    rowtext.h; default build folder: navkit.paths.build_dir())."""
    from navkit.paths import build_dir

    return Path(build or build_dir()) / "fmu" / "record" / "libnavkit_record.so"


_ROW_LIBS: dict = {}     # library path -> its ctypes CDLL, loaded once a process


def _row_lib(build: Path | None = None):
    """The row formatter's ctypes library; OSError naming the file if it is missing."""
    import ctypes
    import errno
    from ctypes import POINTER, c_char_p, c_double, c_int, c_int32, c_size_t, c_uint32, \
        c_uint64, c_void_p

    path = row_library(build)
    lib = _ROW_LIBS.get(path)
    if lib is None:
        if not path.is_file():
            raise FileNotFoundError(errno.ENOENT, "not found: build it (cmake --build <build> "
                                    "--target navkit_record)", str(path))
        lib = ctypes.CDLL(str(path))
        lib.rowtext_new.restype = c_void_p
        lib.rowtext_new.argtypes = [c_size_t, c_size_t, c_char_p, POINTER(c_uint32),
                                    POINTER(c_int32), POINTER(c_int32), c_uint64, c_int32,
                                    c_double, c_double]
        lib.rowtext_free.argtypes = [c_void_p]
        lib.rowtext_state.restype = POINTER(c_uint64 * _STATE_N)
        lib.rowtext_state.argtypes = [c_void_p]
        lib.rowtext_run.restype = c_int
        lib.rowtext_run.argtypes = None     # (program, bytes, int, int): no conversions
        lib.rowtext_fixed.restype = c_size_t
        lib.rowtext_fixed.argtypes = [c_void_p, c_double, c_int]
        lib.fieldtext_new.restype = c_void_p
        lib.fieldtext_new.argtypes = [c_size_t, c_char_p, POINTER(c_uint32), POINTER(c_uint32),
                                      c_char_p, c_size_t]
        lib.fieldtext_free.argtypes = [c_void_p]
        lib.fieldtext_out.restype = c_void_p
        lib.fieldtext_out.argtypes = [c_void_p]
        lib.fieldtext_run.restype = c_int
        lib.fieldtext_run.argtypes = None   # (program, bytes, int): no conversions
        _ROW_LIBS[path] = lib
    return lib


# A field of a row program printed as an integer (rowtext.h ROWTEXT_INT), not with decimals
ROW_INT = -1
# rowtext_run's results for an integer field that is not finite and for a row time without
# an int64 log time in ns (rowtext.h ROWTEXT_ERR_VALUE, ROWTEXT_ERR_TIME)
_ERR_VALUE, _ERR_TIME = -3, -4
_ERRORS = {_ERR_VALUE: "a value that is not finite in an integer field",
           _ERR_TIME: "a time (s) that is not finite or past 9.2e9 s"}
# rowtext.h's call block: its entries (uint64 each) and their number
(_SEQ, _OFFSET, _CHUNK_SIZE, _STOP_EVERY_NS, _CHANNEL, _OUT_LEN, _OUT_AT, _INDEX_AT,
 _STATE_N) = range(9)


def _literals(parts: list) -> tuple:
    """The literal texts `parts` (bytes) of a row or field program back to back, and the
    end of each in them (bytes, a ctypes uint32 array), as rowtext_new and fieldtext_new
    take them."""
    import ctypes

    ends, at = [], 0
    for lit in parts:
        at += len(lit)
        ends.append(at)
    return b"".join(parts), (ctypes.c_uint32 * len(ends))(*ends)


class RowText:
    """A row program of the native row formatter (fmu/record, rowtext.h): rows of
    `width` doubles (column 0 the simulated time, s) to JSON text, and to MCAP Message
    records of it. `fields`: (literal text before the field, row column or None for a
    missing one (0.0), decimals 0..9 or ROW_INT); `tail`: the text after the last field;
    an integer field is int(x) & `int_mask`; field number `wrap_field`'s values in
    [wrap_lo, wrap_hi) print as 0.0. The text of a row is what Python's % gives with
    the fields' template (%.<d>f, %d) (tests/test_sim_record_text.py)."""

    def __init__(self, build, width: int, fields: list, tail: str, int_mask: int = 0,
                 wrap_field: int = -1, wrap_lo: float = 0.0, wrap_hi: float = 0.0):
        import ctypes

        self.fields, self.tail = fields, tail
        self._lib = lib = _row_lib(build)
        n = len(fields)
        self._h = lib.rowtext_new(width, n, *_literals([f[0].encode() for f in fields]
                                                       + [tail.encode()]),
                                  (ctypes.c_int32 * n)(*[-1 if f[1] is None else f[1]
                                                         for f in fields]),
                                  (ctypes.c_int32 * n)(*[f[2] for f in fields]),
                                  int_mask, wrap_field, wrap_lo, wrap_hi)
        if not self._h:
            raise ValueError(f"row program refused by {row_library(build)}: {fields!r}")
        self._state = st = lib.rowtext_state(self._h).contents
        self.run = self._make_run(st, lib.rowtext_run, ctypes.c_void_p(self._h))

    def __del__(self):
        if getattr(self, "_h", None):
            self._lib.rowtext_free(self._h)
            self._h = None

    def records(self, raw: bytes, first: int, last: int, channel: int, seq: int, offset: int,
                chunk_size: int, stop_every_ns: int) -> tuple:
        """Rows first .. last - 1 of `raw` (rows back to back) as MCAP Message records of
        `channel`, sequence numbers from seq + 1, the first at `offset` (bytes) in its
        chunk: stops after a record that ends past `chunk_size` (bytes), after a row whose
        log time (ns) is a multiple of `stop_every_ns` (0: never), or at `last`. Returns
        (rows written, their records' bytes, [log time ns, offset, ...] per record).
        ValueError for an integer field that is not finite (as int() raises). The binding
        of bind() is kept for the run() calls that follow."""
        st = self._state
        bound = st[_CHANNEL], st[_CHUNK_SIZE], st[_STOP_EVERY_NS]
        self.bind(channel, chunk_size, stop_every_ns)
        try:
            return self.run(raw, first, last, seq, offset)
        finally:
            self.bind(*bound)

    def bind(self, channel: int, chunk_size: int, stop_every_ns: int) -> None:
        """records()'s channel, chunk size and stop for the run() calls that follow."""
        st = self._state
        st[_CHANNEL], st[_CHUNK_SIZE], st[_STOP_EVERY_NS] = channel, chunk_size, stop_every_ns

    @staticmethod
    def _make_run(st, call, handle):
        """run(raw, first, last, seq, offset): records() with the channel, chunk size and
        stop of the last bind(), as one function of local names (a call per truth item)
        over the program's call block `st`, rowtext_run `call` and the program `handle`."""
        import ctypes

        string_at, uint64 = ctypes.string_at, ctypes.c_uint64
        pairs_of: dict = {}             # k -> the ctypes type of k records' index pairs

        def run(raw: bytes, first: int, last: int, seq: int, offset: int) -> tuple:
            st[_SEQ] = seq
            st[_OFFSET] = offset
            k = call(handle, raw, first, last)
            if k < 0:
                raise ValueError(f"truth rows {first}..{last - 1}: "
                                 + _ERRORS.get(k, f"row formatter error {k}"))
            pairs = pairs_of.get(k)
            if pairs is None:
                pairs = pairs_of[k] = uint64 * (2 * k)
            return k, string_at(st[_OUT_AT], st[_OUT_LEN]), pairs.from_address(st[_INDEX_AT])[:]
        return run

    def text(self, row: bytes) -> bytes:
        """The JSON text of one row (`width` doubles)."""
        _, data, _ = self.records(row, 0, 1, 0, 0, 0, 1 << 62, 0)
        return data[31:]


class FieldText:
    """A message's JSON text from its bytes by the native message formatter (fmu/record,
    fieldtext.h), with the program of the generated codec's MessageText `mt`
    (navkit_json: its template's %d placeholders filled with the values at its slots):
    text(data, offset) is mt.json % mt.unpack(data, offset)."""

    def __init__(self, build, mt):
        import ctypes

        parts = mt.json.split(b"%d")
        n = len(mt.slots)
        if len(parts) != n + 1 or b"%" in b"".join(parts):
            raise ValueError(f"{mt.name}: its template has not one %d a slot")
        self._lib = lib = _row_lib(build)
        self._h = lib.fieldtext_new(n, *_literals(parts),
                                    (ctypes.c_uint32 * n)(*[off for off, _ in mt.slots]),
                                    "".join(code for _, code in mt.slots).encode(), mt.size)
        if not self._h:
            raise ValueError(f"{mt.name}: field program refused by {row_library(build)}")
        out, run, handle, string_at = (lib.fieldtext_out(self._h), lib.fieldtext_run,
                                       ctypes.c_void_p(self._h), ctypes.string_at)

        def text(data: bytes, offset: int = 0, _program=self) -> bytes:
            """The JSON text of the message at data[offset:] (its `size` bytes there: the
            caller checks); _program keeps the native program alive with the function."""
            return string_at(out, run(handle, data, offset))
        self.text = text

    def __del__(self):
        if getattr(self, "_h", None):
            self._lib.fieldtext_free(self._h)
            self._h = None



# One CAN frame as RunLog.can_frame queues it: time (ns), identifier, flags (bit 0 to the
# host, bit 1 error frame), dlc (bytes), the data padded to 8 bytes; and its /can text.
_CAN_RECORD = struct.Struct("<qHBB8s")
_CAN_TEXT = b'{"t":%.6f,"id":%d,"dlc":%d,"data":"%s","direction":"%s","error_frame":%s}'


# An MCAP message record: opcode, record length (bytes after it), then the message's
# channel id, sequence, log time and publish time (MCAP specification, "Message"); its
# data follows.
_MESSAGE_HEAD = struct.Struct("<BQHIQQ")
# run.mcap's chunk size: a chunk ends after the message that takes it past this (bytes);
# the 1-s span ends them long before
_CHUNK_BYTES = 8 << 20


class _MessageIndex:
    """A chunk's MessageIndex record of one channel (MCAP specification, "Message Index"):
    `records` one flat list of (log time ns, offset in the chunk) pairs, t0, o0, t1, o1,
    ..., packed at once by record()."""

    __slots__ = ("channel_id", "records")

    def __init__(self, channel_id: int):
        self.channel_id, self.records = channel_id, []

    def record(self) -> bytes:
        """The record's bytes."""
        n = len(self.records)       # 2 per entry, 8 bytes each
        return _INDEX_HEAD.pack(_OP_MESSAGE_INDEX, 6 + 8 * n, self.channel_id, 8 * n) \
            + struct.pack(f"<{n}Q", *self.records)


# MCAP (specification v0, mcap.dev/spec): the magic, the opcodes of the records run.mcap
# holds, and the fixed heads of the records written here (opcode, record length, fields)
_MAGIC = b"\x89MCAP0\r\n"
(_OP_HEADER, _OP_FOOTER, _OP_SCHEMA, _OP_CHANNEL, _OP_MESSAGE, _OP_CHUNK, _OP_MESSAGE_INDEX,
 _OP_CHUNK_INDEX, _OP_ATTACHMENT_INDEX, _OP_STATISTICS, _OP_METADATA, _OP_METADATA_INDEX,
 _OP_SUMMARY_OFFSET, _OP_DATA_END) = (1, 2, 3, 4, 5, 6, 7, 8, 10, 11, 12, 13, 14, 15)
_INDEX_HEAD = struct.Struct("<BQHI")          # MessageIndex: channel id, records' bytes
_CHUNK_HEAD = struct.Struct("<BQQQQII3sQ")    # Chunk: times, size, CRC, "lz4", data's bytes
_RECORD_HEAD = struct.Struct("<BQ")


def _text(s: str) -> bytes:
    """An MCAP string: its UTF-8 bytes after their count (uint32)."""
    b = s.encode()
    return struct.pack("<I", len(b)) + b


def _record(op: int, body: bytes) -> bytes:
    return _RECORD_HEAD.pack(op, len(body)) + body


class _McapFile:
    """run.mcap's MCAP writer (the Recorder's): the file the `mcap` package's
    Writer writes with chunk_size `chunk_size`, LZ4 chunks, CRCs of the chunks and of the
    summary, no data-section CRC, every index, schemas and channels repeated in the
    summary (its defaults), byte for byte (tests/test_sim_record_text.py holds the two to
    the same file), written with one struct pack and two list appends a message (the
    Writer builds a Message object and makes a dozen calls a message), a run of /truth
    records as the native row formatter wrote them, and each chunk with its message
    indexes packed and written at once. Schemas and channels go into the first chunk, as
    the Writer puts them. Its message-count, time-span and statistics bookkeeping is
    done at each chunk's end (fold()), not per message."""

    def __init__(self, stream, chunk_size: int):
        import zlib

        import lz4.frame

        self._stream, self._size = stream, chunk_size
        self._compress, self._crc32 = lz4.frame.compress, zlib.crc32
        self._schemas: list = []        # Schema records (bytes), by id from 1
        self._channels_rec: list = []   # Channel records (bytes), by id from 1
        self._metadata: list = []       # MetadataIndex records (bytes)
        self._chunk_indexes: list = []  # ChunkIndex records (bytes)
        self._indices: dict = {}        # the open chunk: channel id -> _MessageIndex
        self._lo = self._hi = None      # earliest / latest log time (ns) of the chunks so far
        self._channels: list = []       # channel ids in the order of their first message
        self._counts: dict = {}         # messages per channel id (at close)
        # The open chunk: its bytes so far (schemas and channels first in the first one)
        # and the messages since then as parts, and where the next one starts (bytes)
        self._head: list = []
        self._parts: list = []
        self._at = [0]

    def start(self, profile: str, library: str) -> None:
        """The magic and the Header record."""
        self._stream.write(_MAGIC + _record(_OP_HEADER, _text(profile) + _text(library)))

    def register_schema(self, name: str, encoding: str, data: bytes) -> int:
        """A Schema record (into the open chunk, and the summary); returns its id."""
        sid = len(self._schemas) + 1
        rec = _record(_OP_SCHEMA, struct.pack("<H", sid) + _text(name) + _text(encoding)
                      + struct.pack("<I", len(data)) + data)
        self._schemas.append(rec)
        self._chunk_head(rec)
        return sid

    def register_channel(self, topic: str, encoding: str, schema_id: int) -> int:
        """A Channel record without metadata (into the open chunk, and the summary);
        returns its id."""
        cid = len(self._channels_rec) + 1
        rec = _record(_OP_CHANNEL, struct.pack("<HH", cid, schema_id) + _text(topic)
                      + _text(encoding) + struct.pack("<I", 0))
        self._channels_rec.append(rec)
        self._chunk_head(rec)
        return cid

    def _chunk_head(self, rec: bytes) -> None:
        self._head.append(rec)
        self._at[0] += len(rec)

    def add_metadata(self, name: str, data: dict) -> None:
        """A Metadata record of string pairs (in the data section, and its index)."""
        pairs = b"".join(_text(k) + _text(v) for k, v in data.items())
        rec = _record(_OP_METADATA, _text(name) + struct.pack("<I", len(pairs)) + pairs)
        offset = self._stream.tell()
        self._stream.write(rec)
        self._metadata.append(_record(_OP_METADATA_INDEX, struct.pack("<QQ", offset, len(rec))
                                      + _text(name)))

    def writer(self, chan: int, n: list, keep=None):
        """fn(t_ns, data): one message on channel `chan` at log (= publish) time t_ns (ns),
        its sequence number n[0] + 1 (stored back in n[0]); `keep`, if given, is called
        with (t_ns, data) after it."""
        pack, size, indices = _MESSAGE_HEAD.pack, self._size, self._indices
        flush, first, put, next_at = self.flush, self._channels.append, self._parts.append, self._at

        def write(t_ns: int, data: bytes) -> None:
            n[0] = seq = n[0] + 1
            idx = indices.get(chan)
            if idx is None:             # the channel's first message in this chunk
                if seq == 1:
                    first(chan)
                idx = indices[chan] = _MessageIndex(chan)
            at = next_at[0]
            end = next_at[0] = at + 31 + len(data)
            idx.records += (t_ns, at)
            put(pack(_OP_MESSAGE, 22 + len(data), chan, seq, t_ns, t_ns))
            put(data)
            if end > size:              # as the Writer: a chunk past chunk_size ends
                flush()
            if keep is not None:
                keep(t_ns, data)
        return write

    def rows_writer(self, chan: int, n: list, fmt: "RowText", stop_every_ns: int,
                    keep_run=None):
        """fn(raw, first, last) -> (rows written, the last one's log time ns): rows first
        .. last - 1 of `raw` as messages on channel `chan` by `fmt` (RowText.run, bound
        here to this channel, the chunk size and `stop_every_ns`: its records go into the
        open chunk as they are; it stops after a row at a multiple of stop_every_ns (ns,
        0: never), or when the chunk is full, which then ends); sequence numbers as
        writer()'s. `keep_run`, if given, is called with (count, message) where
        message(i) -> (t_ns, data) of the i-th message written. `fmt` is this writer's."""
        run, size, indices = fmt.run, self._size, self._indices
        fmt.bind(chan, size, stop_every_ns)
        flush, first_chan, put, next_at = self.flush, self._channels.append, self._parts.append, \
            self._at

        def write(raw: bytes, first: int, last: int) -> tuple:
            at = next_at[0]
            k, data, where = run(raw, first, last, n[0], at)
            if n[0] == 0:
                first_chan(chan)
            idx = indices.get(chan)
            if idx is None:
                idx = indices[chan] = _MessageIndex(chan)
            idx.records += where
            put(data)
            n[0] += k
            end = next_at[0] = at + len(data)
            if keep_run is not None:
                def message(i: int) -> tuple:
                    stop = where[2 * i + 3] - at if i + 1 < k else end - at
                    return where[2 * i], data[where[2 * i + 1] - at + 31:stop]
                keep_run(k, message)
            if end > size:
                flush()
            return k, where[-2]
        return write

    def fold(self) -> tuple:
        """The open chunk's (message count, earliest, latest log time ns; latest at least
        0) from its message indexes, the span folded into the file's."""
        times = [idx.records[0::2] for idx in self._indices.values() if idx.records]
        if not times:
            return 0, 0, 0
        lo = min(map(min, times))
        hi = max(0, max(map(max, times)))
        self._lo = lo if self._lo is None or lo < self._lo else self._lo
        self._hi = hi if self._hi is None or hi > self._hi else self._hi
        return sum(map(len, times)), lo, hi

    def flush(self) -> None:
        """End the open chunk if it holds a message (the Chunk record, its channels'
        MessageIndex records, its ChunkIndex for the summary) and flush the stream."""
        count, lo, hi = self.fold()
        stream = self._stream
        if count:
            data = b"".join(self._head) + b"".join(self._parts)
            self._head.clear()
            self._parts.clear()
            self._at[0] = 0
            packed = self._compress(data)
            chunk = _CHUNK_HEAD.pack(_OP_CHUNK, 43 + len(packed), lo, hi, len(data),
                                     self._crc32(data), 3, b"lz4", len(packed)) + packed
            start = stream.tell()
            at = start + len(chunk)
            out, offsets = [chunk], []
            for chan, idx in self._indices.items():
                rec = idx.record()
                offsets.append(struct.pack("<HQ", chan, at))
                at += len(rec)
                out.append(rec)
            self._indices.clear()
            stream.write(b"".join(out))
            self._chunk_indexes.append(_record(_OP_CHUNK_INDEX, b"".join((
                struct.pack("<QQQQI", lo, hi, start, len(chunk), 10 * len(offsets)), *offsets,
                struct.pack("<Q", at - start - len(chunk)), _text("lz4"),
                struct.pack("<QQ", len(packed), len(data))))))
        stream.flush()

    def finish(self, counts: dict) -> None:
        """The last chunk, the DataEnd record, the summary (schemas, channels, statistics,
        chunk indexes, attachment indexes (none), metadata indexes, their offsets), the
        footer and the magic. `counts`: messages per channel id."""
        self.flush()
        stream = self._stream
        stream.write(_record(_OP_DATA_END, struct.pack("<I", 0)))
        summary_start = stream.tell()
        chans = self._channels
        stats = _record(_OP_STATISTICS, b"".join((
            struct.pack("<QHIIIIQQI", sum(counts[c] for c in chans), len(self._schemas),
                        len(self._channels_rec), 0, len(self._metadata), len(self._chunk_indexes),
                        self._lo if self._lo is not None else 0,
                        self._hi if self._hi is not None else 0, 10 * len(chans)),
            *(struct.pack("<HQ", c, counts[c]) for c in chans))))
        body, offsets = [], []
        at = summary_start
        for op, recs in ((_OP_SCHEMA, self._schemas), (_OP_CHANNEL, self._channels_rec),
                         (_OP_STATISTICS, [stats]), (_OP_CHUNK_INDEX, self._chunk_indexes),
                         (_OP_ATTACHMENT_INDEX, []), (_OP_METADATA_INDEX, self._metadata)):
            group = b"".join(recs)
            offsets.append(_record(_OP_SUMMARY_OFFSET, struct.pack("<BQQ", op, at, len(group))))
            body.append(group)
            at += len(group)
        summary = b"".join(body) + b"".join(offsets)
        crc = self._crc32(_RECORD_HEAD.pack(_OP_FOOTER, 20) + struct.pack("<QQ", summary_start, at),
                          self._crc32(summary))
        stream.write(summary + _record(_OP_FOOTER, struct.pack("<QQI", summary_start, at, crc))
                     + _MAGIC)
        stream.flush()


class Recorder:
    """Writes `run.mcap`. Call `reserve(t0_ns, t1_ns)` before writing messages whose log
    times lie in [t0_ns, t1_ns] (at most `flush_every_s` apart), `write(topic, t_ns, obj)`
    with JSON-able objects, `flush_before(t_ns)` at each frame end with the end of the next
    frame, and `close()` at the end."""

    def __init__(self, path: Path, metadata: dict, flush_every_s: float = 1.0, can: bool = False):
        """`can`: the run is over CAN, so the log also has the /can topic (CAN_SCHEMA).
        The file is written by _McapFile.
        `plot_series` (navkit.plot.RunSeries) keeps what the run plot draws of the
        messages as they are written, in file order, so the plot needs no read-back."""
        from navkit.plot import RunSeries

        self.plot_series = RunSeries()

        self._file = open(path, "wb")
        self._w = _McapFile(self._file, _CHUNK_BYTES)
        self._w.start(profile="", library="navkit")
        schemas = {"/truth": TRUTH_SCHEMA, "/micro/config": _config_schema(),
                   "/host/frame": FRAME_SCHEMA, "/events": EVENT_SCHEMA,
                   "/micro/datalog": _datalog_schema()}
        self._chan = {}
        topics = dict(TOPICS)
        if can:
            schemas["/can"] = CAN_SCHEMA
            topics["/can"] = None
        for topic, msg in topics.items():
            schema = schemas[topic] if msg is None else message_schema(msg)
            sid = self._w.register_schema(schema["title"], "jsonschema",
                                          json.dumps(schema, sort_keys=True).encode())
            self._chan[topic] = self._w.register_channel(topic, "json", sid)
        fox_ids = {}
        for topic, name in foxglove.TOPICS.items():
            if name not in fox_ids:
                text = json.dumps(foxglove.SCHEMAS[name], sort_keys=True).encode()
                fox_ids[name] = self._w.register_schema(name, "jsonschema", text)
            self._chan[topic] = self._w.register_channel(topic, "json", fox_ids[name])
        self._w.add_metadata("navkit", {k: str(v) for k, v in metadata.items()})
        self._n = {topic: [0] for topic in self._chan}    # messages so far = last sequence
        self._flush = self._w.flush     # ends the open chunk
        self._writers = {topic: self._make_writer(topic) for topic in self._chan}
        self.span_ns = int(flush_every_s * 1e9)     # the longest span of one chunk, ns
        self._lo = self._hi = None      # earliest / latest log time (ns) in the open chunk
        self._dumps = json.JSONEncoder(separators=(",", ":")).encode

    def write(self, topic: str, t_ns: int, obj) -> None:
        """One message on `topic` at simulated time `t_ns` (ns)."""
        self.write_raw(topic, t_ns, self._dumps(obj).encode())

    def write_raw(self, topic: str, t_ns: int, data: bytes) -> None:
        """One message whose JSON text is already encoded."""
        self._writers[topic](t_ns, data)

    def writer(self, topic: str):
        """write_raw for `topic` as a function (t_ns, data) without the topic's lookups,
        for a caller that writes it every frame."""
        return self._writers[topic]

    def rows_writer(self, topic: str, fmt: "RowText", stop_every_ns: int):
        """fn(raw, first, last) -> (rows written, the last one's log time ns): rows of
        `raw` as messages on `topic` by the native row formatter `fmt`, stopping after a
        row at a multiple of `stop_every_ns` (_McapFile.rows_writer)."""
        return self._w.rows_writer(self._chan[topic], self._n[topic], fmt, stop_every_ns,
                                   self.plot_series.sink_run(topic))

    def _make_writer(self, topic: str):
        return self._w.writer(self._chan[topic], self._n[topic], self.plot_series.sink(topic))

    @property
    def counts(self) -> dict:
        """Messages written so far per topic."""
        return {topic: n[0] for topic, n in self._n.items()}

    def reserve(self, t0_ns: int, t1_ns: int) -> None:
        """Messages with log times in [t0_ns, t1_ns] (ns, t1_ns - t0_ns <= the span) come
        next: close the open chunk first if with them it would span more than
        `flush_every_s`."""
        lo = self._lo
        if lo is None:
            self._lo, self._hi = t0_ns, t1_ns
            return
        hi = self._hi
        lo = t0_ns if t0_ns < lo else lo
        hi = t1_ns if t1_ns > hi else hi
        if hi - lo > self.span_ns:
            self._flush()
            self._lo, self._hi = t0_ns, t1_ns
        else:
            self._lo, self._hi = lo, hi

    def flush_before(self, next_end_ns: int) -> None:
        """A frame ended; the next one's messages reach `next_end_ns` (ns): close the chunk
        now if they would make it span more than `flush_every_s` (so chunks end at frame
        ends when frames are at most that long)."""
        if self._lo is not None and next_end_ns - self._lo > self.span_ns:
            self._flush()
            self._lo = self._hi = None

    def close(self) -> None:
        """Write the summary section and close the file."""
        if self._file is not None:
            self._w.finish({self._chan[t]: n[0] for t, n in self._n.items()})
            self._file.close()
            self._file = None


class _Receiver:
    """What one end's frame parser accepts of the bytes that reached it (after line noise,
    without what an unplugged port or a dead host lost): the codec's Parser, counted across
    restarts of that end (micro_reset, a re-opened port), so the totals cover the whole run.
    A chunk identical to what the sender sent, arriving while this parser is between
    frames, is counted from the sender's decoding (`same`) instead of parsed again."""

    def __init__(self, protocol, direction):
        self.p, self.direction = protocol, direction
        self.parser = protocol.Parser(direction)
        self.done = dict.fromkeys(("good", "bad_crc", "unknown_type", "bad_length",
                                   "dropped_bytes"), 0)
        self.resyncs = 0          # rejected stretches (Reject events)
        self.fed = 0              # bytes fed to the current parser
        self.between = True       # the current parser holds no bytes and no open reject

    def same(self, n_frames) -> bool:
        """The chunk was the sender's, `n_frames` whole frames back to back (None: not
        whole): count them if this parser is between frames; False: feed() it instead."""
        if self.between and n_frames is not None:
            self.done["good"] += n_frames
            return True
        return False

    def feed(self, data: bytes) -> None:
        events = self.parser.feed(data)
        self.fed += len(data)
        frame_cls = self.p.Frame
        for ev in events:
            if ev.__class__ is not frame_cls:
                self.resyncs += 1
        last = events[-1] if events else None
        self.between = (last.__class__ is frame_cls
                        and last.offset + len(last.raw) == self.fed) or (not data and self.between)

    def restart(self) -> None:
        """The receiving end starts a new parser (what the old one held is lost)."""
        for k, v in self.parser.stats.items():
            if k in self.done:
                self.done[k] += v
        self.parser = self.p.Parser(self.direction)
        self.fed = 0
        self.between = True

    def totals(self) -> dict:
        st = dict(self.done)
        for k, v in self.parser.stats.items():
            if k in st:
                st[k] += v
        return {"frames_received": st["good"], "crc_errors": st["bad_crc"],
                "resyncs": self.resyncs, "bad_length": st["bad_length"],
                "unknown_type": st["unknown_type"], "dropped_bytes": st["dropped_bytes"]}


# The kinds of the items RunLog queues for the worker (each item a tuple, its kind first;
# the rest as each RunLog method says).
HOST_FRAME = "host_frame"   # a host frame: k, t_ns, rx, tx, flags, host bytes, lisp_data, state
HOST_BYTES = "host_bytes"           # bytes the host sent outside a lockstep frame: t_ns, bytes
LISP_DATA = "lisp_data"             # a lisp_data read outside a lockstep frame: t_ns, raw bytes
MICRO_BYTES = "micro_bytes"         # bytes the micro sent: t_ns, bytes
TRUTH_ROWS = "truth_rows"           # truth rows, raw doubles of the coupler
RECEIVED = "received"               # bytes an end received: "h2m" | "m2h", bytes | None (as sent)
RECEIVER_RESTART = "receiver_restart"   # an end's parser starts anew: "h2m" | "m2h"
PLANNER_COMMAND = "planner_command"     # a lisp_cmd written: t_ns, fields, mission entry
EVENT = "event"                     # a mission event: t_ns, kind, detail
HOST_CONSOLE = "host_console"       # host console lines of a frame: t_ns, [(level, message, line)]
WALLS = "walls"                     # the world's walls: the plant's walls output (at t = 0)
CAN_FRAMES = "can_frames"           # CAN frames: _CAN_RECORD records back to back
FRAME_END = "frame_end"             # a frame ended: the end of the next frame, ns

class _Decoder:
    """Turns the harness's raw items into MCAP messages (runs in the log worker). The
    protocol's messages become JSON text through the generated navkit_json
    (protocol.json_texts);
    frames are split and checked by navkit.protocol (split_frames, frame_crc_ok,
    decode_frame, Parser)."""

    def __init__(self, path: Path, metadata: dict, columns: list, width: int, can: bool = False,
                 build: Path | None = None):
        from navkit import protocol

        self.p = protocol
        texts = protocol.json_texts(build)
        self.rec = Recorder(path, metadata, can=can)
        if can:
            self.write_can = self.rec.writer("/can")
        self.write_frame, self.write_micro, self.write_truth, self.write_lisp, \
            self.write_cmd = map(self.rec.writer, ("/host/frame", "/micro/data", "/truth",
                                                   "/planner/data", "/micro/cmd"))
        self.h2m = protocol.Parser(protocol.DIR_TO_MICRO)
        self.m2h = protocol.Parser(protocol.DIR_TO_HOST)
        # what each end received, and the sender's last chunk with its whole-frame count
        self.rx = {"h2m": _Receiver(protocol, protocol.DIR_TO_MICRO),
                   "m2h": _Receiver(protocol, protocol.DIR_TO_HOST)}
        self.last_sent = {"h2m": (b"", None), "m2h": (b"", None)}
        self.whole = None
        self.frame_cls = protocol.Frame
        self.dumps = json.JSONEncoder(separators=(",", ":")).encode
        self.cmd_text = {}          # the last micro_cmd frame -> its text (the host repeats it)
        self.h2m_buf, self.m2h_buf = bytearray(), bytearray()
        self.row_struct = struct.Struct(f"={width}d")
        self.first_t = struct.Struct("=d").unpack_from     # a row's time (s) at an offset
        # /host/frame text per host state, with and without the done message's flags
        head = b'{"frame":%d,"t":%r,"rx_bytes":%d,"tx_bytes":%d'
        self.frame_text = {h: head + b',"host":"%s"}' % h.encode() for h in HOST_STATES}
        self.frame_text_flags = {h: head + b',"flags":%%d,"host":"%s"}' % h.encode()
                                 for h in HOST_STATES}
        # serial type -> (its MessageText, its JSON text function by the native formatter)
        self.text_by_type = {k: (t, FieldText(build, t).text) for k, t in texts.BY_TYPE.items()}
        self.micro_data = md = texts.MICRO_DATA
        self.md_name = md.name
        status = protocol.SPEC.messages[md.name].field("status")
        self.wd_mask = 1 << protocol.SPEC.enums[status.flags].values["watchdog_stop"]
        self.wd_on = False
        self.watchdog_stops = 0     # rising edges of micro_data.status watchdog_stop
        self.md_status = md.at["status"]
        self.md_odom = operator.itemgetter(*(md.at[n] for n in ("x", "y", "heading")))
        self.last_micro_raw = None     # decoded by finish()
        self.datalog = self._datalog_texts(protocol, md)
        # lisp_data: its text, and the host's verdict on each planner command
        # (nav_result of the first lisp_data whose ack_time_tag is the command's time tag)
        self.lisp_data = ld = texts.LISP_DATA
        self.lisp_text = FieldText(build, ld).text
        self.ack_at = (ld.at["ack_time_tag"], ld.at["nav_result"])
        self.last_lisp = None
        self.last_lisp_raw = None      # decoded into last_lisp by finish()
        self.commands = 0
        self.pending = {}              # time tag -> (mission entry, lisp_cmd) not yet acked
        self.verdicts = []             # (mission entry, lisp_cmd, nav_result) acked
        self.unacknowledged = []       # (mission entry, lisp_cmd) never acked
        self.last_row = None        # the last truth item's rows and the last one's index
        self.config_downloads = 0
        idx = {name: i + 1 for i, name in enumerate(columns)}
        # /truth's text (TRUTH_SCHEMA's keys) by the native row formatter: fixed decimals,
        # 1 us of time, 0.1 um / 0.0001 deg of truth; a heading that would print as
        # 360.0000 is written as 0 (0 <= heading_deg < 360); dio_out as a 12-bit integer
        keys = ("t", "x_mm", "y_mm", "yaw_deg", "heading_deg", "distance_mm", "v_mm_s", "w_deg_s")
        fields = [(("{" if k == "t" else ",") + f'"{k}":', 0 if k == "t" else idx.get(k),
                   6 if k == "t" else 4) for k in keys]
        fields += [(',"servo_deg":[' if i == 0 else ",", idx.get(f"servo_deg_{i}"), 4)
                   for i in range(8)]
        fields.append(('],"dio_out":', idx.get("dio_out"), ROW_INT))
        self.truth_text = RowText(build, width, fields, "}", 0xFFF, keys.index("heading_deg"),
                                  _HEADING_ROUNDS_TO_360, 360.0)
        self.row_bytes = 8 * width
        self.truth_rows = self.rec.rows_writer("/truth", self.truth_text,
                                               foxglove.TRUTH_PERIOD_NS)
        # the Foxglove topics: the truth's pose (x_mm, y_mm, yaw_deg), the odometry of
        # micro_data (x, y, heading), events and commands
        self.fox = foxglove.FoxgloveWriter(self.rec.writer)
        self.fox_truth = operator.itemgetter(*[idx.get(k, width)
                                               for k in ("x_mm", "y_mm", "yaw_deg")])
        self.handlers = {HOST_FRAME: self._host_frame, HOST_BYTES: self._host_bytes,
                         LISP_DATA: self._lisp_data, MICRO_BYTES: self._micro_bytes,
                         TRUTH_ROWS: self._truth_handler(), RECEIVED: self._received,
                         RECEIVER_RESTART: self._receiver_restart,
                         PLANNER_COMMAND: self._planner_command, EVENT: self._event,
                         HOST_CONSOLE: self._host_console, WALLS: self._walls,
                         CAN_FRAMES: self._can_frames, FRAME_END: self._frame_end}

    def _datalog_texts(self, protocol, md):
        """A function (t_ns, micro_data values) writing /micro/datalog when the values'
        mc_datalog_sel is a selection with words (spec enum mc_datalog): the words by
        their spec names."""
        m = protocol.SPEC.messages[md.name]
        sel_at, time_at, words_at = (md.at[n] for n in ("mc_datalog_sel", "micro_time",
                                                       "mc_datalog"))
        count = m.field("mc_datalog").count
        enum = protocol.SPEC.enums["mc_datalog"]
        templates = {}
        for name, code in enum.values.items():
            names = enum.words.get(name, ())
            if names:
                last = words_at + min(len(names), count)
                pick = operator.itemgetter(time_at, *range(words_at, last))
                templates[code] = (('{"selection":"%s","micro_time_ms":%%d,' % name
                                    + ",".join(f'"{w}":%d' for w in names) + "}").encode(), pick)
        write = self.rec.writer("/micro/datalog")

        def datalog(t_ns: int, values: tuple) -> None:
            hit = templates.get(values[sel_at])
            if hit is not None:
                write(t_ns, hit[0] % hit[1](values))
        return datalog

    def handle(self, item) -> None:
        """One item of RunLog (its kind first)."""
        self.handlers[item[0]](item)

    def _host_frame(self, item) -> None:
        _, k, t_ns, rx, tx, flags, host_bytes, lisp_raw, host = item
        self.rec.reserve(t_ns, t_ns)
        if flags is None:
            self.write_frame(t_ns, self.frame_text[host] % (k, t_ns / 1e9, rx, tx))
        else:
            self.write_frame(t_ns, self.frame_text_flags[host] % (k, t_ns / 1e9, rx, tx, flags))
        if lisp_raw is not None:
            self.lisp(t_ns, lisp_raw)
        if host_bytes:
            self.host_bytes(t_ns, host_bytes)

    def _lisp_data(self, item) -> None:
        self.rec.reserve(item[1], item[1])
        self.lisp(item[1], item[2])

    def _host_bytes(self, item) -> None:
        self.rec.reserve(item[1], item[1])
        self.host_bytes(item[1], item[2])

    def _micro_bytes(self, item) -> None:
        t_ns = item[1]
        self.rec.reserve(t_ns, t_ns)
        md_name, unpack = self.md_name, self.micro_data.unpack
        for name, frame, text, values in self.frames(self.m2h_buf, self.m2h, item[2]):
            if name == md_name:
                self.last_micro_raw = frame
                self.write_micro(t_ns, text)
                if values is None:
                    values = unpack(frame)
                self.datalog(t_ns, values)
                self.fox.odom(t_ns, *self.md_odom(values))
                wd = bool(values[self.md_status] & self.wd_mask)
                if wd and not self.wd_on:
                    self.watchdog_stops += 1
                self.wd_on = wd
        self.last_sent["m2h"] = (item[2], self.whole)

    def _received(self, item) -> None:
        rx = self.rx[item[1]]
        data = item[2]
        if data is None:
            sent, n_frames = self.last_sent[item[1]]
            if not rx.same(n_frames):
                rx.feed(sent)
        else:
            rx.feed(data)

    def _receiver_restart(self, item) -> None:
        self.rx[item[1]].restart()

    def _truth_handler(self):
        """The TRUTH_ROWS handler: /truth messages by the native row formatter, which stops
        after each row on the Foxglove poses' period for their messages to follow it; one
        function of local names (an item is a call)."""
        rec, write, size, first_t = self.rec, self.truth_rows, self.row_bytes, self.first_t
        reserve, span, fox, fox_ns = rec.reserve, rec.span_ns, self.fox.truth, foxglove.TRUTH_PERIOD_NS
        fox_get, unpack = self.fox_truth, self.row_struct.unpack_from
        pad, to_ns = (0.0,), log_ns

        def truth_rows(item) -> None:
            raw = item[1]
            n = len(raw) // size
            if not n:
                return
            t0 = to_ns(first_t(raw)[0])
            t1 = to_ns(first_t(raw, (n - 1) * size)[0])
            whole = t1 - t0 <= span         # else (a frame over 1 s) a chunk per span
            if whole:
                reserve(t0, t1)
            at = 0
            while at < n:
                if not whole:
                    t_ns = to_ns(first_t(raw, at * size)[0])
                    reserve(t_ns, t_ns)
                k, t_ns = write(raw, at, n if whole else at + 1)
                at += k
                if not t_ns % fox_ns:
                    fox(t_ns, *fox_get(unpack(raw, (at - 1) * size) + pad))
            self.last_row = (raw, n - 1)
        return truth_rows

    def _planner_command(self, item) -> None:
        _, t_ns, cmd, entry = item
        self.rec.reserve(t_ns, t_ns)
        self.rec.write("/planner/cmd", t_ns, cmd)
        self.fox.command(t_ns, cmd, entry)
        self.commands += 1
        self.pending[cmd["time_tag"]] = (entry, cmd)

    def _event(self, item) -> None:
        _, t_ns, kind, detail = item
        self.rec.reserve(t_ns, t_ns)
        self.rec.write("/events", t_ns, {"t": t_ns / 1e9, "kind": kind, "detail": detail})
        self.fox.event(t_ns, kind, detail)

    def _host_console(self, item) -> None:
        self.rec.reserve(item[1], item[1])
        for level, text, line in item[2]:
            self.fox.console(item[1], level, text, line)

    def _walls(self, item) -> None:
        self.rec.reserve(0, 0)
        self.fox.walls(0, item[1])

    def _frame_end(self, item) -> None:
        self.rec.flush_before(item[1])

    def _can_frames(self, item) -> None:
        rec, write, tpl = self.rec, self.write_can, _CAN_TEXT
        for t_ns, can_id, flags, dlc, data in _CAN_RECORD.iter_unpack(item[1]):
            rec.reserve(t_ns, t_ns)
            write(t_ns, tpl % (t_ns / 1e9, can_id, dlc, data[:dlc].hex().encode(),
                               b"to_host" if flags & 1 else b"to_micro",
                               b"true" if flags & 2 else b"false"))

    def lisp(self, t_ns: int, raw: bytes) -> None:
        """One lisp_data (its little-endian bytes) to /planner/data."""
        ld = self.lisp_data
        if len(raw) != ld.size:
            d = self.p.from_bytes(ld.name, raw)     # the codec's error for a bad size
            self.write_lisp(t_ns, self.dumps(d).encode())
        else:
            self.write_lisp(t_ns, self.lisp_text(raw))
            if self.pending:
                self.acks(ld.unpack(raw))
        self.last_lisp_raw = raw
        self.last_lisp = None

    def acks(self, values: tuple) -> None:
        """The verdict of the lisp_data of `values` (generated unpack) on the pending
        planner command it acknowledges (ack_time_tag = its time tag); a pending command
        with an earlier tag was never taken (the host saw a later one)."""
        ack = values[self.ack_at[0]]
        if ack not in self.pending:
            return
        for tag in [tag for tag in self.pending if tag < ack]:
            self.unacknowledged.append(self.pending.pop(tag))
        entry, cmd = self.pending.pop(ack)
        self.verdicts.append((entry, cmd, values[self.ack_at[1]]))

    def frames(self, buf: bytearray, parser, data: bytes):
        """Whole frames of a byte stream as (name, frame bytes, JSON bytes, field values of
        the generated unpack, or None where the codec made the text). The logged
        streams are the senders' (before any line noise), so frames come whole and back to
        back: those (protocol.split_frames) whose type, length and CRC are good become
        text by their generated template, or else by the codec's decode_frame (a micro_cmd
        identical to the last one, the host's repeated command, reuses its text); at the
        first that fails, the rest goes through the codec's resyncing Parser."""
        p = self.p
        self.whole = None       # set below when `data` is whole frames, back to back
        if parser.stats["dropped_bytes"] or buf:
            buf += data
            data = bytes(buf)
            buf.clear()
            if parser.stats["dropped_bytes"]:
                yield from self._parse(parser, data)
                return
            prefixed = True
        else:
            prefixed = False
        frames, end, short = p.split_frames(data)
        at = count = 0
        by_type, crc_ok, stats = self.text_by_type, p.frame_crc_ok, parser.stats
        for msg_type, frame in frames:
            hit = self.cmd_text.get(frame)
            if hit is None:
                t = by_type.get(msg_type)
                if t is not None and t[0].size == len(frame) and crc_ok(frame):
                    hit = (t[0].name, frame, t[1](frame), None)
                else:
                    try:
                        name, fields = p.decode_frame(frame)
                    except p.ProtocolError:
                        short = False       # the rest from this frame on: the Parser
                        break
                    hit = (name, frame, self.dumps(fields).encode(), None)
                if hit[0] == "micro_cmd":
                    self.cmd_text = {frame: hit}
            stats["good"] += 1
            count += 1
            yield hit
            at += len(frame)
        else:
            at = end
        n = len(data)
        if at == n and not prefixed:
            self.whole = count
        if at < n:
            if short:
                buf += data[at:]        # a frame split across chunks: wait for the rest
            else:
                yield from self._parse(parser, data[at:])

    def _parse(self, parser, data: bytes):
        for ev in parser.feed(data):
            if ev.__class__ is self.frame_cls:
                yield ev.name, ev.raw, self.dumps(ev.fields).encode(), None

    def host_bytes(self, t_ns: int, data: bytes) -> None:
        for name, frame, text, _ in self.frames(self.h2m_buf, self.h2m, data):
            if name == "micro_cmd":
                self.write_cmd(t_ns, text)
            else:
                fields = self.p.decode_frame(frame)[1]
                if name == "micro_cfg_geometry":
                    self.config_downloads += 1
                self.rec.write("/micro/config", t_ns, {"message": name, "fields": fields})
        self.last_sent["h2m"] = (data, self.whole)

    def finish(self) -> dict:
        self.rec.close()
        if self.last_lisp is None and self.last_lisp_raw is not None:
            self.last_lisp = self.p.from_bytes("lisp_data", self.last_lisp_raw)
        last_micro = (self.p.decode_frame(self.last_micro_raw)[1]
                      if self.last_micro_raw is not None else None)
        self.unacknowledged += self.pending.values()
        self.pending = {}
        return {"counts": self.rec.counts, "last_micro": last_micro,
                "planner": {"commands": self.commands, "verdicts": self.verdicts,
                            "unacknowledged": self.unacknowledged},
                "last_lisp": self.last_lisp,
                "last_truth": (json.loads(self.truth_text.text(
                    self.last_row[0][self.last_row[1] * self.row_bytes:]))
                    if self.last_row else None),
                "config_downloads": self.config_downloads,
                "peak_rss_kib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss,
                "watchdog_stops": self.watchdog_stops,
                "plot": self.rec.plot_series.raw(),
                "link": {d: dict({"frames_sent": sender.stats["good"]}, **self.rx[d].totals())
                         for d, sender in (("h2m", self.h2m), ("m2h", self.m2h))}}


# The harness's last message to the worker but for the results: stop, then draw plot.png
# (the worker's `plot`) once run.mcap is closed. A plain stop is None.
_STOP_AND_DRAW = "stop and draw plot.png"


def _worker(conn, path, metadata, columns, width, spin, harness_end=None, can=False,
            build=None, plot=None) -> None:
    """Log worker process: decode and write until the harness says stop (None or
    _STOP_AND_DRAW) or goes away (EOF), then close the MCAP file and send the results
    back; after _STOP_AND_DRAW, then draw run plot `plot` (plot.png) from the messages the
    Recorder kept (navkit.plot.plot_mcap) and send {"drawn": bool, "error": the exception
    the drawing raised or None}. With `plot`, Pillow and the plot's fonts are loaded
    first (navkit.plot.warm_up), while the harness sets the run up: their CPU time is not
    in the results' `cpu_s`, nor is the drawing's; the kept messages' drawn fields are
    found while no batch waits (RunSeries.find_ahead, in `cpu_s`). With `spin` it polls
    instead of sleeping while waiting for work (see RunLog.spin). `harness_end`, the
    harness's end of the pipe that fork() copied here, is closed first: else this process
    would hold it open itself and never see the EOF of a harness that was killed. The
    signals of a terminal (Ctrl-C to the process group) or of a group kill are the
    harness's to act on: it ends the worker through the pipe, so the file is closed.
    The harness's objects it was forked with are frozen (gc.freeze: its collections never
    walk them, nor copy their pages) and the collector is on (off in a harness holding it
    through its set-up: navkit.cli.hold_collector)."""
    import gc
    import signal
    import time

    gc.freeze()
    gc.enable()
    if harness_end is not None:
        harness_end.close()
    for sig in STOP_SIGNALS:
        signal.signal(sig, signal.SIG_IGN)

    cpu0 = time.process_time()
    spun = 0.0                  # CPU s spent polling for work (spin), not working
    dec = _Decoder(path, metadata, columns, width, can, build)
    if plot is not None:
        from navkit.plot import warm_up

        w0 = time.process_time()
        warm_up()
        cpu0 += time.process_time() - w0
    gc.freeze()                 # the decoder's objects too: they live as long as the process
    handlers = dec.handlers     # dec.handle's table, looked up here: an item is a call
    find_ahead = dec.rec.plot_series.find_ahead if plot is not None else None
    batch = None
    try:
        while True:
            try:
                if spin.value:
                    s0 = time.process_time()
                    while spin.value and not conn.poll(0):
                        pass
                    spun += time.process_time() - s0
                batch = conn.recv()
            except (EOFError, OSError):
                batch = None
            if batch is None or batch == _STOP_AND_DRAW:
                break
            for item in batch:
                handlers[item[0]](item)
            if find_ahead is not None and not conn.poll(0):   # idle: no batch waiting
                find_ahead()
    finally:
        res = dec.finish()
        series = res.pop("plot") if batch == _STOP_AND_DRAW and plot is not None else None
        found = dec.rec.plot_series.found()
        res["cpu_s"] = round(time.process_time() - cpu0 - spun, 3)
        res["spin_cpu_s"] = round(spun, 3)
        try:
            conn.send(res)
        except (OSError, BrokenPipeError):
            pass
    if series is not None:
        _send_plot(conn, path, plot, series, found)


def _send_plot(conn, path, plot, series, found) -> None:
    """Draw run plot `plot` of run `path` from `series` (RunSeries.raw(), with `found`:
    its RunSeries.found()) and send the harness {"drawn": True, "error": None or the
    exception plot_mcap raised}, or {"drawn": False, ...} when that exception does not
    pickle (the harness draws it itself then, to raise it)."""
    from navkit.plot import plot_mcap

    try:
        plot_mcap(path, plot, series, found)
        err = None
    except Exception as e:  # noqa: BLE001 - the harness reports it as its own drawing's
        err = e
    try:
        try:
            conn.send({"drawn": True, "error": err})
        except (pickle.PicklingError, TypeError, AttributeError):
            conn.send({"drawn": False, "error": None})
    except OSError:
        pass


# The harness's send buffer towards the log worker (bytes; the kernel caps it at
# net.core.wmem_max): a worker that falls behind for a while (its CPU shared with other
# work) holds up the loop only once this much is waiting, not once the kernel's default
# (some hundreds of KiB) is; it catches up later, close() waiting for it anyway.
_SEND_BUFFER_BYTES = 4 << 20


def _deep_send_buffer(conn) -> None:
    """Give the socket of `conn` (a multiprocessing Connection over a socketpair) a send
    buffer of _SEND_BUFFER_BYTES; nothing if it is not a socket."""
    import socket

    try:
        s = socket.socket(fileno=conn.fileno())
    except OSError:
        return
    try:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, _SEND_BUFFER_BYTES)
    except OSError:
        pass
    finally:
        s.detach()


def _send_whole(conn, obj) -> None:
    """conn.send(obj) with the stop signals held off until the message is written whole.
    A Connection writes one message in several writes (length, then the pickle, each
    retried on a partial write); a KeyboardInterrupt raised between them would leave the
    worker waiting forever for the rest of a message, and the harness for its results.
    A signal that comes meanwhile is delivered when send() returns, or where the lockstep
    loop holding them already delivers them (navkit.sim.stops). The pickle is the one
    conn.recv() loads, made by pickle.dumps: conn.send's pickler looks every object up in
    multiprocessing's reducer table, a Python call each, for types the log never sends."""
    data = pickle.dumps(obj, pickle.HIGHEST_PROTOCOL)
    with DeferredStops():
        conn.send_bytes(data)


class RunLog:
    """The harness's side of the run log. Items are queued raw (bytes as they were on the
    links, truth rows as doubles) and sent in batches to a worker process that decodes
    them with the Python codec (navkit.protocol and its generated navkit_json) and writes
    run.mcap, so decoding and MCAP writing run on the other core, off the lockstep loop.
    `inline=True` does it all in this process.

    Items: frame(), host(), micro(), received(), receiver_restart(), truth(), command(),
    event(), can_frame(), console(), walls(), end_frame(); each with its log time, in
    time order within a frame (truth rows before the micro's bytes of the same FMU call)
    but for a few ms in real time;
    close() returns the worker's results (message counts, last
    decoded micro_data / lisp_data / truth, config downloads, watchdog stops, `planner`:
    commands written and per command() its entry and lisp_cmd with the host's
    lisp_data.nav_result once a lisp_data acknowledged it (`verdicts`) or never
    (`unacknowledged`), and `link`:
    per direction frames sent, and frames received, CRC errors, resyncs as the receiving
    end's parser counts them over the whole run; with a worker process also `cpu_s`, its
    CPU time (s) from start to its results, without `spin_cpu_s`, the CPU s it spent
    polling for work). Its `plot` is RunSeries.raw() of the run, but when the worker
    draws plot.png itself (draw_plot(), then plot_done())."""

    def __init__(self, path: Path, metadata: dict, columns: list, width: int,
                 inline: bool = False, batch_frames: int = 10, can: bool = False,
                 build: Path | None = None, plot: Path | None = None):
        """`can`: a run over CAN, whose bus frames (can_frame()) go to the /can topic.
        `build`: the build folder with the generated navkit_json (protocol.json_texts;
        default navkit.paths.build_dir()) and the row formatter (row_library()), loaded
        here, so that a missing or stale one is an OSError of this call. `plot`: the
        run's plot.png, which a worker process gets ready to draw from the start and
        draws after run.mcap is closed when asked (draw_plot)."""
        from navkit import protocol

        protocol.json_texts(build)
        _row_lib(build)
        self._items: list = []
        self._batch = batch_frames
        self._frames = 0
        self._plot = None if inline else plot
        self._draw = self._drawing = False
        if inline:
            self._dec = _Decoder(path, metadata, columns, width, can, build)
            self._conn = self._proc = None
        else:
            import multiprocessing as mp

            ctx = mp.get_context("fork")
            self._conn, child = ctx.Pipe()
            _deep_send_buffer(self._conn)
            self._spin = ctx.Value("b", 0, lock=False)
            self._proc = ctx.Process(target=_worker, args=(child, path, metadata, columns, width,
                                                          self._spin, self._conn, can, build,
                                                          plot),
                                     name="navkit-sim-log", daemon=True)
            self._proc.start()
            child.close()
            self._dec = None
        self.pid = self._proc.pid if self._proc is not None else None

    def spin(self, on: bool) -> None:
        """Let the worker poll for work instead of sleeping (it should then run at idle
        priority on its own CPU). On a VM an idle virtual CPU is slow to wake, a delay
        the kernel's pty work and the host would otherwise pay every frame."""
        if self._proc is not None:
            self._spin.value = 1 if on else 0

    def frame(self, k, t_ns, rx, tx, flags, host_bytes, lisp_raw, host) -> None:
        """Host frame k at t_ns (a /host/frame message): bytes written to the host's port
        and bytes it wrote since the last one (lockstep: the tick's rx_bytes, the done's
        tx_bytes), the done's flags (None: no done message), the host's bytes and the raw
        lisp_data read after it (b"" / None: logged apart, or none) and the host's state
        (one of HOST_STATES)."""
        self._items.append((HOST_FRAME, k, t_ns, rx, tx, flags, host_bytes, lisp_raw, host))

    def host(self, t_ns, data) -> None:
        """Bytes the host sent (real-time mode)."""
        if data:
            self._items.append((HOST_BYTES, t_ns, data))

    def lisp(self, t_ns, lisp_raw) -> None:
        """A lisp_data read outside a lockstep frame (real-time mode)."""
        if lisp_raw is not None:
            self._items.append((LISP_DATA, t_ns, lisp_raw))

    def micro(self, t_ns, data) -> None:
        """Bytes the micro sent in the FMU chunk ending at t_ns."""
        if data:
            self._items.append((MICRO_BYTES, t_ns, data))

    def truth(self, raw) -> None:
        """Truth rows (raw doubles of the coupler)."""
        if raw:
            self._items.append((TRUTH_ROWS, raw))

    def received(self, direction, data) -> None:
        """Bytes the receiving end of `direction` ("h2m": the micro, "m2h": the host) got
        from the sender's last chunk: `data`, or None when they were that chunk unchanged.
        Call after the chunk's frame() / host() / micro() item."""
        self._items.append((RECEIVED, direction, data))

    def receiver_restart(self, direction) -> None:
        """The receiving end of `direction` starts a new frame parser (a reset micro, a
        port the host opens again)."""
        self._items.append((RECEIVER_RESTART, direction))

    def command(self, t_ns, msg, entry) -> None:
        """The planner wrote lisp_cmd `msg` for mission entry `entry` (any picklable
        value, handed back with the host's verdict in close()'s `planner`)."""
        self._items.append((PLANNER_COMMAND, t_ns, msg, entry))

    def event(self, t_ns, kind, detail) -> None:
        self._items.append((EVENT, t_ns, kind, detail))

    def console(self, t_ns, lines) -> None:
        """Lines of the host's console that appeared in the frame at t_ns (ns): [(level,
        message, line number)] as navkit.sim.host_console gives them (foxglove.Log)."""
        if lines:
            self._items.append((HOST_CONSOLE, t_ns, lines))

    def walls(self, data) -> None:
        """The plant FMU's walls output (bytes of whole walls, navkit.sim.foxglove
        WALL_BYTES each): the world's scene at t = 0."""
        self._items.append((WALLS, data))

    def can_frame(self, t_ns, can_id, data, to_host, error) -> None:
        """A frame on the CAN bus at t_ns (a /can message; the log was made with can=True):
        its identifier, data bytes (at most 8), direction (True: micro to host) and whether
        it is an error frame. Frames in a row share one item of packed records."""
        items = self._items
        if not items or items[-1][0] is not CAN_FRAMES:
            items.append((CAN_FRAMES, bytearray()))
        items[-1][1].extend(_CAN_RECORD.pack(t_ns, can_id, to_host | error << 1, len(data), data))

    def end_frame(self, next_end_ns) -> None:
        """A frame ends; the next one ends at `next_end_ns` (ns): the log closes its chunk
        here if the next frame would pass its 1 s span. Sends the batch every
        `batch_frames`."""
        self._items.append((FRAME_END, next_end_ns))
        self._frames += 1
        if self._frames >= self._batch:
            self._send()

    def _send(self) -> None:
        items, self._items, self._frames = self._items, [], 0
        if self._dec is not None:
            for it in items:
                self._dec.handle(it)
        elif items:
            _send_whole(self._conn, items)

    def draw_plot(self) -> bool:
        """Have the worker draw plot.png (the `plot` it was made with) once close() has
        closed run.mcap, while the caller goes on; plot_done() waits for it. False (nothing
        to wait for) with the log inline or made without `plot`."""
        self._draw = self._plot is not None     # None with the log inline
        return self._draw

    def close(self) -> dict:
        """Send what is left, stop the worker, return its results (the worker drawing
        plot.png on, if asked by draw_plot)."""
        self._send()
        if self._dec is not None:
            res, self._dec = self._dec.finish(), None
            return res
        if self._conn is None:
            return {}
        self.spin(False)
        try:
            _send_whole(self._conn, _STOP_AND_DRAW if self._draw else None)
            res = self._conn.recv() if self._conn.poll(60) else {}
        except (EOFError, OSError):
            res = {}
        self._drawing = self._draw and bool(res)
        if not self._drawing:
            self._end()
        return res

    def plot_done(self) -> tuple:
        """Wait for the worker's plot.png after close(): (True, None) drawn, (True, e) its
        drawing raised exception `e` (navkit.plot.plot_mcap's, for the caller to raise as
        its own), (False, None) not drawn (not asked; the worker died or its exception
        would not pickle). Then the worker has ended."""
        if not self._drawing:
            return False, None
        self._drawing = False
        try:
            done = self._conn.recv() if self._conn.poll(60) else None
        except Exception:  # noqa: BLE001 - EOF, or an exception that does not unpickle here
            done = None
        self._end()
        return (True, done["error"]) if done and done["drawn"] else (False, None)

    def _end(self) -> None:
        """Join the worker and close its pipe."""
        self._proc.join(10)
        self._conn.close()
        self._conn = None
