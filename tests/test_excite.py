"""Excitation experiments co-simulated through the real host (config/missions/excite_wheels.toml):
run.mcap holds the duty and wheel speed series (/micro/datalog, named by the selection that
filled them), the host's datalog holds the same samples, and the experiments' duties are the
commanded ones (steps, PRBS, chirp bounded, ended by their duration)."""

import pytest

from navkit import protocol
from navkit.paths import repo_root
from navkit.plot import read_datalog
from sim_helpers import run_mission
from spec_helpers import bit

pytestmark = pytest.mark.timeout(180)

FRAME_S = 0.02  # s: one sample per host frame, 50 per second


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    text = (repo_root() / "config" / "missions" / "excite_wheels.toml").read_text()
    return run_mission(tmp_path_factory, "excite", text, frame_s=FRAME_S)


def _series(run, t0, t1):
    """/micro/datalog messages logged in t0..t1 (s)."""
    return [m for t, m in run.messages("/micro/datalog") if t0 <= t <= t1]


def test_datalog_topic_names_the_wheels_words(run):
    logs = [m for _, m in run.messages("/micro/datalog")]
    words = protocol.SPEC.enums["mc_datalog"].words["wheels"]
    assert len(logs) > 0.9 * 13.0 / FRAME_S      # every micro_data since the selection at 0.5 s
    assert all(m["selection"] == "wheels" and set(words) <= set(m) for m in logs)
    # the same numbers as micro_data's mc_datalog words, and its selection
    data = {m["micro_time"]: m for _, m in run.messages("/micro/data")}
    for m in logs:
        d = data[m["micro_time_ms"]]
        assert d["mc_datalog_sel"] == protocol.SPEC.enums["mc_datalog"].values["wheels"]
        assert [m[w] for w in words] == d["mc_datalog"]


def test_step_duty_and_speed(run):
    """1.0 s: 0.2 s at duty 0, then duty 0.3 on both wheels until 2.5 s; the speed rises
    toward a steady value and both wheels agree."""
    held = _series(run, 1.05, 1.15)
    step = _series(run, 1.3, 2.45)
    assert held and all(m["duty_left_e4"] == 0 == m["duty_right_e4"] for m in held)
    assert step and all(m["duty_left_e4"] == 3000 == m["duty_right_e4"] for m in step)
    v = [m["speed_left_mm_s"] for m in step]
    assert v[0] < v[len(v) // 2] and v[-1] > 100
    assert abs(v[-1] - v[-5]) < 0.1 * v[-1]    # settled
    assert all(abs(m["speed_left_mm_s"] - m["speed_right_mm_s"]) <= 3 for m in step)
    # ended by its duration: duty 0, the status bit clear
    after = _series(run, 2.6, 2.9)
    assert after and all(m["duty_left_e4"] == 0 for m in after)
    active = bit("micro_status", "excite_active")
    assert all(m["status"] & active for m in run.micro_between(1.1, 2.4))
    assert not any(m["status"] & active for m in run.micro_between(2.6, 2.9))


def test_prbs_and_chirp_on_the_spot(run):
    prbs = _series(run, 5.1, 7.9)
    assert {m["duty_left_e4"] for m in prbs} == {2500, -2500}
    assert all(m["duty_right_e4"] == -m["duty_left_e4"] for m in prbs)
    chirp = _series(run, 9.1, 12.9)
    duties = [m["duty_left_e4"] for m in chirp]
    assert max(duties) <= 3000 and min(duties) >= -3000 and max(duties) > 2000 and min(duties) < -2000
    assert len(set(duties)) > len(duties) // 2      # a sweep, not a few levels
    # spinning on the spot: the robot turned but stayed near where the steps left it
    end = run.truth_at(13.9)
    assert abs(end["yaw_deg"]) > 5
    micro = run.micro_between(0, 14)
    assert all(m["cmd_rejected"] == 0 for m in micro)


def test_host_datalog_holds_the_same_samples(run):
    names = run.summary["datalogs"]
    assert len(names) == 1
    params, rows = read_datalog(run.out / names[0])
    cols = [p[0] for p in params]
    for c in ("micro_time_ms", "mc_datalog_sel", "mc_datalog0", "mc_datalog1", "mc_datalog2", "mc_datalog3"):
        assert c in cols, c
    idx = {c: cols.index(c) for c in cols}
    logs = {m["micro_time_ms"]: m for _, m in run.messages("/micro/datalog")}
    words = protocol.SPEC.enums["mc_datalog"].words["wheels"]
    matched = 0
    for r in rows:
        m = logs.get(int(r[idx["micro_time_ms"]]))
        if m is None or r[idx["mc_datalog_sel"]] != 6:
            continue
        assert [int(r[idx[f"mc_datalog{i}"]]) for i in range(4)] == [m[w] for w in words]
        matched += 1
    assert matched > 0.9 * 12.0 / FRAME_S


def test_planner_words_have_the_micro_words_ranges():
    """The host copies lisp_cmd's excitation words into micro_cmd's unchecked: the spec must
    give both the same ranges (and enums), so the planner-side check is the micro's."""
    lisp, micro = protocol.SPEC.messages["lisp_cmd"], protocol.SPEC.messages["micro_cmd"]
    names = [f.name for f in micro.fields if f.name.startswith("excite_")]
    assert len(names) == 9
    for n in names + ["mc_datalog_cmd"]:
        a, b = lisp.field(n), micro.field(n)
        assert (a.min, a.max, a.enum, a.units, a.scale) == (b.min, b.max, b.enum, b.units, b.scale), n


@pytest.mark.parametrize("line, key", [
    ("excite_amplitude = 1001", "excite_amplitude"),
    ("excite_mode = \"sine\"", "excite_mode"),
    ("excite_seed = 65536", "excite_seed"),
    ("excite_wheels = 4", "excite_wheels"),
    ("mc_datalog_cmd = 7", "mc_datalog_cmd"),
])
def test_mission_refuses_bad_experiment_words(line, key):
    from navkit.sim.mission import MissionError, loads

    with pytest.raises(MissionError) as e:
        loads(f"duration_s = 2\n[[command]]\nt = 1\n{line}\n", "m.toml")
    assert "[[command]] #1" in str(e.value) and repr(key) in str(e.value)


def test_mission_takes_experiment_words_by_name(host_converts):
    from navkit.sim.mission import loads

    m = loads('duration_s = 2\n[[command]]\nt = 1\nexcite_mode = "prbs"\nexcite_wheels = "spin"\n'
              'excite_seed = 7\nexcite_duration = 500\nmc_datalog_cmd = "wheels"\n', "m.toml")
    e = protocol.SPEC.enums
    assert m.commands[0].fields == {"excite_mode": e["excite_mode"].values["prbs"],
                                    "excite_wheels": e["excite_wheels"].values["spin"], "excite_seed": 7,
                                    "excite_duration": 500, "mc_datalog_cmd": e["mc_datalog"].values["wheels"]}
