"""`navkit proto`: a tool for people debugging a link.

    navkit proto encode MSG field=value ... [--time-tag N]   frame as hex
    navkit proto decode HEX                                   frames as JSON lines
    navkit proto decode --file capture.bin
    navkit proto decode --port /dev/ttyUSB0 [--baud 115200]   live sniffing (Ctrl-C ends)

encode: unset fields take the spec defaults in messages that have defaults (the config
messages, whose spec_hash is this spec's), and 0 in the others; msg_type is the
message's. decode prints one JSON object per good frame and one error line (byte
offset, length, reason) per rejected stretch of bytes (a frame of another spec version
is its own stretch, reason "schema mismatch: spec hash 0x..."); its exit status is 0
only if every byte formed a good frame. With --port a stretch is printed as soon as the
parser has resynced after it; Ctrl-C prints the good frames and each reject counter.
"""

from __future__ import annotations

import json
import sys

__all__ = ["add_arguments", "run", "summary"]


def add_arguments(parser) -> None:
    sub = parser.add_subparsers(dest="action", required=True, metavar="ACTION")
    enc = sub.add_parser(
        "encode", help="print a frame as hex",
        description="Print a serial frame as hex. Unset fields take the spec defaults in messages "
                    "that have defaults (the config messages, spec_hash = this spec's hash) and 0 in "
                    "the others; msg_type is always the message's own.")
    enc.add_argument("message", help="serial message name, e.g. micro_cmd")
    enc.add_argument("assignments", nargs="*", metavar="field=value",
                     help="field values (ints; arrays as comma lists: adc=1,2,3,4,5,6,7,8)")
    enc.add_argument("--time-tag", type=int,
                     help="time tag (default: time_tag=N if given, else 0; not both)")
    enc.add_argument("--loose", action="store_true",
                     help="allow values outside the spec range (that still fit the type)")
    dec = sub.add_parser("decode", help="decode frames from hex, a capture file or a serial port")
    src = dec.add_mutually_exclusive_group(required=True)
    src.add_argument("hex", nargs="?", help="hex bytes (spaces and colons allowed)")
    src.add_argument("--file", help="binary capture file")
    src.add_argument("--port", help="serial port to sniff (pyserial)")
    dec.add_argument("--baud", type=int, help="baud rate, only with --port (default 115200)")
    dec.add_argument("--direction", choices=("to_micro", "to_host"),
                     help="accept only one direction's message types (default: both)")


def _parse_value(text: str):
    if "," in text:
        return [int(v, 0) for v in text.split(",")]
    return int(text, 0)


def _encode(args) -> int:
    from navkit.protocol import SPEC, ProtocolError, defaults, encode_frame
    fields = {}
    for a in args.assignments:
        name, eq, value = a.partition("=")
        if not eq:
            print(f"navkit proto encode: {a!r}: expected field=value", file=sys.stderr)
            return 2
        if name in fields:
            print(f"navkit proto encode: {name}: given twice", file=sys.stderr)
            return 2
        try:
            fields[name] = _parse_value(value)
        except ValueError:
            print(f"navkit proto encode: {name}: {value!r} is not an integer", file=sys.stderr)
            return 2
    if args.time_tag is not None and "time_tag" in fields:
        print(f"navkit proto encode: time_tag given twice (time_tag={fields['time_tag']} and "
              f"--time-tag {args.time_tag}): give one", file=sys.stderr)
        return 2
    m = SPEC.messages.get(args.message)
    if m is not None and m.framed and any(f.default is not None for f in m.fields):
        fields = {**defaults(args.message), **fields}
    try:
        frame = encode_frame(args.message, fields, time_tag=args.time_tag, strict=not args.loose)
    except ProtocolError as e:
        print(f"navkit proto encode: {e}", file=sys.stderr)
        return 2
    print(frame.hex())
    return 0


def _emit(events) -> int:
    """Print events; return how many were rejects."""
    from navkit.protocol import Frame
    bad = 0
    for e in events:
        if isinstance(e, Frame):
            print(json.dumps({"message": e.name, "offset": e.offset, **e.fields}), flush=True)
        else:
            bad += 1
            print(f"error: byte offset {e.offset}: {e.length} byte(s) rejected: {e.reason}", flush=True)
    return bad


def _decode(args) -> int:
    from navkit.protocol import DIR_TO_HOST, DIR_TO_MICRO, Parser
    direction = {"to_micro": DIR_TO_MICRO, "to_host": DIR_TO_HOST, None: None}[args.direction]
    parser = Parser(direction)
    if args.port:
        return _sniff(args, parser)
    if args.baud is not None:
        print("navkit proto decode: --baud applies only to --port", file=sys.stderr)
        return 2
    if args.file:
        try:
            with open(args.file, "rb") as fh:
                data = fh.read()
        except OSError as e:
            print(f"navkit proto decode: {args.file}: {e.strerror}", file=sys.stderr)
            return 2
    else:
        text = args.hex.replace(" ", "").replace(":", "")
        try:
            data = bytes.fromhex(text)
        except ValueError:
            print(f"navkit proto decode: not hex: {args.hex!r}", file=sys.stderr)
            return 2
    bad = _emit(parser.feed(data)) + _emit(parser.flush())
    return 1 if bad else 0


def summary(parser) -> str:
    """One line: good frames, each reject counter, dropped bytes, and the spec hash of
    the last frame of another spec version (if any)."""
    s = parser.stats
    text = (f"{s['good']} good frame(s); rejected: {s['bad_crc']} bad CRC, {s['unknown_type']} "
            f"unknown type, {s['bad_length']} bad length, {s['schema_mismatch']} schema mismatch; "
            f"{s['dropped_bytes']} byte(s) dropped")
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
        print(f"navkit proto decode: {args.port}: {e}", file=sys.stderr)
        return 2
    bad = 0
    try:
        while True:
            data = port.read(4096)
            if data:
                bad += _emit(parser.feed(data))
            bad += _emit(parser.settle())  # a stretch ends when the parser resyncs
    except KeyboardInterrupt:
        bad += _emit(parser.flush())
    except serial.SerialException as e:
        print(f"navkit proto decode: {args.port}: {e}", file=sys.stderr)
        bad += _emit(parser.flush())
    finally:
        port.close()
    print(summary(parser), file=sys.stderr)
    return 1 if bad else 0


def run(args) -> int:
    return _encode(args) if args.action == "encode" else _decode(args)
