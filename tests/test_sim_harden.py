"""`navkit sim` pushed to break (issue 13, sim items): bad mission files and --out folders
are one line naming the file (and line) with exit 1, never a traceback; Ctrl-C and
SIGTERM stop a run cleanly (outputs closed, summary.json says interrupted, temporary
files gone, exit 128 + signal); a harness killed outright leaves no child running and a
closed run.mcap; two commands in one host frame are refused. The real harness, host and
FMUs as `navkit sim` runs them."""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from navkit.sim.mission import loads
from sim_helpers import navkit_sim, require_build

pytestmark = pytest.mark.timeout(120)

_LONG = """duration_s = 3000.0
[[command]]
t = 0.5
fwd_cmd = 1
speed = 200
distance = 100000
"""


def _one_line_error(r, *said):
    assert r.returncode == 1, r.stdout + r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in r.stderr, r.stderr
    for s in said:
        assert s in lines[0], lines[0]


@pytest.mark.parametrize("text, said", [
    (b"duration_s = 2.0\n# 90\xb0 turn\n", "m.toml:2: byte offset 21: 0xB0 is not UTF-8 text"),
    (bytes(range(256)) * 4, "m.toml:2: byte offset 128: 0x80 is not UTF-8 text"),
    (b"a = " + b"[" * 5000 + b"]" * 5000 + b"\n", "not valid TOML: arrays or tables nested too deeply"),
    (b"duration_s = 1e308\n", "key 'duration_s': 1e+308 must be <= 2147483.647"),
    (b"duration_s = 1e-9\n", "key 'duration_s': 1e-09 s is less than half a host frame (100 ms)"),
    (b"duration_s = 2.0\nworld = \"folder\"\n", "key 'world':"),
    (b"duration_s = 2.0\nworld = \"/dev/zero\"\n", "key 'world': /dev/zero is not a regular file"),
    (b"duration_s = 2.0\n[[command]]\nt = 1.0\nfwd_cmd = 1\n[[command]]\nt = 1.0\nfwd_cmd = 5\n",
     "m.toml: [[command]] #2: key 't': 1 s takes effect in the same host frame (1 s) as [[command]] #1"),
    (b"duration_s = 2.0\n[[command]]\nt = 1.01\nfwd_cmd = 1\n[[command]]\nt = 1.05\nfwd_cmd = 5\n",
     "[[command]] #2: key 't': 1.05 s takes effect in the same host frame (1.1 s) as [[command]] #1 (t = 1.01 s)"),
])
def test_a_bad_mission_is_one_line_naming_the_file(tmp_path, text, said):
    (tmp_path / "folder").mkdir()
    (tmp_path / "m.toml").write_bytes(text)
    r = navkit_sim(["--mission", tmp_path / "m.toml", "--out", tmp_path / "out"])
    _one_line_error(r, str(tmp_path / "m.toml"), said)


def test_a_mission_linked_to_an_endless_file_is_refused(tmp_path):
    (tmp_path / "m.toml").symlink_to("/dev/zero")
    _one_line_error(navkit_sim(["--mission", tmp_path / "m.toml"]), "longer than 1048576 bytes: not a mission file")


def test_an_out_that_is_a_file_or_cannot_be_made_is_one_line(tmp_path):
    (tmp_path / "m.toml").write_text("duration_s = 1.0\n")
    (tmp_path / "f").write_text("")
    _one_line_error(navkit_sim(["--mission", tmp_path / "m.toml", "--out", tmp_path / "f"]), f"--out {tmp_path / 'f'}: not a folder")
    _one_line_error(navkit_sim(["--mission", tmp_path / "m.toml", "--out", tmp_path / "f" / "x"]),
                    f"--out {tmp_path / 'f' / 'x'}: cannot create it: {tmp_path / 'f'} is not a folder")


def test_entries_out_of_time_order_are_said():
    m = loads("duration_s = 5.0\n[[key]]\nt = 3.0\nkey = \"R\"\n[[key]]\nt = 1.0\nkey = \"S\"\n", "m.toml")
    assert [k.key for k in m.keys] == ["S", "R"]
    assert m.warnings == ["m.toml: [[key]] #2 (t = 1 s) comes after [[key]] #1 (t = 3 s) in the file: "
                          "entries run in time order"]


def _descendants(pid: int) -> set:
    """Every live process below `pid` (from /proc)."""
    kids = {}
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                ppid = int((d / "stat").read_text().rsplit(")", 1)[1].split()[1])
            except (OSError, IndexError, ValueError):
                continue
            kids.setdefault(ppid, set()).add(int(d.name))
    out, todo = set(), [pid]
    while todo:
        for k in kids.get(todo.pop(), ()):
            out.add(k)
            todo.append(k)
    return out


def _alive(pids) -> set:
    return {p for p in pids if Path(f"/proc/{p}").exists() and
            (Path(f"/proc/{p}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z")}


def _start(tmp_path, *extra):
    """navkit sim of a long mission in its own session, with TMPDIR its own; returns the
    process once the run is under way (host and log worker started)."""
    (tmp_path / "m.toml").write_text(_LONG)
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    env = dict(os.environ, TMPDIR=str(tmp))
    p = subprocess.Popen([sys.executable, "-m", "navkit", "sim", "--mission", str(tmp_path / "m.toml"),
                          "--out", str(tmp_path / "out"), *extra], env=env, stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True, start_new_session=True)
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline:
        log = tmp_path / "out" / "host.log"
        if log.exists() and "micro configured" in log.read_text(errors="replace"):
            return p
        assert p.poll() is None, p.communicate()
        time.sleep(0.05)
    p.kill()
    raise AssertionError("the run did not get under way")


def _mcap_closed(path: Path) -> bool:
    from mcap.reader import make_reader

    with open(path, "rb") as f:
        return make_reader(f).get_summary() is not None


@pytest.mark.parametrize("sig, group, status", [(signal.SIGINT, True, 130), (signal.SIGTERM, False, 143)])
def test_a_signal_stops_the_run_cleanly(tmp_path, sig, group, status):
    """Ctrl-C (SIGINT to the whole process group, as a terminal sends it) and SIGTERM to
    the harness alone (as `timeout` sends it)."""
    require_build()
    p = _start(tmp_path)
    kids = _descendants(p.pid)
    assert len(kids) >= 2, "the host and the log worker"
    (os.killpg if group else os.kill)(p.pid, sig)
    out, err = p.communicate(timeout=60)
    assert p.returncode == status, out + err
    assert "Traceback" not in err and "interrupted by" in err, err
    s = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert s["interrupted"]["signal"] == sig.name and 0 < s["interrupted"]["at_s"] < 3000
    assert s["host"]["exit_status"] == 0, (tmp_path / "out" / "host.log").read_text()[-600:]
    assert _mcap_closed(tmp_path / "out" / "run.mcap"), "run.mcap has its footer"
    assert list((tmp_path / "tmp").iterdir()) == [], "temporary files removed"
    assert not _alive(kids)


# A harness whose SIGTERM raises KeyboardInterrupt (as navkit sim's does) sends the log
# worker big batches while a child process sends it SIGTERM every few ms; the log must
# still close with the worker's results: no interrupt lands inside one message on the pipe.
_STORM = """
import os, signal, sys, time
from pathlib import Path
from navkit.sim.record import RunLog

armed = False        # raise only inside the try below, never in its except or after it


def stop(signum, frame):
    global armed
    if armed:
        armed = False
        raise KeyboardInterrupt(signum)

signal.signal(signal.SIGTERM, stop)
log = RunLog(Path(sys.argv[1]), {}, ["t"], 1, build=Path(sys.argv[2]))
parent = os.getpid()
storm = os.fork()
if storm == 0:
    for _ in range(400):
        os.kill(parent, signal.SIGTERM)
        time.sleep(0.002)
    os._exit(0)
interrupts, t_ns, line, done = 0, 0, "x" * 200000, False
while not done:
    try:
        armed = True
        t_ns += 1000000
        log.console(t_ns, [(1, line, 1)])
        log.end_frame(t_ns + 1000000)
        armed = False
        done = os.waitpid(storm, os.WNOHANG)[0] != 0
    except KeyboardInterrupt:
        interrupts += 1
signal.signal(signal.SIGTERM, signal.SIG_IGN)
t0 = time.monotonic()
res = log.close()
print(interrupts, bool(res), round(time.monotonic() - t0, 1))
"""


def test_a_signal_never_cuts_a_message_to_the_log_worker(tmp_path):
    from navkit.paths import build_dir

    out = subprocess.run([sys.executable, "-c", _STORM, str(tmp_path / "run.mcap"), str(build_dir())],
                         capture_output=True, text=True, timeout=90)
    assert out.returncode == 0, out.stderr[-2000:]
    interrupts, closed, close_s = out.stdout.split()
    assert int(interrupts) >= 50, out.stdout
    assert closed == "True", f"the worker never answered close() ({close_s} s): a message was cut"


@pytest.mark.parametrize("mode", [(), ("--realtime",)], ids=["lockstep", "realtime"])
def test_a_harness_killed_outright_leaves_no_child_and_a_closed_log(tmp_path, mode):
    """In lockstep the host sees its socket's EOF; in real time it runs on its own clock
    and gets SIGTERM when the harness dies."""
    require_build()
    p = _start(tmp_path, *mode)
    kids = _descendants(p.pid)
    assert len(kids) >= 2
    p.kill()                                  # SIGKILL to the harness alone
    p.communicate(timeout=30)
    deadline = time.monotonic() + 20
    while _alive(kids) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not _alive(kids), "every child ended with the harness"
    assert _mcap_closed(tmp_path / "out" / "run.mcap"), "the log worker closed run.mcap"


def test_plot_streams_any_size_of_run_in_bounded_memory(tmp_path):
    """A long run's run.mcap (here 20 000 /truth rows): the plot streams it and keeps an
    evenly thinned few thousand rows per line, so its memory does not grow with the file
    (reading it whole took 11 GB for a 400 MB file). Measured on the reading with a small
    cap: a whole read of this file peaks near 27 MB."""
    import tracemalloc

    import matplotlib.pyplot as plt
    from mcap.writer import Writer

    import navkit.sim.results  # noqa: F401  (imports are not the reading's memory)
    from navkit import plot

    path = tmp_path / "run.mcap"
    n = 20_000
    with open(path, "wb") as f:
        w = Writer(f)
        w.start()
        cid = w.register_channel("/truth", "json", w.register_schema("truth", "jsonschema", b"{}"))
        for i in range(n):
            row = {"t": i * 0.02, "x_mm": float(i), "y_mm": 0.5 * i, "yaw_deg": 0.0, "heading_deg": i % 360,
                   "v_mm_s": 200.0, "w_deg_s": 0.0, "distance_mm": float(i), "pad": "x" * 40}
            w.add_message(cid, log_time=i * 20_000_000, data=json.dumps(row).encode(), publish_time=0)
        w.finish()
    tracemalloc.start()
    kept = plot.decoded(plot._read_series(path, ("/truth",), (), cap=100))["/truth"]
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert 100 <= len(kept) <= 200 and kept[0][1]["t"] == 0.0 and kept[-1][1]["t"] > 0.95 * (n - 1) * 0.02
    assert peak < 12e6, f"peak {peak / 1e6:.1f} MB"
    fig = plot.mcap_figure(path)
    try:
        xs = fig.axes[1].get_lines()[0].get_xdata()
        assert plot.PLOT_POINTS <= len(xs) <= 2 * plot.PLOT_POINTS, len(xs)
    finally:
        plt.close(fig)


def test_a_long_run_shows_how_far_it_is(tmp_path):
    """`navkit sim` progress on stderr: a line at a time when it is not a terminal; on a
    terminal (a pty here) one line redrawn in place after the first second, removed at
    the end."""
    import re

    from navkit.sim.progress import Progress

    with open(tmp_path / "err", "w") as f:
        p = Progress(100.0, f, every_s=0.0)
        time.sleep(0.01)
        p.at(25.0)
    assert re.fullmatch(r"navkit sim: 25 of 100 s simulated \(25 %\), \d+x real time, ~\d+ s left; "
                        r"Ctrl-C stops it cleanly\n", (tmp_path / "err").read_text())
    master, slave = os.openpty()
    try:
        with open(slave, "w", closefd=False) as term:
            p = Progress(100.0, term)
            p.at(1.0)                     # the first second: nothing yet
            time.sleep(1.05)
            p.at(50.0)
            p.close()
        out = os.read(master, 4096).decode()
    finally:
        os.close(master)
        os.close(slave)
    assert re.fullmatch(r"\r50 of 100 s simulated \(50 %\), \d+x real time, ~\d+ s left; Ctrl-C stops it "
                        r"cleanly\x1b\[K\r\x1b\[K", out), repr(out)


def test_the_speed_line_gives_the_loop_and_the_whole_command(tmp_path):
    import re

    require_build()
    (tmp_path / "m.toml").write_text("duration_s = 2.0\n")
    r = navkit_sim(["--mission", tmp_path / "m.toml", "--out", tmp_path / "out", "--no-plot"])
    assert r.returncode == 0, r.stderr
    loop = re.search(r"^speed +2\.0 s simulated in ([0-9.]+) s wall = [0-9.]+x real time", r.stdout, re.M)
    whole = re.search(r"^ +the whole command: ([0-9.]+) s wall = [0-9.]+x real time \(with Python's start-up "
                      r"and the outputs\)$", r.stdout, re.M)
    assert loop and whole, r.stdout
    assert float(whole.group(1)) >= float(loop.group(1)), "the command holds the loop"
