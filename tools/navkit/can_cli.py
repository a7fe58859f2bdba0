"""`navkit can`: the micro link over CAN, for people debugging a bus.

    navkit can dump --file candump.log             a log python-can reads (.log candump -L,
                                                    .asc, .blf, .csv, .trc)
    navkit can dump --port /dev/ttyACM0            live, through an SLCAN USB-CAN adapter
                                                    (CANable, CANUSB, USBtin), listen-only
    navkit can dump --interface socketcan --channel can0   live, any python-can interface

Every frame on an identifier of the spec's CAN mapping goes through ISO-TP reassembly
(navkit.can, both directions at once); each message reassembled goes through the same
frame checks as the serial link (navkit.protocol's parser and spec check) and prints as
one JSON object: time (s), CAN identifier, message name and its fields in spec order.
Every frame ISO-TP refuses, every message it aborts, and every reassembled message the
frame checks refuse prints as an error line naming the frame (its number in the stream,
time, identifier) and the reason. Flow control frames, other identifiers and bus error frames (counted) print nothing.
At the end (the log's end, --count messages, --seconds of listening, or Ctrl-C) the
counters go to stderr, with the micro's own (the can_* counters of the last micro_data
seen: what its ISO-TP refused and aborted, 0 from a micro on a serial build). The exit
status is 0 only if nothing was refused or aborted.
"""

from __future__ import annotations

import argparse
import json
import sys

__all__ = ["add_arguments", "run", "Dumper", "REASONS"]

# Receiver counter -> what an increment means for the frame that caused it
REASONS = {
    "bad_frame": "frame refused: not a well-formed ISO-TP frame (an 11-bit data frame of 8 bytes, "
                 "a known PCI type and length)",
    "wrong_sn": "message aborted: consecutive frame out of sequence (one lost or reordered)",
    "unexpected": "frame ignored: consecutive frame with no message in progress",
    "restarted": "message aborted: a new first or single frame came before its end",
    "timeout": "message aborted: no consecutive frame within N_Cr",
    "overflow": "frame refused: first frame longer than the receiver's buffer",
}


def _positive(kind):
    def parse(text: str):
        try:
            v = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
        if v <= 0:
            raise argparse.ArgumentTypeError(f"must be above 0, not {text}")
        return v
    return parse


def add_arguments(parser) -> None:
    from navkit.can import CAN
    sub = parser.add_subparsers(dest="action", required=True, metavar="ACTION")
    d = sub.add_parser("dump", help="decode CAN traffic with the spec (a log file or live)",
                       description="Decode the micro link's CAN traffic with the spec: ISO-TP reassembly, "
                                   "then the serial frame checks; one JSON line per message, one error "
                                   "line per refused frame or aborted message.")
    d.add_argument("--file", metavar="LOG", help="a CAN log python-can reads (.log, .asc, .blf, .csv, .trc)")
    d.add_argument("--port", metavar="PATH", help="serial port of an SLCAN USB-CAN adapter (listen-only)")
    d.add_argument("--interface", metavar="NAME", help="a python-can interface (socketcan, slcan, ...) "
                                                       "with --channel")
    d.add_argument("--channel", metavar="CH", help="its channel (can0, a port, ...)")
    d.add_argument("--bitrate", type=_positive(int), default=None, metavar="BIT/S",
                   help=f"bus bit rate for --port (default: the spec's {CAN.bitrate})")
    d.add_argument("--count", type=_positive(int), metavar="N", help="stop after N messages")
    d.add_argument("--seconds", type=_positive(float), metavar="S", help="stop live listening after S seconds")


class Dumper:
    """Reassembles and prints: feed() every frame in bus order; `bad` counts error lines,
    `messages` the messages printed, `micro_can` holds the micro's own CAN counters (the
    can_* fields of the last micro_data printed, prefix dropped; None before one)."""

    def __init__(self, out=None):
        from navkit import can as nc
        from navkit import protocol as p
        self.out = out or sys.stdout
        self.rx = {d: nc.Receiver(d) for d in (p.DIR_TO_MICRO, p.DIR_TO_HOST)}
        self.frames = 0
        self.messages = 0
        self.bad = 0
        self.error_frames = 0   # bus error frames (the controller sends the frame again): counted
        self.micro_can: dict | None = None

    def _error(self, k: int, msg, text: str) -> None:
        self.bad += 1
        print(f"error: frame {k} (t {msg.timestamp:.6f} s, id 0x{msg.arbitration_id:03X}): {text}",
              file=self.out, flush=True)

    def feed(self, msg) -> None:
        from navkit import can as nc
        from navkit import protocol as p
        k = self.frames
        self.frames += 1
        if msg.is_error_frame:
            self.error_frames += 1
            return
        for direction, rx in self.rx.items():
            before = dict(rx.stats)
            got = rx.feed(msg, msg.timestamp)
            rx.take_replies()  # a listener sends nothing
            for key, reason in REASONS.items():
                text = f"{reason} ({nc.CAN.n_cr_ms} ms)" if key == "timeout" else reason
                for _ in range(rx.stats[key] - before[key]):
                    self._error(k, msg, text)
            if got is None:
                continue
            parser = p.Parser(direction)
            events = parser.feed(got.data) + parser.flush()
            for e in events:
                if isinstance(e, p.Frame) and e.name != got.message:
                    self._error(k, msg, f"a {e.name} frame on the identifier of {got.message}")
                elif isinstance(e, p.Frame):
                    try:
                        p.check(e.name, e.fields)
                    except p.ProtocolError as err:
                        self._error(k, msg, f"{got.message}: {err} (CRC good; the receiver's spec check drops it)")
                        continue
                    self.messages += 1
                    if e.name == "micro_data":
                        self.micro_can = {k[4:]: v for k, v in e.fields.items() if k.startswith("can_")}
                    print(json.dumps({"t": round(msg.timestamp, 6), "can_id": f"0x{got.can_id:03X}",
                                      "message": e.name, **e.fields}), file=self.out, flush=True)
                else:
                    self._error(k, msg, f"{got.message}: {e.length} of its {len(got.data)} bytes rejected: {e.reason}")

    def summary(self) -> str:
        parts = [f"{self.frames} frames, {self.messages} messages"
                 + (f", {self.error_frames} error frames" if self.error_frames else "")]
        for direction, rx in self.rx.items():
            counts = ", ".join(f"{k} {v}" for k, v in rx.stats.items() if v and k != "good")
            parts.append(f"{direction.replace('_', ' ')}: {rx.stats['good']} reassembled" + (f", {counts}" if counts else ""))
        if self.micro_can is not None:
            counts = ", ".join(f"{k} {v}" for k, v in self.micro_can.items() if v)
            parts.append(f"the micro's own (its last micro_data): {counts or 'all 0'}")
        return "navkit can dump: " + "; ".join(parts)


def _err(text: str, status: int = 1) -> int:
    print(f"navkit can dump: {text}", file=sys.stderr)
    return status


def _dump(args) -> int:
    import time

    import can
    from navkit.can import CAN
    given = [o for o, v in (("--file", args.file), ("--port", args.port), ("--interface", args.interface)) if v]
    if len(given) != 1:
        return _err(f"give one of --file, --port or --interface, not {' and '.join(given)}" if given
                    else "give the traffic: --file LOG, --port PATH or --interface NAME --channel CH", 2)
    if bool(args.interface) != bool(args.channel):
        return _err("--interface and --channel go together", 2)
    if args.bitrate is not None and not args.port:
        return _err("--bitrate applies only to --port (an interface keeps its own)", 2)
    if args.seconds is not None and args.file:
        return _err("--seconds applies only to live listening", 2)
    dumper = Dumper()
    opened = False
    try:
        if args.file:
            try:
                reader = can.LogReader(args.file)
            except ValueError as e:
                return _err(f"{args.file}: {e}")
            except OSError as e:
                return _err(f"{args.file}: {e.strerror}")
            opened = True
            try:
                for msg in reader:
                    dumper.feed(msg)
                    if args.count and dumper.messages >= args.count:
                        break
            except (ValueError, IndexError) as e:
                return _err(f"{args.file}: frame {dumper.frames}: unreadable: {e}")
        else:
            try:
                if args.port:
                    bus = can.Bus(interface="slcan", channel=args.port, bitrate=args.bitrate or CAN.bitrate,
                                  listen_only=True, sleep_after_open=0.05)
                else:
                    bus = can.Bus(interface=args.interface, channel=args.channel)
            except (can.CanError, ValueError, OSError, ImportError) as e:
                return _err(f"{args.port or args.channel}: cannot open: {e}")
            opened = True
            try:
                end = time.monotonic() + args.seconds if args.seconds else None
                while end is None or time.monotonic() < end:
                    msg = bus.recv(timeout=0.1)
                    if msg is not None:
                        dumper.feed(msg)
                        if args.count and dumper.messages >= args.count:
                            break
            except can.CanError as e:
                return _err(f"{args.port or args.channel}: {e}")
            finally:
                bus.shutdown()
    except KeyboardInterrupt:
        pass
    finally:
        if opened:
            print(dumper.summary(), file=sys.stderr)
    return 1 if dumper.bad else 0


def run(args) -> int:
    return _dump(args)
