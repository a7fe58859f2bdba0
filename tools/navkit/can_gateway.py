"""A CAN gateway for co-simulation: stands where the USB-CAN adapter and the micro's CAN
transport would be, between a host speaking SLCAN on its serial port (`[micro] link =
slcan`) and a firmware speaking the serial link (the firmware FMU, a test's micro).

    host --SLCAN bytes--> SlcanAdapter --CAN frames--> ISO-TP (the micro's side) --frames--> firmware
    host <--SLCAN lines-- SlcanAdapter <--CAN frames-- ISO-TP <--serial bytes, cut into frames-- firmware

Every CAN frame on the simulated bus (both directions, flow controls included) goes to an
optional python-can listener (a `can.Logger` writes a candump-style log or any format it
knows). Times are the caller's seconds (simulated time).

Line noise (`noise(ber)`) is what CAN makes of it: a frame hit by a bit error is destroyed
by an error frame and sent again by the controller, so nothing is lost or corrupted; the
error frames are counted and logged (each try of FRAME_BITS bits fails with probability
1 - (1 - ber)^FRAME_BITS).
"""

from __future__ import annotations

import random
from dataclasses import dataclass, field

import can

from navkit import can as nc
from navkit import protocol as p
from navkit.can_slcan import SlcanAdapter

__all__ = ["CanGateway", "BusTap", "FRAME_BITS", "MAX_TRIES"]

FRAME_BITS = 111   # bits of a classic 8-byte data frame with an 11-bit identifier, unstuffed
MAX_TRIES = 32     # error frames before a frame goes through anyway (a bus this bad is off)


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
    error_frames: int = 0       # frames destroyed by line noise and sent again
    _serial: p.Parser = field(default_factory=lambda: p.Parser(p.DIR_TO_HOST))
    _p_error: float = 0.0       # probability that one try of a frame meets a bit error
    _rng: random.Random | None = None

    def noise(self, ber: float, rng: random.Random | None = None) -> None:
        """Line noise from now on: bit error rate `ber` (0: none), drawn from `rng`."""
        self._p_error = 1.0 - (1.0 - ber) ** FRAME_BITS if ber > 0 else 0.0
        self._rng = rng or self._rng or random.Random(0)

    def _bus(self, msg: can.Message, t: float, rx: bool) -> None:
        self.frames += 1
        tries = 0
        while self._p_error and tries < MAX_TRIES and self._rng.random() < self._p_error:
            tries += 1
            self.error_frames += 1
            if self.listener is not None:
                self.listener.on_message_received(can.Message(timestamp=t, is_error_frame=True,
                                                              arbitration_id=msg.arbitration_id, is_rx=rx,
                                                              is_extended_id=False))
        if self.listener is not None:
            msg.timestamp = t
            msg.is_rx = rx  # rx: towards the host (as the adapter receives it)
            self.listener.on_message_received(msg)

    def _to_host(self, t: float) -> bytes:
        """The micro's frames due now (flow controls, micro_data) as SLCAN lines."""
        out = bytearray()
        for m in self.micro.poll(t):
            self._bus(m, t, True)
            out += self.adapter.to_host(m)
        return bytes(out)

    def from_host(self, data: bytes, t: float) -> tuple[bytes, bytes]:
        """(bytes back to the host: the adapter's answers and the micro's frames now due,
        the serial frames the firmware receives)."""
        reply, frames = self.adapter.feed(data)
        to_micro = bytearray()
        for m in frames:
            self._bus(m, t, False)
            r = self.micro.feed(m, t)
            if r is not None:
                to_micro += r.data
        return reply + self._to_host(t), bytes(to_micro)

    def from_micro(self, data: bytes, t: float) -> bytes:
        """The firmware's serial bytes: each whole frame one ISO-TP message (one at a time:
        a frame while the last is still going out is dropped, as the firmware's CAN build
        skips a reply then); returns the SLCAN lines for the host now due."""
        for e in self._serial.feed(data):
            if isinstance(e, p.Frame) and not self.micro.send(e.raw, t):
                self.skipped += 1
        return self._to_host(t)
