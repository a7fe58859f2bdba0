"""`navkit plot -o FILE`: the image's format is its suffix's. A run plot and a datalog
plot to .png (the run plot drawn by navkit.figure_png, without matplotlib), to .svg
(matplotlib, the run plot's lines in their colours), and a suffix no writer has is
refused in one line naming the file, with nothing written; --repeat times the drawing."""

from pathlib import Path

import pytest

from navkit.cli import main
from sim_helpers import STRAIGHT, run_mission


def _outputs(tmp_path_factory) -> tuple[Path, Path]:
    """(run.mcap, the host's datalog) of a short recorded run (R ... S keys)."""
    text = STRAIGHT + '\n[[key]]\nt = 0.5\nkey = "R"\n[[key]]\nt = 4.0\nkey = "S"\n'
    r = run_mission(tmp_path_factory, "plot-out", text)
    logs = sorted(r.out.glob("Data *.txt"))
    assert logs, "R ... S recorded a datalog in the output folder"
    return r.out / "run.mcap", logs[0]


def test_plot_writes_the_format_its_suffix_names(tmp_path_factory, tmp_path, capsys):
    mcap, datalog = _outputs(tmp_path_factory)
    for src in (mcap, datalog):
        png, svg = tmp_path / f"{src.stem}.png", tmp_path / f"{src.stem}.svg"
        assert main(["plot", str(src), "-o", str(png)]) == 0
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        assert main(["plot", str(src), "-o", str(svg)]) == 0
        head = svg.read_bytes()[:400]
        assert head.startswith(b"<?xml") and b"<svg" in head, head[:80]
        if src == mcap:     # the truth's and the micro's lines
            assert b"stroke: #1f77b4" in svg.read_bytes() and b"stroke: #ff7f0e" in svg.read_bytes()
        # no suffix: the name as given, PNG bytes (matplotlib would append ".png")
        bare = tmp_path / f"{src.stem}-bare"
        assert main(["plot", str(src), "-o", str(bare)]) == 0
        assert bare.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    capsys.readouterr()


def test_plot_refuses_a_suffix_without_a_writer(tmp_path_factory, tmp_path, capsys):
    mcap, datalog = _outputs(tmp_path_factory)
    for src in (mcap, datalog):
        bad = tmp_path / f"{src.stem}.xyz"
        assert main(["plot", str(src), "-o", str(bad)]) == 1
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and err.startswith(f"navkit plot: {bad}: cannot write a .xyz image"), err
        assert ".png" in err and ".svg" in err and "Traceback" not in err
        assert not bad.exists()


def test_plot_repeat_times_the_drawing(tmp_path_factory, tmp_path, capsys):
    """--repeat N: a run drawn N times from its messages read once, the times printed, the
    PNG written; 0 is refused as a bad option."""
    mcap, _ = _outputs(tmp_path_factory)
    png = tmp_path / "r.png"
    assert main(["plot", str(mcap), "-o", str(png), "--repeat", "2"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("drawn 2 times from the messages read once: first ") and "median" in out, out
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with pytest.raises(SystemExit) as e:
        main(["plot", str(mcap), "--repeat", "0"])
    assert e.value.code == 2
