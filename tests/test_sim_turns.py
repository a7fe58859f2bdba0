"""Turns end to end, through the real host, the pty and the firmware FMU, on the plant
FMU's ground truth: the /truth conventions (x forward and y left of the start pose, yaw
counter-clockwise and unwrapped, heading clockwise 0..360).

One lockstep run of 11 simulated s (a fraction of a second of wall time) holds every
phase; each test reads its own stretch of it.
"""

import pytest

from test_sim_util import require_build

pytestmark = pytest.mark.timeout(120)

# Phases (s): each command lands at the first host frame at or after its t.
CURVE = 1.5         # forward 600 mm at 300 mm/s, turning 45 deg left
SPIN = 5.5          # pivot 355 deg counter-clockwise at 90 deg/s: yaw 45 -> 400 deg
END = 11.0

MISSION = f"""
duration_s = {END}
[[command]]
t = {CURVE}
fwd_cmd = "start"
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
"""


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    from navkit.sim.harness import SimOptions, run as sim_run
    from navkit.sim.mission import loads
    from navkit.sim.results import load

    require_build()
    out = tmp_path_factory.mktemp("sim-turns")
    sim_run(SimOptions(mission=loads(MISSION, out / "turns.toml"), out=out, plot=False))
    return load(out)


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


def test_spin_past_360_keeps_yaw_unwrapped_and_heading_its_clockwise_mod_360(run):
    end = run.truth_at(END)
    assert abs(end["yaw_deg"] - 400) <= 2.5, end            # 45 + 355: not wrapped to 40
    assert abs(end["heading_deg"] - 320) <= 2.5, end
    assert abs(end["x_mm"] - run.truth_at(SPIN)["x_mm"]) < 5, "a pivot in place"
    rows = run.truth
    steps = [abs(b["yaw_deg"] - a["yaw_deg"]) for a, b in zip(rows, rows[1:])]
    assert max(steps) < 3, "no jump of +-360 deg anywhere (90 deg/s is 1.8 deg a row)"
    spin = run.truth_between(SPIN, END)
    assert min(m["yaw_deg"] for m in spin) < 50 and max(m["yaw_deg"] for m in spin) > 395
    for m in rows:  # heading_deg == (-yaw_deg) mod 360 on every row
        diff = (m["heading_deg"] - (-m["yaw_deg"]) % 360 + 180) % 360 - 180
        assert abs(diff) < 1e-6 and 0 <= m["heading_deg"] < 360, m
