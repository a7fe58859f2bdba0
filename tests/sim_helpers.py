"""Helpers of the co-simulation tests (tests/test_sim_*.py and the others that run
missions; no tests here): run a mission text once per session through the real host and
FMUs, read its outputs back (can.log through `navkit can dump`), the time span of run.mcap's
chunks, and a copy of an FMU with its model description edited."""

import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

from navkit.paths import build_dir
from navkit.sim.harness import SimOptions, fmu_paths, host_path, run
from navkit.sim.mission import loads
from navkit.sim.results import load

__all__ = ["STRAIGHT", "run_mission", "build_missing", "require_build", "navkit_sim", "can_dump", "chunk_spans",
           "rewrite_fmu"]

_CACHE = {}

# one straight leg of 700 mm in the demo's room (its walls for the sonars and IR rangers),
# then standing still: the PIL runs' mission, over serial and over CAN
STRAIGHT = """
duration_s = 5.0
world = "room.txt"
[[command]]
t = 1.5
fwd_cmd = "start"
accel = 600
speed = 400
distance = 700
"""


def build_missing() -> list:
    """The build products the co-simulation tests need (host, both FMUs, coupler, the run
    log's row formatter) that the build folder lacks, as Paths."""
    from navkit.sim.coupler import library_path
    from navkit.sim.record import row_library

    b = build_dir()
    return [p for p in (host_path(b), *fmu_paths(b), library_path(b), row_library(b))
            if not p.exists()]


def require_build():
    """Skip unless the host, both FMUs and the coupler are built."""
    missing = build_missing()
    if missing:
        pytest.skip("not built: " + ", ".join(map(str, missing)))


def run_mission(tmp_path_factory, name: str, text: str, seed: int = 1, **opts):
    """Run mission `text` (once per session and name) and return its RunResult."""
    key = (name, seed)
    if key not in _CACHE:
        require_build()
        out = tmp_path_factory.mktemp(f"sim-{name}")
        mission = loads(text, out / f"{name}.toml")
        opts.setdefault("plot", False)
        run(SimOptions(mission=mission, out=out, seed=seed, **opts))
        _CACHE[key] = load(out)
    return _CACHE[key]


def navkit_sim(args, timeout: float = 60, **kw) -> subprocess.CompletedProcess:
    """`navkit sim ARGS` as a user runs it (`args` str or Path each), at most `timeout` s: its
    exit status and its stdout and stderr as text (captured unless `kw` points them
    elsewhere); `kw` go to subprocess.run (env, stdout, ...)."""
    kw.setdefault("stdout", subprocess.PIPE)
    kw.setdefault("stderr", subprocess.PIPE)
    return subprocess.run([sys.executable, "-m", "navkit", "sim", *map(str, args)], text=True, timeout=timeout,
                          **kw)


def can_dump(log: Path) -> subprocess.CompletedProcess:
    """`navkit can dump --file log` as a user runs it: its exit status, its messages as JSON
    lines on stdout and its counts on stderr, as text."""
    return subprocess.run([sys.executable, "-m", "navkit", "can", "dump", "--file", str(log)],
                          capture_output=True, text=True, timeout=120)


def chunk_spans(path):
    """[(message_start_time, message_end_time) ns] of every chunk of MCAP file `path`, in
    file order."""
    from mcap.reader import make_reader

    with open(path, "rb") as f:
        idx = make_reader(f).get_summary().chunk_indexes
    return [(c.message_start_time, c.message_end_time)
            for c in sorted(idx, key=lambda c: c.chunk_start_offset)]


def rewrite_fmu(src: Path, dst: Path, edit=lambda xml: xml, drop: str | None = None) -> Path:
    """Copy FMU `src` to `dst` with modelDescription.xml passed through `edit` and the
    members starting with `drop` left out."""
    with zipfile.ZipFile(src) as zin, zipfile.ZipFile(dst, "w", zipfile.ZIP_DEFLATED) as zout:
        for item in zin.infolist():
            if drop and item.filename.startswith(drop):
                continue
            data = zin.read(item)
            if item.filename == "modelDescription.xml":
                data = edit(data.decode()).encode()
            zout.writestr(item, data)
    return dst
