"""navkit-host's face ([animation], config/Animation.ini) through the real binary: in
lockstep with `log = 1` (stdout is a file) the face's versions ramp one per frame toward
the planner's emotion written through navkit.rcomm, the beacon steps only while the
micro is online, talking toggles the mouth; `on = 0` shows nothing and does not read the
file; a bad Animation.ini stops start-up with file:line: key: reason; on a terminal the
face is drawn above the status line."""

import os
import re
import select
import shutil
import signal
import subprocess
import time
import uuid

import pytest

from navkit import rcomm
from navkit.paths import repo_root
from host_helpers import Micro, require_host
from spec_helpers import bit

pytestmark = pytest.mark.timeout(60)

SHIPPED = repo_root() / "config" / "Animation.ini"
FACE_LINE = re.compile(r"^\[\s*([0-9.]+)\] face: (.*)$", re.M)


def faces(out: str) -> list:
    """[(frame, {feature: version})] of every "face:" line; a talking feature's version
    is "N:talk", a gaze-following one's "N@dx,dy"."""
    got = []
    for t, state in FACE_LINE.findall(out):
        got.append((round(float(t) * 10), dict(kv.split("=") for kv in state.split())))
    return got


def version(v: str) -> int:
    return int(re.match(r"\d+", v).group())


def face_host(host_factory, on=1, log=1, file=SHIPPED):
    return host_factory(ini={"NavAndControl.ini": {"on": on, "file": file, "log": log}})


def test_face_ramps_one_version_per_frame_to_the_emotion(host_factory):
    h, m = face_host(host_factory), Micro()
    h.client.write_emotion({"time_tag": 1, "happiness": -100})  # every target is version 0
    h.configure(m)
    assert {version(v) for v in faces(h.output())[-1][1].values()} - {0, 1, 2, 3} == set()
    assert [version(faces(h.output())[-1][1][k]) for k in ("brows", "eyes", "mouth")] == [0, 0, 0]
    start = h.frame
    h.client.write_emotion({"time_tag": 2, "happiness": 100, "arousal": 100, "surprise": 100,
                            "gaze_x": -100})
    for _ in range(6):
        h.step(m)
    got = [f for k, f in faces(h.output()) if k >= start]
    assert [version(f["mouth"]) for f in got[:5]] == [1, 2, 3, 4, 4], "one version per frame, then held"
    assert [version(f["eyes"]) for f in got[:4]] == [1, 2, 3, 3]
    assert [f["eyes"].split("@")[1] for f in got[:3]] == ["-1,+0", "-2,+0", "-2,+0"], "gaze left, one column a frame"
    assert version(got[-1]["brows"]) == 3
    h.client.write_emotion({"time_tag": 3, "happiness": -100, "arousal": 0, "surprise": 0})
    for _ in range(6):
        h.step(m)
    last = faces(h.output())[-1][1]
    assert (version(last["mouth"]), version(last["eyes"]), version(last["brows"])) == (0, 0, 0)


def test_beacon_steps_only_while_the_micro_is_online(host_factory):
    h, m = face_host(host_factory), Micro()
    h.configure(m)
    for _ in range(4):
        h.step(m)
    online = [f for k, f in faces(h.output()) if k >= h.frame - 4]
    beacons = [int(f["beacon"]) for f in online]
    assert len(beacons) == 4 and all((b - a) % 4 == 1 for a, b in zip(beacons, beacons[1:])), beacons
    for _ in range(14):                    # the micro goes silent: offline after 1 s
        h.step(m, reply=False)
    n = len(faces(h.output()))
    for _ in range(5):
        h.step(m, reply=False)
    assert len(faces(h.output())) == n, "offline: the beacon stands still, the face does not change"
    assert not h.client.read_data()["host_status"] & bit("host_status", "micro_online")


def test_talking_toggles_the_mouth_every_frame(host_factory):
    h, m = face_host(host_factory), Micro()
    h.configure(m)
    h.client.write_emotion({"time_tag": 1, "happiness": 0, "talking": 1})
    start = h.frame
    for _ in range(6):
        h.step(m)
    mouths = [f["mouth"] for k, f in faces(h.output()) if k >= start]
    assert [m.endswith(":talk") for m in mouths] == [True, False] * 3, mouths


def test_out_of_range_emotion_is_refused(host_factory):
    h, m = face_host(host_factory), Micro()
    h.configure(m)
    h.client.write_emotion({"time_tag": 9, "happiness": 100})
    h.step(m)
    h.client.write_emotion({"time_tag": 10, "happiness": 500})   # write_emotion does not range-check
    for _ in range(5):
        h.step(m)
    out = h.output()
    assert out.count("planner emotion 10 rejected: happiness out of the spec's range") == 1
    assert version(faces(out)[-1][1]["mouth"]) == 4, "the last valid emotion still drives the face"


def test_animation_off_shows_nothing_and_reads_no_file(host_factory, tmp_path):
    h, m = face_host(host_factory, on=0, log=1, file=tmp_path / "missing.ini"), Micro()
    h.configure(m)
    h.client.write_emotion({"time_tag": 1, "happiness": 100, "talking": 1})
    for _ in range(5):
        h.step(m)
    assert h.stop() == 0
    assert "face" not in h.output()


def test_log_0_keeps_a_non_terminal_quiet(host_factory):
    h, m = face_host(host_factory, on=1, log=0), Micro()
    h.configure(m)
    h.client.write_emotion({"time_tag": 1, "happiness": 100})
    for _ in range(5):
        h.step(m)
    assert h.stop() == 0
    assert "face" not in h.output()


def config_dir(tmp_path, animation: str | None, on: int = 1):
    d = tmp_path / "config"
    d.mkdir()
    for name in ("NavAndControl.ini", "sensors.ini"):
        shutil.copy(repo_root() / "config" / name, d / name)
    text = (d / "NavAndControl.ini").read_text()
    (d / "NavAndControl.ini").write_text(re.sub(r"^on = 0$", f"on = {on}", text, count=1, flags=re.M))
    if animation is not None:
        (d / "Animation.ini").write_text(animation)
    return d


@pytest.mark.parametrize("old, new, bad_line, want", [
    ("version.3 = \"(/)\"", "version.3 = \"(/)\"\nspin = 2", "spin = 2", "spin: unknown key in [beacon]"),
    ("row = 7", "row = 10", "row = 10", "row: 10 is outside 0..9"),
    ("features = beacon, brows, eyes, mouth", "features = beacon, brows, eyes", "[mouth]",
     "[mouth]: unknown section (not in [face] features)"),
])
def test_bad_animation_ini_stops_start_up(tmp_path, old, new, bad_line, want):
    text = SHIPPED.read_text()
    assert text.count(old) == 1
    text = text.replace(old, new)
    line = text.splitlines().index(bad_line) + 1
    d = config_dir(tmp_path, text)
    r = subprocess.run([str(require_host()), "--config", str(d), "--port", "/dev/null",
                        "--shm", f"/nk-face-{uuid.uuid4().hex[:8]}"],
                       stdin=subprocess.DEVNULL, capture_output=True, text=True, timeout=10)
    assert r.returncode == 1
    assert f"{d}/Animation.ini:{line}: {want}" in r.stderr, r.stderr


def test_missing_animation_ini_stops_start_up(tmp_path):
    d = config_dir(tmp_path, None)
    r = subprocess.run([str(require_host()), "--config", str(d), "--port", "/dev/null"],
                       stdin=subprocess.DEVNULL, capture_output=True, text=True, timeout=10)
    assert r.returncode == 1
    assert f"{d}/Animation.ini:0: file: No such file or directory" in r.stderr


def test_face_is_drawn_above_the_status_line_on_a_terminal(tmp_path):
    """Real time at 20 Hz with stdout on a pty: the head is drawn, the status line under
    it, and the planner's smile reaches the screen."""
    d = config_dir(tmp_path, SHIPPED.read_text())
    master, slave = os.openpty()
    shm = f"/nk-face-{os.getpid()}-{uuid.uuid4().hex[:8]}"
    proc = subprocess.Popen([str(require_host()), "--config", str(d), "--port", str(tmp_path / "no-port"),
                             "--shm", shm, "--rate", "20", "--log-dir", str(tmp_path)],
                            stdin=subprocess.DEVNULL, stdout=slave, stderr=subprocess.STDOUT)
    os.close(slave)
    screen = b""

    def read_for(seconds: float) -> None:
        nonlocal screen
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            if select.select([master], [], [], 0.05)[0]:
                try:
                    screen += os.read(master, 65536)
                except OSError:
                    return

    try:
        client = None
        deadline = time.monotonic() + 10
        while client is None:
            try:
                client = rcomm.Client(shm)
            except rcomm.RcommError:
                assert proc.poll() is None and time.monotonic() < deadline, screen
                read_for(0.02)
        read_for(0.3)
        text = screen.decode(errors="replace")
        assert "     .---------.     \r\n" in text, text
        assert "\r\n   |  (-)   (-)  |   \r\n" in text, "eyes version 0 (closed) at start-up"
        assert re.search(r"'---------'     \r\nframe \d+", text), "the status line right under the face"
        client.write_emotion({"time_tag": 1, "happiness": 100})
        read_for(0.6)
        text = screen.decode(errors="replace")
        assert "\x1b[10A\x1b[J" in text, "the changed face is redrawn in place"
        assert "   |    \\___/    |   \r\n" in text, "the smile (mouth version 4)"
        client.close()
    finally:
        proc.send_signal(signal.SIGTERM)
        rc = proc.wait(timeout=10)
        read_for(0.1)
        os.close(master)
        try:
            os.unlink("/dev/shm" + shm)
        except OSError:
            pass
    assert rc == 0
