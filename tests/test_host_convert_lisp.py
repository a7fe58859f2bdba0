"""`navkit-host --convert-lisp`: the host's lisp_cmd -> micro_cmd conversion (Navigation::convert)
as a filter of JSON lines, and navkit.hostconfig.convert_lisp, its client."""

import json

import pytest

from navkit import protocol
from host_helpers import run_host
from spec_helpers import FWD_CMD, TURN_CMD, micro_cmd_field


def _host(*args, stdin=""):
    return run_host(args, input=stdin, timeout=30)


def _convert(*commands):
    r = _host("--convert-lisp", stdin="".join(json.dumps(c) + "\n" for c in commands))
    assert r.returncode == 0 and r.stderr == "", r.stderr
    return [json.loads(line) for line in r.stdout.splitlines()]


def test_converted_commands_give_the_micro_cmd_the_host_sends(host_converts):
    ok, hold, servo, high = _convert(
        {"fwd_cmd": 1, "accel": 400, "speed": 250, "distance": -2000000000},
        {"turn_mode": 11, "turn_distance": -300, "turn_rate": 200, "heading": 100},
        {"rc_servo_num": 7, "rc_param0": 300, "rc_param1": 800, "rc_param2": 9999},
        {"fwd_cmd": 105, "turn_mode": 1, "turn_distance": 900})
    assert ok["nav_result"] == "ok"
    m = ok["micro_cmd"]
    assert set(m) == {f.name for f in protocol.SPEC.messages["micro_cmd"].fields}
    assert (m["fwd_cmd"], m["accel"], m["speed"], m["distance"], m["turn_cmd"]) == \
        (FWD_CMD["start"], 400, 250, -2000000000, TURN_CMD["none"])
    # a hold: HdgSel to the heading given + the offset, wrapped to 0..3599
    assert (hold["micro_cmd"]["turn_cmd"], hold["micro_cmd"]["turn_distance"]) == (TURN_CMD["hdg_sel"], 3400)
    assert hold["micro_cmd"]["turn_rate"] == 200
    # rc7's words follow mc_datalog_cmd: the slot of servo 7, no other
    assert [servo["micro_cmd"][f"rc7_param{i}"] for i in range(3)] == [300, 800, 9999]
    assert all(servo["micro_cmd"][f"rc{n}_param0"] == 0 for n in range(7))
    assert high["nav_result"] == "not_implemented"
    assert (high["micro_cmd"]["fwd_cmd"], high["micro_cmd"]["turn_cmd"]) == \
        (FWD_CMD["none"], TURN_CMD["turn"])


def test_each_refusal_says_why(host_converts):
    speed, rc_rate = micro_cmd_field("speed"), micro_cmd_field("rc2_param0")
    rng, servo, sel, hold, lisp = _convert(
        {"fwd_cmd": 3, "speed": speed.max + 1},
        {"rc_servo_num": 2, "rc_param0": -1},
        {"turn_mode": 10, "turn_distance": 3601},
        {"turn_mode": 11, "turn_distance": 5},
        {"fwd_cmd": 2})
    assert rng == {"nav_result": "rejected", "refusal": "range", "lisp_field": "speed", "value": speed.max + 1,
                   "micro_field": "speed", "min": speed.min, "max": speed.max,
                   "text": f"{speed.max + 1} is outside {speed.min}..{speed.max} (mm/s), the range of "
                           f"micro_cmd.speed it is copied to for fwd_cmd 3 (modify)"}
    assert (servo["refusal"], servo["lisp_field"], servo["micro_field"]) == ("range", "rc_param0", "rc2_param0")
    assert (servo["min"], servo["max"]) == (rc_rate.min, rc_rate.max)
    assert servo["text"].endswith("for rc_servo_num 2")
    assert (sel["refusal"], sel["lisp_field"], sel["value"]) == ("heading_range", "turn_distance", 3601)
    assert sel["text"] == "3601 is outside 0..3600 (deg x 0.1), the headings of turn_mode 10 (heading_select)"
    assert (hold["refusal"], hold["lisp_field"]) == ("heading_missing", "turn_mode")
    assert "needs the micro's current heading" in hold["text"]
    # outside lisp_cmd's own spec: ProcessCommands refuses it before Navigation
    assert (lisp["refusal"], lisp["lisp_field"], lisp["value"]) == ("lisp_range", "fwd_cmd", 2)


@pytest.mark.parametrize("line, where", [
    ('{"fwd_cmd": 1, "sped": 3}', 'byte 15: "sped": not a lisp_cmd field'),
    ('{"fwd_cmd": 1.5}', 'byte 12: "fwd_cmd": expected an integer'),
    ('{"fwd_cmd": 1, "fwd_cmd": 3}', 'byte 15: "fwd_cmd" given twice'),
    ('[1, 2]', "byte 0: expected '{'"),
    ('{"speed": 1} x', "byte 13: text after the object"),
    ('{"heading": 3600}', 'byte 1: "heading": 3600 is outside 0..3599'),
])
def test_a_line_that_is_no_command_ends_the_run_naming_line_and_byte(host_converts, line, where):
    r = _host("--convert-lisp", stdin='{"fwd_cmd": 1}\n' + line + '\n{"fwd_cmd": 5}\n')
    assert r.returncode == 1
    assert r.stderr.startswith(f"navkit-host: --convert-lisp: stdin:2: {where}"), r.stderr
    assert len(r.stdout.splitlines()) == 1, "the line before it answered, none after"


def test_other_options_are_refused(host_converts):
    r = _host("--convert-lisp", "--config", "config")
    assert r.returncode == 2
    assert r.stderr.startswith("navkit-host: --config has no effect with --convert-lisp"), r.stderr


def test_client_asks_once_and_caches(host_converts):
    from navkit.hostconfig import convert_lisp

    cmds = [{"fwd_cmd": 1, "speed": 40000}, {"turn_mode": 1, "turn_distance": 900}]
    first = convert_lisp(cmds)
    assert [v["nav_result"] for v in first] == ["rejected", "ok"]
    assert convert_lisp(cmds) is first


def test_client_without_a_host_says_so(tmp_path):
    from navkit.hostconfig import HostConfigError, convert_lisp

    with pytest.raises(HostConfigError) as e:
        convert_lisp([{"fwd_cmd": 1}], build=tmp_path)
    assert e.value.status == 0 and str(e.value).startswith(f"{tmp_path}/host/navkit-host: not built"), e.value
