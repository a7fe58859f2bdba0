"""End to end sensors: the plant's GP2D12 IR rangers, SRF04 sonars and battery, through the
firmware FMU's ADC and echo timer, the serial link and the host's sensors.ini calibration,
as the planner reads them in lisp_data (/planner/data: ranges in mm, battery in mV).

One lockstep run in a world of two walls (a wall 600 mm ahead of the front sensors, one
400 mm left of the left IR): the robot stands still, drives 400 mm toward the front wall
and stops short of it. Expected readings come from the truth pose (/truth), the sensor
mounts and models of the plant FMU's parameters (their start values) and the walls.
"""

import math
import statistics

import pytest

from sim_helpers import require_build, run_mission

pytestmark = pytest.mark.timeout(120)

# walls (x1, y1, x2, y2) in mm, start pose frame: x forward, y left
WALLS = ((800.0, -1000.0, 800.0, 1000.0),      # front: 600 mm from the front IR / sonar (x 200)
         (-1000.0, 580.0, 800.0, 580.0))       # left: 400 mm from the left IR (y 180)
T_CMD = 2.0                # s: the drive command (after config download and gyro calibration)
DRIVE_MM = 400
MISSION = f"""
duration_s = 5.0
world = "{{world}}"
[[command]]
t = {T_CMD}
fwd_cmd = "start"
accel = 1500
speed = 400
distance = {DRIVE_MM}
"""
IR_VALID_MM = (100, 800)   # lisp_data.ir_range: 0 = out of range (valid 100..800 mm)
ADC_LSB_V = 5.0 / 1023     # 10-bit ADC, 5.0 V reference (docs/internals.md)
BATTERY_DIVIDER = 3.0      # the board divides the pack by 3 into ADC ch4
LAG_S = 0.25               # s: sensor hold + control tick + UART + host frame, generous
NOISE_SIGMAS = 4.0         # per-reading tolerance in noise RMS


@pytest.fixture(scope="module")
def plant():
    """The plant FMU's parameters (start values) as floats, by name."""
    from fmpy import read_model_description

    from navkit.paths import build_dir
    from navkit.sim.harness import fmu_paths

    require_build()
    md = read_model_description(str(fmu_paths(build_dir())[1]))
    return {v.name: float(v.start) for v in md.modelVariables
            if v.causality == "parameter" and v.type == "Float64"}


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    world = tmp_path_factory.mktemp("sensors-world") / "two_walls.txt"
    world.write_text("# test_sim_sensors.py: front and left walls\n"
                     + "".join("wall {:g} {:g} {:g} {:g}\n".format(*w) for w in WALLS))
    return run_mission(tmp_path_factory, "sensors", MISSION.format(world=world))


# ------------------------------------------------------------------ geometry (mm, rad)

def _apex(plant: dict, kind: str, i: int, pose: dict):
    """World position (mm) and pointing angle (rad) of sensor `kind` ("ir"/"sonar") `i`
    at truth pose `pose`."""
    mx, my = plant[f"{kind}_x_mm_{i}"], plant[f"{kind}_y_mm_{i}"]
    yaw = math.radians(pose["yaw_deg"])
    c, s = math.cos(yaw), math.sin(yaw)
    return (pose["x_mm"] + c * mx - s * my, pose["y_mm"] + s * mx + c * my,
            yaw + math.radians(plant[f"{kind}_angle_deg_{i}"]))


def _cross(ax, ay, bx, by):
    return ax * by - ay * bx


def _ray_mm(x, y, th) -> float:
    """Distance (mm) from (x, y) along angle th to the first wall; inf if none."""
    dx, dy = math.cos(th), math.sin(th)
    best = math.inf
    for x1, y1, x2, y2 in WALLS:
        ex, ey = x2 - x1, y2 - y1
        den = _cross(dx, dy, ex, ey)
        if abs(den) < 1e-12:
            continue
        t = _cross(x1 - x, y1 - y, ex, ey) / den
        u = _cross(x1 - x, y1 - y, dx, dy) / den
        if t > 0 and 0 <= u <= 1:
            best = min(best, t)
    return best


def _cone_mm(x, y, th, half) -> float:
    """Distance (mm) from (x, y) to the nearest wall point inside the cone of half-angle
    `half` around angle th; inf if none."""
    right = (math.cos(th - half), math.sin(th - half))
    left = (math.cos(th + half), math.sin(th + half))
    best = math.inf
    for x1, y1, x2, y2 in WALLS:
        lo, hi = 0.0, 1.0     # the part of the wall inside both half-planes of the cone
        for f in (lambda px, py: _cross(*right, px - x, py - y),
                  lambda px, py: _cross(px - x, py - y, *left)):
            f0, f1 = f(x1, y1), f(x2, y2)
            if f0 < 0 and f1 < 0:
                lo, hi = 1.0, 0.0
            elif f0 < 0:
                lo = max(lo, f0 / (f0 - f1))
            elif f1 < 0:
                hi = min(hi, f0 / (f0 - f1))
        if lo > hi:
            continue
        ex, ey = x2 - x1, y2 - y1
        s = ((x - x1) * ex + (y - y1) * ey) / (ex * ex + ey * ey)
        s = min(max(s, lo), hi)
        best = min(best, math.hypot(x1 + s * ex - x, y1 + s * ey - y))
    return best


def _geometric_mm(plant, kind, i, pose) -> float:
    """The range (mm) sensor `kind` `i` should measure at truth pose `pose`."""
    x, y, th = _apex(plant, kind, i, pose)
    if kind == "ir":
        return _ray_mm(x, y, th)
    return max(_cone_mm(x, y, th, math.radians(plant["sonar_beam_deg"]) / 2),
               plant["sonar_min_mm"])


def _band(plant, kind, d, sigmas) -> tuple:
    """(low, high) mm the host may report for geometric range `d` (mm): sensor noise of
    `sigmas` RMS plus one ADC count (IR) or one us of echo timing (sonar), plus the host's
    rounding to 1 mm; (0, 0) where the sensor reads out of range / no echo."""
    if kind == "ir":
        if not IR_VALID_MM[0] <= d <= IR_VALID_MM[1]:
            return 0, 0
        a, b, c = plant["ir_a_v_mm"], plant["ir_b_mm"], plant["ir_c_v"]
        v = a / (d + b) + c
        dv = sigmas * plant["ir_noise_v"] + ADC_LSB_V
        hi = a / (v - dv - c) - b if v - dv - c > 0 else math.inf
        return a / (v + dv - c) - b - 1, hi + 1
    if d > plant["sonar_max_mm"]:
        return 0, 0
    tol = (sigmas * plant["sonar_noise_us"] + 1) * plant["sound_speed_m_s"] / 2000 + 1
    return d - tol, d + tol


def _readings(run, kind, i, t0, t1) -> list:
    """[(t_s, mm), ...] of lisp_data ir_range / sonar_range[i] with t0 <= t <= t1 (s)."""
    key = "ir_range" if kind == "ir" else "sonar_range"
    return [(t, m[key][i]) for t, m in run.messages("/planner/data") if t0 <= t <= t1]


def _still_windows(run) -> list:
    """[(t0, t1), ...]: standing before the drive (from the first sensor data) and after the
    stop (once the last readings taken while moving have passed)."""
    stop = run.stopped_since()
    assert stop is not None and T_CMD < stop < run.truth[-1]["t"] - 1.0, stop
    return [(0.5, T_CMD), (stop + LAG_S, run.truth[-1]["t"])]


SENSORS = [("ir", i) for i in range(4)] + [("sonar", i) for i in range(4)]


def test_the_robot_stops_short_of_the_front_wall(run, plant):
    end = run.truth[-1]
    assert abs(end["x_mm"] - DRIVE_MM) <= 20 and abs(end["y_mm"]) <= 5, end
    assert _geometric_mm(plant, "ir", 0, end) > IR_VALID_MM[0] + 50
    assert all(m["battery"] > 0 for t, m in run.messages("/planner/data") if t >= 0.5), \
        "the host has the micro's data from 0.5 s on"


@pytest.mark.parametrize("kind, i", SENSORS, ids=[f"{k}{i}" for k, i in SENSORS])
def test_standing_readings_match_the_geometry(run, plant, kind, i):
    """Every reading within the noise band of the geometric range; the median within one
    noise RMS (calibration errors show here); out of range / no echo reads 0."""
    for t0, t1 in _still_windows(run):
        pose = run.truth_at(t1)
        d = _geometric_mm(plant, kind, i, pose)
        lo, hi = _band(plant, kind, d, NOISE_SIGMAS)
        got = _readings(run, kind, i, t0, t1)
        assert len(got) >= 10, (t0, t1)
        bad = [(t, v) for t, v in got if not lo <= v <= hi]
        assert not bad, f"{kind}{i} at x {pose['x_mm']:.1f} mm: geometric {d:.1f} mm, " \
                        f"allowed {lo:.1f}..{hi:.1f}, got {bad}"
        med = statistics.median(v for _, v in got)
        lo, hi = _band(plant, kind, d, 1.0)
        assert lo <= med <= hi, f"{kind}{i}: median {med} mm, geometric {d:.1f} mm " \
                                f"(allowed {lo:.1f}..{hi:.1f})"


@pytest.mark.parametrize("kind, i", [("ir", 0), ("ir", 1), ("sonar", 0), ("sonar", 1)])
def test_readings_follow_the_robot_to_the_front_wall(run, plant, kind, i):
    """While driving, each reading lies in the band of the geometric ranges of the last
    LAG_S seconds of truth; the front sensors' readings shrink by about the distance driven,
    the left IR's stay."""
    stop = run.stopped_since()
    got = _readings(run, kind, i, T_CMD, stop + LAG_S)
    assert len(got) >= 8
    for t, v in got:
        ds = [_geometric_mm(plant, kind, i, p) for p in run.truth_between(t - LAG_S, t)]
        lo = _band(plant, kind, min(ds), NOISE_SIGMAS)[0]
        hi = _band(plant, kind, max(ds), NOISE_SIGMAS)[1]
        assert lo <= v <= hi, f"{kind}{i} at {t:.2f} s: {v} mm, geometric " \
                              f"{min(ds):.0f}..{max(ds):.0f} mm"
    (a0, a1), (b0, b1) = _still_windows(run)
    before = statistics.median(v for _, v in _readings(run, kind, i, a0, a1))
    after = statistics.median(v for _, v in _readings(run, kind, i, b0, b1))
    shrink = _geometric_mm(plant, kind, i, run.truth_at(a1)) - \
        _geometric_mm(plant, kind, i, run.truth_at(b1))
    if (kind, i) == ("ir", 1):
        assert abs(shrink) < 1 and abs(after - before) <= 15, (before, after)
    else:
        assert shrink > 250
        assert after < before - 0.9 * shrink, (before, after, shrink)
        if kind == "sonar":     # low noise: never grows by more than the noise on the way
            vs = [v for _, v in got]
            tol = _band(plant, kind, 500, NOISE_SIGMAS)[1] - 500
            assert all(b <= a + tol for a, b in zip(vs, vs[1:])), vs


def test_battery_plausible_and_sags_while_driving(run, plant):
    """lisp_data.battery (mV): at rest the plant's open-circuit voltage less the idle
    current's drop, to two ADC counts (through the /3 divider); lower while the motors
    accelerate the robot; never outside the pack's empty..full range."""
    lsb_mv = ADC_LSB_V * BATTERY_DIVIDER * 1000
    rest_mv = 1000 * (plant["battery_ocv_v"] - plant["battery_r_ohm"] * plant["battery_idle_a"])
    data = [(t, m["battery"]) for t, m in run.messages("/planner/data") if t >= 0.5]
    for t0, t1 in _still_windows(run):
        still = [v for t, v in data if t0 <= t <= t1]
        assert all(abs(v - rest_mv) <= 2 * lsb_mv for v in still), (rest_mv, still)
    assert all(1000 * plant["battery_empty_v"] <= v <= 1000 * plant["battery_ocv_v"] + lsb_mv
               for _, v in data), data
    driving = [v for t, v in data if T_CMD < t <= run.stopped_since()]
    assert min(driving) <= rest_mv - 3 * lsb_mv, (rest_mv, driving)
