"""`navkit proto`: a tool for people debugging a link.

    navkit proto encode MSG field=value ... [--time-tag N]   frame as hex
    navkit proto decode HEX                                   frames as JSON lines
    navkit proto decode --file capture.bin
    navkit proto decode --port /dev/ttyUSB0 [--baud 115200]   live sniffing (Ctrl-C ends)

decode prints one JSON object per good frame and one error line (byte offset, length,
reason) per rejected stretch of bytes; its exit status is 0 only if every byte formed
a good frame.
"""

from __future__ import annotations

import json
import sys

__all__ = ["add_arguments", "run"]


def add_arguments(parser) -> None:
    sub = parser.add_subparsers(dest="action", required=True, metavar="ACTION")
    enc = sub.add_parser("encode", help="print a frame as hex (unset fields 0)")
    enc.add_argument("message", help="serial message name, e.g. micro_cmd")
    enc.add_argument("assignments", nargs="*", metavar="field=value",
                     help="field values (ints; arrays as comma lists: adc=1,2,3,4,5,6,7,8)")
    enc.add_argument("--time-tag", type=int, help="time tag (default: the field's value, else 0)")
    enc.add_argument("--loose", action="store_true",
                     help="allow values outside the spec range (that still fit the type)")
    dec = sub.add_parser("decode", help="decode frames from hex, a capture file or a serial port")
    src = dec.add_mutually_exclusive_group(required=True)
    src.add_argument("hex", nargs="?", help="hex bytes (spaces and colons allowed)")
    src.add_argument("--file", help="binary capture file")
    src.add_argument("--port", help="serial port to sniff (pyserial)")
    dec.add_argument("--baud", type=int, default=115200, help="baud rate for --port (default %(default)s)")
    dec.add_argument("--direction", choices=("to_micro", "to_host"),
                     help="accept only one direction's message types (default: both)")


def _parse_value(text: str):
    if "," in text:
        return [int(v, 0) for v in text.split(",")]
    return int(text, 0)


def _encode(args) -> int:
    from navkit.protocol import ProtocolError, encode_frame
    fields = {}
    for a in args.assignments:
        name, eq, value = a.partition("=")
        if not eq:
            print(f"navkit proto encode: {a!r}: expected field=value", file=sys.stderr)
            return 2
        try:
            fields[name] = _parse_value(value)
        except ValueError:
            print(f"navkit proto encode: {name}: {value!r} is not an integer", file=sys.stderr)
            return 2
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


def _sniff(args, parser) -> int:
    import serial  # pyserial
    try:
        port = serial.Serial(args.port, args.baud, timeout=0.2)
    except serial.SerialException as e:
        print(f"navkit proto decode: {args.port}: {e}", file=sys.stderr)
        return 2
    bad = 0
    try:
        while True:
            data = port.read(4096)
            if data:
                bad += _emit(parser.feed(data))
    except KeyboardInterrupt:
        bad += _emit(parser.flush())
    except serial.SerialException as e:
        print(f"navkit proto decode: {args.port}: {e}", file=sys.stderr)
        bad += _emit(parser.flush())
    finally:
        port.close()
    print(f"{parser.stats['good']} good frame(s), {bad} rejected stretch(es), "
          f"{parser.stats['dropped_bytes']} byte(s) dropped", file=sys.stderr)
    return 1 if bad else 0


def run(args) -> int:
    return _encode(args) if args.action == "encode" else _decode(args)
