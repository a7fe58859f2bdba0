"""navkit-host's micro link and planner link, end to end through the real binary in
lockstep mode: config download at start and after a micro reset, one message per frame,
repeats keep their time tag, only the newest micro_data is used, garbage is survived,
the port vanishes and returns, a micro of another spec is refused, planner commands
reach the wire in the frame that reads them, a silent planner stops the robot, DIO
masks, console teleop only while the planner is quiet (but its stop key always wins),
the battery safety stop, a refused config."""

import os
import signal

import pytest

from navkit import protocol
from host_helpers import Micro
from spec_helpers import FWD_CMD, NAV_RESULT, TURN_CMD, bit

pytestmark = pytest.mark.timeout(60)

CONFIGS = ["micro_cfg_geometry", "micro_cfg_motion", "micro_cfg_io"]


def test_config_download_at_start_then_one_command_per_frame(host_factory):
    h, m = host_factory(), Micro()
    sent = h.configure(m)
    assert [n for n, _ in sent] == CONFIGS + ["micro_cmd"], "config in order, then the command"
    assert sent[0][1]["spec_hash"] == protocol.SPEC_HASH
    cmd = sent[-1][1]
    assert (cmd["fwd_cmd"], cmd["turn_cmd"]) == (FWD_CMD["stop"], TURN_CMD["stop"]), \
        "Navigation Init: the current command is Stop"
    tags = set()
    for _ in range(5):
        msgs, flags = h.step(m)
        assert len(msgs) == 1 and msgs[0][0] == "micro_cmd" and flags == 0
        tags.add(msgs[0][1]["time_tag"])
    assert tags == {cmd["time_tag"]}, "a repeated message keeps its time tag"


def test_restarted_host_downloads_its_config_to_a_configured_micro(host_factory):
    """A host restart without a micro reset: the micro still says configured (another
    host's config), and still gets all three of ours before the first command."""
    h = host_factory(ini={"NavAndControl.ini": {"wheel_diameter": 12000, "wheel_kp": 500,
                                                "servo_max": 800}})
    m = Micro()
    m.cfg.update(CONFIGS)
    sent = h.configure(m)
    assert [n for n, _ in sent] == CONFIGS + ["micro_cmd"], "the whole config, then the command"
    got = dict(sent[:3])
    assert got["micro_cfg_geometry"]["wheel_diameter"] == 12000
    assert got["micro_cfg_motion"]["wheel_kp"] == 500
    assert got["micro_cfg_io"]["servo_max"] == [800] * 8
    assert h.client.read_data()["host_status"] & bit("host_status", "micro_configured"), "once ours is in force"


def test_a_refused_config_is_said_and_never_taken_for_configured(host_factory):
    """A micro configured by someone else refuses our micro_cfg_io: it keeps saying
    configured, but our config is not in force, so it is never driven; the console names
    the refused message, warns after rounds without our config, and the status line says
    unconfigured."""
    h, m = host_factory(), Micro()
    m.cfg.update(CONFIGS)
    m.refuse.add("micro_cfg_io")
    sent = []
    for _ in range(30):                                     # 3 s
        sent += h.step(m)[0]
    names = [n for n, _ in sent]
    assert "micro_cmd" not in names, "never driven with another config"
    assert names[:6] == CONFIGS * 2, "a refusal sends the whole config again"
    assert not h.client.read_data()["host_status"] & bit("host_status", "micro_configured"), "it stays off"
    out = h.output()
    assert "micro refused micro_cfg_io (last_reject 0x8004" in out, out
    assert out.count("micro refused micro_cfg_io") == 1, "said again at most every 5 s (3 s here)"
    assert "micro not configured after 5 rounds of config messages (it refuses micro_cfg_io)" in out, out
    assert "micro online unconfigured" in out, "the status line"
    m.refuse.clear()                                        # the micro takes it now
    again = h.configure(m)
    assert again[-1][0] == "micro_cmd" and "micro configured" in h.output()


def test_config_values_come_from_the_ini(host_factory):
    h, m = host_factory(ini={"NavAndControl.ini": {"wheel_diameter": 12000}}), Micro()
    geo = dict(h.configure(m)[:3])["micro_cfg_geometry"]
    assert geo["wheel_diameter"] == 12000
    assert geo["counts_per_rev"] == protocol.defaults("micro_cfg_geometry")["counts_per_rev"]


def test_micro_reset_config_again_and_no_old_command_rerun(host_factory):
    h, m = host_factory(), Micro()
    h.configure(m)
    h.client.write_cmd({"time_tag": 10, "fwd_cmd": 1, "speed": 300, "distance": 2000})
    msgs, _ = h.step(m)
    go = msgs[0][1]
    assert go["fwd_cmd"] == FWD_CMD["start"] and go["speed"] == 300
    m.reset()
    h.step(m)                      # the host learns of the reset from this frame's reply
    again = h.configure(m)
    assert [n for n, _ in again[:3]] == CONFIGS, "the config is downloaded again"
    after = again[-1][1]
    assert after["time_tag"] != go["time_tag"], "a new time tag after the reset"
    assert after["fwd_cmd"] == FWD_CMD["stop"], "the old start is not run again by the reset micro"
    assert "micro reset" in h.output()


def test_planner_command_reaches_the_wire_in_the_next_frame(host_factory):
    h, m = host_factory(), Micro()
    first = h.configure(m)[-1][1]
    h.client.write_cmd({"time_tag": 1234, "fwd_cmd": 1, "accel": 400, "speed": 250,
                        "distance": 1500, "turn_mode": 1, "turn_rate": 300, "turn_distance": -450,
                        "rc_servo_num": 2, "rc_param0": 1000, "rc_param1": 300, "rc_param2": 9999,
                        "dio_active": 0b1001, "dio_command": 0b0001})
    msgs, _ = h.step(m)
    assert len(msgs) == 1
    c = msgs[0][1]
    assert c["time_tag"] == (first["time_tag"] + 1) & 0xFFFF
    assert (c["fwd_cmd"], c["accel"], c["speed"], c["distance"]) == (1, 400, 250, 1500)
    assert (c["turn_cmd"], c["turn_rate"], c["turn_distance"]) == (1, 300, -450)
    assert (c["rc2_param0"], c["rc2_param1"], c["rc2_param2"]) == (1000, 300, 9999)
    assert c["rc0_param0"] == 0 and c["dio_command"] == 0b0001
    again, _ = h.step(m)
    assert again[0][1] == c, "repeated unchanged, same time tag"
    data = h.client.read_data()
    assert data["ack_time_tag"] == 1234 and data["nav_result"] == NAV_RESULT["ok"]


def test_heading_hold_and_high_level_codes(host_factory):
    h, m = host_factory(), Micro()
    m.fields["heading"] = 3500
    h.configure(m)
    h.client.write_cmd({"time_tag": 5, "turn_mode": 11, "turn_rate": 200, "turn_distance": 300})
    c = h.step(m)[0][0][1]
    assert c["turn_cmd"] == TURN_CMD["hdg_sel"] and c["turn_distance"] == 200, "3500 + 300 wraps to 200"
    h.client.write_cmd({"time_tag": 6, "fwd_cmd": 105})
    c = h.step(m)[0][0][1]
    assert c["fwd_cmd"] == FWD_CMD["none"]
    h.step(m)
    assert h.client.read_data()["nav_result"] == NAV_RESULT["not_implemented"]
    assert "not implemented" in h.output()
    h.client.write_cmd({"time_tag": 7, "fwd_cmd": 2})
    h.step(m)
    h.step(m)
    assert h.client.read_data()["nav_result"] == NAV_RESULT["rejected"]


def test_only_the_newest_of_several_micro_data_is_used(host_factory):
    h, m = host_factory(), Micro()
    h.configure(m)
    h.write(m.data(distance=111) + m.data(distance=222) + m.data(distance=333))
    h.step(m, reply=False)
    assert h.client.read_data()["distance"] == 333
    assert h.stop() == 0
    superseded = int(h.output().split(" micro_data superseded")[0].rsplit(" ", 1)[1])
    assert superseded == 3, "the reply to the last configure frame and two of the three"


def test_garbage_on_the_line_is_survived(host_factory):
    h, m = host_factory(), Micro()
    h.configure(m)
    bad = bytearray(m.data(distance=7))
    bad[20] ^= 0xFF                                   # a CRC error
    h.write(bytes(range(256)) + b"\xa5\xff\x00" + bytes(bad) + os.urandom(300) + m.data(distance=42))
    msgs, flags = h.step(m, reply=False)
    assert len(msgs) == 1 and msgs[0][0] == "micro_cmd" and flags == 0
    d = h.client.read_data()
    assert d["distance"] == 42 and d["link_errors"] >= 1
    assert "bad CRC at stream byte offset" in h.output()
    for _ in range(3):
        assert len(h.step(m)[0]) == 1


def test_port_vanishes_and_returns(host_factory):
    h, m = host_factory(), Micro()
    cmd = h.configure(m)[-1][1]
    h.unplug()
    msgs, flags = h.tick()
    assert msgs == [] and flags & 2, "the host sees the port closed"
    msgs, flags = h.tick()
    assert msgs == [] and flags & 2
    assert h.client.read_data()["host_status"] & (1 << 6), "port_lost"
    h.plug()
    again = h.configure(m)
    assert [n for n, _ in again] == CONFIGS + ["micro_cmd"], "reopened: our config goes again"
    assert again[-1][1]["time_tag"] == cmd["time_tag"], "the micro kept its tags: the command repeats"
    out = h.output()
    assert "lost" in out and out.count("open (") >= 2


def test_spec_hash_mismatch_is_refused(host_factory):
    h = host_factory()
    m = Micro(spec_hash=0xDEADBEEF)
    m.cfg.update(CONFIGS)                 # claims to be configured
    sent = []
    for _ in range(8):
        sent += h.step(m)[0]
    assert sent and all(n != "micro_cmd" for n, _ in sent), "never a command"
    assert "0xDEADBEEF" in h.output() and f"0x{protocol.SPEC_HASH:08X}" in h.output()
    assert h.client.read_data()["host_status"] & (1 << 2)


def test_micro_of_another_spec_length_is_refused_naming_its_hash(host_factory):
    """A micro built from another spec whose micro_data is longer: the parser cannot
    decode it, but its frozen words 4-5 name the micro's spec; the host never drives it."""
    h = host_factory()
    m = Micro()
    words = len(Micro().data()) // 2 + 6
    sent = []
    for k in range(8):
        msgs, _ = h.tick()
        sent += msgs
        h.write(protocol.foreign_frame("micro_data", words, 0xC0FFEE11, time_tag=k))
    assert sent and all(n != "micro_cmd" for n, _ in sent), "never a command"
    out = h.output()
    assert "0xC0FFEE11" in out and f"0x{protocol.SPEC_HASH:08X}" in out
    assert h.client.read_data()["host_status"] & (1 << 2)
    # reflashed with our spec: configured, then driven (from a stop)
    h.configure(m)
    assert "matches the host's" in h.output()


def test_silent_planner_stops_the_robot_then_obeys_again(host_factory):
    h, m = host_factory(), Micro()
    h.configure(m)
    h.client.write_cmd({"time_tag": 1, "fwd_cmd": 1, "speed": 200, "distance": 5000})
    go = h.step(m)[0][0][1]
    stop = None
    for _ in range(15):                    # 1.5 s of silence, planner_timeout = 1 s
        c = h.step(m)[0][0][1]
        if c["time_tag"] != go["time_tag"]:
            stop = c
            break
    assert stop is not None and stop["fwd_cmd"] == FWD_CMD["stop"] and stop["turn_cmd"] == TURN_CMD["stop"]
    assert h.client.read_data()["host_status"] & (1 << 3)
    assert "planner silent" in h.output()
    h.client.write_cmd({"time_tag": 2, "fwd_cmd": 1, "speed": 100, "distance": 100})
    c = h.step(m)[0][0][1]
    assert c["fwd_cmd"] == FWD_CMD["start"] and c["speed"] == 100
    assert not h.client.read_data()["host_status"] & (1 << 3)


def test_dio_masks(host_factory):
    h, m = host_factory(), Micro()
    h.configure(m)
    h.client.write_cmd({"time_tag": 1, "dio_active": 0b1001, "dio_command": 0b0001})
    assert h.step(m)[0][0][1]["dio_command"] == 0b0001
    h.proc.stdin.write(b"4")                   # the console sets bit 3 (planner-owned: no effect)
    h.proc.stdin.write(b"3")                   # and bit 2 (free: taken)
    h.proc.stdin.flush()
    assert h.step(m)[0][0][1]["dio_command"] == 0b0101
    h.client.write_cmd({"time_tag": 2, "dio_active": 0, "dio_command": 0})
    assert h.step(m)[0][0][1]["dio_command"] == 0b1100, "released bits fall to the console's levels"


def test_sigterm_stops_the_robot_and_exits_cleanly(host_factory):
    h, m = host_factory(), Micro()
    h.configure(m)
    h.client.write_cmd({"time_tag": 1, "fwd_cmd": 1, "speed": 200, "distance": 5000})
    h.step(m)
    assert h.stop(signal.SIGTERM) == 0
    tail = h.decode(h.read_available(wait_s=1.0))
    assert tail and tail[-1][0] == "micro_cmd" and tail[-1][1]["fwd_cmd"] == FWD_CMD["stop"]
    assert not os.path.exists("/dev/shm" + h.shm), "rcomm region removed"


def test_eof_on_the_lockstep_socket_is_a_clean_shutdown(host_factory):
    h, m = host_factory(), Micro()
    h.configure(m)
    assert h.stop() == 0
    assert not os.path.exists("/dev/shm" + h.shm)


def test_console_teleop_only_while_the_planner_is_quiet(host_factory):
    h, m = host_factory(ini={"NavAndControl.ini": {"console_idle": 1.0, "teleop_speed": 150}}), Micro()
    h.configure(m)
    h.proc.stdin.write(b"w")
    h.proc.stdin.flush()
    c = h.step(m)[0][0][1]
    assert (c["fwd_cmd"], c["speed"], c["distance"]) == (1, 150, 2000000000), "no planner yet"
    h.client.write_cmd({"time_tag": 1, "fwd_cmd": 5})
    assert h.step(m)[0][0][1]["fwd_cmd"] == FWD_CMD["stop"]
    h.proc.stdin.write(b"a")
    h.proc.stdin.flush()
    assert h.step(m)[0][0][1]["turn_cmd"] == TURN_CMD["none"], "the planner has priority"
    for _ in range(10):
        h.client.heartbeat()
        h.step(m)
    h.proc.stdin.write(b"a")
    h.proc.stdin.flush()
    c = h.step(m)[0][0][1]
    assert c["turn_cmd"] == TURN_CMD["turn"] and c["turn_distance"] < 0, "1 s after the planner's last command"


def test_console_stop_key_wins_over_a_driving_planner(host_factory):
    h, m = host_factory(), Micro()
    h.configure(m)
    h.client.write_cmd({"time_tag": 1, "fwd_cmd": 1, "speed": 200, "distance": 5000})
    go = h.step(m)[0][0][1]
    assert go["fwd_cmd"] == FWD_CMD["start"]
    h.proc.stdin.write(b" ")
    h.proc.stdin.flush()
    stop = h.step(m)[0][0][1]
    assert (stop["fwd_cmd"], stop["turn_cmd"]) == (FWD_CMD["stop"], TURN_CMD["stop"])
    assert stop["time_tag"] != go["time_tag"], \
        "space stops the robot while the planner drives"
    h.client.heartbeat()
    assert h.step(m)[0][0][1] == stop, "the planner's old command is not run again"
    h.proc.stdin.write(b"w")
    h.proc.stdin.flush()
    assert h.step(m)[0][0][1] == stop, "other teleop keys: the planner has priority"
    h.proc.stdin.write(b"d")
    h.proc.stdin.flush()
    h.step(m)
    out = h.output()
    assert out.count("key ignored: planner has priority") == 1, "said once, at most once a second"
    h.client.write_cmd({"time_tag": 2, "fwd_cmd": 1, "speed": 100, "distance": 100})
    c = h.step(m)[0][0][1]
    assert c["fwd_cmd"] == FWD_CMD["start"] and c["speed"] == 100, "the planner's next new command is obeyed"


def test_safety_stop_on_low_battery(host_factory):
    h, m = host_factory(ini={"NavAndControl.ini": {"battery_min_v": 11.0, "planner_timeout": 0}}), Micro()
    full, low = round(12.0 / 3 / 5 * 1023), round(10.0 / 3 / 5 * 1023)
    m.fields["adc"] = [0, 0, 0, 0, full, 0, 0, 0]
    h.configure(m)
    h.client.write_cmd({"time_tag": 1, "fwd_cmd": 1, "speed": 200, "distance": 5000})
    assert h.step(m)[0][0][1]["fwd_cmd"] == FWD_CMD["start"]
    m.fields["adc"] = [0, 0, 0, 0, low, 0, 0, 0]
    h.step(m)                                   # the host reads the low battery in the next frame
    c = h.step(m)[0][0][1]
    assert c["fwd_cmd"] == FWD_CMD["stop"] and "safety stop" in h.output()
    h.client.write_cmd({"time_tag": 2, "fwd_cmd": 1, "speed": 200, "distance": 5000})
    assert h.step(m)[0][0][1]["time_tag"] == c["time_tag"], "motion ignored while it holds"
    assert 9900 <= h.client.read_data()["battery"] <= 10100, "mV"
    m.fields["adc"] = [0, 0, 0, 0, full, 0, 0, 0]
    h.step(m)
    h.step(m)
    h.client.write_cmd({"time_tag": 3, "fwd_cmd": 1, "speed": 100, "distance": 100})
    assert h.step(m)[0][0][1]["speed"] == 100, "cleared: the next new command runs"


def test_spec_mismatch_gets_only_a_probe_a_second_and_recovers_when_reflashed(host_factory):
    h = host_factory()
    m = Micro(spec_hash=0xDEADBEEF)
    m.cfg.update(CONFIGS)
    per_frame = [h.step(m)[0] for _ in range(25)]            # 2.5 s
    sent = [msg for msgs in per_frame[1:] for msg in msgs]   # after the first reply
    assert all(n == "micro_cfg_geometry" for n, _ in sent), "never a command, no config stream"
    assert 2 <= len(sent) <= 3, f"one probe a second, not one a frame: {len(sent)} in 2.4 s"
    assert h.output().count("0xDEADBEEF differs") >= 2, "both hashes said again every second"
    assert f"0x{protocol.SPEC_HASH:08X}" in h.output()
    # the micro is reflashed with our spec (it answers the next probe, unconfigured)
    m.spec_hash = protocol.SPEC_HASH
    m.reset()
    for _ in range(12):
        msgs, _ = h.step(m)
        if msgs and msgs[-1][0] == "micro_cmd":
            break
    assert msgs and msgs[-1][0] == "micro_cmd", "configured and driven after the reflash"
    assert msgs[-1][1]["fwd_cmd"] == FWD_CMD["stop"], "starting from a stop"
    assert "matches the host's" in h.output()
    assert not h.client.read_data()["host_status"] & (1 << 2)


def test_heading_hold_before_any_micro_data_is_rejected(host_factory):
    h, m = host_factory(), Micro()
    h.client.write_cmd({"time_tag": 5, "turn_mode": 11, "turn_rate": 200, "turn_distance": 300})
    msgs, _ = h.step(m, reply=False)
    assert all(n != "micro_cmd" for n, _ in msgs)
    h.step(m, reply=False)
    assert h.client.read_data()["nav_result"] == NAV_RESULT["rejected"]
    assert "heading hold (turn mode 11) needs the micro's current heading" in h.output()
    m.fields["heading"] = 1000
    h.configure(m)
    h.client.write_cmd({"time_tag": 6, "turn_mode": 11, "turn_rate": 200, "turn_distance": 300})
    c = h.step(m)[0][0][1]
    assert c["turn_cmd"] == TURN_CMD["hdg_sel"] and c["turn_distance"] == 1300, "with fresh data it holds"


def test_link_counters_are_kept_apart(host_factory):
    h, m = host_factory(), Micro()
    h.configure(m)
    bad = bytearray(m.data(distance=7))
    bad[20] ^= 0xFF                                   # a CRC error
    h.write(b"\x00\x01\x02" + bytes(bad) + m.data(heading=3600) + m.data(distance=42, rx_bad_length=4))
    h.step(m, reply=False)
    d = h.client.read_data()
    assert d["distance"] == 42
    assert d["link_errors"] == 2, "lisp_data.link_errors: the sum of rejected frames (CRC + decode)"
    assert h.stop() == 0
    out = h.output()
    assert "1 bad CRC, 0 unknown type, 0 bad length, 0 of another spec, 1 decode failures" in out, out
    assert "micro's receive counters (its last micro_data): 0 good, 0 bad CRC, 0 unknown type, " \
        "4 bad length" in out, "the micro's own counters, each apart"
    dropped = int(out.split(" bytes dropped")[0].rsplit(" ", 1)[1])
    assert dropped >= 3 + len(bad)
