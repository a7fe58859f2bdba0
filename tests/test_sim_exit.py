"""The navkit command's `sim` ends at once when the run has returned (navkit.cli.main,
EXIT_AT_ONCE): what it printed is all there (flushed before os._exit), its outputs are
whole, its exit status is the run's, and in-process callers of main() get the status
back instead of an exit."""

import json

from navkit.cli import main
from sim_helpers import navkit_sim, require_build

MISSION = 'duration_s = 1.0\n[[key]]\nt = 0.2\nkey = "R"\n[[key]]\nt = 0.8\nkey = "S"\n'


def test_navkit_sim_exits_at_once_with_everything_written(tmp_path):
    require_build()
    (tmp_path / "m.toml").write_text(MISSION)
    r = navkit_sim(["--mission", tmp_path / "m.toml", "--out", tmp_path / "out", "--no-plot",
                    "--stamps", tmp_path / "st.json"], timeout=120)
    assert r.returncode == 0, r.stderr
    lines = r.stdout.splitlines()
    assert lines[0].startswith("mission ") and any(ln.startswith("speed ") for ln in lines), r.stdout
    assert lines[-1].strip().startswith("of it: start-up"), "the last line, flushed before the exit"
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["frames"] == 10
    assert json.loads((tmp_path / "st.json").read_text())["end"] > 0
    assert list((tmp_path / "out").glob("Data *.txt")), "the host's datalog, closed by the host"
    # a refusal: the same exit at once, its one line on stderr
    r = navkit_sim(["--mission", tmp_path / "none.toml", "--out", tmp_path / "out2", "--no-plot"], timeout=120)
    assert r.returncode == 1 and r.stderr == f"navkit sim: {tmp_path / 'none.toml'}: cannot read: No such file or directory\n"


def test_main_with_arguments_returns_the_status(tmp_path, capsys):
    assert main(["sim", "--mission", str(tmp_path / "none.toml"), "--out", str(tmp_path / "o"),
                 "--no-plot"]) == 1
    assert "cannot read" in capsys.readouterr().err


def test_a_closed_stdout_is_one_line_not_a_traceback(tmp_path):
    """stdout's reader gone before the run prints (`navkit sim | head` that ended): status 1
    and one line saying so, the run's outputs whole."""
    import os

    require_build()
    (tmp_path / "m.toml").write_text(MISSION)
    read_end, write_end = os.pipe()
    os.close(read_end)
    try:
        r = navkit_sim(["--mission", tmp_path / "m.toml", "--out", tmp_path / "out", "--no-plot"],
                       timeout=120, stdout=write_end)
    finally:
        os.close(write_end)
    assert r.returncode == 1 and r.stderr == "navkit sim: stdout: its reader closed it (output cut short)\n", r.stderr
    assert json.loads((tmp_path / "out" / "summary.json").read_text())["frames"] == 10
