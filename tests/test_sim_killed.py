"""Reading what a killed run left: run.mcap cut at any byte (as SIGKILL leaves it, with no
summary or footer) is read up to its last whole chunk by `results.load` and `navkit plot`,
with a warning on stderr; a file that is not MCAP is a one-line error naming it. (A real
SIGKILLed run: test_sim_outputs.py::test_a_killed_lockstep_run_keeps_what_came_before.)"""

import json

import pytest

from sim_helpers import run_mission

pytestmark = pytest.mark.timeout(120)

MISSION = """
duration_s = 3.0
[[command]]
t = 0.5
fwd_cmd = 1
speed = 300
distance = 400
"""


def _chunks(path):
    """[(end offset of the chunk record, its messages as (log_time_ns, topic, data))] of a
    whole MCAP file, from its chunk indexes (the seeking reader, independent of the
    front-to-back reading under test)."""
    from mcap.reader import make_reader
    from mcap.records import Chunk, Message
    from mcap.stream_reader import StreamReader, breakup_chunk

    out = []
    with open(path, "rb") as f:
        summary = make_reader(f).get_summary()
        for ci in sorted(summary.chunk_indexes, key=lambda c: c.chunk_start_offset):
            f.seek(ci.chunk_start_offset)
            chunk = next(StreamReader(f, skip_magic=True, emit_chunks=True).records)
            assert isinstance(chunk, Chunk)
            msgs = [(m.log_time, summary.channels[m.channel_id].topic, m.data)
                    for m in breakup_chunk(chunk) if isinstance(m, Message)]
            out.append((ci.chunk_start_offset + ci.chunk_length, msgs))
    return out


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    return run_mission(tmp_path_factory, "killed-cuts", MISSION)


def test_a_whole_file_reads_as_the_seeking_reader_gives_it(run, capsys):
    from mcap.reader import make_reader

    from navkit.sim.results import load

    with open(run.out / "run.mcap", "rb") as f:
        expect = {}
        for _s, ch, m in make_reader(f).iter_messages(log_time_order=True):
            expect.setdefault(ch.topic, []).append((m.log_time / 1e9, json.loads(m.data)))
    r = load(run.out)
    assert r.truncated is None and "truncated" not in capsys.readouterr().err
    assert r.topics == expect, "same messages in the same order (log time, then file order)"


@pytest.mark.parametrize("where", ["inside the closing magic", "inside a chunk",
                                   "inside a record's header", "after a chunk"])
def test_a_cut_file_is_read_to_its_last_whole_chunk(run, where, tmp_path, capsys):
    from navkit.cli import main
    from navkit.sim.results import load

    data = (run.out / "run.mcap").read_bytes()
    chunks = _chunks(run.out / "run.mcap")
    assert len(chunks) >= 3, "a 3 s run holds at least 3 chunks"
    second_end = chunks[1][0]
    cut = {"inside the closing magic": len(data) - 3,
           "inside a chunk": second_end - 100,
           "inside a record's header": second_end + 4,   # opcode and half the length
           "after a chunk": second_end}[where]
    out = tmp_path / "killed"
    out.mkdir()
    (out / "run.mcap").write_bytes(data[:cut])
    expect = sorted((m for end, msgs in chunks if end <= cut for m in msgs),
                    key=lambda m: m[0])
    r = load(out)
    got = [(t, topic) for topic, msgs in r.topics.items() for t, _ in msgs]
    assert sorted(got) == sorted((t / 1e9, topic) for t, topic, _ in expect)
    assert r.metadata["seed"] == "1" and r.summary == {}
    last = max(t for t, _, _ in expect)
    assert r.truncated["last_log_time_s"] == last / 1e9 and r.truncated["size"] == cut
    err = capsys.readouterr().err
    assert f"{out / 'run.mcap'}: truncated" in err and f"up to log time {last / 1e9:.3f} s" in err
    assert main(["plot", str(out / "run.mcap"), "-o", str(tmp_path / "p.png")]) == 0
    cap = capsys.readouterr()
    assert "truncated" in cap.err and (tmp_path / "p.png").exists()


@pytest.mark.parametrize("content, reason", [
    (b"", "not an MCAP file"),
    (b"PK\x03\x04 a zip, not a run" * 4, "not an MCAP file"),
    (b"\x89MCAP0\r\n", "no /truth messages"),        # killed before the first chunk
])
def test_navkit_plot_names_the_file_on_one_line(content, reason, tmp_path, capsys):
    from navkit.cli import main

    f = tmp_path / "run.mcap"
    f.write_bytes(content)
    assert main(["plot", str(f), "-o", str(tmp_path / "p.png")]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1].startswith(f"navkit plot: {f}: ") and reason in err[-1], err
    assert not any("Traceback" in line for line in err)
    assert not (tmp_path / "p.png").exists()
