"""The firmware FMU's CAN build (build/fmus/navkit_firmware_can.fmu) in fmpy: the core's CAN
link (FW_LINK_CAN=1, ISO-TP in C) behind the Binary variables can_rx / can_tx, one frame
a 12-byte record (fw_fmu_model.h). The host's end here is navkit.can's Endpoint (the
Python ISO-TP): configs and a command go in as CAN frames, micro_data come back as CAN
frames, and a wheel model closes the loop as in test_firmware_fmu. What the micro's ISO-TP
refuses and aborts comes back in micro_data's can_* counters.
"""

from __future__ import annotations

import re
import struct

import pytest

fmpy = pytest.importorskip("fmpy")
import can  # noqa: E402
from fmpy.validation import validate_fmu  # noqa: E402

from navkit import can as nc  # noqa: E402
from navkit import protocol  # noqa: E402
from navkit.gen import can_frames  # noqa: E402
from navkit.paths import build_dir, repo_root  # noqa: E402
from firmware_helpers import Wheels, cmd, config_frames  # noqa: E402

FMU = build_dir() / "fmus" / "navkit_firmware_can.fmu"
MODEL_H = repo_root() / "fmu" / "firmware" / "fw_fmu_model.h"
pytestmark = pytest.mark.skipif(not FMU.exists(), reason=f"{FMU} not built")

RECORD = struct.Struct("<HBx8s")      # identifier, DLC, 0, data (fw_fmu_model.h)
EXT, RTR = 0x8000, 0x4000             # record identifier flags: extended, remote (fw_fmu_model.h)


def can_counters(fields: dict) -> dict:
    """The micro's CAN transport counters of a micro_data (the can_* fields)."""
    return {k: v for k, v in fields.items() if k.startswith("can_")}


def configs_one_a_frame() -> list[bytes]:
    """The three config frames, one message each (one a host frame)."""
    return [f for _, f in protocol.split_frames(config_frames())[0]]


def pack(msgs) -> bytes:
    return b"".join(RECORD.pack(m.arbitration_id, m.dlc, bytes(m.data)) for m in msgs)


def unpack(raw: bytes) -> list[can.Message]:
    assert len(raw) % RECORD.size == 0, len(raw)
    return [can.Message(arbitration_id=i, data=d[:n], is_extended_id=False)
            for i, n, d in RECORD.iter_unpack(raw)]


class Bus:
    """The host's end of the bus (navkit.can.Endpoint) and the FMU, in 1 ms steps: each
    host frame (every `frame_s`) sends the next of `messages` (serial frames; the last one
    repeats); returns the micro_data fields the host reassembled, and keeps every frame the
    micro sent (`sent`)."""

    def __init__(self, m, wheels=None):
        self.m, self.w = m, wheels
        self.host = nc.Endpoint("host")
        self.sent: list[can.Message] = []
        self.skipped = 0                 # host messages ISO-TP could not start (busy)

    def run(self, seconds: float, messages=(), frame_s: float = 0.1, lose=None) -> list[dict]:
        out, queue = [], list(messages)
        every = round(frame_s / 0.001)
        for k in range(round(seconds / 0.001)):
            now = self.m.t
            if queue and k % every == 0:
                if not self.host.send(queue[0], now):
                    self.skipped += 1
                if len(queue) > 1:
                    queue.pop(0)
            frames = self.host.poll(now)
            if lose is not None:
                frames = [f for f in frames if not lose(f)]
            if self.w:
                self.w.drive(self.m)
            self.m.fmu.setBinary([self.m.vr["can_rx"]], [pack(frames)])
            self.m.fmu.doStep(self.m.t, 0.001)
            self.m.t += 0.001
            if self.w:
                self.w.advance(self.m, 0.001)
            for msg in unpack(bytes(self.m.fmu.getBinary([self.m.vr["can_tx"]])[0])):
                self.sent.append(msg)
                got = self.host.feed(msg, self.m.t)
                if got is not None:
                    name, fields = protocol.decode_frame(got.data)
                    assert name == "micro_data" and got.can_id == 0x180
                    out.append(fields)
        return out


def test_the_description_has_can_frames_instead_of_serial_bytes(md):
    assert validate_fmu(str(FMU)) == []
    assert md.coSimulation.modelIdentifier == "navkit_firmware_can"
    names = {v.name: v for v in md.modelVariables}
    assert "serial_rx" not in names and "serial_tx" not in names
    assert (names["can_rx"].type, names["can_rx"].causality) == ("Binary", "input")
    assert (names["can_tx"].type, names["can_tx"].causality) == ("Binary", "output")
    assert "12 bytes each" in names["can_rx"].description
    # the Binary rows of the CAN build's block of fw_fmu_model.h, the rest as the serial FMU's
    blocks = re.findall(r"#define FW_FMU_BINARY_VARS\(X\)(.*?)\n\n", MODEL_H.read_text(), re.S)
    rows = re.findall(r"X\((\d+), (\w+), (\w+)", blocks[1])
    assert {n: (int(vr), c) for vr, n, c in rows} == \
        {v.name: (v.valueReference, v.causality) for v in md.modelVariables if v.type == "Binary"}
    serial = fmpy.read_model_description(str(FMU.with_name("navkit_firmware.fmu")))

    def others(d):
        return {v.name: (v.valueReference, v.type, v.causality, v.start, v.unit)
                for v in d.modelVariables if v.type != "Binary"}
    assert others(md) == others(serial) and len(others(md)) > 25


def test_config_and_a_command_over_can_frames(micro, status_bit):
    m = micro()
    w = Wheels()
    bus = Bus(m, w)
    assert bus.run(1.2) == [] and bus.sent == []     # gyro calibration; nothing unasked
    data = bus.run(5.0, configs_one_a_frame() + [cmd(10, fwd_cmd=1, speed=250, distance=800)])
    assert bus.skipped == 0
    assert len(data) >= 47, len(data)                 # a reply per message, the last ones in flight
    last = data[-1]
    assert last["ack_time_tag"] == 10 and last["status"] & status_bit("fwd_done")
    assert last["distance"] == pytest.approx(800, abs=5) and w.dist == pytest.approx(800, abs=5)
    # the micro's frames: flow control on each host message's flow control identifier,
    # micro_data on its own, every one a classic 8-byte frame
    ids = {msg.arbitration_id for msg in bus.sent}
    assert ids == {0x111, 0x121, 0x123, 0x125, 0x180}
    assert all(msg.dlc == 8 for msg in bus.sent)
    rx = bus.host.rx.stats
    assert rx["good"] == len(data) and rx["wrong_sn"] == rx["bad_frame"] == 0


def configured(micro) -> tuple:
    """(instance, its Bus, the micro_data answering its first command, time tag 5) of a
    micro past its gyro calibration and configured over CAN; its CAN counters are all 0."""
    m = micro()
    bus = Bus(m)
    bus.run(1.2)
    before = bus.run(0.4, configs_one_a_frame() + [cmd(5, fwd_cmd=1, speed=100, distance=10)])[-1]
    assert before["ack_time_tag"] == 5 and not any(can_counters(before).values())
    return m, bus, before


def test_a_lost_frame_costs_one_command(micro, status_bit):
    """A consecutive frame of one micro_cmd lost on the bus: the micro's ISO-TP aborts
    that message, the next host frame's repeat gets through and is answered."""
    _, bus, before = configured(micro)
    n0 = len(bus.sent)
    lost = []

    def lose(f):          # the 3rd consecutive frame of the first micro_cmd from now
        if f.arbitration_id == 0x110 and f.data[0] == 0x23 and not lost:
            lost.append(f)
            return True
        return False
    data = bus.run(0.5, [cmd(6, fwd_cmd=1, speed=100, distance=10)], lose=lose)
    assert lost and 3 <= len(data) <= 4, len(data)    # 5 host frames, one command lost
    assert data[-1]["ack_time_tag"] == 6 and len(bus.sent) > n0
    # the micro says so in micro_data: one message aborted out of sequence, the consecutive
    # frames after the one that aborted it ignored (a micro_cmd is a first + 16 consecutive)
    n_cf = can_frames(protocol.SPEC.messages["micro_cmd"].size) - 1
    assert can_counters(data[-1]) == dict(can_counters(before), can_rx_wrong_sn=1, can_rx_unexpected=n_cf - 4)


def test_refused_frames_come_back_counted_in_micro_data(micro):
    """A short, an extended and a remote frame on micro_cmd's identifier and a stray
    consecutive frame, between two host frames: the micro's ISO-TP refuses the three and
    ignores the fourth, and the next micro_data counts them, each in its own field."""
    m, bus, before = configured(micro)
    bad = [RECORD.pack(0x110, 5, bytes([0x02, 1, 2, 0xCC, 0xCC]) + bytes(3)),
           RECORD.pack(0x110 | EXT, 8, bytes([0x02, 1, 2]) + bytes([0xCC]) * 5),
           RECORD.pack(0x110 | RTR, 0, bytes(8)),
           RECORD.pack(0x110, 8, bytes([0x21]) + bytes(7))]
    m.fmu.setBinary([m.vr["can_rx"]], [b"".join(bad)])
    m.fmu.doStep(m.t, 0.001)
    m.t += 0.001
    assert m.fmu.getBinary([m.vr["can_tx"]])[0] == b"", "no answer to refused frames"
    after = bus.run(0.2, [cmd(6, fwd_cmd=1, speed=100, distance=10)])[-1]
    assert after["ack_time_tag"] == 6
    assert can_counters(after) == dict(can_counters(before), can_rx_bad_frame=3, can_rx_unexpected=1)
    assert after["rx_bad_crc"] == after["rx_dropped_bytes"] == 0, "the frame parser never saw them"


def test_a_partial_record_is_refused_with_a_warning(micro):
    m = micro()
    m.fmu.setDebugLogging(True, ["logEvents"])
    m.fmu.setBinary([m.vr["can_rx"]], [bytes(RECORD.size + 5)])
    m.fmu.doStep(0.0, 0.001)
    assert any("can_rx: 5 bytes are no whole 12-byte frame record" in s for s in m.log), m.log
