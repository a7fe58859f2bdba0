"""The protocol's test and benchmark tools refuse non-positive or malformed counts with
exit status 2 and a message naming the option and the value, instead of running
nothing and passing: `navkit fuzz-proto`, `navkit-proto-bench` and `test_proto_props`
(the C binaries from the build folder)."""

import subprocess
import sys

import pytest

from navkit.paths import build_dir

NAVKIT = [sys.executable, "-m", "navkit"]


def _c_tool(name: str) -> str:
    exe = build_dir() / "tests" / "c" / "protocol" / name
    assert exe.exists(), f"{exe} is not built: cmake --build {build_dir()} --target {name}"
    return str(exe)


@pytest.mark.parametrize("args,message", [
    (["--count", "0"], "argument --count: must be at least 1, not 0"),
    (["--count", "-3"], "argument --count: must be at least 1, not -3"),
    (["--count", "many"], "argument --count: 'many' is not an integer"),
    (["--seconds", "-1"], "argument --seconds: must be a positive, finite time in s, not -1"),
    (["--seconds", "0"], "argument --seconds: must be a positive, finite time in s, not 0"),
    (["--seconds", "nan"], "argument --seconds: must be a positive, finite time in s, not nan"),
    (["--seconds", "1", "--count", "3"], "argument --count: not allowed with argument --seconds"),
])
def test_fuzz_proto_refuses_bad_run_lengths(args, message):
    r = subprocess.run(NAVKIT + ["fuzz-proto", *args], capture_output=True, text=True)
    assert r.returncode == 2 and message in r.stderr, r.stderr
    assert "agree" not in r.stdout


def test_fuzz_proto_runs_the_count_given():
    r = subprocess.run(NAVKIT + ["fuzz-proto", "--count", "3", "--seed", "4"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert r.stdout.startswith("fuzz-proto: seed 4: 3 cases, Python and C parsers agree")


@pytest.mark.parametrize("value", ["0", "-5", "abc", "12x", "", "99999999999999999999"])
def test_proto_bench_refuses_bad_frame_counts(value):
    exe = _c_tool("navkit-proto-bench")
    r = subprocess.run([exe, "--frames", value], capture_output=True, text=True)
    assert r.returncode == 2 and r.stdout == ""
    assert r.stderr == f"{exe}: --frames: '{value}' is not an integer in 1..1000000000\n"


def test_proto_bench_runs_the_frames_given():
    r = subprocess.run([_c_tool("navkit-proto-bench"), "--frames", "0x100"], capture_output=True, text=True)
    assert r.returncode == 0 and len(r.stdout.splitlines()) == 3, r.stderr


@pytest.mark.parametrize("args,message", [
    (["--seed", "x"], "--seed: 'x' is not an integer in 0..18446744073709551615"),
    (["--seed", "-1"], "--seed: '-1' is not an integer in 0..18446744073709551615"),
    (["--seed", "18446744073709551616"], "--seed: '18446744073709551616' is not an integer in 0..18446744073709551615"),
    (["--count", "-1"], "--count: '-1' is not an integer in 1..1000000000"),
    (["--count", "0"], "--count: '0' is not an integer in 1..1000000000"),
    (["--count", "7 "], "--count: '7 ' is not an integer in 1..1000000000"),
])
def test_proto_props_refuses_bad_seed_and_count(args, message):
    exe = _c_tool("test_proto_props")
    r = subprocess.run([exe, *args], capture_output=True, text=True)
    assert r.returncode == 2 and r.stdout == ""
    assert r.stderr == f"{exe}: {message}\n"


def test_proto_props_runs_the_count_given():
    r = subprocess.run([_c_tool("test_proto_props"), "--seed", "0x10", "--count", "3"], capture_output=True, text=True)
    assert r.returncode == 0 and r.stdout == "proto props: seed 16, count 3: 0 failure(s)\n"
