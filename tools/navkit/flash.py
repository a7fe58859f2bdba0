"""`navkit flash`: put the firmware image on an Arduino Mega 2560 and check it answers.

    navkit flash [--port PATH|auto] [--hex FILE]
    navkit flash --bench [--hex FILE]        flash through a simboard, print the time

Steps, each failing with one line that names the fix (exit status 1):
1. the image: --hex FILE, else `<build>/firmware/avr/navkit-mega2560.hex`, built first
   (`cmake --build <build> --target navkit_avr_image`); refused unless its image-info
   block (magic "NAVKITIM" in its data; version 1, or 2 with the link byte) says
   ATmega2560 and this spec's hash; the block also says which micro link the image
   speaks (serial on UART0, or CAN on the MCP2515: step 6);
2. the board: --port PATH, or with `auto` the one USB-serial device of the serial link's
   kinds that navkit-host finds (`navkit-host --list-ports --link serial`: the one table of
   USB ids; none: say so, naming the devices of other kinds; several: list them);
   `$NAVKIT_DEV_ROOT` puts another root in front of /dev and /sys (tests);
3. access: the port must open read-write (EACCES: the group to join and how);
4. reset into the bootloader by DTR (dropped and raised; a pty has no modem lines:
   opening it is what resets `navkit simboard`);
5. the real avrdude for the Mega's stk500v2 bootloader, verifying what it wrote:
   `avrdude -c wiring -p atmega2560 -P PORT -b 115200 -D -U flash:w:IMAGE:i`
   (its own error text is shown when it fails);
6. the board answers: the port is opened again (which resets the board; the
   bootloader waits ~1 s), then a micro_cmd and the three config messages, built by
   navkit.protocol, until a micro_data comes back; its spec_hash must be this spec's,
   and its fw_version, reset_cause and configured state (or the refusal) are reported.
   A CAN image answers on the CAN bus, never on this port: navkit says so and how to
   check it there (navkit-host with link = slcan, `navkit can dump`), and asks nothing.
"""

from __future__ import annotations

import argparse
import errno
import grp
import json
import os
import pwd
import re
import stat
import struct
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

__all__ = [
    "add_arguments", "run", "FlashError", "ImageInfo", "Board", "read_hex", "image_info",
    "check_image", "find_boards", "choose_port", "check_access", "permission_message",
    "reset_by_dtr", "run_avrdude", "query_board", "flash", "FlashResult", "can_image_text",
    "IMAGE_MAGIC", "INFO_FORMAT", "INFO_VERSION", "LINKS", "MCU", "SIGNATURE", "F_CPU_HZ", "BAUD", "APP_BYTES",
]

IMAGE_MAGIC = b"NAVKITIM"
INFO_FORMAT = "<8sB3sII16s"      # versions 1 and 2: magic, info_version, signature, spec_hash, f_cpu, mcu
INFO_BYTES = struct.calcsize(INFO_FORMAT)   # 36; version 2 adds the link byte after them
INFO_VERSION = 2                  # the newest (firmware/avr/board_info.h); 1 is read too (a serial image)
LINKS = {0: "serial", 1: "can"}   # the link byte: board_info.h BOARD_INFO_LINK_*
MCU = "atmega2560"
SIGNATURE = bytes((0x1E, 0x98, 0x01))
F_CPU_HZ = 16_000_000
BAUD = 115200                     # the Mega's stk500v2 bootloader and the micro link, bit/s
APP_BYTES = 256 * 1024 - 8 * 1024  # flash below the 8 KiB boot section, bytes
BOOT_WAIT_S = 1.5                 # the bootloader's wait after a reset (~1 s) plus margin
ANSWER_TIMEOUT_S = 10.0           # after the wait, until a micro_data must have come
AVRDUDE_TIMEOUT_S = 300.0

class FlashError(Exception):
    """A failure the user can fix; str() is the whole message, fix included."""


@dataclass(frozen=True)
class ImageInfo:
    """The image-info block of a navkit AVR image (interface 1)."""

    offset: int          # flash byte address of the block
    info_version: int
    signature: bytes     # 3 device signature bytes
    spec_hash: int
    f_cpu_hz: int
    mcu: str
    link: str = "serial"  # LINKS' name of the micro link it speaks; "#N" for a code not in LINKS


@dataclass(frozen=True)
class Board:
    """A USB-serial device that may be a board: its device node and what it says it is."""

    port: str            # device path as the user would give it (/dev/ttyACM0)
    description: str     # USB product / by-id name / VID:PID


@dataclass
class FlashResult:
    """What a flash did: seconds of avrdude (write + verify), bytes, the board's answer
    (micro_data's fields and the seconds until it came; None and 0 for a CAN image, whose
    answer goes to the CAN bus) and the link the image speaks."""

    port: str
    image: Path
    image_bytes: int
    avrdude_s: float
    answer_s: float
    micro_data: dict | None
    link: str = "serial"


# ---- the image ----

def read_hex(path: Path) -> dict[int, int]:
    """The data of Intel HEX file `path` as {byte address: value} (records 00-05, checksums
    checked). Raises FlashError naming `path:line` for anything else."""
    try:
        text = Path(path).read_text(encoding="ascii", errors="replace")
    except OSError as e:
        raise FlashError(f"{path}: cannot read the image: {e.strerror}") from None
    data: dict[int, int] = {}
    base = 0
    for n, line in enumerate(text.splitlines(), 1):
        line = line.strip()
        if not line:
            continue
        if not line.startswith(":") or len(line) < 11 or len(line) % 2 == 0:
            raise FlashError(f"{path}:{n}: not an Intel HEX record")
        try:
            rec = bytes.fromhex(line[1:])
        except ValueError:
            raise FlashError(f"{path}:{n}: not an Intel HEX record (bad hex digits)") from None
        count, addr, kind = rec[0], (rec[1] << 8) | rec[2], rec[3]
        if len(rec) != count + 5:
            raise FlashError(f"{path}:{n}: record length {count} does not match the line")
        if sum(rec) & 0xFF:
            raise FlashError(f"{path}:{n}: bad record checksum")
        if kind == 0:
            for i, b in enumerate(rec[4:4 + count]):
                data[base + addr + i] = b
        elif kind == 1:
            break
        elif kind == 2 and count == 2:
            base = ((rec[4] << 8) | rec[5]) << 4
        elif kind == 4 and count == 2:
            base = ((rec[4] << 8) | rec[5]) << 16
        elif kind not in (3, 5):
            raise FlashError(f"{path}:{n}: record type {kind} is not Intel HEX")
    return data


def image_info(data: dict[int, int]) -> ImageInfo | None:
    """The image-info block found by its magic in the image's data (gaps read as 0xFF),
    or None when the image has none."""
    if not data:
        return None
    lo, hi = min(data), max(data) + 1
    flat = bytearray(b"\xff" * (hi - lo))
    for a, b in data.items():
        flat[a - lo] = b
    at = flat.find(IMAGE_MAGIC)
    if at < 0 or at + INFO_BYTES > len(flat):
        return None
    _, version, sig, spec_hash, f_cpu, mcu = struct.unpack_from(INFO_FORMAT, flat, at)
    link = "serial"                   # a version-1 block names no link: a serial image
    if version >= 2:
        if at + INFO_BYTES + 1 > len(flat):
            return None
        code = flat[at + INFO_BYTES]
        link = LINKS.get(code, f"#{code}")
    return ImageInfo(lo + at, version, bytes(sig), spec_hash, f_cpu,
                     mcu.split(b"\0", 1)[0].decode("ascii", "replace"), link)


def check_image(path: Path) -> tuple[ImageInfo, int]:
    """The image's info block and its size in bytes, or FlashError saying why this
    image must not go on this kit's board (not navkit's, another MCU, another spec,
    too large)."""
    from navkit.protocol import SPEC_HASH
    data = read_hex(path)
    if not data:
        raise FlashError(f"{path}: the image holds no data")
    info = image_info(data)
    if info is None:
        raise FlashError(f"{path}: not a navkit image (no {IMAGE_MAGIC.decode()} image-info block in "
                         "its data): flash the image `make` builds, "
                         "build/firmware/avr/navkit-mega2560.hex")
    if not 1 <= info.info_version <= INFO_VERSION:
        raise FlashError(f"{path}: image-info version {info.info_version}, this navkit reads 1 to "
                         f"{INFO_VERSION}: rebuild the image with this checkout (make)")
    if info.link not in LINKS.values():
        raise FlashError(f"{path}: its image-info names micro link {info.link}, this navkit knows "
                         + ", ".join(f"{c} {n}" for c, n in LINKS.items())
                         + ": flash it with the navkit of the checkout it came from")
    if info.signature != SIGNATURE or info.mcu != MCU:
        raise FlashError(f"{path}: built for {info.mcu or '?'} (signature {info.signature.hex(' ')}), "
                         f"not the Arduino Mega 2560's {MCU} ({SIGNATURE.hex(' ')}): "
                         "build the image for the Mega (make) or flash it with that board's tools")
    if info.spec_hash != SPEC_HASH:
        raise FlashError(f"{path}: built from spec hash 0x{info.spec_hash:08x}, this checkout's "
                         f"protocol/navkit.toml is 0x{SPEC_HASH:08x}: the host would refuse the "
                         "board; rebuild the image (make) or flash from the checkout it came from")
    if info.f_cpu_hz != F_CPU_HZ:
        raise FlashError(f"{path}: built for a {info.f_cpu_hz} Hz clock, the Mega runs at "
                         f"{F_CPU_HZ} Hz: rebuild the image (make)")
    top = max(data) + 1
    if top > APP_BYTES:
        raise FlashError(f"{path}: data up to 0x{top:05x} reaches the bootloader's section at "
                         f"0x{APP_BYTES:05x}: the image is too large for the Mega")
    return info, len(data)


def _build_image(build: Path) -> Path:
    """Bring `<build>/firmware/avr/navkit-mega2560.hex` up to date: cmake --build of the
    AVR image's target (navkit_avr_image, firmware/avr/avr.cmake)."""
    image = build / "firmware" / "avr" / "navkit-mega2560.hex"
    if not (build / "CMakeCache.txt").exists():
        raise FlashError(f"{build}: not a configured build folder: run make (or give --hex FILE)")
    cmd = ["cmake", "--build", str(build), "--target", "navkit_avr_image"]
    print(f"navkit flash: building the image ({' '.join(cmd)})", flush=True)
    try:
        r = subprocess.run(cmd, capture_output=True, text=True)
    except FileNotFoundError:
        raise FlashError("cmake not found: run make (scripts/setup.sh installs it)") from None
    if r.returncode != 0:
        tail = "\n".join((r.stdout + r.stderr).strip().splitlines()[-20:])
        raise FlashError(f"the build failed ({' '.join(cmd)}):\n{tail}\nfix the errors above, then run make")
    if not image.exists():
        raise FlashError(f"{image}: not built (the AVR image needs gcc-avr and avr-libc: run make, "
                         "which runs scripts/setup.sh)")
    return image


# ---- the board ----

def _dev_root() -> Path:
    return Path(os.environ.get("NAVKIT_DEV_ROOT", "/"))


def _host_ports(root: Path) -> dict:
    """The host's port discovery of the serial link's kinds (`navkit-host --list-ports --link
    serial`, its JSON: "ports" of that kind, "others"), under `root` (--dev-root). The host
    holds the one table of which USB ids are what (host/src/port_discovery.cpp)."""
    from navkit.hostconfig import host_binary

    host = host_binary()
    if not host.is_file():
        raise FlashError(f"{host}: not built (it finds the board: run make), or give --port PATH")
    cmd = [str(host), "--list-ports", "--link", "serial"]
    if root != Path("/"):
        cmd += ["--dev-root", str(root)]
    try:
        r = subprocess.run(cmd, capture_output=True, text=True, errors="replace", timeout=30,
                           stdin=subprocess.DEVNULL)
        found = json.loads(r.stdout) if r.returncode == 0 else None
    except (OSError, subprocess.SubprocessError, ValueError) as e:
        raise FlashError(f"{' '.join(cmd)}: {e}; give --port PATH") from None
    if found is None:
        said = r.stderr.strip().splitlines()[0] if r.stderr.strip() else f"exit status {r.returncode}"
        raise FlashError(f"{' '.join(cmd)}: {said}; give --port PATH")
    return found


def _board(port: dict) -> Board:
    """A port of the host's JSON as a Board: its /dev node and what it says it is."""
    what = port["product"] or port["name"] or "USB serial"
    if port["vid"]:
        what += f" [{port['vid']}:{port['pid']}]"
    if port["serial"]:
        what += f" serial {port['serial']}"
    if port["by_id"]:
        what += f", {port['by_id']}"
    return Board(port["dev"], what)


def find_boards(root: Path | None = None) -> list[Board]:
    """The USB-serial devices a Mega can be behind (the host's serial-link kinds: the Mega's
    own 16U2 on ttyACM, FTDI, CH340, CP210x), found by navkit-host under `root` (default
    `$NAVKIT_DEV_ROOT` or /), sorted by port."""
    root = _dev_root() if root is None else Path(root)
    return _boards(_host_ports(root)["ports"])


def _boards(ports: list) -> list[Board]:
    """The host's JSON ports as Boards, sorted by port."""
    return sorted(map(_board, ports), key=lambda b: b.port)


def choose_port(port: str | None) -> str:
    """`port` itself, or with None/'auto' the one board found; FlashError for none (naming
    the USB devices of other kinds seen) or several (listed), or a port path that does not
    exist."""
    if port and port != "auto":
        if not os.path.exists(port):
            raise FlashError(f"port {port}: no such device (plugged in? for a simulated board "
                             "give the --link path of `navkit simboard`)")
        return port
    found = _host_ports(_dev_root())
    boards = _boards(found["ports"])
    if not boards:
        others = "".join(f"\n  {b.port}  {b.description} (not a serial-link kind)"
                         for b in _boards(found["others"]))
        raise FlashError("no board found: no USB-serial device under /dev/serial/by-id or "
                         "/sys/class/tty; plug the Mega in (a data cable, not charge-only), or "
                         "give --port PATH (for `navkit simboard`: its --link path); the USB ids "
                         "taken for one: navkit-host --list-ports" +
                         (f"; seen:{others}" if others else ""))
    if len(boards) > 1:
        listing = "\n".join(f"  {b.port}  {b.description}" for b in boards)
        raise FlashError(f"several boards found; choose one with --port PATH:\n{listing}")
    return boards[0].port


def permission_message(port: str, st: os.stat_result, user: str | None = None,
                       groups: list[int] | None = None) -> str:
    """The message for a port this user may not open: its owner, group and mode, and the
    fix (join the group and log in again, or log in again when already added).
    `user` and `groups` (gids of this process) default to the current ones."""
    try:
        group = grp.getgrgid(st.st_gid)
        gname, members = group.gr_name, group.gr_mem
    except KeyError:
        gname, members = str(st.st_gid), []
    try:
        owner = pwd.getpwuid(st.st_uid).pw_name
    except KeyError:
        owner = str(st.st_uid)
    if user is None:
        try:
            user = pwd.getpwuid(os.getuid()).pw_name
        except KeyError:
            user = str(os.getuid())
    groups = os.getgroups() if groups is None else groups
    head = (f"cannot open {port}: permission denied (owner {owner}, group {gname}, "
            f"mode {stat.filemode(st.st_mode)})")
    if st.st_mode & (stat.S_IRGRP | stat.S_IWGRP) != stat.S_IRGRP | stat.S_IWGRP:
        return f"{head}: the group may not use it either; ask the admin for a udev rule giving {gname} rw"
    if st.st_gid not in groups and user in members:
        return (f"{head}: {user} is in group {gname} but this login predates it: "
                "log out and in again (or run `newgrp " + gname + "`)")
    return (f"{head}: add yourself to group {gname} with `sudo usermod -aG {gname} $USER`, "
            "then log out and in again")


def check_access(port: str) -> None:
    """Open `port` read-write and close it; FlashError on permission, busy or other errors."""
    try:
        fd = os.open(port, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
    except PermissionError:
        try:
            st = os.stat(port)
        except OSError:
            raise FlashError(f"cannot open {port}: permission denied, and its folder may not be "
                             "searched: ask the admin, or give the device's /dev path") from None
        raise FlashError(permission_message(port, st)) from None
    except OSError as e:
        if e.errno == errno.ENOENT:
            raise FlashError(f"port {port}: no such device (unplugged?)") from None
        if e.errno == errno.EBUSY:
            raise FlashError(f"port {port}: busy; close the program using it (navkit-host, a serial "
                             "monitor) and try again") from None
        raise FlashError(f"port {port}: cannot open it: {e.strerror}") from None
    os.close(fd)


def reset_by_dtr(port: str) -> str | None:
    """Pulse DTR and RTS low then high (the Mega's auto-reset starts its bootloader).
    Returns None when done, else why not: a port without modem lines (a pty, where
    opening it is the reset of `navkit simboard`) or one that is not a serial port."""
    import serial
    try:
        s = serial.Serial(port, BAUD, timeout=0)
    except (OSError, serial.SerialException) as e:
        return f"not reset: cannot open it as a serial port ({e})"
    with s:
        try:
            s.dtr = False
            s.rts = False
            time.sleep(0.05)
            s.dtr = True
            s.rts = True
        except (OSError, serial.SerialException):
            return "no modem lines (a pty): opening it reset the board"
    return None


def run_avrdude(port: str, image: Path, *, verbose: bool = False) -> float:
    """Flash `image` with avrdude through the stk500v2 bootloader, verification on;
    returns the seconds it took. FlashError with avrdude's own text when it fails."""
    cmd = ["avrdude", "-c", "wiring", "-p", MCU, "-P", port, "-b", str(BAUD), "-D",
           "-U", f"flash:w:{image}:i"]
    t0 = time.monotonic()
    try:
        r = subprocess.run(cmd, capture_output=True, text=True, timeout=AVRDUDE_TIMEOUT_S)
    except FileNotFoundError:
        raise FlashError("avrdude not found: install it (scripts/setup.sh does, as root: "
                         "apt-get install avrdude)") from None
    except subprocess.TimeoutExpired:
        raise FlashError(f"avrdude on {port} did not finish in {AVRDUDE_TIMEOUT_S:.0f} s: "
                         "unplug and replug the board and try again") from None
    took = time.monotonic() - t0
    out = (r.stdout + r.stderr).strip()
    if verbose:
        print(out)
    if r.returncode != 0:
        lines = [ln for ln in out.splitlines()
                 if ln.strip() and not re.match(r"\s*(Reading|Writing) \|", ln)]
        text = "\n".join("  " + ln.strip() for ln in lines[-15:])
        raise FlashError(f"avrdude failed (exit {r.returncode}) on {port}:\n{text}\n"
                         "check that PORT is the Mega (not another device), that it has its "
                         "stk500v2 bootloader, and that no other program holds the port "
                         f"(command: {' '.join(cmd)})")
    return took


def _micro_data_text(d: dict) -> str:
    """fw_version, reset cause and configured state of a micro_data, for the report."""
    from navkit.protocol import SPEC
    parts = [f"spec hash 0x{d['spec_hash']:08x}",
             f"fw_version {d['fw_version'] >> 8}.{d['fw_version'] & 0xFF}"]
    if "reset_cause" in d:
        names = {v: k for k, v in SPEC.enums["reset_cause"].values.items()}
        parts.append(f"reset_cause {names.get(d['reset_cause'], d['reset_cause'])}")
    bit = SPEC.enums["micro_status"].values["configured"]
    if d["status"] >> bit & 1:
        parts.append("configured")
    else:
        parts.append("not configured" + _refusal(d["last_reject"]))
    return ", ".join(parts)


def _refusal(last_reject: int) -> str:
    """Why the last message was refused (micro_data.last_reject, flags `reject`), as
    ' (MESSAGE refused: REASON)', or '' when nothing was."""
    from navkit.protocol import SPEC
    bits = SPEC.enums["reject"].values
    types = {v: k for k, v in SPEC.enums["msg_type"].values.items()}
    low = last_reject & ~(1 << bits["range"] | 1 << bits["unconfigured"])
    if last_reject >> bits["range"] & 1:
        if types.get(low) == "micro_cfg_geometry":
            from navkit.protocol import defaults
            rate = defaults("micro_cfg_geometry")["control_rate"]
            return (f" (micro_cfg_geometry refused: a field outside the board's range; navkit "
                    f"sends the spec defaults, whose control_rate {rate} Hz is above the AVR "
                    "image's ceiling: give the host's NavAndControl.ini [micro_cfg_geometry] "
                    "control_rate at most that ceiling, docs/avr.md)")
        return f" ({types.get(low, low)} refused: a field outside the board's range)"
    if last_reject >> bits["unconfigured"] & 1:
        return f" ({types.get(low, low)} refused: not configured)"
    return f" (command {last_reject} refused)" if last_reject else ""


def query_board(port: str, *, boot_wait: float = BOOT_WAIT_S,
                timeout: float = ANSWER_TIMEOUT_S) -> dict:
    """Open `port` (resetting the board), wait out the bootloader, then send a micro_cmd
    (no command) and the three config messages (spec defaults) after 0, 0.5, 1.5, 3.5 s
    ... until micro_data answers; return the fields of the last micro_data of that round (the
    board skips a reply that does not fit its TX buffer, so not every frame gets one).
    FlashError when none comes in `timeout` s or it carries another spec hash."""
    import serial
    try:
        return _query(port, boot_wait, timeout)
    except (OSError, serial.SerialException) as e:
        raise FlashError(f"port {port}: {e}: the board went away while navkit waited for its "
                         "answer (unplugged? simboard stopped?)") from None


def _query(port: str, boot_wait: float, timeout: float) -> dict:
    import serial
    from navkit.protocol import (DIR_TO_HOST, SPEC_HASH, Frame, Parser, defaults,
                                 encode_frame)
    names = ("micro_cfg_geometry", "micro_cfg_motion", "micro_cfg_io")
    parser = Parser(direction=DIR_TO_HOST)
    tag = 0
    with serial.Serial(port, BAUD, timeout=0.05) as s:
        t_end = time.monotonic() + boot_wait
        while time.monotonic() < t_end:   # the bootloader would take our bytes for its own
            s.read(256)
        t_end = time.monotonic() + timeout
        next_send, gap = 0.0, 0.5
        last = None
        while time.monotonic() < t_end:
            if last is None and time.monotonic() >= next_send:
                tag += 1
                s.write(encode_frame("micro_cmd", {}, time_tag=tag))
                for name in names:
                    tag += 1
                    s.write(encode_frame(name, defaults(name), time_tag=tag))
                # doubling gaps: a bootloader still waiting (a slow simboard) takes each
                # round as its own and waits on; a long enough gap lets it time out
                next_send, gap = time.monotonic() + gap, gap * 2
            for ev in parser.feed(s.read(512)):
                if isinstance(ev, Frame) and ev.name == "micro_data":
                    if last is None:   # the other replies of this round follow within ~10 ms
                        t_end = time.monotonic() + 0.3
                    last = ev.fields
            if parser.foreign_hash is not None:
                raise FlashError(f"the board on {port} answers with spec hash 0x{parser.foreign_hash:08x}, "
                                 f"this checkout's is 0x{SPEC_HASH:08x}: the flashed image is not "
                                 "the one checked (flash again; rebuild with make)")
        if last is not None:
            if last["spec_hash"] != SPEC_HASH:
                raise FlashError(f"the board on {port} answers with spec hash 0x{last['spec_hash']:08x}, "
                                 f"this checkout's is 0x{SPEC_HASH:08x}: the flashed image is not "
                                 "the one checked (flash again; rebuild with make)")
            return last
    raise FlashError(f"the board on {port} never answered: no micro_data within {boot_wait + timeout:.0f} s "
                     f"of opening it at {BAUD} bit/s; press its reset button and run `navkit proto decode "
                     f"--port {port}` to see what it sends, or flash again")


def flash(port: str, image: Path, *, verbose: bool = False, say=print) -> FlashResult:
    """Steps 3-6 of the module docstring on a chosen port and a checked image."""
    info, nbytes = check_image(image)
    check_access(port)
    why = reset_by_dtr(port)
    say(f"navkit flash: {port}: " + (why or "reset by DTR"))
    say(f"navkit flash: avrdude -c wiring -p {MCU} -P {port} -b {BAUD} -D -U flash:w:{image}:i")
    took = run_avrdude(port, image, verbose=verbose)
    say(f"navkit flash: {nbytes} bytes written and verified in {took:.2f} s")
    if info.link != "serial":         # its micro link is on the CAN bus: nothing answers here
        return FlashResult(port, Path(image), nbytes, took, 0.0, None, info.link)
    t0 = time.monotonic()
    data = query_board(port)
    return FlashResult(port, Path(image), nbytes, took, time.monotonic() - t0, data)


def can_image_text(port: str) -> str:
    """What `navkit flash` says after flashing a CAN image on `port`: where the micro
    answers (the CAN bus at the spec's bit rate) and how to check it there."""
    from navkit.protocol import SPEC
    return (f"the image speaks the micro link over CAN (the MCP2515 on the SPI, {SPEC.can.bitrate} bit/s), "
            f"not on {port}, so its answer is not checked here; to see it answer, wire an SLCAN adapter "
            "(CANable, USBtin, CANUSB) to the MCP2515's CAN bus, run navkit-host with [micro] link = slcan "
            "and port = auto, and watch the bus with `navkit can dump --port ADAPTER` (docs/can.md)")


def _bench(image: Path) -> int:
    """Flash `image` through a fresh simboard at real time; print seconds and bytes/s, and
    how much of real time the simulation kept (below 1 the host was too slow or busy)."""
    import tempfile
    from navkit.simboard import SimBoard, SimBoardError
    with tempfile.TemporaryDirectory(prefix="navkit-flash-bench-") as tmp:
        link = Path(tmp) / "mega"
        try:
            board = SimBoard(link, Path(tmp) / "flash.bin")
            t0 = time.monotonic()
            with board:
                r = flash(str(link), image, say=lambda *_: None)
            wall = time.monotonic() - t0
        except SimBoardError as e:
            raise FlashError(str(e)) from None
        m = re.search(r"stopped after ([0-9.]+) s of simulated time", board.output())
    print(f"flash time through simboard ({BAUD} bit/s, write + verify): {r.avrdude_s:.2f} s for "
          f"{r.image_bytes} bytes = {r.image_bytes / r.avrdude_s:.0f} bytes/s")
    if r.micro_data is None:
        print(f"board answer not measured: the image speaks the micro link over {r.link.upper()}")
    else:
        print(f"board answered {r.answer_s:.2f} s after the port was opened again (bootloader wait "
              f"{BOOT_WAIT_S} s included): {_micro_data_text(r.micro_data)}")
    if m:
        print(f"simboard ran {float(m.group(1)):.2f} s of simulated time in {wall:.2f} s "
              f"({float(m.group(1)) / wall:.2f} of real time)")
    return 0


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--port", default="auto", metavar="PATH|auto",
                        help="serial port of the board, or auto (default): the one USB-serial "
                             "device found; a `navkit simboard --link` path works too")
    parser.add_argument("--hex", type=Path, metavar="FILE",
                        help="image to flash (default: the build's firmware/avr/navkit-mega2560.hex, "
                             "built first)")
    parser.add_argument("--verbose", action="store_true", help="show avrdude's whole output")
    parser.add_argument("--bench", action="store_true",
                        help="flash through a fresh `navkit simboard` at real time and print "
                             "the time and bytes/s (no board needed)")


def run(args) -> int:
    from navkit.paths import build_dir
    try:
        image = args.hex if args.hex is not None else _build_image(build_dir())
        if not image.exists():
            raise FlashError(f"--hex {image}: no such file")
        info, nbytes = check_image(image)
        print(f"navkit flash: {image}: {nbytes} bytes for {info.mcu}, spec hash 0x{info.spec_hash:08x}, "
              f"micro link {info.link}")
        if args.bench:
            return _bench(image)
        port = choose_port(args.port)
        r = flash(port, image, verbose=args.verbose)
        if r.micro_data is None:
            print(f"navkit flash: {can_image_text(port)}")
        else:
            print(f"navkit flash: the board on {port} answers: {_micro_data_text(r.micro_data)}")
        return 0
    except FlashError as e:
        print(f"navkit flash: {e}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("navkit flash: interrupted; if avrdude was writing, the board holds part of the "
              "image: flash again (its bootloader is untouched)", file=sys.stderr)
        return 130
