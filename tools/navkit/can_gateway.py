"""A CAN gateway for co-simulation: stands where the USB-CAN adapter and the micro's CAN
transport would be, between a host speaking SLCAN on its serial port (`[micro] link =
slcan`) and a firmware speaking the serial link (the firmware FMU, a test's micro).

    host --SLCAN bytes--> SlcanAdapter --CAN frames--> ISO-TP (the micro's side) --frames--> firmware
    host <--SLCAN lines-- SlcanAdapter <--CAN frames-- ISO-TP <--serial bytes, cut into frames-- firmware

With `firmware_can=True` the micro's side is a firmware FMU's CAN build
(navkit_firmware_can.fmu, or navkit_firmware_avr_can.fmu: the AVR CAN image in simavr
with its MCP2515; either way the micro's ISO-TP is the firmware's C): the gateway then only
translates SLCAN <-> CAN frames, the FMU's frames being 12-byte records (RECORD, the
layout of fw_fmu_model.h), and reassembles both directions as a bus analyser would
(listening only: its flow controls go nowhere) so the run log keeps the serial frames.

    host --SLCAN bytes--> SlcanAdapter --CAN frame records--> firmware FMU (can_rx)
    host <--SLCAN lines-- SlcanAdapter <--CAN frame records-- firmware FMU (can_tx)

Every CAN frame on the simulated bus (both directions, flow controls included) goes to an
optional python-can listener (a `can.Logger` writes a candump-style log or any format it
knows). Times are the caller's seconds (simulated time).

Line noise (`noise(ber)`) is what CAN makes of it: a frame hit by a bit error is destroyed
by an error frame and sent again by the controller, so nothing is corrupted; the error
frames are counted and logged (each try of FRAME_BITS bits fails with probability
1 - (1 - ber)^FRAME_BITS). One thing CAN lets through: a bit error in the last bit of the
end of frame, which the receivers ignore (ISO 11898-1: they have taken the frame a bit
earlier) and the transmitter does not, so it sends the frame again and the receivers get it
twice (`duplicates`; one failed try in FRAME_BITS). ISO-TP then sees a consecutive frame
out of sequence (the message aborts) or a first frame twice (it restarts): the counters of
both ends move, and the next repeat of the message makes it good.
"""

from __future__ import annotations

import random
import struct
from dataclasses import dataclass, field

import can

from navkit import can as nc
from navkit import protocol as p
from navkit.can_slcan import SlcanAdapter

__all__ = ["CanGateway", "BusTap", "FRAME_BITS", "MAX_TRIES", "RECORD"]

FRAME_BITS = 111   # bits of a classic 8-byte data frame with an 11-bit identifier, unstuffed
MAX_TRIES = 32     # error frames before a frame goes through anyway (a bus this bad is off)
# one CAN frame in the firmware FMU's can_rx / can_tx: identifier, DLC, 0, data padded to 8
RECORD = struct.Struct("<HBx8s")


class BusTap(can.Listener):
    """A listener handing every bus frame to `logger` (a python-can Listener, e.g. can.Logger
    writing can.log) and to `record(t_ns, can_id, data, to_host, error_frame)` (the run log's
    /can topic): time in ns from the frame's timestamp (s), data bytes-like, `to_host` the
    frame's is_rx (sent by the micro)."""

    def __init__(self, logger: can.Listener, record):
        self.logger, self.record = logger, record

    def on_message_received(self, msg: can.Message) -> None:
        self.logger.on_message_received(msg)
        self.record(round(msg.timestamp * 1e9), msg.arbitration_id, msg.data, msg.is_rx,
                    msg.is_error_frame)

    def stop(self) -> None:
        self.logger.stop()


@dataclass
class CanGateway:
    """The gateway. `from_host()` takes the host's bytes, `from_micro()` the firmware's;
    each returns what goes where. `listener` (a python-can Listener, e.g. can.Logger) gets
    every frame on the bus; `frames` counts them."""

    listener: can.Listener | None = None
    adapter: SlcanAdapter = field(default_factory=SlcanAdapter)
    micro: nc.Endpoint = field(default_factory=lambda: nc.Endpoint("micro"))
    frames: int = 0
    skipped: int = 0            # the firmware's frames dropped while the last one was going out
                                # (firmware_can: messages it got whole minus replies it began)
    error_frames: int = 0       # frames destroyed by line noise and sent again
    duplicates: int = 0         # frames the receivers took twice (an error in the last EOF bit)
    _serial: p.Parser = field(default_factory=lambda: p.Parser(p.DIR_TO_HOST))
    firmware_can: bool = False  # the micro is the firmware FMU's CAN build: frames as RECORDs
    # firmware_can: the serial frames reassembled from the bus in the last from_host() /
    # from_micro() call (host -> micro, micro -> host), for the run log
    h2m_serial: bytes = b""
    m2h_serial: bytes = b""
    _m2h: nc.Receiver = field(default_factory=lambda: nc.Receiver(p.DIR_TO_HOST))
    _m2h_starts: int = 0        # firmware_can: micro messages begun (first or single frames)
    _p_error: float = 0.0       # probability that one try of a frame meets a bit error
    _rng: random.Random | None = None
    _data_id: int = field(default_factory=lambda: nc.CAN.ids["micro_data"].id)

    def noise(self, ber: float, rng: random.Random | None = None) -> None:
        """Line noise from now on: bit error rate `ber` (0: none), drawn from `rng`."""
        self._p_error = 1.0 - (1.0 - ber) ** FRAME_BITS if ber > 0 else 0.0
        self._rng = rng or self._rng or random.Random(0)

    def _bus(self, msg: can.Message, t: float, rx: bool) -> int:
        """Put `msg` on the bus at `t` (s), `rx` towards the host; returns how many times the
        receivers take it: 1, or more when line noise duplicated it."""
        copies = 1
        self.frames += 1
        msg.timestamp = t
        msg.is_rx = rx  # rx: towards the host (as the adapter receives it)
        tries = 0
        while self._p_error and tries < MAX_TRIES and self._rng.random() < self._p_error:
            tries += 1
            if self._rng.random() < 1.0 / FRAME_BITS:  # the transmitter's last EOF bit: taken, sent again
                copies += 1
                self.frames += 1
                self.duplicates += 1
                if self.listener is not None:
                    self.listener.on_message_received(msg)
            self.error_frames += 1
            if self.listener is not None:
                self.listener.on_message_received(can.Message(timestamp=t, is_error_frame=True,
                                                              arbitration_id=msg.arbitration_id, is_rx=rx,
                                                              is_extended_id=False))
        if self.listener is not None:
            self.listener.on_message_received(msg)
        return copies

    def _to_host(self, t: float) -> bytes:
        """The micro's frames due now (flow controls, micro_data) as SLCAN lines."""
        out = bytearray()
        for m in self.micro.poll(t):
            out += self.adapter.to_host(m) * self._bus(m, t, True)
        return bytes(out)

    def from_host(self, data: bytes, t: float) -> tuple[bytes, bytes]:
        """(bytes back to the host: the adapter's answers and the micro's frames now due,
        the serial frames the firmware receives)."""
        reply, frames = self.adapter.feed(data)
        to_micro = bytearray()
        if self.firmware_can:      # records for can_rx; the micro's frames come from can_tx
            serial = bytearray()
            for m in frames:
                for _ in range(self._bus(m, t, False)):
                    to_micro += RECORD.pack(m.arbitration_id, m.dlc, bytes(m.data))
                    r = self.micro.rx.feed(m, t)    # listening: its flow controls go nowhere
                    if r is not None:
                        serial += r.data
            self.micro.rx.take_replies()
            self.h2m_serial = bytes(serial)
            return reply, bytes(to_micro)
        for m in frames:
            for _ in range(self._bus(m, t, False)):
                r = self.micro.feed(m, t)
                if r is not None:
                    to_micro += r.data
        return reply + self._to_host(t), bytes(to_micro)

    def micro_tx_stats(self) -> dict:
        """The micro's ISO-TP transmission counters (navkit.can.TX_STATS). With firmware_can
        as the bus shows them: `sent` the micro_data reassembled whole, the rest 0 (the
        firmware's own counters are not reported)."""
        if self.firmware_can:
            return dict(dict.fromkeys(nc.TX_STATS, 0), sent=self._m2h.stats["good"])
        return dict(self.micro.tx.stats)

    def from_micro(self, data: bytes, t: float) -> bytes:
        """The firmware's serial bytes: each whole frame one ISO-TP message (one at a time:
        a frame while the last is still going out is dropped, as the firmware's CAN build
        skips a reply then); returns the SLCAN lines for the host now due. With
        firmware_can, `data` is the FMU's can_tx (RECORDs): each frame goes on the bus."""
        if self.firmware_can:
            out, serial = bytearray(), bytearray()
            for can_id, dlc, payload in RECORD.iter_unpack(data):
                m = can.Message(arbitration_id=can_id & 0x7FF, data=payload[:dlc], is_extended_id=False)
                copies = self._bus(m, t, True)
                out += self.adapter.to_host(m) * copies
                if can_id == self._data_id and dlc and payload[0] >> 4 in (nc.SINGLE, nc.FIRST):
                    self._m2h_starts += 1       # a duplicate restarts the same reply: not another
                for _ in range(copies):
                    r = self._m2h.feed(m, t)
                    if r is not None:
                        serial += r.data
            self._m2h.take_replies()
            self.m2h_serial = bytes(serial)
            # the firmware answers each message it gets whole, but skips while its last
            # reply is still going out: the bus shows how many (one may be under way)
            self.skipped = max(0, self.micro.rx.stats["good"] - self._m2h_starts)
            return bytes(out)
        for e in self._serial.feed(data):
            if isinstance(e, p.Frame) and not self.micro.send(e.raw, t):
                self.skipped += 1
        return self._to_host(t)
