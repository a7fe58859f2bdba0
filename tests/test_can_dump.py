"""`navkit can dump`: CAN logs written by python-can's own writers, and an SLCAN adapter
on a pty (the ASCII protocol, python-can's slcan interface on the tool's side), decoded with
the spec; refused frames and aborted messages as error lines naming the frame; bad options
and files as one-line errors."""

import json
import os
import pty
import select
import subprocess
import sys
import threading
import time
import tty

import can
import pytest

from navkit import can as nc
from navkit import protocol as p
from navkit.can_slcan import SlcanAdapter

NAVKIT = [sys.executable, "-m", "navkit", "can", "dump"]


def _traffic(drop_cf_of: int | None = None) -> list[can.Message]:
    """The frames of a host and a micro exchanging three micro_cmd / micro_data pairs
    (flow controls included), 1 ms steps; the consecutive frame 0x23 of the micro_cmd with
    time tag `drop_cf_of` is lost. Each micro_data reports the micro's ISO-TP receiver
    counters in its can_rx_* fields, as the firmware's CAN build does."""
    host, micro = nc.Endpoint("host"), nc.Endpoint("micro")
    frames, t = [], 100.0
    for k in range(3):
        host.send(p.encode_frame("micro_cmd", {"fwd_cmd": 1, "speed": 200 + k}, time_tag=k), t)
        for _ in range(60):
            for m in host.poll(t):
                if k == drop_cf_of and m.arbitration_id == 0x110 and m.data[0] == 0x23:
                    continue
                frames.append(m)
                if micro.feed(m, t):
                    own = {f"can_rx_{n}": v for n, v in micro.rx.stats.items() if n != "good"}
                    micro.send(p.encode_frame("micro_data", {"ack_time_tag": k, **own}, time_tag=k), t)
            for m in micro.poll(t):
                frames.append(m)
                host.feed(m, t)
            t += 0.001
    return frames


def _write(path, frames):
    with can.Logger(str(path)) as log:
        for m in frames:
            log.on_message_received(m)


def _lines(out: str):
    return [json.loads(ln) for ln in out.splitlines() if ln.startswith("{")], \
           [ln for ln in out.splitlines() if ln.startswith("error:")]


@pytest.mark.parametrize("suffix", [".log", ".asc"])
def test_a_log_decodes_to_the_kits_messages(tmp_path, suffix):
    path = tmp_path / f"bus{suffix}"
    _write(path, _traffic())
    r = subprocess.run(NAVKIT + ["--file", str(path)], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    msgs, errors = _lines(r.stdout)
    assert errors == []
    assert [(m["message"], m["time_tag"]) for m in msgs] == [
        ("micro_cmd", 0), ("micro_data", 0), ("micro_cmd", 1), ("micro_data", 1), ("micro_cmd", 2), ("micro_data", 2)]
    assert msgs[2]["speed"] == 201 and msgs[3]["ack_time_tag"] == 1 and msgs[1]["can_id"] == "0x180"
    assert "host to micro: 3 reassembled; micro to host: 3 reassembled" in r.stderr
    assert "the micro's own (its last micro_data): all 0" in r.stderr


def test_loss_and_bad_frames_are_error_lines_naming_the_frame(tmp_path):
    frames = _traffic(drop_cf_of=1)
    bad_crc = bytearray(p.encode_frame("micro_cmd", {}, time_tag=9))
    bad_crc[-1] ^= 0xFF
    t = frames[-1].timestamp + 1.0
    extra = nc.segment(0x110, bytes(bad_crc)) + [nc.frame(0x110, bytes([0x40])),
                                                  nc.frame(0x110, bytes([0x03, 0xA5, 0xFF, 0x01]))]
    for m in extra:
        m.timestamp = t
    frames += extra
    path = tmp_path / "bus.log"
    _write(path, frames)
    r = subprocess.run(NAVKIT + ["--file", str(path)], capture_output=True, text=True, timeout=60)
    assert r.returncode == 1
    msgs, errors = _lines(r.stdout)
    # the command with the lost frame is gone (and so is its reply); the others pass
    assert [(m["message"], m["time_tag"]) for m in msgs] == [
        ("micro_cmd", 0), ("micro_data", 0), ("micro_cmd", 2), ("micro_data", 2)]
    first = [e for e in errors if "out of sequence" in e]
    assert len(first) == 1 and "id 0x110" in first[0]
    n = int(first[0].split("frame ")[1].split(" ")[0])
    assert bytes.fromhex(path.read_text().splitlines()[n].split("#")[1].split()[0])[0] == 0x24  # the frame after the gap
    assert any("frame ignored: consecutive frame with no message in progress" in e for e in errors)
    assert any("micro_cmd: 116 of its 116 bytes rejected: bad CRC" in e for e in errors)
    assert any("frame refused: not a well-formed ISO-TP frame" in e for e in errors)
    assert any("micro_cmd: 3 of its 3 bytes rejected" in e for e in errors)
    assert "wrong_sn 1" in r.stderr and "bad_frame 1" in r.stderr
    # what the micro itself counted (a micro_cmd is a first frame + 16 consecutive: the
    # lost 0x23 aborts it at 0x24, the 12 after are ignored), from its last micro_data
    assert "the micro's own (its last micro_data): rx_wrong_sn 1, rx_unexpected 12" in r.stderr, r.stderr


@pytest.mark.parametrize("argv,status,text", [
    ([], 2, "give the traffic: --file LOG, --port PATH or --interface NAME --channel CH"),
    (["--file", "x.log", "--port", "/dev/null"], 2, "give one of --file, --port or --interface, not --file and --port"),
    (["--interface", "socketcan"], 2, "--interface and --channel go together"),
    (["--file", "x.log", "--bitrate", "250000"], 2, "--bitrate applies only to --port"),
    (["--file", "x.log", "--seconds", "1"], 2, "--seconds applies only to live listening"),
    (["--file", "{tmp}/missing.log"], 1, "missing.log: No such file or directory"),
    (["--file", "{tmp}/bus.xyz"], 1, "bus.xyz: "),
    (["--port", "{tmp}/no-such-port"], 1, "no-such-port: cannot open"),
    (["--count", "0", "--file", "x.log"], 2, "must be above 0"),
])
def test_bad_options_and_files_are_one_line(tmp_path, argv, status, text):
    (tmp_path / "bus.xyz").write_text("x")
    argv = [a.replace("{tmp}", str(tmp_path)) for a in argv]
    r = subprocess.run(NAVKIT + argv, capture_output=True, text=True, timeout=60)
    assert r.returncode == status, r.stderr
    assert text in r.stderr and "Traceback" not in r.stderr, r.stderr


def test_an_slcan_adapter_on_a_pty(tmp_path):
    """The tool opens the adapter with python-can's slcan interface (bit rate, listen-only);
    navkit.can_slcan's adapter on the pty's other side answers it and sends the frames."""
    master, slave = pty.openpty()
    tty.setraw(slave)
    port = os.ttyname(slave)
    frames = _traffic()
    adapter = SlcanAdapter()
    stop = threading.Event()
    modes = []  # listen_only of the channel when the frames went out

    def serve():
        sent = False
        while not stop.is_set():
            try:
                ready, _, _ = select.select([master], [], [], 0.05)
                if ready:
                    reply, _ = adapter.feed(os.read(master, 256))
                    os.write(master, reply)
                if adapter.is_open and not sent:
                    time.sleep(0.2)  # python-can opens twice: let it settle
                    modes.append(adapter.listen_only)
                    for m in frames:
                        os.write(master, adapter.to_host(m))
                    sent = True
            except OSError:
                return
    th = threading.Thread(target=serve, daemon=True)
    th.start()
    try:
        r = subprocess.run(NAVKIT + ["--port", port, "--count", "6", "--seconds", "20"], capture_output=True,
                           text=True, timeout=60)
    finally:
        stop.set()
        th.join(2)
        os.close(master)
        os.close(slave)
    assert r.returncode == 0, r.stderr
    msgs, errors = _lines(r.stdout)
    assert errors == [] and [m["time_tag"] for m in msgs] == [0, 0, 1, 1, 2, 2]
    # the spec's bit rate, listen-only (a listener never sends: nothing was refused either)
    assert adapter.bitrate == nc.CAN.bitrate and modes == [True] and adapter.stats["refused"] == 0
    assert not adapter.is_open  # closed at the end ("C")


def test_any_python_can_interface_live(capsys):
    """--interface NAME --channel CH: python-can's own buses (here its in-process virtual
    one, as socketcan's can0 would be), frames sent while the tool listens."""
    from navkit.cli import main

    frames = _traffic()
    sender = can.Bus(interface="virtual", channel="nk-dump-test")
    stop = threading.Event()

    def send():
        time.sleep(0.3)
        for m in frames:
            if stop.is_set():
                return
            sender.send(m)
    th = threading.Thread(target=send, daemon=True)
    th.start()
    try:
        rc = main(["can", "dump", "--interface", "virtual", "--channel", "nk-dump-test", "--count", "6",
                   "--seconds", "20"])
    finally:
        stop.set()
        th.join(5)
        sender.shutdown()
    out = capsys.readouterr()
    assert rc == 0, out.err
    msgs, errors = _lines(out.out)
    assert errors == [] and [(m["message"], m["time_tag"]) for m in msgs][:2] == [("micro_cmd", 0), ("micro_data", 0)]
    assert len(msgs) == 6 and "6 messages" in out.err
