"""navkit.can_gateway between the real navkit-host (lockstep, `[micro] link = slcan`) and a
micro that speaks the serial link (host_helpers' Micro, as the firmware FMU does): the
host configures and drives it over the simulated CAN bus, every frame on the bus lands in
a candump log written by python-can's Logger, and `navkit can dump` decodes that log."""

import json

import can
import pytest

from navkit import protocol
from navkit.can_gateway import CanGateway
from host_helpers import FRAME_US, Host, Micro, RawHost
from sim_helpers import can_dump
from spec_helpers import bit

pytestmark = pytest.mark.timeout(60)


def test_host_and_a_serial_micro_through_the_gateway(tmp_path):
    (tmp_path / "h").mkdir()
    h = RawHost(tmp_path / "h", ini={"NavAndControl.ini": {"link": "slcan"}})
    log = tmp_path / "bus.log"
    writer = can.Logger(str(log))
    gw, m = CanGateway(listener=writer), Micro()
    got = []
    try:
        for _ in range(15):
            raw, _ = h.tick()
            t = h.frame * FRAME_US / 1e6
            back, serial = gw.from_host(raw, t)
            msgs = Host.decode(serial) if serial else []
            m.handle(msgs)
            got += msgs
            replies = b"".join(m.data() for _ in msgs)  # one micro_data per message, as the firmware
            h.write(back + gw.from_micro(replies, t))
        assert h.client.read_data()["host_status"] & bit("host_status", "micro_configured"), h.output()
    finally:
        writer.stop()
        h.close()
    names = [n for n, _ in got]
    assert names[:3] == ["micro_cfg_geometry", "micro_cfg_motion", "micro_cfg_io"] and "micro_cmd" in names
    assert gw.adapter.stats["refused"] == 0 and gw.frames > 100
    # the bus log: navkit can dump finds the same messages, both ways, nothing refused
    r = can_dump(log)
    assert r.returncode == 0, r.stdout + r.stderr
    dumped = [json.loads(ln) for ln in r.stdout.splitlines()]
    to_micro = [d["message"] for d in dumped if d["message"] != "micro_data"]
    assert to_micro == names
    data = [d for d in dumped if d["message"] == "micro_data"]
    assert data and all(d["spec_hash"] == protocol.SPEC_HASH for d in data)
