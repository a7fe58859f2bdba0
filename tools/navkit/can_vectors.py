"""Golden vectors of ISO-TP reception on the kit's CAN mapping, shared by the C firmware's
can_tp (ctest fw_test_can_tp reads the file) and navkit.can (pytest checks the file is what
it makes): the two implementations are held to the same behaviour frame by frame.

`tests/vectors/can.txt`: one case a line, `case | frames | messages | replies | stats`:
- frames: what reaches the micro's receiver, `T:ID#DATA` each (T ms, ID hex: 3 digits
  an 11-bit identifier, 8 digits an extended one; DATA hex, its length the DLC, `R` a
  remote frame);
- messages: the hex of each message completed, in order (`-`: none);
- replies: the flow control frames the receiver sends, `ID#DATA` (`-`: none);
- stats: the receiver's counters, in navkit.can.RX_STATS order.

    python -m navkit.can_vectors --write     # (re)make the file (review the diff!)
"""

from __future__ import annotations

import argparse
import random

import can

from navkit import can as nc
from navkit import protocol as p
from navkit.gen import spec_label
from navkit.paths import repo_root

__all__ = ["CAN_VECTORS", "make_vectors", "read_vectors", "main"]

CAN_VECTORS = repo_root() / "tests" / "vectors" / "can.txt"
_DIR = p.DIR_TO_MICRO  # the micro's receiver


def _fmt(t: int, m: can.Message) -> str:
    ident = f"{m.arbitration_id:08X}" if m.is_extended_id else f"{m.arbitration_id:03X}"
    return f"{t}:{ident}#" + ("R" if m.is_remote_frame else bytes(m.data).hex().upper())


def _case(name: str, frames: list[tuple[int, can.Message]]) -> str:
    rx = nc.Receiver(_DIR, n_cr=nc.CAN.n_cr_ms)  # times in ms: integer deadlines, as in C
    got, replies = [], []
    for t, m in frames:
        r = rx.feed(m, t)
        if r is not None:
            got.append(r.data.hex().upper())
        replies += [f"{f.arbitration_id:03X}#{bytes(f.data).hex().upper()}" for f in rx.take_replies()]
    stats = ",".join(str(rx.stats[k]) for k in nc.RX_STATS)
    return " | ".join([name, " ".join(_fmt(t, m) for t, m in frames), ",".join(got) or "-",
                       " ".join(replies) or "-", stats])


def _timed(frames, t0: int = 0, dt: int = 1) -> list[tuple[int, can.Message]]:
    return [(t0 + k * dt, m) for k, m in enumerate(frames)]


def make_vectors(seed: int = 1) -> str:
    """The cases: every to-micro message whole; one consecutive frame lost, two swapped;
    a first frame and a single frame during a reception; a consecutive frame too late;
    one of each bad frame; an overflow; other identifiers; then seeded random streams of
    whole, cut, mangled and interleaved messages."""
    rng = random.Random(seed)
    msgs = [m for m in p.SPEC.serial_messages() if m.direction == _DIR]
    cmd_id = nc.CAN.ids["micro_cmd"].id

    def frames_of(name: str, tag: int) -> list[can.Message]:
        return nc.segment(nc.CAN.ids[name].id, p.encode_frame(name, p.defaults(name), time_tag=tag))
    cmd = frames_of("micro_cmd", 7)
    lines = [f"# navkit golden vectors (ISO-TP reception towards the micro) for {spec_label(p.SPEC)}",
             f"# spec-hash 0x{p.SPEC_HASH:08x}", "# case | frames | messages | replies | stats"]
    lines += [_case(f"whole {m.name}", _timed(frames_of(m.name, 3))) for m in msgs]
    lines.append(_case("lost cf", _timed(cmd[:3] + cmd[4:])))
    lines.append(_case("swapped cf", _timed(cmd[:3] + [cmd[4], cmd[3]] + cmd[5:])))
    lines.append(_case("ff restarts", _timed(cmd[:5] + frames_of("micro_cmd", 8))))
    lines.append(_case("sf aborts", _timed(cmd[:5] + [nc.frame(cmd_id, bytes([2, 0xAB, 0xCD]))] + cmd[5:7])))
    late = _timed(cmd[:4]) + [(3 + nc.CAN.n_cr_ms + 1, cmd[4])]
    lines.append(_case("late cf", late))
    lines.append(_case("just in time", [(k * (nc.CAN.n_cr_ms - 1), m) for k, m in enumerate(cmd)]))
    bad = [can.Message(arbitration_id=cmd_id, data=bytes([0x10, 0x74, 1]), is_extended_id=False),
           can.Message(arbitration_id=cmd_id, data=bytes(8), is_extended_id=True),
           can.Message(arbitration_id=cmd_id, is_remote_frame=True, dlc=8, is_extended_id=False),
           nc.frame(cmd_id, bytes([0x40, 1])), nc.frame(cmd_id, bytes([0x00, 1])),
           nc.frame(cmd_id, bytes([0x08] + [1] * 7)), nc.frame(cmd_id, bytes([0x10, 0x07] + [1] * 6)),
           nc.flow_control(cmd_id)]
    lines.append(_case("bad frames", _timed(bad)))
    lines.append(_case("overflow", _timed([nc.frame(cmd_id, bytes([0x1F, 0xFF] + [0] * 6))] + cmd[1:3])))
    others = [nc.frame(0x7FF, bytes(8)), nc.flow_control(nc.CAN.ids["micro_cmd"].fc_id),
              nc.segment(nc.CAN.ids["micro_data"].id, p.encode_frame("micro_data", {}))[0]]
    lines.append(_case("other traffic", _timed(others + cmd)))
    for k in range(12):
        stream, t = [], 0
        for _ in range(rng.randint(2, 5)):
            name = rng.choice(msgs).name
            fr = frames_of(name, rng.randrange(65536))
            roll = rng.random()
            if roll < 0.25:
                fr = fr[:rng.randint(1, len(fr) - 1)]               # cut short
            elif roll < 0.45:
                del fr[rng.randrange(1, len(fr))]                   # one frame lost
            elif roll < 0.55 and len(fr) > 3:
                i = rng.randrange(1, len(fr) - 1)
                fr[i], fr[i + 1] = fr[i + 1], fr[i]                 # two swapped
            for f in fr:
                t += 150 if rng.random() < 0.03 else rng.choice((0, 1, 1, 2, 3))  # 150 ms: past N_Cr
                stream.append((t, f))
        lines.append(_case(f"random {k}", stream))
    return "\n".join(lines) + "\n"


def read_vectors(path=CAN_VECTORS) -> list[list[str]]:
    """The cases of a vectors file, each as its five fields."""
    return [[x.strip() for x in ln.split("|")] for ln in path.read_text().splitlines()
            if ln.strip() and not ln.startswith("#")]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m navkit.can_vectors", description=__doc__.splitlines()[0])
    ap.add_argument("--write", action="store_true", help=f"write {CAN_VECTORS}")
    args = ap.parse_args(argv)
    text = make_vectors()
    if args.write:
        CAN_VECTORS.write_text(text)
    else:
        print(text, end="")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
