"""navkit-host's command line, config errors, console keys, datalog and real-time mode
(the real binary; no timing assertions: speed belongs to `navkit bench-host`)."""

import os
import select
import signal
import socket
import struct
import subprocess
import time
import tty

import pytest

from navkit import plot
from host_helpers import Micro, require_host, run_host
from spec_helpers import FWD_CMD, TURN_CMD

pytestmark = pytest.mark.timeout(60)


def test_help_and_unknown_options():
    r = run_host(["--help"])
    assert r.returncode == 0 and "--clock real|lockstep" in r.stdout
    r = run_host(["--frobnicate"])
    assert r.returncode == 2 and "--frobnicate: unknown option" in r.stderr
    r = run_host(["--clock", "sometimes"])
    assert r.returncode == 2 and "real or lockstep" in r.stderr


@pytest.mark.parametrize("text, where", [
    ("[executive]\nframe_rate_hz = fast\n", "frame_rate_hz: 'fast' is not a decimal number"),
    ("[executive]\nwarp = 9\n", "warp: unknown key"),
    ("[teleport]\n", "[teleport]: unknown section"),
    ("[micro_cfg_geometry]\ncounts_per_rev = 3\n", "counts_per_rev: outside the spec's range"),
    ("[executive]\nshm_name = /a/b\n", "shm_name: '/a/b' is not a POSIX shared-memory name"),
    ("[executive]\nshm_group = nosuchgroup-nk\n", "shm_group: 'nosuchgroup-nk' is not a group of this system"),
    ("[executive]\nlog_dir = /nonexistent/dir\n", "log_dir: /nonexistent/dir: No such file or directory"),
])
def test_config_errors_name_file_line_and_key(tmp_path, text, where):
    from navkit.paths import repo_root

    (tmp_path / "sensors.ini").write_text((repo_root() / "config/sensors.ini").read_text())
    (tmp_path / "NavAndControl.ini").write_text("; comment\n" + text)
    r = run_host(["--config", str(tmp_path), "--port", "/nonexistent", "--shm", f"/nk-cfg-{os.getpid()}"])
    assert r.returncode == 1
    assert f"{tmp_path}/NavAndControl.ini:" in r.stderr and where in r.stderr, r.stderr
    line = r.stderr.split("NavAndControl.ini:")[1].split(":")[0]
    assert int(line) >= 2, r.stderr


def test_missing_config_file(tmp_path):
    r = run_host(["--config", str(tmp_path), "--shm", f"/nk-cfg-{os.getpid()}"])
    assert r.returncode == 1 and "NavAndControl.ini:0: file:" in r.stderr


def test_keys_record_a_datalog_and_quit(host_factory):
    h, m = host_factory(), Micro()
    h.configure(m)
    h.proc.stdin.write(b"R")
    h.proc.stdin.flush()
    m.fields["servo_pos"] = [0, 0, 0, -455, 0, 0, 0, 0]
    for k in range(6):
        m.fields["distance"] = 10 * k
        h.step(m)
    h.proc.stdin.write(b"S")
    h.proc.stdin.flush()
    h.step(m)
    h.proc.stdin.write(b"Q")
    h.proc.stdin.flush()
    msgs, flags = h.tick()
    assert flags & 1, "quitting"
    assert msgs[-1][1]["fwd_cmd"] == FWD_CMD["stop"], "the last frame's message is the stop"
    assert h.proc.wait(timeout=10) == 0
    logs = sorted(h.tmp.glob("Data *.txt"))
    assert len(logs) == 1
    assert logs[0].name[5:7].isdigit() and ";" in logs[0].name
    params, rows = plot.read_datalog(logs[0])
    assert params[0][0] == "time_s" and len(rows) == 6, "one row per frame while recording"
    assert [r[2] for r in rows][-1] == 40
    names = [p[0] for p in params]
    assert names[names.index("battery_v") + 1:][:8] == [f"servo{i}_deg" for i in range(8)]
    assert rows[-1][names.index("servo3_deg")] == -45.5, "calibrated servo position, deg"
    assert names[-7:] == ["owner", "micro_time_ms", "mc_datalog_sel"] + [f"mc_datalog{i}" for i in range(4)]
    assert all(len(r) == len(names) for r in rows)


def test_record_option_starts_the_datalog(host_factory):
    h, m = host_factory(args=("--record",)), Micro()
    h.step(m)
    h.step(m)
    assert h.stop() == 0
    params, rows = plot.read_datalog(next(h.tmp.glob("Data *.txt")))
    assert len(rows) == 2


def test_record_that_cannot_create_its_log_refuses_to_start(tmp_path):
    """--record asks for a datalog: a log folder where no file can be made (/proc, which
    root may write to but where no file can be created) stops start-up instead of running
    without a log."""
    if os.geteuid() != 0:
        # a folder without write permission is refused earlier, as --log-dir (exit 2)
        pytest.skip("needs root: /proc passes the --log-dir access check but takes no new file")
    log_dir = "/proc"
    shm = f"/nk-rec-{os.getpid()}"
    r = run_host(["--port", "/nonexistent", "--shm", shm, "--log-dir", log_dir, "--record"], stdin=subprocess.DEVNULL)
    assert r.returncode == 1, r.stdout + r.stderr
    assert "--record / [executive] record = 1: cannot record (" in r.stderr and "not starting" in r.stderr, r.stderr
    assert not os.path.exists("/dev/shm" + shm), "nothing left behind"


def test_real_time_mode_sends_config_and_stops_on_sigint(host_factory):
    h = host_factory(lockstep=False, args=("--rate", "50"))
    assert h.read_available(wait_s=2.0), "the host talks to the port on its own clock"
    h.proc.send_signal(signal.SIGINT)
    assert h.proc.wait(timeout=10) == 0
    assert not os.path.exists("/dev/shm" + h.shm)
    assert "signal 2" in h.output()


def test_a_key_flood_does_not_hold_the_frames(host_factory):
    """stdin is /dev/zero (endless bytes): keys are read at most 64 bytes a frame, so
    the 20 Hz frames go on and SIGINT ends the host cleanly."""
    with open("/dev/zero", "rb") as zero:
        h = host_factory(lockstep=False, args=("--rate", "20"), stdin=zero)
        time.sleep(2.0)
        h.proc.send_signal(signal.SIGINT)
        assert h.proc.wait(timeout=10) == 0, h.output()
    frames = int(h.output().split("shut down after ")[1].split(" frames")[0])
    # about 40 at 20 Hz; an unbounded read never ends frame 0 (a loaded machine may lose some)
    assert frames >= 10, f"{frames} frames in about 2 s at 20 Hz"


def test_closed_stdin_gives_no_keys(host_factory):
    """The host started with fd 0 closed: it must not take a file it opens later (the
    rcomm region, the port) for its keyboard."""
    h, m = host_factory(stdin="closed"), Micro()
    sent = h.configure(m)
    for _ in range(5):
        msgs, flags = h.step(m)
        assert flags == 0 and msgs == sent[-1:], "no key moved, stopped or quit the robot"
    assert h.stop() == 0
    out = h.output()
    assert "recording" not in out and not list(h.tmp.glob("Data *.txt")), out
    assert "key ignored" not in out and "Q: quitting" not in out


@pytest.mark.parametrize("args, said", [
    (["--port", "--record"], "--port: needs a value (got the option --record)"),
    (["--clock", "lockstep"], "--clock lockstep needs --lockstep-fd N"),
    (["--clock", "lockstep", "--lockstep-fd", "0", "--rate", "20"], "--rate has no effect with --clock lockstep"),
    (["--clock", "lockstep", "--lockstep-fd", "0", "--timing-log", "t.txt"],
     "--timing-log has no effect with --clock lockstep"),
    (["--rate", "0.05"], "not a rate in 0.1..1000 Hz"),
    (["--rate", "0x10"], "--rate: 0x10: not a rate in 0.1..1000 Hz"),
    (["--lockstep-fd", "3"], "--lockstep-fd needs --clock lockstep"),
    (["--rate", "4"], "--rate 4: a frame of 250 ms at 4 Hz needs [micro_cfg_motion] watchdog_timeout above two frames"),
    (["--port", "a", "--port", "/nonexistent"], "--port: given twice"),
    (["--record", "--record"], "--record: given twice"),
    (["-h", "--help"], "--help: given twice"),
    (["--shm", "a/b"], "--shm: 'a/b' is not a POSIX shared-memory name"),
    (["--log-dir", "/nonexistent/dir"], "--log-dir: /nonexistent/dir: No such file or directory"),
])
def test_options_without_effect_or_value_are_refused(args, said):
    r = run_host(args)
    assert r.returncode == 2 and said in r.stderr, r.stderr


def test_unsupported_baud_is_a_config_error(tmp_path):
    from navkit.paths import repo_root

    for name in ("sensors.ini", "NavAndControl.ini"):
        (tmp_path / name).write_text((repo_root() / "config" / name).read_text())
    p = tmp_path / "NavAndControl.ini"
    p.write_text(p.read_text().replace("baud = 115200", "baud = 250000"))
    r = run_host(["--config", str(tmp_path), "--port", "/nonexistent", "--shm", f"/nk-cfg-{os.getpid()}"])
    assert r.returncode == 1 and "NavAndControl.ini:" in r.stderr
    assert "baud: 250000 is not a supported rate (9600, " in r.stderr, r.stderr


def test_the_rate_in_use_must_leave_the_watchdog_two_frames(tmp_path):
    """frame_rate_hz = 4 (250 ms frames) with the 300 ms watchdog: refused at the INI's
    line; --rate 10 overrides it and the host runs (the command line wins)."""
    import signal
    import time

    from navkit.paths import repo_root

    for name in ("sensors.ini", "NavAndControl.ini"):
        (tmp_path / name).write_text((repo_root() / "config" / name).read_text())
    p = tmp_path / "NavAndControl.ini"
    p.write_text(p.read_text().replace("frame_rate_hz = 10\n", "frame_rate_hz = 4\n"))
    line = 1 + p.read_text().splitlines().index("watchdog_timeout = 300")
    shm = f"/nk-rate-{os.getpid()}"
    r = run_host(["--config", str(tmp_path), "--port", "/nonexistent", "--shm", shm])
    assert r.returncode == 1, r.stderr
    assert r.stderr.startswith(f"navkit-host: {p}:{line}: watchdog_timeout: a frame of 250 ms at 4 Hz needs "), r.stderr
    host = subprocess.Popen([str(require_host()), "--config", str(tmp_path), "--port", "/nonexistent",
                             "--shm", shm, "--rate", "10"], stdin=subprocess.DEVNULL,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    time.sleep(0.5)
    assert host.poll() is None, host.communicate()[0]
    host.send_signal(signal.SIGTERM)
    assert host.wait(timeout=10) == 0


def test_a_second_host_on_the_same_region_is_refused(host_factory):
    h, m = host_factory(), Micro()
    h.configure(m)
    r = run_host(["--config", str(h.cfg), "--port", "/nonexistent", "--shm", h.shm])
    assert r.returncode == 1
    assert f"rcomm {h.shm}: in use by a running navkit-host" in r.stderr and "--shm NAME" in r.stderr
    assert len(h.step(m)[0]) == 1, "the first host runs on"
    assert h.client.read_data()["frame"] == h.frame - 1, "its region untouched"
    h.proc.kill()                                   # dies without removing the region
    h.proc.wait()
    stale = os.stat("/dev/shm" + h.shm).st_ino
    second = subprocess.Popen([str(require_host()), "--config", str(h.cfg), "--port", "/nonexistent",
                               "--shm", h.shm], stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                              stderr=subprocess.STDOUT)
    try:
        from navkit import rcomm
        for _ in range(200):                         # the stale region is replaced
            try:
                if os.stat("/dev/shm" + h.shm).st_ino != stale:
                    with rcomm.Client(h.shm):
                        break
            except (OSError, rcomm.RcommError):
                pass
            time.sleep(0.02)
        else:
            second.kill()
            raise AssertionError(f"the second host did not take over the stale region: "
                                 f"{second.communicate()[0].decode(errors='replace')}")
    finally:
        second.send_signal(signal.SIGTERM)
    assert second.wait(timeout=10) == 0, second.communicate()[0].decode(errors="replace")


def test_quit_while_the_micro_is_unconfigured_sends_no_command(host_factory):
    h, m = host_factory(), Micro()
    h.step(m)
    h.proc.stdin.write(b"Q")
    h.proc.stdin.flush()
    msgs, flags = h.tick()
    assert flags & 1
    assert h.proc.wait(timeout=10) == 0
    tail = msgs + h.decode(h.read_available(wait_s=0.5))
    assert tail and all(n != "micro_cmd" for n, _ in tail), "an unconfigured micro is not moving"
    assert "micro not configured by us: not moving, no stop sent" in h.output()


def test_quit_ends_with_one_stop_going_out(host_factory):
    h, m = host_factory(), Micro()
    h.configure(m)
    h.client.write_cmd({"time_tag": 1, "fwd_cmd": 1, "speed": 200, "distance": 5000})
    assert h.step(m)[0][0][1]["fwd_cmd"] == FWD_CMD["start"]
    h.proc.stdin.write(b"Q")
    h.proc.stdin.flush()
    msgs, flags = h.tick()
    assert flags & 1 and len(msgs) == 1
    assert (msgs[0][1]["fwd_cmd"], msgs[0][1]["turn_cmd"]) == (FWD_CMD["stop"], TURN_CMD["stop"])
    assert h.proc.wait(timeout=10) == 0
    assert h.decode(h.read_available(wait_s=0.3)) == [], "the frame's stop was the last message"
    assert "stop sent" in h.output()


def test_status_line_is_drawn_in_place_on_a_terminal(host_factory):
    """The host on a pty as its stdin and stdout: the status line is redrawn in place
    (carriage return, erase line), keys work without Enter (raw mode), and the terminal
    is given back as it was."""
    import pty
    import termios

    h, m = host_factory(), Micro()
    h.close()                                       # this test starts its own host on a pty
    master, slave = pty.openpty()
    before = termios.tcgetattr(slave)
    sock, theirs = socket.socketpair(socket.AF_UNIX, socket.SOCK_STREAM)
    link = h.tmp / "ttyNK2"
    pm, ps = os.openpty()
    tty.setraw(pm)
    os.symlink(os.ttyname(ps), link)
    shm = h.shm + "-tty"
    proc = subprocess.Popen([str(require_host()), "--clock", "lockstep", "--lockstep-fd", str(theirs.fileno()),
                             "--port", str(link), "--shm", shm, "--config", str(h.cfg), "--log-dir", str(h.tmp)],
                            stdin=slave, stdout=slave, stderr=slave, pass_fds=(theirs.fileno(),))
    theirs.close()
    screen = b""
    try:
        def tick(k):
            nonlocal screen
            sock.sendall(struct.pack("<IIQII", 0x4B544B4E, k, k * 100_000, 0, 0))
            assert len(sock.recv(16)) == 16
            while select.select([master], [], [], 0.2)[0]:
                screen += os.read(master, 65536)
        for k in range(3):
            tick(k)
        assert b"\r\x1b[Kframe 2  micro offline unconfigured  owner none" in screen, screen
        assert b"status:" not in screen, "not the pipe form"
        os.write(master, b"Q")                        # no Enter: raw mode
        tick(3)
        assert proc.wait(timeout=10) == 0
        assert termios.tcgetattr(slave)[3] == before[3], "local modes (ICANON, ECHO) restored"
    finally:
        if proc.poll() is None:
            proc.kill()
        sock.close()
        for fd in (master, slave, pm, ps):
            os.close(fd)
        try:
            os.unlink("/dev/shm" + shm)
        except OSError:
            pass


def _responder(master, stop, micro_state):
    """A real-time micro on the pty: answers every host frame with one micro_data,
    accepts configs, and records every frame the host sent."""
    from navkit import protocol

    parser = protocol.Parser(protocol.DIR_TO_MICRO)
    tag = 0
    while not stop.is_set():
        if not select.select([master], [], [], 0.02)[0]:
            continue
        try:
            data = os.read(master, 4096)
        except (BlockingIOError, OSError):
            continue
        for ev in parser.feed(data):
            if not isinstance(ev, protocol.Frame):
                continue
            micro_state["sent"].append((ev.name, ev.fields))
            if ev.name.startswith("micro_cfg"):
                micro_state["cfg"].add(ev.name)
            tag = (tag + 1) & 0xFFFF
            status = 1 | (7 << 9) if len(micro_state["cfg"]) == 3 else 0
            try:
                os.write(master, protocol.encode_frame("micro_data", {
                    "status": status, "spec_hash": protocol.SPEC_HASH}, time_tag=tag))
            except OSError:
                return


def test_real_time_sigint_sends_a_stop_last(host_factory):
    import threading

    h = host_factory(lockstep=False, args=("--rate", "50"))
    state = {"sent": [], "cfg": set()}
    stop = threading.Event()
    t = threading.Thread(target=_responder, args=(h.master, stop, state), daemon=True)
    t.start()
    try:
        deadline = time.monotonic() + 5
        while not any(n == "micro_cmd" for n, _ in state["sent"]):
            assert time.monotonic() < deadline, "never configured"
            time.sleep(0.02)
        h.client.write_cmd({"time_tag": 1, "fwd_cmd": 1, "speed": 200, "distance": 5000})
        while not any(n == "micro_cmd" and f["fwd_cmd"] == FWD_CMD["start"] for n, f in state["sent"]):
            assert time.monotonic() < deadline, "the command never went out"
            time.sleep(0.02)
        h.client.heartbeat()
        h.proc.send_signal(signal.SIGINT)
        assert h.proc.wait(timeout=10) == 0
        time.sleep(0.2)
    finally:
        stop.set()
        t.join(timeout=2)
    last = state["sent"][-1]
    assert last[0] == "micro_cmd", last
    assert (last[1]["fwd_cmd"], last[1]["turn_cmd"]) == (FWD_CMD["stop"], TURN_CMD["stop"]), last
    assert "signal 2" in h.output() and "stop sent" in h.output()


def test_real_time_stall_skips_frames_instead_of_bunching_them(host_factory, tmp_path):
    """The real binary at 100 Hz is stopped (SIGSTOP) for 0.3 s: the frames whose start
    passed meanwhile are skipped, counted, and the schedule goes on from the latest one."""
    timing = tmp_path / "timing.txt"
    h = host_factory(lockstep=False, args=("--rate", "100", "--timing-log", str(timing)))
    time.sleep(0.3)
    h.proc.send_signal(signal.SIGSTOP)
    time.sleep(0.3)
    h.proc.send_signal(signal.SIGCONT)
    time.sleep(0.2)
    h.proc.send_signal(signal.SIGINT)
    assert h.proc.wait(timeout=10) == 0
    from navkit import host_bench

    rows = [tuple(int(x) for x in line.split()) for line in timing.read_text().splitlines()
            if not line.startswith("#")]
    gaps = [b[0] - a[0] for a, b in zip(rows, rows[1:])]
    assert max(gaps) >= 20, f"about 30 frames passed while stopped: {max(gaps)}"
    s = host_bench.summarize(timing)
    said = h.output().split("clock: ")[1].split("\n")[0]
    overruns, skipped = int(said.split(" overruns")[0]), int(said.split(", ")[1].split(" frames")[0])
    assert skipped == s["skipped"] >= 20, (said, s)
    assert overruns >= 1
    late = [(start - sched) for _, sched, start, _ in rows]
    i = gaps.index(max(gaps)) + 1
    # the latest frame whose start has passed: at most one period (10 ms) old, plus wake-up
    # latency; running the first missed frame instead would be ~300 ms late
    assert late[i] < 20_000_000, "the frame run after the stall is the latest one due, not an old one"
