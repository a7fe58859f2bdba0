"""navkit-host's command line, config errors, console keys, datalog and real-time mode
(the real binary; no timing assertions: speed belongs to `navkit bench-host`)."""

import os
import signal
import subprocess

import pytest

from navkit import plot
from test_host_util import Micro, host_factory, require_host  # noqa: F401  (fixture)

pytestmark = pytest.mark.timeout(60)


def _run(args, **kw):
    return subprocess.run([str(require_host()), *args], capture_output=True, text=True,
                          timeout=20, **kw)


def test_help_and_unknown_options():
    r = _run(["--help"])
    assert r.returncode == 0 and "--clock real|lockstep" in r.stdout
    r = _run(["--frobnicate"])
    assert r.returncode == 2 and "--frobnicate: unknown option" in r.stderr
    r = _run(["--clock", "sometimes"])
    assert r.returncode == 2 and "real or lockstep" in r.stderr


@pytest.mark.parametrize("text, where", [
    ("[executive]\nframe_rate_hz = fast\n", "frame_rate_hz: 'fast' is not a number"),
    ("[executive]\nwarp = 9\n", "warp: unknown key"),
    ("[teleport]\n", "[teleport]: unknown section"),
    ("[micro_cfg_geometry]\ncounts_per_rev = 3\n", "counts_per_rev: outside the spec's range"),
])
def test_config_errors_name_file_line_and_key(tmp_path, text, where):
    from navkit.paths import repo_root

    (tmp_path / "sensors.ini").write_text((repo_root() / "config/sensors.ini").read_text())
    (tmp_path / "NavAndControl.ini").write_text("; comment\n" + text)
    r = _run(["--config", str(tmp_path), "--port", "/nonexistent", "--shm", f"/nk-cfg-{os.getpid()}"])
    assert r.returncode == 1
    assert f"{tmp_path}/NavAndControl.ini:" in r.stderr and where in r.stderr, r.stderr
    line = r.stderr.split("NavAndControl.ini:")[1].split(":")[0]
    assert int(line) >= 2, r.stderr


def test_missing_config_file(tmp_path):
    r = _run(["--config", str(tmp_path), "--shm", f"/nk-cfg-{os.getpid()}"])
    assert r.returncode == 1 and "NavAndControl.ini:0: file:" in r.stderr


def test_keys_record_a_datalog_and_quit(host_factory):
    h, m = host_factory(), Micro()
    h.configure(m)
    h.proc.stdin.write(b"R")
    h.proc.stdin.flush()
    for k in range(6):
        m.fields["distance"] = 10 * k
        h.step(m)
    h.proc.stdin.write(b"S")
    h.proc.stdin.flush()
    h.step(m)
    h.proc.stdin.write(b"Q")
    h.proc.stdin.flush()
    msgs, flags = h.tick()
    assert flags & 1, "quitting"
    assert msgs[-1][1]["fwd_cmd"] == 5, "the last frame's message is the stop"
    assert h.proc.wait(timeout=10) == 0
    logs = sorted(h.tmp.glob("Data *.txt"))
    assert len(logs) == 1
    assert logs[0].name[5:7].isdigit() and ";" in logs[0].name
    params, rows = plot.read_datalog(logs[0])
    assert params[0][0] == "time_s" and len(rows) == 6, "one row per frame while recording"
    assert [r[2] for r in rows][-1] == 40


def test_record_option_starts_the_datalog(host_factory):
    h, m = host_factory(args=("--record",)), Micro()
    h.step(m)
    h.step(m)
    assert h.stop() == 0
    params, rows = plot.read_datalog(next(h.tmp.glob("Data *.txt")))
    assert len(rows) == 2


def test_real_time_mode_sends_config_and_stops_on_sigint(host_factory):
    h = host_factory(lockstep=False, args=("--rate", "50"))
    assert h.read_available(wait_s=2.0), "the host talks to the port on its own clock"
    h.proc.send_signal(signal.SIGINT)
    assert h.proc.wait(timeout=10) == 0
    assert not os.path.exists("/dev/shm" + h.shm)
    assert "signal 2" in h.output()
