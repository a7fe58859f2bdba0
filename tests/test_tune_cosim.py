"""`navkit tune` end to end through the real host, the firmware FMU and the plant FMU, on a
plant the tuner was not written for (heavier, weaker motors): the wheel experiment is
co-simulated and identified, the design meets its targets, the tuned config loads in the
host and the co-simulated move stays within 5 % overshoot; the same experiment's run.mcap
and host datalog tune through --log; the heading loop tunes on top of the wheel loops."""

import json
import re
import subprocess
import sys

import pytest

from navkit.paths import build_dir, repo_root
from navkit.sim.results import load
from sim_helpers import require_build

# heavier (18 kg instead of 12) with weaker motors (torque constant -20 %, more resistance)
HEAVY = {"mass_kg": 18.0, "motor_kt_nm_a": 0.022, "motor_ke_v_s_rad": 0.022, "motor_r_ohm": 2.4,
         "yaw_inertia_kg_m2": 0.54}


def _navkit(*args, timeout=300):
    return subprocess.run([sys.executable, "-m", "navkit", *map(str, args)], capture_output=True, text=True,
                          timeout=timeout, env={**__import__("os").environ, "NAVKIT_BUILD_DIR": str(build_dir())})


def _mission(tmp_path):
    """config/missions/tune_wheels.toml with the heavy plant and the host's datalog on."""
    text = (repo_root() / "config" / "missions" / "tune_wheels.toml").read_text()
    plant = "[plant]\n" + "".join(f"{k} = {v!r}\n" for k, v in HEAVY.items())
    keys = '\n[[key]]\nt = 0.1\nkey = "R"\n\n[[key]]\nt = 8.9\nkey = "S"\n'
    text = re.sub(r"^(duration_s = .*\n)", lambda m: m.group(1) + plant, text, count=1, flags=re.M)
    path = tmp_path / "heavy_wheels.toml"
    path.write_text(text + keys)
    return path


@pytest.fixture(scope="module")
def wheel(tmp_path_factory):
    require_build()
    tmp = tmp_path_factory.mktemp("tune")
    mission = _mission(tmp)
    out = tmp / "wheel"
    r = _navkit("tune", "wheel", "--mission", mission, "--out", out, "--samples", 20)
    assert r.returncode == 0, r.stderr
    return mission, out, r.stdout, json.loads((out / "tune.json").read_text())


def test_wheel_meets_targets_on_a_heavy_plant(wheel):
    _, out, stdout, tj = wheel
    assert "tuned     wheel:" in stdout and "co-simulated overshoot" in stdout
    for name in ("fit.png", "bode.png", "step.png", "tune.json"):
        assert (out / name).stat().st_size > 1000
    # the identified model is the heavy plant's: slower than the reference robot's ~40 ms
    m = tj["model"]
    lag = m["tau1_s"] + m["tau2_s"] + m["delay_s"]
    assert 0.08 < lag < 0.16
    assert all(x["fits"][m["kind"]]["nrmse"] < 0.1 for x in tj["records"])
    assert all(all(x["replayed"]) for x in tj["records"])
    # margins near the target with the quantised gains; the co-simulated move within 5 %
    mq = tj["margins_quantised"]
    assert mq["phase_margin_deg"] == pytest.approx(60.0, abs=3.0)
    assert mq["gain_margin_db"] >= 6.0
    assert tj["predicted"]["move"]["overshoot_pct"] <= 5.0
    sim = tj["simulated"]["move"]
    assert sim["overshoot_pct"] <= 5.0
    # predicted and co-simulated responses agree: within 4 % of the speed RMS
    assert sim["rms_deviation"] < 0.04 * tj["verify"]["speed_mm_s"]
    assert tj["robustness"]["analytic"]["samples"] == 20


def test_tuned_config_loads_in_the_host(wheel):
    _, out, _, tj = wheel
    ini = (out / "config" / "NavAndControl.ini").read_text()
    assert "; --- navkit tune wheel: begin" in ini and "; previous: wheel_kff 180, wheel_kp 400" in ini
    # the verification run used the tuned config: the host sent the tuned gains to the micro
    run = load(tj["simulated"]["run"])
    motion = [m for _, m in run.messages("/micro/config") if m["message"] == "micro_cfg_motion"]
    assert motion
    for k, v in tj["raw"].items():
        assert motion[-1]["fields"][k] == v
    # and `navkit sim --config` takes it directly
    r = _navkit("sim", "--mission", tj["simulated"]["mission"], "--config", out / "config",
                "--out", out / "sim_check", "--no-plot")
    assert r.returncode == 0, r.stderr


def test_log_of_the_same_experiment(wheel, tmp_path):
    _, out, _, tj = wheel
    run = out / "experiment" / "run.mcap"
    r = _navkit("tune", "wheel", "--log", run, "--out", tmp_path / "from_mcap", "--samples", 0)
    assert r.returncode == 0, r.stderr
    tl = json.loads((tmp_path / "from_mcap" / "tune.json").read_text())
    assert tl["model"]["gain_mm_s"] == pytest.approx(tj["model"]["gain_mm_s"], rel=1e-6)
    assert tl["raw"] == tj["raw"] and tl["simulated"] is None
    # the host's datalog of the same run: duty held between its 20 ms rows, the same gain
    logs = sorted((out / "experiment").glob("Data *.txt"))
    assert logs
    r = _navkit("tune", "wheel", "--log", logs[0], "--out", tmp_path / "from_datalog", "--samples", 0)
    assert r.returncode == 0, r.stderr
    td = json.loads((tmp_path / "from_datalog" / "tune.json").read_text())
    assert td["model"]["gain_mm_s"] == pytest.approx(tj["model"]["gain_mm_s"], rel=0.05)
    assert not any(any(x["replayed"]) for x in td["records"])


def test_heading_on_the_tuned_wheels(wheel, tmp_path):
    _, out, _, _ = wheel
    r = _navkit("tune", "heading", "--wheel", out, "--out", tmp_path / "heading", "--samples", 10)
    assert r.returncode == 0, r.stderr
    th = json.loads((tmp_path / "heading" / "tune.json").read_text())
    assert th["margins_quantised"]["phase_margin_deg"] >= 57.0
    assert th["simulated"]["heading_select"]["overshoot_pct"] <= 5.0
    assert th["simulated"]["heading_select"]["rms_deviation"] < 2.0  # deg, over a 90 deg select
    ini = (tmp_path / "heading" / "config" / "NavAndControl.ini").read_text()
    # both blocks: the wheel gains come along from the wheel tuning's config
    assert "navkit tune wheel: begin" in ini and "navkit tune heading: begin" in ini
    assert f"heading_kp = {th['raw']['heading_kp']}" in ini


def test_wheel_on_the_avr_image(tmp_path):
    # processor in the loop: the AVR image in simavr runs its 400 Hz ceiling, the design uses it
    from navkit.sim.harness import fmu_paths

    require_build()
    if not fmu_paths(build_dir(), "avr")[0].exists():
        pytest.skip("the AVR firmware FMU is not built (needs avr-gcc and libsimavr)")
    out = tmp_path / "avr"
    r = _navkit("tune", "wheel", "--mission", repo_root() / "config" / "missions" / "tune_wheels.toml",
                "--firmware", "avr", "--out", out, "--samples", 0)
    assert r.returncode == 0, r.stderr
    tj = json.loads((out / "tune.json").read_text())
    assert tj["targets"]["control_rate_hz"] == 400.0 and tj["source"]["firmware"] == "avr"
    assert tj["margins_quantised"]["phase_margin_deg"] == pytest.approx(60.0, abs=3.0)
    assert tj["simulated"]["move"]["overshoot_pct"] <= 5.0
    assert "; designed at 400 Hz, the rate the avr firmware ran" in (out / "config" / "NavAndControl.ini").read_text()
