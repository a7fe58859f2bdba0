"""The `navkit` command line itself: its help lists every subcommand, no command is a
usage error (status 2), an unknown one is one line naming the choices (status 2)."""

import subprocess
import sys

from navkit.cli import SUBCOMMANDS


def _navkit(*args) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "navkit", *args], capture_output=True, text=True,
                          timeout=60)


def test_help_lists_every_subcommand():
    r = _navkit("--help")
    assert r.returncode == 0, r.stderr
    for name, (_, help_text) in SUBCOMMANDS.items():
        assert name in r.stdout and help_text.split()[0] in r.stdout, name


def test_no_command_is_a_usage_error():
    r = _navkit()
    assert r.returncode == 2
    assert r.stdout.startswith("usage: navkit"), r.stdout


def test_unknown_command_is_one_line_naming_the_choices():
    r = _navkit("bogus", "--x")
    assert r.returncode == 2
    last = r.stderr.strip().splitlines()[-1]
    assert last == f"navkit: error: unknown command 'bogus' (choose from {', '.join(SUBCOMMANDS)})", r.stderr
    assert "Traceback" not in r.stderr


def test_ctrl_c_before_a_run_started_is_one_line_and_status_130(tmp_path):
    """Ctrl-C while `navkit sim` still reads its mission (a FIFO nobody writes, so the
    moment is known: the command holds its read end) stops it with one line, no
    traceback, status 130 (128 + SIGINT), and leaves no output folder."""
    import os
    import signal
    import time

    fifo = tmp_path / "mission.toml"
    os.mkfifo(fifo)
    out = tmp_path / "out"
    p = subprocess.Popen([sys.executable, "-m", "navkit", "sim", "--mission", str(fifo), "--out", str(out)],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                         preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    writer = None
    try:
        deadline = time.monotonic() + 30
        while writer is None:       # ENXIO until the command opens the FIFO to read it
            try:
                writer = os.open(fifo, os.O_WRONLY | os.O_NONBLOCK)
            except OSError:
                assert p.poll() is None and time.monotonic() < deadline, p.communicate()
                time.sleep(0.01)
        time.sleep(0.05)            # into its read, which waits for bytes that never come
        p.send_signal(signal.SIGINT)
        _, err = p.communicate(timeout=30)
    finally:
        if writer is not None:
            os.close(writer)
        if p.poll() is None:
            p.kill()
    assert p.returncode == 130, err
    assert err.strip().splitlines() == ["navkit sim: stopped by SIGINT"], err
    assert not out.exists()
