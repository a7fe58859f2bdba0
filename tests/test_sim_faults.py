"""Each fault kind end to end through the real host and the FMUs: the robot stops when the
host dies, a reset micro is configured again and stays still, line noise causes no wrong
motion, the host recovers from an unplugged port, a silent planner stops the robot."""

import pytest

from sim_helpers import run_mission
from spec_helpers import bit

pytestmark = pytest.mark.timeout(120)

T0 = 1.5
WATCHDOG_S = 0.300        # micro_cfg_motion.watchdog_timeout default
WATCHDOG_DECEL = 500.0    # micro_cfg_motion.watchdog_decel default, mm/s^2


def test_kill_host_robot_stops_within_watchdog_timeout_plus_decel(tmp_path_factory):
    r = run_mission(tmp_path_factory, "kill", f"""
duration_s = 7.0
[[command]]
t = {T0}
fwd_cmd = 1
speed = 400
distance = 5000
[[fault]]
t = 3.5
kind = "kill_host"
""")
    v0 = r.truth_at(3.5)["v_mm_s"]
    assert v0 > 350
    # the last bytes of the host may still be in flight for one frame + UART
    limit = 3.5 + 0.1 + WATCHDOG_S + v0 / WATCHDOG_DECEL + 0.15
    stopped = r.stopped_since()
    assert stopped is not None and stopped <= limit, (stopped, limit)
    coast = r.truth[-1]["distance_mm"] - r.truth_at(3.5)["distance_mm"]
    assert coast <= v0 * (0.1 + WATCHDOG_S + 0.05) + v0 ** 2 / (2 * WATCHDOG_DECEL) + 30, coast
    assert r.summary["host"]["state"] == "killed"
    assert not r.micro_between(4.0), "no host, no frames: the micro stays silent"
    frames = r.messages("/host/frame")
    assert len(frames) == r.summary["frames"] + 1 == 36, "35 ticks, then the host is gone"
    assert all(m["host"] == "running" for t, m in frames[:-1])
    assert frames[-1] == (3.5, {"frame": 35, "t": 3.5, "rx_bytes": frames[-1][1]["rx_bytes"],
                                "tx_bytes": 0, "host": "killed"})


def test_micro_reset_config_again_and_no_motion_until_a_new_command(tmp_path_factory):
    r = run_mission(tmp_path_factory, "reset", f"""
duration_s = 11.0
[[command]]
t = {T0}
fwd_cmd = 1
speed = 300
distance = 2000
[[fault]]
t = 3.0
kind = "micro_reset"
[[command]]
t = 8.0
fwd_cmd = 1
speed = 200
distance = 300
""")
    configs = [m["message"] for t, m in r.messages("/micro/config") if t > 3.0]
    assert "micro_cfg_geometry" in configs and "micro_cfg_motion" in configs \
        and "micro_cfg_io" in configs, "the host downloads the config again"
    assert r.summary["host"]["config_downloads"] >= 2
    # motors released at the reset: the robot rolls to a stop and stays there
    d_rest = r.truth_at(7.9)["distance_mm"]
    still = r.truth_between(4.5, 8.0)
    assert all(abs(m["v_mm_s"]) < 2 for m in still), "nothing moves until a new command"
    assert abs(still[0]["distance_mm"] - d_rest) < 2
    assert r.micro_between(4.5, 8.0)[-1]["status"] & bit("micro_status", "configured"), "again"
    assert abs(r.truth[-1]["distance_mm"] - (d_rest + 300)) <= 15, "the new command runs"
    # the link counts are the harness's, over the whole run: a clean line delivers every
    # frame both ways, while the micro's own counter restarted at the reset
    link = r.summary["link"]
    h2m, m2h = link["host_to_micro"], link["micro_to_host"]
    assert h2m["frames_received"] == h2m["frames_sent"] == r.summary["frames"]
    assert m2h["frames_received"] == m2h["frames_sent"] == len(r.messages("/micro/data"))
    assert link["crc_errors"] == link["resyncs"] == 0
    assert r.summary["micro"]["rx_good"] < h2m["frames_received"] - 25, "reset at 3 s of 11"


def test_line_noise_causes_no_wrong_motion(tmp_path_factory):
    r = run_mission(tmp_path_factory, "noise", f"""
duration_s = 10.0
[[fault]]
t = 1.0
kind = "line_noise"
ber = 2e-4
duration_s = 8.0
[[command]]
t = {T0}
fwd_cmd = 1
speed = 300
distance = 1500
[[command]]
t = 2.0
rc_servo_num = 1
rc_param0 = 900
rc_param1 = 450
rc_param2 = 9999
""")
    s = r.summary
    noise = s["link"]["line_noise"]
    assert noise["flips"] + noise["drops"] + noise["inserts"] > 10
    # counted by the harness from the receiving ends' parsers: frames lost each way, every
    # lost frame shows as a rejected stretch, and the totals add up
    link = s["link"]
    h2m, m2h = link["host_to_micro"], link["micro_to_host"]
    for d in (h2m, m2h):
        assert d["frames_received"] <= d["frames_sent"]
        assert d["resyncs"] >= 1 and d["dropped_bytes"] > 0
    assert h2m["frames_received"] < h2m["frames_sent"]
    assert link["crc_errors"] == h2m["crc_errors"] + m2h["crc_errors"] > 0
    assert link["resyncs"] == h2m["resyncs"] + m2h["resyncs"]
    assert m2h["frames_sent"] == len(r.messages("/micro/data"))
    assert m2h["host_link_errors"] is not None
    # no micro_reset here: the micro's own counter agrees with the harness's
    assert s["micro"]["rx_good"] == h2m["frames_received"]
    errs = (s["micro"]["rx_bad_crc"] + s["micro"]["rx_bad_length"] + s["micro"]["rx_dropped_bytes"]
            + (s["planner_data"].get("link_errors") or 0))
    assert errs > 0, "the noise was seen and rejected"
    d = [m["distance_mm"] for m in r.truth]
    assert max(d) <= 1500 + 10, "never past the target"
    assert all(b >= a - 1.0 for a, b in zip(d, d[1:])), "never backwards"
    assert all(abs(m["y_mm"]) < 15 and min(m["heading_deg"], 360 - m["heading_deg"]) < 2
               for m in r.truth), "no turn"
    assert all(abs(m["servo_deg"][k]) < 0.01 for m in r.truth for k in (0, 2, 3, 4, 5, 6, 7))
    assert all(abs(m["servo_deg"][1]) <= 45.5 for m in r.truth)
    if not s["watchdog_stops"]:
        assert abs(d[-1] - 1500) <= 15


def test_unplug_host_recovers(tmp_path_factory):
    r = run_mission(tmp_path_factory, "unplug", f"""
duration_s = 10.0
[[command]]
t = {T0}
fwd_cmd = 1
speed = 200
distance = 5000
[[fault]]
t = 3.0
kind = "unplug"
duration_s = 1.0
[[command]]
t = 6.0
fwd_cmd = 1
speed = 200
distance = 500
""")
    assert r.truth_at(3.0)["v_mm_s"] > 180
    assert all(abs(m["v_mm_s"]) < 2 for m in r.truth_between(4.0, 6.0)), "watchdog stop"
    frames = [m for t, m in r.messages("/host/frame")]
    assert any(m["flags"] & 2 for m in frames), "the host saw its port closed"
    assert not (frames[-1]["flags"] & 2), "and open again"
    assert [m["t"] for m in frames if m["host"] == "unplugged"] == \
        pytest.approx([3.0 + 0.1 * i for i in range(10)]), "unplugged from 3.0 s for 1.0 s"
    assert all(m["host"] == "running" for m in frames if not 3.0 <= m["t"] < 3.95)
    d6 = r.truth_at(6.0)["distance_mm"]
    assert abs(r.truth[-1]["distance_mm"] - (d6 + 500)) <= 15, "commands flow again"
    assert r.summary["watchdog_stops"] >= 1


def test_planner_silent_robot_stops(tmp_path_factory):
    r = run_mission(tmp_path_factory, "silent", f"""
duration_s = 8.0
[[command]]
t = {T0}
fwd_cmd = 1
speed = 250
distance = 5000
[[fault]]
t = 3.0
kind = "planner_silent"
""")
    assert r.truth_at(3.0)["v_mm_s"] > 200
    stopped = r.stopped_since()
    assert stopped is not None and stopped < 7.0, stopped
    data = [m for t, m in r.messages("/planner/data") if t > stopped]
    assert data and data[-1]["host_status"] & (1 << 3), "planner_timeout_stop"


def test_planner_silent_for_a_while_then_the_planner_resumes(tmp_path_factory):
    """A silent planner (no heartbeat, no commands) stops the robot; when it resumes, its
    next command is obeyed; a command due while silent is never written."""
    r = run_mission(tmp_path_factory, "silent-resume", f"""
duration_s = 9.0
[[command]]
t = {T0}
fwd_cmd = 1
speed = 250
distance = 5000
[[fault]]
t = 2.5
kind = "planner_silent"
duration_s = 3.0
[[command]]
t = 4.0
fwd_cmd = 1
speed = 250
distance = 3000
[[command]]
t = 6.0
fwd_cmd = 1
speed = 200
distance = 400
""")
    assert [round(t, 3) for t, m in r.messages("/planner/cmd")] == [T0, 6.0], \
        "the command at 4.0 s fell in the silence"
    kinds = [(round(t, 3), m["kind"]) for t, m in r.messages("/events")]
    assert (2.5, "planner_silent") in kinds and (5.5, "planner_resumes") in kinds
    stopped = [m for m in r.truth_between(4.5, 6.0)]
    assert all(abs(m["v_mm_s"]) < 2 for m in stopped), "planner timeout stop"
    timeout_bit = 1 << 3            # host_status planner_timeout_stop
    data = r.messages("/planner/data")
    assert any(m["host_status"] & timeout_bit for t, m in data if 4.5 <= t <= 5.5)
    assert not data[-1][1]["host_status"] & timeout_bit, "cleared once the planner is back"
    d6 = r.truth_at(6.0)["distance_mm"]
    assert abs(r.truth[-1]["distance_mm"] - (d6 + 400)) <= 15, "the resumed planner drives"
