"""run.mcap's chunks hold at most 1 s of simulated data (latest minus earliest log time)
whatever the host frame period (`navkit sim --frame-ms`): closed at a frame end before a
frame that would pass 1 s, and between truth rows when one frame is longer than 1 s.
(100 ms frames: test_sim_outputs.py; real time: test_realtime_mode_paces_to_the_wall_clock.)"""

import pytest

from test_sim_util import run_mission

pytestmark = pytest.mark.timeout(120)

MISSION = """
duration_s = 6.0
[[command]]
t = 0.0
fwd_cmd = 1
speed = 300
distance = 1000
"""


def chunk_spans(path):
    """[(message_start_time, message_end_time) ns] of every chunk, in file order."""
    from mcap.reader import make_reader

    with open(path, "rb") as f:
        idx = make_reader(f).get_summary().chunk_indexes
    return [(c.message_start_time, c.message_end_time)
            for c in sorted(idx, key=lambda c: c.chunk_start_offset)]


@pytest.mark.parametrize("frame_ms", [300, 150, 1500])
def test_no_chunk_spans_more_than_one_simulated_second(tmp_path_factory, frame_ms):
    r = run_mission(tmp_path_factory, f"chunks-{frame_ms}ms", MISSION, frame_s=frame_ms / 1000)
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
