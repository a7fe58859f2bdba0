"""Golden test vectors shared by the C tests (ctest) and the Python tests (pytest).

`tests/vectors/frames.txt`: one message per line, `message | hex | field=value ...`
(arrays as comma lists); serial messages as whole frames, rcomm messages as their
little-endian bytes. `tests/vectors/streams.txt`: `direction | good,bad_crc,
unknown_type,bad_length,dropped_bytes | hex`: a byte stream and the parser counters
it must produce. Both files name the spec hash they were made from.

    python -m navkit.vectors --write      # (re)make the golden files (review the diff!)
    python -m navkit.vectors --emit-c F   # C test source checking them (build step)
"""

from __future__ import annotations

import argparse
import random
from pathlib import Path

from navkit import protocol as p
from navkit.paths import repo_root
from navkit.spec import TYPES

__all__ = ["FRAMES", "STREAMS", "read_frames", "read_streams", "make_frames", "make_streams",
           "emit_c", "main"]

FRAMES = repo_root() / "tests" / "vectors" / "frames.txt"
STREAMS = repo_root() / "tests" / "vectors" / "streams.txt"
_STATS = ("good", "bad_crc", "unknown_type", "bad_length", "dropped_bytes")


def _header(what: str) -> str:
    return (f"# navkit golden vectors ({what}) for protocol/navkit.toml\n"
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


def make_frames(seed: int = 1) -> str:
    """Golden frames: for every message its defaults, all-minimum, all-maximum and
    three seeded random value sets (values within the type, not the spec range, so
    the codec is exercised at the edges)."""
    rng = random.Random(seed)
    lines = [_header("frames"), "# message | hex | fields\n"]
    for m in p.SPEC.messages.values():
        def fill(pick):
            out = {}
            for f in m.fields:
                vals = [pick(f) for _ in range(f.count)]
                out[f.name] = vals if f.count > 1 else vals[0]
            if m.framed:
                out["msg_type"] = m.id
            return out
        cases = [p.defaults(m.name),
                 fill(lambda f: TYPES[f.type][2]),
                 fill(lambda f: TYPES[f.type][3])]
        cases += [fill(lambda f: rng.randint(TYPES[f.type][2], TYPES[f.type][3])) for _ in range(3)]
        for fields in cases:
            lines.append(f"{m.name} | {_encode(m.name, fields).hex()} | {_fmt(fields)}\n")
    return "".join(lines)


def make_streams(seed: int = 2) -> str:
    """Golden parser streams: clean frames, garbage around and between them, a bad
    CRC, a truncated frame, a false start word, the other direction's type, a wrong
    length word; the counters come from the Python parser and are checked by both."""
    rng = random.Random(seed)
    cmd = p.encode_frame("micro_cmd", {"fwd_cmd": 1, "speed": 200, "distance": 1000}, time_tag=1)
    cfg = p.encode_frame("micro_cfg_motion", p.defaults("micro_cfg_motion"), time_tag=2)
    data = p.encode_frame("micro_data", {"status": 1, "heading": 900}, time_tag=3)
    bad_crc = cmd[:-1] + bytes([cmd[-1] ^ 0x01])
    bad_len = cmd[:6] + b"\x30\x00" + cmd[8:]
    garbage = bytes(rng.randrange(256) for _ in range(40))
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
    ]
    lines = [_header("streams"), "# direction | good,bad_crc,unknown_type,bad_length,dropped_bytes | hex\n"]
    for direction, stream in cases:
        parser = p.Parser(p.DIR_TO_MICRO if direction == "to_micro" else p.DIR_TO_HOST)
        parser.feed(stream)
        counts = ",".join(str(parser.stats[k]) for k in _STATS)
        lines.append(f"{direction} | {counts} | {stream.hex()}\n")
    return "".join(lines)


def _data_lines(path: Path):
    for n, line in enumerate(path.read_text().splitlines(), 1):
        if line.strip() and not line.startswith("#"):
            yield n, [part.strip() for part in line.split("|")]


def read_frames(path: Path = FRAMES) -> list[tuple[str, bytes, dict]]:
    """(message, bytes, fields) of every golden frame; ValueError naming path:line."""
    if _spec_hash_of(path) != p.SPEC_HASH:
        raise ValueError(f"{path}: made for spec 0x{_spec_hash_of(path):08x}, the spec is "
                         f"0x{p.SPEC_HASH:08x}: review and rerun `python -m navkit.vectors --write`")
    out = []
    for n, (name, hexs, fields_text) in _data_lines(path):
        fields = {}
        for item in fields_text.split():
            k, _, v = item.partition("=")
            fields[k] = [int(x) for x in v.split(",")] if "," in v else int(v)
        if name not in p.SPEC.messages:
            raise ValueError(f"{path}:{n}: unknown message {name!r}")
        out.append((name, bytes.fromhex(hexs), fields))
    return out


def read_streams(path: Path = STREAMS) -> list[tuple[str, dict, bytes]]:
    """(direction, expected counters, stream bytes) of every golden stream."""
    out = []
    for _, (direction, counts, hexs) in _data_lines(path):
        out.append((direction, dict(zip(_STATS, map(int, counts.split(",")))), bytes.fromhex(hexs)))
    return out


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
    out = [f"/* GENERATED by navkit.vectors from tests/vectors (frames.txt, streams.txt); spec hash 0x{p.SPEC_HASH:08x}. */",
           '#include "navkit/navkit_proto.h"', "#include <stdio.h>", "#include <string.h>", "",
           "static int failures;",
           "#define CHECK(cond, what) do { if (!(cond)) { failures++; "
           "printf(\"FAIL %s: %s\\n\", what, #cond); } } while (0)", ""]
    calls = []
    for i, (name, data, fields) in enumerate(frames):
        m = p.SPEC.messages[name]
        t = f"navkit_{name}_t"
        body = [f"static void frame_{i}(void)", "{",
                f"    static const uint8_t want[] = {_c_bytes(data)};",
                f"    {t} m, d;", "    memset(&m, 0, sizeof m);", "    memset(&d, 0, sizeof d);"]
        for f in m.fields:
            vals = fields[f.name] if f.count > 1 else [fields[f.name]]
            for k, v in enumerate(vals):
                sfx = f"[{k}]" if f.count > 1 else ""
                body.append(f"    m.{f.name}{sfx} = ({'u' if not f.signed else ''}int{f.size * 8}_t){_c_int(v, f.type)};")
        what = f'"{name} vector {i}"'
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
    out.append("static void run_stream(const char *what, navkit_dir_t dir, const uint8_t *s, size_t n,")
    out.append("                       const uint32_t want[5])")
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
    out.append("        CHECK(parser.stats.dropped_bytes == want[4], what);")
    out.append("    }\n}\n")
    for i, (direction, counts, data) in enumerate(streams):
        d = "NAVKIT_DIR_TO_MICRO" if direction == "to_micro" else "NAVKIT_DIR_TO_HOST"
        out.append(f"static void stream_{i}(void)\n{{")
        out.append(f"    static const uint8_t s[] = {_c_bytes(data)};")
        out.append("    static const uint32_t want[5] = {" + ", ".join(f"{counts[k]}u" for k in _STATS) + "};")
        out.append(f'    run_stream("stream {i}", {d}, s, sizeof s, want);\n}}\n')
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
    args = ap.parse_args(argv)
    if args.write:
        FRAMES.write_text(make_frames())
        STREAMS.write_text(make_streams())
    if args.emit_c:
        text = emit_c(read_frames(), read_streams())
        if not args.emit_c.exists() or args.emit_c.read_text() != text:
            args.emit_c.parent.mkdir(parents=True, exist_ok=True)
            args.emit_c.write_text(text)
    if not (args.write or args.emit_c):
        ap.print_help()
        return 2
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
