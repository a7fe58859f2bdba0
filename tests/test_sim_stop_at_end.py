"""A stop signal that comes once `navkit sim`'s loop has ended (the shutdown, summary.json,
plot.png) waits until the outputs are closed: the command then says so in one line and
exits 128 + the signal's number, without a traceback, its outputs whole. One that comes
before the run has started is one line as well, and a second one while an interrupted run
closes its outputs waits for them."""

import json
import signal
import subprocess
import sys
import textwrap

from sim_helpers import require_build

# navkit sim as its own process (navkit.cli.main without argv), sending itself a signal
# as each function argv[1] names starts: "rig.SimRig.stop=SIGTERM,harness.run_lockstep=..."
DRIVER = textwrap.dedent("""
    import os, signal, sys
    import navkit.cli
    from navkit.sim import harness, rig

    owners = {"rig.SimRig": rig.SimRig, "harness": harness}
    for spec in sys.argv[1].split(","):
        where, name = spec.split("=")
        owner, attr = where.rsplit(".", 1)
        def signalled(*a, _f=getattr(owners[owner], attr), _s=signal.Signals[name], **k):
            os.kill(os.getpid(), _s)
            return _f(*a, **k)
        setattr(owners[owner], attr, signalled)

    sys.argv = ["navkit", *sys.argv[2:]]
    raise SystemExit(navkit.cli.main())
""")


def _sim(tmp_path, signals: str):
    """Run a 1 s mission with `signals` (DRIVER's argv[1]); the process and its output folder."""
    require_build()
    driver, mission, out = tmp_path / "driver.py", tmp_path / "m.toml", tmp_path / "out"
    driver.write_text(DRIVER)
    mission.write_text("duration_s = 1.0\n")
    done = subprocess.run([sys.executable, str(driver), signals, "sim", "-m", str(mission), "-o", str(out),
                           "--no-progress"], capture_output=True, text=True, timeout=60)
    return done, out


def test_a_stop_signal_at_the_runs_end_waits_for_the_outputs(tmp_path):
    done, out = _sim(tmp_path, "rig.SimRig.stop=SIGTERM")
    assert done.returncode == 128 + signal.SIGTERM, done.stderr
    assert "Traceback" not in done.stderr, done.stderr
    assert done.stderr.strip().splitlines()[-1] == (f"navkit sim: stopped by SIGTERM as the run "
                                                    f"ended: its outputs are closed in {out}/")
    summary = json.loads((out / "summary.json").read_text())
    assert "interrupted" not in summary and summary["sim_time_s"] == 1.0, summary
    assert (out / "plot.png").stat().st_size > 0 and (out / "run.mcap").stat().st_size > 0


def test_a_stop_signal_before_the_run_is_one_line(tmp_path):
    done, out = _sim(tmp_path, "rig.SimRig.__init__=SIGTERM")
    assert done.returncode == 128 + signal.SIGTERM, done.stderr
    assert done.stderr == "navkit sim: stopped by SIGTERM before the run started\n", done.stderr
    assert not out.exists()


def test_a_second_stop_signal_waits_for_the_interrupted_runs_outputs(tmp_path):
    done, out = _sim(tmp_path, "harness.run_lockstep=SIGTERM,rig.SimRig.stop=SIGHUP")
    assert done.returncode == 128 + signal.SIGTERM, done.stderr
    assert "Traceback" not in done.stderr, done.stderr
    assert done.stderr.strip().splitlines()[-1].startswith("navkit sim: interrupted by SIGTERM at t = "), \
        done.stderr
    assert json.loads((out / "summary.json").read_text())["interrupted"]["signal"] == "SIGTERM"
