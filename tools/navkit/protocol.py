"""The Python codec of the navkit protocol, built from `protocol/navkit.toml` at import.

Same semantics as the generated C code (checked byte for byte by the golden vectors in
`tests/vectors/`): little-endian words, frames of start word / time tag / type / length
/ payload / CRC-16/MCRF4XX, and a streaming parser that resyncs on the next start word,
never accepts a bad frame, counts each rejected candidate once, and recognizes a
CRC-good frame of another spec version (spec hash at the frozen words 4-5) as a schema
mismatch (the ordering contract in protocol/runtime/navkit/navkit_wire.h).

Values are raw integers as on the wire (units apply to raw x scale, see
docs/protocol.md); `count` fields are lists.

    >>> frame = encode_frame("micro_cmd", {"fwd_cmd": 1, "speed": 200}, time_tag=7)
    >>> decode_frame(frame)[1]["speed"]
    200
"""

from __future__ import annotations

import binascii
import struct
from dataclasses import dataclass, field

from navkit.paths import spec_path
from navkit.spec import STRUCT_CODES, TYPES, Message, load, struct_format

__all__ = [
    "SPEC", "SPEC_HASH", "ProtocolError", "crc16", "defaults", "check", "encode_frame",
    "decode_frame", "pack_words", "unpack_words", "to_bytes", "from_bytes", "Parser",
    "Frame", "Reject", "DIR_TO_MICRO", "DIR_TO_HOST", "ERR_CRC", "ERR_TYPE", "ERR_LENGTH", "ERR_SCHEMA",
    "STATS", "foreign_frame", "frame_crc_ok", "split_frames", "json_texts",
]

SPEC = load(spec_path())
SPEC_HASH: int = SPEC.hash

DIR_TO_MICRO = "host_to_micro"
DIR_TO_HOST = "micro_to_host"
ERR_CRC, ERR_TYPE, ERR_LENGTH = "bad CRC", "unknown message type", "bad length"
ERR_SCHEMA = "schema mismatch"
# The Parser's counters, in the order of the C navkit_link_stats_t.
STATS = ("good", "bad_crc", "unknown_type", "bad_length", "schema_mismatch", "dropped_bytes")

_START = SPEC.framing["start_word"]
_LEN_WORD = SPEC.framing["length_word"]
_HASH_WORD = SPEC.framing["hash_word"]
_MAX_WORDS = SPEC.framing["max_frame_words"]
_HEADER = 2 * (_LEN_WORD + 1)
_MIN_FRAME = _HEADER + 2        # header and CRC word: shorter is a bad length (as in C)
_LEN_AT = 2 * _LEN_WORD        # byte offset of the length word (frame words)
_TYPE_AT = _LEN_AT - 2          # byte offset of the type word, the word before the length
_DIR_TEXT = {DIR_TO_MICRO: "to-micro", DIR_TO_HOST: "to-host"}
_BY_ID = {m.id: m for m in SPEC.serial_messages()}
_HASHED = {m.id for m in SPEC.serial_messages() if any(f.name == "spec_hash" for f in m.fields)}


class ProtocolError(ValueError):
    """A value, name or frame that the spec does not allow; the text says which.
    `field` is the name of the offending field when there is one (else None)."""

    def __init__(self, text: str, field: str | None = None):
        super().__init__(text)
        self.field = field


def _reverse_bits(x: int, width: int) -> int:
    return int(f"{x:0{width}b}"[::-1], 2)


# CRC-16/MCRF4XX is the reflected form of CRC-16 with poly 0x1021: it equals the
# non-reflected CRC (binascii.crc_hqx, in C) over bit-reversed bytes, bit-reversed.
_REVERSE_BYTES = bytes(_reverse_bits(b, 8) for b in range(256))


def crc16(data: bytes, crc: int = 0xFFFF) -> int:
    """CRC-16/MCRF4XX (poly 0x1021 reflected, init 0xFFFF, no final xor) of `data`."""
    return _reverse_bits(binascii.crc_hqx(bytes(data).translate(_REVERSE_BYTES), _reverse_bits(crc, 16)), 16)


def frame_crc_ok(frame: bytes) -> bool:
    """The CRC word at the end of `frame` (little-endian, at least 2 bytes) is crc16 of
    the bytes before it. The CRC is compared reflected (its bytes bit-reversed in the
    other order), which saves crc16's two bit reversals of a 16-bit value: one translate
    and one binascii.crc_hqx a frame."""
    r = frame.translate(_REVERSE_BYTES)
    return binascii.crc_hqx(r[:-2], 0xFFFF) == (r[-2] << 8 | r[-1])


def split_frames(data: bytes) -> tuple[list[tuple[int, bytes]], int, bool]:
    """The candidate frames at the start of `data`, back to back: each begins with the
    start word and its length word gives at least a header and CRC word that fit in
    `data` (type, length against the type and CRC unchecked: decode_frame, or a
    generated template after frame_crc_ok, checks those). Returns ((type word, frame
    bytes) of each, bytes they take, whether the rest may be a frame cut short: fewer
    bytes than a header, or a start word whose length word needs more bytes than are
    left)."""
    out = []
    at, n = 0, len(data)
    lo, hi = _START & 0xFF, _START >> 8
    while n - at >= _HEADER:
        if data[at] != lo or data[at + 1] != hi:
            return out, at, False
        size = 2 * (data[at + _LEN_AT] | data[at + _LEN_AT + 1] << 8)
        if size < _MIN_FRAME:
            return out, at, False
        if at + size > n:
            return out, at, True
        out.append((data[at + _TYPE_AT] | data[at + _TYPE_AT + 1] << 8, data[at:at + size]))
        at += size
    return out, at, at < n


_GENERATED: dict = {}     # path -> the loaded navkit_json module


def json_texts(build=None):
    """The generated module navkit_json (`navkit gen --py-out`, built into
    <build>/gen/python by cmake; default build folder navkit.paths.build_dir()): each
    message's JSON text from its bytes, the codec's fast path for the run log. OSError
    naming the file when it is missing or was generated from another spec."""
    import errno
    import importlib.util
    from pathlib import Path

    from navkit.paths import build_dir

    path = (Path(build) if build is not None else build_dir()) / "gen" / "python" / "navkit_json.py"
    mod = _GENERATED.get(path)
    if mod is None:
        if not path.is_file():
            raise FileNotFoundError(errno.ENOENT, "not found: build it (cmake --build <build>)",
                                    str(path))
        spec = importlib.util.spec_from_file_location("navkit_json", path)
        mod = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(mod)
        if mod.SPEC_HASH != SPEC_HASH:
            raise OSError(errno.ESTALE, f"generated from spec hash 0x{mod.SPEC_HASH:08x}, not "
                          f"0x{SPEC_HASH:08x} ({SPEC.path.name}): rebuild it (cmake --build "
                          "<build>)", str(path))
        _GENERATED[path] = mod
    return mod


@dataclass
class _Layout:
    """How one message maps to bytes: a struct over the frame minus its CRC word."""

    message: Message
    struct: struct.Struct
    slots: list[tuple[str, int | None]]  # (field or framing name, element index)
    zero: dict = field(default_factory=dict)    # every field 0 (tuples for arrays)
    limits: dict = field(default_factory=dict)  # name -> (count, min, max, type min, type max)
    zero_bad: tuple = ()                        # fields whose 0 is outside min..max
    codes: dict = field(default_factory=dict)   # coded field (Field.coded) name -> its enum
    constraints: tuple = ()                     # the spec's Constraints, checked after the ranges


def _layout(m: Message) -> _Layout:
    items = []  # (byte offset, code, name, index)
    if m.framed:
        items += [(0, "H", "#start", None), (2 * _LEN_WORD, "H", "#length", None)]
    for f in m.fields:
        for i in range(f.count):
            items.append((f.byte_offset + i * f.size, STRUCT_CODES[f.type], f.name, i if f.count > 1 else None))
    items.sort()
    fmt = struct_format([(off, code) for off, code, _, _ in items], m.size - (2 if m.framed else 0))
    slots = [(name, idx) for _, _, name, idx in items]
    zero = {f.name: (0,) * f.count if f.count > 1 else 0 for f in m.fields}
    limits = {f.name: (f.count, f.min, f.max, TYPES[f.type][2], TYPES[f.type][3]) for f in m.fields}
    zero_bad = tuple(f.name for f in m.fields if not f.min <= 0 <= f.max)
    codes = {f.name: SPEC.enums[f.enum] for f in m.fields if f.coded}
    return _Layout(m, struct.Struct(fmt), slots, zero, limits, zero_bad, codes, m.constraints)


_LAYOUTS = {m.name: _layout(m) for m in SPEC.messages.values()}


def _message(name: str) -> _Layout:
    try:
        return _LAYOUTS[name]
    except KeyError:
        raise ProtocolError(f"unknown message {name!r} (known: {', '.join(_LAYOUTS)})") from None


def defaults(name: str) -> dict:
    """Field values of `name` with the spec defaults (0 where none), msg_type set and
    spec_hash = SPEC_HASH where the message has one."""
    m = _message(name).message
    out = {}
    for f in m.fields:
        v = f.default if f.default is not None else 0
        out[f.name] = [v] * f.count if f.count > 1 else v
    if m.framed:
        out["msg_type"] = m.id
    if "spec_hash" in out:
        out["spec_hash"] = SPEC_HASH
    return out


def _values(lay: _Layout, fields: dict, strict: bool) -> dict:
    """All field values of the message: `fields` checked (type range; with strict also
    the spec range and, for a coded field, enum membership), the rest 0. An array
    element is named with its index:
    `micro_cfg_io.servo_center[2]: 400 is outside 500..2500`."""
    m = lay.message
    full = dict(lay.zero)
    for k, v in fields.items():
        lim = lay.limits.get(k)
        if lim is None:
            raise ProtocolError(f"{m.name}: unknown field {k!r} (fields: {', '.join(lay.limits)})", k)
        count, fmin, fmax, tmin, tmax = lim
        lo, hi = (fmin, fmax) if strict else (tmin, tmax)
        if count > 1:
            if not isinstance(v, (list, tuple)) or len(v) != count:
                raise ProtocolError(f"{m.name}.{k}: needs a list of {count} values", k)
            elems = v
        else:
            elems = (v,)
        enum = lay.codes.get(k) if strict else None
        for i, e in enumerate(elems):
            if e.__class__ is not int or not lo <= e <= hi or (enum and e not in enum.values.values()):
                where = f"{m.name}.{k}[{i}]" if count > 1 else f"{m.name}.{k}"
                if e.__class__ is not int:
                    raise ProtocolError(f"{where}: {e!r} is not an integer", k)
                if not lo <= e <= hi:
                    raise ProtocolError(f"{where}: {e} is outside {lo}..{hi}", k)
                names = ", ".join(f"{n}={c}" for n, c in enum.values.items())
                raise ProtocolError(f"{where}: {e} is not a {enum.name} code ({names})", k)
        full[k] = v
    if strict:
        for k in lay.zero_bad:
            if k not in fields:
                lim = lay.limits[k]
                raise ProtocolError(f"{m.name}.{k}: 0 (unset) is outside {lim[1]}..{lim[2]}", k)
        for c in lay.constraints:
            _constraint(m, c, full, fields)
    return full


def _constraint(m: Message, c, full: dict, given: dict) -> None:
    """ProtocolError naming the last field constraint `c` binds (as the C check's
    bad_field) and the element, if the values `full` break it."""
    a = full[c.fields[0]]
    b = full[c.fields[1]] if c.kind == "le" else None
    count = m.field(c.fields[0]).count
    for i in range(count):
        va = a[i] if count > 1 else a
        vb = (b[i] if count > 1 else b) if b is not None else 0
        at = f"[{i}]" if count > 1 else ""
        if c.kind == "nonzero" and va == 0:
            unset = "" if c.fields[0] in given else " (unset)"
            raise ProtocolError(f"{m.name}.{c.fields[0]}{at}: 0{unset} breaks the constraint {c.text}", c.fields[0])
        if c.kind == "le" and va > vb:
            raise ProtocolError(f"{m.name}.{c.fields[1]}{at}: {vb} is below {c.fields[0]}{at} {va} "
                                f"(constraint {c.text})", c.fields[1])


def check(name: str, fields: dict) -> None:
    """Raise ProtocolError naming the field (also as its `field`) if any value of
    `fields` is outside its spec range, or is not one of its enum's codes (a coded field:
    `enum` and units other than "bits"; range first, then the code), or is unknown or
    not an integer; then the message's spec constraints (`le`, `nonzero`) on the values
    with unset fields 0, naming the last field the broken one binds. Fields are checked in
    the order given, so for a whole message in spec order the field named is the one the C
    navkit_<msg>_check() reports."""
    _values(_message(name), fields, strict=True)


def _pack(lay: _Layout, full: dict, extra: dict) -> bytes:
    vals = []
    for name, idx in lay.slots:
        v = extra[name] if name[0] == "#" else full[name]
        vals.append(v if idx is None else v[idx])
    return lay.struct.pack(*vals)


def encode_frame(name: str, fields: dict | None = None, *, time_tag: int | None = None,
                 strict: bool = True) -> bytes:
    """The whole serial frame of message `name`: unset fields 0, msg_type set (giving
    another msg_type is an error), `time_tag` (if given) overriding fields['time_tag']
    (so `encode_frame(n, defaults(n), time_tag=k)` works; the CLI refuses both).

    Range checks: by default (strict=True) every value must be within its spec
    min..max and a coded field's value one of its enum's codes, as check() and
    navkit_<msg>_check() require. With strict=False values only need
    to fit their type: that is what the C navkit_<msg>_encode() does, which never
    range-checks (to build out-of-range test frames)."""
    lay = _message(name)
    m = lay.message
    if not m.framed:
        raise ProtocolError(f"{name} is an rcomm message: use pack_words/to_bytes")
    fields = dict(fields or {})
    if fields.get("msg_type", m.id) != m.id:
        raise ProtocolError(f"{name}.msg_type: is always {m.id}, not {fields['msg_type']!r}", "msg_type")
    if time_tag is not None:
        fields["time_tag"] = time_tag
    fields["msg_type"] = m.id
    full = _values(lay, fields, strict)
    body = _pack(lay, full, {"#start": _START, "#length": m.words})
    return body + struct.pack("<H", crc16(body))


def foreign_frame(name: str, words: int, spec_hash: int, time_tag: int = 0) -> bytes:
    """A frame as a peer built from another spec version would send message `name`:
    its type, `words` words long (start, time tag, type, length, the uint32 `spec_hash`
    at the frozen words 4-5, zero payload, then a good CRC). For tests of the parser's
    schema-mismatch rule; `words` must be within hash_word + 3 .. max_frame_words."""
    m = _message(name).message
    if m.id not in _HASHED:
        raise ProtocolError(f"{name} carries no spec_hash")
    if not _HASH_WORD + 3 <= words <= _MAX_WORDS:
        raise ProtocolError(f"{name}: {words} words is outside {_HASH_WORD + 3}..{_MAX_WORDS}")
    body = bytearray(2 * words - 2)
    struct.pack_into("<HHHH", body, 0, _START, time_tag, m.id, words)
    struct.pack_into("<I", body, 2 * _HASH_WORD, spec_hash)
    return bytes(body) + struct.pack("<H", crc16(body))


def _wrong_direction(m: Message) -> str:
    """The reason for a frame of a known type that goes the other way (counted as
    unknown type, as in C)."""
    return f"wrong direction: {m.name} is a {_DIR_TEXT[m.direction]} message"


def _frame_reason(frame: bytes, direction: str | None) -> tuple[str | None, Message | None]:
    """Why one whole frame is refused (None if it is good), the order of the C
    navkit_frame_check(): length, start word, type, length word, CRC."""
    if len(frame) < _MIN_FRAME:
        return f"{ERR_LENGTH}: {len(frame)} byte(s), a frame has at least {_MIN_FRAME}", None
    if struct.unpack_from("<H", frame)[0] != _START:
        return "no start word", None
    msg_type, words = struct.unpack_from("<HH", frame, 4)
    m = _BY_ID.get(msg_type)
    if m is None:
        return f"{ERR_TYPE} {msg_type}", None
    if direction is not None and m.direction != direction:
        return _wrong_direction(m), None
    if words != m.words or len(frame) != m.size:
        return (f"{ERR_LENGTH}: {m.name} has {m.words} words ({m.size} bytes); length word {words}, "
                f"{len(frame)} bytes"), m
    if not frame_crc_ok(frame):
        return ERR_CRC, m
    return None, m


def _unpack(lay: _Layout, data: bytes) -> dict:
    """Field values in spec order (arrays as lists)."""
    out = {f.name: [0] * f.count if f.count > 1 else 0 for f in lay.message.fields}
    for (name, idx), v in zip(lay.slots, lay.struct.unpack_from(data)):
        if name[0] == "#":
            continue
        if idx is None:
            out[name] = v
        else:
            out[name][idx] = v
    return out


def decode_frame(frame: bytes, direction: str | None = None) -> tuple[str, dict]:
    """(message name, fields) of one whole frame; ProtocolError with the reason if the
    start word, type (for `direction`, if given), length or CRC is wrong."""
    reason, m = _frame_reason(bytes(frame), direction)
    if reason:
        raise ProtocolError(reason)
    return m.name, _unpack(_LAYOUTS[m.name], frame)


def pack_words(name: str, fields: dict | None = None) -> list[int]:
    """The int32 words of rcomm message `name` (unset fields 0)."""
    data = to_bytes(name, fields)
    return list(struct.unpack(f"<{len(data) // 4}i", data))


def unpack_words(name: str, words) -> dict:
    """Fields of rcomm message `name` from its int32 words."""
    return from_bytes(name, struct.pack(f"<{len(words)}i", *words))


def to_bytes(name: str, fields: dict | None = None, *, strict: bool = False) -> bytes:
    """Little-endian bytes of rcomm message `name` (the words of its shared-memory slot).
    Values must fit their type; with strict=True also their spec range."""
    lay = _message(name)
    if lay.message.framed:
        raise ProtocolError(f"{name} is a serial message: use encode_frame")
    return _pack(lay, _values(lay, dict(fields or {}), strict), {})


def from_bytes(name: str, data: bytes) -> dict:
    """Fields of rcomm message `name` from its little-endian bytes."""
    lay = _message(name)
    if len(data) != lay.message.size:
        raise ProtocolError(f"{name}: needs {lay.message.size} bytes, got {len(data)}")
    return _unpack(lay, data)


@dataclass
class Frame:
    """A good frame found by the Parser at stream byte `offset`."""

    name: str
    fields: dict
    offset: int
    raw: bytes


@dataclass
class Reject:
    """A stretch of `length` rejected bytes at stream byte `offset`; `reason` is why its
    first candidate failed ("garbage" when no start word was there). A frame of another
    spec version is a stretch of its own, reason "schema mismatch: spec hash 0x..."."""

    offset: int
    length: int
    reason: str


@dataclass
class Parser:
    """Streaming frame parser: feed() bytes in any chunking, get Frame and Reject events.

    `direction` (DIR_TO_MICRO, DIR_TO_HOST or None for both) selects the types accepted;
    frames of other types count as unknown type. Memory is bounded by the longest frame
    of any spec version (max_frame_words). `stats` counts as the C parser does (STATS:
    good, bad_crc, unknown_type, bad_length, schema_mismatch, dropped_bytes), with the
    same ordering contract (navkit_wire.h); `foreign_hash` and `foreign_offset` are the
    spec hash and stream offset of the last schema-mismatch frame (None before one)."""

    direction: str | None = None
    stats: dict = field(default_factory=lambda: dict.fromkeys(STATS, 0))
    foreign_hash: int | None = None
    foreign_offset: int | None = None
    _buf: bytearray = field(default_factory=bytearray)
    _offset: int = 0            # stream offset of _buf[0]
    _reject: Reject | None = None

    def _drop(self, n: int, reason: str, events: list) -> None:
        if self._reject and self._reject.offset + self._reject.length == self._offset:
            self._reject.length += n
        else:
            self._flush_reject(events)
            self._reject = Reject(self._offset, n, reason)
        self.stats["dropped_bytes"] += n
        del self._buf[:n]
        self._offset += n

    def _flush_reject(self, events: list) -> None:
        if self._reject:
            events.append(self._reject)
            self._reject = None

    def settle(self) -> list:
        """The rejected stretch still open, as a Reject event now, if the parser has
        resynced (its buffer is empty or begins with a start word); else []. For live
        sniffing: feed() keeps a stretch open across calls (so its events do not depend
        on the chunking), which would otherwise delay reporting it until the next frame."""
        events: list = []
        if not self._buf or self._buf[:2] == _START.to_bytes(2, "little"):
            self._flush_reject(events)
        return events

    def feed(self, data: bytes) -> list:
        """Add bytes; return the events they complete, in stream order."""
        self._buf += data
        events: list = []
        buf, lo, hi = self._buf, _START & 0xFF, _START >> 8
        while True:
            i = buf.find(lo)
            if i < 0:
                if buf:
                    self._drop(len(buf), "garbage", events)
                break
            if i:
                self._drop(i, "garbage", events)
            if len(buf) < 2:
                break
            if buf[1] != hi:
                self._drop(1, "garbage", events)
                continue
            if len(buf) < _HEADER:
                break
            msg_type, words = struct.unpack_from("<HH", buf, 4)
            m = _BY_ID.get(msg_type)
            if m is None or (self.direction is not None and m.direction != self.direction):
                self.stats["unknown_type"] += 1
                self._drop(1, f"{ERR_TYPE} {msg_type}" if m is None else _wrong_direction(m), events)
                continue
            if words != m.words:
                # contract 5: maybe a whole frame of another spec version
                if msg_type not in _HASHED or not _HASH_WORD + 3 <= words <= _MAX_WORDS:
                    self.stats["bad_length"] += 1
                    self._drop(1, ERR_LENGTH, events)
                    continue
                if len(buf) < 2 * words:
                    break
                if struct.unpack_from("<H", buf, 2 * words - 2)[0] != crc16(buf[:2 * words - 2]):
                    self.stats["bad_length"] += 1
                    self._drop(1, ERR_LENGTH, events)
                    continue
                self.stats["schema_mismatch"] += 1
                self.foreign_hash = struct.unpack_from("<I", buf, 2 * _HASH_WORD)[0]
                self.foreign_offset = self._offset
                self._flush_reject(events)
                self._drop(2 * words, f"{ERR_SCHEMA}: spec hash 0x{self.foreign_hash:08x} "
                           f"(this spec 0x{SPEC_HASH:08x})", events)
                self._flush_reject(events)
                continue
            if len(buf) < m.size:
                break
            raw = bytes(buf[:m.size])
            if not frame_crc_ok(raw):
                self.stats["bad_crc"] += 1
                self._drop(1, ERR_CRC, events)
                continue
            self._flush_reject(events)
            self.stats["good"] += 1
            events.append(Frame(m.name, _unpack(_LAYOUTS[m.name], raw), self._offset, raw))
            del buf[:m.size]
            self._offset += m.size
        return events

    def flush(self) -> list:
        """End of stream: the bytes still waiting become a Reject ('truncated frame')."""
        events: list = []
        if self._buf:
            self._drop(len(self._buf), "truncated frame", events)
        self._flush_reject(events)
        return events
