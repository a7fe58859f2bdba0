"""navkit-host with `[micro] link = slcan`: the real binary in lockstep mode, its port a pty
whose other end is a USB-CAN adapter (navkit.can_slcan) with the micro behind it on the
CAN bus (navkit.can's ISO-TP, host_helpers' Micro for what it accepts and answers). The
link above the transport works as over serial: config download, one message per frame,
repeats keeping their time tag, micro_configured; a lost CAN frame costs one message, which
the next frame's repeat makes good; bad frames are refused and counted; the options."""

import os
import subprocess

import pytest

from navkit import can as nc
from navkit import protocol
from navkit.can_slcan import SlcanAdapter
from host_helpers import FRAME_US, Micro, RawHost, require_host
from spec_helpers import FWD_CMD, TURN_CMD, bit

pytestmark = pytest.mark.timeout(60)

CONFIGS = ["micro_cfg_geometry", "micro_cfg_motion", "micro_cfg_io"]


class CanMicro:
    """The adapter on the host's pty, and the micro behind it on the bus."""

    def __init__(self, micro: Micro | None = None):
        self.adapter = SlcanAdapter()
        self.end = nc.Endpoint("micro")
        self.micro = micro or Micro()
        self.drop = None        # drop(frame) -> True loses that frame from the host
        self.frames = []        # every CAN frame the host sent

    def step(self, h: RawHost, extra: bytes = b"") -> list:
        """One host frame; the messages the micro completed in it (name, fields)."""
        raw, _ = h.tick()
        t = h.frame * FRAME_US / 1e6
        reply, frames = self.adapter.feed(raw)
        got = []
        for f in frames:
            self.frames.append(f)
            if self.drop and self.drop(f):
                continue
            r = self.end.feed(f, t)
            if r is None:
                continue
            name, fields = protocol.decode_frame(r.data, protocol.DIR_TO_MICRO)
            got.append((name, fields))
            self.micro.handle([(name, fields)])
            self.end.send(self.micro.data(), t)  # one micro_data per message, as the firmware
        lines = b"".join(self.adapter.to_host(m) for m in self.end.poll(t))
        h.write(reply + lines + extra)
        return got

    def run(self, h: RawHost, frames: int) -> list:
        out = []
        for _ in range(frames):
            out += self.step(h)
        return out


@pytest.fixture
def can_host(host_factory):
    """host_factory's RawHost on `[micro] link = slcan` unless told another ini."""
    def make(**kw) -> RawHost:
        kw.setdefault("ini", {"NavAndControl.ini": {"link": "slcan"}})
        return host_factory(RawHost, **kw)
    return make


def test_the_host_configures_and_drives_the_micro_over_can(can_host):
    h, m = can_host(), CanMicro()
    got = m.run(h, 12)
    names = [n for n, _ in got]
    assert names[:3] == CONFIGS and "micro_cmd" in names, names
    assert all(f["spec_hash"] == protocol.SPEC_HASH for n, f in got if n in CONFIGS)
    cmds = [f for n, f in got if n == "micro_cmd"]
    assert (cmds[0]["fwd_cmd"], cmds[0]["turn_cmd"]) == (FWD_CMD["stop"], TURN_CMD["stop"]), "Navigation Init: Stop"
    assert len({f["time_tag"] for f in cmds}) == 1, "a repeated message keeps its time tag"
    assert len(cmds) >= 4, "one message a frame once the pipeline runs"
    assert h.client.read_data()["host_status"] & bit("host_status", "micro_configured")
    # the adapter was set up as SLCAN says: the spec's bit rate, open to send, nothing refused
    assert m.adapter.bitrate == nc.CAN.bitrate and m.adapter.is_open and not m.adapter.listen_only
    assert m.adapter.stats["refused"] == 0
    # every frame on the bus is a padded classic frame on the mapping's identifiers
    ids = {c.id for c in nc.CAN.ids.values()} | {c.fc_id for c in nc.CAN.ids.values()}
    assert all(f.dlc == 8 and not f.is_extended_id and f.arbitration_id in ids for f in m.frames)
    out = h.output()
    assert "SLCAN adapter, CAN at 500000 bit/s, ISO-TP" in out and "micro configured" in out, out
    assert h.client.read_data()["link_errors"] == 0


def test_a_lost_can_frame_costs_one_message_and_bad_frames_are_counted(can_host):
    h, m = can_host(), CanMicro()
    m.run(h, 12)
    assert h.client.read_data()["host_status"] & bit("host_status", "micro_configured")
    lost = []

    def drop(f):  # the third consecutive frame of the next micro_cmd
        if not lost and f.arbitration_id == nc.CAN.ids["micro_cmd"].id and f.data[0] == 0x23:
            lost.append(f)
            return True
        return False
    m.drop = drop
    before = m.end.rx.stats["good"]
    got = m.run(h, 4)
    assert lost and m.end.rx.stats["wrong_sn"] == 1
    assert [n for n, _ in got] == ["micro_cmd"] * 3, "three of four arrive; the next repeat makes it good"
    assert m.end.rx.stats["good"] == before + 3
    assert h.client.read_data()["host_status"] & bit("host_status", "micro_configured"), "still configured: nothing above the link noticed"
    # frames from the bus the host refuses (a short frame on micro_data's identifier, a line
    # that is no frame), counted in link_errors and said on the console
    m.step(h, extra=b"t180140\r" + b"t18G\r")
    m.step(h)
    assert h.client.read_data()["link_errors"] >= 2
    out = h.output()
    assert "micro link:" in out and "CAN 2 (since the port opened: ISO-TP refused 1 frames" in out, out
    assert "1 adapter lines no frame" in out, out


def test_link_and_bit_rate_options(tmp_path):
    """--link, [micro] link and can_bitrate: bad values are refused naming where."""
    host = str(require_host())
    r = subprocess.run([host, "--link", "can"], capture_output=True, text=True, timeout=20)
    assert r.returncode == 2 and "--link: 'can' is not serial or slcan" in r.stderr, r.stderr
    r = subprocess.run([host, "--help"], capture_output=True, text=True, timeout=20)
    assert "--link serial|slcan" in r.stdout
    from navkit.paths import repo_root
    for text, said in (("[micro]\nlink = can\n", "link: 'can' is not serial or slcan"),
                       ("[micro]\ncan_bitrate = 400000\n", "can_bitrate: 400000 is not a bit rate an SLCAN adapter "
                                                           "sets (10000, 20000, 50000")):
        (tmp_path / "sensors.ini").write_text((repo_root() / "config/sensors.ini").read_text())
        (tmp_path / "NavAndControl.ini").write_text("; comment\n" + text)
        r = subprocess.run([host, "--config", str(tmp_path), "--port", "/nonexistent", "--shm",
                            f"/nk-can-{os.getpid()}"], capture_output=True, text=True, timeout=20)
        assert r.returncode == 1 and f"{tmp_path}/NavAndControl.ini:3: " in r.stderr and said in r.stderr, r.stderr


def test_the_link_option_overrides_the_ini(can_host):
    h, m = can_host(ini={}, args=("--link", "slcan")), CanMicro()
    got = m.run(h, 12)
    assert [n for n, _ in got][:3] == CONFIGS


def test_the_stop_at_shutdown_goes_out_whole(can_host):
    """Outside the frame loop the host waits for the flow control of its last stop, so the
    micro gets it whole before the host ends."""
    import select
    import signal
    import threading
    import time

    h, m = can_host(), CanMicro()
    m.run(h, 12)
    got, stop = [], threading.Event()

    def serve():
        while not stop.is_set():
            ready, _, _ = select.select([h.master], [], [], 0.01)
            if not ready:
                continue
            try:
                data = os.read(h.master, 4096)
            except (BlockingIOError, OSError):
                continue
            now = time.monotonic()
            reply, frames = m.adapter.feed(data)
            for f in frames:
                r = m.end.feed(f, now)
                if r is not None:
                    got.append(protocol.decode_frame(r.data)[1])
            os.write(h.master, reply + b"".join(m.adapter.to_host(x) for x in m.end.poll(now)))
    th = threading.Thread(target=serve, daemon=True)
    th.start()
    try:
        rc = h.stop(signal.SIGTERM)
    finally:
        stop.set()
        th.join(2)
    assert rc == 0, h.output()
    assert got and got[-1]["fwd_cmd"] == FWD_CMD["stop"] and got[-1]["turn_cmd"] == TURN_CMD["stop"], got
