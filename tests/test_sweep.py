"""`navkit sweep`: --vary ranges, grids and random points; sweeps on a real Dask
LocalCluster and on a scheduler and worker started here (loopback), deterministic per
seed whatever the worker count, a failing run reported without losing the others,
Ctrl-C, bad options. Each run is a real co-simulation (host, firmware and plant FMUs)."""

import csv
import io
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from navkit.sweep.plan import SweepError, check_varies, grid, parse_vary, sample
from sim_helpers import require_build

# 500 mm forward and a heading select to 90 deg in 6 s; [expect] gives the table its errors
MISSION = """
duration_s = 6.0
[expect]
x_mm = 500.0
y_mm = 0.0
heading_deg = 90.0
[[command]]
t = 0.2
fwd_cmd = "start"
accel = 600
speed = 400
distance = 500
[[command]]
t = 2.5
turn_mode = "heading_select"
turn_rate = 900
turn_distance = 900
"""

PARAMS = {"mass_kg": "Float64", "friction_coulomb_n": "Float64",
          "encoder_counts_per_rev": "Int32"}


def _navkit(*args, timeout=120, **kw):
    return subprocess.run([sys.executable, "-m", "navkit", *args], capture_output=True,
                          text=True, timeout=timeout, **kw)


def _table(path: Path) -> list:
    return list(csv.DictReader(io.StringIO(Path(path).read_text())))


# ------------------------------------------------------------------ plan (no build needed)

@pytest.mark.parametrize("text, why", [
    ("mass_kg", "expected KEY=LO:HI"),
    ("mass_kg=14:10", "LO 14 is above HI 10"),
    ("mass_kg=10:14:0", "N must be at least 1"),
    ("mass_kg=10:14:2.5", "not a whole number"),
    ("mass_kg=ten:14", "LO 'ten' is not a number"),
    ("mass_kg=10:inf", "not finite"),
    ("mass_kg=12:12:3", "3 points between equal ends"),
    ("=1:2", "expected KEY=LO:HI"),
])
def test_parse_vary_refuses(text, why):
    with pytest.raises(SweepError) as e:
        parse_vary(text)
    assert str(e.value).startswith(f"--vary {text!r}: ") and why in str(e.value)


def test_grid_points_and_integers():
    v = [parse_vary("mass_kg=10:14:3"), parse_vary("encoder_counts_per_rev=1000:1001:4")]
    pts = grid(v, PARAMS)
    # 3 masses (ends exact) x 2 distinct whole counts (4 points round to 1000, 1000, 1001, 1001)
    assert [p["mass_kg"] for p in pts] == [10.0, 10.0, 12.0, 12.0, 14.0, 14.0]
    assert [p["encoder_counts_per_rev"] for p in pts] == [1000, 1001] * 3
    assert all(isinstance(p["encoder_counts_per_rev"], int) for p in pts)
    assert grid([parse_vary("mass_kg=9:11")], PARAMS) == [{"mass_kg": x} for x in (9.0, 10.0, 11.0)]
    assert grid([], PARAMS) == [{}]


def test_latin_hypercube_and_uniform():
    v = [parse_vary("mass_kg=10:20"), parse_vary("friction_coulomb_n=0:1")]
    n = 50
    pts = sample(v, PARAMS, n, "lhs", seed=7)
    assert pts == sample(v, PARAMS, n, "lhs", seed=7), "a function of the seed"
    assert pts != sample(v, PARAMS, n, "lhs", seed=8)
    for key, lo, hi in (("mass_kg", 10, 20), ("friction_coulomb_n", 0, 1)):
        strata = sorted(int((p[key] - lo) / (hi - lo) * n) for p in pts)
        assert strata == list(range(n)), f"one {key} in each of the {n} strata"
    u = sample(v, PARAMS, n, "uniform", seed=7)
    assert u == sample(v, PARAMS, n, "uniform", seed=7) and u != pts
    assert all(10 <= p["mass_kg"] <= 20 and 0 <= p["friction_coulomb_n"] <= 1 for p in u)
    with pytest.raises(SweepError, match=r"--vary 'mass_kg=10:20:3': ':N' is the grid's"):
        sample([parse_vary("mass_kg=10:20:3")], PARAMS, 4)


def test_check_varies_names_the_key():
    with pytest.raises(SweepError, match=r"--vary 'mas_kg=1:2': key 'mas_kg' is not a numeric "
                                         r"parameter of the plant FMU p.fmu \(did you mean mass_kg\?\)"):
        check_varies([parse_vary("mas_kg=1:2")], PARAMS, "p.fmu")
    with pytest.raises(SweepError, match=r"key 'seed' is set by the harness.*--seeds N"):
        check_varies([parse_vary("seed=1:2")], PARAMS, "p.fmu")
    with pytest.raises(SweepError, match=r"key 'mass_kg' is varied twice"):
        check_varies([parse_vary("mass_kg=1:2"), parse_vary("mass_kg=3:4")], PARAMS, "p.fmu")
    with pytest.raises(SweepError, match=r"integer \(Int32\) and 1000.2..1000.8 holds no whole"):
        check_varies([parse_vary("encoder_counts_per_rev=1000.2:1000.8")], PARAMS, "p.fmu")


def test_mission_expect_table(host_converts):
    from navkit.sim.mission import MissionError, loads

    m = loads(MISSION, "m.toml")
    assert m.expect == {"x_mm": 500.0, "y_mm": 0.0, "heading_deg": 90.0}
    with pytest.raises(MissionError, match=r"m.toml: \[expect\]: unknown key 'z_mm' \(one of x_mm"):
        loads("duration_s = 1.0\n[expect]\nz_mm = 1.0\n", "m.toml")
    with pytest.raises(MissionError, match=r"m.toml: \[expect\]: key 'x_mm': 'a' is not a finite"):
        loads("duration_s = 1.0\n[expect]\nx_mm = 'a'\n", "m.toml")


# ------------------------------------------------------------------ sweeps (real runs)

@pytest.fixture(scope="module")
def mission_file(tmp_path_factory):
    require_build()
    p = tmp_path_factory.mktemp("sweep-mission") / "short.toml"
    p.write_text(MISSION)
    return p


# mass -12 kg: the plant FMU refuses it at initialisation, so those runs fail
VARY = ["--vary", "mass_kg=-12:12:2", "--vary", "friction_coulomb_n=2:4:2"]


@pytest.fixture(scope="module")
def local_tables(mission_file, tmp_path_factory):
    """The same 4-point x 1-seed sweep (2 of its runs fail) on 1 and on 2 workers."""
    out = {}
    for workers in (1, 2):
        d = tmp_path_factory.mktemp(f"sweep-w{workers}")
        p = _navkit("sweep", "--mission", str(mission_file), *VARY, "--out", str(d),
                    "--workers", str(workers), "--keep", "failed")
        out[workers] = (d, p)
    return out


def test_sweep_deterministic_and_survives_failing_runs(local_tables):
    d1, p1 = local_tables[1]
    d2, p2 = local_tables[2]
    for p in (p1, p2):
        assert p.returncode == 1, p.stdout + p.stderr        # some runs failed
        assert "Traceback" not in p.stderr, p.stderr
        assert "4 runs" in p.stdout and "2 failed" in p.stdout, p.stdout
        assert "figure    err_pos_mm: min " in p.stdout and "mass_kg=12" in p.stdout, p.stdout
    text = (d1 / "results.csv").read_text()
    assert text == (d2 / "results.csv").read_text(), "same table on 1 and 2 workers"
    rows = _table(d1 / "results.csv")
    assert [r["run"] for r in rows] == ["0", "1", "2", "3"]
    assert [(float(r["mass_kg"]), float(r["friction_coulomb_n"])) for r in rows] == \
        [(-12, 2), (-12, 4), (12, 2), (12, 4)]
    for r in rows[:2]:
        assert r["status"] == "failed" and r["x_mm"] == ""
        assert "[plant]: key 'mass_kg'" in r["error"] and "-12" in r["error"], r["error"]
        # reported with its parameters as it happened, and its folder kept
        params = f"seed 1, mass_kg=-12, friction_coulomb_n={float(r['friction_coulomb_n']):g}"
        assert f"run {r['run']} ({params}) failed: " in p1.stderr, p1.stderr
        assert (d1 / "runs" / f"{int(r['run']):04d}").is_dir()
    for r in rows[2:]:
        assert r["status"] == "ok" and r["error"] == "", r
        assert abs(float(r["err_x_mm"])) < 15 and abs(float(r["err_heading_deg"])) < 2, r
        assert abs(float(r["x_mm"]) - 500 - float(r["err_x_mm"])) < 1e-6
        assert float(r["err_pos_mm"]) >= abs(float(r["err_x_mm"]))
        assert r["watchdog_stops"] == "0" and r["planner_accepted"] == "2", r
        assert int(r["h2m_sent"]) > 50 and r["h2m_received"] == r["h2m_sent"], r
        assert r["crc_errors"] == "0" and r["host_state"] == "running" and r["host_exit"] == "0", r
        assert float(r["odo_err_mm"]) < 20, r
        assert not (d1 / "runs" / f"{int(r['run']):04d}").exists(), "ok runs not kept"
    # more Coulomb friction, same mass: the runs differ (the figures are the runs')
    assert rows[2]["x_mm"] != rows[3]["x_mm"] or rows[2]["odo_heading_deg"] != rows[3]["odo_heading_deg"]
    assert (d1 / "summary.png").stat().st_size > 10_000


def test_sweep_api_seeds_keep_and_a_dying_worker(mission_file, tmp_path):
    """The Python API: results in run order, per-seed figures, an extract function's
    figures; a run whose worker process dies under it (as with a crashing FMU) fails
    naming it and its folder (kept like any failed run's), and the others (one held by
    the dying worker) finish on the restarted workers."""
    from navkit.sweep import RunSpec, run_sweep

    runs = [RunSpec(plant={"mass_kg": 14.0}, seed=s) for s in (3, 2, 4, 3)]
    res = run_sweep(mission_file, runs, tmp_path, workers=2, progress=False, keep="failed",
                    extract=_mcap_size_or_die_on_seed_2)
    assert [r.index for r in res] == [0, 1, 2, 3] and [r.spec.seed for r in res] == [3, 2, 4, 3]
    assert [r.status for r in res] == ["ok", "failed", "ok", "ok"], [r.error for r in res]
    assert res[1].error.startswith("KilledWorker: the worker process running it died (a crash")
    assert res[1].out == tmp_path / "runs" / "0001" and (res[1].out / "host.log").exists()
    assert str(res[1].out) in res[1].error, "the failed run's folder is named"
    ok = [res[i] for i in (0, 2, 3)]
    assert all(r.out is None and r.figures["mcap_bytes"] > 0 for r in ok), "ok runs not kept"
    assert sorted(p.name for p in (tmp_path / "runs").iterdir()) == ["0001"]
    assert res[0].figures == res[3].figures, "same spec, same figures"
    assert res[0].figures != res[2].figures, "another seed, other noise"
    x, y, hdg = res[0].final_pose
    assert abs(x - 500) < 15 and abs(hdg - 90) < 2
    rows = _table(tmp_path / "results.csv")
    assert "mcap_bytes" in rows[0] and rows[1]["error"].startswith("KilledWorker")


def _mcap_size_or_die_on_seed_2(run_dir, summary):
    """An extract function: run.mcap's size; it kills the worker running the seed-2 run."""
    if summary["seed"] == 2:
        os.kill(os.getpid(), signal.SIGKILL)
    return {"mcap_bytes": (Path(run_dir) / "run.mcap").stat().st_size}


def test_pil_sweep(mission_file, tmp_path):
    """firmware="avr": the runs are processor in the loop (the AVR image in simavr), with
    the same table's figures."""
    import json

    from navkit.paths import build_dir
    from navkit.sweep import RunSpec, run_sweep

    if not (build_dir() / "fmus" / "navkit_firmware_avr.fmu").exists():
        pytest.skip("not built: navkit_firmware_avr.fmu")
    res = run_sweep(mission_file, [RunSpec(seed=1), RunSpec(seed=2)], tmp_path, workers=2,
                    progress=False, plot=False, firmware="avr")
    assert [r.status for r in res] == ["ok", "ok"], [r.error for r in res]
    for r in res:
        assert abs(r.figures["err_x_mm"]) < 15 and abs(r.figures["err_heading_deg"]) < 2, r.figures
        assert r.figures["watchdog_stops"] == 0 and r.figures["planner_accepted"] == 2
    assert json.loads((tmp_path / "sweep.json").read_text())["firmware"] == "avr"


def test_sweep_on_a_scheduler(mission_file, local_tables, tmp_path):
    """--scheduler: the same sweep on a scheduler and a worker started here with the dask
    CLIs on 127.0.0.1 gives the same table as the LocalCluster."""
    dask = Path(sys.executable).parent / "dask"
    sched_file = tmp_path / "scheduler.json"
    env = dict(os.environ)
    procs = []
    try:
        # both at once: the worker waits for the scheduler's file
        procs.append(subprocess.Popen([str(dask), "scheduler", "--host", "127.0.0.1", "--port", "0",
                                       "--no-dashboard", "--scheduler-file", str(sched_file)],
                                      stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                      env=env, start_new_session=True))
        procs.append(subprocess.Popen([str(dask), "worker", "--scheduler-file", str(sched_file),
                                       "--nthreads", "1", "--no-dashboard", "--host", "127.0.0.1"],
                                      stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                      env=env, start_new_session=True))
        deadline = time.monotonic() + 30
        while not sched_file.exists() and time.monotonic() < deadline:
            time.sleep(0.1)
        assert sched_file.exists(), "the scheduler did not start"
        import json

        address = json.loads(sched_file.read_text())["address"]
        assert address.startswith("tcp://127.0.0.1:")
        out = tmp_path / "out"
        p = _navkit("sweep", "--mission", str(mission_file), *VARY, "--out", str(out),
                    "--scheduler", address)
        assert p.returncode == 1 and "Traceback" not in p.stderr, p.stdout + p.stderr
        assert (out / "results.csv").read_text() == \
            (local_tables[1][0] / "results.csv").read_text()
        assert address in (out / "sweep.json").read_text()
    finally:
        for proc in reversed(procs):     # the worker first: it says goodbye to the scheduler
            proc.terminate()
            try:
                proc.wait(timeout=15)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()


@pytest.mark.parametrize("args, code, message", [
    (["--vary", "mas_kg=1:2"], 2, "--vary 'mas_kg=1:2': key 'mas_kg' is not a numeric parameter "
                                  "of the plant FMU"),
    (["--vary", "mass_kg=2:1"], 2, "--vary 'mass_kg=2:1': LO 2 is above HI 1"),
    (["--vary", "world_file=1:2"], 2, "key 'world_file' is set by the harness"),
    (["--samples", "3"], 2, "--samples: give the ranges to sample with --vary KEY=LO:HI"),
    (["--workers", "2", "--scheduler", "tcp://127.0.0.1:1"], 2, "--workers: only for the LocalCluster"),
    (["--scheduler", "127.0.0.1:8786"], 2, "--scheduler '127.0.0.1:8786': Invalid url scheme"),
])
def test_bad_options(mission_file, tmp_path, args, code, message):
    p = _navkit("sweep", "--mission", str(mission_file), "--out", str(tmp_path / "o"), *args)
    assert p.returncode == code, p.stdout + p.stderr
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("navkit sweep: "), p.stderr
    assert message in p.stderr and "Traceback" not in p.stderr, p.stderr
    assert not (tmp_path / "o").exists(), "nothing run"


def test_bad_mission(tmp_path):
    require_build()
    bad = tmp_path / "bad.toml"
    bad.write_text("duration_s = 1.0\nspeed = 3\n")
    p = _navkit("sweep", "--mission", str(bad), "--out", str(tmp_path / "o"))
    assert p.returncode == 1 and "Traceback" not in p.stderr
    assert p.stderr.startswith(f"navkit sweep: {bad}: unknown top-level key 'speed'"), p.stderr


def test_ctrl_c_keeps_the_finished_runs(tmp_path):
    """Ctrl-C typed at a terminal (a pty: SIGINT to the whole foreground process group,
    the LocalCluster's workers too) while runs are going: a progress bar before, then exit
    130 with the table of the runs that finished and no worker tracebacks."""
    import pty
    import select

    require_build()
    mission = tmp_path / "long.toml"
    mission.write_text("duration_s = 20.0\n[[command]]\nt = 0.5\nfwd_cmd = \"start\"\n"
                       "speed = 300\ndistance = 900\n")
    out = tmp_path / "o"
    pid, fd = pty.fork()
    if pid == 0:                                  # the child: navkit sweep on the pty
        os.execv(sys.executable, [sys.executable, "-m", "navkit", "sweep", "--mission",
                                  str(mission), "--seeds", "40", "--workers", "2", "--keep",
                                  "all", "--out", str(out)])
    text, sent, status = b"", False, None
    deadline = time.monotonic() + 90
    try:
        while time.monotonic() < deadline:
            if select.select([fd], [], [], 0.05)[0]:
                try:
                    chunk = os.read(fd, 4096)
                except OSError:                   # the child closed the pty
                    chunk = b""
                if not chunk:
                    break
                text += chunk
            if not sent and b"] 3/40 runs" in text:     # the bar: 3 runs in the table
                os.write(fd, b"\x03")             # Ctrl-C, as typed
                sent = True
        _, st = os.waitpid(pid, 0)
        status = os.waitstatus_to_exitcode(st)
    finally:
        if status is None:
            os.kill(pid, signal.SIGKILL)
            os.waitpid(pid, 0)
        os.close(fd)
    out_text = text.decode(errors="replace")
    assert sent, out_text
    assert status == 130, out_text
    assert "Traceback" not in out_text and "KeyboardInterrupt" not in out_text, out_text
    assert "[#" in out_text and " runs, 0 failed, " in out_text, "the progress bar"
    rows = _table(out / "results.csv")
    assert 3 <= len(rows) < 40 and all(r["status"] == "ok" for r in rows), rows
    assert f"interrupted: {len(rows)} of 40 runs finished" in out_text, out_text


def test_bench_command(mission_file, tmp_path):
    """`navkit sweep --bench` (make bench-sweep) prints runs per minute for 1 and 2
    workers, their ratio and that both tables agree (2 runs each here; figures come from
    the command, not from this test). Its temporary folders go into tmp_path."""
    p = _navkit("sweep", "--bench", "--bench-runs", "2", "--mission", str(mission_file),
                env=dict(os.environ, TMPDIR=str(tmp_path)))
    assert p.returncode == 0, p.stdout + p.stderr
    lines = p.stdout.splitlines()
    assert any(line.strip().startswith("1 worker : 2 runs in") and "runs/min" in line for line in lines)
    assert any(line.strip().startswith("2 workers: 2 runs in") and "runs/min" in line for line in lines)
    assert any(line.strip().startswith("ratio 2 workers / 1 worker: ") for line in lines)
    assert "tables of 1 and 2 workers identical: yes" in p.stdout
