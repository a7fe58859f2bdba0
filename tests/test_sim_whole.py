"""`navkit sim` fast end to end: plot.png is drawn by the log worker (Pillow, no
matplotlib) from the messages it kept while it wrote run.mcap (no read-back), the same
figure `navkit plot` draws from the file, its errors told by navkit sim as its own; the
command's speed lines and --stamps; bench-sim's whole-command figures; a run stopped
before its first /truth has no plot."""

import argparse
import json
import struct

import pytest

from sim_helpers import require_build

pytestmark = pytest.mark.timeout(180)

# commands and a fault: the plot marks both
MISSION = """
duration_s = 4.0
[[command]]
t = 0.5
fwd_cmd = 1
speed = 300
distance = 300
[[command]]
t = 2.0
turn_mode = 1
turn_rate = 300
turn_distance = 450
[[fault]]
t = 2.5
kind = "unplug"
duration_s = 0.5
"""

# summary.json values that are measurements of this run's machine, not of the run
_MEASURED = {"wall_time_s", "realtime_factor", "memory_peak_mib", "time_share_s", "log_worker_cpu_s"}


def _png_size(path) -> tuple:
    """(width, height) in pixels of PNG file `path`: its signature and IHDR chunk."""
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and data[12:16] == b"IHDR", path
    return struct.unpack(">II", data[16:24])


def _drawn_in_the_harness(*_a, **_k):
    raise AssertionError("plot.png drawn in the harness, not by the log worker")


def test_sim_plot_is_navkit_plot_of_its_run_mcap_without_reading_it_back(tmp_path, monkeypatch, capsys):
    """plot.png is drawn by the log worker (the harness's plot_mcap fails here) from the
    series it kept (reading run.mcap fails here), is a 990 x 1210 PNG (9 x 11 in at 110
    dpi) and is byte for byte what `navkit plot run.mcap` draws. The speed lines give the
    loop and the whole command with its parts; --stamps has the phases in order."""
    from navkit import plot
    from navkit.cli import main
    from navkit.sim import harness, results

    require_build()
    (tmp_path / "m.toml").write_text(MISSION)
    out, stamps = tmp_path / "out", tmp_path / "stamps.json"

    def no_read_back(*_a, **_k):
        raise AssertionError("run.mcap read back")

    monkeypatch.setattr(results, "iter_mcap", no_read_back)
    monkeypatch.setattr(harness, "plot_mcap", _drawn_in_the_harness)
    assert main(["sim", "--mission", str(tmp_path / "m.toml"), "--out", str(out), "--no-progress",
                 "--stamps", str(stamps)]) == 0
    monkeypatch.undo()
    text = capsys.readouterr().out
    assert "4.0 s simulated in" in text and "x real time, 40 host frames" in text, text
    whole = [ln for ln in text.splitlines() if "the whole command:" in ln]
    parts = [ln for ln in text.splitlines() if ln.strip().startswith("of it: start-up")]
    assert len(whole) == 1 and len(parts) == 1 and "outputs" in parts[0] and "plot.png" in parts[0], text
    st = json.loads(stamps.read_text())
    keys = ["cli", "run", "started", "loop", "stopped", "summary", "plot", "end"]
    assert list(st) == keys and [st[k] for k in keys] == sorted(st.values()), st
    assert _png_size(out / "plot.png") == (990, 1210)
    assert main(["plot", str(out / "run.mcap"), "-o", str(tmp_path / "replot.png")]) == 0
    assert (out / "plot.png").read_bytes() == (tmp_path / "replot.png").read_bytes()
    fig = plot.mcap_figure(out / "run.mcap")
    marks = {c.get_gid(): [seg[0][0] for seg in c.get_segments()] for c in fig.axes[1].collections}
    assert marks == {"command": [0.5, 2.0], "event": [2.5, 3.0]}, "both commands, the unplug and the plug"


def test_a_plot_the_worker_cannot_write_is_navkit_sims_one_line(tmp_path, monkeypatch, capsys):
    """plot.png that cannot be written (a folder of that name): the log worker's error,
    told by navkit sim as its own in one line naming the file, status 1; run.mcap and
    summary.json are written whole."""
    from navkit.cli import main
    from navkit.sim import harness
    from navkit.sim.results import load

    require_build()
    (tmp_path / "m.toml").write_text(MISSION)
    out = tmp_path / "out"
    (out / "plot.png").mkdir(parents=True)
    monkeypatch.setattr(harness, "plot_mcap", _drawn_in_the_harness)
    assert main(["sim", "--mission", str(tmp_path / "m.toml"), "--out", str(out), "--no-progress"]) == 1
    err = capsys.readouterr().err
    assert err.strip().splitlines()[-1] == f"navkit sim: {out / 'plot.png'}: Is a directory", err
    assert "Traceback" not in err, err
    assert load(out).summary["sim_time_s"] == pytest.approx(4.0)


def test_an_inline_log_has_the_harness_draw_the_plot(tmp_path):
    """With the log written in the harness's process (log_inline: no worker), the harness
    draws plot.png from the series the log kept: what `navkit plot run.mcap` draws."""
    from navkit.cli import main
    from navkit.sim.harness import SimOptions, run
    from navkit.sim.mission import loads

    require_build()
    out = tmp_path / "out"
    run(SimOptions(mission=loads(MISSION, tmp_path / "m.toml"), out=out, log_inline=True, progress=False))
    assert main(["plot", str(out / "run.mcap"), "-o", str(tmp_path / "replot.png")]) == 0
    assert (out / "plot.png").read_bytes() == (tmp_path / "replot.png").read_bytes()


def test_summary_and_run_mcap_do_not_depend_on_the_plot(tmp_path):
    """The same run with and without plot.png: summary.json has the same keys and the same
    values but for the machine's measurements, and run.mcap the same messages and metadata
    (the plot's series are not in either)."""
    from navkit.sim.harness import SimOptions, run
    from navkit.sim.mission import loads
    from navkit.sim.results import load

    require_build()
    runs = {}
    for plot in (True, False):
        out = tmp_path / f"plot-{plot}"
        run(SimOptions(mission=loads(MISSION, tmp_path / "m.toml"), out=out, plot=plot, progress=False))
        assert (out / "plot.png").exists() == plot
        runs[plot] = load(out)
    with_plot, without = runs[True], runs[False]
    assert "plot" not in with_plot.summary
    strip = lambda s: {k: v for k, v in s.items() if k not in _MEASURED}  # noqa: E731
    assert strip(with_plot.summary) == strip(without.summary)
    assert with_plot.topics == without.topics and with_plot.metadata == without.metadata


def test_the_log_writer_keeps_what_navkit_plot_reads_from_the_file(tmp_path):
    """A long run's messages through the run log's Recorder: the series it keeps as it
    writes (RunSeries, handed over at close) are those navkit plot streams out of the
    file: /truth and /micro/data thinned to PLOT_POINTS..2 * PLOT_POINTS messages each,
    every /planner/cmd and /events message, the other topics not at all."""
    from navkit import plot
    from navkit.sim.record import Recorder

    path = tmp_path / "run.mcap"
    rec = Recorder(path, {})
    for i in range(20_000):             # 400 s at 50 Hz, /micro/data at 10 Hz
        t_ns = i * 20_000_000
        rec.reserve(t_ns, t_ns)
        rec.write("/truth", t_ns, {"t": t_ns / 1e9, "x_mm": i * 0.5, "y_mm": 0.0, "v_mm_s": 25.0,
                                   "heading_deg": i % 360})
        if i % 5 == 0:
            rec.write("/micro/data", t_ns, {"x": i // 2, "y": 0, "fwd_speed": 25, "heading": i % 3600})
            rec.write("/host/frame", t_ns, {"frame": i // 5})
        if i % 2000 == 0:
            rec.write("/planner/cmd", t_ns, {"fwd_cmd": 1, "speed": 25, "distance": 100})
            rec.write("/events", t_ns, {"t": t_ns / 1e9, "kind": "key", "detail": {}})
        rec.flush_before(t_ns + 20_000_000)
    rec.close()
    kept = rec.plot_series.raw()
    assert set(kept) == {"/truth", "/micro/data", "/planner/cmd", "/events"}
    for topic in ("/truth", "/micro/data"):
        assert plot.PLOT_POINTS <= len(kept[topic]) <= 2 * plot.PLOT_POINTS, (topic, len(kept[topic]))
    assert len(kept["/planner/cmd"]) == len(kept["/events"]) == 10
    assert plot.decoded(kept) == plot.decoded(plot._read_series(path))


@pytest.mark.parametrize("least", [7, 512])
def test_fields_found_ahead_are_those_found_when_drawn(monkeypatch, least):
    """RunSeries.find_ahead (the log worker between batches), at random moments across
    the thinning's halvings: fields() given what it found returns the arrays it finds
    from the kept messages alone; a message whose field is not a plain number stops
    finding ahead and fields() decodes them all, as it would."""
    import functools
    import random

    import numpy as np

    from navkit import plot

    monkeypatch.setattr(plot, "_FIND_AT_LEAST", least)
    rng = random.Random(least)
    series = plot.RunSeries(cap=400)
    truth, micro = series.sink("/truth"), series.sink("/micro/data")
    dumps = functools.partial(json.dumps, separators=(",", ":"))     # as the log writes them
    for i in range(20_000):
        t_ns = i * 10_000_000
        truth(t_ns, dumps({"t": t_ns / 1e9, "x_mm": rng.uniform(-1e4, 1e4), "y_mm": rng.random(),
                                "v_mm_s": rng.randint(-300, 300), "heading_deg": 1e-7 * i}).encode())
        if i % 4 == 0:
            micro(t_ns, dumps({"x": i, "y": -i, "fwd_speed": 3, "heading": i % 3600,
                                    "extra": {"x": 1}} if i == 16_000 else
                                   {"x": i, "y": -i, "fwd_speed": 3, "heading": i % 3600}).encode())
        if rng.random() < 0.01:
            series.find_ahead()
    raw, found = series.raw(), series.found()
    assert found["/truth"][0] > 0
    if least < 10:                      # searched after the nested x (else only when drawn)
        assert "/micro/data" not in found, "a nested x stops finding ahead"
    for topic, keys in plot.RUN_FIELDS.items():
        t_ahead, ahead = plot.fields(topic, raw[topic], keys, found.get(topic))
        t_end, end = plot.fields(topic, raw[topic], keys)
        assert np.array_equal(t_ahead, t_end) and list(ahead) == list(keys)
        assert all(np.array_equal(ahead[k], end[k]) for k in keys), topic


def test_decoded_series_parse_each_message_as_one_json_value():
    """decoded(): each message its own JSON value in log-time order (file order among
    equal times); a message holding two values is an error, not two messages."""
    from navkit import plot

    raw = {"/truth": [(2, b'{"t": 2}'), (1, b"[1, 2]"), (1, b'"a,b"')], "/events": []}
    assert plot.decoded(raw) == {"/truth": [(1, [1, 2]), (1, "a,b"), (2, {"t": 2})], "/events": []}
    with pytest.raises(ValueError):
        plot.decoded({"/truth": [(1, b"1, 2")]})


def test_bench_sim_prints_the_whole_command_and_its_parts(capsys):
    """bench-sim runs `python -m navkit sim` as a user does and prints its wall time and
    the parts of it, which add up to it."""
    from navkit import sim_bench

    require_build()
    parser = argparse.ArgumentParser()
    sim_bench.add_arguments(parser)
    assert sim_bench.run(parser.parse_args(["--minutes", "0.2", "--whole", "1"])) == 0
    out = capsys.readouterr().out
    lines = out.splitlines()
    head = [i for i, ln in enumerate(lines) if ln.startswith("whole command")]
    assert len(head) == 1 and "12 s simulated in" in lines[head[0]], out
    parts = lines[head[0] + 1:head[0] + 1 + len(sim_bench.PHASES)]
    assert [ln.split("  ")[1].strip() for ln in parts] == [name for _, name in sim_bench.PHASES], out
    secs = [float(ln.rsplit(" s ", 1)[0].split()[-1]) for ln in parts]
    total = float(lines[head[0]].split(" in ")[1].split(" s wall")[0])
    assert all(s >= 0 for s in secs) and abs(sum(secs) - total) < 0.01 + 0.001 * len(secs), (secs, total)


# `navkit sim` whose loop is stopped by SIGTERM before its first step, as a signal in the
# set-up's last moment stops it: the run has no /truth message to draw
_STOPPED_AT_ONCE = """
import os, signal, sys
from navkit.cli import main
from navkit.sim import harness

def stopped(rig, faults):
    os.kill(os.getpid(), signal.SIGTERM)
    raise AssertionError("SIGTERM did not stop the run")

def drawn_in_the_harness(*_a, **_k):
    raise AssertionError("plot.png drawn in the harness, not by the log worker")

harness.run_lockstep = stopped
harness.plot_mcap = drawn_in_the_harness
sys.exit(main(["sim", "--mission", sys.argv[1], "--out", sys.argv[2], "--no-progress"]))
"""


def test_a_run_stopped_before_its_first_truth_says_why_it_has_no_plot(tmp_path):
    """Stopped before any /truth: the outputs closed, summary.json says interrupted, no
    plot.png and one warning naming it (not a traceback; the log worker's error, the
    harness draws nothing), status 128 + SIGTERM."""
    import signal
    import subprocess
    import sys

    require_build()
    (tmp_path / "m.toml").write_text(MISSION)
    out = tmp_path / "out"
    done = subprocess.run([sys.executable, "-c", _STOPPED_AT_ONCE, str(tmp_path / "m.toml"), str(out)],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 128 + signal.SIGTERM, done.stderr
    assert "Traceback" not in done.stderr, done.stderr
    assert f"warning: {out / 'plot.png'}: not drawn: no /truth messages" in done.stderr, done.stderr
    assert json.loads((out / "summary.json").read_text())["interrupted"]["signal"] == "SIGTERM"
    assert not (out / "plot.png").exists()
