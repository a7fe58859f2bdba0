"""navkit.can_slcan: the adapter's side of SLCAN, alone and facing python-can's own slcan
interface over a pty (the real client, as `navkit can dump --port` and a host use it),
with the kit's ISO-TP messages crossing it both ways."""

import os
import pty
import select
import threading
import time
import tty

import can
import pytest

from navkit import can as nc
from navkit import protocol as p
from navkit.can_slcan import SlcanAdapter, frame_line


def test_commands_and_their_answers():
    a = SlcanAdapter()
    reply, frames = a.feed(b"O\r")  # no bit rate yet: refused
    assert reply == b"\x07" and not a.is_open
    reply, frames = a.feed(b"S6\rV\rN\rO\r")
    assert reply == b"\rV1013\rNA123\r\r" and a.bitrate == 500_000 and a.is_open and frames == []
    reply, frames = a.feed(b"S4\r")  # no bit rate change while open
    assert reply == b"\x07" and a.bitrate == 500_000
    reply, frames = a.feed(b"t1108" + b"1074A5FF07000100" + b"\rT1ABCDEF02AABB\rr1230\r")
    assert reply == b"z\rZ\rz\r"
    assert [(f.arbitration_id, f.is_extended_id, f.is_remote_frame, bytes(f.data)) for f in frames] == [
        (0x110, False, False, bytes.fromhex("1074A5FF07000100")), (0x1ABCDEF0, True, False, b"\xaa\xbb"),
        (0x123, False, True, b"")]
    # chunking does not matter
    got = [a.feed(bytes([b])) for b in b"t7FF100\r"]
    assert b"".join(r for r, _ in got) == b"z\r" and [f for _, fs in got for f in fs][0].arbitration_id == 0x7FF


@pytest.mark.parametrize("line", [b"t8001AA", b"t1109" + b"00" * 9, b"t1102AA", b"t11G0", b"tZZ", b"S",
                                  b"S10", b"Q", b"T2000000000", b"r1231AA", b"x" * 80])
def test_malformed_commands_are_refused_and_counted(line):
    a = SlcanAdapter()
    a.feed(b"S6\rO\r")
    reply, frames = a.feed(line + b"\r")
    assert reply == b"\x07" and frames == [] and a.stats["refused"] == 1


def test_the_channel_state_gates_frames_both_ways():
    a = SlcanAdapter()
    a.feed(b"S6\r")
    msg = nc.frame(0x180, bytes(8))
    assert a.to_host(msg) == b"" and a.stats["dropped"] == 1  # closed: nothing to the host
    assert a.feed(b"t110100\r")[0] == b"\x07"                 # closed: nothing to the bus
    a.feed(b"L\r")
    assert a.feed(b"L\r")[0] == b"\r" and a.feed(b"O\r")[0] == b"\x07"  # the same mode again: done
    assert a.to_host(msg) == frame_line(msg) and a.stats["received"] == 1
    assert a.feed(b"t110100\r") == (b"\x07", [])              # listen-only: never sends
    a.feed(b"C\rO\r")
    assert a.feed(b"t110100\r")[0] == b"z\r"
    assert frame_line(msg) == b"t1808" + b"00" * 8 + b"\r"


def _adapter_on_pty(adapter: SlcanAdapter, bus_side: list, outbox: list, stop: threading.Event, master: int):
    """Serve the adapter on the pty master: the host's bytes in, the replies and the
    frames of `outbox` (from the bus) out; what the host sends goes to `bus_side`."""
    while not stop.is_set():
        ready, _, _ = select.select([master], [], [], 0.01)
        if ready:
            reply, frames = adapter.feed(os.read(master, 1024))
            bus_side.extend(frames)
            if reply:
                os.write(master, reply)
        while outbox:
            line = adapter.to_host(outbox.pop(0))
            if line:
                os.write(master, line)


def test_python_cans_slcan_interface_talks_to_the_adapter_and_iso_tp_crosses_it():
    master, slave = pty.openpty()
    tty.setraw(slave)
    adapter, bus_side, outbox, stop = SlcanAdapter(), [], [], threading.Event()
    th = threading.Thread(target=_adapter_on_pty, args=(adapter, bus_side, outbox, stop, master), daemon=True)
    th.start()
    bus = None
    try:
        bus = can.Bus(interface="slcan", channel=os.ttyname(slave), bitrate=nc.CAN.bitrate, sleep_after_open=0)
        assert bus.get_version(2.0) == (10, 13)
        deadline = time.monotonic() + 5
        while not adapter.is_open and time.monotonic() < deadline:
            time.sleep(0.01)
        assert adapter.is_open and adapter.bitrate == nc.CAN.bitrate and not adapter.listen_only
        # the host (python-can's side) sends a micro_cmd; the micro (behind the adapter) answers
        host, micro = nc.Endpoint("host"), nc.Endpoint("micro")
        cmd = p.encode_frame("micro_cmd", {"fwd_cmd": 1, "speed": 250}, time_tag=12)
        host.send(cmd, time.monotonic())
        got_cmd, got_data = [], []
        deadline = time.monotonic() + 10
        while not got_data and time.monotonic() < deadline:
            now = time.monotonic()
            for m in host.poll(now):
                bus.send(m)
            while bus_side:
                r = micro.feed(bus_side.pop(0), now)
                if r:
                    got_cmd.append(r)
                    micro.send(p.encode_frame("micro_data", {"ack_time_tag": 12}, time_tag=3), now)
            outbox.extend(micro.poll(now))
            msg = bus.recv(timeout=0.005)
            while msg is not None:
                r = host.feed(msg, time.monotonic())
                if r:
                    got_data.append(r)
                msg = bus.recv(timeout=0)
        assert [r.data for r in got_cmd] == [cmd]
        assert [p.decode_frame(r.data)[1]["ack_time_tag"] for r in got_data] == [12]
        assert adapter.stats["refused"] == 0, adapter.last_refused
        assert adapter.stats["sent"] == 1 + 16 + 1  # FF, CFs, the host's FC
    finally:
        if bus is not None:
            bus.shutdown()
        stop.set()
        th.join(2)
        os.close(master)
        os.close(slave)
    assert not adapter.is_open  # shutdown closes the channel ("C")
