"""`navkit proto`: a tool for people debugging a link.

    navkit proto encode MSG field=value ... [--time-tag N] [--defaults]   frame as hex
    navkit proto decode HEX ...                               frames as JSON lines
    navkit proto decode --file capture.bin
    navkit proto decode --port /dev/ttyUSB0 [--baud 115200]   live sniffing (Ctrl-C ends)

encode: unset fields are 0, except spec_hash, which is this spec's hash unless given (it
is the spec's identity, not a value: a receiver refuses a frame of another hash);
msg_type is always the message's. --defaults fills the unset fields with their spec
defaults instead (the config messages have them). Values and --time-tag are integers as
in Python (-5, 0x10); an array is a comma list, every element given.

decode: HEX is hex digits; whitespace and colons may separate bytes, each run of digits
may start with 0x (`a5ff 0000`, `a5:ff:00`, `0xa5 0xff`); several arguments are joined
with spaces. It prints one JSON object per good frame (fields in spec order) and one
error line (byte offset, length, reason) per rejected stretch of bytes: bad CRC, unknown
type or the other direction's type, bad length, a frame of another spec version (its
own stretch, reason "schema mismatch: spec hash 0x..."), and a CRC-good frame that
fails the spec check (a field outside its range, or not one of its codes), which the
host and the firmware drop too. The exit status is 0 only if every byte formed a good
frame. With --port a stretch is printed as soon as the parser has resynced after it;
Ctrl-C prints the good frames and each reject counter.
"""

from __future__ import annotations

import argparse
import json
import re
import sys

__all__ = ["add_arguments", "run", "summary", "parse_hex"]


def _int(text: str) -> int:
    try:
        return int(text, 0)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer (e.g. 9 or 0x10)") from None


def _baud(text: str) -> int:
    n = _int(text)
    if n < 1:
        raise argparse.ArgumentTypeError(f"must be a positive rate in bit/s (e.g. 115200), not {n}")
    return n


def add_arguments(parser) -> None:
    sub = parser.add_subparsers(dest="action", required=True, metavar="ACTION")
    enc = sub.add_parser(
        "encode", help="print a frame as hex",
        description="Print a serial frame as hex. Unset fields are 0, except spec_hash: it is "
                    "this spec's hash unless given (the spec's identity, not a value; a receiver "
                    "refuses another hash). --defaults fills the unset fields with their spec "
                    "defaults instead (the config messages have them). msg_type is always the "
                    "message's own.")
    enc.add_argument("message", help="serial message name, e.g. micro_cmd")
    enc.add_argument("assignments", nargs="*", metavar="field=value",
                     help="field values (integers, 0x allowed; arrays as comma lists: adc=1,2,3,4,5,6,7,8)")
    enc.add_argument("--time-tag", type=_int,
                     help="time tag (default: time_tag=N if given, else 0; not both)")
    enc.add_argument("--defaults", action="store_true",
                     help="unset fields take their spec defaults (config messages), not 0")
    enc.add_argument("--loose", action="store_true",
                     help="allow values outside the spec range or codes (that still fit the type)")
    dec = sub.add_parser(
        "decode", help="decode frames from hex, a capture file or a serial port",
        description="Print one JSON object per good frame and one error line (byte offset, length, "
                    "reason) per rejected stretch of bytes, including CRC-good frames that fail "
                    "the spec check; exit status 0 only if every byte formed a good frame.")
    dec.add_argument("hex", nargs="*",
                     help="hex bytes; whitespace and colons may separate bytes, each run may start "
                          "with 0x; several arguments are joined")
    dec.add_argument("--file", help="binary capture file")
    dec.add_argument("--port", help="serial port to sniff (pyserial)")
    dec.add_argument("--baud", type=_baud, help="baud rate, only with --port (default 115200)")
    dec.add_argument("--direction", choices=("to_micro", "to_host"),
                     help="accept only one direction's message types (default: both)")


def _err(action: str, text: str) -> int:
    print(f"navkit proto {action}: {text}", file=sys.stderr)
    return 2


def _excerpt(text: str, n: int = 24) -> str:
    return repr(text if len(text) <= n else text[:n // 2] + "..." + text[-n // 2:])


def parse_hex(text: str) -> bytes:
    """The bytes of `text`: runs of hex digits separated by whitespace or colons, each
    run an even number of digits with an optional 0x prefix. ValueError names the
    (1-based) character position of the first problem."""
    out = bytearray()
    for m in re.finditer(r"[^\s:]+", text):
        run, at = m.group(), m.start()
        if run[:2] in ("0x", "0X"):
            run, at = run[2:], at + 2
            if not run:
                raise ValueError(f"character {m.start() + 1}: 0x without hex digits")
        bad = re.search(r"[^0-9a-fA-F]", run)
        if bad:
            raise ValueError(f"character {at + bad.start() + 1}: {bad.group()!r} is not a hex digit")
        if len(run) % 2:
            raise ValueError(f"characters {at + 1}-{at + len(run)}: odd number of hex digits ({len(run)}) "
                             f"in {_excerpt(run)}")
        out += bytes.fromhex(run)
    if not out:
        raise ValueError("no hex digits")
    return bytes(out)


def _parse_value(name: str, text: str):
    """An integer, or a list of them for a comma list; ValueError naming the element."""
    parts = text.split(",")
    out = []
    for i, v in enumerate(parts):
        try:
            out.append(int(v, 0))
        except ValueError:
            where = f"{name}[{i}]" if len(parts) > 1 else name
            raise ValueError(f"{where}: {v!r} is not an integer (e.g. 9 or 0x10)") from None
    return out if len(parts) > 1 else out[0]


def _encode(args) -> int:
    from navkit.protocol import SPEC, SPEC_HASH, ProtocolError, defaults, encode_frame
    m = SPEC.messages.get(args.message)
    serial = [s.name for s in SPEC.serial_messages()]
    if m is None:
        return _err("encode", f"unknown message {args.message!r} (serial messages: {', '.join(serial)})")
    if not m.framed:
        return _err("encode", f"{m.name!r} is an rcomm (shared memory) message, not a serial frame "
                              f"(serial messages: {', '.join(serial)})")
    names = [f.name for f in m.fields]
    fields = {}
    for a in args.assignments:
        name, eq, value = a.partition("=")
        if not eq:
            return _err("encode", f"{a!r}: expected field=value")
        if name not in names:
            return _err("encode", f"{m.name}: unknown field {name!r} (fields: {', '.join(names)})")
        if name in fields:
            return _err("encode", f"{name}: given twice")
        try:
            fields[name] = _parse_value(name, value)
        except ValueError as e:
            return _err("encode", f"{m.name}.{e}")
    if args.time_tag is not None and "time_tag" in fields:
        return _err("encode", f"time_tag given twice (time_tag={fields['time_tag']} and --time-tag "
                              f"{args.time_tag}): give one")
    if args.defaults:
        if not any(f.default is not None for f in m.fields):
            with_defaults = [s.name for s in SPEC.serial_messages() if any(f.default is not None for f in s.fields)]
            return _err("encode", f"--defaults: {m.name} has no spec defaults (messages with "
                                  f"defaults: {', '.join(with_defaults)})")
        fields = {**defaults(m.name), **fields}
    elif not args.loose:
        zero_bad = [f"{f.name} ({f.min}..{f.max})" for f in m.fields
                    if f.name not in fields and f.name not in ("spec_hash", "msg_type")
                    and not f.min <= 0 <= f.max]
        if zero_bad:
            return _err("encode", f"{m.name}: unset fields are 0, outside the spec range of "
                                  f"{', '.join(zero_bad)}: give them, or --defaults for the spec defaults")
    if "spec_hash" in names and "spec_hash" not in fields:
        fields["spec_hash"] = SPEC_HASH
    try:
        frame = encode_frame(m.name, fields, time_tag=args.time_tag, strict=not args.loose)
    except ProtocolError as e:
        return _err("encode", str(e))
    print(frame.hex())
    return 0


class _Emitter:
    """Prints parser events: a good frame as JSON, a rejected stretch or a CRC-good
    frame that fails the spec check (counted in `failed_check`) as an error line."""

    def __init__(self):
        self.bad = 0            # error lines printed
        self.failed_check = 0   # CRC-good frames refused by the spec check

    def emit(self, events) -> None:
        from navkit.protocol import Frame, ProtocolError, check
        for e in events:
            if isinstance(e, Frame):
                try:
                    check(e.name, e.fields)
                except ProtocolError as err:
                    self.bad += 1
                    self.failed_check += 1
                    print(f"error: byte offset {e.offset}: {len(e.raw)} byte(s) rejected: {err} "
                          "(CRC good; the receiver's spec check drops it)", flush=True)
                    continue
                print(json.dumps({"message": e.name, "offset": e.offset, **e.fields}), flush=True)
            else:
                self.bad += 1
                print(f"error: byte offset {e.offset}: {e.length} byte(s) rejected: {e.reason}", flush=True)


def _decode(args) -> int:
    from navkit.protocol import DIR_TO_HOST, DIR_TO_MICRO, Parser
    given = [o for o, v in (("HEX", args.hex), ("--file", args.file), ("--port", args.port)) if v]
    if len(given) != 1:
        return _err("decode", f"give one of HEX, --file or --port, not {' and '.join(given)}" if given
                    else "give the bytes: HEX, --file capture.bin or --port PATH")
    if args.baud is not None and not args.port:
        return _err("decode", "--baud applies only to --port")
    direction = {"to_micro": DIR_TO_MICRO, "to_host": DIR_TO_HOST, None: None}[args.direction]
    parser = Parser(direction)
    if args.port:
        return _sniff(args, parser)
    if args.file:
        try:
            with open(args.file, "rb") as fh:
                data = fh.read()
        except OSError as e:
            return _err("decode", f"{args.file}: {e.strerror}")
    else:
        try:
            data = parse_hex(" ".join(args.hex))
        except ValueError as e:
            return _err("decode", f"HEX: {e}")
    out = _Emitter()
    out.emit(parser.feed(data))
    out.emit(parser.flush())
    return 1 if out.bad else 0


def summary(parser, failed_check: int = 0) -> str:
    """One line: good frames (CRC good and passing the spec check), each reject counter
    (`failed_check`: CRC-good frames that failed the spec check), dropped bytes, and the
    spec hash of the last frame of another spec version (if any)."""
    s = parser.stats
    text = (f"{s['good'] - failed_check} good frame(s); rejected: {s['bad_crc']} bad CRC, "
            f"{s['unknown_type']} unknown type, {s['bad_length']} bad length, {s['schema_mismatch']} "
            f"schema mismatch, {failed_check} failed spec check; {s['dropped_bytes']} byte(s) dropped")
    if parser.foreign_hash is not None:
        from navkit.protocol import SPEC_HASH
        text += (f"; last foreign spec hash 0x{parser.foreign_hash:08x} at byte offset "
                 f"{parser.foreign_offset} (this spec 0x{SPEC_HASH:08x})")
    return text


def _sniff(args, parser) -> int:
    import serial  # pyserial
    try:
        port = serial.Serial(args.port, 115200 if args.baud is None else args.baud, timeout=0.2)
    except (serial.SerialException, ValueError) as e:
        return _err("decode", f"{args.port}: {e}")
    out = _Emitter()
    try:
        while True:
            data = port.read(4096)
            if data:
                out.emit(parser.feed(data))
            out.emit(parser.settle())  # a stretch ends when the parser resyncs
    except KeyboardInterrupt:
        out.emit(parser.flush())
    except serial.SerialException as e:
        print(f"navkit proto decode: {args.port}: {e}", file=sys.stderr)
        out.emit(parser.flush())
    finally:
        port.close()
    print(summary(parser, out.failed_check), file=sys.stderr)
    return 1 if out.bad else 0


def run(args) -> int:
    return _encode(args) if args.action == "encode" else _decode(args)
