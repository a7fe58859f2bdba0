"""The protocol: spec validation, generated code, Python codec, golden vectors,
seeded properties of the parser, and the `navkit proto` tool."""

import os
import pty
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from navkit import protocol as p
from navkit import vectors
from navkit.paths import build_dir, repo_root, spec_path
from navkit.spec import SpecError, load

NAVKIT = [sys.executable, "-m", "navkit"]


# ------------------------------------------------------------ spec validation

def _broken_spec(tmp_path: Path, old: str, new: str) -> Path:
    text = spec_path().read_text()
    assert old in text, old
    path = tmp_path / "navkit.toml"
    path.write_text(text.replace(old, new, 1))
    return path


def _line_of(path: Path, needle: str) -> int:
    return next(i for i, ln in enumerate(path.read_text().splitlines(), 1) if needle in ln)


@pytest.mark.parametrize("old,new,needle,reason", [
    ('{ name = "speed", word = 7,', '{ name = "speed", word = 6,', '"speed", word = 6', "overlaps accel"),
    ('default = 300, doc = "Acceleration used', 'default = 9000, doc = "Acceleration used',
     "default = 9000", "default 9000 is outside 10..5000"),
    ('{ name = "fwd_cmd", word = 4,', '{ name = "fwd_cmd", wrod = 4,', "wrod = 4", "unknown key 'wrod'"),
    ('{ name = "dio_command", word = 22, type = "uint16"', '{ name = "dio_command", word = 22, type = "uint12"',
     "uint12", "type must be one of"),
    ('{ name = "time_tag", word = 1, type = "uint16", doc = "Sequence number of the command',
     '{ name = "time_tag", word = 3, type = "uint16", doc = "Sequence number of the command',
     "\"time_tag\", word = 3", "overlaps length word"),
    ('enum = "fwd_cmd", max = 5', 'enum = "fwd_kmd", max = 5', "fwd_kmd", "unknown enum 'fwd_kmd'"),
])
def test_spec_errors_name_file_line_and_key(tmp_path, old, new, needle, reason):
    path = _broken_spec(tmp_path, old, new)
    with pytest.raises(SpecError) as e:
        load(path)
    msg = str(e.value)
    assert msg.startswith(f"{path}:{_line_of(path, needle)}: "), msg
    assert reason in msg


def test_spec_hash_ignores_doc_text_but_not_layout(tmp_path):
    base = load(spec_path()).hash
    doc_only = _broken_spec(tmp_path, 'doc = "Acceleration used when', 'doc = "Accel used when')
    assert load(doc_only).hash == base
    moved = _broken_spec(tmp_path, "default = 300, doc", "default = 301, doc")
    assert load(moved).hash != base


def test_gen_reports_spec_errors_and_exit_status(tmp_path):
    path = _broken_spec(tmp_path, '{ name = "speed", word = 7,', '{ name = "speed", word = 6,')
    r = subprocess.run(NAVKIT + ["gen", "--spec", str(path), "--c-out", str(tmp_path / "out")],
                       capture_output=True, text=True)
    assert r.returncode == 1
    line = _line_of(path, '"speed", word = 6')
    assert f"{path}:{line}: micro_cmd.speed: word 6 overlaps accel" in r.stderr


# ------------------------------------------------------------ generated files

def test_generated_files_name_spec_and_carry_hash():
    gen = build_dir() / "gen"
    for f in (gen / "navkit" / "navkit_proto.h", gen / "navkit_proto.c"):
        text = f.read_text()
        assert "protocol/navkit.toml" in text.splitlines()[0]
        assert f"0x{p.SPEC_HASH:08x}" in text
    assert f"#define NAVKIT_SPEC_HASH 0x{p.SPEC_HASH:08x}UL" in (gen / "navkit" / "navkit_proto.h").read_text()


def test_docs_are_generated_from_the_current_spec():
    r = subprocess.run(NAVKIT + ["gen", "--check-docs", str(repo_root() / "docs" / "protocol.md")],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    text = (repo_root() / "docs" / "protocol.md").read_text()
    assert "| 8/9 | `distance` | int32 | mm |" in text
    assert "How the seed's slips were resolved" in text


def test_micro_cmd_keeps_the_seed_word_numbers():
    m = p.SPEC.messages["micro_cmd"]
    seed_words = {"time_tag": 1, "msg_type": 2, "fwd_cmd": 4, "accel": 6, "speed": 7, "distance": 8,
                  "turn_cmd": 10, "turn_accel": 12, "turn_rate": 13, "turn_distance": 14,
                  "dg_control": 16, "dg_set": 17, "x_set": 18, "y_set": 20, "dio_command": 22,
                  "rc0_param0": 23, "rc6_param0": 41, "rc6_param1": 42, "rc6_param2": 43,
                  "mc_datalog_cmd": 44, "rc7_param0": 45}
    for name, word in seed_words.items():
        assert m.field(name).byte_offset == 2 * word, name
    lisp = [f.name for f in p.SPEC.messages["lisp_cmd"].fields]
    assert lisp == ["time_tag", "msg_type", "fwd_cmd", "accel", "speed", "distance", "turn_mode",
                    "turn_accel", "turn_rate", "turn_distance", "rc_servo_num", "rc_param0",
                    "rc_param1", "rc_param2", "dio_active", "dio_command"]


# ------------------------------------------------------------ codec

def test_crc_check_value():
    assert p.crc16(b"123456789") == 0x6F91


def test_golden_frames_byte_for_byte():
    frames = vectors.read_frames()
    assert len(frames) >= 6 * len(p.SPEC.messages)
    for name, data, fields in frames:
        if p.SPEC.messages[name].framed:
            assert p.encode_frame(name, fields, strict=False) == data, name
            assert p.decode_frame(data) == (name, fields)
        else:
            assert p.to_bytes(name, fields) == data, name
            assert p.from_bytes(name, data) == fields
            assert p.unpack_words(name, p.pack_words(name, fields)) == fields


@pytest.mark.parametrize("chunk", [1, 2, 3, 7, 64, 100000])
def test_golden_streams_give_the_same_counters(chunk):
    for direction, want, stream in vectors.read_streams():
        parser = p.Parser(p.DIR_TO_MICRO if direction == "to_micro" else p.DIR_TO_HOST)
        for i in range(0, len(stream), chunk):
            parser.feed(stream[i:i + chunk])
        assert parser.stats == want, (direction, chunk)


def test_values_are_checked_against_the_spec():
    with pytest.raises(p.ProtocolError, match=r"micro_cmd.fwd_cmd: 7 is outside 0..5"):
        p.encode_frame("micro_cmd", {"fwd_cmd": 7})
    with pytest.raises(p.ProtocolError, match=r"unknown field 'speeed'"):
        p.encode_frame("micro_cmd", {"speeed": 7})
    with pytest.raises(p.ProtocolError, match=r"outside -32768..32767"):
        p.encode_frame("micro_cmd", {"speed": 40000}, strict=False)
    with pytest.raises(p.ProtocolError, match=r"needs a list of 8"):
        p.encode_frame("micro_data", {"adc": [1, 2]})
    assert p.encode_frame("micro_cmd", {"fwd_cmd": 7}, strict=False)


def _random_fields(rng, name):
    from navkit.spec import TYPES
    out = {}
    for f in p.SPEC.messages[name].fields:
        vals = [rng.randint(TYPES[f.type][2], TYPES[f.type][3]) for _ in range(f.count)]
        out[f.name] = vals if f.count > 1 else vals[0]
    if p.SPEC.messages[name].framed:
        out["msg_type"] = p.SPEC.messages[name].id
    return out


def test_property_round_trip_every_message(prop_seed, prop_count):
    rng = random.Random(prop_seed)
    for i in range(prop_count):
        for name, m in p.SPEC.messages.items():
            fields = _random_fields(rng, name)
            if m.framed:
                assert p.decode_frame(p.encode_frame(name, fields, strict=False)) == (name, fields), (prop_seed, i)
            else:
                assert p.from_bytes(name, p.to_bytes(name, fields)) == fields, (prop_seed, i)


def test_property_every_bit_flip_and_truncation_rejected(prop_seed):
    rng = random.Random(prop_seed)
    for m in p.SPEC.serial_messages():
        frame = p.encode_frame(m.name, _random_fields(rng, m.name), strict=False)
        for bit in range(8 * len(frame)):
            bad = bytearray(frame)
            bad[bit // 8] ^= 1 << (bit % 8)
            parser = p.Parser()
            events = parser.feed(bytes(bad))
            assert not any(isinstance(e, p.Frame) for e in events), (m.name, bit)
            events = parser.feed(frame) + parser.flush()
            good = [e for e in events if isinstance(e, p.Frame)]
            assert len(good) == 1 and good[0].raw == frame, (m.name, bit)
        for cut in range(len(frame)):
            parser = p.Parser()
            events = parser.feed(frame[:cut]) + parser.flush()
            assert not any(isinstance(e, p.Frame) for e in events)
            with pytest.raises(p.ProtocolError):
                p.decode_frame(frame[:cut])


def test_property_garbage_between_frames(prop_seed, prop_count):
    rng = random.Random(prop_seed)
    for case in range(max(1, prop_count // 10)):
        stream, sent = bytearray(), []
        for _ in range(20):
            stream += bytes(rng.choice((0xA5, 0xFF, rng.randrange(256))) for _ in range(rng.randrange(40)))
            m = rng.choice(p.SPEC.serial_messages())
            frame = p.encode_frame(m.name, _random_fields(rng, m.name), strict=False)
            sent.append(frame)
            stream += frame
        parser, events = p.Parser(), []
        at = 0
        while at < len(stream):
            n = rng.randrange(1, 80)
            events += parser.feed(bytes(stream[at:at + n]))
            at += n
        events += parser.flush()
        got = [e.raw for e in events if isinstance(e, p.Frame)]
        assert all(f in got for f in sent), (prop_seed, case)
        rejected = sum(e.length for e in events if isinstance(e, p.Reject))
        assert sum(map(len, got)) + rejected == len(stream)
        assert rejected == parser.stats["dropped_bytes"]


# ------------------------------------------------------------ the tool

def _navkit(*args, **kw):
    return subprocess.run(NAVKIT + list(args), capture_output=True, text=True, **kw)


def test_proto_encode_decode_round_trip():
    r = _navkit("proto", "encode", "micro_cmd", "fwd_cmd=1", "speed=200", "distance=-1500", "--time-tag", "9")
    assert r.returncode == 0, r.stderr
    frame = bytes.fromhex(r.stdout.strip())
    assert p.decode_frame(frame)[1]["distance"] == -1500
    r = _navkit("proto", "decode", "00 11 " + frame.hex())
    assert r.returncode == 1
    lines = r.stdout.splitlines()
    assert lines[0] == "error: byte offset 0: 2 byte(s) rejected: garbage"
    assert '"message": "micro_cmd", "offset": 2, "time_tag": 9' in lines[1]
    assert _navkit("proto", "decode", frame.hex()).returncode == 0


def test_proto_encode_errors_are_clear():
    r = _navkit("proto", "encode", "micro_cmd", "fwd_cmd=7")
    assert r.returncode == 2 and "micro_cmd.fwd_cmd: 7 is outside 0..5" in r.stderr
    r = _navkit("proto", "encode", "micro_kmd")
    assert r.returncode == 2 and "unknown message 'micro_kmd'" in r.stderr


def test_proto_decode_file_reports_offsets(tmp_path):
    good = p.encode_frame("micro_data", {"heading": 1800}, time_tag=4)
    bad = bytearray(good)
    bad[20] ^= 0x10
    cap = tmp_path / "capture.bin"
    cap.write_bytes(good + bytes(bad) + good[:10])
    r = _navkit("proto", "decode", "--file", str(cap))
    assert r.returncode == 1
    lines = r.stdout.splitlines()
    assert '"heading": 1800' in lines[0]
    assert lines[1] == f"error: byte offset {len(good)}: {len(good) + 10} byte(s) rejected: bad CRC"


def test_proto_decode_sniffs_a_serial_port():
    master, slave = pty.openpty()
    name = os.ttyname(slave)
    proc = subprocess.Popen(NAVKIT + ["proto", "decode", "--port", name], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    try:
        time.sleep(1.0)  # let pyserial open the port
        for tag in range(3):
            os.write(master, p.encode_frame("micro_data", {"status": 1}, time_tag=tag))
        os.write(master, b"\x00\x01\x02")
        time.sleep(1.0)
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=10)
    finally:
        proc.kill()
        os.close(master)
        os.close(slave)
    assert out.count('"message": "micro_data"') == 3
    assert "3 good frame(s), 1 rejected stretch(es)" in err
