"""A bare `pytest` without a build stops at once with one message naming the build folder
and the fix (tests/conftest.py), instead of skipping every test that needs the build;
NAVKIT_TEST_WITHOUT_BUILD=1 lets the tests run without one."""

import os
import subprocess
import sys
from pathlib import Path

TESTS = Path(__file__).resolve().parent


def _pytest(tmp_path, *args, **env):
    """Run pytest with `args` in a child whose build folder is `tmp_path / "no-build"` (absent),
    with the environment `env` and no opt-out unless `env` sets one."""
    e = {k: v for k, v in os.environ.items() if k != "NAVKIT_TEST_WITHOUT_BUILD"}
    e.update(NAVKIT_BUILD_DIR=str(tmp_path / "no-build"), PYTHONDONTWRITEBYTECODE="1", **env)
    return subprocess.run([sys.executable, "-m", "pytest", "-p", "no:cacheprovider", *args], cwd=tmp_path,
                          env=e, capture_output=True, text=True, timeout=120)


def test_no_build_stops_the_run_with_one_message(tmp_path):
    r = _pytest(tmp_path, "-q", str(TESTS / "test_plant_fmu.py"))
    folder = tmp_path / "no-build"
    assert r.returncode == 4, r.stdout + r.stderr
    lines = [line for line in r.stderr.splitlines() if line.strip()]
    assert lines == [f"ERROR: {folder}: not built (no navkit-host, navkit_firmware.fmu, navkit_plant.fmu, "
                     "libnavkit_cosim.so, libnavkit_record.so): run `make build`, or set NAVKIT_BUILD_DIR "
                     "to a built folder (NAVKIT_TEST_WITHOUT_BUILD=1 runs only the tests that need no "
                     "build)"], r.stderr
    assert "skipped" not in r.stdout and "passed" not in r.stdout


def test_the_opt_out_runs_without_a_build(tmp_path):
    r = _pytest(tmp_path, "-q", "-rs", str(TESTS / "test_plant_fmu.py"), NAVKIT_TEST_WITHOUT_BUILD="1")
    assert r.returncode == 0, r.stdout + r.stderr
    assert "skipped" in r.stdout and "navkit_plant.fmu not built" in r.stdout
