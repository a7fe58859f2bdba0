"""Mission files: loading, and clear errors naming file, entry and key (a mission's
[[command]] entries are judged by the built navkit-host: those tests take `host_converts`)."""

from pathlib import Path

import pytest

from navkit.paths import repo_root
from navkit.sim.mission import MissionError, load, loads
from spec_helpers import micro_cmd_field

GOOD = """
duration_s = 5.0
[plant]
motor_kt = 0.02
[[command]]
t = 1.0
fwd_cmd = "start"
speed = 300
distance = 1000
[[command]]
t = 0.5
turn_mode = 10
turn_distance = 900
[[key]]
t = 0.2
key = "R"
[[fault]]
t = 2.0
kind = "line_noise"
ber = 1e-3
duration_s = 1.0
[[fault]]
t = 3.0
kind = "planner_silent"
"""


def test_good_mission_loads_sorted(host_converts):
    m = loads(GOOD, "good.toml")
    assert m.duration_s == 5.0
    assert [c.t for c in m.commands] == [0.5, 1.0]
    assert m.commands[1].fields == {"fwd_cmd": 1, "speed": 300, "distance": 1000}
    assert m.commands[0].fields == {"turn_mode": 10, "turn_distance": 900}
    assert m.keys[0].key == "R"
    assert m.faults[0].kind == "line_noise" and m.faults[0].params == {"ber": 1e-3, "duration_s": 1.0}
    assert m.faults[1].duration_s is None
    assert m.plant == {"motor_kt": 0.02}


def test_shipped_missions_load(host_converts):
    files = sorted((repo_root() / "config" / "missions").glob("*.toml"))
    assert any(f.name == "demo.toml" for f in files)
    for f in files:
        load(f)


@pytest.mark.parametrize("text, entry, key", [
    ("duration_s = 5\n[[command]]\nt = 6\nfwd_cmd = 1", "[[command]] #1", "'t'"),
    ("duration_s = 5\n[[command]]\nt = 1\nspeeed = 1", "[[command]] #1", "'speeed'"),
    ("duration_s = 5\n[[command]]\nt = 1\n[[command]]\nt = 2\nfwd_cmd = 7", "[[command]] #2", "'fwd_cmd'"),
    ("duration_s = 5\n[[command]]\nt = 1\ndio_active = 4096", "[[command]] #1", "'dio_active'"),
    ("duration_s = 5\n[[command]]\nt = 1\nspeed = 1.5", "[[command]] #1", "'speed'"),
    ("duration_s = 5\n[[command]]\nfwd_cmd = 1", "[[command]] #1", "'t'"),
    ("duration_s = 5\n[[command]]\nt = -1", "[[command]] #1", "'t'"),
    ("duration_s = 5\n[[key]]\nt = 1", "[[key]] #1", "'key'"),
    ("duration_s = 5\n[[key]]\nt = 1\nkey = 'R'\nfoo = 1", "[[key]] #1", "'foo'"),
    ("duration_s = 5\n[[fault]]\nt = 1\nkind = 'zap'", "[[fault]] #1", "'kind'"),
    ("duration_s = 5\n[[fault]]\nt = 1\nkind = 'unplug'", "[[fault]] #1", "'duration_s'"),
    ("duration_s = 5\n[[fault]]\nt = 4\nkind = 'unplug'\nduration_s = 2", "[[fault]] #1", "'duration_s'"),
    ("duration_s = 5\n[[fault]]\nt = 1\nkind = 'line_noise'\nduration_s = 1\nber = 2", "[[fault]] #1", "'ber'"),
    ("duration_s = 5\n[[fault]]\nt = 1\nkind = 'kill_host'\nduration_s = 1", "[[fault]] #1", "'duration_s'"),
    ("duration_s = 5\n[[fault]]\nt = 1\nkind = 'micro_reset'\nber = 0.1", "[[fault]] #1", "'ber'"),
    ("duration_s = 5\nspeed = 3", "bad.toml", "'speed'"),
    ("duration_s = -5", "bad.toml", "'duration_s'"),
    ("[[command]]\nt = 1", "bad.toml", "'duration_s'"),
    ("duration_s = 5\n[plant]\nx = [1, 2]", "[plant]", "'x'"),
])
def test_bad_mission_names_file_entry_key(text, entry, key):
    with pytest.raises(MissionError) as e:
        loads(text, "bad.toml")
    msg = str(e.value)
    assert msg.startswith("bad.toml"), msg
    assert entry in msg and key in msg, msg


def test_missing_file_and_bad_toml(tmp_path: Path):
    with pytest.raises(MissionError, match="cannot read"):
        load(tmp_path / "nope.toml")
    p = tmp_path / "broken.toml"
    p.write_text("duration_s = = 3")
    with pytest.raises(MissionError, match="broken.toml: not valid TOML"):
        load(p)


def test_sim_cli_rejects_bad_mission(tmp_path: Path, capsys):
    import argparse

    from navkit.sim import cli

    p = tmp_path / "bad.toml"
    p.write_text("duration_s = 2\n[[command]]\nt = 1\nfwd_cmd = 1\nsped = 100\n")
    parser = argparse.ArgumentParser()
    cli.add_arguments(parser)
    rc = cli.run(parser.parse_args(["--mission", str(p), "--out", str(tmp_path / "o")]))
    out = capsys.readouterr().err
    assert rc == 1
    assert "bad.toml: [[command]] #1: unknown key 'sped'" in out
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("plant, key, what", [
    ("no_such_parameter = 1.0", "'no_such_parameter'", "no such variable"),
    ("mass_kg = \"heavy\"", "'mass_kg'", "does not fit"),
    ("x_mm = 5.0", "'x_mm'", "not a parameter"),
])
def test_plant_overrides_checked_against_the_plant_fmu(tmp_path: Path, plant, key, what):
    from navkit.paths import build_dir
    from navkit.sim.harness import SimOptions, fmu_paths, run

    if not all(p.exists() for p in fmu_paths(build_dir())):
        pytest.skip("FMUs not built")
    m = loads(f"duration_s = 1.0\n[plant]\n{plant}\n", tmp_path / "p.toml")
    with pytest.raises(MissionError) as e:
        run(SimOptions(mission=m, out=tmp_path / "out", plot=False))
    msg = str(e.value)
    assert "p.toml: [plant]" in msg and key in msg and what in msg, msg
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("key", ["seed", "world_file"])
def test_plant_table_refuses_the_harness_keys(key):
    """seed and world_file come from --seed and `world` (and the metadata records them):
    [plant] may not override them."""
    with pytest.raises(MissionError) as e:
        loads(f"duration_s = 5\n[plant]\n{key} = 3\n", "bad.toml")
    msg = str(e.value)
    assert msg.startswith(f"bad.toml: [plant]: key {key!r} is set by the harness"), msg
    assert ("--seed" if key == "seed" else "`world = ") in msg, msg


def test_planner_silent_may_not_outlast_the_mission():
    with pytest.raises(MissionError, match=r"\[\[fault\]\] #1: key 'duration_s': the fault "
                                           r"ends at 6.0 s, past duration_s = 5.0 s"):
        loads("duration_s = 5\n[[fault]]\nt = 4\nkind = 'planner_silent'\nduration_s = 2\n",
              "bad.toml")
    loads("duration_s = 5\n[[fault]]\nt = 4\nkind = 'planner_silent'\nduration_s = 1\n")


def _run(tmp_path, text, name="p.toml"):
    from navkit.sim.harness import SimOptions, run

    from sim_helpers import require_build

    require_build()
    m = loads(text, tmp_path / name)
    return run(SimOptions(mission=m, out=tmp_path / "out", plot=False))


@pytest.mark.parametrize("plant, key, fmu_text", [
    ("mass_kg = -1.0", "'mass_kg'", "parameter mass_kg = -1 is out of range"),
    ("sonar_beam_deg = 200.0", "'sonar_beam_deg'", "parameter sonar_beam_deg = 200"),
])
def test_bad_plant_value_names_mission_key_and_the_fmu_message(tmp_path: Path, plant, key,
                                                               fmu_text):
    with pytest.raises(MissionError) as e:
        _run(tmp_path, f"duration_s = 1.0\n[plant]\n{plant}\n")
    msg = str(e.value)
    assert msg.startswith(f"{tmp_path / 'p.toml'}: [plant]: key {key}"), msg
    assert fmu_text in msg and "fmi3ExitInitializationMode" in msg, msg
    assert not (tmp_path / "out").exists()


def test_malformed_world_file_names_mission_world_file_and_line(tmp_path: Path):
    (tmp_path / "bent.txt").write_text("# a world\nwall 0 0 1000 0\nwall 1 2 3\n")
    with pytest.raises(MissionError) as e:
        _run(tmp_path, 'duration_s = 1.0\nworld = "bent.txt"\n')
    msg = str(e.value)
    assert msg.startswith(f"{tmp_path / 'p.toml'}: key 'world': "), msg
    assert f"{tmp_path / 'bent.txt'}:3: 'wall' takes 4 numbers" in msg, msg


def test_sim_cli_reports_a_plant_refusal_without_a_traceback(tmp_path: Path, capsys):
    import argparse

    from navkit.sim import cli
    from sim_helpers import require_build

    require_build()
    p = tmp_path / "heavy.toml"
    p.write_text("duration_s = 1.0\n[plant]\nmass_kg = -1.0\n")
    parser = argparse.ArgumentParser()
    cli.add_arguments(parser)
    rc = cli.run(parser.parse_args(["--mission", str(p), "--out", str(tmp_path / "o")]))
    out = capsys.readouterr().err
    assert rc == 1
    assert out.startswith(f"navkit sim: {p}: [plant]: key 'mass_kg'"), out
    assert "Traceback" not in out


@pytest.mark.parametrize("what, entry", [
    ("[[command]]\nt = 0.95\nfwd_cmd = 1", "[[command]] #1"),
    ("[[key]]\nt = 1.0\nkey = 'R'", "[[key]] #1"),
    ("[[fault]]\nt = 0.91\nkind = 'micro_reset'", "[[fault]] #1"),
])
def test_event_after_the_last_frame_start_is_refused(tmp_path: Path, what, entry):
    """duration 1.0 s with 100 ms frames: the last frame starts at 0.9 s; an event after
    it would never happen, so the run refuses it before starting anything."""
    with pytest.raises(MissionError) as e:
        _run(tmp_path, f"duration_s = 1.0\n{what}\n")
    msg = str(e.value)
    assert msg.startswith(f"{tmp_path / 'p.toml'}: {entry}: key 't': "), msg
    assert "last frame of the run starts at 0.9 s" in msg, msg
    assert not (tmp_path / "out").exists()


def test_events_take_effect_at_the_first_frame_at_or_after_t(tmp_path: Path):
    from navkit.sim.results import load as load_run

    _run(tmp_path, "duration_s = 1.0\n[[command]]\nt = 0.25\nspeed = 5\n"
                   "[[command]]\nt = 0.9\nspeed = 7\n[[key]]\nt = 0.81\nkey = 'x'\n")
    r = load_run(tmp_path / "out")
    assert [(round(t, 3), m["speed"]) for t, m in r.messages("/planner/cmd")] == \
        [(0.3, 5), (0.9, 7)]
    assert [round(t, 3) for t, m in r.messages("/events") if m["kind"] == "key"] == [0.9]


# ---- values the host could not convert to a micro_cmd (host/src/navigation.cpp)

def _host_refused_cases():
    """(lisp_cmd fields, key): each value one step outside the micro_cmd range the host
    copies it to, from the spec (int16 words, a servo rate >= 0, a heading 0..3600)."""
    speed, accel = micro_cmd_field("speed"), micro_cmd_field("accel")
    rate, t_accel = micro_cmd_field("turn_rate"), micro_cmd_field("turn_accel")
    p0, p1, p2 = micro_cmd_field("rc5_param0"), micro_cmd_field("rc5_param1"), micro_cmd_field("rc5_param2")
    return [
        ({"fwd_cmd": 1, "speed": 99999999, "distance": 1000}, "speed"),
        ({"fwd_cmd": 1, "speed": speed.max + 1}, "speed"),
        ({"fwd_cmd": 3, "accel": accel.min - 1}, "accel"),
        ({"fwd_cmd": 5, "accel": accel.max + 1}, "accel"),
        ({"turn_mode": 1, "turn_rate": rate.max + 1, "turn_distance": 900}, "turn_rate"),
        ({"turn_mode": 11, "turn_accel": t_accel.min - 1}, "turn_accel"),
        ({"turn_mode": 10, "turn_distance": 3601}, "turn_distance"),
        ({"turn_mode": 10, "turn_distance": -1}, "turn_distance"),
        ({"rc_servo_num": 5, "rc_param0": -1, "rc_param1": 100}, "rc_param0"),
        ({"rc_servo_num": 5, "rc_param0": p0.max + 1}, "rc_param0"),
        ({"rc_servo_num": 5, "rc_param0": 100, "rc_param1": p1.max + 1}, "rc_param1"),
        ({"rc_servo_num": 5, "rc_param0": 100, "rc_param2": p2.min - 1}, "rc_param2"),
    ]


def _host_taken_cases():
    """lisp_cmd fields at the edge of what the host converts, or values it never converts
    (a forward value without a low-level fwd_cmd, a turn angle copied int32 to int32, a
    heading hold's offset, a servo number the micro lacks or a rate of 0)."""
    speed, accel = micro_cmd_field("speed"), micro_cmd_field("accel")
    rate, t_accel, p1 = micro_cmd_field("turn_rate"), micro_cmd_field("turn_accel"), micro_cmd_field("rc0_param1")
    return [
        {"fwd_cmd": 1, "speed": speed.max, "accel": accel.min, "distance": 2000000000},
        {"fwd_cmd": 0, "speed": 99999999},
        {"fwd_cmd": 105, "speed": 99999999, "accel": -99999999},
        {"turn_mode": 1, "turn_rate": rate.max, "turn_accel": t_accel.min,
         "turn_distance": -99999999},
        {"turn_mode": 10, "turn_distance": 3600},
        {"turn_mode": 10, "turn_distance": 0},
        {"turn_mode": 11, "turn_distance": -99999999},
        {"turn_rate": 99999999, "turn_distance": 99999999},
        {"rc_servo_num": 8, "rc_param0": -5, "rc_param1": 99999999},
        {"rc_servo_num": 2, "rc_param0": 0, "rc_param1": 99999999},
        {"rc_servo_num": 7, "rc_param0": 1, "rc_param1": p1.max, "rc_param2": p1.min},
    ]


def _toml(fields: dict, t=1.0) -> str:
    return f"[[command]]\nt = {t}\n" + "".join(f"{k} = {v}\n" for k, v in fields.items())


@pytest.mark.parametrize("fields, key", _host_refused_cases())
def test_value_the_host_cannot_convert_names_file_entry_key_and_range(host_converts, fields, key):
    text = "duration_s = 5\n" + _toml({"fwd_cmd": 1, "speed": 100}, 0.5) + _toml(fields)
    with pytest.raises(MissionError) as e:
        loads(text, "bad.toml")
    msg = str(e.value)
    assert msg.startswith(f"bad.toml: [[command]] #2: key {key!r}: {fields[key]} is outside "), msg
    assert "the host would drop the command" in msg, msg
    cause = ("fwd_cmd", "turn_mode", "rc_servo_num")
    named = [k for k in cause if k in fields]
    assert f"{named[0]} {fields[named[0]]}" in msg, msg     # the field that makes the copy
    if key == "turn_distance":
        assert "outside 0..3600 (deg x 0.1)" in msg and "turn_mode 10 (heading_select)" in msg
    else:
        micro = f"rc5_{key[3:]}" if key.startswith("rc_") else key
        f = micro_cmd_field(micro)
        assert f"outside {f.min}..{f.max} (" in msg and f"micro_cmd.{micro} " in msg, msg


def test_commands_are_judged_by_the_built_host_or_the_load_says_it_cannot(tmp_path: Path):
    """A mission without commands asks no host; one with commands names its first command
    and the host that is not built (one line, never a traceback)."""
    m = loads("duration_s = 5\n[[key]]\nt = 1\nkey = 'R'\n", "m.toml", build=tmp_path)
    assert m.keys[0].key == "R"
    with pytest.raises(MissionError) as e:
        loads("duration_s = 5\n" + _toml({"fwd_cmd": 1, "speed": 100}, 2) + _toml({"speed": 5}),
              "m.toml", build=tmp_path)
    host = tmp_path / "host" / "navkit-host"
    assert str(e.value) == (f"m.toml: [[command]] #1: the host judges the commands and cannot: {host}: not "
                            f"built (cmake --build {tmp_path}); navkit-host converts planner commands")


def test_sim_cli_without_a_built_host_is_one_line(tmp_path: Path):
    import os

    from sim_helpers import navkit_sim

    p = tmp_path / "m.toml"
    p.write_text("duration_s = 2\n[[command]]\nt = 1\nfwd_cmd = 1\n")
    env = {**os.environ, "NAVKIT_BUILD_DIR": str(tmp_path)}
    r = navkit_sim(["--mission", p, "--out", tmp_path / "o"], env=env)
    assert r.returncode == 1
    assert r.stderr == (f"navkit sim: {p}: [[command]] #1: the host judges the commands and cannot: "
                        f"{tmp_path}/host/navkit-host: not built (cmake --build {tmp_path}); navkit-host "
                        f"converts planner commands\n"), r.stderr


@pytest.mark.parametrize("fields", _host_taken_cases())
def test_value_the_host_converts_or_ignores_loads(host_converts, fields):
    m = loads("duration_s = 5\n" + _toml(fields))
    assert m.commands[0].fields == fields


def test_the_checks_ranges_are_the_hosts(tmp_path: Path):
    """One run through the real host: each value the loader takes gives nav_result ok,
    each it refuses (written here past the loader, as a planner of one's own could) gives
    nav_result rejected and the host's console message, and moves nothing."""
    from navkit import protocol
    from navkit.sim.harness import SimOptions, run
    from navkit.sim.mission import Command
    from navkit.sim.results import load as load_run

    from sim_helpers import require_build

    require_build()

    def still(f):       # no distance or angle to go: nothing the robot acts on moves it
        return {k: 0 if k in ("distance", "turn_distance") and f.get("turn_mode") != 10 else v
                for k, v in f.items()}

    # a heading hold needs the micro's heading (rejected before its first micro_data), and a
    # heading select anywhere but here would turn: both checked by loading alone above
    taken = [still(f) for f in _host_taken_cases() if f.get("turn_mode") not in (10, 11)]
    taken.append({"turn_mode": 10, "turn_distance": 0})
    refused = [still(f) for f, _ in _host_refused_cases()]
    refused_keys = [k for _, k in _host_refused_cases()]
    n = len(taken) + len(refused)
    m = loads(f"duration_s = {0.1 * (n + 3):.1f}\n" +
              "".join(_toml(f, round(0.2 + 0.1 * i, 1)) for i, f in enumerate(taken)),
              tmp_path / "edges.toml")
    for i, f in enumerate(refused):
        m.commands.append(Command(round(0.2 + 0.1 * (len(taken) + i), 1), f, f"refused #{i}"))
    run(SimOptions(mission=m, out=tmp_path / "out", plot=False))
    r = load_run(tmp_path / "out")
    tags = [msg["time_tag"] for _, msg in r.messages("/planner/cmd")]
    assert len(tags) == n
    verdict = {d["ack_time_tag"]: d["nav_result"] for _, d in r.messages("/planner/data")}
    codes = protocol.SPEC.enums["nav_result"].values
    high_level = [c for k, c in protocol.SPEC.enums["fwd_cmd"].values.items()
                  if c > micro_cmd_field("fwd_cmd").max]
    want = [codes["not_implemented" if f.get("fwd_cmd") in high_level else "ok"] for f in taken]
    want += [codes["rejected"]] * len(refused)
    assert [verdict.get(tag) for tag in tags] == want
    log = (tmp_path / "out" / "host.log").read_text(errors="replace")
    # one a frame: the console says the first, then at most one a second, counting the
    # ones it held back, and the last one held back at shutdown
    # the host's reason, as mission loading words it (Conversion::text)
    first = refused_keys[0]
    said = f"planner command {tags[len(taken)]} rejected: {first}: {refused[0][first]} is outside "
    assert said in log, log
    last = refused_keys[-1]
    assert f"planner command {tags[-1]} rejected: {last}: {refused[-1][last]} is outside " in log
    assert "more like it" in log
    assert all(abs(row["x_mm"]) < 2 and abs(row["yaw_deg"]) < 1 for row in r.truth)


def test_judge_later_leaves_the_hosts_verdict_to_judged(host_converts):
    """navkit sim loads with judge_later (the host judges while fmpy imports): the
    verdict, taken by judged(), is the MissionError loads raises at once."""
    text = "duration_s = 5\n" + _toml({"fwd_cmd": 1, "speed": 99999999})
    with pytest.raises(MissionError) as at_once:
        loads(text, "bad.toml")
    m = loads(text, "bad.toml", judge_later=True)
    with pytest.raises(MissionError) as later:
        m.judged()
    assert str(later.value) == str(at_once.value)
    assert "key 'speed'" in str(later.value) and "the host would drop" in str(later.value)
    m.judged()                          # taken once
    loads("duration_s = 5\n" + _toml({"fwd_cmd": 1, "speed": 300}), judge_later=True).judged()


def test_judge_later_a_later_tables_error_comes_after_the_hosts_verdict(host_converts):
    """A mission whose commands the host drops and whose [[fault]] is bad fails, with
    judge_later as without, on the command: the host's verdict is taken first."""
    text = ("duration_s = 5\n" + _toml({"fwd_cmd": 1, "speed": 99999999})
            + "[[fault]]\nt = 1\nkind = 'zap'\n")
    with pytest.raises(MissionError) as at_once:
        loads(text, "bad.toml")
    with pytest.raises(MissionError) as later:
        loads(text, "bad.toml", judge_later=True)
    assert str(later.value) == str(at_once.value)
    assert "[[command]] #1: key 'speed'" in str(later.value), later.value


def test_sim_cli_a_mission_the_host_rejects_is_one_line(host_converts, tmp_path: Path, capsys):
    """navkit sim says a command the host would drop in one line, without the file-order
    warnings of a mission it does not run."""
    import argparse

    from navkit.sim import cli

    p = tmp_path / "bad.toml"
    p.write_text("duration_s = 5\n" + _toml({"fwd_cmd": 1, "speed": 300}, 2.0)
                 + _toml({"fwd_cmd": 1, "speed": 99999999}, 1.0))
    parser = argparse.ArgumentParser()
    cli.add_arguments(parser)
    rc = cli.run(parser.parse_args(["--mission", str(p), "--out", str(tmp_path / "o")]))
    err = capsys.readouterr().err
    assert rc == 1
    assert err.startswith(f"navkit sim: {p}: [[command]] #2: key 'speed'") and err.count("\n") == 1, err
    assert not (tmp_path / "o").exists()
