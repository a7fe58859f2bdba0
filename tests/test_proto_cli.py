"""`navkit proto`: the spec check on decoded frames, hex input, the encode rules
(zeros, spec_hash, --defaults), exact error values, --direction and --port/--baud on a
real pty. Most cases run the real command in-process (navkit.cli.main); the sniffing
test runs it as a process on a pseudo-terminal."""

import json
import os
import pty
import select
import signal
import subprocess
import sys
import termios
import time

import pytest

from navkit import protocol as p
from navkit.cli import main

NAVKIT = [sys.executable, "-m", "navkit"]


def _run(capsys, *args):
    """(exit status, stdout lines, stderr) of `navkit ARGS` run in-process."""
    try:
        rc = main(list(args))
    except SystemExit as e:     # argparse errors
        rc = e.code
    out, err = capsys.readouterr()
    return rc, out.splitlines(), err


# ------------------------------------------------------------ decode: the spec check

def test_decode_rejects_a_crc_good_frame_outside_the_spec(capsys, tmp_path):
    """A CRC-good frame with a field outside its range is reported as rejected (byte
    offset, message.field, value, range) and the exit status is 1, as the host drops it."""
    bad = p.encode_frame("micro_data", {"heading": 5000}, strict=False, time_tag=1)
    good = p.encode_frame("micro_data", {"heading": 3599}, time_tag=2)
    data = b"\x00" + bad + good
    rc, lines, _ = _run(capsys, "proto", "decode", data.hex())
    assert rc == 1
    assert lines[:2] == ["error: byte offset 0: 1 byte(s) rejected: garbage",
                         f"error: byte offset 1: {len(bad)} byte(s) rejected: micro_data.heading: 5000 is "
                         "outside 0..3599 (CRC good; the receiver's spec check drops it)"]
    assert json.loads(lines[2])["heading"] == 3599 and len(lines) == 3
    cap = tmp_path / "capture.bin"
    cap.write_bytes(bad)
    rc, lines, _ = _run(capsys, "proto", "decode", "--file", str(cap))
    assert rc == 1 and lines == [f"error: byte offset 0: {len(bad)} byte(s) rejected: micro_data.heading: "
                                 "5000 is outside 0..3599 (CRC good; the receiver's spec check drops it)"]
    # an array element is named with its index; a good frame alone gives 0
    cfg = p.defaults("micro_cfg_io")
    cfg["servo_center"] = [1500, 1500, 400] + [1500] * 5
    rc, lines, _ = _run(capsys, "proto", "decode", p.encode_frame("micro_cfg_io", cfg, strict=False).hex())
    assert rc == 1 and "micro_cfg_io.servo_center[2]: 400 is outside 500..2500" in lines[0]
    rc, lines, _ = _run(capsys, "proto", "decode", good.hex())
    assert rc == 0 and len(lines) == 1


def test_decode_and_encode_refuse_a_value_that_is_no_code(capsys):
    rc, _, err = _run(capsys, "proto", "encode", "micro_cmd", "fwd_cmd=2")
    assert rc == 2 and "micro_cmd.fwd_cmd: 2 is not a fwd_cmd code (none=0, start=1," in err
    rc, lines, _ = _run(capsys, "proto", "encode", "micro_cmd", "fwd_cmd=2", "--loose")
    assert rc == 0
    rc, lines, _ = _run(capsys, "proto", "decode", lines[0])
    assert rc == 1 and lines[0].startswith("error: byte offset 0: ")
    assert "rejected: micro_cmd.fwd_cmd: 2 is not a fwd_cmd code" in lines[0]


# ------------------------------------------------------------ decode: hex input

def test_decode_takes_spaced_colon_and_0x_hex(capsys):
    frame = p.encode_frame("micro_cmd", {"speed": 5}, time_tag=3)
    h = frame.hex()
    for args in ([" ".join(h[i:i + 2] for i in range(0, len(h), 2))],      # quoted, spaced
                 [h[i:i + 2] for i in range(0, len(h), 2)],                  # unquoted: one byte each
                 [h[:10], h[10:]],
                 [":".join(h[i:i + 2] for i in range(0, len(h), 2))],
                 ["0x" + h[:4], "0X" + h[4:]],
                 [" ".join("0x" + h[i:i + 2] for i in range(0, len(h), 2))]):
        rc, lines, err = _run(capsys, "proto", "decode", *args)
        assert rc == 0, (args, err)
        assert json.loads(lines[0])["speed"] == 5 and len(lines) == 1


@pytest.mark.parametrize("args,message", [
    (["zza5ff"], "HEX: character 1: 'z' is not a hex digit"),
    (["a5ff", "00g1"], "HEX: character 8: 'g' is not a hex digit"),
    (["a5ff 0"], "HEX: characters 6-6: odd number of hex digits (1) in '0'"),
    (["a5", "fff"], "HEX: characters 4-6: odd number of hex digits (3) in 'fff'"),
    (["a5ff" + "00" * 40 + "1"],
     "HEX: characters 1-85: odd number of hex digits (85) in 'a5ff00000000...000000000001'"),
    (["0x"], "HEX: character 1: 0x without hex digits"),
    (["a50xff"], "HEX: character 4: 'x' is not a hex digit"),
    ([" : "], "HEX: no hex digits"),
])
def test_decode_bad_hex_names_the_position(capsys, args, message):
    rc, lines, err = _run(capsys, "proto", "decode", *args)
    assert rc == 2 and lines == []
    assert err == f"navkit proto decode: {message}\n"


def test_decode_needs_exactly_one_source(capsys, tmp_path):
    rc, _, err = _run(capsys, "proto", "decode")
    assert rc == 2 and "give the bytes: HEX, --file capture.bin or --port PATH" in err
    rc, _, err = _run(capsys, "proto", "decode", "a5ff", "--file", str(tmp_path / "x.bin"))
    assert rc == 2 and "give one of HEX, --file or --port, not HEX and --file" in err


# ------------------------------------------------------------ decode: --direction

def test_decode_direction_names_the_other_directions_message(capsys):
    data = p.encode_frame("micro_data", {"heading": 10}).hex()
    cmd = p.encode_frame("micro_cmd").hex()
    rc, lines, _ = _run(capsys, "proto", "decode", "--direction", "to_micro", data + cmd)
    assert rc == 1
    assert lines[0] == (f"error: byte offset 0: {len(data) // 2} byte(s) rejected: wrong direction: "
                        "micro_data is a to-host message")
    assert json.loads(lines[1])["message"] == "micro_cmd"
    rc, lines, _ = _run(capsys, "proto", "decode", "--direction", "to_host", data + cmd)
    assert rc == 1 and json.loads(lines[0])["message"] == "micro_data"
    assert "wrong direction: micro_cmd is a to-micro message" in lines[1]
    rc, lines, _ = _run(capsys, "proto", "decode", "--direction", "to_host", data)
    assert rc == 0 and len(lines) == 1


# ------------------------------------------------------------ encode

def _encoded(lines):
    return p.decode_frame(bytes.fromhex(lines[0]))[1]


def test_encode_zeros_but_this_specs_hash(capsys):
    rc, lines, err = _run(capsys, "proto", "encode", "micro_data", "heading=900")
    assert rc == 0, err
    assert _encoded(lines) == {**{f.name: [0] * f.count if f.count > 1 else 0
                                  for f in p.SPEC.messages["micro_data"].fields},
                               "msg_type": 17, "heading": 900, "spec_hash": p.SPEC_HASH}
    rc, lines, _ = _run(capsys, "proto", "encode", "micro_data", "spec_hash=0x12345678")
    assert rc == 0 and _encoded(lines)["spec_hash"] == 0x12345678
    rc, lines, _ = _run(capsys, "proto", "encode", "micro_cmd", "speed=9")
    assert _encoded(lines) == {**{f.name: 0 for f in p.SPEC.messages["micro_cmd"].fields},
                               "msg_type": 1, "speed": 9}


def test_encode_config_needs_values_or_defaults(capsys):
    """A config message follows the same rule (unset = 0): its fields whose 0 is outside
    the range are named; --defaults fills every unset field with its spec default."""
    rc, lines, err = _run(capsys, "proto", "encode", "micro_cfg_geometry", "track_width=2500")
    m = p.SPEC.messages["micro_cfg_geometry"]
    need = [f"{f.name} ({f.min}..{f.max})" for f in m.fields
            if f.name not in ("track_width", "spec_hash", "msg_type") and not f.min <= 0 <= f.max]
    assert rc == 2 and lines == [] and need
    assert err == (f"navkit proto encode: micro_cfg_geometry: unset fields are 0, outside the spec range "
                   f"of {', '.join(need)}: give them, or --defaults for the spec defaults\n")
    rc, lines, err = _run(capsys, "proto", "encode", "micro_cfg_geometry", "track_width=2500", "--defaults")
    assert rc == 0, err
    assert _encoded(lines) == {**p.defaults("micro_cfg_geometry"), "track_width": 2500}
    assert _encoded(lines)["spec_hash"] == p.SPEC_HASH
    # --loose encodes the zeros (a test frame the receiver refuses)
    rc, lines, _ = _run(capsys, "proto", "encode", "micro_cfg_geometry", "--loose")
    assert rc == 0 and _encoded(lines)["wheel_diameter"] == 0
    rc, _, err = _run(capsys, "proto", "encode", "micro_cmd", "--defaults")
    assert rc == 2 and err == ("navkit proto encode: --defaults: micro_cmd has no spec defaults (messages "
                               "with defaults: micro_cfg_geometry, micro_cfg_motion, micro_cfg_io)\n")
    rc, out, _ = _run(capsys, "proto", "encode", "--help")
    assert "spec_hash" in " ".join(out) and "--defaults" in " ".join(out)


def test_encode_errors_name_the_exact_value(capsys):
    centers = "1500,1500,400,1500,1500,1500,1500,1500"
    rc, _, err = _run(capsys, "proto", "encode", "micro_cfg_io", f"servo_center={centers}", "--defaults")
    assert rc == 2 and err == "navkit proto encode: micro_cfg_io.servo_center[2]: 400 is outside 500..2500\n"
    rc, _, err = _run(capsys, "proto", "encode", "micro_cfg_io", "servo_center=1500,1500,15OO", "--defaults")
    assert rc == 2 and err == ("navkit proto encode: micro_cfg_io.servo_center[2]: '15OO' is not an integer "
                               "(e.g. 9 or 0x10)\n")
    rc, _, err = _run(capsys, "proto", "encode", "micro_cmd", "speed=fast")
    assert rc == 2 and "micro_cmd.speed: 'fast' is not an integer" in err
    rc, _, err = _run(capsys, "proto", "encode", "micro_cmd", "sped=4")
    names = ", ".join(f.name for f in p.SPEC.messages["micro_cmd"].fields)
    assert rc == 2 and err == f"navkit proto encode: micro_cmd: unknown field 'sped' (fields: {names})\n"
    rc, _, err = _run(capsys, "proto", "encode", "lisp_cmd")
    assert rc == 2 and "'lisp_cmd' is an rcomm (shared memory) message, not a serial frame" in err
    rc, lines, _ = _run(capsys, "proto", "encode", "micro_cmd", "--time-tag", "0x10")
    assert rc == 0 and _encoded(lines)["time_tag"] == 16
    rc, _, err = _run(capsys, "proto", "encode", "micro_cmd", "--time-tag", "0x1g")
    assert rc == 2 and "argument --time-tag: '0x1g' is not an integer" in err
    rc, _, err = _run(capsys, "proto", "encode", "micro_cmd", "--time-tag", "0x10000")
    assert rc == 2 and "micro_cmd.time_tag: 65536 is outside 0..65535" in err


# ------------------------------------------------------------ --port and --baud on a pty

def _ready(fd) -> bool:
    return bool(select.select([fd], [], [], 0)[0])


def _wait(what, cond, timeout=15.0):
    end = time.monotonic() + timeout
    while not cond():
        assert time.monotonic() < end, f"timed out waiting for {what}"
        time.sleep(0.02)


def test_decode_port_applies_the_baud_and_checks_frames():
    """The sniffer opens a real pty slave through pyserial at --baud 9600 (the slave's
    termios speed becomes B9600), decodes a good frame and rejects a CRC-good frame
    outside the spec; Ctrl-C prints the counters."""
    master, slave = pty.openpty()
    os.set_blocking(master, False)
    termios.tcsetattr(slave, termios.TCSANOW, termios.tcgetattr(slave)[:4] +
                      [termios.B38400, termios.B38400] + termios.tcgetattr(slave)[6:])
    proc = subprocess.Popen(NAVKIT + ["proto", "decode", "--port", os.ttyname(slave), "--baud", "9600"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    try:
        _wait("the port at 9600 baud", lambda: termios.tcgetattr(slave)[4:6] == [termios.B9600] * 2)
        good = p.encode_frame("micro_data", {"heading": 900}, time_tag=1)
        bad = p.encode_frame("micro_data", {"heading": 4000}, time_tag=2, strict=False)
        os.write(master, good + bad)
        fd, got = proc.stdout.fileno(), bytearray()
        os.set_blocking(fd, False)
        _wait("two lines", lambda: got.extend(os.read(fd, 4096) if _ready(fd) else b"") or got.count(b"\n") >= 2)
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=10)
    finally:
        proc.kill()
        os.close(master)
        os.close(slave)
    lines, err = (bytes(got) + out).decode().splitlines(), err.decode()
    assert proc.returncode == 1
    assert json.loads(lines[0])["heading"] == 900
    assert lines[1].startswith(f"error: byte offset {len(good)}: {len(bad)} byte(s) rejected: "
                               "micro_data.heading: 4000 is outside 0..3599")
    assert ("1 good frame(s); rejected: 0 bad CRC, 0 unknown type, 0 bad length, 0 schema mismatch, "
            "1 failed spec check; 0 byte(s) dropped") in err


@pytest.mark.parametrize("baud,message", [
    ("0", "argument --baud: must be a positive rate in bit/s (e.g. 115200), not 0"),
    ("-9600", "argument --baud: must be a positive rate in bit/s (e.g. 115200), not -9600"),
    ("fast", "argument --baud: 'fast' is not an integer"),
])
def test_decode_port_refuses_a_bad_baud(capsys, baud, message):
    master, slave = pty.openpty()
    try:
        rc, lines, err = _run(capsys, "proto", "decode", "--port", os.ttyname(slave), "--baud", baud)
    finally:
        os.close(master)
        os.close(slave)
    assert rc == 2 and lines == [] and message in err
