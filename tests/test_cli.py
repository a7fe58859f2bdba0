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
