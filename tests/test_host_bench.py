"""`navkit bench-host`: the timing-log arithmetic, and a short real run of the real
binary (figures are printed, never asserted: speed is not a test)."""

import argparse

import pytest

from navkit import host_bench
from host_helpers import require_host
pytestmark = pytest.mark.timeout(60)


def test_summarize_counts_overruns_skips_and_drift(tmp_path):
    log = tmp_path / "t.txt"
    # period 100 ns; frame 1 ends late (overrun), frames 2 and 3 were skipped
    log.write_text("# frame scheduled_ns start_ns end_ns (since t0), period_ns 100\n"
                   "0 0 0 10\n1 100 105 350\n4 400 410 420\n5 500 530 540\n")
    s = host_bench.summarize(log)
    assert s["frames"] == 4 and s["overruns"] == 1 and s["skipped"] == 2
    assert s["start_error_us"]["max"] == pytest.approx(0.030)
    assert s["drift_us"] == pytest.approx(0.030)
    assert s["work_us"]["max"] == pytest.approx(0.245)


def test_short_run_of_the_benchmark(tmp_path, capsys):
    require_host()
    parser = argparse.ArgumentParser()
    host_bench.add_arguments(parser)
    assert host_bench.run(parser.parse_args(["--seconds", "0.5", "--rates", "20",
                                             "--keep", str(tmp_path)])) == 0
    out = capsys.readouterr().out
    assert "20 Hz:" in out and "start error median" in out and "CPU" in out
    assert "micro configured" in (tmp_path / "host-20hz.log").read_text(), \
        "the bench's micro answered and the host configured it"
