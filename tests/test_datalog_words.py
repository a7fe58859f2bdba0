"""The micro datalog selection (micro_cmd word 44) from its three sources through the real
host: the INI key [executive] mc_datalog at start-up, the console key l (the next selection,
after the last back to none) and the planner's lisp_cmd.mc_datalog_cmd (0 keeps the current
one); the micro reports the selection in force (micro_data.mc_datalog_sel) and fills the
words; a bad INI value stops the host with file:line: key."""

import re
import shutil
import subprocess

import pytest

from navkit import protocol
from navkit.paths import build_dir, repo_root
from navkit.sim.harness import host_path
from sim_helpers import require_build, run_mission
from spec_helpers import FWD_CMD

pytestmark = pytest.mark.timeout(180)

SEL = protocol.SPEC.enums["mc_datalog"].values

MISSION = """
duration_s = 4.0
[[key]]
t = 0.5
key = "l"
[[command]]
t = 1.0
mc_datalog_cmd = "heading"
[[command]]
t = 1.5
fwd_cmd = "start"
speed = 100
distance = 50
[[key]]
t = 2.0
key = "l"
[[key]]
t = 2.5
key = "L"
[[command]]
t = 3.0
mc_datalog_cmd = "fwd_profile"
"""


def _config_with(tmp_path, line: str):
    """A copy of config/ with `line` after [executive]'s dio_default."""
    cfg = tmp_path / "config"
    shutil.copytree(repo_root() / "config", cfg)
    ini = cfg / "NavAndControl.ini"
    text = ini.read_text()
    text = re.sub(r"(?m)^mc_datalog = .*\n", "", text)
    ini.write_text(re.sub(r"(?m)^(dio_default = .*\n)", lambda m: m.group(1) + line + "\n", text, count=1))
    return cfg


def _changes(values):
    """The sequence of values with repeats collapsed."""
    out = []
    for v in values:
        if not out or out[-1] != v:
            out.append(v)
    return out


def test_ini_key_console_key_and_planner_word_reach_word_44(tmp_path_factory):
    cfg = _config_with(tmp_path_factory.mktemp("cfg"), "mc_datalog = 2")
    r = run_mission(tmp_path_factory, "datalog-words", MISSION, config_dir=cfg)
    sent = [m["mc_datalog_cmd"] for _, m in r.messages("/micro/cmd")]
    # INI 2 (wheel_right); l -> 3; the planner's heading (5); its next command's 0 keeps 5;
    # l -> 6 (wheels); L -> 0 (after the last: none); the planner's fwd_profile (3)
    assert _changes(sent) == [SEL["wheel_right"], SEL["fwd_profile"], SEL["heading"], SEL["wheels"],
                              SEL["none"], SEL["fwd_profile"]]
    # the micro runs each and says so
    reported = [m["mc_datalog_sel"] for _, m in r.messages("/micro/data")]
    assert _changes(reported)[-6:] == _changes(sent)
    # while heading was selected, the words are the heading's (deg x 10) as micro_data says
    during = [m for t, m in r.messages("/micro/data") if 1.3 <= t <= 1.9]
    assert during and all(m["mc_datalog_sel"] == SEL["heading"] and m["mc_datalog"][0] == m["heading"]
                          for m in during)
    # the console said which selection each key chose
    log = (r.out / "host.log").read_text()
    assert "micro datalog selection 3 " in log and "micro datalog selection 0 " in log


@pytest.mark.parametrize("value", ["7", "-1", "wheels", "0x2"])
def test_bad_ini_value_is_refused_naming_the_line(tmp_path, value):
    require_build()
    cfg = _config_with(tmp_path, f"mc_datalog = {value}")
    line = next(i for i, ln in enumerate((cfg / "NavAndControl.ini").read_text().splitlines(), 1)
                if ln.startswith("mc_datalog ="))
    p = subprocess.run([str(host_path(build_dir())), "--config", str(cfg), "--port", "/dev/null/none"],
                       capture_output=True, text=True, timeout=30, stdin=subprocess.DEVNULL)
    assert p.returncode == 1
    err = p.stderr.strip().splitlines()
    assert len(err) == 1 and f"NavAndControl.ini:{line}: mc_datalog: " in err[0], p.stderr


RESET = """
duration_s = 3.0
[[command]]
t = 0.5
mc_datalog_cmd = "wheels"
[[fault]]
t = 1.5
kind = "micro_reset"
"""


def test_a_reset_micro_gets_the_selection_back(tmp_path_factory):
    """A micro reset forgets the selection (none from reset); the host's stop that replaces
    its last command carries it, so the micro reports it again once configured."""
    r = run_mission(tmp_path_factory, "datalog-reset", RESET)
    reported = [(t, m["mc_datalog_sel"]) for t, m in r.messages("/micro/data")]
    assert _changes([s for _, s in reported]) == [SEL["none"], SEL["wheels"], SEL["none"], SEL["wheels"]]
    back = next(t for t, s in reported if t > 1.5 and s == SEL["wheels"])
    assert back < 2.5
    cmds = [m for t, m in r.messages("/micro/cmd") if t > 1.5]
    assert any(m["fwd_cmd"] == FWD_CMD["stop"] and m["mc_datalog_cmd"] == SEL["wheels"] for m in cmds)
