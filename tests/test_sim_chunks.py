"""run.mcap's chunks hold at most 1 s of simulated data (latest minus earliest log time)
whatever the host frame period (`navkit sim --frame-ms`): closed at a frame end before a
frame that would pass 1 s, and between truth rows when one frame is longer than 1 s.
(100 ms frames: test_sim_outputs.py; real time: test_realtime_mode_paces_to_the_wall_clock.)"""

import shutil

import pytest

from sim_helpers import chunk_spans, require_build, run_mission

pytestmark = pytest.mark.timeout(120)

MISSION = """
duration_s = 6.0
[[command]]
t = 0.0
fwd_cmd = 1
speed = 300
distance = 1000
"""


def config_with_watchdog(tmp_path_factory, watchdog_ms: int):
    """A copy of config/ whose [micro_cfg_motion] watchdog_timeout is `watchdog_ms` (ms)."""
    from navkit.paths import repo_root

    d = tmp_path_factory.mktemp(f"config-wd{watchdog_ms}")
    for name in ("NavAndControl.ini", "sensors.ini"):
        shutil.copy(repo_root() / "config" / name, d / name)
    ini = d / "NavAndControl.ini"
    text = ini.read_text()
    assert "\nwatchdog_timeout = 300\n" in text
    ini.write_text(text.replace("\nwatchdog_timeout = 300\n", f"\nwatchdog_timeout = {watchdog_ms}\n"))
    return d


@pytest.mark.parametrize("frame_ms", [300, 150, 1500])
def test_no_chunk_spans_more_than_one_simulated_second(tmp_path_factory, frame_ms):
    # frames this long need a watchdog above two of them (the shipped 300 ms allows 149 ms)
    config = config_with_watchdog(tmp_path_factory, 2 * frame_ms + 1)
    r = run_mission(tmp_path_factory, f"chunks-{frame_ms}ms", MISSION, frame_s=frame_ms / 1000,
                    config_dir=config)
    frame_ns = frame_ms * 1_000_000
    spans = chunk_spans(r.out / "run.mcap")
    assert all(t1 - t0 <= 1_000_000_000 for t0, t1 in spans), spans
    assert spans[0][0] == 0 and spans[-1][1] == 6_000_000_000, "the whole run, 0 .. 6 s"
    assert all(a[1] <= b[0] for a, b in zip(spans, spans[1:])), "in time order, no overlap"
    if frame_ms <= 1000:
        # closed at frame ends only, and only when the next frame would not fit
        assert all(t0 % frame_ns == 0 for t0, _ in spans), spans
        assert all(t1 - t0 > 1_000_000_000 - frame_ns for t0, t1 in spans[:-1]), spans
    else:
        # a frame longer than 1 s is split between its truth rows (20 ms apart)
        assert all(t1 - t0 >= 1_000_000_000 - 20_000_000 or t1 % frame_ns == 0
                   for t0, t1 in spans), spans
    assert len(r.messages("/truth")) == 6 * 50 + 1, "every row written once"


@pytest.mark.parametrize("frame_ms, said", [
    (0, "--frame-ms 0: not a positive number of ms"),
    (-5, "--frame-ms -5: not a positive number of ms"),
    (2.5, "--frame-ms: a frame of 2.5 ms is not a whole number of the FMUs' 1 ms steps"),
    (150, "--frame-ms: a frame of 150 ms needs [micro_cfg_motion] watchdog_timeout above two frames (300 ms)"),
])
def test_a_frame_the_run_cannot_keep_is_refused(frame_ms, said, tmp_path, capsys):
    """A frame of no length, of part of an FMU step, or one the micro's watchdog would
    stop the robot in after a single lost frame: refused before anything starts."""
    from navkit.cli import main

    require_build()
    mission = tmp_path / "m.toml"
    mission.write_text("duration_s = 0.3\n")
    rc = main(["sim", "--mission", str(mission), "--out", str(tmp_path / "out"),
               "--frame-ms", str(frame_ms), "--no-plot"])
    assert rc == (2 if frame_ms <= 0 else 1) and said in capsys.readouterr().err
    assert not (tmp_path / "out").exists(), "refused before anything starts"
