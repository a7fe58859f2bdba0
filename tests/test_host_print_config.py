"""`navkit-host --config PATH --print-config`: the host's effective configuration as JSON
(every key's value after defaults and command-line overrides, and the file:line, option or
"default" it came from), and navkit.hostconfig, the one Python door to it."""

import json
from pathlib import Path

import pytest

from navkit import protocol
from navkit.hostconfig import HostConfigError, effective_config, header_line, origin_line, value
from navkit.paths import repo_root
from host_helpers import run_host

CONFIG = repo_root() / "config"


def _host(*args):
    return run_host(args)


def _print(path, *args) -> dict:
    r = _host("--config", path, "--print-config", *args)
    assert r.returncode == 0 and r.stderr == "", r.stderr
    return json.loads(r.stdout)


def _written(path):
    """{(section, key): (value text, line)} of the INI at `path`: the test's own reading of
    the shipped files' plain 'key = value' lines (the oracle the host is held to)."""
    out, section = {}, None
    for n, line in enumerate(path.read_text().splitlines(), 1):
        s = line.strip()
        if not s or s[0] in ";#":
            continue
        if s.startswith("["):
            section = s[1:s.index("]")].lower()
            continue
        key, _, text = s.partition("=")
        out[(section, key.strip().lower())] = (text.split(";")[0].strip(), n)
    return out


def _same(shown, text: str) -> bool:
    """Whether the JSON value `shown` is the INI's `text` (numbers by value, 0/1 keys as
    booleans, a per-servo key's one value for all eight)."""
    if isinstance(shown, bool):
        return shown == (text == "1")
    if isinstance(shown, list):
        parts = [int(p, 0) for p in text.split(",")]
        return shown == (parts * 8 if len(parts) == 1 else parts)
    if isinstance(shown, (int, float)):
        return shown == (int(text, 16) if text.lower().startswith("0x") else float(text))
    return shown == text


def test_every_key_of_the_shipped_files_with_its_value_and_line():
    got = _print(CONFIG)
    files = [f"{CONFIG}/NavAndControl.ini", f"{CONFIG}/sensors.ini"]
    assert got["files"] == files
    shown = {(s, k): v for s, keys in got["sections"].items() for k, v in keys.items()}
    written = {}
    for f in files:
        written.update({k: (text, f"{f}:{n}") for k, (text, n) in _written(Path(f)).items()})
    # the shipped files list every key the host knows, each once
    assert set(shown) == set(written)
    for k, (text, where) in written.items():
        assert shown[k]["from"] == where, k
        assert _same(shown[k]["value"], text), (k, shown[k]["value"], text)
    ini = _written(CONFIG / "NavAndControl.ini")
    line = next(n for n, ln in enumerate((CONFIG / "NavAndControl.ini").read_text().splitlines(), 1)
                if ln.strip() == "[micro_cfg_motion]")
    assert got["headers"]["micro_cfg_motion"] == f"{CONFIG}/NavAndControl.ini:{line}"
    assert ini[("animation", "file")][0] == shown[("animation", "file")]["value"] == "Animation.ini"


def test_keys_left_out_are_the_defaults(tmp_path):
    """A folder with only section headers: every key 'default', the micro's config the
    spec's defaults, the executive's the host's (10 Hz, /navkit)."""
    (tmp_path / "NavAndControl.ini").write_text("[executive]\n[micro_cfg_motion]\n")
    (tmp_path / "sensors.ini").write_text("; nothing\n")
    got = _print(tmp_path)
    assert all(v["from"] == "default" for keys in got["sections"].values() for v in keys.values())
    assert got["headers"] == {"executive": f"{tmp_path}/NavAndControl.ini:1",
                              "micro_cfg_motion": f"{tmp_path}/NavAndControl.ini:2"}
    for msg in ("micro_cfg_geometry", "micro_cfg_motion", "micro_cfg_io"):
        want = protocol.defaults(msg)
        assert got["sections"][msg] and set(got["sections"][msg]) <= set(want)
        for key, shown in got["sections"][msg].items():
            d = want[key]
            assert shown["value"] == (list(d) if isinstance(d, (list, tuple)) else d), (msg, key)
    ex = got["sections"]["executive"]
    assert (ex["frame_rate_hz"]["value"], ex["shm_name"]["value"], ex["record"]["value"]) == (10, "/navkit", False)


def test_the_command_line_wins(tmp_path):
    port = 'odd "port" \\ name'
    got = _print(CONFIG, "--rate", "20", "--port", port, "--record", "--shm", "/nk-pc", "--log-dir", tmp_path)
    s = got["sections"]
    assert s["executive"]["frame_rate_hz"] == {"value": 20, "from": "--rate"}
    assert s["micro"]["port"] == {"value": port, "from": "--port"}
    assert s["executive"]["record"] == {"value": True, "from": "--record"}
    assert s["executive"]["shm_name"] == {"value": "/nk-pc", "from": "--shm"}
    assert s["executive"]["log_dir"] == {"value": str(tmp_path), "from": "--log-dir"}
    assert s["micro"]["baud"]["from"].startswith(f"{CONFIG}/NavAndControl.ini:"), "the others: the file's"
    got = _print(CONFIG, "--frame-ms", "50")
    assert got["sections"]["executive"]["frame_rate_hz"] == {"value": 20, "from": "--frame-ms"}


def _copy(tmp_path, old: str, new: str):
    for name in ("NavAndControl.ini", "sensors.ini"):
        (tmp_path / name).write_text((CONFIG / name).read_text())
    p = tmp_path / "NavAndControl.ini"
    text = p.read_text()
    assert f"\n{old}\n" in text
    p.write_text(text.replace(f"\n{old}\n", f"\n{new}\n"))
    return p, 1 + p.read_text().splitlines().index(new)


def test_errors_name_the_place_and_print_nothing(tmp_path):
    p, line = _copy(tmp_path, "wheel_kp = 400", "wheel_kp = fast")
    r = _host("--config", tmp_path, "--print-config")
    assert (r.returncode, r.stdout) == (1, "")
    assert r.stderr == f"navkit-host: {p}:{line}: wheel_kp: 'fast' is not a decimal integer\n", r.stderr
    # the frame-vs-watchdog rule is the host's, for the INI's rate and for a frame given
    p, line = _copy(tmp_path, "watchdog_timeout = 300", "watchdog_timeout = 150")
    r = _host("--config", tmp_path, "--print-config")
    assert r.returncode == 1 and r.stderr.startswith(
        f"navkit-host: {p}:{line}: watchdog_timeout: a frame of 100 ms at 10 Hz needs "), r.stderr
    r = _host("--config", CONFIG, "--print-config", "--frame-ms", "150")
    assert r.returncode == 2 and r.stderr.startswith(
        "navkit-host: --frame-ms: a frame of 150 ms needs [micro_cfg_motion] watchdog_timeout above two "
        "frames (300 ms), not 300 ms"), r.stderr
    for args, said in ((["--clock", "real"], "--clock has no effect with --print-config"),
                       (["--rate", "20", "--frame-ms", "50"], "--rate and --frame-ms both set the frame"),
                       (["--frame-ms", "0.5"], "--frame-ms: 0.5: not a frame of 1..10000 ms")):
        r = _host("--config", CONFIG, "--print-config", *args)
        assert r.returncode == 2 and r.stdout == "" and said in r.stderr, r.stderr
    r = _host("--config", tmp_path / "none", "--print-config")
    assert r.returncode == 1 and f"{tmp_path}/none/NavAndControl.ini:0: file: " in r.stderr


def test_one_file_alone(tmp_path):
    """--config FILE: that file's sections only; a folder without sensors.ini is fine."""
    (tmp_path / "NavAndControl.ini").write_text("[micro_cfg_motion]\nwheel_kp = 500\n")
    got = _print(tmp_path / "NavAndControl.ini")
    assert got["files"] == [f"{tmp_path}/NavAndControl.ini"]
    assert "battery" not in got["sections"] and "micro_cfg_motion" in got["sections"]
    assert got["sections"]["micro_cfg_motion"]["wheel_kp"] == {"value": 500, "from": f"{tmp_path}/NavAndControl.ini:2"}
    assert "micro_cfg_io" in got["sections"] and "micro_cfg_io" not in got["headers"]
    assert _host("--config", tmp_path, "--print-config").returncode == 1, "the folder needs sensors.ini"


def test_effective_config_asks_the_host_once_per_content(tmp_path):
    p, line = _copy(tmp_path, "wheel_kp = 400", "wheel_kp = 401")
    cfg = effective_config(tmp_path)
    assert value(cfg, "micro_cfg_motion", "wheel_kp") == 401
    assert origin_line(cfg, "micro_cfg_motion", "wheel_kp") == line
    assert origin_line(cfg, "micro_cfg_motion", "wheel_kd") is not None
    assert header_line(cfg, "micro_cfg_motion") == 1 + p.read_text().splitlines().index("[micro_cfg_motion]")
    assert effective_config(tmp_path) is cfg, "cached"
    # a rewrite of the same size at once (the mtime may not move): asked again
    p.write_text(p.read_text().replace("wheel_kp = 401", "wheel_kp = 402"))
    assert value(effective_config(tmp_path), "micro_cfg_motion", "wheel_kp") == 402
    p.write_text(p.read_text().replace("wheel_kp = 402", "wheel_kp = 4x2"))
    with pytest.raises(HostConfigError) as e:
        effective_config(tmp_path)
    assert e.value.status == 1 and str(e.value) == f"{p}:{line}: wheel_kp: '4x2' is not a decimal integer"
    with pytest.raises(HostConfigError) as e:
        effective_config(CONFIG, build=tmp_path)
    assert e.value.status == 0 and "not built" in str(e.value)


def test_the_harness_takes_the_hosts_verdict(tmp_path):
    """navkit.sim.harness.host_config: the host's answer, or its message as a SimError."""
    from navkit.sim.harness import SimError, frame_period, host_config

    assert frame_period(CONFIG) == 0.1
    assert value(host_config(CONFIG, frame_s=0.05), "executive", "frame_rate_hz") == 20
    with pytest.raises(SimError, match=r"^--frame-ms: a frame of 200 ms needs \[micro_cfg_motion\] watchdog_timeout"):
        host_config(CONFIG, frame_s=0.2)


def test_sweep_refuses_a_config_the_host_refuses_before_any_run(tmp_path, capsys):
    from navkit.cli import main

    p, line = _copy(tmp_path, "wheel_kp = 400", "wheel_kp = -1")
    rc = main(["sweep", "--config", str(tmp_path), "--seeds", "2", "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert rc == 1 and err == f"navkit sweep: {p}:{line}: wheel_kp: -1 is outside 0..65535\n", err
    assert not (tmp_path / "out").exists()


def test_the_micro_cfg_sections_are_the_specs_config_fields(tmp_path):
    """The host's [micro_cfg_*] keys come from the spec (navkit_proto.h
    NAVKIT_<MSG>_CONFIG_FIELDS): one key per field but the framing, hex only where the
    field's units are bits, a sign refused at its own line by the spec's check."""
    (tmp_path / "NavAndControl.ini").write_text("[micro_cfg_geometry]\n[micro_cfg_motion]\n[micro_cfg_io]\n")
    (tmp_path / "sensors.ini").write_text("; nothing\n")
    got = _print(tmp_path)
    for msg in ("micro_cfg_geometry", "micro_cfg_motion", "micro_cfg_io"):
        fields = protocol.SPEC.messages[msg].fields
        assert list(got["sections"][msg]) == sorted(f.name for f in fields
                                                    if f.name not in ("time_tag", "msg_type", "spec_hash"))
    for f in protocol.SPEC.messages["micro_cfg_io"].fields[3:]:
        ini = tmp_path / "NavAndControl.ini"
        ini.write_text(f"[micro_cfg_io]\n{f.name} = 0x{max(f.min, 1):X}\n")
        r = _host("--config", tmp_path, "--print-config")
        if f.units == "bits":
            assert r.returncode == 0 and json.loads(r.stdout)["sections"]["micro_cfg_io"][f.name]["value"] == max(f.min, 1)
        else:
            assert r.returncode == 1 and r.stderr.startswith(f"navkit-host: {ini}:2: {f.name}: "), r.stderr
    (tmp_path / "NavAndControl.ini").write_text("[micro_cfg_geometry]\n\nmotor_right_sign = 0\n")
    r = _host("--config", tmp_path, "--print-config")
    assert (r.returncode, r.stderr) == (1, f"navkit-host: {tmp_path}/NavAndControl.ini:3: motor_right_sign: '0' is "
                                           "not 1 or -1 (the micro refuses any other sign)\n")


def test_an_early_ask_is_the_answer_of_the_files_then(tmp_path):
    """ask_config starts the host at once (navkit sim: beside the mission's loading);
    effective_config takes its answer when the files are unchanged, asks again when they
    changed, and a refusal asked early is the same refusal; forget_asks ends the rest."""
    from navkit import hostconfig

    p, line = _copy(tmp_path, "wheel_kp = 400", "wheel_kp = 401")
    hostconfig.ask_config(tmp_path, frame_ms=50)
    cfg = effective_config(tmp_path, frame_ms=50)
    assert value(cfg, "micro_cfg_motion", "wheel_kp") == 401
    assert value(cfg, "executive", "frame_rate_hz") == 20
    assert effective_config(tmp_path, frame_ms=50) is cfg
    hostconfig.ask_config(tmp_path)
    p.write_text(p.read_text().replace("wheel_kp = 401", "wheel_kp = 402"))   # after the ask
    assert value(effective_config(tmp_path), "micro_cfg_motion", "wheel_kp") == 402
    p.write_text(p.read_text().replace("wheel_kp = 402", "wheel_kp = 4x2"))
    hostconfig.ask_config(tmp_path)
    with pytest.raises(HostConfigError) as e:
        effective_config(tmp_path)
    assert e.value.status == 1 and str(e.value) == f"{p}:{line}: wheel_kp: '4x2' is not a decimal integer"
    hostconfig.ask_config(tmp_path, frame_ms=30)    # never taken
    hostconfig.forget_asks()
    assert not hostconfig._asking
