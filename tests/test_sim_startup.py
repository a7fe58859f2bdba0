"""The start-up and set-up of `navkit sim`: the navkit command holds Python's cyclic
garbage collector off through its imports and the run's set-up (navkit.cli.hold_collector,
released by navkit.sim.rig.SimRig.start), and the loop and the log worker run with it on."""

import gc
import subprocess
import sys
import textwrap

from navkit.cli import hold_collector, release_collector
from sim_helpers import require_build


def test_release_freezes_and_turns_the_collector_back_on():
    assert gc.isenabled()
    frozen = gc.get_freeze_count()
    try:
        hold_collector()
        assert not gc.isenabled()
        kept = [[] for _ in range(1000)]       # objects made while held
        release_collector()
        assert gc.isenabled()
        assert gc.get_freeze_count() >= frozen + len(kept), "what was made is frozen"
        release_collector()                    # a second release does nothing
        assert gc.isenabled()
    finally:
        gc.enable()
        gc.unfreeze()


def test_a_collector_already_off_stays_off():
    gc.disable()
    try:
        hold_collector()
        release_collector()
        assert not gc.isenabled(), "the caller's own choice is kept"
    finally:
        gc.enable()


# navkit sim as its own process (navkit.cli.main without argv), with the collector's state
# written to a file at the set-up's start and end, the loop's start and the log worker's
DRIVER = textwrap.dedent("""
    import gc, os, sys
    import navkit.cli
    from navkit.sim import harness, record, rig

    out = open(sys.argv[1], "a")
    harness_pid = os.getpid()

    def note(what):
        out.write(f"{what} {gc.isenabled()}\\n")
        out.flush()

    start = rig.SimRig.start
    def noted_start(self):
        note("setup_start")
        start(self)
        note("setup_end")
    rig.SimRig.start = noted_start

    loop = harness.run_lockstep
    def noted_loop(*a):
        note("loop")
        return loop(*a)
    harness.run_lockstep = noted_loop

    decoder = record._Decoder.__init__
    def noted_decoder(self, *a, **k):
        note("worker" if os.getpid() != harness_pid else "inline")
        decoder(self, *a, **k)
    record._Decoder.__init__ = noted_decoder

    sys.argv = ["navkit", *sys.argv[2:]]
    raise SystemExit(navkit.cli.main())
""")


def test_sim_holds_the_collector_through_its_set_up_only(tmp_path):
    require_build()
    driver, notes, mission = tmp_path / "driver.py", tmp_path / "notes.txt", tmp_path / "m.toml"
    driver.write_text(DRIVER)
    mission.write_text("duration_s = 1.0\n")
    done = subprocess.run([sys.executable, str(driver), str(notes), "sim", "-m", str(mission),
                           "-o", str(tmp_path / "out"), "--no-plot", "--no-progress"],
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    said = dict(line.split() for line in notes.read_text().splitlines())
    assert said == {"setup_start": "False", "setup_end": "True", "loop": "True",
                    "worker": "True"}, said
