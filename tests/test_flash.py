"""`navkit flash`: image checks, board discovery, permissions, and flashing through a
simboard with the real avrdude (tests/avr_helpers.py builds the test images)."""

import json
import os
import shutil
import stat
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest

from navkit import flash as fl
from navkit.hostconfig import host_binary
from navkit.paths import build_dir
from navkit.protocol import SPEC, SPEC_HASH, encode_frame, defaults
from navkit.simboard import SimBoard, program
from avr_helpers import ECHO_C, TEST_SPEED, avrdude, build_image

MEGA = {"spec_hash": SPEC_HASH, "signature": (0x1E, 0x98, 0x01), "mcu": "atmega2560"}
REAL_IMAGE = build_dir() / "firmware" / "avr" / "navkit-mega2560.hex"
CAN_IMAGE = build_dir() / "firmware" / "avr" / "navkit-mega2560-can.hex"

needs_avr = pytest.mark.skipif(
    any(shutil.which(t) is None for t in ("avr-gcc", "avr-objcopy", "avrdude")),
    reason="avr-gcc/avrdude missing: run make (scripts/setup.sh)")
needs_sim = pytest.mark.skipif(not program().exists(), reason=f"{program()} not built: run make")
needs_real = pytest.mark.skipif(not REAL_IMAGE.exists(), reason=f"{REAL_IMAGE} not built: run make")
needs_can = pytest.mark.skipif(not CAN_IMAGE.exists(), reason=f"{CAN_IMAGE} not built: run make")


def responder_c(spec_hash: int) -> str:
    """An image that answers each burst of received bytes (a quiet ~10 ms after it) with one
    micro_data frame carrying `spec_hash`, fw_version 1.0, reset_cause external: a stand-in
    board whose answer the test controls."""
    fields = defaults("micro_data")
    fields.update(spec_hash=spec_hash, fw_version=0x0100)
    if "reset_cause" in fields:
        fields["reset_cause"] = SPEC.enums["reset_cause"].values["external"]
    frame = encode_frame("micro_data", fields)
    return r"""
#include <avr/io.h>
#include <avr/pgmspace.h>
static const uint8_t reply[] PROGMEM = { %s };
static void tx(uint8_t c) { while (!(UCSR0A & (1 << UDRE0))) {} UDR0 = c; }
int main(void)
{
    uint8_t got = 0;
    uint32_t idle = 0;
    UCSR0A = 1 << U2X0; UBRR0 = 16; UCSR0B = (1 << RXEN0) | (1 << TXEN0);
    for (;;) {
        if (UCSR0A & (1 << RXC0)) { (void)UDR0; got = 1; idle = 0; }
        else if (got && ++idle > 20000u) {
            for (uint16_t i = 0; i < sizeof reply; i++) { tx(pgm_read_byte(&reply[i])); }
            got = 0;
        }
    }
}
""" % ", ".join(str(b) for b in frame)


@pytest.fixture(scope="module")
def images(tmp_path_factory):
    """Test images: answering (responder, this spec), another spec's answer, silent (echo)."""
    if any(shutil.which(t) is None for t in ("avr-gcc", "avr-objcopy")):
        pytest.skip("avr-gcc missing: run make")
    tmp = tmp_path_factory.mktemp("images")
    return {
        "answers": build_image(tmp, "answers", responder_c(SPEC_HASH), info=MEGA),
        "other_spec_answer": build_image(tmp, "other", responder_c(SPEC_HASH ^ 0x5A5A), info=MEGA),
        "silent": build_image(tmp, "silent", ECHO_C, info=MEGA),
        "no_info": build_image(tmp, "noinfo", ECHO_C),
        "uno": build_image(tmp, "uno", ECHO_C, info=dict(MEGA, signature=(0x1E, 0x95, 0x0F), mcu="atmega328p")),
        "old_spec": build_image(tmp, "oldspec", ECHO_C, info=dict(MEGA, spec_hash=SPEC_HASH ^ 1)),
    }


def navkit_flash(*args, env=None, cwd=None):
    return subprocess.run([sys.executable, "-m", "navkit", "flash", *map(str, args)], capture_output=True,
                          text=True, timeout=180, env=env, cwd=cwd)


# ---- flashing through simboard ----

@needs_avr
@needs_sim
def test_navkit_flash_then_the_board_answers(tmp_path, images):
    with SimBoard(tmp_path / "mega", tmp_path / "flash.bin", speed=TEST_SPEED) as board:
        r = navkit_flash("--port", board.link, "--hex", images["answers"])
    assert r.returncode == 0, r.stdout + r.stderr
    lines = r.stdout.splitlines()
    assert lines[1] == f"navkit flash: {board.link}: no modem lines (a pty): opening it reset the board"
    assert "bytes written and verified in" in lines[3]
    want = f"answers: spec hash 0x{SPEC_HASH:08x}, fw_version 1.0"
    if any(f.name == "reset_cause" for f in SPEC.messages["micro_data"].fields):
        want += ", reset_cause external"
    assert want in lines[-1]


@needs_avr
@needs_sim
def test_board_answering_with_another_spec_is_reported(tmp_path, images):
    with SimBoard(tmp_path / "mega", speed=TEST_SPEED) as board:
        r = navkit_flash("--port", board.link, "--hex", images["other_spec_answer"])
    assert r.returncode == 1
    assert (f"answers with spec hash 0x{SPEC_HASH ^ 0x5A5A:08x}, this checkout's is 0x{SPEC_HASH:08x}"
            in r.stderr)


@needs_avr
@needs_sim
def test_answer_comes_although_the_bootloader_took_the_first_rounds(tmp_path, images):
    # no wait after the open: the bootloader takes the frames as its own and waits for
    # more (~6.5 s of simulated time, 1.6 s at 4x); a doubled gap outlasts it (the 2 s
    # gap when simboard keeps 4x, a later one when a busy host slows it)
    with SimBoard(tmp_path / "mega", speed=TEST_SPEED) as board:
        assert avrdude(board.link, images["answers"], "-D").returncode == 0
        t0 = time.monotonic()
        data = fl.query_board(str(board.link), boot_wait=0.0, timeout=20.0)
    assert data["spec_hash"] == SPEC_HASH
    assert time.monotonic() - t0 > 1.5


@needs_avr
@needs_sim
def test_board_that_never_answers(tmp_path, images):
    with SimBoard(tmp_path / "mega", speed=TEST_SPEED) as board:
        assert avrdude(board.link, images["silent"], "-D").returncode == 0
        with pytest.raises(fl.FlashError) as e:
            fl.query_board(str(board.link), boot_wait=0.6, timeout=1.0)
    assert str(e.value).startswith(f"the board on {board.link} never answered: no micro_data within 2 s")
    assert "navkit proto decode --port" in str(e.value)


@needs_avr
@needs_sim
def test_board_going_away_while_waiting(tmp_path, images):
    import threading
    board = SimBoard(tmp_path / "mega", speed=TEST_SPEED)
    board.start()
    try:
        assert avrdude(board.link, images["silent"], "-D").returncode == 0
        threading.Timer(1.0, board.stop).start()
        with pytest.raises(fl.FlashError, match=f"^port {board.link}: .*the board went away while navkit "
                                                "waited for its answer"):
            fl.query_board(str(board.link), boot_wait=0.5, timeout=5.0)
    finally:
        board.stop()


@needs_avr
@needs_sim
@needs_real
def test_real_image_with_navkit_flash(tmp_path):
    with SimBoard(tmp_path / "mega", tmp_path / "flash.bin", speed=TEST_SPEED) as board:
        r = navkit_flash("--port", board.link, "--hex", REAL_IMAGE)
    assert r.returncode == 0, r.stdout + r.stderr
    assert f"answers: spec hash 0x{SPEC_HASH:08x}, fw_version" in r.stdout.splitlines()[-1]


@needs_avr
@needs_sim
@needs_real
def test_real_image_with_plain_avrdude_boots_and_answers(tmp_path):
    causes = SPEC.enums["reset_cause"].values
    with SimBoard(tmp_path / "mega", tmp_path / "flash.bin", speed=TEST_SPEED) as board:
        r = avrdude(board.link, REAL_IMAGE, "-D")
        assert r.returncode == 0, r.stderr
        first = fl.query_board(str(board.link))
        again = fl.query_board(str(board.link))      # the image ran before this open's reset
    assert first["spec_hash"] == again["spec_hash"] == SPEC_HASH
    assert first["rx_good"] >= 1 and first["rx_bad_crc"] == 0
    # whether the image ran before the first open's reset depends on the bootloader's
    # 100 ms after avrdude left (power_on if not); before the second it ran: DTR's reset
    assert first["reset_cause"] in (causes["power_on"], causes["external"])
    assert again["reset_cause"] == causes["external"]


@needs_avr
@needs_sim
@needs_can
def test_can_image_flashes_and_says_where_it_answers(tmp_path):
    """The CAN image's micro link is the MCP2515's bus, never the USB-serial port: after
    avrdude's verify navkit asks nothing on the port and says where and how to check it,
    exit 0 (a waited-for micro_data that cannot come would be a false failure)."""
    with SimBoard(tmp_path / "mega", tmp_path / "flash.bin", speed=TEST_SPEED) as board:
        r = navkit_flash("--port", board.link, "--hex", CAN_IMAGE)
    assert r.returncode == 0, r.stdout + r.stderr
    assert r.stderr == ""
    lines = r.stdout.splitlines()
    assert lines[0].endswith(f"spec hash 0x{SPEC_HASH:08x}, micro link can")
    assert "bytes written and verified in" in lines[3]
    assert lines[-1] == f"navkit flash: {fl.can_image_text(str(board.link))}"
    assert f"over CAN (the MCP2515 on the SPI, {SPEC.can.bitrate} bit/s), not on {board.link}" in lines[-1]
    assert "[micro] link = slcan" in lines[-1] and "`navkit can dump --port ADAPTER`" in lines[-1]
    assert "never answered" not in r.stdout
    image = fl.read_hex(CAN_IMAGE)
    flashed = (tmp_path / "flash.bin").read_bytes()
    assert all(flashed[a] == b for a, b in image.items())      # what avrdude verified is on the board


@needs_real
@needs_can
def test_the_builds_images_say_their_link():
    assert fl.check_image(REAL_IMAGE)[0].link == "serial"
    can_info, _ = fl.check_image(CAN_IMAGE)
    assert (can_info.info_version, can_info.link) == (fl.INFO_VERSION, "can") == (2, "can")


# ---- the image ----

@needs_avr
@pytest.mark.parametrize("name, message", [
    ("no_info", "not a navkit image (no NAVKITIM image-info block in its data)"),
    ("uno", "built for atmega328p (signature 1e 95 0f), not the Arduino Mega 2560's atmega2560 (1e 98 01)"),
    ("old_spec", f"built from spec hash 0x{SPEC_HASH ^ 1:08x}, this checkout's protocol/navkit.toml is "
                 f"0x{SPEC_HASH:08x}"),
])
def test_foreign_images_are_refused(images, name, message):
    r = navkit_flash("--port", "/nonexistent", "--hex", images[name])
    assert r.returncode == 1
    assert r.stdout == ""
    assert r.stderr.startswith(f"navkit flash: {images[name]}: {message}")
    assert len(r.stderr.strip().splitlines()) == 1


def _hex_record(addr: int, data: bytes, kind: int = 0) -> str:
    rec = bytes((len(data), addr >> 8 & 0xFF, addr & 0xFF, kind)) + data
    return ":" + (rec + bytes(((-sum(rec)) & 0xFF,))).hex().upper()


def _info_block(link: int | None = None, **over) -> bytes:
    """An image-info block: version 1, or with `link` (its code) version 2."""
    f = dict(MEGA, **over)
    import struct
    block = struct.pack(fl.INFO_FORMAT, fl.IMAGE_MAGIC, 1 if link is None else 2, bytes(f["signature"]),
                        f["spec_hash"], 16_000_000, f["mcu"].encode())
    return block if link is None else block + bytes((link,))


@pytest.mark.parametrize("link, name", [(None, "serial"), (0, "serial"), (1, "can")])
def test_image_info_versions_and_links(tmp_path, link, name):
    path = tmp_path / "x.hex"
    path.write_text("\n".join([_hex_record(0x100, _info_block(link)), ":00000001FF"]) + "\n")
    info, _ = fl.check_image(path)
    assert (info.info_version, info.link, info.offset) == (1 if link is None else 2, name, 0x100)


def test_unknown_link_or_version_is_refused(tmp_path):
    path = tmp_path / "x.hex"
    path.write_text("\n".join([_hex_record(0, _info_block(7)), ":00000001FF"]) + "\n")
    r = navkit_flash("--port", "/nonexistent", "--hex", path)
    assert r.returncode == 1 and r.stdout == ""
    assert r.stderr == (f"navkit flash: {path}: its image-info names micro link #7, this navkit knows 0 serial, "
                        "1 can: flash it with the navkit of the checkout it came from\n")
    block = bytearray(_info_block(1))
    block[8] = 3                                                   # a version from a later navkit
    path.write_text("\n".join([_hex_record(0, bytes(block)), ":00000001FF"]) + "\n")
    with pytest.raises(fl.FlashError, match="image-info version 3, this navkit reads 1 to 2: rebuild"):
        fl.check_image(path)


def test_image_info_is_found_across_records_and_segments(tmp_path):
    block = _info_block()
    lines = [_hex_record(0, b"\x0c\x94" * 4), _hex_record(0, b"\x10\x00", kind=2),  # base 0x10000
             _hex_record(0xFFF0, block[:16]), _hex_record(0, b"\x00\x02", kind=4),  # base 0x20000
             _hex_record(0x0000, block[16:]), ":00000001FF"]
    # block[:16] at 0x1FFF0 and block[16:] at 0x20000: one block split over a 64 KiB boundary
    path = tmp_path / "split.hex"
    path.write_text("\n".join(lines) + "\n")
    info, nbytes = fl.check_image(path)
    assert info.offset == 0x1FFF0 and info.spec_hash == SPEC_HASH and info.mcu == "atmega2560"
    assert nbytes == 8 + 36


def test_image_reaching_the_bootloader_is_refused(tmp_path):
    path = tmp_path / "big.hex"
    path.write_text("\n".join([_hex_record(0, _info_block()), _hex_record(0, b"\x00\x03", kind=4),
                               _hex_record(0xE000, b"\xff\xff"), ":00000001FF"]) + "\n")
    with pytest.raises(fl.FlashError, match=r"data up to 0x3e002 reaches the bootloader's section at 0x3e000"):
        fl.check_image(path)


@pytest.mark.parametrize("text, where", [
    (":0400000000FC\n", "1: record length 4 does not match the line"),
    ("garbage\n", "1: not an Intel HEX record"),
    (":0100000000FE\n:0100000000FE\n", "1: bad record checksum"),
    (":00000001FF\n", None),
])
def test_bad_hex_names_the_line(tmp_path, text, where):
    path = tmp_path / "x.hex"
    path.write_text(text)
    with pytest.raises(fl.FlashError) as e:
        fl.check_image(path)
    assert str(e.value) == (f"{path}:{where}" if where else f"{path}: the image holds no data")


def test_missing_hex_file(tmp_path):
    r = navkit_flash("--hex", tmp_path / "none.hex")
    assert r.returncode == 1 and r.stderr == f"navkit flash: --hex {tmp_path / 'none.hex'}: no such file\n"


def test_unconfigured_build_folder_names_make(tmp_path):
    env = dict(os.environ, NAVKIT_BUILD_DIR=str(tmp_path / "nobuild"))
    r = navkit_flash(env=env)
    assert r.returncode == 1
    assert r.stderr == (f"navkit flash: {tmp_path / 'nobuild'}: not a configured build folder: run make "
                        "(or give --hex FILE)\n")


def test_failing_build_is_shown(tmp_path):
    (tmp_path / "CMakeCache.txt").write_text("")   # configured, but no build system in it
    r = navkit_flash(env=dict(os.environ, NAVKIT_BUILD_DIR=str(tmp_path)))
    assert r.returncode == 1
    assert r.stdout == f"navkit flash: building the image (cmake --build {tmp_path} --target navkit_avr_image)\n"
    assert r.stderr.startswith(f"navkit flash: the build failed (cmake --build {tmp_path} --target "
                               "navkit_avr_image):\n")
    assert r.stderr.rstrip().endswith("fix the errors above, then run make")


# ---- finding the board ----

def _usb_tty(root: Path, tty: str, vid: str, pid: str, product: str, by_id: str | None = None) -> None:
    """A fake /dev node and sysfs tty of a USB-serial device (the kernel's layout)."""
    dev = root / "sys" / "devices" / "pci0000:00" / "0000:00:14.0" / "usb1" / f"1-{tty[-1]}"
    iface = dev / f"1-{tty[-1]}:1.0"
    (iface / "tty" / tty).mkdir(parents=True)
    for name, value in (("idVendor", vid), ("idProduct", pid), ("product", product), ("serial", "85735")):
        (dev / name).write_text(value + "\n")
    (iface / "tty" / tty / "device").symlink_to("../../../" + iface.name)
    (root / "sys" / "class" / "tty").mkdir(parents=True, exist_ok=True)
    (root / "sys" / "class" / "tty" / tty).symlink_to(iface / "tty" / tty)
    (root / "dev").mkdir(exist_ok=True)
    (root / "dev" / tty).touch()
    if by_id:
        (root / "dev" / "serial" / "by-id").mkdir(parents=True, exist_ok=True)
        (root / "dev" / "serial" / "by-id" / by_id).symlink_to(f"../../{tty}")


def _platform_tty(root: Path, tty: str) -> None:
    d = root / "sys" / "devices" / "platform" / "serial8250" / "tty" / tty
    d.mkdir(parents=True)
    (d / "device").symlink_to("../../../serial8250")
    (root / "sys" / "class" / "tty").mkdir(parents=True, exist_ok=True)
    (root / "sys" / "class" / "tty" / tty).symlink_to(d)
    (root / "dev").mkdir(exist_ok=True)
    (root / "dev" / tty).touch()


def test_no_board(tmp_path, monkeypatch):
    _platform_tty(tmp_path, "ttyS0")     # a built-in UART is no board
    monkeypatch.setenv("NAVKIT_DEV_ROOT", str(tmp_path))
    assert fl.find_boards() == []
    with pytest.raises(fl.FlashError, match="^no board found: no USB-serial device under "
                                            "/dev/serial/by-id or /sys/class/tty; plug the Mega in"):
        fl.choose_port("auto")


def test_one_board_is_chosen(tmp_path, monkeypatch):
    _platform_tty(tmp_path, "ttyS0")
    _usb_tty(tmp_path, "ttyACM0", "2341", "0042", "Arduino Mega 2560",
             by_id="usb-Arduino__www.arduino.cc__0042_85735-if00")
    monkeypatch.setenv("NAVKIT_DEV_ROOT", str(tmp_path))
    boards = fl.find_boards()
    assert boards == [fl.Board(str(tmp_path / "dev" / "ttyACM0"),
                               "Arduino Mega 2560 [2341:0042] serial 85735, "
                               "usb-Arduino__www.arduino.cc__0042_85735-if00")]
    assert fl.choose_port("auto") == str(tmp_path / "dev" / "ttyACM0")
    assert fl.choose_port(None) == str(tmp_path / "dev" / "ttyACM0")


def test_several_boards_are_listed(tmp_path, monkeypatch):
    _usb_tty(tmp_path, "ttyACM0", "2341", "0042", "Arduino Mega 2560")
    _usb_tty(tmp_path, "ttyUSB1", "0403", "6001", "FT232R USB UART")
    monkeypatch.setenv("NAVKIT_DEV_ROOT", str(tmp_path))
    with pytest.raises(fl.FlashError) as e:
        fl.choose_port("auto")
    assert str(e.value) == ("several boards found; choose one with --port PATH:\n"
                            f"  {tmp_path}/dev/ttyACM0  Arduino Mega 2560 [2341:0042] serial 85735\n"
                            f"  {tmp_path}/dev/ttyUSB1  FT232R USB UART [0403:6001] serial 85735")


@needs_avr
def test_several_boards_through_the_cli(tmp_path, images):
    _usb_tty(tmp_path, "ttyACM0", "2341", "0042", "Arduino Mega 2560")
    _usb_tty(tmp_path, "ttyACM1", "2341", "0010", "Arduino Mega 2560")
    r = navkit_flash("--hex", images["answers"], env=dict(os.environ, NAVKIT_DEV_ROOT=str(tmp_path)))
    assert r.returncode == 1
    assert r.stderr.splitlines()[0] == "navkit flash: several boards found; choose one with --port PATH:"
    assert len(r.stderr.splitlines()) == 3


def test_a_can_adapter_is_no_board_and_is_named(tmp_path, monkeypatch):
    """A CANable (16d0:117e, the slcan link's kind) alone: no board, and the message says
    what was seen instead."""
    _usb_tty(tmp_path, "ttyACM1", "16d0", "117e", "CANable")
    monkeypatch.setenv("NAVKIT_DEV_ROOT", str(tmp_path))
    assert fl.find_boards() == []
    with pytest.raises(fl.FlashError) as e:
        fl.choose_port("auto")
    assert str(e.value).startswith("no board found: ")
    assert str(e.value).endswith(f"; seen:\n  {tmp_path}/dev/ttyACM1  CANable [16d0:117e] serial 85735 "
                                 "(not a serial-link kind)")


def test_the_org_mega_and_a_clone_are_boards_an_unknown_tty_is_not(tmp_path, monkeypatch):
    _usb_tty(tmp_path, "ttyACM0", "2a03", "0042", "Arduino Mega 2560")
    _usb_tty(tmp_path, "ttyUSB3", "1a86", "7523", "USB2.0-Serial")
    _usb_tty(tmp_path, "ttyUSB4", "1d50", "6018", "Black Magic Probe")
    monkeypatch.setenv("NAVKIT_DEV_ROOT", str(tmp_path))
    assert fl.find_boards() == [
        fl.Board(str(tmp_path / "dev" / "ttyACM0"), "Arduino Mega 2560 [2a03:0042] serial 85735"),
        fl.Board(str(tmp_path / "dev" / "ttyUSB3"), "USB2.0-Serial [1a86:7523] serial 85735")]


def test_flash_reads_the_hosts_listing(tmp_path):
    """What `navkit flash` asks: navkit-host --list-ports, here for the slcan link: the
    CANable among the ports, the Mega among the others, each with its ids and kind."""
    _usb_tty(tmp_path, "ttyACM0", "2341", "0042", "Arduino Mega 2560",
             by_id="usb-Arduino__www.arduino.cc__0042_85735-if00")
    _usb_tty(tmp_path, "ttyACM1", "16d0", "117e", "CANable")
    r = subprocess.run([str(host_binary()), "--list-ports", "--link", "slcan",
                        "--dev-root", str(tmp_path)], capture_output=True, text=True, timeout=30)
    assert r.returncode == 0, r.stderr
    found = json.loads(r.stdout)
    assert found["link"] == "slcan"
    assert [(p["tty"], p["vid"], p["pid"], p["link"], p["name"]) for p in found["ports"]] == [
        ("ttyACM1", "16d0", "117e", "slcan", "CANable (slcan firmware)")]
    assert [(p["path"], p["dev"], p["link"], p["name"]) for p in found["others"]] == [
        (f"{tmp_path}/dev/serial/by-id/usb-Arduino__www.arduino.cc__0042_85735-if00",
         f"{tmp_path}/dev/ttyACM0", "serial", "Arduino Mega 2560 R3")]


def test_port_that_does_not_exist(tmp_path):
    with pytest.raises(fl.FlashError, match=f"^port {tmp_path}/ttyACM9: no such device"):
        fl.choose_port(str(tmp_path / "ttyACM9"))


# ---- permission ----

def _stat(mode: int, gid: int) -> os.stat_result:
    return os.stat_result((stat.S_IFCHR | mode, 0, 0, 1, 0, gid, 0, 0, 0, 0))


def test_permission_message_names_the_group_and_the_fix():
    dialout = 20
    msg = fl.permission_message("/dev/ttyACM0", _stat(0o660, dialout), user="ann", groups=[1000])
    name = __import__("grp").getgrgid(dialout).gr_name
    assert msg == (f"cannot open /dev/ttyACM0: permission denied (owner root, group {name}, mode crw-rw----): "
                   f"add yourself to group {name} with `sudo usermod -aG {name} $USER`, then log out and in again")


def test_permission_message_when_added_but_not_logged_in_again(monkeypatch):
    import grp
    fake = grp.struct_group(("dialout", "x", 20, ["ann"]))
    monkeypatch.setattr(grp, "getgrgid", lambda gid: fake)
    msg = fl.permission_message("/dev/ttyACM0", _stat(0o660, 20), user="ann", groups=[1000])
    assert msg.endswith("ann is in group dialout but this login predates it: log out and in again "
                        "(or run `newgrp dialout`)")


def test_permission_message_when_the_group_cannot_either():
    msg = fl.permission_message("/dev/ttyS0", _stat(0o620, 5), user="ann", groups=[])
    assert "mode crw--w----" in msg and "the group may not use it either" in msg


@pytest.mark.skipif(os.geteuid() != 0 or shutil.which("setpriv") is None or not os.path.exists("/dev/ttyS0")
                    or os.stat("/dev/ttyS0").st_mode & 0o006,
                    reason="needs root, setpriv and a /dev/ttyS0 that others may not open")
def test_permission_denied_for_a_real_user():
    # nobody runs the base interpreter on a world-readable copy of the package: the
    # checkout (and pytest's temporary folders) may sit in a folder only root can enter
    pkg = Path(tempfile.mkdtemp(prefix="navkit-nobody-"))
    try:
        pkg.chmod(0o755)
        shutil.copytree(Path(fl.__file__).parent, pkg / "navkit",
                        ignore=shutil.ignore_patterns("__pycache__"))
        for p in [pkg / "navkit", *(pkg / "navkit").rglob("*")]:
            p.chmod(0o755 if p.is_dir() else 0o644)
        code = ("import sys; from navkit.flash import check_access, FlashError\n"
                "try: check_access('/dev/ttyS0')\nexcept FlashError as e: print(e); sys.exit(1)")
        r = subprocess.run(["setpriv", "--reuid=nobody", "--regid=nogroup", "--clear-groups",
                            os.path.realpath(sys.executable), "-c", code],
                           capture_output=True, text=True, timeout=30, cwd="/",
                           env=dict(os.environ, PYTHONPATH=str(pkg)))
    finally:
        shutil.rmtree(pkg, ignore_errors=True)
    assert r.returncode == 1, r.stderr
    assert r.stdout.startswith("cannot open /dev/ttyS0: permission denied (owner root, group ")


# ---- avrdude ----

@needs_avr
def test_avrdude_failure_shows_its_own_text(tmp_path, images):
    not_a_tty = tmp_path / "ttyFAKE"
    not_a_tty.write_bytes(b"")
    r = navkit_flash("--port", not_a_tty, "--hex", images["answers"])
    assert r.returncode == 1
    assert f"navkit flash: {not_a_tty}: not reset: cannot open it as a serial port" in r.stdout
    assert r.stderr.startswith(f"navkit flash: avrdude failed (exit 1) on {not_a_tty}:\n")
    assert "avrdude" in r.stderr.splitlines()[1]                      # avrdude's own line
    assert "stk500v2 bootloader" in r.stderr.splitlines()[-1]


def test_avrdude_missing(tmp_path, monkeypatch):
    monkeypatch.setenv("PATH", str(tmp_path))
    with pytest.raises(fl.FlashError, match="^avrdude not found: install it"):
        fl.run_avrdude(str(tmp_path / "port"), tmp_path / "x.hex")


def test_a_refused_config_is_said_with_its_fix():
    """A range refusal of micro_cfg_geometry (the spec-default control_rate above the AVR
    image's ceiling) names the INI key to change; another message's is said plainly."""
    from navkit.flash import _refusal
    from navkit.protocol import SPEC

    rng = 1 << SPEC.enums["reject"].values["range"]
    types = SPEC.enums["msg_type"].values
    text = _refusal(rng | types["micro_cfg_geometry"])
    assert "[micro_cfg_geometry] control_rate" in text and "NavAndControl.ini" in text
    assert _refusal(rng | types["micro_cfg_motion"]) == \
        " (micro_cfg_motion refused: a field outside the board's range)"
    assert _refusal(0) == ""
