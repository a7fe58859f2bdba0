"""`navkit compare RUN_A RUN_B`: a run against itself is zero everywhere; another seed or
a heavier plant deviates where expected; runs with different frame periods align on
simulated time; runs of different missions warn; bad inputs are one line naming the run.
The runs are real co-simulations (host, firmware and plant FMUs)."""

import json
import subprocess
import sys

import pytest

from navkit.compare import CompareError, compare_runs
from sim_helpers import require_build

# 500 mm forward, then a heading select to 90 deg: two legs. The first command waits for
# the config download (one message per host frame: 0.3 s with 100 ms frames)
MISSION = """
duration_s = 7.0
[[command]]
t = 1.0
fwd_cmd = "start"
accel = 600
speed = 400
distance = 500
[[command]]
t = 3.5
turn_mode = "heading_select"
turn_rate = 900
turn_distance = 900
"""
HEAVY = MISSION.replace("duration_s = 7.0", "duration_s = 7.0\n[plant]\nmass_kg = 40.0\n"
                        "motor_i_max_a = 1.0")
OTHER = MISSION.replace("distance = 500", "distance = 400")


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """name -> run folder: the mission with seed 1 (100 and 50 ms frames), seed 2, a
    heavier robot with weaker motors, and another mission."""
    from navkit.sim.harness import SimOptions, run
    from navkit.sim.mission import loads

    require_build()
    out = {}
    for name, text, seed, frame_s in (("a", MISSION, 1, None), ("a50", MISSION, 1, 0.05),
                                      ("seed2", MISSION, 2, None), ("heavy", HEAVY, 1, None),
                                      ("other", OTHER, 1, None)):
        d = tmp_path_factory.mktemp(f"cmp-{name}")
        m = loads(text, d / f"{name if name == 'other' else 'short'}.toml")
        run(SimOptions(mission=m, out=d, seed=seed, frame_s=frame_s, plot=False))
        out[name] = d
    return out


def _devs(c):
    return list(c.truth.values()) + list(c.odometry.values())


def test_run_against_itself_is_zero(runs):
    c = compare_runs(runs["a"], runs["a"])
    assert len(_devs(c)) == 6
    assert all(d.max == 0 and d.rms == 0 and d.parted_at is None for d in _devs(c))
    assert [(leg.leg, leg.t_start, leg.t_end) for leg in c.legs] == [(1, 1.0, 3.5), (2, 3.5, 7.0)]
    assert all(leg.pos_mm == leg.heading_deg == leg.speed_mm_s == leg.odo_pos_mm == 0
               for leg in c.legs)
    assert c.legs_within(0, 0) and c.warnings == []
    assert c.series["t"].size == 351       # 0..7 s of /truth at 50 Hz


def test_another_seed_deviates_a_little(runs):
    """Another seed: other gyro and sensor noise, so the wheel and heading loops act a
    little differently and the path differs, by far less than the thresholds (the micro's
    whole-mm and 0.1-deg odometry may not show it)."""
    c = compare_runs(runs["a"], runs["seed2"])
    assert c.truth["heading"].max > 0 and c.truth["position"].max > 0
    assert c.truth["speed"].max > 0
    assert all(d.parted_at is None for d in _devs(c)), c.text()
    assert c.legs_within(5.0, 0.5), c.text()
    assert c.info["A"]["seed"] == 1 and c.info["B"]["seed"] == 2


def test_heavier_robot_parts_while_accelerating(runs):
    """40 kg and 1 A motors: it accelerates slower, so the speeds part right after the
    first command (1 s); the position loop brings it to the same end (a few mm)."""
    c = compare_runs(runs["a"], runs["heavy"])
    v, pos = c.truth["speed"], c.truth["position"]
    assert 1.0 < v.parted_at < 1.4 and v.max > 10, c.text()
    assert 1.0 < pos.t_max < 3.5 and pos.max > 1, "worst while driving the first leg"
    assert c.odometry["speed"].parted_at is not None
    assert 0.5 < c.legs[0].pos_mm < 5, c.text()
    assert c.warnings == [], "same mission, another plant: no warning"


def test_frame_periods_align_on_simulated_time(runs):
    """100 ms against 50 ms host frames: compared at the coarser run's instants, micro
    data placed by the micro's own clock."""
    c = compare_runs(runs["a"], runs["a50"])
    assert (c.info["A"]["frame_s"], c.info["B"]["frame_s"]) == (0.1, 0.05)
    assert c.series["odo_t"].size <= 71, "A's micro_data instants, not the union"
    assert c.truth["position"].max < 1.0 and c.truth["heading"].max < 0.05, c.text()
    assert c.odometry["position"].max < 2.0 and c.odometry["speed"].max < 20, c.text()
    assert len(c.legs) == 2 and c.legs_within(1.0, 0.1), c.text()


def test_different_missions_warn(runs):
    c = compare_runs(runs["a"], runs["other"])
    assert any(w.startswith("runs of different missions (A: short.toml, B: other.toml: ")
               for w in c.warnings), c.warnings
    assert c.legs[0].pos_mm > 90, "100 mm shorter first leg"
    assert "warning: runs of different missions" in c.text()


def _navkit(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "navkit", "compare", *map(str, args)],
                          capture_output=True, text=True, timeout=60, cwd=cwd)


def test_cli_text_plot_json_check(runs, tmp_path):
    p = _navkit(runs["a"], runs["seed2"], "--json", tmp_path / "c.json", cwd=tmp_path)
    assert p.returncode == 0, p.stderr
    assert "/truth position" in p.stdout and "worst leg end" in p.stdout
    assert (tmp_path / "compare.png").stat().st_size > 10_000, "the default plot, in the cwd"
    doc = json.loads((tmp_path / "c.json").read_text())
    assert len(doc["legs"]) == 2 and doc["truth"]["heading"]["max"] > 0
    # --check: nonzero deviations beyond zero thresholds fail, a run against itself passes
    p = _navkit(runs["a"], runs["seed2"], "--no-plot", "--check", "--pos-tol", 0,
                "--heading-tol", 0, cwd=tmp_path)
    assert p.returncode == 1 and p.stderr.startswith("navkit compare: a leg's end is beyond 0 mm")
    p = _navkit(runs["a"], runs["a"], "--plot", tmp_path / "self.png", "--check")
    assert p.returncode == 0 and (tmp_path / "self.png").exists()


def _mcap_without_truth(path):
    from mcap.writer import Writer

    with open(path, "wb") as fh:
        w = Writer(fh)
        w.start()
        sid = w.register_schema("e", "jsonschema", b"{}")
        cid = w.register_channel("/events", "json", sid)
        w.add_message(cid, log_time=0, data=b"{}", publish_time=0)
        w.finish()


@pytest.mark.parametrize("case, message", [
    ("missing", "run A {a}: no such run folder"),
    ("empty", "run A {a}: no run.mcap in it (not an output folder of navkit sim)"),
    ("not_mcap", "run A: {a}/run.mcap: not an MCAP file"),
    ("no_truth", "run A {a}/run.mcap: 0 /truth messages, at least 2 needed"),
])
def test_bad_runs(runs, tmp_path, case, message):
    a = tmp_path / "run"
    if case != "missing":
        a.mkdir()
    if case == "not_mcap":
        (a / "run.mcap").write_text("hello")
    if case == "no_truth":
        _mcap_without_truth(a / "run.mcap")
    with pytest.raises(CompareError) as e:
        compare_runs(a, runs["a"])
    assert str(e.value).startswith(message.format(a=a)), str(e.value)
    p = _navkit(a, runs["a"], "--no-plot")
    assert p.returncode == 1 and "Traceback" not in p.stderr
    assert p.stderr.strip().splitlines() == [f"navkit compare: {e.value}"], p.stderr


def test_bad_option(runs):
    p = _navkit(runs["a"], runs["a"], "--pos-tol", "-1")
    assert p.returncode == 2 and "a finite number of at least 0" in p.stderr


def test_micro_data_placed_by_the_micros_clock():
    """/micro/data sampled at micro_time since the micro's reset, not at its log time (the
    end of the FMU call that carried it); after a micro_reset fault at the harness's event
    time, else at the log time minus micro_time."""
    from navkit.compare import _micro_times

    micro = [(0.04, {"micro_time": 3}), (0.14, {"micro_time": 103}),
             (2.04, {"micro_time": 5}), (2.14, {"micro_time": 105}),   # reset at 2.0 s
             (5.04, {"micro_time": 7})]                                # reset, no event
    assert list(_micro_times(micro, [2.0])) == pytest.approx([0.003, 0.103, 2.005, 2.105, 5.04])
