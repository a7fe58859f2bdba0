"""SLCAN, the ASCII protocol of common FTDI/CDC-based USB-CAN adapters (Lawicel CANUSB,
CANable with slcan firmware, USBtin), seen from the adapter's side: the piece that lets a
program stand where the adapter would be (the co-simulation harness in front of the host's
serial port, a test in front of `navkit can dump --port`).

The host writes commands ending in CR; the adapter answers CR for done, BEL (0x07) for
refused, and sends each frame it receives from the bus as a line:
    Sn         bit rate n: 0 10k, 1 20k, 2 50k, 3 100k, 4 125k, 5 250k, 6 500k, 7 800k,
               8 1M (python-can also sends 9 for 83.3k); refused while the channel is open
    sXXYY      bit timing registers (BTR0, BTR1 of an SJA1000 at 8 MHz); refused while open
    O / L / C  open the channel, open it listen-only, close it (opening an open channel:
               done in the same mode, refused in the other)
    tIIILDD..  send a standard frame (III hex id, L 0-8 data bytes) -> "z" CR
    TIIIIIIIILDD..  an extended one -> "Z" CR;  rIIIL / RIIIIIIIIL remote frames
    V / N / F  version ("V1013"), serial number ("NA123"), status flags ("F00")
    Zn         time stamps on (1) or off (0): accepted, none are sent
Frames go to the host only while the channel is open; sending needs it open and not
listen-only. Anything else is refused (BEL) and counted.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import can

__all__ = ["BITRATES", "SlcanAdapter", "frame_line"]

BITRATES = {0: 10_000, 1: 20_000, 2: 50_000, 3: 100_000, 4: 125_000, 5: 250_000, 6: 500_000, 7: 800_000,
            8: 1_000_000, 9: 83_300}  # Sn -> bit/s
OK, ERROR = b"\r", b"\x07"


def frame_line(msg: can.Message) -> bytes:
    """The SLCAN line of a classic CAN frame, as an adapter sends it to the host."""
    if msg.is_extended_id:
        head = f"{'R' if msg.is_remote_frame else 'T'}{msg.arbitration_id:08X}{msg.dlc:d}"
    else:
        head = f"{'r' if msg.is_remote_frame else 't'}{msg.arbitration_id:03X}{msg.dlc:d}"
    body = "" if msg.is_remote_frame else bytes(msg.data[:msg.dlc]).hex().upper()
    return (head + body).encode() + OK


def _hex(text: str) -> bool:
    return all(c in "0123456789abcdefABCDEF" for c in text)


@dataclass
class SlcanAdapter:
    """The adapter's state: bit rate (bit/s), channel open / listen-only, counters.

    `feed(data)` takes the bytes the host wrote (any chunking) and returns (reply bytes,
    frames the host sent to the bus); `to_host(msg)` the line of a frame from the bus
    (b"" while the channel is closed: the frame is dropped and counted)."""

    bitrate: int = 0          # bit/s; 0: not set yet
    is_open: bool = False
    listen_only: bool = False
    stats: dict = field(default_factory=lambda: dict.fromkeys(
        ("commands", "refused", "sent", "received", "dropped"), 0))
    last_refused: str = ""    # the last command refused (for the message that reports it)
    _line: bytearray = field(default_factory=bytearray, repr=False)

    def feed(self, data: bytes) -> tuple[bytes, list[can.Message]]:
        reply, frames = bytearray(), []
        for b in data:
            if b != 0x0D:
                if len(self._line) < 64:  # longer than any command: refused at its CR
                    self._line.append(b)
                else:
                    self._line = bytearray(b"?" * 65)
                continue
            line, self._line = self._line.decode("ascii", "replace"), bytearray()
            if not line:
                continue  # an empty line (hosts send CRs to flush an adapter): no answer
            self.stats["commands"] += 1
            answer, msg = self._command(line)
            if answer == ERROR:
                self.stats["refused"] += 1
                self.last_refused = line
            if msg is not None:
                frames.append(msg)
                self.stats["sent"] += 1
            reply += answer
        return bytes(reply), frames

    def to_host(self, msg: can.Message) -> bytes:
        if not self.is_open:
            self.stats["dropped"] += 1
            return b""
        self.stats["received"] += 1
        return frame_line(msg)

    def _command(self, line: str) -> tuple[bytes, can.Message | None]:
        c, arg = line[0], line[1:]
        if c == "S" and len(arg) == 1 and arg.isdigit() and int(arg) in BITRATES and not self.is_open:
            self.bitrate = BITRATES[int(arg)]
            return OK, None
        if c == "s" and len(arg) == 4 and _hex(arg) and not self.is_open:
            self.bitrate = -1  # a register setting: a rate this model does not derive
            return OK, None
        if c in "OL" and not arg and self.bitrate and (not self.is_open or self.listen_only == (c == "L")):
            # opening an open channel in the same mode is done (CANable's firmware says so;
            # python-can's slcan interface opens twice), in the other mode refused
            self.is_open, self.listen_only = True, c == "L"
            return OK, None
        if c == "C" and not arg:
            self.is_open = self.listen_only = False
            return OK, None
        if c == "V" and not arg:
            return b"V1013" + OK, None
        if c == "N" and not arg:
            return b"NA123" + OK, None
        if c == "F" and not arg and self.is_open:
            return b"F00" + OK, None
        if c == "Z" and arg in ("0", "1"):
            return OK, None
        if c in "tTrR" and self.is_open and not self.listen_only:
            msg = self._frame(c, arg)
            if msg is not None:
                return (b"Z" if c in "TR" else b"z") + OK, msg
        return ERROR, None

    @staticmethod
    def _frame(c: str, arg: str) -> can.Message | None:
        """The frame of a t/T/r/R command, or None if malformed."""
        n = 8 if c in "TR" else 3
        if len(arg) < n + 1 or not _hex(arg[:n]) or not arg[n].isdigit() or int(arg[n]) > 8:
            return None
        ident, dlc, data = int(arg[:n], 16), int(arg[n]), arg[n + 1:]
        if ident >= (1 << (29 if n == 8 else 11)):
            return None
        remote = c in "rR"
        if (remote and data) or (not remote and (len(data) != 2 * dlc or not _hex(data))):
            return None
        return can.Message(arbitration_id=ident, is_extended_id=n == 8, is_remote_frame=remote, dlc=dlc,
                           data=None if remote else bytes.fromhex(data))
