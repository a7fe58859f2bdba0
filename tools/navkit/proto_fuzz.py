"""`navkit fuzz-proto`: differential fuzzing of the Python and C frame parsers.

Each case mutates a stream of valid frames and frames of another spec version
(hash-carrying types at other lengths: schema mismatch), with bit flips, byte inserts,
deletes, duplicated and truncated frames and start-word-rich garbage; feeds it to both
parsers in random chunkings, and requires the same frames at the same offsets, the same
counters and the same foreign hash and offset; every frame accepted must decode. The C
parser is reached through the test shim library `libnavkit_proto_shim.so` in the build
folder (`cmake --build <build> --target navkit_proto_shim`).

    navkit fuzz-proto --seed 1 --count 2000      # a fixed number of cases
    navkit fuzz-proto --seconds 600              # a long run
"""

from __future__ import annotations

import argparse
import ctypes
import random
import sys
import time

from navkit.cli import positive_int

__all__ = ["add_arguments", "run", "CParser", "ShimMissing", "shim_path", "mutated_stream",
           "check_case"]


class ShimMissing(RuntimeError):
    """The C parser's test shim is not built (or does not load); the text says how."""


def shim_path():
    """Where the shim library is: `<build>/tests/c/protocol/libnavkit_proto_shim.so`."""
    from navkit.paths import build_dir
    return build_dir() / "tests" / "c" / "protocol" / "libnavkit_proto_shim.so"


class CParser:
    """The C parser (through the shim) with the Python Parser's vocabulary."""

    _lib = None

    def __init__(self, direction: str):
        from navkit import protocol as p
        if CParser._lib is None:
            path = shim_path()
            if not path.exists():
                raise ShimMissing(f"{path} is missing: build it with `cmake --build {path.parents[3]} "
                                  "--target navkit_proto_shim` (or `make build`; NAVKIT_BUILD_DIR picks "
                                  "the build folder)")
            try:
                lib = ctypes.CDLL(str(path))
            except OSError as e:
                raise ShimMissing(f"{path} does not load: {e}: rebuild it with `cmake --build "
                                  f"{path.parents[3]} --target navkit_proto_shim`") from None
            lib.shim_new.restype = ctypes.c_void_p
            lib.shim_new.argtypes = [ctypes.c_int]
            lib.shim_feed.restype = ctypes.c_int
            lib.shim_feed.argtypes = [ctypes.c_void_p, ctypes.c_char_p, ctypes.c_size_t, ctypes.c_size_t,
                                      ctypes.POINTER(ctypes.c_uint32), ctypes.c_int]
            lib.shim_stats.argtypes = [ctypes.c_void_p, ctypes.POINTER(ctypes.c_uint32)]
            lib.shim_free.argtypes = [ctypes.c_void_p]
            CParser._lib = lib
        self._h = CParser._lib.shim_new(1 if direction == p.DIR_TO_HOST else 0)

    def feed(self, data: bytes, chunk: int) -> list[int]:
        """Byte offsets of the frames the C parser returns for `data`."""
        offsets = (ctypes.c_uint32 * 4096)()
        n = CParser._lib.shim_feed(self._h, data, len(data), chunk, offsets, 4096)
        return list(offsets[:n])

    def stats(self) -> dict:
        """The counters (protocol.STATS) and `foreign_hash`, `foreign_offset` (None
        while there was no schema mismatch, as in the Python Parser)."""
        from navkit import protocol as p
        out = (ctypes.c_uint32 * 8)()
        CParser._lib.shim_stats(self._h, out)
        stats = dict(zip(p.STATS, out))
        seen = stats["schema_mismatch"] > 0
        stats["foreign_hash"] = out[6] if seen else None
        stats["foreign_offset"] = out[7] if seen else None
        return stats

    def __del__(self):
        if self._lib is not None and getattr(self, "_h", None):
            self._lib.shim_free(self._h)


def mutated_stream(rng: random.Random) -> bytes:
    """A stream of random valid frames, then mutated."""
    from navkit import protocol as p
    from navkit.spec import TYPES
    out = bytearray()
    hashed = [m for m in p.SPEC.serial_messages() if any(f.name == "spec_hash" for f in m.fields)]
    lo, hi = p.SPEC.framing["hash_word"] + 3, p.SPEC.framing["max_frame_words"]
    for _ in range(rng.randint(1, 12)):
        if rng.random() < 0.15:  # a frame of another spec version
            frame = p.foreign_frame(rng.choice(hashed).name, rng.randint(lo, hi), rng.getrandbits(32),
                                    rng.getrandbits(16))
        else:
            m = rng.choice(p.SPEC.serial_messages())
            fields = {}
            for f in m.fields:
                vals = [rng.randint(TYPES[f.type][2], TYPES[f.type][3]) for _ in range(f.count)]
                fields[f.name] = vals if f.count > 1 else vals[0]
            fields["msg_type"] = m.id
            frame = p.encode_frame(m.name, fields, strict=False)
        if rng.random() < 0.2:
            frame = frame[:rng.randrange(len(frame))]
        out += frame
        if rng.random() < 0.3:
            out += bytes(rng.choice((0xA5, 0xFF, 0x01, 0x11, rng.randrange(256)))
                         for _ in range(rng.randrange(20)))
    for _ in range(rng.randrange(6)):
        if not out:
            break
        op, i = rng.randrange(4), rng.randrange(len(out))
        if op == 0:
            out[i] ^= 1 << rng.randrange(8)
        elif op == 1:
            out.insert(i, rng.randrange(256))
        elif op == 2:
            del out[i]
        else:
            j = rng.randrange(i, len(out) + 1)
            out[i:i] = out[i:j]
    return bytes(out)


def check_case(rng: random.Random) -> str | None:
    """Run one random case through both parsers; a description of any difference."""
    from navkit import protocol as p
    data = mutated_stream(rng)
    direction = rng.choice((p.DIR_TO_MICRO, p.DIR_TO_HOST))
    chunk = rng.choice((1, 2, 5, 17, 64, 4096))
    py = p.Parser(direction)
    frames = []
    for i in range(0, len(data), chunk):
        frames += [e for e in py.feed(data[i:i + chunk]) if isinstance(e, p.Frame)]
    c = CParser(direction)
    c_offsets = c.feed(data, chunk)
    if [f.offset for f in frames] != c_offsets:
        return f"frame offsets differ: python {[f.offset for f in frames]} c {c_offsets} on {data.hex()}"
    py_stats = {**py.stats, "foreign_hash": py.foreign_hash, "foreign_offset": py.foreign_offset}
    if py_stats != c.stats():
        return f"counters differ: python {py_stats} c {c.stats()} on {data.hex()}"
    for f in frames:
        p.decode_frame(f.raw, direction)
    return None


def _seconds(text: str) -> float:
    try:
        s = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not 0 < s < float("inf"):    # also refuses nan
        raise argparse.ArgumentTypeError(f"must be a positive, finite time in s, not {text}")
    return s


def add_arguments(parser) -> None:
    parser.add_argument("--seed", type=int, default=1, help="random seed (default %(default)s)")
    runs = parser.add_mutually_exclusive_group()
    runs.add_argument("--count", type=positive_int, default=2000,
                      help="cases to run, >= 1 (default %(default)s)")
    runs.add_argument("--seconds", type=_seconds, help="run for this long (s, > 0) instead of --count")


def run(args) -> int:
    rng = random.Random(args.seed)
    t0, n = time.monotonic(), 0
    try:
        CParser("host_to_micro")
    except ShimMissing as e:
        print(f"navkit fuzz-proto: {e}", file=sys.stderr)
        return 2
    while (time.monotonic() - t0 < args.seconds) if args.seconds else (n < args.count):
        problem = check_case(rng)
        n += 1
        if problem:
            print(f"navkit fuzz-proto: seed {args.seed}, case {n}: {problem}", file=sys.stderr)
            return 1
    print(f"fuzz-proto: seed {args.seed}: {n} cases, Python and C parsers agree "
          f"({time.monotonic() - t0:.1f} s)")
    return 0
