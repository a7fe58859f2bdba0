"""navkit-host pushed to break (issue 13, host items): every signal that would end it
takes the SIGTERM path, a second host on the same serial port is refused naming the
holder, a region cut short under it stops the robot instead of a SIGBUS, nothing of a
micro_data of another spec is used, the command line's --log-dir wins over the INI's,
INI files that never end a line or hold a NUL are refused, and the smaller refusals.
The real binary throughout (lockstep against a pty, see host_helpers)."""

import os
import signal
import subprocess

import pytest

from navkit import protocol, rcomm
from host_helpers import Micro, require_host, run_host
from spec_helpers import FWD_CMD, TURN_CMD

pytestmark = pytest.mark.timeout(60)

_ONLINE = 1 << protocol.SPEC.enums["host_status"].values["micro_online"]


def _drive(h, m):
    """Configure the micro, then the planner starts a long drive (on the wire)."""
    h.configure(m)
    h.client.write_cmd({"time_tag": 1, "fwd_cmd": 1, "speed": 200, "distance": 5000})
    assert h.step(m)[0][0][1]["fwd_cmd"] == FWD_CMD["start"]


@pytest.mark.parametrize("sig", [signal.SIGHUP, signal.SIGQUIT, signal.SIGUSR1, signal.SIGUSR2,
                                 signal.SIGALRM, signal.SIGRTMIN + 2])
def test_every_ending_signal_stops_the_robot_closes_the_log_and_removes_the_region(host_factory, sig):
    h, m = host_factory(args=("--record",)), Micro()
    _drive(h, m)
    assert h.stop(sig) == 0, h.output()
    tail = h.decode(h.read_available(wait_s=1.0))
    assert tail and tail[-1][0] == "micro_cmd" and tail[-1][1]["fwd_cmd"] == FWD_CMD["stop"], \
        "the stop went out last"
    assert not os.path.exists("/dev/shm" + h.shm), "rcomm region removed"
    out = h.output()
    assert f"signal {int(sig)}: shutting down" in out and "recording stopped:" in out, out
    logs = list(h.tmp.glob("Data *.txt"))
    assert len(logs) == 1 and logs[0].read_text().endswith("\n"), "the datalog closed on a whole row"


def test_a_second_host_on_the_same_port_is_refused_naming_the_holder(host_factory, tmp_path):
    h, m = host_factory(), Micro()
    h.configure(m)
    shm = h.shm + "-2"
    r = subprocess.run([str(require_host()), "--port", str(h.link), "--shm", shm, "--config", str(h.cfg),
                        "--log-dir", str(tmp_path)], capture_output=True, text=True, timeout=20)
    assert r.returncode == 1, r.stdout + r.stderr
    assert f"micro port {h.link}: in use by process {h.proc.pid} (it holds the port's lock)" in r.stderr, r.stderr
    assert "not starting" in r.stderr and not os.path.exists("/dev/shm" + shm)
    assert h.read_available() == b"", "the second host wrote nothing to the micro"
    msgs, _ = h.step(m)
    assert msgs and msgs[0][0] == "micro_cmd", "the first host drives on"


def test_a_region_cut_short_stops_the_robot_and_the_client_says_so(host_factory):
    h, m = host_factory(), Micro()
    _drive(h, m)
    os.truncate("/dev/shm" + h.shm, 0)              # a planner process cuts the region
    with pytest.raises(rcomm.RcommError, match=r"cut to 0 bytes by another process"):
        h.client.read_data()
    h.client = None
    msgs, flags = h.tick()                         # the host's next frame finds it cut
    assert flags & 1, "the frame ends with the host quitting"
    assert h.proc.wait(timeout=10) == 1, h.output()
    tail = h.decode(h.read_available(wait_s=1.0))
    assert tail and (tail[-1][1]["fwd_cmd"], tail[-1][1]["turn_cmd"]) == (FWD_CMD["stop"], TURN_CMD["stop"]), \
        "stop sent last"
    assert f"rcomm {h.shm}: the region was cut to 0 bytes by another process" in h.output()
    assert not os.path.exists("/dev/shm" + h.shm)


def test_nothing_of_a_micro_data_of_another_spec_is_used(host_factory):
    h = host_factory()
    m = Micro(spec_hash=0xDEADBEEF)
    m.cfg.update(["micro_cfg_geometry", "micro_cfg_motion", "micro_cfg_io"])
    for _ in range(4):
        h.step(m, distance=888888, heading=1234, status=m.status)
    d = h.client.read_data()
    assert d["distance"] != 888888 and d["heading"] != 1234, "its values never reach the planner"
    assert not d["host_status"] & _ONLINE, "a micro of another spec is not online"
    assert d["host_status"] & (1 << protocol.SPEC.enums["host_status"].values["spec_mismatch"])
    assert "0xDEADBEEF differs" in h.output()


def _config(tmp_path, nav_text=None):
    """A config folder: the shipped sensors.ini and NavAndControl.ini (or nav_text)."""
    from navkit.paths import repo_root

    for name in ("NavAndControl.ini", "sensors.ini"):
        (tmp_path / name).write_text((repo_root() / "config" / name).read_text())
    if nav_text is not None:
        (tmp_path / "NavAndControl.ini").write_bytes(nav_text)
    return tmp_path


def test_log_dir_on_the_command_line_wins_over_the_ini(host_factory, tmp_path):
    h, m = host_factory(ini={"NavAndControl.ini": {"log_dir": "/nonexistent/dir"}}), Micro()
    h.configure(m)                                  # started: --log-dir replaced the INI's folder
    assert h.stop() == 0
    r = run_host(["--config", str(h.cfg), "--port", "/nonexistent", "--shm", h.shm + "-2"])
    assert r.returncode == 1
    assert f"{h.cfg}/NavAndControl.ini:25: log_dir: /nonexistent/dir: No such file or directory" in r.stderr


@pytest.mark.parametrize("text, said", [
    (b"[executive]\nframe_rate_hz = 2\0 0\n", "NavAndControl.ini:2: line: a NUL byte at column 18 (not a text file)"),
    (b"[executive]\rframe_rate_hz = 2\r", "NavAndControl.ini:1: line: a carriage return not followed by a line "
                                          "feed at column 12 (CR-only line ends: save the file with LF or CR LF)"),
])
def test_ini_nul_bytes_and_cr_only_line_ends_are_refused_at_their_line(tmp_path, text, said):
    cfg = _config(tmp_path, text)
    r = run_host(["--config", str(cfg), "--port", "/nonexistent", "--shm", f"/nk-nul-{os.getpid()}"])
    assert r.returncode == 1 and said in r.stderr, r.stderr


def test_ini_linked_to_an_endless_file_is_refused_at_once(tmp_path):
    cfg = _config(tmp_path)
    (cfg / "NavAndControl.ini").unlink()
    (cfg / "NavAndControl.ini").symlink_to("/dev/zero")
    r = run_host(["--config", str(cfg), "--port", "/nonexistent", "--shm", f"/nk-zero-{os.getpid()}"])
    assert r.returncode == 1
    assert f"{cfg}/NavAndControl.ini:1: line: a NUL byte at column 1 (not a text file)" in r.stderr, r.stderr


@pytest.mark.parametrize("text", [b"", b"; nothing set here\n\n# nor here\n[executive]\n"])
def test_an_ini_without_keys_runs_on_defaults_and_says_so_once(tmp_path, text):
    cfg = _config(tmp_path, text)
    p = subprocess.Popen([str(require_host()), "--config", str(cfg), "--port", "/nonexistent",
                          "--shm", f"/nk-empty-{os.getpid()}", "--log-dir", str(tmp_path)],
                         stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    first = [p.stdout.readline() for _ in range(3)]  # the banner, the note, the port's line
    p.send_signal(signal.SIGTERM)
    out = "".join(first) + p.stdout.read()
    assert p.wait(timeout=10) == 0, out
    assert out.count("NavAndControl.ini: no keys (empty, or only comments and sections): every value is "
                     "its default") == 1, out


@pytest.mark.parametrize("args, said", [
    (["--shm", "relfoo"], "--shm: 'relfoo' is not a POSIX shared-memory name"),
    (["--config", "", "--shm", "/x"], "--config: needs a value (got an empty one)"),
    (["--config", "--shm", "/x"], "--config: needs a value (got the option --shm)"),
    (["--clock", "lockstep", "--lockstep-fd", "99"], "--lockstep-fd 99: not an open file descriptor"),
])
def test_usage_errors_are_said_before_anything_starts(args, said):
    r = run_host(args)
    assert r.returncode == 2 and said in r.stderr and r.stdout == "", r.stdout + r.stderr


def test_a_garbage_only_link_does_not_say_last_reject_ok(host_factory):
    h, m = host_factory(), Micro()
    h.configure(m)
    h.write(bytes(range(1, 200)) * 3)
    h.step(m, reply=False)
    out = h.output()
    assert "dropped bytes" in out and "last reject: ok" not in out, out
    assert "no frame rejected: the dropped bytes held no frame start" in out, out


def test_a_planner_writing_bad_commands_every_frame_gets_a_line_a_second(host_factory):
    h, m = host_factory(), Micro()
    h.configure(m)
    for k in range(25):                              # 2.5 s of a new bad command every frame
        h.client.write_cmd({"time_tag": 100 + k, "fwd_cmd": 99})
        h.step(m)
    assert h.stop() == 0
    lines = [ln for ln in h.output().splitlines() if "planner command" in ln and "rejected" in ln]
    assert 3 <= len(lines) <= 4, lines              # at 0, 1 and 2 s, and the last held back at shutdown
    assert "(9 more like it in the last 1.0 s held back)" in lines[1], lines
    assert "planner command 124 rejected: fwd_cmd out of the spec's range" in lines[-1], lines


def test_the_rcomm_client_checks_the_name_and_never_follows_a_link(host_factory, tmp_path):
    h = host_factory()
    with pytest.raises(rcomm.RcommError, match="is not a POSIX shared-memory name"):
        rcomm.Client(h.shm.lstrip("/"))
    with pytest.raises(rcomm.RcommError, match="is not a POSIX shared-memory name"):
        rcomm.Client("/../" + h.shm.lstrip("/"))
    link = h.shm + "-link"
    os.symlink("/dev/shm" + h.shm, "/dev/shm" + link)
    try:
        with pytest.raises(rcomm.RcommError, match=f"/dev/shm{link} is a symbolic link: refused"):
            rcomm.Client(link)
    finally:
        os.unlink("/dev/shm" + link)
