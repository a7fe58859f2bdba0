"""The micro link over CAN: ISO 15765-2 (ISO-TP) segmentation and reassembly of the kit's
serial frames on classic CAN, with python-can's `can.Message` as the frame type.

The spec's [can] mapping (protocol/navkit.toml, docs/protocol.md "CAN") gives every
serial message an 11-bit identifier for its frames and one for the flow control its
receiver answers with. Each serial frame, whole (start word to CRC word), is one ISO-TP
message; every CAN frame is padded to 8 data bytes. A `Receiver` reassembles what travels
towards one end, a `Sender` segments what that end sends; `Endpoint` is both, as the host
or the micro. Times are seconds on any monotonic clock the caller passes in (`now`).

What the standard defines, and this module does (the C runtime's navkit_isotp.c, which the
firmware's CAN transport uses, the same):
- a consecutive frame out of sequence (one lost, or two swapped by a gateway) aborts the
  message (`wrong_sn`); the frames after it are ignored until a new first frame
  (`unexpected`);
- a first or single frame during a reception aborts it and starts anew (`restarted`);
- no consecutive frame within n_cr_ms aborts the reception (`timeout`), no flow control
  within n_bs_ms the transmission (Sender `timeout`);
- a first frame longer than the receiver's buffer gets an overflow flow control
  (`overflow`), and the sender, on it, abandons the message;
- a frame on a receiving identifier that is not a well-formed ISO-TP frame (shorter than
  8 bytes, remote, extended, FD, error frame, an unknown PCI type, a bad length) is refused
  and counted (`bad_frame`). Frames on other identifiers are other nodes' traffic: ignored.
One reception and one transmission at a time per end: a sender finishes (or abandons) a
message before it starts the next, as the serial link sends one frame after another.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import can

from navkit import protocol as p

__all__ = [
    "CAN", "SINGLE", "FIRST", "CONSECUTIVE", "FLOW", "CONTINUE", "WAIT", "OVERFLOW", "RX_STATS", "TX_STATS",
    "st_min_seconds", "frame", "segment", "flow_control", "max_bytes", "Received", "Receiver", "Sender",
    "Endpoint",
]

CAN = p.SPEC.can
if CAN is None:  # pragma: no cover - the kit's spec always has one
    raise p.ProtocolError(f"{p.SPEC.path}: no [can] mapping")

# ISO-TP PCI frame types (high nibble of byte 0) and flow statuses (low nibble of a flow control)
SINGLE, FIRST, CONSECUTIVE, FLOW = 0, 1, 2, 3
CONTINUE, WAIT, OVERFLOW = 0, 1, 2
SF_MAX = 7     # bytes: the most a single frame carries on classic CAN
FF_DATA = 6    # bytes: what a first frame carries after its 2 PCI bytes
CF_DATA = 7    # bytes: what a consecutive frame carries
FF_MAX = 0xFFF  # bytes: the 12-bit FF_DL

RX_STATS = ("good", "bad_frame", "wrong_sn", "unexpected", "restarted", "timeout", "overflow")
TX_STATS = ("sent", "busy", "timeout", "overflow", "bad_fc", "wait")

_IDS = {c.id: c for c in CAN.ids.values()}


def st_min_seconds(st_min: int) -> float:
    """The separation time of an ISO STmin byte, s: 0x00-0x7F ms, 0xF1-0xF9 100-900 us; a
    reserved value counts as 0x7F (127 ms), as ISO 15765-2 tells a sender to."""
    if st_min <= 0x7F:
        return st_min / 1000.0
    if 0xF1 <= st_min <= 0xF9:
        return (st_min - 0xF0) / 10000.0
    return 0.127


def max_bytes(direction: str) -> int:
    """Bytes of the largest serial frame travelling in `direction` (the spec's
    NAVKIT_CAN_MAX_TO_MICRO/TO_HOST_BYTES: a receiver's ISO-TP buffer)."""
    return max(m.size for m in p.SPEC.serial_messages() if m.direction == direction)


def frame(can_id: int, data: bytes, timestamp: float = 0.0) -> can.Message:
    """A classic CAN data frame on 11-bit `can_id`, `data` padded to 8 bytes."""
    data = bytes(data) + bytes([CAN.padding]) * (8 - len(data))
    return can.Message(arbitration_id=can_id, data=data, dlc=8, is_extended_id=False, timestamp=timestamp)


def segment(can_id: int, payload: bytes) -> list[can.Message]:
    """The CAN frames of one ISO-TP message: a single frame (up to 7 bytes), else a first
    frame and its consecutive frames (sequence numbers 1, 2, .. 15, 0, 1, ..), as a sender
    sends them after a flow control that lets all through."""
    n = len(payload)
    if not 1 <= n <= FF_MAX:
        raise ValueError(f"an ISO-TP message is 1..{FF_MAX} bytes, not {n}")
    if n <= SF_MAX:
        return [frame(can_id, bytes([n]) + payload)]
    out = [frame(can_id, bytes([0x10 | n >> 8, n & 0xFF]) + payload[:FF_DATA])]
    for k, at in enumerate(range(FF_DATA, n, CF_DATA), 1):
        out.append(frame(can_id, bytes([0x20 | k & 0xF]) + payload[at:at + CF_DATA]))
    return out


def flow_control(fc_id: int, status: int = CONTINUE, block_size: int = CAN.fc_block_size,
                 st_min: int = CAN.fc_st_min) -> can.Message:
    """A flow control frame on `fc_id`."""
    return frame(fc_id, bytes([0x30 | status, block_size, st_min]))


def _well_formed(msg: can.Message) -> bool:
    """A classic 11-bit data frame of 8 data bytes (the mapping pads every frame)."""
    return not (msg.is_extended_id or msg.is_remote_frame or msg.is_error_frame or msg.is_fd
                or msg.dlc != 8 or len(msg.data) != 8)


@dataclass
class Received:
    """One reassembled message: the CAN identifier it came on, its spec message name
    and its bytes (a serial frame, to be checked by `navkit.protocol` like any other)."""

    can_id: int
    message: str
    data: bytes


@dataclass
class Receiver:
    """ISO-TP reception of the messages travelling towards `direction`
    ("host_to_micro": the micro's side, "micro_to_host": the host's), one at a time.

    `feed()` takes every CAN frame seen on the bus; flow control frames to send back
    collect in `replies` (take them with `take_replies()`). `stats` counts RX_STATS."""

    direction: str
    capacity: int = 0               # bytes; 0 = the largest frame of `direction`
    block_size: int = CAN.fc_block_size
    st_min: int = CAN.fc_st_min
    n_cr: float = CAN.n_cr_ms / 1000.0  # s
    stats: dict = field(default_factory=lambda: dict.fromkeys(RX_STATS, 0))
    replies: list = field(default_factory=list)
    _ids: dict = field(default_factory=dict, repr=False)
    _buf: bytearray | None = field(default=None, repr=False)  # None: no reception in progress
    _id: int = field(default=0, repr=False)
    _want: int = field(default=0, repr=False)
    _sn: int = field(default=0, repr=False)
    _block: int = field(default=0, repr=False)      # consecutive frames left in this block
    _deadline: float = field(default=0.0, repr=False)

    def __post_init__(self):
        if self.direction not in (p.DIR_TO_MICRO, p.DIR_TO_HOST):
            raise ValueError(f"direction must be {p.DIR_TO_MICRO} or {p.DIR_TO_HOST}, not {self.direction!r}")
        self.capacity = self.capacity or max_bytes(self.direction)
        self._ids = {c.id: c for c in CAN.ids.values() if p.SPEC.messages[c.message].direction == self.direction}

    @property
    def busy(self) -> bool:
        """A reception is in progress."""
        return self._buf is not None

    def take_replies(self) -> list[can.Message]:
        out, self.replies = self.replies, []
        return out

    def _abort(self, why: str) -> None:
        self.stats[why] += 1
        self._buf = None

    def poll(self, now: float) -> None:
        """Abort a reception whose next consecutive frame is overdue (N_Cr)."""
        if self._buf is not None and now > self._deadline:
            self._abort("timeout")

    def feed(self, msg: can.Message, now: float) -> Received | None:
        """Handle one CAN frame; the message it completes, if any."""
        self.poll(now)
        mapping = self._ids.get(msg.arbitration_id)
        if mapping is None:
            return None  # another node's traffic (or our own flow control)
        if not _well_formed(msg):
            self.stats["bad_frame"] += 1
            return None
        data = bytes(msg.data)
        kind = data[0] >> 4
        if kind == SINGLE:
            n = data[0] & 0xF
            if not 1 <= n <= SF_MAX:
                self.stats["bad_frame"] += 1
                return None
            if self._buf is not None:
                self._abort("restarted")
            self.stats["good"] += 1
            return Received(msg.arbitration_id, mapping.message, data[1:1 + n])
        if kind == FIRST:
            n = (data[0] & 0xF) << 8 | data[1]
            if n <= SF_MAX:
                self.stats["bad_frame"] += 1
                return None
            if self._buf is not None:
                self._abort("restarted")
            if n > self.capacity:
                self.stats["overflow"] += 1
                self.replies.append(flow_control(mapping.fc_id, OVERFLOW, 0, 0))
                return None
            self._buf, self._id, self._want, self._sn = bytearray(data[2:8]), msg.arbitration_id, n, 1
            self._block, self._deadline = self.block_size, now + self.n_cr
            self.replies.append(flow_control(mapping.fc_id, CONTINUE, self.block_size, self.st_min))
            return None
        if kind == CONSECUTIVE:
            if self._buf is None or msg.arbitration_id != self._id:
                self.stats["unexpected"] += 1
                return None
            if data[0] & 0xF != self._sn:
                self._abort("wrong_sn")
                return None
            self._buf += data[1:1 + min(CF_DATA, self._want - len(self._buf))]
            self._sn = (self._sn + 1) & 0xF
            self._deadline = now + self.n_cr
            if len(self._buf) >= self._want:
                out, self._buf = bytes(self._buf), None
                self.stats["good"] += 1
                return Received(self._id, mapping.message, out)
            if self.block_size:
                self._block -= 1
                if self._block == 0:
                    self._block = self.block_size
                    self.replies.append(flow_control(mapping.fc_id, CONTINUE, self.block_size, self.st_min))
            return None
        self.stats["bad_frame"] += 1  # a flow control on a message identifier, or PCI type 4-15
        return None


@dataclass
class Sender:
    """ISO-TP transmission of the messages one end sends (`direction`), one at a time.

    `send()` starts a message; `poll(now)` returns the CAN frames due now (a single
    frame or first frame at once, the consecutive frames as the receiver's flow control
    allows: block size, STmin); `feed()` takes every CAN frame seen, for the flow
    control. `stats` counts TX_STATS."""

    direction: str
    n_bs: float = CAN.n_bs_ms / 1000.0  # s
    stats: dict = field(default_factory=lambda: dict.fromkeys(TX_STATS, 0))
    _frames: list = field(default_factory=list, repr=False)  # frames not yet sent
    _fc_id: int = field(default=-1, repr=False)
    _waiting: bool = field(default=False, repr=False)   # for a flow control
    _deadline: float = field(default=0.0, repr=False)
    _block: int = field(default=0, repr=False)          # consecutive frames left before the next FC (0 = all)
    _gap: float = field(default=0.0, repr=False)        # s between consecutive frames
    _next: float = field(default=0.0, repr=False)       # when the next consecutive frame may go

    @property
    def busy(self) -> bool:
        """A message is being sent."""
        return bool(self._frames)

    def send(self, payload: bytes, now: float, can_id: int | None = None) -> bool:
        """Start sending `payload` (a serial frame: its msg_type picks the identifier unless
        `can_id` is given). False (counted in `busy`) while another is being sent."""
        if self._frames:
            self.stats["busy"] += 1
            return False
        if can_id is None:
            mtype = int.from_bytes(payload[4:6], "little") if len(payload) >= 6 else -1
            found = [m for m in p.SPEC.serial_messages() if m.id == mtype and m.direction == self.direction]
            if not found:
                raise ValueError(f"no {self.direction} message has msg_type {mtype}")
            mapping = CAN.ids[found[0].name]
        else:
            mapping = _IDS.get(can_id)
            if mapping is None:
                raise ValueError(f"0x{can_id:03X} is no message identifier of the CAN mapping")
        self._frames = segment(mapping.id, bytes(payload))
        self._fc_id = mapping.fc_id
        self._waiting = len(self._frames) > 1
        self._deadline, self._next, self._block = now + self.n_bs, now, 0
        return True

    def feed(self, msg: can.Message, now: float) -> None:
        """Take a flow control for the message being sent (other frames are ignored)."""
        if not self._frames or msg.arbitration_id != self._fc_id or not self._waiting:
            return
        data = bytes(msg.data)
        if not _well_formed(msg) or data[0] >> 4 != FLOW:
            self.stats["bad_fc"] += 1
            return
        status = data[0] & 0xF
        if status == CONTINUE:
            self._waiting, self._block = False, data[1]
            # STmin holds between any two consecutive frames, across a flow control too
            self._gap, self._next = st_min_seconds(data[2]), max(self._next, now)
        elif status == WAIT:
            self.stats["wait"] += 1
            self._deadline = now + self.n_bs
        elif status == OVERFLOW:
            self.stats["overflow"] += 1
            self._frames = []
        else:  # an invalid flow status aborts the message (ISO 15765-2 N_INVALID_FS)
            self.stats["bad_fc"] += 1
            self._frames = []

    def poll(self, now: float) -> list[can.Message]:
        """The frames due now (a single or first frame at once, consecutive frames as the
        flow control allows); aborts a message whose flow control is overdue (N_Bs)."""
        out = []
        while self._frames:
            kind = self._frames[0].data[0] >> 4
            if kind in (SINGLE, FIRST):
                out.append(self._stamp(self._frames.pop(0), now))
                if kind == SINGLE:
                    self.stats["sent"] += 1
                continue
            if self._waiting:
                if now > self._deadline:
                    self.stats["timeout"] += 1
                    self._frames = []
                break
            if now < self._next:
                break
            out.append(self._stamp(self._frames.pop(0), now))
            self._next = now + self._gap
            if not self._frames:
                self.stats["sent"] += 1
                break
            if self._block:
                self._block -= 1
                if self._block == 0:
                    self._waiting, self._deadline = True, now + self.n_bs
            if self._gap > 0:
                break
        return out

    @staticmethod
    def _stamp(msg: can.Message, now: float) -> can.Message:
        msg.timestamp = now
        return msg


@dataclass
class Endpoint:
    """One end of the micro link over CAN: `side` "host" (sends to the micro, receives
    micro_data) or "micro". `feed()` every frame seen on the bus (flow control for the
    sender, message frames for the receiver), `send()` a serial frame, `poll(now)` the
    frames to put on the bus (flow control first: they keep the peer going)."""

    side: str
    rx: Receiver = field(init=False)
    tx: Sender = field(init=False)

    def __post_init__(self):
        if self.side not in ("host", "micro"):
            raise ValueError(f"side must be host or micro, not {self.side!r}")
        send, recv = ((p.DIR_TO_MICRO, p.DIR_TO_HOST) if self.side == "host" else (p.DIR_TO_HOST, p.DIR_TO_MICRO))
        self.rx, self.tx = Receiver(recv), Sender(send)

    def feed(self, msg: can.Message, now: float) -> Received | None:
        self.tx.feed(msg, now)
        return self.rx.feed(msg, now)

    def send(self, payload: bytes, now: float) -> bool:
        return self.tx.send(payload, now)

    def poll(self, now: float) -> list[can.Message]:
        self.rx.poll(now)
        return self.rx.take_replies() + self.tx.poll(now)
