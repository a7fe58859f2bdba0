"""The plant FMU (fmu/plant, build/fmus/navkit_plant.fmu) through fmpy: validation, the
variable contract of docs/internals.md, physics, sensors, worlds, determinism, FMI states."""

import math
import re
from pathlib import Path

import pytest

fmpy = pytest.importorskip("fmpy")
from fmpy import extract, read_model_description  # noqa: E402
from fmpy.fmi3 import FMU3Slave  # noqa: E402
from fmpy.validation import validate_fmu  # noqa: E402

from navkit.paths import build_dir, repo_root  # noqa: E402

FMU = build_dir() / "fmus" / "navkit_plant.fmu"
WORLDS = repo_root() / "config" / "worlds"

pytestmark = pytest.mark.skipif(not FMU.exists(), reason=f"{FMU} not built")

# defaults of the variable table (fmu/plant/navkit_plant.h)
WHEEL_D_MM, CPR, TRACK_MM = 100.0, 2000, 300.0


@pytest.fixture
def plant(fmu3):
    """plant(**params) -> an instance of the plant FMU (conftest's Fmu3) with `params` set
    before initialization, stepped from t = 0 in steps of its `h` (s)."""
    def make(**params):
        p = fmu3("plant", start=False)
        p.set(**params)
        p.start()
        return p
    return make


def steady_speed_mm_s(duty, vbat, d_mm=WHEEL_D_MM):
    """Steady forward speed of the default drive train: motor force = friction."""
    kt = ke = 0.0275
    g = 33.0 / (d_mm / 2000.0)
    r, fc, cv = 2.0, 3.0, 2.0
    return 1000.0 * (kt * g * duty * vbat / r - fc) / (kt * ke * g * g / r + cv)


# ---------------------------------------------------------------- the FMU as a file


def test_validate_fmu():
    assert validate_fmu(str(FMU)) == []


def test_contract_names_of_internals_md(md):
    """Every firmware <-> plant variable of docs/internals.md exists with its type and the
    opposite (plant-side) causality; the truth outputs and parameters are there."""
    vars_ = {v.name: v for v in md.modelVariables}
    text = (repo_root() / "docs" / "internals.md").read_text()
    section = text.split("## Firmware FMU <-> plant FMU")[1].split("\n## ")[0]
    rows = re.findall(r"^\| `([a-z_0-9]+)`(?:, `([a-z_0-9]+)`)?(?: \.\. `([a-z_0-9]+)`)? \| (\w+) \| (\w+) \|",
                      section, re.M)
    assert len(rows) >= 10
    flip = {"output": "input", "input": "output"}
    for first, second, last, typ, caus in rows:
        names = [first] + ([second] if second else [])
        if last:
            stem = first.rsplit("_", 1)[0]
            names = [f"{stem}_{i}" for i in range(int(first.rsplit("_", 1)[1]), int(last.rsplit("_", 1)[1]) + 1)]
        for n in names:
            assert n in vars_, n
            assert vars_[n].type == typ, n
            assert vars_[n].causality == flip[caus], n
    for n in ["x_mm", "y_mm", "yaw_deg", "heading_deg", "distance_mm", "v_mm_s", "w_deg_s"] + \
             [f"servo_deg_{i}" for i in range(8)]:
        assert vars_[n].causality == "output" and vars_[n].type == "Float64", n
    assert vars_["seed"].causality == "parameter" and vars_["world_file"].type == "String"
    for v in md.modelVariables:
        if v.causality == "parameter":
            assert v.start is not None and v.description, v.name


def test_xml_follows_the_header_table(md):
    """modelDescription.xml is generated from navkit_plant.h: same names, same order."""
    header = (repo_root() / "fmu" / "plant" / "navkit_plant.h").read_text()
    names = re.findall(r"^(?:F64|I32|STR|BIN)\((\w+),", header, re.M)
    assert [v.name for v in md.modelVariables] == names
    assert [v.valueReference for v in md.modelVariables] == list(range(len(names)))


def test_docs_parameter_table_matches_the_header(md):
    """docs/plant.md lists every parameter with its default and unit."""
    doc = (repo_root() / "docs" / "plant.md").read_text()
    rows = dict(re.findall(r"^\| `(\w+)` \| ([^|]+?) \| ", doc, re.M))
    for v in md.modelVariables:
        if v.causality != "parameter":
            continue
        assert v.name in rows, v.name
        if v.type == "Float64":
            assert float(rows[v.name]) == float(v.start), v.name
        elif v.type == "Int32":
            assert int(rows[v.name]) == int(v.start), v.name


def test_units_declared_and_in_the_docs_table(md):
    """Every Float64 parameter's unit is an FMI unit definition and shows in docs/plant.md's
    unit column ("-" only for the dimensionless ones)."""
    doc = (repo_root() / "docs" / "plant.md").read_text()
    units = dict(re.findall(r"^\| `(\w+)` \| [^|]+? \| ([^|]+?) \| ", doc, re.M))
    defined = {u.name for u in md.unitDefinitions}
    dimensionless = {"wheel_scale_left", "wheel_scale_right", "gear_ratio"}
    for v in md.modelVariables:
        if v.causality != "parameter" or v.type != "Float64":
            continue
        if v.name in dimensionless:
            assert v.unit is None and units[v.name] == "-", v.name
        else:
            assert v.unit in defined, v.name
            assert units[v.name] == v.unit, v.name
    by_name = {v.name: v for v in md.modelVariables}
    assert by_name["gyro_bias_walk_dps_rt_s"].unit == "deg/s/sqrt(s)"
    assert by_name["ir_a_v_mm"].unit == "V.mm"


# ---------------------------------------------------------------- drive


def test_equal_duty_drives_straight_to_the_steady_speed(plant):
    p = plant()
    p.set(motor_left_duty=0.5, motor_right_duty=0.5)
    p.run(3.0)
    v = p.get("v_mm_s")
    expected = steady_speed_mm_s(0.5, p.get("battery_voltage"))
    assert v == pytest.approx(expected, rel=0.01)
    assert 250 < v < 350
    assert abs(p.get("y_mm")) < 1e-6 and abs(p.get("yaw_deg")) < 1e-9
    assert p.get("x_mm") == pytest.approx(p.get("distance_mm"), rel=1e-9)
    assert p.get("x_mm") > 700
    assert p.get("heading_deg") == 0.0


def test_full_duty_cannot_reach_800_mm_s(plant):
    p = plant()
    p.set(motor_left_duty=1.0, motor_right_duty=1.0)
    p.h = 0.01
    p.run(3.0)
    v = p.get("v_mm_s")
    assert 600 < v < 700                     # a commanded 800 mm/s is out of reach at 12 V
    assert v == pytest.approx(steady_speed_mm_s(1.0, p.get("battery_voltage")), rel=0.01)


def test_current_limit_is_an_acceleration_limit(plant):
    """From rest at full duty the armature current (~5.7 A) is over motor_i_max_a: each
    wheel pushes kt * gear / r * i_max, less Coulomb friction, on half the mass plus its
    rotor's reflected inertia, so the speed ramps at a constant rate set by i_max."""
    r_m = WHEEL_D_MM / 2000.0
    g = 33.0 / r_m                                   # rad/m
    m_wheel = 12.0 / 2 + 1.0e-6 * g * g              # kg per drive train
    for i_max in (2.5, 1.25):
        p = plant(motor_i_max_a=i_max)
        p.set(motor_left_duty=1.0, motor_right_duty=1.0)
        v = p.run(0.030, watch=["v_mm_s"])["v_mm_s"]
        v_mm_s = p.get("v_mm_s")
        # still current-limited at 30 ms: back-EMF of ke * g * v well below the battery's 12 V
        assert 0.0275 * g * v_mm_s / 1000 < 12.0 - 2.0 * i_max - 1.0
        accel = (v[24] - v[4]) / 0.020 / 1000.0      # m/s^2 between 5 and 25 ms
        # viscous friction (2 N.s/m at < 0.2 m/s) costs under 0.4 N of the ~40 N
        expected = (0.0275 * g * i_max - 3.0) / m_wheel
        assert accel == pytest.approx(expected, rel=0.015), (i_max, accel, expected)


def test_opposite_duty_pivots_in_place_clockwise(plant):
    p = plant()
    p.set(motor_left_duty=0.5, motor_right_duty=-0.5)   # left forward, right back: clockwise
    rows = p.run(1.0, watch=["heading_deg", "yaw_deg"])
    assert abs(p.get("x_mm")) < 1e-6 and abs(p.get("y_mm")) < 1e-6
    assert abs(p.get("distance_mm")) < 1e-6 and abs(p.get("v_mm_s")) < 1e-9
    yaw = p.get("yaw_deg")
    assert yaw < -80                          # counter-clockwise positive: negative here
    assert p.get("w_deg_s") < -100
    assert p.get("heading_deg") == pytest.approx((-yaw) % 360.0, abs=1e-9)
    assert 0 < rows["heading_deg"][100] < 90  # heading grows clockwise from 0
    # truth and encoders agree on the angle: track * yaw = right - left travel
    cpm = CPR / (math.pi * WHEEL_D_MM)
    d_enc = (p.get("enc_right") - p.get("enc_left")) / cpm
    assert math.radians(yaw) * TRACK_MM == pytest.approx(d_enc, abs=2 / cpm)


def test_encoders_match_the_distance_within_a_count(plant):
    p = plant()
    p.set(motor_left_duty=0.3, motor_right_duty=0.3)
    p.run(2.0)
    p.set(motor_left_duty=-0.6, motor_right_duty=-0.6)
    p.h = 0.005
    p.run(2.0)
    cpm = CPR / (math.pi * WHEEL_D_MM)
    for side in ("enc_left", "enc_right"):
        assert p.get(side) == math.floor(p.get("distance_mm") * cpm)
    assert p.get("distance_mm") < 0           # reversed past the start: signed


def test_large_steps_substep_like_small_ones(plant):
    a, b = plant(), plant()
    for p in (a, b):
        p.set(motor_left_duty=0.7, motor_right_duty=0.5)
    a.run(1.0)
    b.h = 0.05
    b.run(1.0)
    for n in ("x_mm", "y_mm", "yaw_deg", "v_mm_s"):
        assert a.get(n) == pytest.approx(b.get(n), rel=1e-6, abs=1e-6), n


def test_stiction_holds_below_the_breakaway_duty(plant):
    p = plant()
    p.set(motor_left_duty=0.02, motor_right_duty=0.02)  # motor force < Coulomb friction
    p.h = 0.01
    p.run(1.0)
    assert p.get("distance_mm") == 0.0 and p.get("enc_left") == 0


# ---------------------------------------------------------------- sensors


def wall_world(tmp_path, x_mm):
    f = tmp_path / "wall.txt"
    f.write_text(f"# a long wall across the path\nwall {x_mm} -3000 {x_mm} 3000\n")
    return str(f)


def ir_volts(d_mm):
    return 331.4 / (d_mm + 40.0) + 0.015


@pytest.mark.parametrize("wall_mm", [500, 1000])
def test_wall_in_front_ir_and_sonar(plant, tmp_path, wall_mm):
    p = plant(world_file=wall_world(tmp_path, wall_mm), ir_noise_v=0.0, sonar_noise_us=0.0)
    rng = wall_mm - 200.0                     # front sensors sit 200 mm ahead of the axle
    assert p.get("ir_voltage_0") == pytest.approx(ir_volts(rng), abs=1e-9)
    assert p.get("sonar_echo_0") == pytest.approx(2 * rng / 343.0e3 * 1e6, abs=1e-6)
    assert p.get("ir_voltage_3") == pytest.approx(ir_volts(1500.0))   # nothing behind
    assert p.get("sonar_echo_3") == 0.0                                # no echo
    # the 45 deg sonars see the wall at the nearest point inside their 30 deg cone
    d = (wall_mm - 170.0) / math.cos(math.radians(30))
    assert p.get("sonar_echo_1") == pytest.approx(2 * d / 343.0e3 * 1e6, rel=1e-9)


def test_ir_curve_and_reading_period(plant, tmp_path):
    p = plant(world_file=wall_world(tmp_path, 700))
    v0 = p.get("ir_voltage_0")
    assert v0 == pytest.approx(ir_volts(500.0), abs=0.05)            # noise 0.01 V RMS
    assert 0.38 < ir_volts(800) < 0.45 and 2.2 < ir_volts(100) < 2.6  # GP2D12 datasheet shape
    p.set(motor_left_duty=0.6, motor_right_duty=0.6)
    rows = p.run(0.2, watch=["ir_voltage_0"])
    changes = sum(1 for a, b in zip(rows["ir_voltage_0"], rows["ir_voltage_0"][1:]) if a != b)
    assert 4 <= changes <= 6                  # one reading per 38 ms
    assert rows["ir_voltage_0"][-1] > v0      # closer wall, higher voltage


def test_sonar_max_range_and_beam(plant, tmp_path):
    far = plant(world_file=wall_world(tmp_path, 3300))
    assert far.get("sonar_echo_0") == 0.0     # 3100 mm > 3000 mm max range
    f = tmp_path / "post.txt"
    f.write_text("wall 870 820 970 820\n")    # a post 41..45 deg left: 47..51 deg off sonar 0's axis
    p = plant(world_file=str(f), sonar_noise_us=0.0)
    assert p.get("sonar_echo_0") == 0.0       # outside the 15 deg half beam
    assert p.get("sonar_echo_1") > 0          # inside the 45 deg sonar's beam


def test_battery_sags_under_load_and_discharges(plant):
    p = plant()
    rest = p.get("battery_voltage")
    assert rest == pytest.approx(12.0 - 0.1 * 0.5)
    p.set(motor_left_duty=1.0, motor_right_duty=1.0)
    p.run(0.02)
    loaded = p.get("battery_voltage")
    assert rest - loaded > 0.4                # 2 x 2.5 A current limit through 0.1 Ohm
    p.set(motor_left_duty=0.0, motor_right_duty=0.0)
    p.h = 0.01
    p.run(2.0)
    assert p.get("battery_voltage") == pytest.approx(rest, abs=0.01)
    small = plant(battery_capacity_ah=0.001)
    small.h = 0.01
    small.run(2.0)
    assert small.get("battery_voltage") < rest - 0.3   # idle current drains a tiny battery


def test_gyro_and_compass(plant):
    p = plant(gyro_noise_dps=0.0, gyro_bias_walk_dps_rt_s=0.0, compass_noise_deg=0.0,
              compass_start_deg=350.0)
    assert p.get("gyro_raw") == round(0.5 * 131)   # bias only at rest
    p.set(motor_left_duty=-0.5, motor_right_duty=0.5)    # counter-clockwise
    p.run(1.0)
    w = p.get("w_deg_s")
    assert w > 0
    assert p.get("gyro_raw") == round((w + 0.5) * 131)
    expect = (350.0 + p.get("heading_deg")) % 360.0
    assert p.get("compass_raw") == round(expect * 10) % 3600
    fast = plant(gyro_lsb_per_dps=200.0)
    fast.set(motor_left_duty=-1.0, motor_right_duty=1.0)
    fast.h = 0.01
    fast.run(2.0)
    assert fast.get("w_deg_s") * 200 > 33000
    assert fast.get("gyro_raw") == 32767       # 16-bit saturation


def test_gyro_white_noise_rms(plant):
    """At rest, with no bias walk: gyro_raw / gyro_lsb_per_dps has mean gyro_bias_dps and
    standard deviation gyro_noise_dps (2000 samples: the estimate is within ~3 %)."""
    import statistics

    p = plant(gyro_noise_dps=0.4, gyro_bias_dps=-0.3, gyro_bias_walk_dps_rt_s=0.0)
    dps = [r / 131.0 for r in p.run(2.0, watch=["gyro_raw"])["gyro_raw"]]
    assert statistics.fmean(dps) == pytest.approx(-0.3, abs=0.03)
    assert statistics.pstdev(dps) == pytest.approx(0.4, rel=0.06)
    quiet = plant(gyro_noise_dps=0.0, gyro_bias_dps=-0.3, gyro_bias_walk_dps_rt_s=0.0)
    assert set(quiet.run(0.2, watch=["gyro_raw"])["gyro_raw"]) == {round(-0.3 * 131)}


def test_compass_noise_rms(plant):
    """At rest: compass_raw / 10 has mean compass_start_deg and standard deviation
    compass_noise_deg (away from the 0/360 wrap)."""
    import statistics

    p = plant(compass_noise_deg=2.5, compass_start_deg=200.0)
    deg = [r / 10.0 for r in p.run(2.0, watch=["compass_raw"])["compass_raw"]]
    assert statistics.fmean(deg) == pytest.approx(200.0, abs=0.2)
    assert statistics.pstdev(deg) == pytest.approx(2.5, rel=0.06)


def test_gyro_bias_random_walk(plant):
    still = plant(gyro_noise_dps=0.0, gyro_bias_walk_dps_rt_s=0.0)
    walk = plant(gyro_noise_dps=0.0, gyro_bias_walk_dps_rt_s=0.02)
    for p in (still, walk):
        p.h = 0.1
    rows_s = still.run(100.0, watch=["gyro_raw"])["gyro_raw"]
    rows_w = walk.run(100.0, watch=["gyro_raw"])["gyro_raw"]
    assert set(rows_s) == {round(0.5 * 131)}
    drift = [abs(r - 66) for r in rows_w]
    assert max(drift) > 5                      # 0.02 deg/s/rt(s) over 100 s: ~0.2 deg/s, ~26 LSB
    assert max(drift) < 131                    # but not a whole deg/s


def test_servo_rate_limit_and_hold(plant):
    p = plant()
    p.set(servo_pulse_0=2400.0, servo_pulse_1=1000.0)     # +90 deg (clockwise), -50 deg
    p.run(0.1)
    assert p.get("servo_deg_0") == pytest.approx(30.0)   # 300 deg/s
    assert p.get("servo_deg_1") == pytest.approx(-30.0)
    p.run(0.3)
    assert p.get("servo_deg_0") == pytest.approx(90.0)
    assert p.get("servo_deg_1") == pytest.approx(-50.0)
    p.set(servo_pulse_0=0.0)                             # not driven: holds
    p.run(0.1)
    assert p.get("servo_deg_0") == pytest.approx(90.0)
    assert p.get("servo_deg_2") == 0.0


def test_dio_loopback(plant):
    p = plant(dio_input_pattern=0xF0F)
    p.set(dio_dir=0x0FF, dio_out=0x0A5)
    assert p.get("dio_in") == 0xF00 | 0x0A5   # follows the inputs at once
    p.run(0.001)
    assert p.get("dio_in") == 0xF00 | 0x0A5


# ---------------------------------------------------------------- determinism


def noisy_trace(plant, seed):
    p = plant(seed=seed, world_file=str(WORLDS / "hallway.txt"))
    p.set(motor_left_duty=0.5, motor_right_duty=0.45)
    p.h = 0.002
    rows = p.run(0.4, watch=["gyro_raw", "compass_raw", "ir_voltage_1", "sonar_echo_2"])
    return rows


def test_same_seed_same_outputs_other_seed_differs(plant):
    a, b, c = noisy_trace(plant, 7), noisy_trace(plant, 7), noisy_trace(plant, 8)
    assert a == b
    assert a["gyro_raw"] != c["gyro_raw"] and a["ir_voltage_1"] != c["ir_voltage_1"]


# ---------------------------------------------------------------- worlds


@pytest.mark.parametrize("name", ["empty.txt", "hallway.txt", "room.txt"])
def test_shipped_worlds_load(plant, name):
    p = plant(world_file=str(WORLDS / name))
    if name == "hallway.txt":   # 900 mm to each side wall, side IRs 180 mm off the centre
        assert p.get("ir_voltage_1") == pytest.approx(ir_volts(720.0), abs=0.05)
        assert p.get("ir_voltage_2") == pytest.approx(ir_volts(720.0), abs=0.05)
    if name == "room.txt":      # table 2.8 m ahead, west wall 1 m behind
        assert p.get("sonar_echo_0") == pytest.approx(2 * 2600 / 343e3 * 1e6, abs=60)
        assert p.get("ir_voltage_0") == pytest.approx(ir_volts(1500.0), abs=0.05)
        assert p.get("sonar_echo_3") == pytest.approx(2 * 800 / 343e3 * 1e6, abs=60)


def test_world_start_pose_moves_the_walls(plant, tmp_path):
    f = tmp_path / "turned.txt"
    f.write_text("start 0 0 90   # robot faces +y of this file\nwall -1000 700 1000 700\n")
    p = plant(world_file=str(f), ir_noise_v=0.0)
    assert p.get("ir_voltage_0") == pytest.approx(ir_volts(500.0), abs=1e-9)


def walls_mm(p) -> list:
    """The plant's walls output: (ax, ay, bx, by) mm per wall (4 little-endian float64)."""
    import struct

    data = p.get("walls")
    assert len(data) % 32 == 0
    return list(struct.iter_unpack("<4d", data))


def test_walls_output_is_the_world_in_the_start_frame(plant, tmp_path):
    """The walls output gives the loaded world exactly as the sensors see it: every wall,
    box side and polyline segment in file order, moved into the start pose frame, in mm;
    no world, no bytes."""
    f = tmp_path / "w.txt"
    f.write_text("start 1000 500 90\nwall 0 0 0 2000\nbox 2000 0 2200 300\n"
                 "polyline 0 0 -100 0 -100 -100\n")
    got = walls_mm(plant(world_file=str(f)))
    # file (x, y) -> start frame: 90 deg left of the file's x, origin at (1000, 500)
    def to_start(x, y):
        return (y - 500.0, -(x - 1000.0))
    want = [(0, 0, 0, 2000), (2000, 0, 2200, 0), (2200, 0, 2200, 300), (2200, 300, 2000, 300),
            (2000, 300, 2000, 0), (0, 0, -100, 0), (-100, 0, -100, -100)]
    assert len(got) == len(want)
    for g, (ax, ay, bx, by) in zip(got, want):
        assert g == pytest.approx(to_start(ax, ay) + to_start(bx, by), abs=1e-9)
    hall = walls_mm(plant(world_file=str(WORLDS / "hallway.txt")))
    assert hall[-1] == (4000.0, -500.0, 4000.0, -900.0), "no turn: the file's mm to the bit"
    assert walls_mm(plant()) == [] and walls_mm(plant(world_file=str(WORLDS / "empty.txt"))) == []


def init_log(md, unzipped, world_file):
    """Log messages of an instance whose initialization with world_file fails."""
    log = []
    fmu = FMU3Slave(guid=md.guid, unzipDirectory=unzipped,
                    modelIdentifier=md.coSimulation.modelIdentifier, instanceName="bad")
    fmu.instantiate(logMessage=lambda env, st, cat, msg: log.append(msg.decode()))
    vr = {v.name: v.valueReference for v in md.modelVariables}["world_file"]
    fmu.setString([vr], [world_file])
    fmu.enterInitializationMode()
    with pytest.raises(Exception):
        fmu.exitInitializationMode()
    fmu.freeInstance()
    return log


@pytest.mark.parametrize("body, line, text", [
    ("wall 0 0 1000 0\n\nwall 1 2 3\n", 3, "'wall' takes 4 numbers"),
    ("# c\nbox 0 0 10 x\n", 2, "not a finite number"),
    ("door 0 0 1 1\n", 1, "unknown keyword 'door'"),
    ("box 10 0 0 10\n", 1, "XMIN < XMAX"),
    ("start 0 0 0\nstart 1 1 1\n", 2, "second 'start'"),
    ("polyline 0 0 5 5 5 5\n", 1, "repeats"),
])
def test_bad_world_file_names_file_and_line(md, unzipped, tmp_path, body, line, text):
    f = tmp_path / "bad.txt"
    f.write_text(body)
    log = init_log(md, unzipped, str(f))
    assert any(m.startswith(f"{f}:{line}: ") and text in m for m in log), log


def test_missing_world_file_is_named(md, unzipped, tmp_path):
    missing = tmp_path / "nope.txt"
    log = init_log(md, unzipped, str(missing))
    assert any(m.startswith(f"{missing}: cannot open") for m in log), log


# ---------------------------------------------------------------- FMI states


def test_illegal_calls_are_errors_and_reset_restarts(md, unzipped):
    fmu = FMU3Slave(guid=md.guid, unzipDirectory=unzipped,
                    modelIdentifier=md.coSimulation.modelIdentifier, instanceName="states")
    log = []
    fmu.instantiate(logMessage=lambda env, st, cat, msg: log.append(msg.decode()))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    with pytest.raises(Exception):
        fmu.doStep(0.0, 0.001)                       # not in step mode yet
    with pytest.raises(Exception):
        fmu.getFloat64([vr["x_mm"]])                 # no values before initialization
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    with pytest.raises(Exception):
        fmu.setFloat64([vr["mass_kg"]], [5.0])       # fixed parameter in step mode
    with pytest.raises(Exception):
        fmu.setFloat64([vr["x_mm"]], [5.0])          # outputs are never set
    with pytest.raises(Exception):
        fmu.doStep(0.5, 0.001)                       # wrong communication point
    fmu.setFloat64([vr["motor_left_duty"], vr["motor_right_duty"]], [0.5, 0.5])
    t = 0.0
    for _ in range(100):
        fmu.doStep(t, 0.01)
        t += 0.01
    assert fmu.getFloat64([vr["x_mm"]])[0] > 100
    fmu.reset()                                      # back to the start pose, start values
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    assert fmu.getFloat64([vr["x_mm"], vr["motor_left_duty"]]) == [0.0, 0.0]
    fmu.doStep(0.0, 0.001)
    fmu.terminate()
    with pytest.raises(Exception):
        fmu.doStep(0.001, 0.001)
    fmu.freeInstance()
    assert any("not allowed" in m for m in log)


# ---------------------------------------------------------------- FMI 2.0 from the same source

FMU2 = build_dir() / "fmus" / "navkit_plant_fmi2.fmu"


def test_fmi2_validates():
    assert FMU2.exists(), f"{FMU2} not built: fmu/plant/CMakeLists.txt always builds it"
    assert validate_fmu(str(FMU2)) == []


def test_fmi2_same_variables_and_outputs_as_fmi3(md, plant, tmp_path):
    from fmpy.fmi2 import FMU2Slave

    md2 = read_model_description(str(FMU2))
    assert [(v.name, v.valueReference, v.causality) for v in md2.modelVariables] == \
           [(v.name, v.valueReference, v.causality) for v in md.modelVariables
            if v.type != "Binary"], "the same but FMI 3.0's Binary walls"
    vr = {v.name: v.valueReference for v in md2.modelVariables}
    fmu = FMU2Slave(guid=md2.guid, unzipDirectory=extract(str(FMU2), unzipdir=str(tmp_path / "u2")),
                    modelIdentifier=md2.coSimulation.modelIdentifier, instanceName="p2")
    fmu.instantiate()
    fmu.setupExperiment(startTime=0.0)
    fmu.setString([vr["world_file"]], [str(WORLDS / "hallway.txt")])
    fmu.setInteger([vr["seed"]], [5])
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    p3 = plant(world_file=str(WORLDS / "hallway.txt"), seed=5)
    duties = {"motor_left_duty": 0.6, "motor_right_duty": 0.4}
    fmu.setReal([vr[k] for k in duties], list(duties.values()))
    p3.set(**duties)
    t = 0.0
    for _ in range(50):
        fmu.doStep(t, 0.02)
        t += 0.02
    p3.h = 0.02
    p3.run(1.0)
    for name in ("x_mm", "y_mm", "yaw_deg", "ir_voltage_1", "sonar_echo_2", "battery_voltage"):
        assert fmu.getReal([vr[name]])[0] == p3.get(name), name
    for name in ("enc_left", "enc_right", "gyro_raw", "compass_raw"):
        assert fmu.getInteger([vr[name]])[0] == p3.get(name), name
    fmu.terminate()
    fmu.freeInstance()
