"""`navkit bench-proto`: frames/s of the codec for micro_cmd, in Python and in C, each
beside a bare memcpy+CRC of the same bytes on the same machine.

Prints one line per measurement (language, what, frames/s, us or ns per frame). The C
figures come from the `navkit-proto-bench` binary in the build folder."""

from __future__ import annotations

import subprocess
import sys
import time

from navkit.cli import positive_int

__all__ = ["add_arguments", "run"]


def add_arguments(parser) -> None:
    parser.add_argument("--frames", type=positive_int, default=50000,
                        help="frames per Python measurement, >= 1 (default %(default)s; C runs 40x that)")


def _report(what: str, n: int, dt: float) -> None:
    print(f"py {what:<28} {n / dt:12.0f} frames/s {1e6 * dt / n:8.2f} us/frame")


def run(args) -> int:
    from navkit import protocol as p
    from navkit.paths import build_dir
    n = args.frames
    fields = {"fwd_cmd": 1, "speed": 200, "distance": 1000}
    t0 = time.perf_counter()
    for i in range(n):
        frame = p.encode_frame("micro_cmd", fields, time_tag=i & 0xFFFF)
    _report("micro_cmd encode", n, time.perf_counter() - t0)
    parser = p.Parser(p.DIR_TO_MICRO)
    t0 = time.perf_counter()
    for _ in range(n):
        for event in parser.feed(frame):
            p.check(event.name, event.fields)
    _report("micro_cmd parse+decode+check", n, time.perf_counter() - t0)
    if parser.stats["good"] != n:
        print(f"navkit bench-proto: the parser returned {parser.stats['good']} of {n} frames "
              f"({parser.stats})", file=sys.stderr)
        return 1
    t0 = time.perf_counter()
    for _ in range(n):
        p.crc16(bytes(bytearray(frame)))
    _report("baseline memcpy+crc16", n, time.perf_counter() - t0)
    exe = build_dir() / "tests" / "c" / "protocol" / "navkit-proto-bench"
    if not exe.exists():
        print(f"c  (not built: {exe}; run `make build`)")
        return 1
    return subprocess.run([str(exe), "--frames", str(40 * n)]).returncode
