"""The lockstep loop's native frames (navkit.sim.coupler.NativeFrames, fmu/cosim/lockstep.h):
a run whose frames go native gives the run log of the Python path, message for message,
through faults that hand frames back to Python; and each way a host breaks the lockstep
contract raises what the Python path raises, against a scripted host end (the real
socket, pty and FMUs)."""

import os
import struct

import pytest

from sim_helpers import require_build

pytestmark = pytest.mark.timeout(120)

# commands, then each fault that sends frames the Python way for a while
MISSION = """
duration_s = 9.0
[[command]]
t = 0.5
fwd_cmd = 1
speed = 400
distance = 3000
rc_servo_num = 1
rc_param0 = 900
[[fault]]
t = 2.0
kind = "line_noise"
ber = 0.001
duration_s = 0.5
[[fault]]
t = 3.0
kind = "unplug"
duration_s = 0.5
[[fault]]
t = 4.5
kind = "planner_silent"
duration_s = 0.3
[[command]]
t = 5.5
turn_mode = 10
turn_rate = 900
turn_distance = 900
[[fault]]
t = 6.5
kind = "micro_reset"
"""


def _run(tmp_path, name, monkeypatch, native: bool):
    from navkit.sim import lockstep
    from navkit.sim.harness import SimOptions, run
    from navkit.sim.mission import loads
    from navkit.sim.results import read_mcap

    calls = {"host": 0}
    real = lockstep.NativeFrames

    class Counted(real):
        def host(self, frame, rx_bytes):
            calls["host"] += 1
            return super().host(frame, rx_bytes)

    with monkeypatch.context() as m:
        m.setattr(lockstep, "NativeFrames", Counted if native else (lambda *a, **k: None))
        out = tmp_path / name
        run(SimOptions(mission=loads(MISSION, tmp_path / f"{name}.toml"), out=out, seed=4,
                       plot=False, progress=False))
    return read_mcap(out / "run.mcap").messages, calls["host"]


def test_native_frames_log_what_the_python_path_logs(tmp_path, monkeypatch):
    require_build()
    fast, n_native = _run(tmp_path, "native", monkeypatch, True)
    slow, n_none = _run(tmp_path, "python", monkeypatch, False)
    assert n_none == 0
    # 90 frames, of which the faults' go the Python way: line noise 5, unplugged 5,
    # silent 3
    assert n_native == 90 - 5 - 5 - 3
    assert len(fast) == len(slow) > 1000
    for i, (a, b) in enumerate(zip(fast, slow)):
        assert a == b, f"message {i} differs: {a[:2]} vs {b[:2]}"


@pytest.fixture
def frames(tmp_path):
    """A NativeFrames of a real coupler on a real Lockstep and Port, and the host's ends."""
    from navkit.sim.coupler import Coupler, NativeFrames, library_path
    from navkit.sim.fmus import FmuPair
    from navkit.sim.harness import fmu_paths
    from navkit.sim.links import Lockstep, Port
    from navkit.sim.mission import loads
    from navkit.paths import build_dir

    require_build()
    b = build_dir()
    fw, plant = fmu_paths(b)
    fmus = FmuPair(fw, plant, tmp_path, {"seed": 3}, loads("duration_s = 1.0", tmp_path / "m.toml"))
    c = Coupler(fmus.fw, fmus.fw_md, fmus.plant, fmus.plant_md, build=b)
    lock, port = Lockstep(), Port(tmp_path / "tty")
    nf = NativeFrames(c, lock, port.master, 100, 40, timeout_s=0.3)
    assert library_path(b).exists()
    yield nf, lock, port, c
    nf.close()
    lock.close()
    port.close()
    c.close()
    fmus.close()


def _done(lock, frame, tx_bytes=0, flags=0, magic=None):
    from navkit.sim.links import DONE_MAGIC

    lock.host_end.send(struct.pack("<IIII", DONE_MAGIC if magic is None else magic, frame,
                                   tx_bytes, flags))


def test_a_frame_ticks_reads_and_steps(frames):
    from navkit.sim.links import TICK_MAGIC

    nf, lock, port, c = frames
    os.write(port.slave, b"hello")         # the host's bytes, then its done
    _done(lock, 7, tx_bytes=5, flags=0)
    assert nf.host(7, 12) == (5, 0, b"hello", None)
    # the tick the Python path packs: magic, frame, simulated time in us, rx_bytes, 0
    assert lock.host_end.recv(24) == struct.pack("<IIQII", TICK_MAGIC, 7, 700_000, 12, 0)
    rows, tx, wrote, rows2, tx2, wrote2 = nf.micro()
    assert c.steps == 100
    assert (len(rows), len(rows2)) == (2 * c.width * 8, 3 * c.width * 8), "a row every 20 steps"
    assert wrote == len(tx) and wrote2 == len(tx2)
    host_s, _pty_s, fmus_s = nf.times_s()
    assert host_s > 0 and fmus_s > 0


@pytest.mark.parametrize("magic, frame, text", [
    (0x12345678, 3, "bad done magic 0x12345678 for frame 3"),
    (None, 4, "done for frame 4, expected 3"),
])
def test_a_bad_done_raises_as_the_python_path(frames, magic, frame, text):
    from navkit.sim.links import LinkError

    nf, lock, _, _ = frames
    _done(lock, frame, magic=magic)
    with pytest.raises(LinkError, match=text):
        nf.host(3, 0)


def test_no_done_within_the_timeout_eof_and_a_closed_socket(frames):
    import socket

    from navkit.sim.links import LinkError

    nf, lock, _, _ = frames
    with pytest.raises(LinkError, match=r"no done from the host for frame 2 within 0\.3 s"):
        nf.host(2, 0)
    lock.host_end.shutdown(socket.SHUT_WR)  # the host went away after the tick: no done
    assert nf.host(3, 0) is None
    assert lock.frame(4, 0, 0) is None
    lock.host_end.close()                   # gone before the tick: the send fails
    for tick in (lambda: nf.host(5, 0), lambda: lock.frame(5, 0, 0)):
        with pytest.raises(BrokenPipeError):
            tick()


def test_the_host_bytes_late_are_waited_for(frames):
    import threading

    nf, lock, port, _ = frames
    os.write(port.slave, b"abc")            # 3 of the 5 bytes the done reports, the rest later
    late = threading.Timer(0.3, os.write, (port.slave, b"de"))
    late.start()
    _done(lock, 1, tx_bytes=5)
    try:
        assert nf.host(1, 0)[2] == b"abcde"
    finally:
        late.join()
    assert nf.waits() == (1, 1), "one read found them missing and slept past the spin"


def test_a_signal_while_the_pty_is_full_drops_no_bytes(frames):
    """A signal (a deferred stop) that interrupts the wait for room in a full pty resumes
    the wait, as Port.write's select does; the host drains the port within it."""
    import signal
    import threading

    from navkit import protocol

    nf, lock, port, _ = frames
    import select

    filled = 0
    while select.select([], [port.master], [], 0.05)[1]:     # full until the host reads
        try:
            while True:
                filled += os.write(port.master, b"\0" * 4096)
        except BlockingIOError:
            pass
    cmd = protocol.encode_frame("micro_cmd", {"fwd_cmd": 1, "speed": 200, "distance": 2000}, time_tag=1)
    os.write(port.slave, cmd)
    _done(lock, 0, tx_bytes=len(cmd))
    assert nf.host(0, 0)[2] == cmd
    main = threading.get_ident()
    old = signal.signal(signal.SIGUSR1, lambda *_: None)
    kick = threading.Timer(0.05, signal.pthread_kill, (main, signal.SIGUSR1))
    drain = threading.Timer(0.1, os.read, (port.slave, filled + 4096))
    kick.start()
    drain.start()
    try:
        _rows, tx, wrote, _rows2, tx2, wrote2 = nf.micro()
    finally:
        kick.join()
        drain.join()
        signal.signal(signal.SIGUSR1, old)
    assert len(tx) + len(tx2) > 0, "the micro answers the command"
    assert (wrote, wrote2) == (len(tx), len(tx2))


def test_host_bytes_that_do_not_come_raise_after_links_read_wait(frames, monkeypatch):
    """The native read waits links.READ_WAIT_S (the Python path's) and says so."""
    from navkit.sim import links
    from navkit.sim.coupler import NativeFrames
    from navkit.sim.links import LinkError

    _, lock, port, c = frames
    monkeypatch.setattr(links, "READ_WAIT_S", 0.2)
    nf = NativeFrames(c, lock, port.master, 100, 40, timeout_s=0.3)
    try:
        os.write(port.slave, b"abc")        # 3 of the 5 bytes the done reports
        _done(lock, 1, tx_bytes=5)
        with pytest.raises(LinkError, match=r"read 3 of the 5 bytes the host reported within 0\.2 s"):
            nf.host(1, 0)
    finally:
        nf.close()
