"""`navkit simboard`: the simulated Mega 2560 (real simavr, the real stk500v2 bootloader of
arduino-core-avr, the real avrdude). Test images are built with avr-gcc (avr_helpers, shared
with tests/test_flash.py)."""

import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from avr_helpers import ECHO_C, TEST_SPEED, avrdude, build_image
from navkit.simboard import SimBoard, SimBoardError, program

NEEDS = [t for t in ("avr-gcc", "avr-objcopy", "avrdude") if shutil.which(t) is None]
pytestmark = [
    pytest.mark.skipif(bool(NEEDS), reason=f"{', '.join(NEEDS)} missing: run make (scripts/setup.sh)"),
    pytest.mark.skipif(not program().exists(), reason=f"{program()} not built: run make"),
]

BOOT_GREETING = b"navkit-test\n"


def read_until(port, marker: bytes, seconds: float) -> bytes:
    """Open `port` (which resets the board) and read until `marker` or `seconds` pass."""
    import serial
    got = b""
    with serial.Serial(str(port), 115200, timeout=0.05) as s:
        t_end = time.monotonic() + seconds
        while marker not in got and time.monotonic() < t_end:
            got += s.read(256)
    return got


@pytest.fixture
def board(tmp_path):
    """A running simboard at tmp_path/mega with its flash in tmp_path/flash.bin."""
    with SimBoard(tmp_path / "mega", tmp_path / "flash.bin", speed=TEST_SPEED) as b:
        yield b


@pytest.fixture(scope="module")
def echo_image(tmp_path_factory) -> Path:
    return build_image(tmp_path_factory.mktemp("echo"), "echo", ECHO_C)


def test_plain_avrdude_flashes_and_the_image_boots(board, echo_image):
    # -D: the Mega's stk500v2 bootloader refuses a chip erase (its issue 543), on the
    # board as here; it erases each page as it writes it
    r = avrdude(board.link, echo_image, "-D")
    assert r.returncode == 0, r.stderr
    assert "bytes of flash verified" in r.stderr
    assert "device signature = 0x1e9801" in r.stderr
    # opening the port resets the board: bootloader (~1 s), then the image greets
    got = read_until(board.link, BOOT_GREETING, 5.0)
    assert got == BOOT_GREETING, got
    import serial
    with serial.Serial(str(board.link), 115200, timeout=0.05) as s:
        got = b""
        t_end = time.monotonic() + 5.0
        while BOOT_GREETING not in got and time.monotonic() < t_end:
            got += s.read(64)
        s.write(b"ABC")
        reply = b""
        while len(reply) < 3 and time.monotonic() < t_end:
            reply += s.read(3)
    assert reply == b"BCD"
    assert board.output().count("port opened: reset into the bootloader") >= 3


def test_a_second_open_does_not_reset(board, echo_image):
    import serial
    assert avrdude(board.link, echo_image, "-D").returncode == 0
    with serial.Serial(str(board.link), 115200, timeout=0.05) as a:
        got, t_end = b"", time.monotonic() + 5.0
        while BOOT_GREETING not in got and time.monotonic() < t_end:
            got += a.read(64)
        assert got == BOOT_GREETING
        with serial.Serial(str(board.link), 115200, timeout=0.05) as b:   # DTR is already low
            time.sleep(0.6)                     # > the bootloader's wait, at TEST_SPEED
            assert a.read(64) + b.read(64) == b""
            b.write(b"x")
            assert (a.read(8) + b.read(8))[:1] == b"y"
    assert board.output().count("port opened: reset into the bootloader") == 2   # avrdude, a


def test_chip_erase_is_refused_as_by_the_real_bootloader(board, echo_image):
    r = avrdude(board.link, echo_image)           # no -D: avrdude asks for a chip erase first
    assert r.returncode != 0
    assert "erasing chip" in r.stderr and "command failed" in r.stderr
    assert "device signature = 0x1e9801" in r.stderr


def test_flash_file_persists_across_a_restart(tmp_path, echo_image):
    link, flash = tmp_path / "mega", tmp_path / "flash.bin"
    with SimBoard(link, flash, speed=TEST_SPEED) as b:
        assert avrdude(link, echo_image, "-D").returncode == 0
        assert read_until(link, BOOT_GREETING, 5.0) == BOOT_GREETING
    assert b.proc.returncode == 0
    assert not link.exists() and not link.is_symlink()          # link removed at exit
    image = flash.read_bytes()
    assert len(image) == 256 * 1024
    assert image[0x3E000:0x3E004] == bytes.fromhex("0d9489f1")  # the bootloader's first jmp
    with SimBoard(link, flash, speed=TEST_SPEED):                # no flashing this time
        assert read_until(link, BOOT_GREETING, 5.0) == BOOT_GREETING


def test_erased_board_stays_in_the_bootloader(board):
    # nothing to run: the bootloader's timeout jumps into erased flash, which runs up
    # into the bootloader again, so the port stays silent and avrdude still finds it
    assert read_until(board.link, b"\n", 2.0) == b""
    r = subprocess.run(["avrdude", "-c", "wiring", "-p", "atmega2560", "-P", str(board.link),
                        "-b", "115200", "-U", "signature:r:-:h"], capture_output=True, text=True,
                       timeout=60)
    assert r.returncode == 0, r.stderr
    assert "0x1e,0x98,0x1" in r.stdout


# Greets, then sleeps with interrupts off: a board that hangs until reset (simavr's core
# stops: "done").
HALT_C = ECHO_C.replace("    for (;;) {",
                        "    SMCR = 1 << SE;\n    __asm__ volatile (\"cli\\n\\tsleep\");\n    for (;;) {")


def test_a_stopped_core_waits_for_the_next_open(board, tmp_path):
    halt = build_image(tmp_path, "halt", HALT_C)
    assert "sleep" in (tmp_path / "halt.c").read_text()
    assert avrdude(board.link, halt, "-D").returncode == 0
    assert read_until(board.link, BOOT_GREETING, 5.0) == BOOT_GREETING
    time.sleep(0.2)
    assert "the AVR stopped (done)" in board.output()
    assert read_until(board.link, BOOT_GREETING, 5.0) == BOOT_GREETING   # this open reset it


def test_sigterm_saves_flash_and_removes_link(tmp_path, echo_image):
    link, flash = tmp_path / "mega", tmp_path / "flash.bin"
    b = SimBoard(link, flash, speed=TEST_SPEED)
    b.start()
    try:
        assert avrdude(link, echo_image, "-D").returncode == 0
    finally:
        b.proc.send_signal(signal.SIGTERM)
        assert b.proc.wait(10) == 0
    assert not link.is_symlink()
    assert flash.read_bytes()[:2] != b"\xff\xff"      # the image's vector table is there


def test_navkit_simboard_replaces_a_stale_link_and_ends_on_ctrl_c(tmp_path):
    link = tmp_path / "mega"
    link.symlink_to("/dev/pts/nonexistent")          # left by a killed run
    p = subprocess.Popen([sys.executable, "-m", "navkit", "simboard", "--link", str(link), "--speed", "4"],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        first = p.stdout.readline()                   # the program (exec'd) says where it is
        assert first.startswith("simboard: ATmega2560 at 16000000 Hz, bootloader ")
        assert first.rstrip().endswith(f"link {link} -> {os.readlink(link)}")
        assert os.readlink(link).startswith("/dev/pts/") and Path(os.readlink(link)).exists()
    finally:
        p.send_signal(signal.SIGINT)
        out, err = p.communicate(timeout=10)
    assert p.returncode == 0, err
    assert "stopped after" in out
    assert not link.is_symlink()


def _simboard(tmp_path, *args):
    return subprocess.run([sys.executable, "-m", "navkit", "simboard", *args], capture_output=True,
                          text=True, timeout=20, cwd=tmp_path)


def test_missing_bootloader_is_named(tmp_path):
    r = _simboard(tmp_path, "--link", str(tmp_path / "mega"), "--bootloader", str(tmp_path / "none.hex"))
    assert r.returncode == 1
    assert r.stderr.strip() == (f"navkit-simboard: bootloader {tmp_path / 'none.hex'}: No such file or "
                                "directory: install arduino-core-avr (scripts/setup.sh) or give "
                                "--bootloader HEX")
    assert not (tmp_path / "mega").exists()


def test_bad_bootloader_record_names_its_line(tmp_path):
    bad = tmp_path / "boot.hex"
    bad.write_text(":020000023000CC\n:10E000000D9489F10D94B2F10D94B2F10D94B2F128\n")  # checksum off by 1
    r = _simboard(tmp_path, "--link", str(tmp_path / "mega"), "--bootloader", str(bad))
    assert r.returncode == 1
    assert r.stderr.strip() == f"navkit-simboard: bootloader {bad}:2: bad record checksum"


def test_flash_file_of_wrong_size_is_refused(tmp_path):
    (tmp_path / "flash.bin").write_bytes(b"\xff" * 1000)
    r = _simboard(tmp_path, "--link", str(tmp_path / "mega"), "--flash", str(tmp_path / "flash.bin"))
    assert r.returncode == 1
    assert "not a flash image of the ATmega2560 (1000 bytes, needs 262144)" in r.stderr


def test_link_taken_by_a_file_is_refused(tmp_path):
    (tmp_path / "mega").write_text("mine")
    r = _simboard(tmp_path, "--link", str(tmp_path / "mega"))
    assert r.returncode == 1
    assert "exists and is not a symlink" in r.stderr
    assert (tmp_path / "mega").read_text() == "mine"


def test_bad_options_exit_2(tmp_path):
    assert _simboard(tmp_path).returncode == 2                          # --link missing
    r = _simboard(tmp_path, "--link", str(tmp_path / "m"), "--speed", "fast")
    assert r.returncode == 2 and "--speed" in r.stderr
    r = subprocess.run([str(program()), "--link", str(tmp_path / "m"), "--nope"], capture_output=True,
                       text=True)
    assert r.returncode == 2 and "unknown option --nope" in r.stderr


def test_unbuilt_program_names_the_fix(tmp_path, monkeypatch):
    env = dict(os.environ, NAVKIT_BUILD_DIR=str(tmp_path / "nobuild"))
    r = subprocess.run([sys.executable, "-m", "navkit", "simboard", "--link", str(tmp_path / "m")],
                       capture_output=True, text=True, env=env, timeout=20)
    assert r.returncode == 1
    assert r.stderr.strip() == (f"navkit simboard: {tmp_path / 'nobuild'}/firmware/avr-simboard/"
                                "navkit-simboard is not built: run make")
    monkeypatch.setenv("NAVKIT_BUILD_DIR", str(tmp_path / "nobuild"))
    with pytest.raises(SimBoardError, match="not built: run make"):
        SimBoard(tmp_path / "m")


def test_simavr_missing_message(tmp_path, monkeypatch):
    import navkit.simboard as sb
    assert "simavr is missing" not in sb.missing_message(tmp_path / "navkit-simboard")
    monkeypatch.setenv("PATH", str(tmp_path))       # no pkg-config: no libsimavr found
    msg = sb.missing_message(tmp_path / "navkit-simboard")
    assert "simavr is missing" in msg and "libsimavr-dev" in msg and "make" in msg
