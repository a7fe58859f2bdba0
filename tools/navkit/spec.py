"""Parse and validate the protocol spec (`protocol/navkit.toml`) into a model.

This is the first stage of the generator (parse + validate -> model -> emitters) and
the source of the Python codec. Only the standard library is used, so CMake can run
the generator with any Python >= 3.11.

Errors name the place: `SpecError` reads "protocol/navkit.toml:123: micro_cmd.accel: reason"
and carries `path` and `line` (None when the file cannot be read).
"""

from __future__ import annotations

import bisect
import hashlib
import json
import re
import struct
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

__all__ = [
    "SpecError", "Field", "Constraint", "Message", "Enum", "Rcomm", "Can", "CanId", "Spec", "load", "TYPES",
    "STRUCT_CODES", "struct_format",
]

# type name -> (size in bytes, signed, minimum, maximum)
TYPES = {
    "uint16": (2, False, 0, 0xFFFF),
    "int16": (2, True, -0x8000, 0x7FFF),
    "uint32": (4, False, 0, 0xFFFFFFFF),
    "int32": (4, True, -0x80000000, 0x7FFFFFFF),
}
# type name -> its Python struct format character (little-endian, standard sizes)
STRUCT_CODES = {"uint16": "H", "int16": "h", "uint32": "I", "int32": "i"}


def struct_format(values, size: int) -> str:
    """The little-endian struct format of `size` bytes holding a value of struct code
    `code` at each (byte offset, code) of `values`, in offset order, pad bytes between
    them and after the last."""
    fmt, end = "<", 0
    for off, code in sorted(values):
        fmt += (f"{off - end}x" if off > end else "") + code
        end = off + struct.calcsize("<" + code)
    return fmt + (f"{size - end}x" if size > end else "")

_TOP_KEYS = {"spec", "framing", "links", "enums", "flags", "message", "seed_slip", "can"}
_MESSAGE_KEYS = {"name", "link", "direction", "id", "doc", "field", "constraint"}
# A [[message]] constraint entry: one kind key (the fields it binds) and doc.
_CONSTRAINT_KINDS = ("nonzero", "le")
_FIELD_KEYS = {"name", "word", "type", "count", "units", "scale", "min", "max",
               "default", "enum", "flags", "special", "doc"}
_ENUM_KEYS = {"doc", "values", "words"}
_FRAMING_KEYS = {"doc", "start_word", "length_word", "crc", "crc_doc", "max_frame_words",
                 "hash_word", "hash_doc"}
_FRAMING_REQUIRED = ("start_word", "length_word", "max_frame_words", "hash_word")
_SLIP_KEYS = {"slip", "resolution"}
_LINK_KEYS = {"doc", "word_bits", "framing"}
# The shared-memory region of the unframed link (all required there, refused elsewhere).
_RCOMM_KEYS = {"magic", "layout_version", "header_bytes", "header", "slot_align", "slot_words_at", "layout_doc"}
# The header words every region has (uint32 each; the host and the clients use all five).
_RCOMM_HEADER_WORDS = ("magic", "version", "spec_hash", "planner_heartbeat", "host_heartbeat")
# The directions a link carries, by its framing: a serial-framed link joins host and
# micro, an unframed (shared-memory) link planner and host.
_LINK_DIRECTIONS = {"serial": ("host_to_micro", "micro_to_host"),
                    None: ("planner_to_host", "host_to_planner")}
_DIRECTIONS = {d for ds in _LINK_DIRECTIONS.values() for d in ds}
_NAME_RE = re.compile(r"^[a-z][a-z0-9_]*$")
_CRCS = {"CRC-16/MCRF4XX"}
# The CAN mapping ([can]): its integer keys with their ranges, then the others.
_CAN_INTS = {"id_bits": (11, 11), "bitrate": (10_000, 1_000_000), "padding": (0, 0xFF),
             "fc_block_size": (0, 0xFF), "fc_st_min": (0, 0xF9), "n_bs_ms": (1, 60_000),
             "n_cr_ms": (1, 60_000)}
_CAN_KEYS = set(_CAN_INTS) | {"doc", "transport_doc", "ids"}
_CAN_ID_KEYS = {"id", "fc_id"}
_ISOTP_MAX_BYTES = 4095  # the 12-bit FF_DL of a classic ISO 15765-2 first frame


class SpecError(ValueError):
    """A spec that cannot be used: `path`, `line` (1-based; None when the file cannot be
    read) and the text, which reads `path:line: what: reason`."""

    def __init__(self, path: Path, line: int | None, text: str):
        super().__init__(f"{path}:{line}: {text}" if line is not None else f"{path}: {text}")
        self.path, self.line = path, line


def _toml_kind(v) -> str:
    """The TOML name of a value's kind, for error texts."""
    if isinstance(v, bool):
        return "boolean"
    return {int: "integer", float: "float", str: "string", list: "array", dict: "table"}.get(type(v), type(v).__name__)


def _is_int(v) -> bool:
    """An integer TOML value (TOML booleans are Python ints: they are not)."""
    return isinstance(v, int) and not isinstance(v, bool)


@dataclass(frozen=True)
class Field:
    """One field of a message. `word` counts link words; values are raw (units apply
    to raw * scale)."""

    name: str
    word: int
    type: str
    count: int
    units: str
    scale: float
    min: int
    max: int
    default: int | None
    enum: str | None
    flags: str | None
    special: str | None     # enum of special values within min..max (e.g. servo_goto)
    doc: str
    line: int
    byte_offset: int  # from the start of the frame (serial) or message (rcomm)

    @property
    def size(self) -> int:
        """Bytes of one element."""
        return TYPES[self.type][0]

    @property
    def signed(self) -> bool:
        return TYPES[self.type][1]

    @property
    def raw_units(self) -> str:
        """The units of its raw (wire) value, as docs/protocol.md writes them: 'mm/s',
        'deg x 0.1' (units times scale)."""
        return self.units if self.scale == 1 else f"{self.units} x {self.scale:g}"

    @property
    def coded(self) -> bool:
        """Its value must be one of its enum's values (checked beside its range): a field
        with `enum` whose units are not "bits". A bit set such as micro_cmd.dg_control
        (units "bits") takes any combination of its enum's bits: only its range is
        checked. `flags` and `special` fields are never coded."""
        return self.enum is not None and self.units != "bits"


@dataclass(frozen=True)
class Constraint:
    """A rule of message fields beyond their ranges, checked after them. `kind` "nonzero":
    each element of fields[0] is not 0; "le": fields[0] <= fields[1] (raw values,
    element by element when both are arrays of one count)."""

    kind: str
    fields: tuple[str, ...]
    doc: str
    line: int

    @property
    def text(self) -> str:
        """The rule as docs and error texts write it: 'gyro_sign != 0', 'servo_min <= servo_max'."""
        return f"{self.fields[0]} != 0" if self.kind == "nonzero" else f"{self.fields[0]} <= {self.fields[1]}"


@dataclass(frozen=True)
class Message:
    """One message. For serial messages `words` counts the whole frame (start word,
    header, payload and CRC word); for rcomm messages the payload words."""

    name: str
    link: str
    direction: str
    id: int | None
    doc: str
    fields: tuple[Field, ...]
    word_bits: int
    words: int
    line: int
    constraints: tuple[Constraint, ...] = ()

    @property
    def framed(self) -> bool:
        return self.link == "serial"

    @property
    def size(self) -> int:
        """Bytes of the whole frame (serial) or message (rcomm)."""
        return self.words * self.word_bits // 8

    def field(self, name: str) -> Field:
        for f in self.fields:
            if f.name == name:
                return f
        raise KeyError(name)


@dataclass(frozen=True)
class Enum:
    """Named coded values (`kind` 'enum') or bit positions (`kind` 'flags')."""

    name: str
    kind: str
    doc: str
    values: dict[str, int]
    line: int
    # value name -> names of the data words that value selects (an enum that selects what
    # a group of words carries, e.g. mc_datalog: which internal words fill micro_data's
    # mc_datalog); each name is snake_case and ends in its unit; empty for most enums
    words: dict[str, tuple[str, ...]] = field(default_factory=dict)


@dataclass(frozen=True)
class Rcomm:
    """The shared-memory region of the unframed link; every offset and size in bytes.

    The header holds uint32 words at `header` offsets (magic, version = layout version,
    spec_hash, planner_heartbeat, host_heartbeat) within `header_bytes`; then one slot
    per rcomm message in spec order, each at a multiple of `slot_align`: a uint32
    seqlock sequence at +0, the message's words from +`slot_words_at`."""

    link: str
    magic: int
    version: int
    header: dict[str, int]
    header_bytes: int
    slot_align: int
    slot_words_at: int
    slots: dict[str, int]   # message -> offset of its slot
    size: int               # bytes of the whole region
    doc: str

    @property
    def magic_text(self) -> str:
        """The magic's 4 bytes as ASCII (little-endian, as in memory), or '' if not printable."""
        b = self.magic.to_bytes(4, "little")
        return b.decode("ascii") if all(0x20 <= c < 0x7F for c in b) else ""


@dataclass(frozen=True)
class CanId:
    """The CAN identifiers of one serial message: `id` carries its frames (single, first
    and consecutive frames of ISO 15765-2), `fc_id` the flow control its receiver answers
    with; `line` is the spec line of the mapping."""

    message: str
    id: int
    fc_id: int
    line: int


@dataclass(frozen=True)
class Can:
    """The micro link over classic CAN ([can]): each serial frame, whole, is one ISO 15765-2
    message on its message's identifier. `padding` fills every frame to 8 data bytes;
    `fc_block_size` and `fc_st_min` (the ISO STmin byte: 0-127 ms, 0xF1-0xF9 100-900 us)
    are what a receiver's flow control asks for; `n_bs_ms` (ms) bounds a sender's wait for
    flow control, `n_cr_ms` (ms) a receiver's wait for the next consecutive frame;
    `bitrate` (bit/s) is the default bit rate of the bus."""

    id_bits: int
    bitrate: int
    padding: int
    fc_block_size: int
    fc_st_min: int
    n_bs_ms: int
    n_cr_ms: int
    ids: dict[str, CanId]   # serial message name -> its identifiers, in spec order
    doc: str
    transport_doc: str
    line: int

    def by_id(self, can_id: int) -> CanId | None:
        """The mapping whose frames travel on `can_id` (not a flow control id), or None."""
        for c in self.ids.values():
            if c.id == can_id:
                return c
        return None


@dataclass
class Spec:
    """The validated model of the whole spec."""

    path: Path
    name: str
    version: int
    doc: str
    framing: dict
    links: dict
    enums: dict[str, Enum]
    messages: dict[str, Message]
    seed_slips: list[dict]
    rcomm: Rcomm | None = None  # the shared-memory region of the (one, required) unframed link
    can: Can | None = None  # the CAN mapping of the serial messages ([can]; optional)
    hash: int = 0           # uint32: first 4 bytes of the canonical model's sha256
    hash_hex: str = ""      # the full sha256, hex
    canonical: str = field(default="", repr=False)

    @property
    def max_frame_bytes(self) -> int:
        """Bytes of the largest serial frame defined."""
        return max(m.size for m in self.messages.values() if m.framed)

    def serial_messages(self):
        return [m for m in self.messages.values() if m.framed]

    def rcomm_messages(self):
        return [m for m in self.messages.values() if not m.framed]


# `name = "..."` anywhere in a line (every start, overlapping), what _Lines.name_line indexes
_NAMED = re.compile(r'(?=name\s*=\s*"([^"]*)")')


class _Lines:
    """Finds the source line of spec items (tomllib keeps no positions). The lookups a
    valid spec makes for each field and table (name_line, header_line, block_span) use
    indexes of the lines built on first use, one pass each; `find` compiles its regex,
    which only the error paths and a few fixed patterns need. Lines are 1-based where
    returned (0: none), 0-based in spans and starts."""

    def __init__(self, text: str):
        self.lines = text.splitlines()
        self._named = None       # name -> 0-based lines holding name = "name", ascending
        self._brackets = None    # "[...]" -> 0-based lines starting with it, ascending
        self._headers = None     # 0-based lines starting with "[", ascending
        self._exact = {}         # stripped line -> 0-based lines equal to it, ascending

    def find(self, pattern: str, start: int = 0, stop: int | None = None) -> int:
        """1-based line of the first match of regex `pattern` in lines [start, stop)."""
        rx = re.compile(pattern)
        stop = len(self.lines) if stop is None else stop
        for i in range(start, stop):
            if rx.search(self.lines[i]):
                return i + 1
        return 0

    def _first(self, at: list, start: int, stop: int | None) -> int:
        """1-based line of the first of ascending 0-based lines `at` in [start, stop), or 0."""
        stop = len(self.lines) if stop is None else stop
        i = bisect.bisect_left(at, start)
        return at[i] + 1 if i < len(at) and at[i] < stop else 0

    def name_line(self, name: str, start: int = 0, stop: int | None = None) -> int:
        """find(rf'name\\s*=\\s*"{re.escape(name)}"', start, stop): the first line in [start,
        stop) holding `name = "<name>"`."""
        if '"' in name or start < 0:
            return self.find(rf'name\s*=\s*"{re.escape(name)}"', start, stop)
        if self._named is None:
            self._named = {}
            for i, line in enumerate(self.lines):
                if "name" in line:
                    for m in _NAMED.finditer(line):
                        at = self._named.setdefault(m.group(1), [])
                        if not at or at[-1] != i:
                            at.append(i)
        return self._first(self._named.get(name, []), start, stop)

    def header_line(self, header: str) -> int:
        """find(rf"^{re.escape(header)}"): the first line starting with `header`, a table
        header "[...]"."""
        if not (header.startswith("[") and header.find("]") == len(header) - 1):
            return self.find(rf"^{re.escape(header)}")
        if self._brackets is None:
            self._brackets = {}
            for i, line in enumerate(self.lines):
                end = line.find("]") if line.startswith("[") else -1
                if end > 0:
                    self._brackets.setdefault(line[:end + 1], []).append(i)
        at = self._brackets.get(header)
        return at[0] + 1 if at else 0

    def entry_line(self, start: int, k: int, stop: int | None = None) -> int:
        """1-based line of entry k (0-based) of the array that opens at line `start`
        (`key = [`, one entry a line, as the spec's convention is): the k-th line after it
        that is neither blank nor a comment; `start` if there are not that many."""
        stop = len(self.lines) if stop is None else stop
        n = 0
        for i in range(start, stop):
            text = self.lines[i].strip()
            if text and not text.startswith("#"):
                if n == k:
                    return i + 1
                n += 1
        return start

    def block_span(self, header: str, k: int) -> tuple[int, int]:
        """0-based [start, stop) line span of the k-th (0-based) table `header`, e.g.
        '[[seed_slip]]', up to the next table header."""
        starts = self._exact.get(header)
        if starts is None:
            starts = self._exact[header] = [i for i, ln in enumerate(self.lines) if ln.strip() == header]
        if k >= len(starts):
            return 0, len(self.lines)
        s = starts[k]
        if self._headers is None:
            self._headers = [i for i, ln in enumerate(self.lines) if ln.startswith("[")]
        nxt = bisect.bisect_right(self._headers, s)
        return s, self._headers[nxt] if nxt < len(self._headers) else len(self.lines)


def load(path: str | Path) -> Spec:
    """Parse, validate and model the spec at `path`; raise SpecError naming file:line."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as e:
        raise SpecError(path, None, f"cannot read: {e.strerror}") from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        m = re.search(r"line (\d+)", str(e))
        raise SpecError(path, int(m.group(1)) if m else 0, f"TOML syntax: {e}") from None
    return _Builder(path, text, data).build()


class _Builder:
    def __init__(self, path: Path, text: str, data: dict):
        self.path, self.data, self.lines = path, data, _Lines(text)

    def fail(self, line: int, what: str, reason: str):
        raise SpecError(self.path, line, f"{what}: {reason}")

    def unknown(self, table: dict, allowed: set, what: str, span=(0, None)):
        for key in table:
            if key not in allowed:
                line = self.lines.find(rf"(^|[\s{{,]){re.escape(key)}\s*=", *span) or \
                    self.lines.find(rf"^\[+{re.escape(key)}\b", *span)
                self.fail(line, what, f"unknown key {key!r} (allowed: {', '.join(sorted(allowed))})")

    def table(self, value, line: int, what: str) -> dict:
        """`value` if it is a TOML table, else fail naming `what`."""
        if not isinstance(value, dict):
            self.fail(line, what, f"must be a table, not {_toml_kind(value)} {value!r}")
        return value

    def tables(self, value, line: int, what: str) -> list:
        """`value` if it is an array, else fail; its entries are checked where they are read
        (`table`), each at its own line."""
        if not isinstance(value, list):
            self.fail(line, what, f"must be an array of tables, not {_toml_kind(value)} {value!r}")
        return value

    def child_line(self, parent: str, name: str) -> int:
        """Line of `[parent.name]`, or of `name = ...` under it (an inline entry)."""
        esc = re.escape(name)
        return (self.lines.header_line(f"[{parent}.{name}]")
                or self.lines.find(rf"^\s*{esc}\s*=", max(self.lines.header_line(f"[{parent}]") - 1, 0))
                or self.lines.find(rf"^{re.escape(parent)}\s*=") or 1)

    def build(self) -> Spec:
        d = self.data
        self.unknown(d, _TOP_KEYS, "spec")
        head = self.table(d.get("spec", {}), self.lines.find(r"^\[?spec\b") or 1, "[spec]")
        self.unknown(head, {"name", "version", "doc"}, "[spec]")
        version = head.get("version", 1)
        if not _is_int(version) or version < 1:
            self.fail(self.lines.find(r"^version\s*=") or self.lines.find(r"^\[spec\]"), "spec.version",
                      f"must be a positive integer, not {version!r}")
        for key in ("name", "doc"):
            if not isinstance(head.get(key, ""), str):
                self.fail(self.lines.find(rf"^{key}\s*=") or 1, f"spec.{key}", "must be a string")
        framing = self.framing(self.table(d.get("framing", {}), self.lines.find(r"^\[?framing\b") or 1,
                                          "[framing]"))
        links = self.table(d.get("links", {}), self.lines.find(r"^\[?links\b") or 1, "[links]")
        shared = None  # the unframed link: (name, line)
        for lname, link in links.items():
            lline = self.child_line("links", lname)
            self.table(link, lline, f"links.{lname}")
            framed_link = "framing" in link
            self.unknown(link, _LINK_KEYS if framed_link else _LINK_KEYS | _RCOMM_KEYS, f"[links.{lname}]",
                         (lline - 1 if lline else 0, None))
            if not framed_link:
                if shared is not None:
                    self.fail(lline, f"links.{lname}", f"a second unframed link (links.{shared[0]} is one): "
                                                       "the generated rcomm layout is for one region")
                shared = (lname, lline)
            if not isinstance(link.get("doc"), str) or not link["doc"]:
                self.fail(lline, f"links.{lname}.doc", "missing (a non-empty string)")
            if link.get("word_bits") not in (16, 32) or isinstance(link.get("word_bits"), bool):
                self.fail(lline, f"links.{lname}.word_bits", "must be 16 or 32")
            if "framing" in link and link["framing"] != "serial":
                self.fail(self.lines.find(r"^framing\s*=", lline) or lline, f"links.{lname}.framing",
                          f"unknown framing {link['framing']!r} (known: serial; omit the key for an "
                          "unframed link)")
        if shared is None:
            self.fail(self.lines.find(r"^\[?links\b") or 1, "[links]",
                      "no unframed (shared-memory) link: the planner link's rcomm region needs one")
        slips = self.tables(d.get("seed_slip", []), self.lines.find(r"^\[*seed_slip\b") or 1, "seed_slip")
        for k, slip in enumerate(slips):
            span = self.lines.block_span("[[seed_slip]]", k)
            self.table(slip, span[0] + 1, f"seed_slip {k + 1}")
            self.unknown(slip, _SLIP_KEYS, f"seed_slip {k + 1}", span)
            for key in sorted(_SLIP_KEYS):
                if not isinstance(slip.get(key), str) or not slip[key]:
                    self.fail(span[0] + 1, f"seed_slip {k + 1}.{key}", "missing (a non-empty string)")
        enums = {}
        for kind, top in (("enum", "enums"), ("flags", "flags")):
            table = self.table(d.get(top, {}), self.lines.find(rf"^\[?{top}\b") or 1, f"[{top}]")
            for ename, e in table.items():
                line = self.child_line(top, ename)
                self.table(e, line, f"{kind} {ename}")
                self.unknown(e, _ENUM_KEYS, f"{kind} {ename}")
                if ename in enums:
                    self.fail(line, ename, "defined twice (enums and flags share one namespace)")
                if not _NAME_RE.match(ename):
                    self.fail(line, ename, f"{kind} name must be snake_case")
                if not isinstance(e.get("doc", ""), str):
                    self.fail(line, f"{ename}.doc", "must be a string")
                vline = self.lines.find(r"^\s*values\s*=", line) or line
                values = self.table(e.get("values", {}), vline, f"{ename}.values")
                for vname, v in values.items():
                    if not _NAME_RE.match(vname) or not _is_int(v):
                        self.fail(vline, f"{ename}.{vname}",
                                  f"values must be snake_case = integer, not {_toml_kind(v)} {v!r}")
                    if kind == "flags" and not 0 <= v < 32:
                        self.fail(vline, f"{ename}.{vname}", "flag bit must be 0..31")
                if len(set(values.values())) != len(values):
                    self.fail(vline, ename, "two names share a value")
                words = self.enum_words(e, kind, ename, values, line)
                enums[ename] = Enum(ename, kind, e.get("doc", ""), dict(values), line, words)
        messages, ids = {}, {}
        raws = self.tables(d.get("message", []), self.lines.find(r"^\[*message\b") or 1, "message")
        for k, raw in enumerate(raws):
            m = self.message(k, raw, links, framing, enums)
            if m.name in messages:
                self.fail(m.line, m.name, "message defined twice")
            messages[m.name] = m
            if m.framed:
                if m.id in ids:
                    self.fail(self.lines.find(r"^id\s*=", m.line - 1) or m.line, f"{m.name}.id",
                              f"id {m.id} is already the id of {ids[m.id]}")
                ids[m.id] = m.name
        msg_type = enums.get("msg_type")
        for m in messages.values():
            if m.framed and (msg_type is None or msg_type.values.get(m.name) != m.id):
                self.fail(m.line, m.name, f"enum msg_type must map {m.name} = {m.id}")
        rcomm = self.rcomm(shared[0], links[shared[0]], shared[1], messages)
        can = self.can(d["can"], framing, messages) if "can" in d else None
        spec = Spec(self.path, head.get("name", "navkit"), version,
                    head.get("doc", ""), dict(framing), dict(links), enums, messages,
                    list(slips), rcomm, can)
        _seal(spec)
        return spec

    def rcomm(self, lname: str, link: dict, lline: int, messages: dict) -> Rcomm:
        """The validated region layout of the unframed link `lname`, with its slots."""
        def at(key):
            return self.lines.find(rf"^{key}\s*=", lline) or lline

        def uint(key, lo, hi=0xFFFFFFFF):
            v = link.get(key)
            if v is None:
                self.fail(lline, f"links.{lname}.{key}", "missing (an integer)")
            if not _is_int(v) or not lo <= v <= hi:
                self.fail(at(key), f"links.{lname}.{key}", f"must be an integer in {lo}..{hi}, not {v!r}")
            return v
        magic = uint("magic", 1)
        version = uint("layout_version", 1)
        align = uint("slot_align", 4, 4096)
        if align & (align - 1):
            self.fail(at("slot_align"), f"links.{lname}.slot_align", f"{align} is not a power of two")
        header_bytes = uint("header_bytes", 4, 65536)
        if header_bytes % align:
            self.fail(at("header_bytes"), f"links.{lname}.header_bytes",
                      f"{header_bytes} is not a multiple of slot_align {align} (the first slot starts there)")
        words_at = uint("slot_words_at", 4, 4096)
        if words_at % 4:
            self.fail(at("slot_words_at"), f"links.{lname}.slot_words_at",
                      f"{words_at} is not a multiple of 4 (words are aligned uint32; the seq is at +0)")
        if "header" not in link:
            self.fail(lline, f"links.{lname}.header", "missing (a table of header word = byte offset)")
        header = self.table(link["header"], at("header"), f"links.{lname}.header")
        taken = {}
        for word in _RCOMM_HEADER_WORDS:
            if word not in header:
                self.fail(at("header"), f"links.{lname}.header.{word}", "missing (a byte offset)")
        for word, off in header.items():
            if word not in _RCOMM_HEADER_WORDS:
                self.fail(at("header"), f"links.{lname}.header", f"unknown header word {word!r} "
                                                                 f"(known: {', '.join(_RCOMM_HEADER_WORDS)})")
            if not _is_int(off) or off % 4 or not 0 <= off <= header_bytes - 4:
                self.fail(at("header"), f"links.{lname}.header.{word}",
                          f"{off!r} must be a multiple of 4 in 0..{header_bytes - 4} (a uint32 within header_bytes)")
            if off in taken:
                self.fail(at("header"), f"links.{lname}.header.{word}", f"offset {off} is also {taken[off]}'s")
            taken[off] = word
        if not isinstance(link.get("layout_doc"), str) or not link["layout_doc"]:
            self.fail(lline, f"links.{lname}.layout_doc", "missing (a non-empty string)")
        slots, end = {}, header_bytes
        for m in messages.values():
            if m.link == lname:
                slots[m.name] = end
                end += -(-(words_at + m.size) // align) * align
        return Rcomm(lname, magic, version, dict(header), header_bytes, align, words_at, slots, end,
                     link["layout_doc"])

    def can(self, raw, framing: dict, messages: dict) -> Can:
        """The validated [can] mapping: every serial message on one identifier pair, every
        identifier unique and within 11 bits, every frame within one ISO-TP message."""
        cline = self.lines.find(r"^\[can\]") or 1
        table = self.table(raw, cline, "[can]")
        self.unknown(table, _CAN_KEYS, "[can]", (cline - 1, None))

        def at(key):
            return self.lines.find(rf"^{key}\s*=", cline) or cline
        ints = {}
        for key, (lo, hi) in _CAN_INTS.items():
            v = table.get(key)
            if v is None:
                self.fail(cline, f"can.{key}", f"missing (an integer in {lo}..{hi})")
            if not _is_int(v) or not lo <= v <= hi:
                self.fail(at(key), f"can.{key}", f"must be an integer in {lo}..{hi}, not {v!r}"
                          + (" (only 11-bit identifiers are supported)" if key == "id_bits" else ""))
            ints[key] = v
        if 0x80 <= ints["fc_st_min"] <= 0xF0:
            self.fail(at("fc_st_min"), "can.fc_st_min",
                      f"0x{ints['fc_st_min']:02X} is a reserved STmin (0-127 ms or 0xF1-0xF9 for 100-900 us)")
        for key in ("doc", "transport_doc"):  # the docs print them
            if not isinstance(table.get(key), str) or not table[key]:
                self.fail(cline, f"can.{key}", "missing (a non-empty string)")
        if framing["max_frame_words"] * 2 > _ISOTP_MAX_BYTES:
            self.fail(cline, "[can]", f"framing.serial.max_frame_words {framing['max_frame_words']} makes frames "
                                      f"longer than one ISO-TP message ({_ISOTP_MAX_BYTES} bytes)")
        iline = self.lines.find(r"^\[can\.ids\]") or cline
        ids_raw = self.table(table.get("ids", {}), iline, "can.ids")
        ids, owner = {}, {}  # owner: identifier -> "message.key" that holds it
        top = 1 << ints["id_bits"]
        for name, entry in ids_raw.items():
            line = self.lines.find(rf"^\s*{re.escape(name)}\s*=", iline - 1) or iline
            what = f"can.ids.{name}"
            m = messages.get(name)
            if m is None or not m.framed:
                serial = ", ".join(x.name for x in messages.values() if x.framed)
                self.fail(line, what, ("an rcomm message does not travel on CAN" if m is not None
                                       else "not a message of the spec") + f" (serial messages: {serial})")
            self.table(entry, line, what)
            self.unknown(entry, _CAN_ID_KEYS, what, (line - 1, line))
            for key in ("id", "fc_id"):
                v = entry.get(key)
                if not _is_int(v) or not 0 <= v < top:
                    self.fail(line, f"{what}.{key}", f"{v!r} is not an {ints['id_bits']}-bit identifier "
                                                     f"(0..0x{top - 1:X})")
                if v in owner:
                    self.fail(line, f"{what}.{key}", f"identifier 0x{v:03X} is already {owner[v]}")
                owner[v] = f"can.ids.{name}.{key}"
            ids[name] = CanId(name, entry["id"], entry["fc_id"], line)
        for m in messages.values():
            if m.framed and m.name not in ids:
                self.fail(iline, "can.ids", f"serial message {m.name} has no identifiers (every serial "
                                            "message travels on CAN too)")
        ordered = {m.name: ids[m.name] for m in messages.values() if m.framed}
        return Can(ints["id_bits"], ints["bitrate"], ints["padding"], ints["fc_block_size"], ints["fc_st_min"],
                   ints["n_bs_ms"], ints["n_cr_ms"], ordered, table["doc"], table["transport_doc"], cline)

    def framing(self, tables: dict) -> dict:
        """The validated [framing.serial] table (the only framing there is)."""
        for fname in tables:
            if fname != "serial":
                self.fail(self.lines.find(rf"^\[framing\.{re.escape(fname)}\]"), f"[framing.{fname}]",
                          "unknown framing (known: serial)")
        framing = tables.get("serial")
        if framing is None:
            self.fail(1, "[framing.serial]", "missing")
        fline = self.child_line("framing", "serial")
        self.table(framing, fline, "framing.serial")
        self.unknown(framing, _FRAMING_KEYS, "[framing.serial]", (fline - 1, None))

        def at(key):
            return self.lines.find(rf"^{key}\s*=", fline) or fline
        for key in _FRAMING_REQUIRED:
            if key not in framing:
                self.fail(fline, f"framing.serial.{key}", "missing (an integer)")
            if not _is_int(framing[key]):
                self.fail(at(key), f"framing.serial.{key}", f"must be an integer, not {framing[key]!r}")
        if not 0 < framing["start_word"] <= 0xFFFF or framing["start_word"] & 0xFF == framing["start_word"] >> 8:
            self.fail(at("start_word"), "framing.serial.start_word",
                      f"0x{framing['start_word']:X} must be a 16-bit word of two different bytes")
        if framing["length_word"] != 3:
            self.fail(at("length_word"), "framing.serial.length_word",
                      "must be 3 (words 0-3: start, time tag, msg type, length are frozen)")
        if framing["hash_word"] != framing["length_word"] + 1:
            self.fail(at("hash_word"), "framing.serial.hash_word",
                      f"must be {framing['length_word'] + 1}, right after the header (words 0-5 are frozen)")
        if not framing["hash_word"] + 3 <= framing["max_frame_words"] <= 0x7FFF:
            self.fail(at("max_frame_words"), "framing.serial.max_frame_words",
                      f"must be {framing['hash_word'] + 3}..32767")
        for key in ("doc", "crc_doc", "hash_doc"):  # the docs print them
            if not isinstance(framing.get(key), str) or not framing[key]:
                self.fail(fline, f"framing.serial.{key}", "missing (a non-empty string)")
        if framing.get("crc") not in _CRCS:
            self.fail(at("crc"), "framing.serial.crc",
                      f"unsupported {framing.get('crc')!r} (supported: {', '.join(sorted(_CRCS))})")
        return framing

    def enum_words(self, e: dict, kind: str, ename: str, values: dict, line: int) -> dict:
        """The checked `words` table of enum `ename` (value name -> tuple of word names)."""
        if "words" not in e:
            return {}
        wline = self.lines.find(r"^\s*words\s*=", line) or line
        if kind != "enum":
            self.fail(wline, f"{ename}.words", "only an enum names words, not a flag set")
        table = self.table(e["words"], wline, f"{ename}.words")
        out = {}
        for vname, names in table.items():
            if vname not in values:
                self.fail(wline, f"{ename}.words.{vname}", f"not a value of enum {ename}")
            if (not isinstance(names, list) or not all(isinstance(n, str) and _NAME_RE.match(n) for n in names)
                    or len(set(names)) != len(names)):
                self.fail(wline, f"{ename}.words.{vname}", "must be a list of distinct snake_case names")
            out[vname] = tuple(names)
        return out

    def message(self, k: int, raw, links: dict, framing: dict, enums: dict) -> Message:
        """The k-th (0-based) [[message]]."""
        span = self.lines.block_span("[[message]]", k)
        line = span[0] + 1
        self.table(raw, line, f"message {k + 1}")
        name = raw.get("name", "?")
        if not isinstance(name, str) or not _NAME_RE.match(name):
            self.fail(self.lines.find(r"^name\s*=", *span) or line, f"message {k + 1}.name",
                      f"message name must be a snake_case string, not {name!r}")
        self.unknown(raw, _MESSAGE_KEYS, f"message {name}", span)

        def at(key):
            return self.lines.find(rf"^{key}\s*=", *span) or line
        link = raw.get("link")
        if not isinstance(link, str) or link not in links:
            self.fail(at("link"), f"{name}.link", f"unknown link {link!r} (known: {', '.join(links)})")
        allowed = _LINK_DIRECTIONS[links[link].get("framing")]
        direction = raw.get("direction")
        if not isinstance(direction, str) or direction not in allowed:
            kind = "serial-framed" if links[link].get("framing") else "unframed (shared-memory)"
            self.fail(at("direction"), f"{name}.direction",
                      f"{direction!r} is not a direction of link {link} ({kind}: {' or '.join(allowed)})")
        if not isinstance(raw.get("doc", ""), str):
            self.fail(at("doc"), f"{name}.doc", "must be a string")
        word_bits = links[link]["word_bits"]
        framed = links[link].get("framing") == "serial"
        if framed and not _is_int(raw.get("id")):
            self.fail(at("id"), f"{name}.id", f"serial messages need an integer id, not {raw.get('id')!r}")
        if not framed and "id" in raw:
            self.fail(at("id"), f"{name}.id", "only serial messages have an id (msg_type)")
        used = {}  # word -> owner
        if framed:
            used[0] = "start word"
            used[framing["length_word"]] = "length word"
        fields, seen = [], {}
        fline = self.lines.find(r"^field\s*=", *span) or line
        for i, f in enumerate(self.tables(raw.get("field", []), fline, f"{name}.field")):
            fld = self.field(name, i, f, span, fline, word_bits, used, enums, seen)
            seen[fld.name] = fld.line
            fields.append(fld)
        if framed:
            for must, word in (("time_tag", 1), ("msg_type", 2)):
                if not any(f.name == must and f.word == word for f in fields):
                    self.fail(line, name, f"serial messages need {must} at word {word}")
            for f in fields:
                if f.name == "spec_hash" and (f.word != framing["hash_word"] or f.type != "uint32"
                                              or f.count != 1):
                    self.fail(f.line, f"{name}.spec_hash",
                              f"must be one uint32 at word {framing['hash_word']} (framing.serial.hash_word: "
                              "words 0-5 of every frame carrying the hash are frozen across spec versions)")
        last = max(used) if used else -1
        words = last + 1 + (1 if framed else 0)  # + CRC word
        if framed and words > framing["max_frame_words"]:
            self.fail(line, name, f"{words} words exceed max_frame_words {framing['max_frame_words']}")
        if not framed:
            holes = sorted(set(range(words)) - set(used))
            if holes:
                self.fail(line, name, f"rcomm words {holes} are not defined (rcomm messages are dense)")
        constraints = self.constraints(name, raw.get("constraint", []), span, {f.name: f for f in fields})
        return Message(name, link, direction, raw.get("id"), raw.get("doc", ""),
                       tuple(fields), word_bits, words, line, constraints)

    def constraints(self, mname: str, raw, span, fields: dict) -> tuple:
        """The checked `constraint = [...]` entries of message mname, one Constraint per
        field a `nonzero` list names."""
        cline = self.lines.find(r"^constraint\s*=", *span) or span[0] + 1
        out, seen = [], set()
        for i, c in enumerate(self.tables(raw, cline, f"{mname}.constraint")):
            line = self.lines.entry_line(cline, i, span[1])
            what = f"{mname}.constraint {i + 1}"
            if not isinstance(c, dict):
                self.fail(line, what, f"must be an inline table {{ le = [a, b], doc = ... }}, not {_toml_kind(c)} {c!r}")
            self.unknown(c, set(_CONSTRAINT_KINDS) | {"doc"}, what, (line - 1, line))
            kinds = [k for k in _CONSTRAINT_KINDS if k in c]
            if len(kinds) != 1:
                self.fail(line, what, f"needs exactly one of {', '.join(_CONSTRAINT_KINDS)}")
            if not isinstance(c.get("doc"), str) or not c["doc"]:
                self.fail(line, what, "every constraint needs doc text")
            kind, names = kinds[0], c[kinds[0]]
            if (not isinstance(names, list) or not names or not all(isinstance(n, str) for n in names)
                    or (kind == "le" and len(names) != 2)):
                want = "two field names [a, b]" if kind == "le" else "a non-empty list of field names"
                self.fail(line, what, f"{kind} needs {want}, not {names!r}")
            for n in names:
                if n not in fields:
                    self.fail(line, what, f"unknown field {n!r} of {mname}")
                if n in ("msg_type", "time_tag", "spec_hash"):
                    self.fail(line, what, f"{n} is framing, not a field a constraint binds")
            if kind == "nonzero":
                for n in names:
                    f = fields[n]
                    if not f.min <= 0 <= f.max:
                        self.fail(line, what, f"{n}'s range {f.min}..{f.max} already excludes 0")
                    if not f.default:
                        self.fail(line, what, f"{n}'s default {f.default or 0} breaks it (give {n} a default)")
                    out.append(Constraint(kind, (n,), c["doc"], line))
            else:
                a, b = fields[names[0]], fields[names[1]]
                if a.name == b.name:
                    self.fail(line, what, f"le binds one field twice ({a.name})")
                if a.count != b.count:
                    self.fail(line, what, f"le binds {a.name} ({a.count} elements) and {b.name} "
                                          f"({b.count}): arrays of one count, or two scalars")
                if a.min > b.max:
                    self.fail(line, what, f"never holds: {a.name}'s min {a.min} is above {b.name}'s max {b.max}")
                if a.max <= b.min:
                    self.fail(line, what, f"always holds: {a.name}'s max {a.max} is not above {b.name}'s min {b.min}")
                if a.default is not None and b.default is not None and a.default > b.default:
                    self.fail(line, what, f"the defaults break it: {a.name} {a.default} > {b.name} {b.default}")
                out.append(Constraint(kind, (a.name, b.name), c["doc"], line))
            for con in out[-len(names) if kind == "nonzero" else -1:]:
                if (con.kind, con.fields) in seen:
                    self.fail(line, what, f"{con.text} is stated twice")
                seen.add((con.kind, con.fields))
        return tuple(out)

    def field(self, mname, i, f, span, fline, word_bits, used, enums, seen) -> Field:
        """Entry i (0-based) of message mname's `field = [...]` (which starts at line fline)."""
        if not isinstance(f, dict):
            self.fail(self.lines.entry_line(fline, i, span[1]), f"{mname}.field {i + 1}",
                      f"must be an inline table {{ name = ..., word = ..., ... }}, not {_toml_kind(f)} {f!r}")
        fname = f.get("name", "?")
        if not isinstance(fname, str):
            self.fail(self.lines.entry_line(fline, i, span[1]), f"{mname}.field {i + 1}",
                      f"field name must be a snake_case string, not {fname!r}")
        line = self.lines.name_line(fname, *span) or span[0] + 1
        if fname in seen:  # the second definition's line
            line = self.lines.name_line(fname, seen[fname], span[1]) or line
        what = f"{mname}.{fname}"
        self.unknown(f, _FIELD_KEYS, what, (line - 1, line))
        if not isinstance(fname, str) or not _NAME_RE.match(fname):
            self.fail(line, what, "field name must be snake_case")
        if fname in seen:
            self.fail(line, what, f"field defined twice (first at line {seen[fname]})")
        ftype = f.get("type")
        if not isinstance(ftype, str) or ftype not in TYPES:
            self.fail(line, what, f"type must be one of {', '.join(TYPES)}")
        size, _, tmin, tmax = TYPES[ftype]
        if word_bits == 32 and size != 4:
            self.fail(line, what, "rcomm fields are 32-bit (int32 or uint32)")
        word, count = f.get("word"), f.get("count", 1)
        if not _is_int(word) or word < 0:
            self.fail(line, what, "word must be a non-negative integer")
        if not _is_int(count) or count < 1:
            self.fail(line, what, "count must be a positive integer")
        span_words = size * 8 // word_bits * count
        for w in range(word, word + span_words):
            if w in used:
                self.fail(line, what, f"word {w} overlaps {used[w]}")
            used[w] = fname
        fmin, fmax = f.get("min", tmin), f.get("max", tmax)
        for key, v in (("min", fmin), ("max", fmax)):
            if not _is_int(v) or not tmin <= v <= tmax:
                self.fail(line, what, f"{key} {v!r} is outside {ftype} ({tmin}..{tmax})")
        if fmin > fmax:
            self.fail(line, what, f"min {fmin} > max {fmax}")
        default = f.get("default")
        if default is not None and (not _is_int(default) or not fmin <= default <= fmax):
            self.fail(line, what, f"default {default!r} is outside {fmin}..{fmax}")
        scale = f.get("scale", 1)
        if not isinstance(scale, (int, float)) or isinstance(scale, bool) or scale <= 0:
            self.fail(line, what, f"scale must be a positive number, not {scale!r}")
        units = f.get("units")
        if not isinstance(units, str) or not units.strip():
            self.fail(line, what, f"units must be a non-empty string ('1' for a dimensionless value, "
                                  f"'count', 'bits' for a mask), not {units!r}")
        for key in ("enum", "flags", "special"):
            ref = f.get(key)
            if ref is not None:
                e = enums.get(ref) if isinstance(ref, str) else None
                if e is None or e.kind != ("flags" if key == "flags" else "enum"):
                    self.fail(line, what, f"unknown {'enum' if key == 'special' else key} {ref!r}")
                if key == "flags":
                    width = size * 8
                    for bname, bit in e.values.items():
                        if bit >= width:
                            self.fail(line, what, f"flag {ref}.{bname} is bit {bit}, beyond the {width} bits "
                                                  f"of {ftype}")
                        if fmax < tmax and 1 << bit > fmax:
                            self.fail(line, what, f"flag {ref}.{bname} (bit {bit}, {1 << bit}) exceeds max {fmax}")
                if key == "enum" and any(not tmin <= v <= tmax for v in e.values.values()):
                    self.fail(line, what, f"enum {ref} has values outside {ftype}")
                if key == "special" and any(not fmin <= v <= fmax for v in e.values.values()):
                    self.fail(line, what, f"special values of {ref} must lie within {fmin}..{fmax}")
        if f.get("enum") is not None and f.get("special") is not None:
            self.fail(line, what, "a field has enum or special, not both")
        if f.get("enum") is not None and units != "bits":  # coded: a value must be a member
            codes = enums[f["enum"]].values.values()
            if not any(fmin <= v <= fmax for v in codes):
                self.fail(line, what, f"no value of enum {f['enum']} lies within {fmin}..{fmax}")
            if default is not None and default not in codes:
                self.fail(line, what, f"default {default} is not a value of enum {f['enum']}")
        if not isinstance(f.get("doc"), str) or not f["doc"]:
            self.fail(line, what, "every field needs doc text")
        return Field(fname, word, ftype, count, units, float(scale), fmin, fmax,
                     default, f.get("enum"), f.get("flags"), f.get("special"), f["doc"], line,
                     word * word_bits // 8)


def _seal(spec: Spec) -> None:
    """Compute the spec hash over everything that reaches the wire, and deliberately not
    doc text (docs/protocol.md says so): two ends built from wire-compatible specs agree,
    and any change of layout, type, unit, scale, range, default or enum differs."""
    model = {
        "name": spec.name, "version": spec.version,
        "framing": {k: v for k, v in spec.framing.items() if not k.endswith("doc")},
        "links": {k: {kk: vv for kk, vv in v.items() if not kk.endswith("doc")} for k, v in spec.links.items()},
        "enums": {e.name: [e.kind, e.values] + ([{k: list(v) for k, v in e.words.items()}] if e.words else [])
                  for e in spec.enums.values()},
        "messages": [
            [m.name, m.link, m.direction, m.id, m.words,
             [[f.name, f.word, f.type, f.count, f.units, f.scale, f.min, f.max, f.default,
               f.enum, f.flags, f.special] for f in m.fields],
             [[c.kind, *c.fields] for c in m.constraints]]
            for m in spec.messages.values()
        ],
    }
    if spec.can is not None:  # the CAN mapping reaches the wire too (identifiers, ISO-TP parameters)
        c = spec.can
        model["can"] = [c.id_bits, c.bitrate, c.padding, c.fc_block_size, c.fc_st_min, c.n_bs_ms, c.n_cr_ms,
                        [[i.message, i.id, i.fc_id] for i in c.ids.values()]]
    spec.canonical = json.dumps(model, sort_keys=True, separators=(",", ":"))
    digest = hashlib.sha256(spec.canonical.encode()).hexdigest()
    spec.hash_hex = digest
    spec.hash = int(digest[:8], 16)
