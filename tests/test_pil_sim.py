"""Processor in the loop end to end: missions through the real host over its pty with the
AVR image executing in simavr (`navkit sim --firmware avr`, navkit_firmware_avr.fmu),
checked against the same missions with the SIL firmware FMU and the same plant physics
(navkit.compare at each leg's end), plus the PIL run's summary (firmware, control rate,
the profile measured from the running image) and the PIL config of navkit.sim.pil.

The PIL runs use the AVR build's control_rate ceiling (400 Hz: the config's 1000 Hz is
capped by a PIL config); the SIL runs keep the config's 1 kHz (the SIL FMU steps whole
ticks of the harness's 1 ms steps, which 400 Hz is not). docs/pil.md says how closely the
runs agree and why they differ.
"""

import json
import os
import subprocess
import sys

import pytest

from navkit.paths import build_dir, repo_root
from sim_helpers import STRAIGHT, require_build, run_mission

AVR_FMU = build_dir() / "fmus" / "navkit_firmware_avr.fmu"
pytestmark = [pytest.mark.timeout(300),
              pytest.mark.skipif(not AVR_FMU.exists(), reason=f"{AVR_FMU} not built (needs avr-gcc and libsimavr)")]

RATE = 400            # Hz: the AVR image's ceiling
POS_MM, HDG_DEG = 5.0, 0.5

# a leg, a heading select to 90 deg (the gyro's heading) and a leg on the new heading
TURNS = """
duration_s = 9.0
[[command]]
t = 1.5
fwd_cmd = "start"
accel = 600
speed = 400
distance = 500
[[command]]
t = 4.0
turn_mode = "heading_select"
turn_rate = 900
turn_distance = 900
[[command]]
t = 6.5
fwd_cmd = "start"
speed = 300
distance = 300
"""

def pair(tmp_path_factory, name, text):
    """(SIL run, PIL run) of mission `text`."""
    require_build()
    sil = run_mission(tmp_path_factory, f"{name}-sil", text)
    pil = run_mission(tmp_path_factory, f"{name}-pil", text, firmware="avr")
    return sil, pil


def leg_ends(sil, pil):
    from navkit.compare import compare_runs

    return compare_runs(sil.out, pil.out).legs


@pytest.fixture(scope="module")
def straight(tmp_path_factory):
    return pair(tmp_path_factory, "straight", STRAIGHT)


# ---------------------------------------------------------------- the runs agree


def test_straight_leg_agrees_with_sil(straight):
    legs = leg_ends(*straight)
    assert legs, "the compare found no legs"
    for leg in legs:
        assert abs(leg.pos_mm) <= POS_MM and abs(leg.heading_deg) <= HDG_DEG, leg
    sil, pil = straight
    assert pil.truth[-1]["x_mm"] == pytest.approx(700, abs=6)
    assert pil.truth[-1]["x_mm"] == pytest.approx(sil.truth[-1]["x_mm"], abs=POS_MM)


def test_turns_agree_with_sil(tmp_path_factory):
    for leg in leg_ends(*pair(tmp_path_factory, "turns", TURNS)):
        assert abs(leg.pos_mm) <= POS_MM and abs(leg.heading_deg) <= HDG_DEG, leg


def test_demo_agrees_with_sil_at_every_leg_end(tmp_path_factory):
    """The demo mission (`make sim`): drive, heading select, a turning leg, a reverse with a
    heading select across north, servo scans, DIO: every leg's end within 5 mm and 0.5 deg."""
    text = (repo_root() / "config" / "missions" / "demo.toml").read_text()
    legs = leg_ends(*pair(tmp_path_factory, "demo", text))
    assert len(legs) == 5
    for leg in legs:
        assert abs(leg.pos_mm) <= POS_MM and abs(leg.heading_deg) <= HDG_DEG, leg


# a leg cut short by a micro reset (fmi3Reset: the simulated board powers up again from the
# image), then a new leg once the host has configured it again
RESET = """
duration_s = 8.0
[[command]]
t = 1.5
fwd_cmd = "start"
speed = 300
distance = 2000
[[fault]]
t = 3.0
kind = "micro_reset"
[[command]]
t = 6.0
fwd_cmd = "start"
speed = 200
distance = 300
"""


def test_micro_reset_powers_the_board_up_again(tmp_path_factory):
    """The fault resets the AVR FMU: a new board boots the image, the host configures it
    again and the next command drives; the profile counts from the new power-on, and the
    whole run still agrees with SIL at every leg's end."""
    sil, pil = pair(tmp_path_factory, "reset", RESET)
    assert pil.summary["host"]["config_downloads"] >= 2
    prof = pil.summary["firmware_profile"]
    assert prof["prof_resets"] == 0 and prof["prof_ticks"] == pytest.approx(RATE * (8.0 - 3.0), abs=3)
    assert pil.truth[-1]["distance_mm"] - pil.truth_at(5.9)["distance_mm"] == pytest.approx(300, abs=6)
    for leg in leg_ends(sil, pil):
        assert abs(leg.pos_mm) <= POS_MM and abs(leg.heading_deg) <= HDG_DEG, leg


def test_sensors_read_the_same_through_the_image(straight):
    """The planner's sonar and IR ranges and the battery, standing still after the leg
    (t >= 4 s), frame by frame: the image's echo timer and ADC against the SIL board's. The
    image times its own pings, so it may read another ping of the plant (each with its own
    noise, 10 us RMS = 1.7 mm) than the SIL firmware: medians within 3 mm, every frame
    within 12 mm; IR ranges and the battery within one ADC count's worth."""
    sil, pil = straight
    a = {round(t, 3): m for t, m in sil.messages("/planner/data") if t >= 4.0}
    b = {round(t, 3): m for t, m in pil.messages("/planner/data") if t >= 4.0}
    ts = sorted(set(a) & set(b))
    assert len(ts) >= 9
    for k in range(4):
        d = sorted(abs(b[t]["sonar_range"][k] - a[t]["sonar_range"][k]) for t in ts)
        assert d[len(d) // 2] <= 3 and d[-1] <= 12, ("sonar", k, d)
        assert any(a[t]["sonar_range"][k] for t in ts), ("sonar", k, "the room has walls in range")
        d = [abs(b[t]["ir_range"][k] - a[t]["ir_range"][k]) for t in ts]
        assert max(d) <= max(10, 0.03 * max(a[t]["ir_range"][k] for t in ts)), ("ir", k, d)
    for t in ts:
        assert b[t]["battery"] == pytest.approx(a[t]["battery"], abs=3 * 5000 * 3 / 1024), t


# ---------------------------------------------------------------- the PIL run's outputs


def test_summary_names_firmware_rate_and_profile(straight):
    sil, pil = straight
    s, p = sil.summary, pil.summary
    assert (s["firmware"], p["firmware"]) == ("fmu", "avr")
    assert p["firmware_fmu"].endswith("navkit_firmware_avr.fmu")
    assert s["control_rate_hz"] == 1000 and "control_rate_note" not in s and "firmware_profile" not in s
    assert p["control_rate_hz"] == RATE
    assert "NavAndControl.ini:" in p["control_rate_note"] and "control_rate = 1000" in p["control_rate_note"]
    prof = p["firmware_profile"]
    # 400 Hz from reset (the image's ceiling) and after the config: 5 s of ticks
    assert prof["prof_ticks"] == pytest.approx(RATE * p["sim_time_s"], abs=2)
    assert 0 < prof["prof_tick_mean_cycles"] <= prof["prof_tick_worst_cycles"] < 16_000_000 // RATE
    assert 0 < prof["prof_poll_mean_cycles"] <= prof["prof_poll_worst_cycles"]
    assert prof["avr_cycles"] >= round(p["sim_time_s"] * 16_000_000)
    assert 0 < prof["tick_cpu_share_pct"] < 100 and prof["prof_resets"] == 0
    assert pil.metadata["firmware"] == "avr" and pil.metadata["control_rate_hz"] == str(RATE)


def test_pil_config_changes_only_the_rate_line(tmp_path):
    """rate_config: a config within the ceiling is used as it is; one above is copied with
    only [micro_cfg_geometry] control_rate changed, on its line; without the key the spec's
    default applies, and the key is added to the section."""
    import shutil

    from navkit.sim.pil import control_rate, rate_config

    src = tmp_path / "config"
    shutil.copytree(repo_root() / "config", src)
    ini = src / "NavAndControl.ini"
    rate, line = control_rate(src)
    assert rate == 1000 and ini.read_text().splitlines()[line - 1].strip().startswith("control_rate")
    folder, used, note = rate_config(src, RATE, tmp_path / "a")
    assert used == RATE and folder != src and f"{ini}:{line}:" in note
    old, new = ini.read_text().splitlines(), (folder / "NavAndControl.ini").read_text().splitlines()
    assert [i for i, (x, y) in enumerate(zip(old, new)) if x != y] == [line - 1] and len(old) == len(new)
    assert control_rate(folder) == (RATE, line)
    assert (folder / "sensors.ini").read_text() == (src / "sensors.ini").read_text()
    assert rate_config(folder, RATE, tmp_path / "b") == (folder, RATE, None)
    ini.write_text("\n".join(x for x in old if not x.strip().startswith("control_rate")) + "\n")
    folder, used, note = rate_config(src, RATE, tmp_path / "c")
    assert used == RATE and "spec default 1000" in note and control_rate(folder)[0] == RATE


def test_cli_prints_firmware_and_rate_and_names_a_missing_fmu(tmp_path):
    """`navkit sim --firmware avr` prints the FMU, the rate and the note of the PIL config;
    with a build folder without the AVR FMU: one line naming the file and what it needs,
    exit 1; an unknown --firmware is a usage error (2)."""
    require_build()
    mission = tmp_path / "still.toml"
    mission.write_text("duration_s = 1.0\n")
    r = subprocess.run([sys.executable, "-m", "navkit", "sim", "--firmware", "avr", "--mission", str(mission),
                        "--out", str(tmp_path / "still"), "--no-plot"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    lines = {line.split()[0]: line for line in r.stdout.splitlines() if line.strip()}
    assert lines["firmware"].split()[1].endswith("navkit_firmware_avr.fmu") and "(control_rate 400 Hz)" in lines["firmware"]
    assert "NavAndControl.ini:" in lines["note"] and lines["note"].endswith("the run's config says 400 Hz")
    bare = tmp_path / "build"
    (bare / "fmus").mkdir(parents=True)
    r = subprocess.run([sys.executable, "-m", "navkit", "sim", "--firmware", "avr", "--build", str(bare),
                        "--mission", str(mission),  # no commands: no host asked at load
                        "--out", str(tmp_path / "out"), "--no-plot"], capture_output=True, text=True)
    assert r.returncode == 1 and r.stderr.count("\n") == 1, r.stderr
    assert "navkit_firmware_avr.fmu not found" in r.stderr and "avr-gcc" in r.stderr
    r = subprocess.run([sys.executable, "-m", "navkit", "sim", "--firmware", "arm"], capture_output=True, text=True)
    assert r.returncode == 2 and "invalid choice" in r.stderr


def test_summary_json_on_disk_names_the_firmware(straight):
    _, pil = straight
    s = json.loads((pil.out / "summary.json").read_text())
    assert s["firmware"] == "avr" and s["control_rate_hz"] == RATE


@pytest.mark.skipif(not os.environ.get("NAVKIT_PIL_LONG"),
                    reason="opt-in (NAVKIT_PIL_LONG=1): 5 simulated minutes of PIL, about a minute of CPU")
def test_five_minutes_of_the_bench_mission_stay_close(tmp_path_factory):
    """`navkit bench-sim`'s mission for 5 minutes (14 whole cycles of 1 m out, a heading
    select to 180 or 0 deg, 1 m back under heading hold: 28 m of path). Each leg's end
    heading is set by its own heading select or hold, so it stays within 1.5 deg of SIL's;
    the position adds up the small heading differences of every leg, so it is allowed to
    part by 100 mm (0.36 % of the path)."""
    from navkit.sim_bench import bench_mission

    legs = leg_ends(*pair(tmp_path_factory, "bench5", bench_mission(5.0)))
    assert len(legs) == 3 * 14
    for leg in legs:
        assert abs(leg.heading_deg) <= 1.5 and abs(leg.pos_mm) <= 100.0, leg
