"""ISO 15765-2 on the kit's CAN mapping (navkit.can): every message of the spec survives
the trip both ways; loss and reordering behave as the standard defines (a consecutive frame
out of sequence aborts the message, a new first frame restarts, timeouts abort); bad frames
are refused and counted; the flow control's block size and STmin pace the sender."""

import random

import can
import pytest

from navkit import can as nc
from navkit import protocol as p

CMD_ID = nc.CAN.ids["micro_cmd"].id
DATA_ID = nc.CAN.ids["micro_data"].id


def _cmd(tag: int) -> bytes:
    return p.encode_frame("micro_cmd", {"fwd_cmd": 1, "speed": 200, "distance": 1000 + tag}, time_tag=tag)


def _run(sender: nc.Endpoint, receiver: nc.Endpoint, t0: float = 0.0, steps: int = 60, dt: float = 0.0005,
         mangle=None):
    """Exchange frames between two ends for `steps` steps of `dt` s; `mangle(frames)`
    may drop or reorder the frames the sender puts on the bus. Returns (messages the
    receiver completed, every frame on the bus)."""
    got, bus, t = [], [], t0
    for _ in range(steps):
        out = sender.poll(t)
        if mangle:
            out = mangle(out)
        for m in out:
            bus.append(m)
            r = receiver.feed(m, t)
            if r:
                got.append(r)
        for m in receiver.poll(t):
            bus.append(m)
            sender.feed(m, t)
        t += dt
    return got, bus


@pytest.mark.parametrize("name", [m.name for m in p.SPEC.serial_messages()])
def test_every_message_survives_the_trip(name):
    m = p.SPEC.messages[name]
    a, b = (nc.Endpoint("host"), nc.Endpoint("micro")) if m.direction == p.DIR_TO_MICRO else \
        (nc.Endpoint("micro"), nc.Endpoint("host"))
    frame = p.encode_frame(name, p.defaults(name), time_tag=77)
    assert a.send(frame, 0.0)
    got, bus = _run(a, b)
    assert [(r.message, r.data) for r in got] == [(name, frame)]
    assert p.decode_frame(got[0].data)[1]["time_tag"] == 77
    on_id = [f for f in bus if f.arbitration_id == nc.CAN.ids[name].id]
    on_fc = [f for f in bus if f.arbitration_id == nc.CAN.ids[name].fc_id]
    assert len(on_id) == 1 + -(-(len(frame) - 6) // 7) and len(on_fc) == 1  # block size 0: one flow control
    assert all(f.dlc == 8 and not f.is_extended_id for f in bus)
    assert bytes(on_id[-1].data).endswith(bytes([nc.CAN.padding]))  # the last frame is padded
    assert a.tx.stats["sent"] == 1 and b.rx.stats == dict.fromkeys(nc.RX_STATS, 0) | {"good": 1}


def test_a_lost_consecutive_frame_aborts_the_message_and_the_next_one_passes():
    host, micro = nc.Endpoint("host"), nc.Endpoint("micro")
    dropped = []

    def drop_third_cf(frames):
        keep = []
        for f in frames:
            if f.data[0] == 0x23 and not dropped:
                dropped.append(f)
                continue
            keep.append(f)
        return keep
    host.send(_cmd(1), 0.0)
    got, _ = _run(host, micro, mangle=drop_third_cf)
    assert got == [] and dropped
    st = micro.rx.stats
    # the frame after the gap aborts (wrong sequence number); the rest are ignored as unexpected
    n_cf = -(-(len(_cmd(1)) - 6) // 7)
    assert st["wrong_sn"] == 1 and st["unexpected"] == n_cf - 4 and st["good"] == 0
    assert host.tx.stats["sent"] == 1  # the sender cannot know: ISO-TP has no acknowledgement
    host.send(_cmd(2), 0.1)
    got, _ = _run(host, micro, t0=0.1)
    assert [r.data for r in got] == [_cmd(2)]


def test_reordered_consecutive_frames_abort_the_message():
    host, micro = nc.Endpoint("host"), nc.Endpoint("micro")

    def swap(frames):  # a gateway that swaps CF 2 and CF 3
        d = [f.data[0] for f in frames]
        if 0x22 in d and 0x23 in d:
            i, j = d.index(0x22), d.index(0x23)
            frames[i], frames[j] = frames[j], frames[i]
        return frames
    host.send(_cmd(5), 0.0)
    got, _ = _run(host, micro, mangle=swap)
    assert got == [] and micro.rx.stats["wrong_sn"] == 1


def test_sequence_numbers_wrap_after_15():
    frames = nc.segment(DATA_ID, p.encode_frame("micro_data", {}))
    sn = [f.data[0] & 0xF for f in frames[1:]]
    assert sn[:17] == list(range(1, 16)) + [0, 1]
    rx = nc.Receiver(p.DIR_TO_HOST)
    got = [rx.feed(f, 0.0) for f in frames]
    assert got[-1].data == p.encode_frame("micro_data", {}) and got[:-1] == [None] * (len(frames) - 1)


def test_a_new_first_frame_restarts_and_a_single_frame_aborts():
    rx = nc.Receiver(p.DIR_TO_MICRO)
    a, b = nc.segment(CMD_ID, _cmd(1)), nc.segment(CMD_ID, _cmd(2))
    for f in a[:5]:
        assert rx.feed(f, 0.0) is None
    got = [rx.feed(f, 0.001) for f in b]
    assert got[-1].data == _cmd(2) and rx.stats["restarted"] == 1 and rx.stats["good"] == 1
    # a single frame (a peer's short message) during a reception: the reception is abandoned
    for f in a[:3]:
        rx.feed(f, 0.002)
    single = rx.feed(nc.frame(CMD_ID, bytes([0x03, 1, 2, 3])), 0.002)
    assert single.data == bytes([1, 2, 3]) and rx.stats["restarted"] == 2
    assert rx.feed(a[3], 0.002) is None and rx.stats["unexpected"] == 1


def test_a_late_consecutive_frame_times_out():
    rx = nc.Receiver(p.DIR_TO_MICRO)
    frames = nc.segment(CMD_ID, _cmd(1))
    for f in frames[:4]:
        rx.feed(f, 0.0)
    late = 0.0 + nc.CAN.n_cr_ms / 1000.0 + 0.001
    assert rx.feed(frames[4], late) is None
    assert rx.stats["timeout"] == 1 and rx.stats["unexpected"] == 1 and not rx.busy
    # just within N_Cr the reception goes on
    rx2 = nc.Receiver(p.DIR_TO_MICRO)
    t = 0.0
    for f in frames:
        got = rx2.feed(f, t)
        t += nc.CAN.n_cr_ms / 1000.0 - 0.001
    assert got.data == _cmd(1) and rx2.stats["timeout"] == 0


@pytest.mark.parametrize("make,what", [
    (lambda: can.Message(arbitration_id=CMD_ID, data=bytes([0x10, 0x74, 1, 2, 3]), is_extended_id=False), "short"),
    (lambda: can.Message(arbitration_id=CMD_ID, data=bytes(8), is_extended_id=True), "extended"),
    (lambda: can.Message(arbitration_id=CMD_ID, is_remote_frame=True, dlc=8, is_extended_id=False), "remote"),
    (lambda: can.Message(arbitration_id=CMD_ID, is_error_frame=True, data=bytes(8), is_extended_id=False), "error"),
    (lambda: nc.frame(CMD_ID, bytes([0x40, 1, 2])), "PCI type 4"),
    (lambda: nc.frame(CMD_ID, bytes([0x00, 1, 2])), "single frame of length 0"),
    (lambda: nc.frame(CMD_ID, bytes([0x08, 1, 2, 3, 4, 5, 6, 7])), "single frame of length 8"),
    (lambda: nc.frame(CMD_ID, bytes([0x10, 0x07, 1, 2, 3, 4, 5, 6])), "first frame of 7 bytes"),
    (lambda: nc.flow_control(CMD_ID), "flow control on a message identifier"),
])
def test_bad_frames_are_refused_and_counted(make, what):
    rx = nc.Receiver(p.DIR_TO_MICRO)
    assert rx.feed(make(), 0.0) is None, what
    assert rx.stats == dict.fromkeys(nc.RX_STATS, 0) | {"bad_frame": 1}, what
    assert rx.take_replies() == [] and not rx.busy


def test_other_traffic_is_ignored_not_counted():
    rx = nc.Receiver(p.DIR_TO_MICRO)
    for f in (nc.frame(0x7FF, bytes(8)), nc.segment(DATA_ID, p.encode_frame("micro_data", {}))[0],
              nc.flow_control(nc.CAN.ids["micro_cmd"].fc_id)):
        assert rx.feed(f, 0.0) is None
    assert rx.stats == dict.fromkeys(nc.RX_STATS, 0)


def test_an_overflow_flow_control_makes_the_sender_give_up():
    host = nc.Endpoint("host")
    micro = nc.Endpoint("micro")
    micro.rx.capacity = 40
    host.send(_cmd(1), 0.0)
    got, bus = _run(host, micro, steps=5)
    assert got == [] and micro.rx.stats["overflow"] == 1 and host.tx.stats["overflow"] == 1 and not host.tx.busy
    assert [f.data[0] for f in bus] == [0x10, 0x32]  # the first frame, the overflow: nothing more


def test_block_size_and_st_min_pace_the_sender():
    host, micro = nc.Endpoint("host"), nc.Endpoint("micro")
    micro.rx.block_size, micro.rx.st_min = 4, 0xF5  # 4 frames a block, 500 us apart
    frame = _cmd(9)
    host.send(frame, 0.0)
    got, bus = _run(host, micro, steps=400, dt=0.0001)
    assert [r.data for r in got] == [frame]
    cfs = [f for f in bus if f.arbitration_id == CMD_ID and f.data[0] >> 4 == nc.CONSECUTIVE]
    fcs = [f for f in bus if f.arbitration_id == nc.CAN.ids["micro_cmd"].fc_id]
    assert len(fcs) == -(-len(cfs) // 4)  # one after the first frame, one after each full block but the last
    gaps = [b.timestamp - a.timestamp for a, b in zip(cfs, cfs[1:])]
    assert min(gaps) >= 0.0005 - 1e-9


def test_the_sender_waits_for_flow_control_then_gives_up():
    tx = nc.Sender(p.DIR_TO_MICRO)
    assert tx.send(_cmd(1), 0.0) and not tx.send(_cmd(2), 0.0) and tx.stats["busy"] == 1
    assert [f.data[0] for f in tx.poll(0.0)] == [0x10]
    assert tx.poll(0.05) == []  # no consecutive frame before the flow control
    fc_id = nc.CAN.ids["micro_cmd"].fc_id
    tx.feed(nc.flow_control(fc_id, nc.WAIT), 0.09)  # WAIT restarts N_Bs
    assert tx.poll(0.15) == [] and tx.busy and tx.stats["wait"] == 1
    assert tx.poll(0.09 + nc.CAN.n_bs_ms / 1000.0 + 0.001) == []
    assert tx.stats["timeout"] == 1 and not tx.busy
    # an invalid flow status aborts; a flow control on another identifier is not ours
    tx.send(_cmd(3), 1.0)
    tx.poll(1.0)
    tx.feed(nc.flow_control(nc.CAN.ids["micro_cfg_io"].fc_id), 1.0)
    assert tx.busy
    tx.feed(nc.frame(fc_id, bytes([0x37, 0, 0])), 1.0)
    assert tx.stats["bad_fc"] == 1 and not tx.busy


def test_random_loss_and_reordering_never_deliver_a_wrong_message(prop_seed, prop_count):
    """Seeded: messages through a bus that drops and swaps frames at random; every message
    delivered is one that was sent, whole, and every one sent is delivered or counted."""
    rng = random.Random(prop_seed)
    host, micro = nc.Endpoint("host"), nc.Endpoint("micro")
    sent, t = {}, 0.0

    def mangle(frames):
        out = [f for f in frames if rng.random() > 0.02]
        if len(out) > 1 and rng.random() < 0.05:
            i = rng.randrange(len(out) - 1)
            out[i], out[i + 1] = out[i + 1], out[i]
        return out
    delivered = []
    for k in range(max(prop_count // 3, 20)):
        frame = _cmd(k)
        sent[frame] = k
        assert host.send(frame, t), k
        got, _ = _run(host, micro, t0=t, steps=30, mangle=mangle)
        t += 0.5  # past every timeout: each message starts clean
        host.poll(t)
        micro.poll(t)
        delivered += [r.data for r in got]
    assert all(d in sent for d in delivered), f"seed {prop_seed}"
    st = micro.rx.stats
    lost = st["wrong_sn"] + st["timeout"] + st["restarted"]
    assert st["good"] == len(delivered) and 0 < len(delivered) < len(sent), f"seed {prop_seed}"
    assert st["good"] + lost + host.tx.stats["timeout"] >= len(sent), f"seed {prop_seed}: {st} {host.tx.stats}"


def test_the_golden_vectors_are_what_navkit_can_makes():
    """tests/vectors/can.txt holds navkit.can's reception frame by frame; the C firmware's
    can_tp is held to the same file (ctest firmware.can_tp.*)."""
    from navkit.can_vectors import CAN_VECTORS, make_vectors, read_vectors
    assert CAN_VECTORS.read_text() == make_vectors(), "stale: run python -m navkit.can_vectors --write"
    cases = read_vectors()
    assert len(cases) >= 20 and all(len(c) == 5 for c in cases)
    # the file exercises every counter of the receiver
    totals = [sum(int(c[4].split(",")[k]) for c in cases) for k in range(len(nc.RX_STATS))]
    assert all(totals), dict(zip(nc.RX_STATS, totals))
