"""Every firmware motion rule end to end: the planner's lisp_cmd through the real host, the
pty and the firmware FMU, checked on the plant FMU's ground truth (mm, deg, mm/s).

Each test runs one short lockstep mission (a few simulated seconds, well under a second of
wall time each at hundreds of times real time). Commands start at t = 1.5 s, after the
config download and the gyro's standstill calibration.
"""

import pytest

from sim_helpers import run_mission

pytestmark = pytest.mark.timeout(120)

T0 = 1.5            # s: first command
LATENCY = 0.35      # s: host frame + UART + control tick, generous


def _peak(rows, key="v_mm_s"):
    return max(m[key] for m in rows)


def test_forward_move_peak_speed_stop_point_and_time(tmp_path_factory):
    r = run_mission(tmp_path_factory, "fwd", f"""
duration_s = 8.0
[[command]]
t = {T0}
fwd_cmd = 1
accel = 300
speed = 300
distance = 1000
""")
    peak = _peak(r.truth)
    assert 285 <= peak <= 315, peak
    end = r.truth[-1]
    assert abs(end["distance_mm"] - 1000) <= 15, end
    assert abs(end["x_mm"] - 1000) <= 20 and abs(end["y_mm"]) <= 20, end
    # trapezoid: 1 s up, 1 s down, 700 mm at 300 mm/s -> 4.33 s
    stopped = r.stopped_since()
    assert stopped is not None
    assert T0 + 4.33 - 0.2 <= stopped <= T0 + 4.33 + LATENCY + 0.4, stopped
    # the micro says the move is done (status bit fwd_done)
    assert r.micro_between(7.0)[-1]["status"] & (1 << 2)


def test_forward_modify_up_down_reverse_and_after_completion(tmp_path_factory):
    r = run_mission(tmp_path_factory, "modify", f"""
duration_s = 17.0
[[command]]
t = {T0}
fwd_cmd = 1
accel = 400
speed = 200
distance = 3000
[[command]]
t = 3.5
fwd_cmd = 3
accel = 400
speed = 400
distance = 3000
[[command]]
t = 5.5
fwd_cmd = 3
accel = 400
speed = 150
distance = 3000
[[command]]
t = 7.5
fwd_cmd = 3
accel = 400
speed = 300
distance = 1000
[[command]]
t = 12.0
fwd_cmd = 3
accel = 400
speed = 300
distance = 1500
""")
    v_before = r.truth_between(2.8, 3.5)
    assert all(abs(m["v_mm_s"] - 200) < 12 for m in v_before), "cruise at 200 first"
    assert 385 <= _peak(r.truth_between(3.5, 5.5)) <= 415, "modify up to 400"
    slow = r.truth_between(6.8, 7.5)
    assert all(abs(m["v_mm_s"] - 150) < 12 for m in slow), "modify down to 150"
    # the new distance (1000) is behind the robot: it backs up to it
    assert min(m["v_mm_s"] for m in r.truth_between(7.5, 12.0)) < -250
    assert abs(r.truth_at(11.9)["distance_mm"] - 1000) <= 15
    # modify after completion: same reference, on to 1500
    assert abs(r.truth[-1]["distance_mm"] - 1500) <= 15
    assert _peak(r.truth_between(12.0, 17.0)) > 250


def test_stop_latches_until_a_new_start(tmp_path_factory):
    r = run_mission(tmp_path_factory, "stop", f"""
duration_s = 9.0
[[command]]
t = {T0}
fwd_cmd = 1
speed = 300
distance = 5000
[[command]]
t = 3.5
fwd_cmd = 5
accel = 600
[[command]]
t = 4.5
fwd_cmd = 3
speed = 300
distance = 5000
[[command]]
t = 6.0
fwd_cmd = 1
speed = 200
distance = 300
""")
    d_stop = r.truth_at(4.4)["distance_mm"]
    # 300 mm/s stopped at 600 mm/s^2: 0.5 s, 75 mm, after the command's latency
    assert r.truth_at(3.5 + 0.5 + LATENCY)["v_mm_s"] < 5
    assert all(abs(m["v_mm_s"]) < 2 for m in r.truth_between(4.4 + 0.1, 6.0)), "modify ignored"
    latched = [m["status"] for m in r.micro_between(4.7, 6.0)]
    assert latched and all(s & (1 << 4) for s in latched), "fwd_stop_latched"
    assert abs(r.truth[-1]["distance_mm"] - (d_stop + 300)) <= 15, "a new start moves again"


def test_turn_by_encoders_and_heading_select_across_north(tmp_path_factory):
    r = run_mission(tmp_path_factory, "turn", f"""
duration_s = 15.0
[[command]]
t = {T0}
turn_mode = 1
turn_rate = 450
turn_distance = 900
[[command]]
t = 5.5
turn_mode = 10
turn_rate = 450
turn_distance = 3300
[[command]]
t = 10.0
turn_mode = 10
turn_rate = 450
turn_distance = 300
""")
    a = r.truth_at(5.4)
    assert abs(a["heading_deg"] - 90) <= 2.5, a            # 90 deg clockwise by encoders
    assert abs(a["x_mm"]) < 10 and abs(a["y_mm"]) < 10, a  # pivot in place
    # HdgSel 330 from 90: the short way is 120 deg counter-clockwise, through north
    leg = r.truth_between(5.5, 9.9)
    assert max(m["w_deg_s"] for m in leg) > 20 and min(m["w_deg_s"] for m in leg) > -2
    assert abs(r.truth_at(9.9)["heading_deg"] - 330) <= 2.0
    # HdgSel 30 from 330: 60 deg clockwise, through north again
    leg = r.truth_between(10.0, 15.0)
    assert min(m["w_deg_s"] for m in leg) < -20 and max(m["w_deg_s"] for m in leg) < 2
    end = r.truth[-1]
    assert abs(end["heading_deg"] - 30) <= 2.0, end
    assert abs(end["x_mm"]) < 15 and abs(end["y_mm"]) < 15, end


def test_heading_hold_keeps_a_lopsided_robot_straight(tmp_path_factory):
    # the left wheel is 4 % larger than the firmware believes: open loop it curves right
    r = run_mission(tmp_path_factory, "hold", f"""
duration_s = 19.0
[plant]
wheel_scale_left = 1.04
[[command]]
t = {T0}
fwd_cmd = 1
speed = 300
distance = 1500
[[command]]
t = 8.0
fwd_cmd = 1
speed = 300
distance = 1500
turn_mode = 11
turn_rate = 300
[[command]]
t = 15.0
turn_mode = 11
turn_rate = 300
turn_distance = 450
""")
    drift = r.truth_at(7.9)["heading_deg"] - r.truth_at(T0)["heading_deg"]
    assert drift > 4, f"open loop should curve clockwise, drifted {drift:.1f} deg"
    h0 = r.truth_at(8.0 + LATENCY)["heading_deg"]
    held = [m["heading_deg"] for m in r.truth_between(8.5, 14.5)]
    assert max(abs(h - h0) for h in held) <= 2.0, (h0, min(held), max(held))
    # hold with an offset: the current heading + 45 deg
    assert abs(r.truth[-1]["heading_deg"] - (r.truth_at(14.9)["heading_deg"] + 45)) <= 3.0


def test_servo_goto_and_scan(tmp_path_factory):
    r = run_mission(tmp_path_factory, "servo", f"""
duration_s = 7.0
[[command]]
t = {T0}
rc_servo_num = 2
rc_param0 = 1000
rc_param1 = 300
rc_param2 = 9999
[[command]]
t = 1.6
rc_servo_num = 7
rc_param0 = 400
rc_param1 = 200
rc_param2 = -200
""")
    s2 = [m["servo_deg"][2] for m in r.truth_between(T0 + 0.3 + LATENCY, 7.0)]
    assert all(abs(a - 30) <= 0.5 for a in s2), (min(s2), max(s2))
    # 30 deg at 100 deg/s takes 0.3 s: not there 0.15 s after the command lands
    assert r.truth_at(T0 + 0.1)["servo_deg"][2] < 25
    s7 = [m["servo_deg"][7] for m in r.truth_between(2.5, 7.0)]
    assert max(s7) == pytest.approx(20, abs=1.0) and min(s7) == pytest.approx(-20, abs=1.0)
    turns = sum(1 for a, b, c in zip(s7, s7[1:], s7[2:]) if (b - a) * (c - b) < 0)
    assert turns >= 3, "scan bounces between its limits (40 deg at 40 deg/s: 1 s per sweep)"
    assert all(abs(m["servo_deg"][k]) < 0.01 for m in r.truth for k in (0, 1, 3, 4, 5, 6))


def test_dio_active_and_command_masks_and_release(tmp_path_factory):
    r = run_mission(tmp_path_factory, "dio", f"""
duration_s = 7.0
[plant]
dio_input_pattern = 0xA5F      # external levels: only pins 8-11 (inputs) read them
[[command]]
t = {T0}
dio_active = 0x00F
dio_command = 0x005
[[command]]
t = 2.5
dio_active = 0x00F
dio_command = 0x00A
[[command]]
t = 3.5
dio_active = 0x003
dio_command = 0x00E
[[command]]
t = 4.5
dio_active = 0x900
dio_command = 0x900
[[command]]
t = 5.5
""")
    def dio(t):
        return r.truth_at(t)["dio_out"]
    assert dio(T0 - 0.1) == 0
    assert dio(2.4) == 0x005
    assert dio(3.4) == 0x00A
    assert dio(4.4) == 0x002, "only the active bits follow the command; bits 2, 3 released"
    assert dio(5.4) == 0x000, "bits 8-11 are inputs: never driven"
    assert dio(6.9) == 0x000, "no active bits: all released"
    # all 12 pins reach the planner: outputs looped back, inputs from the plant's pattern
    assert r.micro_between(2.0, 2.4)[-1]["dio_state"] == 0xA00 | 0x005
    assert r.micro_between(6.5)[-1]["dio_state"] == 0xA00
    lisp = [(t, m["dio_state"]) for t, m in r.messages("/planner/data")]
    assert [d for t, d in lisp if 2.0 <= t <= 2.4][-1] == 0xA05
    assert [d for t, d in lisp if 3.0 <= t <= 3.4][-1] == 0xA0A
    assert lisp[-1][1] == 0xA00


def test_unreachable_speed_goes_as_fast_as_it_can_and_stops_on_target(tmp_path_factory):
    r = run_mission(tmp_path_factory, "fast", f"""
duration_s = 9.0
[[command]]
t = {T0}
fwd_cmd = 1
accel = 1000
speed = 2500
distance = 2500
""")
    peak = _peak(r.truth)
    top = no_load_speed_mm_s()
    assert 600 < top < 660
    assert top * 0.99 <= peak <= top * 1.005, \
        f"full duty holds the plant's top speed {top:.0f} mm/s (not the 1000 asked), peak {peak:.0f}"
    cruise = [m["v_mm_s"] for m in r.truth_between(2.6, 4.5)]
    assert min(cruise) >= top * 0.99, "it stays there while the target is far"
    limited = [m["status"] & (1 << 8) for m in r.micro_between(T0, 5.0)]
    assert any(limited), "speed_limited reported"
    assert abs(r.truth[-1]["distance_mm"] - 2500) <= 20, "and still stops at the target"
    assert max(m["distance_mm"] for m in r.truth) <= 2500 + 20
    assert r.stopped_since() is not None


def no_load_speed_mm_s(p=None) -> float:
    """The plant's top speed at full duty from its parameters (defaults of
    fmu/plant/navkit_plant.h, overridden by `p`): motor force kt * g * (V - ke * g * v) / R
    equals Coulomb plus viscous friction, with the battery sagging by battery_r_ohm under
    the idle and both motors' currents (g = gear_ratio / wheel radius)."""
    q = dict(wheel_diameter_mm=100.0, gear_ratio=33.0, motor_r_ohm=2.0, motor_kt_nm_a=0.0275,
             motor_ke_v_s_rad=0.0275, friction_coulomb_n=3.0, friction_viscous_n_s_m=2.0,
             battery_ocv_v=12.0, battery_r_ohm=0.1, battery_idle_a=0.5, **(p or {}))
    g = q["gear_ratio"] / (q["wheel_diameter_mm"] / 2000.0)        # rad/m
    kt, ke, r = q["motor_kt_nm_a"] * g, q["motor_ke_v_s_rad"] * g, q["motor_r_ohm"]
    v, vbat = 0.0, q["battery_ocv_v"]
    for _ in range(100):                 # fixed point of speed and battery voltage
        v = (kt * vbat / r - q["friction_coulomb_n"]) / (kt * ke / r + q["friction_viscous_n_s_m"])
        amps = (vbat - ke * v) / r
        vbat = q["battery_ocv_v"] - q["battery_r_ohm"] * (q["battery_idle_a"] + 2 * amps)
    return 1000.0 * v
