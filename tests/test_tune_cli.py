"""`navkit tune` refuses bad inputs with one line naming the place, exit status 1 (2 for a
bad option), never a traceback."""

import json
import subprocess
import sys

from navkit.paths import repo_root


def _tune(*args):
    r = subprocess.run([sys.executable, "-m", "navkit", "tune", *map(str, args)], capture_output=True,
                       text=True, timeout=120)
    assert "Traceback" not in r.stderr, r.stderr
    return r


def _one_line(r, status: int, *needles):
    assert r.returncode == status, (r.returncode, r.stdout, r.stderr)
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 or status == 2, r.stderr
    for n in needles:
        assert n in r.stderr, r.stderr


def test_mission_without_an_experiment(tmp_path):
    r = _tune("wheel", "--mission", repo_root() / "config" / "missions" / "demo.toml", "--out", tmp_path)
    _one_line(r, 1, "demo.toml: no wheel experiment", "excite_mode")


def test_missing_mission(tmp_path):
    r = _tune("wheel", "--mission", tmp_path / "nope.toml", "--out", tmp_path / "o")
    _one_line(r, 1, "nope.toml")


def test_log_that_is_not_a_log(tmp_path):
    bad = tmp_path / "junk.txt"
    bad.write_text("hello\n")
    _one_line(_tune("wheel", "--log", bad, "--out", tmp_path / "o"), 1, "junk.txt", "line 1")
    _one_line(_tune("wheel", "--log", tmp_path / "none.mcap", "--out", tmp_path / "o"), 1, "none.mcap: no such file")
    fake = tmp_path / "cut.mcap"
    fake.write_bytes(b"\x89MCAP0\r\n" + b"\x00" * 5)
    r = _tune("wheel", "--log", fake, "--out", tmp_path / "o")
    # run.mcap's reader warns that the file is cut short, then the one error line
    assert r.returncode == 1 and r.stderr.strip().splitlines()[-1].endswith("cut.mcap: no /micro/data messages")


def test_datalog_without_the_columns(tmp_path):
    log = tmp_path / "Data 01-01-26 00;00;00.txt"
    log.write_text("2\ntime_s 0 600\nspeed_mm_s -1000 1000\n0.0\t0\n0.1\t5\n")
    _one_line(_tune("wheel", "--log", log, "--out", tmp_path / "o"), 1,
              "lacks the column(s) micro_time_ms, micro_status, mc_datalog_sel, mc_datalog0")


def test_datalog_without_an_experiment(tmp_path):
    cols = ["time_s", "micro_time_ms", "micro_status", "mc_datalog_sel"] + [f"mc_datalog{i}" for i in range(4)]
    rows = [f"{k * 0.02}\t{k * 20}\t1\t6\t0\t0\t0\t0" for k in range(50)]
    log = tmp_path / "Data 01-01-26 00;00;01.txt"
    log.write_text(f"{len(cols)}\n" + "".join(f"{c} 0 1\n" for c in cols) + "\n".join(rows) + "\n")
    _one_line(_tune("wheel", "--log", log, "--out", tmp_path / "o"), 1, "no excitation in the log")


def test_bad_options(tmp_path):
    _one_line(_tune("wheel", "--log", "x", "--out", tmp_path, "--pm", "-3"), 2, "--pm")
    _one_line(_tune("wheel", "--log", "x", "--out", tmp_path, "--pm", "95"), 2, "--pm 95")
    _one_line(_tune("wheel", "--out", tmp_path), 2, "--mission --log")
    _one_line(_tune("wheel", "--log", "x", "--out", tmp_path, "--variation", "1.5"), 2, "--variation")


def test_heading_without_a_wheel_tuning(tmp_path):
    _one_line(_tune("heading", "--wheel", tmp_path, "--out", tmp_path / "h"), 1, "tune.json: no such file")
    (tmp_path / "tune.json").write_text(json.dumps({"kind": "heading"}))
    _one_line(_tune("heading", "--wheel", tmp_path, "--out", tmp_path / "h"), 1, "not a wheel tuning's tune.json")


def test_missing_config_folder(tmp_path):
    r = _tune("wheel", "--log", "x.mcap", "--config", tmp_path / "noconf", "--out", tmp_path / "o")
    _one_line(r, 1, "noconf/NavAndControl.ini: no such file")
