"""`navkit sim --plant FMU` (SimOptions.plant_fmu): a plant FMU of the user's instead of
<build>/fmus/navkit_plant.fmu. The built plant given explicitly gives the same run; a plant
that lacks or mistypes a contract variable, an FMI 2.0 plant and one without a binary are
refused up front with the FMU's path and every problem; mission [plant] overrides are
checked against the chosen FMU's parameters."""

import argparse
import re
import shutil
from pathlib import Path

import pytest

from navkit.paths import build_dir
from navkit.sim.harness import SimError, SimOptions, fmu_paths, run
from navkit.sim.mission import MissionError, loads
from navkit.sim.plant import FMI2_UNSUPPORTED
from navkit.sim.results import load
from sim_helpers import require_build, rewrite_fmu, run_mission

pytestmark = pytest.mark.timeout(120)

MISSION = """
duration_s = 3.0
world = "room.txt"
[[command]]
t = 1.5
fwd_cmd = "start"
speed = 300
distance = 300
"""


def _plant() -> Path:
    require_build()
    return fmu_paths(build_dir())[1]


def _without(xml: str, name: str) -> str:
    out, n = re.subn(rf'\n\s*<\w+ name="{name}"[^>]*/>', "", xml)
    assert n == 1, name
    return out


def _cli(*argv) -> int:
    from navkit.sim import cli

    parser = argparse.ArgumentParser()
    cli.add_arguments(parser)
    return cli.run(parser.parse_args([str(a) for a in argv]))


def test_built_plant_given_explicitly_gives_the_same_run(tmp_path_factory, tmp_path, capsys):
    default = run_mission(tmp_path_factory, "plant-default", MISSION)
    mine = shutil.copy(_plant(), tmp_path / "my_plant.fmu")
    (tmp_path / "m.toml").write_text(MISSION)
    assert _cli("--mission", tmp_path / "m.toml", "--out", tmp_path / "out", "--plant", mine,
                "--no-plot") == 0
    assert f"plant     {mine}" in capsys.readouterr().out
    explicit = load(tmp_path / "out")
    assert explicit.summary["plant_fmu"] == str(mine)
    assert default.summary["plant_fmu"] == str(_plant())
    assert explicit.topics == default.topics
    assert explicit.truth[-1]["x_mm"] > 250, "the robot moved"
    strip = lambda m: {k: v for k, v in m.items() if k != "mission_file"}  # noqa: E731
    assert strip(explicit.metadata) == strip(default.metadata)


def test_missing_and_mistyped_variables_are_named(tmp_path, capsys):
    def edit(xml):
        return _without(xml, "motor_right_duty").replace('<Int32 name="gyro_raw"',
                                                         '<Float64 name="gyro_raw"')

    broken = rewrite_fmu(_plant(), tmp_path / "broken.fmu", edit)
    m = loads(MISSION, tmp_path / "m.toml")
    with pytest.raises(SimError) as e:
        run(SimOptions(mission=m, out=tmp_path / "out", plant_fmu=broken, plot=False))
    msg = str(e.value)
    assert msg.startswith(f"{broken}: does not fit the firmware FMU's variables"), msg
    assert "missing motor_right_duty (Float64 input)" in msg, msg
    assert "gyro_raw is Float64 output, expected Int32 output" in msg, msg
    assert msg.count("\n") == 2, "one line per problem"
    assert not (tmp_path / "out").exists()
    (tmp_path / "m.toml").write_text(MISSION)
    assert _cli("--mission", tmp_path / "m.toml", "--out", tmp_path / "out", "--plant", broken) == 1
    assert "missing motor_right_duty" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("case", ["fmi2", "no_binary", "not_a_zip", "no_file", "schema"])
def test_unusable_plant_fmus_are_refused(tmp_path, case):
    if case == "schema":        # a user's plant is checked against the FMI schemas
        fmu = rewrite_fmu(_plant(), tmp_path / "schema.fmu", lambda xml: xml.replace(
            "<fmiModelDescription", '<fmiModelDescription colour="red"', 1))
        want = "attribute 'colour': The attribute 'colour' is not allowed"
    elif case == "fmi2":
        fmu = build_dir() / "fmus" / "navkit_plant_fmi2.fmu"
        if not fmu.exists():
            pytest.skip(f"{fmu} not built")
        want = FMI2_UNSUPPORTED
    elif case == "no_binary":
        fmu = rewrite_fmu(_plant(), tmp_path / "nobin.fmu", drop="binaries/")
        want = "no binary for this platform (binaries/x86_64-linux/navkit_plant.so)"
    elif case == "not_a_zip":
        fmu = tmp_path / "text.fmu"
        fmu.write_text("not an FMU")
        want = "not a readable FMU"
    else:
        fmu, want = tmp_path / "nope.fmu", "no such file (the plant FMU)"
    _plant()
    m = loads(MISSION, tmp_path / "m.toml")
    with pytest.raises(SimError) as e:
        run(SimOptions(mission=m, out=tmp_path / "out", plant_fmu=fmu, plot=False))
    assert str(e.value).startswith(f"{fmu}: ") and want in str(e.value), str(e.value)


def test_plant_overrides_checked_against_the_chosen_fmu(tmp_path):
    """mass_kg is a parameter of the built plant, but not of this one."""
    lean = rewrite_fmu(_plant(), tmp_path / "lean.fmu", lambda xml: _without(xml, "mass_kg"))
    m = loads("duration_s = 1.0\n[plant]\nmass_kg = 10.0\n", tmp_path / "p.toml")
    with pytest.raises(MissionError) as e:
        run(SimOptions(mission=m, out=tmp_path / "out", plant_fmu=lean, plot=False))
    msg = str(e.value)
    assert "p.toml: [plant]: key 'mass_kg'" in msg and f"({lean}) has no such variable" in msg, msg
    run(SimOptions(mission=m, out=tmp_path / "ok", plot=False))   # the built plant has it
    assert (tmp_path / "ok" / "run.mcap").exists()
