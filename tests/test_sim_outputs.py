"""What a run leaves behind: MCAP topics, schemas, metadata and chunking, summary.json,
plot.png, the host's datalog and `navkit plot`; determinism; the demo mission."""

import argparse
import contextlib
import json
import os
import re
import subprocess
from pathlib import Path

import pytest

from sim_helpers import chunk_spans, require_build, run_mission
from spec_helpers import MSG_TYPE

pytestmark = pytest.mark.timeout(180)

NOISY = """
duration_s = 6.0
[[key]]
t = 0.5
key = "R"
[[command]]
t = 1.5
fwd_cmd = 1
speed = 300
distance = 600
turn_mode = 1
turn_rate = 300
turn_distance = 300
rc_servo_num = 3
rc_param0 = 600
rc_param1 = 300
rc_param2 = -300
dio_active = 3
dio_command = 1
[[fault]]
t = 2.0
kind = "line_noise"
ber = 1e-4
duration_s = 2.0
[[key]]
t = 5.5
key = "S"
"""


def _contents(r):
    return {topic: [(t, m) for t, m in msgs] for topic, msgs in r.topics.items()}


def test_two_runs_identical_message_contents(tmp_path_factory):
    a = run_mission(tmp_path_factory, "det-a", NOISY)
    b = run_mission(tmp_path_factory, "det-b", NOISY)
    assert _contents(a) == _contents(b)
    strip = lambda m: {k: v for k, v in m.items() if k != "mission_file"}  # noqa: E731
    assert strip(a.metadata) == strip(b.metadata)
    c = run_mission(tmp_path_factory, "det-a", NOISY, seed=2)
    assert c.messages("/micro/data") != a.messages("/micro/data"), \
        "another seed, another run (sensor noise, line noise)"


def test_mcap_topics_schemas_metadata_and_chunks(tmp_path_factory):
    from mcap.reader import make_reader

    r = run_mission(tmp_path_factory, "det-a", NOISY)
    for topic in ("/truth", "/micro/cmd", "/micro/data", "/planner/cmd", "/planner/data",
                  "/host/frame", "/micro/config", "/events"):
        assert r.messages(topic), topic
    truth = r.truth
    assert set(truth[0]) == {"t", "x_mm", "y_mm", "yaw_deg", "heading_deg", "distance_mm",
                             "v_mm_s", "w_deg_s", "servo_deg", "dio_out"}
    assert len(truth[0]["servo_deg"]) == 8
    ts = [m["t"] for m in truth]
    assert max(b - a for a, b in zip(ts, ts[1:])) <= 0.02 + 1e-9, ">= 50 Hz"
    assert ts[-1] == pytest.approx(6.0)
    assert len(r.messages("/host/frame")) == r.summary["frames"]
    meta = r.metadata
    assert meta["seed"] == "1" and "fwd_cmd = 1" in meta["mission"]
    assert meta["spec_hash"].startswith("0x")
    assert re.fullmatch(r"[0-9a-f]{40}(\+dirty)?", meta["git_revision"]), meta["git_revision"]
    with open(r.out / "run.mcap", "rb") as f:
        reader = make_reader(f)
        summ = reader.get_summary()
        for s in summ.schemas.values():
            assert s.encoding == "jsonschema"
            schema = json.loads(s.data)
            assert schema["type"] == "object" and schema["properties"]
        for ch in summ.channels.values():
            assert ch.message_encoding == "json"
        # every message fits its channel's schema (a sample of each topic); jsonschema
        # is a test dependency (pyproject.toml), so this never skips
        import jsonschema
        per_topic = {}
        for schema, channel, message in reader.iter_messages():
            if per_topic.get(channel.topic, 0) < 20:
                per_topic[channel.topic] = per_topic.get(channel.topic, 0) + 1
                jsonschema.validate(json.loads(message.data), json.loads(schema.data))
        # closed at least every simulated second
        assert len(summ.chunk_indexes) >= 6
        assert all(c.message_end_time - c.message_start_time <= 1_000_000_000
                   for c in summ.chunk_indexes)
    # planner commands are whole lisp_cmds with a time tag
    cmd = r.messages("/planner/cmd")[0][1]
    assert cmd["time_tag"] == 1500 and cmd["rc_servo_num"] == 3 and cmd["accel"] == 0


def test_summary_fields(tmp_path_factory):
    s = run_mission(tmp_path_factory, "det-a", NOISY).summary
    for k in ("sim_time_s", "wall_time_s", "realtime_factor", "frames", "truth", "micro",
              "link", "host", "watchdog_stops"):
        assert k in s, k
    assert s["sim_time_s"] == pytest.approx(6.0)
    assert s["frames"] > 0 and s["realtime_factor"] > 1
    assert s["micro"]["msg_type"] == MSG_TYPE["micro_data"]
    assert s["link"]["host_to_micro"]["frames_sent"] > 0
    assert s["link"]["micro_to_host"]["frames_sent"] > 0
    assert "crc_errors" in s["link"] and "resyncs" in s["link"]
    assert "overruns" in s["host"] and s["host"]["config_downloads"] >= 1
    assert s["planner"] == {"commands": 1, "accepted": 1, "rejected": 0, "not_implemented": 0,
                            "planner_timeout": 0, "unacknowledged": 0, "refused": []}


REFUSED = """
duration_s = 4.0
[[command]]
t = 0.5
fwd_cmd = "explore"
[[command]]
t = 1.0
fwd_cmd = 1
speed = 200
distance = 150
[[fault]]
t = 2.0
kind = "unplug"
duration_s = 1.5
[[command]]
t = 3.0
turn_mode = "heading_hold"
turn_rate = 300
turn_distance = 900
"""


def test_commands_the_host_refuses_are_counted_and_warned_about(tmp_path_factory, capsys):
    """fwd_cmd "explore" (a high-level code) is not implemented; a heading hold while the
    micro is unplugged is rejected (no heading to hold). Each refusal is a warning on
    stderr naming the mission entry, its t and the reason (two commands in one frame are
    refused at load: tests/test_sim_harden.py)."""
    r = run_mission(tmp_path_factory, "refused", REFUSED)
    err = capsys.readouterr().err
    p = r.summary["planner"]
    where = lambda i: f"{r.out / 'refused.toml'}: [[command]] #{i}"  # noqa: E731
    assert p == {"commands": 3, "accepted": 1, "rejected": 1, "not_implemented": 1,
                 "planner_timeout": 0, "unacknowledged": 0, "refused": [
                     {"command": 1, "t": 0.5, "where": where(1), "nav_result": "not_implemented",
                      "reason": "fwd_cmd 105 (explore) is a high-level code; the rest of the "
                                "command applies"},
                     {"command": 3, "t": 3.0, "where": where(3), "nav_result": "rejected",
                      "reason": "heading hold (turn_mode 11) needs the micro's current heading "
                                "and the host had none (no fresh micro_data: micro offline); "
                                "the command was dropped"}]}
    warnings = [line for line in err.splitlines() if line.startswith("warning: ")]
    assert warnings == [
        f"warning: {where(1)} (t = 0.5 s): not implemented by the host: {p['refused'][0]['reason']} "
        "(lisp_data.nav_result = not_implemented)",
        f"warning: {where(3)} (t = 3 s): rejected by the host: {p['refused'][1]['reason']} "
        "(lisp_data.nav_result = rejected)"], err
    assert r.truth[-1]["distance_mm"] == pytest.approx(150, abs=5), "the forward command ran"
    host_log = (r.out / "host.log").read_text()
    assert "fwd_cmd 105 (high level) is not implemented" in host_log
    assert "planner command 3000 rejected: heading hold" in host_log


def test_frame_period_option_in_lockstep(tmp_path_factory):
    """`navkit sim --frame-ms 50`: the harness drives 20 host frames per simulated second
    (the lockstep host takes its time from the driver, so no --rate is passed)."""
    text = "duration_s = 2.0\n[[command]]\nt = 0.2\nfwd_cmd = 1\nspeed = 200\ndistance = 100\n"
    r = run_mission(tmp_path_factory, "frame-50ms", text, frame_s=0.05)
    assert r.summary["frames"] == 40
    assert r.summary["truth"]["distance_mm"] == pytest.approx(100, abs=5)


def test_datalog_and_plots(tmp_path_factory, tmp_path):
    from navkit import plot

    r = run_mission(tmp_path_factory, "det-a", NOISY)
    logs = sorted(r.out.glob("Data *.txt"))
    assert logs, "R ... S recorded a datalog in the output folder"
    params, rows = plot.read_datalog(logs[0])
    assert params and len(rows) >= 30, "about one row per 100 ms frame for 5 s"
    parser = argparse.ArgumentParser()
    plot.add_arguments(parser)
    assert plot.run(parser.parse_args([str(logs[0]), "-o", str(tmp_path / "log.png")])) == 0
    assert plot.run(parser.parse_args([str(r.out / "run.mcap"), "-o", str(tmp_path / "run.png")])) == 0
    assert (tmp_path / "log.png").stat().st_size > 10_000
    assert (tmp_path / "run.png").stat().st_size > 10_000


def test_git_revision_clean_dirty_and_not_a_checkout(tmp_path):
    """The metadata's git_revision: HEAD's 40 hex digits, "+dirty" when `git status
    --porcelain` lists anything (a modified or an untracked file), "unknown" outside a
    git checkout."""
    from navkit.sim.harness import git_revision

    assert git_revision(tmp_path) == "unknown"
    git = ["git", "-C", str(tmp_path), "-c", "user.name=navkit", "-c", "user.email=n@k"]
    subprocess.run(git + ["init", "-q"], check=True)
    (tmp_path / "a.txt").write_text("a\n")
    subprocess.run(git + ["add", "a.txt"], check=True)
    subprocess.run(git + ["commit", "-q", "-m", "a"], check=True)
    head = subprocess.run(git + ["rev-parse", "HEAD"], capture_output=True, text=True,
                          check=True).stdout.strip()
    assert re.fullmatch(r"[0-9a-f]{40}", head)
    assert git_revision(tmp_path) == head
    (tmp_path / "a.txt").write_text("b\n")
    assert git_revision(tmp_path) == head + "+dirty"
    subprocess.run(git + ["checkout", "-q", "a.txt"], check=True)
    (tmp_path / "new.txt").write_text("n\n")
    assert git_revision(tmp_path) == head + "+dirty"


def test_run_plot_has_path_speed_heading_and_a_mark_per_command(tmp_path_factory):
    """plot.png's figure: three panels (path, speed, heading) holding the /truth values,
    and on the speed and heading panels one line per /planner/cmd message and per
    /events message at its log time."""
    import matplotlib.pyplot as plt

    from navkit import plot

    r = run_mission(tmp_path_factory, "refused", REFUSED)
    fig = plot.mcap_figure(r.out / "run.mcap")
    try:
        ax_xy, ax_v, ax_h = fig.axes
        assert (ax_xy.get_xlabel(), ax_xy.get_ylabel()) == ("y (left), mm", "x (forward), mm")
        assert ax_v.get_ylabel() == "speed, mm/s" and ax_h.get_ylabel() == "heading, deg (cw)"
        assert ax_h.get_xlabel() == "simulated time, s"
        truth = r.truth
        path, speed, heading = (ax.get_lines()[0] for ax in (ax_xy, ax_v, ax_h))
        assert list(path.get_xdata()) == [m["y_mm"] for m in truth]
        assert list(path.get_ydata()) == [m["x_mm"] for m in truth]
        assert list(speed.get_xdata()) == list(heading.get_xdata()) == [m["t"] for m in truth]
        assert list(speed.get_ydata()) == [m["v_mm_s"] for m in truth]
        assert list(heading.get_ydata()) == [m["heading_deg"] % 360 for m in truth]
        cmd_t = [t for t, _ in r.messages("/planner/cmd")]
        ev_t = [t for t, _ in r.messages("/events")]
        assert cmd_t == [0.5, 1.0, 3.0] and ev_t == [2.0, 3.5], "unplug and plug"
        for ax in (ax_v, ax_h):
            marks = {c.get_gid(): [seg[0][0] for seg in c.get_segments()] for c in ax.collections}
            assert marks == {"command": cmd_t, "event": ev_t}
        labels = [a.get_text() for a in ax_v.texts]
        assert labels == ["fwd 105 v0 d0", "fwd 1 v200 d150", "turn 11 90deg"], labels
    finally:
        plt.close(fig)


def _make_sim_command() -> list:
    """The command line of the Makefile's `sim` target ($(PY) = .venv/bin/python)."""
    from navkit.paths import repo_root

    text = (repo_root() / "Makefile").read_text()
    recipe = text.split("\nsim:", 1)[1].split("\n")[1].strip().lstrip("@")
    return recipe.replace("$(PY)", ".venv/bin/python").split()


def test_make_sim_command_line(tmp_path):
    """What `make sim` runs after the build (the Makefile's recipe, verbatim): the demo
    mission into <build>/sim/demo; it prints the outputs (datalog included), the final pose
    and the speed. The build folder it is given is a temporary one linking every part of
    the real one, so its <build>/sim/demo is the test's own (never the user's)."""
    import subprocess

    from navkit.paths import build_dir, repo_root

    require_build()
    cmd = _make_sim_command()
    assert "config/missions/demo.toml" in cmd
    build = tmp_path / "build"
    build.mkdir()
    for part in build_dir().iterdir():
        if part.name != "sim":
            (build / part.name).symlink_to(part)
    env = dict(os.environ, NAVKIT_BUILD_DIR=str(build))
    out = build / "sim" / "demo"
    out.mkdir(parents=True)
    old = out / "Data 01-01-20 00;00;00.txt"     # an earlier run's datalog: kept, not listed
    old.write_text("old\n")
    p = subprocess.run(cmd, cwd=repo_root(), env=env, capture_output=True, text=True,
                       timeout=120)
    assert p.returncode == 0, p.stdout + p.stderr
    lines = {line.split()[0]: line for line in p.stdout.splitlines() if line.strip()}
    assert str(out) in lines["outputs"] and "run.mcap" in lines["outputs"], p.stdout
    assert "final" in lines and "heading" in lines["final"], p.stdout
    assert "real time" in lines["speed"], p.stdout
    logs = [line.split(None, 1)[1] for line in p.stdout.splitlines() if line.startswith("datalog")]
    assert logs and all(Path(f).parent == out and Path(f).exists() for f in logs), p.stdout
    assert str(old) not in logs and old.read_text() == "old\n", "only this run's datalogs"
    for f in ("run.mcap", "summary.json", "plot.png"):
        assert (out / f).exists(), f
    s = json.loads((out / "summary.json").read_text())
    t = s["truth"]
    assert (t["x_mm"] ** 2 + t["y_mm"] ** 2) ** 0.5 > 500, "the demo goes somewhere"
    assert s["sim_time_s"] == pytest.approx(24.0)
    assert [str(out / name) for name in s["datalogs"]] == logs


def test_realtime_mode_paces_to_the_wall_clock(tmp_path_factory):
    r = run_mission(tmp_path_factory, "realtime", """
duration_s = 3.0
[[command]]
t = 1.2
fwd_cmd = 1
speed = 300
distance = 200
""", realtime=True)
    s = r.summary
    assert s["mode"] == "realtime"
    # /host/frame: the host's own frames as seen at the harness's once-per-frame reads
    frames = [m for _, m in r.messages("/host/frame")]
    assert len(frames) >= 20 and all("flags" not in m and m["host"] == "running" for m in frames)
    numbers = [m["frame"] for m in frames]
    assert numbers == sorted(set(numbers)) and numbers[-1] + 1 == s["frames"]
    assert sum(m["tx_bytes"] for m in frames) > 0 and sum(m["rx_bytes"] for m in frames) > 0
    assert r.messages("/planner/data")
    assert 0.7 < s["realtime_factor"] <= 1.1, s["wall_time_s"]
    assert abs(r.truth[-1]["distance_mm"] - 200) <= 15, "the command reached the micro"
    assert s["host"]["config_downloads"] >= 1
    spans = chunk_spans(r.out / "run.mcap")
    assert len(spans) >= 3 and all(t1 - t0 <= 1_000_000_000 for t0, t1 in spans), spans


QUIT = """
duration_s = 2.0
[[fault]]
t = 0.5
kind = "unplug"
duration_s = 0.3
[[key]]
t = 1.2
key = "Q"
"""


@pytest.mark.parametrize("realtime", [False, True])
def test_host_frame_states(tmp_path_factory, realtime):
    """/host/frame's `host`: running, unplugged while the port is unplugged, and one
    message `exited` at the first frame after the host quit (key Q), in lockstep and in
    real time (where the frames are the host's own, read once per frame)."""
    r = run_mission(tmp_path_factory, "quit-rt" if realtime else "quit", QUIT,
                    realtime=realtime)
    states = [(round(t, 3), m["host"]) for t, m in r.messages("/host/frame")]
    expect = ([(round(0.1 * i, 3), "running") for i in range(5)]
              + [(round(0.1 * i, 3), "unplugged") for i in range(5, 8)]
              + [(round(0.1 * i, 3), "running") for i in range(8, 13)] + [(1.3, "exited")])
    if realtime:      # the host's own clock: frames may land late or be missed on a busy machine
        runs = [h for i, (_, h) in enumerate(states) if i == 0 or states[i - 1][1] != h]
        assert runs == ["running", "unplugged", "running", "exited"], states
        assert all(0.5 <= t < 1.2 for t, h in states if h == "unplugged"), states
        assert states[-1][0] > 1.2, "exited after the Q key"
    else:
        assert states == expect
        assert r.messages("/host/frame")[12][1]["flags"] & 1, "quitting in its last frame"
        assert r.summary["frames"] == 13
    assert r.summary["host"]["state"] == "exited"


def test_a_killed_run_keeps_what_came_before(tmp_path):
    """SIGKILL to the whole run (harness, log worker, host) in real-time mode once the
    first chunks are on disk (a few wall seconds): run.mcap still holds the simulated
    seconds before."""
    import sys

    require_build()
    mission = tmp_path / "long.toml"
    mission.write_text("duration_s = 30.0\n[[command]]\nt = 1.2\nfwd_cmd = 1\nspeed = 100\n"
                       "distance = 5000\n")
    out = tmp_path / "out"
    times = _kill_when_chunks_on_disk([sys.executable, "-c", _RUN_CODE, str(mission), str(out),
                                       "realtime"], out, min_bytes=12_000, timeout_s=20.0)
    assert times, "messages of the first seconds survived"
    assert 0.9 <= max(times) < 10.0, max(times)
    assert not (out / "summary.json").exists()


def _kill_when_chunks_on_disk(cmd, out, min_bytes, timeout_s=60.0):
    """Run `cmd` in its own session; SIGKILL the whole session (harness, log worker, host)
    once `out`/run.mcap holds `min_bytes` bytes (at most `timeout_s` s of wall time).
    Returns the message log times (s) the file kept."""
    import glob
    import signal
    import subprocess
    import time

    from mcap.records import Message
    from mcap.stream_reader import StreamReader

    p = subprocess.Popen(cmd, start_new_session=True)
    try:
        deadline = time.monotonic() + timeout_s
        f = out / "run.mcap"
        while time.monotonic() < deadline and p.poll() is None:
            if f.exists() and f.stat().st_size >= min_bytes:
                break
            time.sleep(0.005)
        assert p.poll() is None, "the run ended before it was killed"
    finally:
        os.killpg(p.pid, signal.SIGKILL)
        p.wait()
        # the host may still remove its region itself (its parent's death ends it cleanly)
        for shm in glob.glob(f"/dev/shm/navkit-sim-{p.pid}-*"):
            with contextlib.suppress(FileNotFoundError):
                os.unlink(shm)
    times = []
    with open(out / "run.mcap", "rb") as fh:
        try:
            for rec in StreamReader(fh, skip_magic=False).records:
                if isinstance(rec, Message):
                    times.append(rec.log_time / 1e9)
        except Exception:  # noqa: BLE001 - the file ends mid-record: expected
            pass
    return times


_RUN_CODE = ("import sys; from pathlib import Path; from navkit.sim.harness import SimOptions, run;"
             "from navkit.sim.mission import load;"
             "run(SimOptions(mission=load(sys.argv[1]), out=Path(sys.argv[2]),"
             " realtime=sys.argv[3] == 'realtime', plot=False))")


def test_a_killed_lockstep_run_keeps_what_came_before(tmp_path, capsys):
    """The same in lockstep, hundreds of times faster than real time: killed once a few
    chunks are on disk, the file still holds whole simulated seconds from 0; `navkit plot`
    and `results.load` read it (no footer, no summary), saying on stderr that it is
    truncated and up to what log time they read it."""
    import sys

    from navkit.cli import main
    from navkit.sim.results import load

    require_build()
    mission = tmp_path / "long.toml"
    mission.write_text("duration_s = 3000.0\n[[command]]\nt = 1.2\nfwd_cmd = 1\nspeed = 100\n"
                       "distance = 50000\n")
    out = tmp_path / "out"
    times = _kill_when_chunks_on_disk([sys.executable, "-c", _RUN_CODE, str(mission), str(out),
                                       "lockstep"], out, 150_000)
    assert times, "messages of the first seconds survived"
    assert min(times) == 0.0 and 2.0 <= max(times) < 2900.0, (min(times), max(times))
    assert not (out / "summary.json").exists()
    capsys.readouterr()
    r = load(out)
    err = capsys.readouterr().err
    assert r.summary == {} and r.metadata["seed"] == "1"
    assert sorted(t for msgs in r.topics.values() for t, _ in msgs) == sorted(times), \
        "every message of the file's whole chunks, no more"
    assert r.truncated["last_log_time_s"] == max(times)
    assert r.truth[-1]["t"] == pytest.approx(max(t for t, _ in r.messages("/truth")))
    assert f"{out / 'run.mcap'}: truncated" in err and f"up to log time {max(times):.3f} s" in err
    assert main(["plot", str(out / "run.mcap"), "-o", str(tmp_path / "killed.png")]) == 0
    cap = capsys.readouterr()
    assert cap.out.strip() == str(tmp_path / "killed.png") and "truncated" in cap.err
    assert "Traceback" not in cap.err and (tmp_path / "killed.png").stat().st_size > 10_000


def test_bench_sim_prints_its_figures(capsys):
    from navkit import sim_bench

    require_build()
    parser = argparse.ArgumentParser()
    sim_bench.add_arguments(parser)
    assert sim_bench.run(parser.parse_args(["--minutes", "0.5"])) == 0
    out = capsys.readouterr().out
    assert "real-time factor" in out and "FMUs" in out and "host frame" in out
    assert "peak memory" in out and "log worker on the other CPU" in out


@pytest.mark.parametrize("seed", [2 ** 31, 5_000_000_000, -(2 ** 31) - 1, 2 ** 32 - 1])
def test_a_seed_the_plant_cannot_take_is_refused(seed, tmp_path, capsys):
    """The built plant's seed is an Int32: fmpy would wrap 5000000000 to 705032704 (and
    4294967295 to -1) silently, giving another seed's run under this seed's name."""
    from navkit.cli import main
    from navkit.paths import build_dir

    require_build()
    mission = tmp_path / "m.toml"
    mission.write_text("duration_s = 0.3\n")
    assert main(["sim", "--mission", str(mission), "--out", str(tmp_path / "out"),
                 "--seed", str(seed), "--no-plot"]) == 1
    out = capsys.readouterr().err
    assert out == (f"navkit sim: --seed {seed}: outside -2147483648..2147483647, the values "
                   f"of the plant FMU's seed parameter (Int32, "
                   f"{build_dir() / 'fmus' / 'navkit_plant.fmu'})\n")
    assert not (tmp_path / "out").exists(), "refused before anything starts"


@pytest.mark.parametrize("seed", [2 ** 31 - 1, -(2 ** 31)])
def test_the_seeds_at_the_ends_of_the_plants_range_run(seed, tmp_path_factory):
    r = run_mission(tmp_path_factory, "seed-ends", "duration_s = 0.3\n", seed=seed)
    assert r.metadata["seed"] == str(seed) and r.summary["seed"] == seed
    assert r.truth[-1]["t"] == pytest.approx(0.3)


def test_a_relative_config_folder_is_the_callers(tmp_path, monkeypatch, capsys):
    """`--config cfg` names a folder relative to where navkit runs, although the host runs
    in the output folder."""
    import shutil

    from navkit.cli import main
    from navkit.paths import repo_root

    require_build()
    shutil.copytree(repo_root() / "config", tmp_path / "cfg")
    (tmp_path / "m.toml").write_text("duration_s = 0.3\n")
    monkeypatch.chdir(tmp_path)
    assert main(["sim", "--mission", "m.toml", "--out", "out", "--config", "cfg", "--no-plot"]) == 0, \
        capsys.readouterr().err
    assert json.loads((tmp_path / "out" / "summary.json").read_text())["frames"] == 3
