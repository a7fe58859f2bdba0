"""navkit.rcomm, the planner client, against the layout of docs/internals.md: it refuses
what is not a navkit region of ours, and its seqlock never returns a torn message."""

import os
import struct

import pytest

from navkit import protocol, rcomm
from host_helpers import Micro, rcomm_region

pytestmark = pytest.mark.timeout(60)


def test_missing_region(shm_name):
    with pytest.raises(rcomm.RcommError, match="rcomm"):
        rcomm.Client(shm_name)


def test_wrong_magic_or_spec_is_refused(shm_name):
    rcomm_region(shm_name, magic=0x12345678)
    with pytest.raises(rcomm.RcommError, match="magic"):
        rcomm.Client(shm_name)
    rcomm_region(shm_name, spec_hash=protocol.SPEC_HASH ^ 1)
    with pytest.raises(rcomm.RcommError, match="spec hash"):
        rcomm.Client(shm_name)


@pytest.mark.skipif(os.geteuid() != 0, reason="needs root to make another user's region")
def test_another_users_region_is_refused(shm_name):
    os.chown(rcomm_region(shm_name), 65534, 65534)
    with pytest.raises(rcomm.RcommError, match="not us"):
        rcomm.Client(shm_name)


def test_seqlock_write_and_torn_read(shm_name):
    rcomm_region(shm_name)
    with rcomm.Client(shm_name) as c:
        assert c.read_data() is None, "never written"
        c.write_cmd({"time_tag": 9, "fwd_cmd": 1, "distance": -5})
        assert c.read_cmd()["distance"] == -5
        off = protocol.SPEC.rcomm.slots["lisp_cmd"]
        with open("/dev/shm" + shm_name, "r+b") as f:
            f.seek(off)
            seq = struct.unpack("<I", f.read(4))[0]
            assert seq == 2, "odd while writing, +2 per message"
            f.seek(off)
            f.write(struct.pack("<I", seq + 1))      # a writer stopped half way
        assert c.read_cmd() is None, "a write in progress is never returned"
        c.write_cmd({"time_tag": 10})
        assert c.read_cmd()["time_tag"] == 10


def test_still_read_is_the_seqlock_read_in_one_copy(shm_name):
    rcomm_region(shm_name)
    off = protocol.SPEC.rcomm.slots["lisp_data"]
    data = protocol.to_bytes("lisp_data", {"time_tag": 7, "distance": -123, "heading": 2700})
    with rcomm.Client(shm_name) as c, open("/dev/shm" + shm_name, "r+b") as f:
        assert c.read_data_raw_still() is None, "never written"
        f.seek(off)
        f.write(struct.pack("<I", 2) + data)         # a host's whole write: seq 2
        f.flush()
        assert c.read_data_raw_still() == c.read_data_raw() == data
        f.seek(off)
        f.write(struct.pack("<I", 3))                # a write in progress after all
        f.flush()
        assert c.read_data_raw_still() is None, "the seqlock read answers: no torn message"


def test_heartbeats_both_ways(host_factory):
    h, m = host_factory(), Micro()
    c = h.client
    c.heartbeat()
    h.step(m)
    h.step(m)
    assert c.host_heartbeat() == 1, "the host's frame counter (frames 0, 1 run)"
    c.write_emotion({"happiness": -100, "talking": 1})
    assert h.client.read_data()["frame"] == 1


def test_heartbeat_is_read_modify_write_of_the_shared_word(shm_name):
    rcomm_region(shm_name)
    with rcomm.Client(shm_name) as a, rcomm.Client(shm_name) as b:
        a.heartbeat()
        b.heartbeat()
        a.heartbeat()
        assert a.planner_heartbeat() == b.planner_heartbeat() == 3, "no beat lost to a cached copy"
    with rcomm.Client(shm_name) as c:
        c.heartbeat()
        assert c.planner_heartbeat() == 4
    with pytest.raises(rcomm.RcommError, match="closed"):
        c.heartbeat()


def test_world_writable_region_is_refused(shm_name):
    os.chmod(rcomm_region(shm_name), 0o666)
    with pytest.raises(rcomm.RcommError, match="world-writable"):
        rcomm.Client(shm_name)


def test_owner_rule():
    me, mine = os.geteuid(), os.getegid()
    assert rcomm.owner_refusal(me, mine + 4321, 0o100600) == ""
    assert "world-writable" in rcomm.owner_refusal(me, mine, 0o100666)
    assert rcomm.owner_refusal(me + 1, mine, 0o100660) == "", "shared with our group"
    assert "not ours" in rcomm.owner_refusal(me + 1, mine, 0o100600), "group has no rw"
    assert "not ours" in rcomm.owner_refusal(me + 1, mine + 4321, 0o100660)


@pytest.mark.skipif(os.geteuid() != 0, reason="needs root to make another user's region")
def test_another_users_region_shared_with_our_group_is_accepted(shm_name):
    path = rcomm_region(shm_name)
    os.chown(path, 65534, os.getegid())
    os.chmod(path, 0o660)
    with rcomm.Client(shm_name) as c:
        c.write_cmd({"time_tag": 3})
        assert c.read_cmd()["time_tag"] == 3
    os.chown(path, 65534, 65534)
    with pytest.raises(rcomm.RcommError, match="not ours"):
        rcomm.Client(shm_name)
