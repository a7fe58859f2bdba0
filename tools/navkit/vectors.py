"""Golden test vectors shared by the C tests (ctest) and the Python tests (pytest).

`tests/vectors/frames.txt`: one message per line, `message | case | check | hex |
field=value ...` (arrays as comma lists); serial messages as whole frames, rcomm
messages as their little-endian bytes. `case` is `defaults` for the spec defaults
(both codecs' defaults() must give these values), else min, max, random, below or
above (one field just outside its range), nonmember (a coded field, Field.coded, at
a value within its range that is none of its enum's) or constraint (the defaults with
one spec constraint broken); `check` is what validation against the spec says, worked
out here from the spec (the oracle both codecs' checks are held to): `ok`, or the name
of the first field, in spec order, outside its range or not one of its enum's values
(C: its index, NAVKIT_ERR_RANGE), or else the last field of the first broken
constraint (C: NAVKIT_ERR_CONSTRAINT).
`tests/vectors/streams.txt`: `direction | good,bad_crc,unknown_type,bad_length,
schema_mismatch,dropped_bytes | foreign hash | hex`: a byte stream, the parser counters
it must produce and the spec hash of the last frame of another spec version in it
(`none` if there is none). Both files name the spec and the hash they were made from.

    python -m navkit.vectors --write          # (re)make the golden files (review the diff!)
    python -m navkit.vectors --emit-c F       # C test source checking them (build step)
    python -m navkit.vectors --fuzz-corpus D  # the streams as libFuzzer seed files in D
"""

from __future__ import annotations

import argparse
import random
from pathlib import Path

import struct

from navkit import protocol as p
from navkit.gen import spec_label
from navkit.paths import repo_root
from navkit.spec import TYPES

__all__ = ["FRAMES", "STREAMS", "read_frames", "read_streams", "make_frames", "make_streams",
           "emit_c", "write_corpus", "main"]

FRAMES = repo_root() / "tests" / "vectors" / "frames.txt"
STREAMS = repo_root() / "tests" / "vectors" / "streams.txt"
_STATS = p.STATS
FOREIGN_HASH = 0xDEADBEEF  # the spec hash of the other spec version in the streams


def _header(what: str) -> str:
    return (f"# navkit golden vectors ({what}) for {spec_label(p.SPEC)}\n"
            f"# spec-hash 0x{p.SPEC_HASH:08x}\n")


def _spec_hash_of(path: Path) -> int:
    for line in path.read_text().splitlines():
        if line.startswith("# spec-hash "):
            return int(line.split()[2], 16)
    raise ValueError(f"{path}: no '# spec-hash' line")


def _fmt(fields: dict) -> str:
    return " ".join(f"{k}={','.join(map(str, v)) if isinstance(v, list) else v}" for k, v in fields.items())


def _encode(name: str, fields: dict) -> bytes:
    if p.SPEC.messages[name].framed:
        return p.encode_frame(name, fields, strict=False)
    return p.to_bytes(name, fields)


def _verdict(name: str, fields: dict) -> tuple[str, str]:
    """("ok", ""), or (the name of the first field (spec order) with a value outside its
    min..max or, for a coded field, not one of its enum's values, "range"), or else (the
    last field of the first broken constraint, "constraint"): the spec's verdict, not
    the codec's."""
    m = p.SPEC.messages[name]
    for f in m.fields:
        codes = set(p.SPEC.enums[f.enum].values.values()) if f.coded else None
        for v in fields[f.name] if f.count > 1 else [fields[f.name]]:
            if not f.min <= v <= f.max or (codes is not None and v not in codes):
                return f.name, "range"
    for c in m.constraints:
        def elems(n):
            return fields[n] if m.field(n).count > 1 else [fields[n]]
        a = elems(c.fields[0])
        b = elems(c.fields[1]) if c.kind == "le" else [0] * len(a)
        if any(x == 0 if c.kind == "nonzero" else x > y for x, y in zip(a, b)):
            return c.fields[-1], "constraint"
    return "ok", ""


def _check_result(name: str, fields: dict) -> str:
    """The check column: `ok` or the field _verdict names."""
    return _verdict(name, fields)[0]


def make_frames(seed: int = 1) -> str:
    """Golden frames: for every message its defaults, all-minimum, all-maximum, three
    seeded random value sets (values within the type, not the spec range, so the codec
    is exercised at the edges), the defaults with the first ranged field just below
    its min and the last just above its max, and for every coded field (but a framed
    message's msg_type, which the frame sets) whose range holds a value none of its
    enum's, the defaults with the smallest such value; each with its check verdict."""
    rng = random.Random(seed)
    lines = [_header("frames"), "# message | case | check | hex | fields\n"]
    for m in p.SPEC.messages.values():
        def fill(pick):
            out = {}
            for f in m.fields:
                vals = [pick(f) for _ in range(f.count)]
                out[f.name] = vals if f.count > 1 else vals[0]
            if m.framed:
                out["msg_type"] = m.id
            return out
        cases = [("defaults", p.defaults(m.name)),
                 ("min", fill(lambda f: TYPES[f.type][2])),
                 ("max", fill(lambda f: TYPES[f.type][3]))]
        cases += [("random", fill(lambda f: rng.randint(TYPES[f.type][2], TYPES[f.type][3])))
                  for _ in range(3)]
        below = [f for f in m.fields if f.min > TYPES[f.type][2]]
        above = [f for f in m.fields if f.max < TYPES[f.type][3]]
        edges = [("below", f, f.min - 1) for f in below[:1]] + [("above", f, f.max + 1) for f in above[-1:]]
        for f in m.fields:
            if f.coded and not (m.framed and f.name == "msg_type"):
                codes = set(p.SPEC.enums[f.enum].values.values())
                v = next((v for v in range(f.min, f.max + 1) if v not in codes), None)
                if v is not None:
                    edges.append(("nonmember", f, v))
        for case, f, v in edges:
            fields = p.defaults(m.name)
            fields[f.name] = [v] * f.count if f.count > 1 else v
            cases.append((case, fields))
        for c in m.constraints:  # the defaults with the last element of c broken
            fields = p.defaults(m.name)
            a = m.field(c.fields[0])
            if c.kind == "nonzero":
                bad = {a.name: 0}
            else:
                b = m.field(c.fields[1])
                bad = ({a.name: b.default + 1} if b.default + 1 <= a.max else {b.name: a.default - 1})
            for k, v in bad.items():
                if m.field(k).count > 1:
                    fields[k] = fields[k][:-1] + [v]
                else:
                    fields[k] = v
            cases.append(("constraint", fields))
        for case, fields in cases:
            lines.append(f"{m.name} | {case} | {_check_result(m.name, fields)} | "
                         f"{_encode(m.name, fields).hex()} | {_fmt(fields)}\n")
    return "".join(lines)


def _sealed(msg_type: int, words: int, payload: bytes = b"") -> bytes:
    """A CRC-good frame of `words` words with any type (payload after word 3, zeros)."""
    body = bytearray(2 * words - 2)
    struct.pack_into("<HHHH", body, 0, p.SPEC.framing["start_word"], 0, msg_type, words)
    body[8:8 + len(payload)] = payload
    return bytes(body) + struct.pack("<H", p.crc16(body))


def make_streams(seed: int = 2) -> str:
    """Golden parser streams: clean frames, garbage around and between them, a bad
    CRC, a truncated frame, a false start word, the other direction's type, a wrong
    length word, and frames of another spec version (schema mismatch: a config and a
    micro_data of other lengths; not when the CRC is bad, the type carries no spec hash
    or the length is beyond max_frame_words); the counters come from the Python parser
    and are checked by both."""
    rng = random.Random(seed)
    cmd = p.encode_frame("micro_cmd", {"fwd_cmd": 1, "speed": 200, "distance": 1000}, time_tag=1)
    cfg = p.encode_frame("micro_cfg_motion", p.defaults("micro_cfg_motion"), time_tag=2)
    data = p.encode_frame("micro_data", {"status": 1, "heading": 900}, time_tag=3)
    bad_crc = cmd[:-1] + bytes([cmd[-1] ^ 0x01])
    bad_len = cmd[:6] + b"\x30\x00" + cmd[8:]
    garbage = bytes(rng.randrange(256) for _ in range(40))
    max_words = p.SPEC.framing["max_frame_words"]
    cfg_id, data_id = p.SPEC.messages["micro_cfg_motion"].id, p.SPEC.messages["micro_data"].id
    foreign_cfg = p.foreign_frame("micro_cfg_motion", 30, FOREIGN_HASH, time_tag=5)
    foreign_data = p.foreign_frame("micro_data", 70, FOREIGN_HASH, time_tag=6)
    foreign_short = p.foreign_frame("micro_data", p.SPEC.framing["hash_word"] + 3, FOREIGN_HASH)
    foreign_bad_crc = foreign_cfg[:-1] + bytes([foreign_cfg[-1] ^ 0x80])
    cmd_other_len = _sealed(p.SPEC.messages["micro_cmd"].id, 60)   # micro_cmd carries no hash
    too_long = _sealed(cfg_id, max_words + 1)
    too_short = _sealed(data_id, p.SPEC.framing["hash_word"] + 2)
    cases = [
        ("to_micro", cmd + cfg + cmd),
        ("to_micro", garbage + cmd + garbage[:7] + cfg),
        ("to_micro", bad_crc + cmd),
        ("to_micro", cmd[:50] + cmd),
        ("to_micro", b"\xa5\xff\x01\x00" + cmd),
        ("to_micro", data + cmd),
        ("to_micro", bad_len + cfg),
        ("to_host", cmd + data + b"\xa5" + data),
        ("to_host", data[: len(data) - 1]),
        ("to_micro", foreign_cfg + cmd),
        ("to_micro", garbage[:9] + foreign_cfg + garbage[:5] + cfg),
        ("to_host", foreign_data + data + foreign_short + data),
        ("to_micro", foreign_bad_crc + cmd),
        ("to_micro", cmd_other_len + cmd),
        ("to_micro", too_long + cmd),
        ("to_host", too_short + data),
        ("to_micro", foreign_data + cmd),
        ("to_host", foreign_data[:-10]),
    ]
    lines = [_header("streams"),
             "# direction | " + ",".join(_STATS) + " | foreign hash | hex\n"]
    for direction, stream in cases:
        parser = p.Parser(p.DIR_TO_MICRO if direction == "to_micro" else p.DIR_TO_HOST)
        parser.feed(stream)
        counts = ",".join(str(parser.stats[k]) for k in _STATS)
        foreign = "none" if parser.foreign_hash is None else f"0x{parser.foreign_hash:08x}"
        lines.append(f"{direction} | {counts} | {foreign} | {stream.hex()}\n")
    return "".join(lines)


def _data_lines(path: Path):
    for n, line in enumerate(path.read_text().splitlines(), 1):
        if line.strip() and not line.startswith("#"):
            yield n, [part.strip() for part in line.split("|")]


def _same_spec(path: Path) -> None:
    if _spec_hash_of(path) != p.SPEC_HASH:
        raise ValueError(f"{path}: made for spec 0x{_spec_hash_of(path):08x}, the spec is "
                         f"0x{p.SPEC_HASH:08x}: review and rerun `python -m navkit.vectors --write`")


def read_frames(path: Path = FRAMES) -> list[tuple[str, str, str, bytes, dict]]:
    """(message, case, check verdict, bytes, fields) of every golden frame; ValueError
    naming path:line."""
    _same_spec(path)
    out = []
    for n, parts in _data_lines(path):
        if len(parts) != 5:
            raise ValueError(f"{path}:{n}: needs 5 columns (message | case | check | hex | fields)")
        name, case, verdict, hexs, fields_text = parts
        fields = {}
        for item in fields_text.split():
            k, _, v = item.partition("=")
            fields[k] = [int(x) for x in v.split(",")] if "," in v else int(v)
        if name not in p.SPEC.messages:
            raise ValueError(f"{path}:{n}: unknown message {name!r}")
        if verdict != "ok" and verdict not in fields:
            raise ValueError(f"{path}:{n}: check verdict {verdict!r} is neither ok nor a field")
        out.append((name, case, verdict, bytes.fromhex(hexs), fields))
    return out


def read_streams(path: Path = STREAMS) -> list[tuple[str, dict, int | None, bytes]]:
    """(direction, expected counters, expected foreign hash or None, stream bytes) of
    every golden stream; ValueError naming path:line."""
    _same_spec(path)
    out = []
    for n, parts in _data_lines(path):
        if len(parts) != 4:
            raise ValueError(f"{path}:{n}: needs 4 columns (direction | counters | foreign hash | hex)")
        direction, counts, foreign, hexs = parts
        out.append((direction, dict(zip(_STATS, map(int, counts.split(",")))),
                    None if foreign == "none" else int(foreign, 16), bytes.fromhex(hexs)))
    return out


def write_corpus(folder: Path) -> list[Path]:
    """Each golden stream as libFuzzer seed files in `folder` (byte 0: bit 0 the
    direction, 1 = to host; the rest the feed chunk - 1, as fuzz_proto_parser.c reads
    it): chunks of 1, 33 and 128 bytes. Returns the files written."""
    folder.mkdir(parents=True, exist_ok=True)
    written = []
    for i, (direction, _, _, data) in enumerate(read_streams()):
        for chunk in (1, 33, 128):
            head = (1 if direction == "to_host" else 0) | ((chunk - 1) << 1)
            path = folder / f"vector-stream-{i:02d}-chunk{chunk}"
            path.write_bytes(bytes([head]) + data)
            written.append(path)
    return written


def _c_bytes(b: bytes) -> str:
    return "{" + ",".join(f"0x{x:02x}" for x in b) + "}"


def _c_int(v: int, ftype: str) -> str:
    if ftype == "int32" and v == -0x80000000:
        return "(-2147483647L - 1)"
    return f"{v}" + ("L" if TYPES[ftype][0] == 4 and TYPES[ftype][1] else "UL" if TYPES[ftype][0] == 4 else "")


def emit_c(frames, streams) -> str:
    """A C test source: encode each golden struct and compare bytes; decode the golden
    bytes and compare the struct; run each golden stream through the C parser (in
    every chunking from 1 byte to whole) and compare the counters."""
    out = [f"/* GENERATED by navkit.vectors from tests/vectors (frames.txt, streams.txt) for spec "
           f"{spec_label(p.SPEC)}.\n * spec hash: 0x{p.SPEC_HASH:08x} (sha256 {p.SPEC.hash_hex}) */",
           '#include "navkit/navkit_proto.h"', "#include <stdio.h>", "#include <string.h>", "",
           "static int failures;",
           "#define CHECK(cond, what) do { if (!(cond)) { failures++; "
           "printf(\"FAIL %s: %s\\n\", what, #cond); } } while (0)", ""]
    calls = []
    for i, (name, case, verdict, data, fields) in enumerate(frames):
        m = p.SPEC.messages[name]
        t = f"navkit_{name}_t"
        body = [f"static void frame_{i}(void)", "{",
                f"    static const uint8_t want[] = {_c_bytes(data)};",
                f"    {t} m, d;", "    int bad = -2;", "    memset(&m, 0, sizeof m);", "    memset(&d, 0, sizeof d);"]
        for f in m.fields:
            vals = fields[f.name] if f.count > 1 else [fields[f.name]]
            for k, v in enumerate(vals):
                sfx = f"[{k}]" if f.count > 1 else ""
                body.append(f"    m.{f.name}{sfx} = ({'u' if not f.signed else ''}int{f.size * 8}_t){_c_int(v, f.type)};")
        what = f'"{name} vector {i} ({case})"'
        if case == "defaults":
            body += [f"    navkit_{name}_defaults(&d);",
                     f"    CHECK(memcmp(&d, &m, sizeof m) == 0, {what} \": defaults\");",
                     "    memset(&d, 0, sizeof d);"]
        if verdict == "ok":
            body.append(f"    CHECK(navkit_{name}_check(&m, &bad) == NAVKIT_OK && bad == -1, {what} \": check ok\");")
        else:
            code = "NAVKIT_ERR_" + _verdict(name, fields)[1].upper()
            body.append(f"    CHECK(navkit_{name}_check(&m, &bad) == {code} && "
                        f"bad == NAVKIT_{name.upper()}_FIELD_{verdict.upper()}, {what} \": check {verdict}\");")
        if m.constraints:
            broken = ">= 0" if _verdict(name, fields)[1] == "constraint" else "< 0" if verdict == "ok" else None
            if broken:
                body.append(f"    CHECK(navkit_{name}_constraint_check(&m, NULL, NULL) {broken}, {what} "
                            f"\": constraint_check\");")
        if m.framed:
            body += ["    uint8_t got[sizeof want];",
                     f"    CHECK(navkit_{name}_encode(&m, got, sizeof got) == sizeof want, {what});",
                     f"    CHECK(memcmp(got, want, sizeof want) == 0, {what});",
                     f"    CHECK(navkit_{name}_encode(&m, got, sizeof got - 1) == 0, {what});",
                     f"    CHECK(navkit_{name}_decode(want, sizeof want, &d) == NAVKIT_OK, {what});",
                     f"    CHECK(memcmp(&d, &m, sizeof m) == 0, {what});"]
        else:
            body += ["    uint8_t got[sizeof want];", f"    int32_t words[NAVKIT_{name.upper()}_WORDS];",
                     f"    navkit_{name}_store(&m, got);",
                     f"    CHECK(memcmp(got, want, sizeof want) == 0, {what});",
                     f"    navkit_{name}_load(want, &d);",
                     f"    CHECK(memcmp(&d, &m, sizeof m) == 0, {what});",
                     f"    navkit_{name}_pack(&m, words);", "    memset(&d, 0, sizeof d);",
                     f"    navkit_{name}_unpack(words, &d);",
                     f"    CHECK(memcmp(&d, &m, sizeof m) == 0, {what});"]
        body.append("}")
        out += body + [""]
        calls.append(f"    frame_{i}();")
    out.append("static void field_ranges(void)\n{")  # navkit_<msg>_in_range at each field's edges
    for m in p.SPEC.messages.values():
        for i, f in enumerate(m.fields):
            what = f'"{m.name}.{f.name} in_range"'
            out.append(f"    CHECK(navkit_{m.name}_in_range({i}, {f.min}LL) && navkit_{m.name}_in_range({i}, {f.max}LL) "
                       f"&& !navkit_{m.name}_in_range({i}, {f.min - 1}LL) && !navkit_{m.name}_in_range({i}, {f.max + 1}LL)"
                       f", {what});")
        out.append(f"    CHECK(!navkit_{m.name}_in_range({len(m.fields)}, 0), \"{m.name} in_range unknown field\");")
    out.append("}\n")
    calls.append("    field_ranges();")
    out.append("static void run_stream(const char *what, navkit_dir_t dir, const uint8_t *s, size_t n,")
    out.append(f"                       const uint32_t want[{len(_STATS)}], uint32_t foreign_hash)")
    out.append("{\n    size_t chunk;\n    for (chunk = 1; chunk <= n; chunk = chunk < 8 ? chunk + 1 : chunk * 2) {")
    out.append("        navkit_parser_t parser;\n        size_t at = 0, frame_len;\n        const uint8_t *frame;")
    out.append("        navkit_parser_init(&parser, dir);")
    out.append("        while (at < n) {")
    out.append("            size_t len = n - at < chunk ? n - at : chunk;")
    out.append("            size_t took = navkit_parser_feed(&parser, s + at, len);")
    out.append("            at += took;")
    out.append("            while (navkit_parser_next(&parser, &frame, &frame_len)) {")
    out.append("                CHECK(navkit_frame_check(frame, frame_len, dir) == NAVKIT_OK, what);")
    out.append("            }\n        }")
    out.append("        CHECK(parser.stats.good == want[0], what);")
    out.append("        CHECK(parser.stats.bad_crc == want[1], what);")
    out.append("        CHECK(parser.stats.unknown_type == want[2], what);")
    out.append("        CHECK(parser.stats.bad_length == want[3], what);")
    out.append("        CHECK(parser.stats.schema_mismatch == want[4], what);")
    out.append("        CHECK(parser.stats.dropped_bytes == want[5], what);")
    out.append("        CHECK(parser.foreign_hash == foreign_hash, what);")
    out.append("    }\n}\n")
    for i, (direction, counts, foreign, data) in enumerate(streams):
        d = "NAVKIT_DIR_TO_MICRO" if direction == "to_micro" else "NAVKIT_DIR_TO_HOST"
        out.append(f"static void stream_{i}(void)\n{{")
        out.append(f"    static const uint8_t s[] = {_c_bytes(data)};")
        out.append(f"    static const uint32_t want[{len(_STATS)}] = {{" + ", ".join(f"{counts[k]}u" for k in _STATS) + "};")
        out.append(f'    run_stream("stream {i}", {d}, s, sizeof s, want, 0x{foreign or 0:08x}UL);\n}}\n')
        calls.append(f"    stream_{i}();")
    out.append("int main(void)\n{")
    out += calls
    out.append(f'    printf("%d failure(s) in {len(frames)} frame and {len(streams)} stream vectors\\n", failures);')
    out.append("    return failures ? 1 : 0;\n}\n")
    return "\n".join(out)


def main(argv=None) -> int:
    """Command line: --write the golden files, or --emit-c a C test source."""
    ap = argparse.ArgumentParser(prog="python -m navkit.vectors", description=__doc__.splitlines()[0])
    ap.add_argument("--write", action="store_true", help="rewrite tests/vectors/*.txt")
    ap.add_argument("--emit-c", type=Path, metavar="FILE", help="write the C test source to FILE")
    ap.add_argument("--fuzz-corpus", type=Path, metavar="DIR",
                    help="write the golden streams as libFuzzer seed files into DIR")
    args = ap.parse_args(argv)
    if args.write:
        FRAMES.write_text(make_frames())
        STREAMS.write_text(make_streams())
    if args.emit_c:
        text = emit_c(read_frames(), read_streams())
        if not args.emit_c.exists() or args.emit_c.read_text() != text:
            args.emit_c.parent.mkdir(parents=True, exist_ok=True)
            args.emit_c.write_text(text)
    if args.fuzz_corpus:
        print(f"navkit.vectors: {len(write_corpus(args.fuzz_corpus))} seed files in {args.fuzz_corpus}")
    if not (args.write or args.emit_c or args.fuzz_corpus):
        ap.print_help()
        return 2
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
