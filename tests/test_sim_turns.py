"""Turns end to end, through the real host, the pty and the firmware FMU, on the plant
FMU's ground truth: the /truth conventions (y left, yaw counter-clockwise and unwrapped,
heading clockwise 0..360) and the firmware's turn rules the other files leave out (turn
modify, turn stop and its latch, + clockwise also when reversing, accel 0 = the default
300 mm/s^2, turn codes the planner may not use refused as a whole).

One lockstep run of 24 simulated s (about a quarter of a second of wall time) holds every
phase; each test reads its own stretch of it.
"""

import statistics

import pytest

from sim_helpers import require_build
from spec_helpers import TURN_CMD

pytestmark = pytest.mark.timeout(120)

LATENCY = 0.35      # s: host frame + UART + control tick, generous

# Phases (s): each command lands at the first host frame at or after its t.
CURVE = 1.5         # forward 600 mm at 300 mm/s with accel 0, turning 45 deg left
SPIN = 5.5          # pivot 355 deg counter-clockwise at 90 deg/s: yaw 45 -> 400 deg
MODIFY = (11.0, 12.5)   # turn 180 deg clockwise at 45 deg/s, modified to 90 deg
STOP = (15.0, 16.5, 17.5)   # turn 180 deg clockwise, stop at 90 deg/s^2, modify (latched)
REVERSE = 19.0      # back up 400 mm turning +45 deg (clockwise) at 30 deg/s
REFUSED = (22.0, 23.0)  # a forward move with turn_mode 13, then with turn_mode 2
END = 24.0

MISSION = f"""
duration_s = {END}
[[command]]
t = {CURVE}
fwd_cmd = "start"
accel = 0
speed = 300
distance = 600
turn_mode = "turn"
turn_rate = 300
turn_distance = -450
[[command]]
t = {SPIN}
turn_mode = "turn"
turn_rate = 900
turn_distance = -3550
[[command]]
t = {MODIFY[0]}
turn_mode = "turn"
turn_rate = 450
turn_distance = 1800
[[command]]
t = {MODIFY[1]}
turn_mode = "modify"
turn_rate = 450
turn_distance = 900
[[command]]
t = {STOP[0]}
turn_mode = "turn"
turn_rate = 450
turn_distance = 1800
[[command]]
t = {STOP[1]}
turn_mode = "stop"
turn_accel = 900
[[command]]
t = {STOP[2]}
turn_mode = "modify"
turn_rate = 450
turn_distance = 1800
[[command]]
t = {REVERSE}
fwd_cmd = "start"
speed = 200
distance = -400
turn_mode = "turn"
turn_rate = 300
turn_distance = 450
"""

# written past the mission check (which refuses them, see the last test), as a planner of
# one's own could: 13 is the micro's reserved "modify heading", outside lisp_cmd's
# turn_mode range; 2 is inside the range but no turn_mode code
REFUSED_FIELDS = [{"fwd_cmd": 1, "speed": 300, "distance": 500, "turn_mode": mode,
                   "turn_rate": 450, "turn_distance": 900} for mode in (13, 2)]


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    from navkit.sim.harness import SimOptions, run as sim_run
    from navkit.sim.mission import Command, loads
    from navkit.sim.results import load

    require_build()
    out = tmp_path_factory.mktemp("sim-turns")
    m = loads(MISSION, out / "turns.toml")
    m.commands += [Command(t, f, f"refused turn_mode {f['turn_mode']}")
                   for t, f in zip(REFUSED, REFUSED_FIELDS)]
    sim_run(SimOptions(mission=m, out=out, plot=False))
    return load(out)


def _status_bit(name: str) -> int:
    from navkit import protocol

    return 1 << protocol.SPEC.enums["micro_status"].values[name]


def test_left_curve_is_y_positive_w_positive_yaw_increasing(run):
    leg = run.truth_between(CURVE, SPIN)
    n = next(i for i, m in enumerate(leg) if m["yaw_deg"] >= 44)    # the turn, to 44 deg
    assert max(m["w_deg_s"] for m in leg[:n]) > 25, "turning left: w > 0 (counter-clockwise)"
    assert min(m["w_deg_s"] for m in leg[:n]) > -0.5
    yaws = [m["yaw_deg"] for m in leg[:n + 1]]
    assert all(b >= a - 0.01 for a, b in zip(yaws, yaws[1:])), "yaw increasing"
    assert all(44 <= m["yaw_deg"] <= 46 for m in leg[n:]), "then it settles at 45 deg"
    end = run.truth_at(SPIN)
    assert abs(end["yaw_deg"] - 45) <= 2, end
    assert abs(end["heading_deg"] - 315) <= 2, end            # clockwise: 45 deg left = 315
    # 600 mm along an arc that turns 45 deg left in its first half: y left of the start
    assert end["y_mm"] > 250 and end["x_mm"] > 400, end
    assert all(m["y_mm"] >= -1 for m in leg)
    assert abs(end["distance_mm"] - 600) <= 15, end


def test_accel_0_is_the_default_300_mm_s2(run):
    """accel 0 in the curve's command: the measured ramps (up, and down to the stop) have
    the firmware's default slope."""
    def slope(t0, t1):
        rows = [m for m in run.truth_between(t0, t1) if 30 < abs(m["v_mm_s"]) < 270]
        assert len(rows) > 20
        return statistics.linear_regression([m["t"] for m in rows],
                                             [m["v_mm_s"] for m in rows]).slope
    up, down = slope(CURVE, CURVE + 1.5), slope(CURVE + 1.5, SPIN)
    assert abs(up - 300) <= 15, up
    assert abs(down + 300) <= 15, down


def test_spin_past_360_keeps_yaw_unwrapped_and_heading_its_clockwise_mod_360(run):
    end = run.truth_at(MODIFY[0])
    assert abs(end["yaw_deg"] - 400) <= 2.5, end            # 45 + 355: not wrapped to 40
    assert abs(end["heading_deg"] - 320) <= 2.5, end
    assert abs(end["x_mm"] - run.truth_at(SPIN)["x_mm"]) < 5, "a pivot in place"
    rows = run.truth
    steps = [abs(b["yaw_deg"] - a["yaw_deg"]) for a, b in zip(rows, rows[1:])]
    assert max(steps) < 3, "no jump of +-360 deg anywhere (90 deg/s is 1.8 deg a row)"
    spin = run.truth_between(SPIN, MODIFY[0])
    assert min(m["yaw_deg"] for m in spin) < 50 and max(m["yaw_deg"] for m in spin) > 395
    for m in rows:  # heading_deg == (-yaw_deg) mod 360 on every row
        diff = (m["heading_deg"] - (-m["yaw_deg"]) % 360 + 180) % 360 - 180
        assert abs(diff) < 1e-6 and 0 <= m["heading_deg"] < 360, m


def test_turn_modify_keeps_the_reference_and_ends_at_the_new_angle(run):
    start = run.truth_at(MODIFY[0])["yaw_deg"]
    at_modify = run.truth_at(MODIFY[1])["yaw_deg"]
    assert 30 < start - at_modify < 80, "modified on the way, short of 90 deg"
    end = run.truth_at(STOP[0])
    assert abs((start - end["yaw_deg"]) - 90) <= 2, (start, end)    # clockwise: yaw falls
    assert abs(end["w_deg_s"]) < 0.5
    micro = run.micro_between(STOP[0] - 0.5, STOP[0])[-1]
    assert abs(micro["turn_progress"] - 900) <= 20, micro           # deg x 0.1, from the 1
    assert micro["status"] & _status_bit("turn_done")


def test_turn_stop_latches_until_a_new_turn_1(run):
    start = run.truth_at(STOP[0])["yaw_deg"]
    stopped = run.truth_at(STOP[2])["yaw_deg"]
    # 45 deg/s for 1.5 s, ramps of 90 deg/s^2 at both ends: 67.5 deg, far short of 180
    assert abs((start - stopped) - 67.5) <= 4, (start, stopped)
    assert run.truth_at(STOP[1] + 0.5 + LATENCY)["w_deg_s"] > -1, "stopped at 90 deg/s^2"
    latched = run.truth_between(STOP[2], REVERSE - 0.05)
    assert all(abs(m["yaw_deg"] - stopped) < 0.3 and abs(m["w_deg_s"]) < 0.5
               for m in latched), "the later modify to 180 deg does nothing"
    status = [m["status"] for m in run.micro_between(STOP[2] + LATENCY, REVERSE - 0.05)]
    assert status and all(s & _status_bit("turn_stop_latched") for s in status)
    after = run.micro_between(REVERSE + LATENCY, REFUSED[0])
    assert after and not any(m["status"] & _status_bit("turn_stop_latched") for m in after)


def test_plus_is_clockwise_also_when_reversing(run):
    leg = run.truth_between(REVERSE + LATENCY, REVERSE + 1.8)
    assert all(m["v_mm_s"] < -50 for m in leg), "backing up"
    assert max(m["w_deg_s"] for m in leg) < 1 and min(m["w_deg_s"] for m in leg) < -20, \
        "turning clockwise looking down (yaw falls)"
    before, after = run.truth_at(REVERSE), run.truth_at(REFUSED[0])
    assert abs((after["heading_deg"] - before["heading_deg"]) - 45) <= 2, (before, after)
    assert abs((after["distance_mm"] - before["distance_mm"]) + 400) <= 15, (before, after)


def test_turn_codes_the_planner_may_not_use_are_refused_as_a_whole(run):
    """The host refuses the whole lisp_cmd (nav_result rejected, a console line), so
    neither its turn nor its forward move happens, and the micro never sees the code
    (its own refusal of 13/15/20/23/25 is tested on the firmware FMU)."""
    from navkit import protocol
    from navkit.sim.mission import MissionError, loads

    rest = run.truth_at(REFUSED[0])
    for m in run.truth_between(REFUSED[0], END):
        assert abs(m["v_mm_s"]) < 1 and abs(m["w_deg_s"]) < 0.5, m
        assert abs(m["x_mm"] - rest["x_mm"]) < 1 and abs(m["yaw_deg"] - rest["yaw_deg"]) < 0.1
    rejected = protocol.SPEC.enums["nav_result"].values["rejected"]
    for t in REFUSED:
        data = [m for tt, m in run.messages("/planner/data") if t <= tt < t + 0.5]
        assert data and all(m["nav_result"] == rejected for m in data), (t, data[:1])
    log = (run.out / "host.log").read_text(errors="replace")
    assert f"planner command {int(REFUSED[0] * 1000)} rejected: turn_mode out of the " \
           f"spec's range" in log
    assert f"planner command {int(REFUSED[1] * 1000)} rejected" in log
    tags_before = {m["time_tag"] for t, m in run.messages("/micro/cmd") if t < REFUSED[0]}
    after = run.messages("/micro/cmd")
    assert {m["time_tag"] for t, m in after if t >= REFUSED[0]} <= tags_before, \
        "no new micro_cmd: the host repeats the last one it sent"
    assert all(m["turn_cmd"] in [TURN_CMD[n] for n in ("none", "turn", "modify", "stop", "hdg_sel")]
               for _, m in after)
    assert run.micro_between(END - 0.5)[-1]["cmd_rejected"] == 0
    # and a mission file cannot say it at all
    for f in REFUSED_FIELDS:
        text = "duration_s = 5\n[[command]]\nt = 1\n" + \
            "".join(f"{k} = {v}\n" for k, v in f.items())
        with pytest.raises(MissionError, match=r"m.toml: \[\[command\]\] #1: key 'turn_mode': "
                                               rf"{f['turn_mode']} is not a turn_mode code"):
            loads(text, "m.toml")
