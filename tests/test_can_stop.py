"""`navkit sim --link can`: however the run ends, the last message the host puts on the bus
is a stop micro_cmd (fwd_cmd stop, turn_cmd stop) that went out whole, and host.log's last
line says "stop sent". A micro_cmd is a segmented ISO-TP message, so the host waits for the
micro's flow control while it shuts down: the harness plays the bus until it has exited
(navkit.sim.playout), and the host's stop pre-empts a command still waiting for its own
(host/src/micro_link.cpp). Checked on the bus log both ways (can.log through `navkit can
dump`, run.mcap's /can reassembled with navkit.can), for a run's normal end while the robot
drives, a planner timeout, the Q key mid-run, SIGTERM to the harness, and the real-time loop. The serial
versions: test_host_harden, test_host_cli (the host), test_sim_harden (SIGTERM)."""

import json
import os
import re
import signal
import subprocess
import sys
import time

import can
import pytest

from navkit import can as nc
from navkit import protocol
from sim_helpers import can_dump, require_build, run_mission
from spec_helpers import FWD_CMD, TURN_CMD, bit

pytestmark = pytest.mark.timeout(120)

STOP = (FWD_CMD["stop"], TURN_CMD["stop"])

DRIVING = """duration_s = 3.0
[[command]]
t = 0.5
fwd_cmd = 1
speed = 300
distance = 5000
"""

SILENT = DRIVING.replace("3.0", "4.0", 1) + """[[fault]]
t = 1.5
kind = "planner_silent"
"""


def _dumped(out) -> tuple[list, int]:
    """(the messages towards the micro in `out`/can.log as `navkit can dump` decodes them, in
    order; how many it saw restarted: a message whose first frame a newer one pre-empted)."""
    r = can_dump(out / "can.log")
    found = re.search(r"host to micro: \d+ reassembled(?:, restarted (\d+))?", r.stderr)
    assert found, r.stderr[-2000:]
    restarted = int(found.group(1) or 0)
    assert r.returncode == (1 if restarted else 0), r.stderr[-2000:]
    msgs = [json.loads(ln) for ln in r.stdout.splitlines() if ln.startswith("{")]   # else "error: ..." lines
    return [m for m in msgs if m["message"] != "micro_data"], restarted


def _mcap_cmds(run) -> list:
    """The micro_cmd messages reassembled from run.mcap's /can frames towards the micro."""
    rx = nc.Receiver(protocol.DIR_TO_MICRO)
    cmds = []
    for t, m in run.messages("/can"):
        if m["direction"] != "to_micro" or m["error_frame"]:
            continue
        got = rx.feed(can.Message(arbitration_id=m["id"], data=bytes.fromhex(m["data"]), is_extended_id=False), t)
        rx.take_replies()
        if got is not None:
            name, fields = protocol.decode_frame(got.data, protocol.DIR_TO_MICRO)
            if name == "micro_cmd":
                cmds.append(fields)
    return cmds


def _ends_with_a_stop(out, run=None) -> list:
    """The last micro_cmd on the bus is a stop, newer than every command before it, and the
    host says it went out; every message it abandoned for it is one the bus saw restarted.
    Returns the messages towards the micro (navkit can dump's)."""
    msgs, restarted = _dumped(out)
    cmds = [m for m in msgs if m["message"] == "micro_cmd"]
    assert cmds and (cmds[-1]["fwd_cmd"], cmds[-1]["turn_cmd"]) == STOP, cmds[-3:]
    assert msgs[-1] is cmds[-1], "nothing after it"
    assert cmds[-1]["time_tag"] > max(c["time_tag"] for c in cmds[:-1]), "the shutdown's own stop"
    if run is not None:
        assert _mcap_cmds(run) == [{k: v for k, v in c.items() if k not in ("t", "can_id", "message")}
                                   for c in cmds], "run.mcap's /can carries the same messages"
    log = (out / "host.log").read_text()
    assert "(stop sent," in log.splitlines()[-1], log[-800:]
    assert f"{restarted} abandoned unfinished for the stop" in log, log[-1500:]
    return msgs


def test_a_run_ending_while_the_robot_drives_ends_with_a_stop_on_the_bus(tmp_path_factory):
    r = run_mission(tmp_path_factory, "can-stop-end", DRIVING, link="can")
    msgs = _ends_with_a_stop(r.out, r)
    assert any(m.get("fwd_cmd") == FWD_CMD["start"] for m in msgs), "it was driving"
    # the last command had its flow control when the host shut down: it ended whole, then
    # the stop; the bus analyser reassembled every message, none aborted
    rx = r.summary["link"]["can"]["micro_iso_tp_rx"]
    assert rx["good"] == len(msgs) and rx["restarted"] == rx["timeout"] == 0
    assert "0 abandoned unfinished for the stop" in (r.out / "host.log").read_text()


def test_a_planner_timeout_run_ends_with_a_stop_on_the_bus(tmp_path_factory):
    r = run_mission(tmp_path_factory, "can-stop-silent", SILENT, link="can")
    data = [m for t, m in r.messages("/planner/data")]
    assert data[-1]["host_status"] & bit("host_status", "planner_timeout_stop")
    _ends_with_a_stop(r.out, r)


def test_the_q_key_mid_run_ends_with_its_stop_on_the_bus(tmp_path_factory):
    """Q: the host's quitting frame sends the stop's first frame; it gets that frame's flow
    control and finishes the stop while the run goes on without it."""
    r = run_mission(tmp_path_factory, "can-stop-q", DRIVING + """[[key]]
t = 1.5
key = "Q"
""", link="can")
    msgs = _ends_with_a_stop(r.out, r)
    assert any(m.get("fwd_cmd") == FWD_CMD["start"] for m in msgs), "it was driving"
    assert "Q: quitting" in (r.out / "host.log").read_text()
    assert [m["host"] for t, m in r.messages("/host/frame")][-1] == "exited"
    h2m = r.summary["link"]["host_to_micro"]
    assert h2m["frames_received"] == h2m["frames_sent"] == len(msgs), "the stop reached the micro"


def test_the_real_time_loop_ends_with_a_stop_on_the_bus(tmp_path_factory):
    r = run_mission(tmp_path_factory, "can-stop-realtime", DRIVING.replace("3.0", "2.0", 1), link="can",
                    realtime=True)
    _ends_with_a_stop(r.out, r)


def test_sigterm_to_the_harness_ends_with_a_stop_on_the_bus(tmp_path):
    require_build()
    (tmp_path / "m.toml").write_text(DRIVING.replace("3.0", "3000.0", 1))
    out = tmp_path / "out"
    p = subprocess.Popen([sys.executable, "-m", "navkit", "sim", "--link", "can", "--no-plot", "--mission",
                          str(tmp_path / "m.toml"), "--out", str(out)], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True, start_new_session=True)
    deadline = time.monotonic() + 30
    while "micro configured" not in _text(out / "host.log"):
        assert p.poll() is None and time.monotonic() < deadline, p.communicate()
        time.sleep(0.05)
    time.sleep(1.0)                     # well into the drive (the command is at 0.5 s)
    os.kill(p.pid, signal.SIGTERM)
    _, err = p.communicate(timeout=60)
    assert p.returncode == 128 + signal.SIGTERM, err
    _ends_with_a_stop(out)


def _text(path) -> str:
    return path.read_text(errors="replace") if path.exists() else ""
