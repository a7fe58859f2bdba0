"""A stop signal that comes once `navkit sim`'s loop has ended (the shutdown, summary.json,
plot.png) waits until the outputs are closed: the command then says so in one line and
exits 128 + the signal's number, without a traceback, its outputs whole. One that comes
before the run has started is one line as well."""

import json
import signal
import subprocess
import sys
import textwrap

from sim_helpers import require_build

# navkit sim as its own process (navkit.cli.main without argv), sending itself SIGTERM as
# SimRig's method argv[1] (stop: the shutdown, __init__: the run's checks) starts
DRIVER = textwrap.dedent("""
    import os, signal, sys
    import navkit.cli
    from navkit.sim import rig

    method = getattr(rig.SimRig, sys.argv[1])
    def signalled(self, *a, **k):
        os.kill(os.getpid(), signal.SIGTERM)
        method(self, *a, **k)
    setattr(rig.SimRig, sys.argv[1], signalled)
    del sys.argv[1]

    sys.argv = ["navkit", *sys.argv[1:]]
    raise SystemExit(navkit.cli.main())
""")


def test_a_stop_signal_at_the_runs_end_waits_for_the_outputs(tmp_path):
    require_build()
    driver, mission, out = tmp_path / "driver.py", tmp_path / "m.toml", tmp_path / "out"
    driver.write_text(DRIVER)
    mission.write_text("duration_s = 1.0\n")
    done = subprocess.run([sys.executable, str(driver), "stop", "sim", "-m", str(mission), "-o", str(out),
                           "--no-progress"], capture_output=True, text=True, timeout=60)
    assert done.returncode == 128 + signal.SIGTERM, done.stderr
    assert "Traceback" not in done.stderr, done.stderr
    assert done.stderr.strip().splitlines()[-1] == (f"navkit sim: stopped by SIGTERM as the run "
                                                    f"ended: its outputs are closed in {out}/")
    summary = json.loads((out / "summary.json").read_text())
    assert "interrupted" not in summary and summary["sim_time_s"] == 1.0, summary
    assert (out / "plot.png").stat().st_size > 0 and (out / "run.mcap").stat().st_size > 0


def test_a_stop_signal_before_the_run_is_one_line(tmp_path):
    require_build()
    driver, mission, out = tmp_path / "driver.py", tmp_path / "m.toml", tmp_path / "out"
    driver.write_text(DRIVER)
    mission.write_text("duration_s = 1.0\n")
    done = subprocess.run([sys.executable, str(driver), "__init__", "sim", "-m", str(mission), "-o",
                           str(out), "--no-progress"], capture_output=True, text=True, timeout=60)
    assert done.returncode == 128 + signal.SIGTERM, done.stderr
    assert done.stderr == "navkit sim: stopped by SIGTERM before the run started\n", done.stderr
    assert not out.exists()


# navkit sim sending itself SIGTERM as its loop starts and SIGHUP as the shutdown of that
# interrupted run starts
DRIVER_TWICE = textwrap.dedent("""
    import os, signal, sys
    import navkit.cli
    from navkit.sim import harness, rig

    loop = harness.run_lockstep
    def signalled_loop(*a):
        os.kill(os.getpid(), signal.SIGTERM)
        return loop(*a)
    harness.run_lockstep = signalled_loop

    stop = rig.SimRig.stop
    def signalled_stop(self):
        os.kill(os.getpid(), signal.SIGHUP)
        stop(self)
    rig.SimRig.stop = signalled_stop

    sys.argv = ["navkit", *sys.argv[1:]]
    raise SystemExit(navkit.cli.main())
""")


def test_a_second_stop_signal_waits_for_the_interrupted_runs_outputs(tmp_path):
    require_build()
    driver, mission, out = tmp_path / "driver.py", tmp_path / "m.toml", tmp_path / "out"
    driver.write_text(DRIVER_TWICE)
    mission.write_text("duration_s = 1.0\n")
    done = subprocess.run([sys.executable, str(driver), "sim", "-m", str(mission), "-o", str(out),
                           "--no-progress"], capture_output=True, text=True, timeout=60)
    assert done.returncode == 128 + signal.SIGTERM, done.stderr
    assert "Traceback" not in done.stderr, done.stderr
    assert done.stderr.strip().splitlines()[-1].startswith("navkit sim: interrupted by SIGTERM at t = "), \
        done.stderr
    assert json.loads((out / "summary.json").read_text())["interrupted"]["signal"] == "SIGTERM"
