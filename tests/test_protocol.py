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
from spec_helpers import edited_spec, line_of

NAVKIT = [sys.executable, "-m", "navkit"]


# ------------------------------------------------------------ spec validation

@pytest.mark.parametrize("old,new,needle,reason", [
    ('{ name = "speed", word = 7,', '{ name = "speed", word = 6,', '"speed", word = 6', "overlaps accel"),
    ('default = 300, doc = "Acceleration used', 'default = 9000, doc = "Acceleration used',
     "default = 9000", "default 9000 is outside 10..5000"),
    ('{ name = "fwd_cmd", word = 4,', '{ name = "fwd_cmd", wrod = 4,', "wrod = 4", "unknown key 'wrod'"),
    ('{ name = "dio_command", word = 22, type = "uint16"', '{ name = "dio_command", word = 22, type = "uint12"',
     "uint12", "type must be one of"),
    ('{ name = "time_tag", word = 1, type = "uint16", units = "count", doc = "Sequence number of the command',
     '{ name = "time_tag", word = 3, type = "uint16", units = "count", doc = "Sequence number of the command',
     "\"time_tag\", word = 3", "overlaps length word"),
    ('enum = "fwd_cmd", max = 5', 'enum = "fwd_kmd", max = 5', "fwd_kmd", "unknown enum 'fwd_kmd'"),
    # a field name used twice in one message: the second one is named
    ('{ name = "speed", word = 7,', '{ name = "accel", word = 7,', '"accel", word = 7', "field defined twice"),
    ('resolution = "Read as 41, 42, 43', 'resolutoin = "Read as 41, 42, 43', "resolutoin",
     "unknown key 'resolutoin'"),
    ('[links.serial]', '[framing.spi]\nstart_word = 1\n\n[links.serial]', "[framing.spi]", "unknown framing"),
    ('framing = "serial"', 'framing = "serail"', 'framing = "serail"', "unknown framing 'serail'"),
    ('id = 3\n', 'id = 2  # same as micro_cfg_geometry\n', "id = 2  # same", "id 2 is already the id of micro_cfg_geometry"),
    ('length_word = 3\n', '', "[framing.serial]", "framing.serial.length_word: missing"),
    ('max_frame_words = 128\n', '', "[framing.serial]", "framing.serial.max_frame_words: missing"),
    ('start_word = 0xFFA5\n', '', "[framing.serial]", "framing.serial.start_word: missing"),
    ('start_word = 0xFFA5\n', 'start_word = 0x1FFA5\n', "start_word = 0x1FFA5", "must be a 16-bit word"),
    ('hash_word = 4\n', 'hash_word = 6\n', "hash_word = 6", "must be 4, right after the header"),
    ('hash_doc = "Every', 'hash_doc = "" # "Every', "[framing.serial]", "framing.serial.hash_doc: missing"),
    ('version = 1\n', 'version = "x"\n', 'version = "x"', "must be a positive integer"),
    ('{ name = "speed", word = 7, type = "int16", units = "mm/s"', '{ name = "speed", word = 7, type = "int16", units = 5',
     '"speed", word = 7', "units must be a non-empty string"),
    ('{ name = "speed", word = 7, type = "int16", units = "mm/s", ', '{ name = "speed", word = 7, type = "int16", ',
     '"speed", word = 7', "units must be a non-empty string"),
    ('{ name = "speed", word = 7, type = "int16", units = "mm/s"', '{ name = "speed", word = 7, type = "int16", units = "mm/s", scale = true',
     '"speed", word = 7', "scale must be a positive number, not True"),
    ('{ name = "adc", word = 26, type = "uint16", count = 8', '{ name = "adc", word = 26, type = "uint16", count = true',
     '"adc", word = 26', "count must be a positive integer"),
    # the spec hash sits at the frozen words 4-5 as uint32
    ('{ name = "spec_hash", word = 4, type = "uint32", units = "1", doc = "The spec hash the firmware',
     '{ name = "spec_hash", word = 76, type = "uint32", units = "1", doc = "The spec hash the firmware',
     '"spec_hash", word = 76', "micro_data.spec_hash: must be one uint32 at word 4"),
    ('{ name = "rc0_param2", word = 25, type = "int16", units = "deg", scale = 0.1,',
     '{ name = "rc0_param2", word = 25, type = "int16", units = "deg", scale = 0.1, max = 1800,',
     '"rc0_param2", word = 25', "special values of servo_goto must lie within -32768..1800"),
])
def test_spec_errors_name_file_line_and_key(tmp_path, old, new, needle, reason):
    path = edited_spec(tmp_path, old, new, first=True)
    with pytest.raises(SpecError) as e:
        load(path)
    msg = str(e.value)
    assert msg.startswith(f"{path}:{line_of(path, needle)}: "), msg
    assert reason in msg


def test_seed_slip_needs_both_keys(tmp_path):
    path = edited_spec(tmp_path, 'resolution = "Read as 41, 42, 43: rc6_param0/1/2."\n', "", first=True)
    with pytest.raises(SpecError, match=r":\d+: seed_slip 2.resolution: missing"):
        load(path)


def test_spec_hash_ignores_doc_text_but_not_layout(tmp_path):
    base = load(spec_path()).hash
    doc_only = edited_spec(tmp_path, 'doc = "Acceleration used when', 'doc = "Accel used when', first=True)
    assert load(doc_only).hash == base
    moved = edited_spec(tmp_path, "default = 300, doc", "default = 301, doc", first=True)
    assert load(moved).hash != base


def test_gen_reports_spec_errors_and_exit_status(tmp_path):
    path = edited_spec(tmp_path, '{ name = "speed", word = 7,', '{ name = "speed", word = 6,', first=True)
    r = subprocess.run(NAVKIT + ["gen", "--spec", str(path), "--c-out", str(tmp_path / "out")],
                       capture_output=True, text=True)
    assert r.returncode == 1
    line = line_of(path, '"speed", word = 6')
    assert f"{path}:{line}: micro_cmd.speed: word 6 overlaps accel" in r.stderr
    # a missing framing key is a SpecError too (no KeyError traceback)
    path = edited_spec(tmp_path, "length_word = 3\n", "", first=True)
    r = subprocess.run(NAVKIT + ["gen", "--spec", str(path), "--print-hash"], capture_output=True, text=True)
    assert r.returncode == 1 and "Traceback" not in r.stderr
    assert f"{path}:{line_of(path, '[framing.serial]')}: framing.serial.length_word: missing" in r.stderr


def test_gen_names_the_spec_it_was_given(tmp_path):
    spec = tmp_path / "other.toml"
    spec.write_text(spec_path().read_text())
    r = subprocess.run(NAVKIT + ["gen", "--spec", str(spec), "--c-out", str(tmp_path / "out"),
                                 "--docs-out", str(tmp_path / "protocol.md")], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    header = (tmp_path / "out" / "navkit" / "navkit_proto.h").read_text().splitlines()[0]
    assert f"from {spec.resolve()}." in header and "protocol/navkit.toml" not in header
    assert f"Spec: `{spec.resolve()}`" in (tmp_path / "protocol.md").read_text()


def test_cmake_regenerates_on_every_module_the_generator_runs():
    """protocol/CMakeLists.txt lists every navkit module `python -m navkit gen` imports."""
    code = ("import runpy, sys\nsys.argv = ['navkit', 'gen', '--print-hash']\n"
            "try:\n    runpy.run_module('navkit', run_name='__main__')\nexcept SystemExit:\n    pass\n"
            "import navkit\nprint('MODULES', *sorted({m.__file__ for n, m in sys.modules.items()\n"
            "      if (n == 'navkit' or n.startswith('navkit.')) and getattr(m, '__file__', None)}))")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=repo_root())
    assert r.returncode == 0, r.stderr
    # `python -m navkit` runs __main__.py as the __main__ module (not navkit.__main__)
    used = {Path(f).name for f in r.stdout.split("MODULES", 1)[1].split()} | {"__main__.py"}
    assert {"__init__.py", "__main__.py", "cli.py", "paths.py", "spec.py", "gen.py"} <= used
    cmake = (repo_root() / "protocol" / "CMakeLists.txt").read_text()
    for name in used:
        assert f"tools/navkit/{name}" in cmake, name


# ------------------------------------------------------------ generated files

def test_generated_files_name_spec_and_carry_hash():
    gen = build_dir() / "gen"
    for f in (gen / "navkit" / "navkit_proto.h", gen / "navkit_proto.c", gen / "test_vectors.c"):
        text = f.read_text()
        assert "protocol/navkit.toml" in text.splitlines()[0], f
        assert f"0x{p.SPEC_HASH:08x}" in text, f
    assert f"#define NAVKIT_SPEC_HASH 0x{p.SPEC_HASH:08x}UL" in (gen / "navkit" / "navkit_proto.h").read_text()


def test_docs_are_generated_from_the_current_spec():
    r = subprocess.run(NAVKIT + ["gen", "--check-docs", str(repo_root() / "docs" / "protocol.md")],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    text = (repo_root() / "docs" / "protocol.md").read_text()
    assert "| 8/9 | `distance` | int32 | mm |" in text
    assert "How the seed's slips were resolved" in text
    assert "deliberately ignores doc text" in text.split("## Links")[0]
    assert "words 0-5 of these frames are frozen across spec versions" in text
    micro_cmd = text.split("## micro_cmd")[1].split("\n## ")[0]
    for w in (5, 11):
        assert f"| {w} | *spare* | uint16 | | | spare (sent as 0) |" in micro_cmd
    assert "special values: 9999 = goto_flag" in micro_cmd
    assert "| 4/5 | `spec_hash` | uint32 | 1 |" in text.split("## micro_data")[1]


def test_generated_comments_show_units():
    """(The loader requires units on every field: test_spec_errors_name_file_line_and_key.)"""
    header = (build_dir() / "gen" / "navkit" / "navkit_proto.h").read_text()
    assert "uint16_t rx_good; /* word 53: [count]" in header
    assert "uint16_t status; /* word 7: [bits]" in header


def test_spec_hash_is_at_the_frozen_words_of_every_frame_carrying_it():
    hashed = [m for m in p.SPEC.serial_messages() if any(f.name == "spec_hash" for f in m.fields)]
    assert {m.name for m in hashed} == {"micro_data", "micro_cfg_geometry", "micro_cfg_motion", "micro_cfg_io"}
    for m in hashed:
        assert m.field("spec_hash").byte_offset == 8 and m.field("spec_hash").type == "uint32"
        assert p.decode_frame(p.encode_frame(m.name, p.defaults(m.name), strict=False))[1]["spec_hash"] == p.SPEC_HASH
        assert p.encode_frame(m.name, p.defaults(m.name), strict=False)[8:12] == p.SPEC_HASH.to_bytes(4, "little")


def test_micro_cmd_keeps_the_seed_word_numbers():
    m = p.SPEC.messages["micro_cmd"]
    seed_words = {"time_tag": 1, "msg_type": 2, "fwd_cmd": 4, "accel": 6, "speed": 7, "distance": 8,
                  "turn_cmd": 10, "turn_accel": 12, "turn_rate": 13, "turn_distance": 14,
                  "dg_control": 16, "dg_set": 17, "x_set": 18, "y_set": 20, "dio_command": 22,
                  "rc0_param0": 23, "rc6_param0": 41, "rc6_param1": 42, "rc6_param2": 43,
                  "mc_datalog_cmd": 44, "rc7_param0": 45}
    for name, word in seed_words.items():
        assert m.field(name).byte_offset == 2 * word, name
    # the seed's 16 lisp_cmd words keep their places; additions come after them
    lisp = [f.name for f in p.SPEC.messages["lisp_cmd"].fields]
    assert lisp[:16] == ["time_tag", "msg_type", "fwd_cmd", "accel", "speed", "distance", "turn_mode",
                         "turn_accel", "turn_rate", "turn_distance", "rc_servo_num", "rc_param0",
                         "rc_param1", "rc_param2", "dio_active", "dio_command"]
    assert [f.word for f in p.SPEC.messages["lisp_cmd"].fields] == list(range(len(lisp)))
    assert all(f.word > 47 for f in m.fields if f.name.startswith("excite_"))


# ------------------------------------------------------------ codec

def test_crc_check_value():
    assert p.crc16(b"123456789") == 0x6F91


def test_golden_frames_byte_for_byte():
    """Encode/decode, and the same defaults and range-check verdicts the C test checks
    (test_proto_vectors, generated from the same file)."""
    frames = vectors.read_frames()
    assert len(frames) >= 6 * len(p.SPEC.messages)
    cases = {case for _, case, _, _, _ in frames}
    assert cases == {"defaults", "min", "max", "random", "below", "above", "nonmember", "constraint"}
    assert sum(v != "ok" for _, _, v, _, _ in frames) >= 20
    for name, case, verdict, data, fields in frames:
        if p.SPEC.messages[name].framed:
            assert p.encode_frame(name, fields, strict=False) == data, name
            assert p.decode_frame(data) == (name, fields)
        else:
            assert p.to_bytes(name, fields) == data, name
            assert p.from_bytes(name, data) == fields
            assert p.unpack_words(name, p.pack_words(name, fields)) == fields
        if case == "defaults":
            assert p.defaults(name) == fields, name
        if verdict == "ok":
            p.check(name, fields)
        else:
            with pytest.raises(p.ProtocolError) as e:
                p.check(name, fields)
            assert e.value.field == verdict, (name, case)
            if p.SPEC.messages[name].framed:  # strict encoding refuses what C encodes unchecked
                with pytest.raises(p.ProtocolError):
                    p.encode_frame(name, fields)


@pytest.mark.parametrize("chunk", [1, 2, 3, 7, 64, 100000])
def test_golden_streams_give_the_same_counters(chunk):
    streams = vectors.read_streams()
    assert sum(want["schema_mismatch"] for _, want, _, _ in streams) >= 4
    for direction, want, foreign, stream in streams:
        parser = p.Parser(p.DIR_TO_MICRO if direction == "to_micro" else p.DIR_TO_HOST)
        for i in range(0, len(stream), chunk):
            parser.feed(stream[i:i + chunk])
        assert parser.stats == want, (direction, chunk)
        assert parser.foreign_hash == foreign, (direction, chunk)


def test_schema_mismatch_is_detected_across_lengths():
    """A frame of another spec version (hash-carrying type, other length, good CRC) is a
    schema mismatch with its hash and offset, consumed whole; the frame after is found."""
    lo, hi = p.SPEC.framing["hash_word"] + 3, p.SPEC.framing["max_frame_words"]
    good = p.encode_frame("micro_data", {"heading": 900}, time_tag=2)
    for words in (lo, 40, p.SPEC.messages["micro_data"].words - 1, p.SPEC.messages["micro_data"].words + 1, hi):
        foreign = p.foreign_frame("micro_data", words, 0x12345678, time_tag=1)
        parser = p.Parser(p.DIR_TO_HOST)
        events = parser.feed(b"\x00" * 3 + foreign + good)
        assert [type(e).__name__ for e in events] == ["Reject", "Reject", "Frame"], words
        assert events[1].offset == 3 and events[1].length == 2 * words
        assert events[1].reason == f"schema mismatch: spec hash 0x12345678 (this spec 0x{p.SPEC_HASH:08x})"
        assert parser.foreign_hash == 0x12345678 and parser.foreign_offset == 3
        assert parser.stats["schema_mismatch"] == 1 and parser.stats["bad_length"] == 0
        assert events[2].offset == 3 + 2 * words
    # a bad CRC, a type without spec_hash, or a length beyond the bounds: bad length as before
    bad = bytearray(p.foreign_frame("micro_cfg_io", 30, 7))
    bad[-1] ^= 1
    parser = p.Parser(p.DIR_TO_MICRO)
    parser.feed(bytes(bad) + bytes(300))
    assert parser.stats["bad_length"] == 1 and parser.stats["schema_mismatch"] == 0
    assert parser.foreign_hash is None
    with pytest.raises(p.ProtocolError, match="carries no spec_hash"):
        p.foreign_frame("micro_cmd", 30, 7)
    with pytest.raises(p.ProtocolError, match=f"outside {lo}..{hi}"):
        p.foreign_frame("micro_data", hi + 1, 7)


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
    with pytest.raises(p.ProtocolError, match=r"micro_cmd.msg_type: is always 1, not 3"):
        p.encode_frame("micro_cmd", {"msg_type": 3})
    assert p.encode_frame("micro_cmd", {"msg_type": 1, "time_tag": 4}, time_tag=5)[2:4] == b"\x05\x00"


def test_errors_name_the_array_element_and_the_valid_fields():
    centers = [1500, 1500, 400, 1500, 1500, 1500, 1500, 1500]
    with pytest.raises(p.ProtocolError) as e:
        p.check("micro_cfg_io", {"servo_center": centers})
    assert str(e.value) == "micro_cfg_io.servo_center[2]: 400 is outside 500..2500"
    assert e.value.field == "servo_center"
    with pytest.raises(p.ProtocolError, match=r"servo_min\[7\]: 'x' is not an integer"):
        p.check("micro_cfg_io", {"servo_min": [0] * 7 + ["x"]})
    with pytest.raises(p.ProtocolError) as e:
        p.check("micro_cmd", {"speeed": 7})
    names = ", ".join(f.name for f in p.SPEC.messages["micro_cmd"].fields)
    assert str(e.value) == f"micro_cmd: unknown field 'speeed' (fields: {names})"


def test_coded_fields_take_only_their_enum_codes():
    """A field with `enum` (units other than "bits") takes only its codes, range first;
    a bit-mask field (dg_control, units "bits") any value in its range."""
    coded = [(m, f) for m in p.SPEC.messages.values() for f in m.fields if f.coded]
    assert {f"{m.name}.{f.name}" for m, f in coded} >= {"micro_cmd.fwd_cmd", "micro_cmd.turn_cmd",
                                                        "lisp_cmd.fwd_cmd", "lisp_cmd.turn_mode"}
    for m, f in coded:
        codes = set(p.SPEC.enums[f.enum].values.values())
        for v in range(f.min, min(f.max, f.min + 300) + 1):
            fields = {**p.defaults(m.name), f.name: v}
            if v in codes:
                p.check(m.name, fields)
            else:
                with pytest.raises(p.ProtocolError, match=rf"^{m.name}.{f.name}: {v} is not a {f.enum} code \("):
                    p.check(m.name, fields)
    with pytest.raises(p.ProtocolError) as e:
        p.check("micro_cmd", {"fwd_cmd": 2})
    assert str(e.value) == "micro_cmd.fwd_cmd: 2 is not a fwd_cmd code (none=0, start=1, modify=3, stop=5, " \
                           "contest_hallway=100, contest_start_circle=101, explore=105)"
    assert e.value.field == "fwd_cmd"
    with pytest.raises(p.ProtocolError, match=r"fwd_cmd: 7 is outside 0..5"):   # the range comes first
        p.check("micro_cmd", {"fwd_cmd": 7})
    for v in (13, 15, 20, 23, 25):    # reserved by the seed: valid codes, the firmware refuses and counts them
        p.check("micro_cmd", {"turn_cmd": v})
    with pytest.raises(p.ProtocolError, match="lisp_cmd.fwd_cmd: 50 is not a fwd_cmd code"):
        p.check("lisp_cmd", {"fwd_cmd": 50})
    assert not p.SPEC.messages["micro_cmd"].field("dg_control").coded
    for v in range(4):
        p.check("micro_cmd", {"dg_control": v})
    assert p.decode_frame(p.encode_frame("micro_cmd", {"turn_cmd": 2}, strict=False))[1]["turn_cmd"] == 2
    with pytest.raises(p.ProtocolError, match="micro_cmd.turn_cmd: 2 is not a turn_cmd code"):
        p.encode_frame("micro_cmd", {"turn_cmd": 2})


def test_decode_frame_reasons_follow_the_c_order():
    """Too short is a bad length even with the start word (C: NAVKIT_ERR_LENGTH); a known
    type of the other direction is named as such."""
    for short in (b"", b"\xa5\xff\x00", p.encode_frame("micro_cmd")[:9]):
        with pytest.raises(p.ProtocolError, match=rf"^bad length: {len(short)} byte\(s\), a frame has at least 10$"):
            p.decode_frame(short)
    with pytest.raises(p.ProtocolError, match="^no start word$"):
        p.decode_frame(b"\xa6" + p.encode_frame("micro_cmd")[1:])
    data = p.encode_frame("micro_data")
    with pytest.raises(p.ProtocolError, match="^wrong direction: micro_data is a to-host message$"):
        p.decode_frame(data, p.DIR_TO_MICRO)
    assert p.decode_frame(data, p.DIR_TO_HOST)[0] == "micro_data"
    with pytest.raises(p.ProtocolError, match=r"^bad length: micro_data has \d+ words"):
        p.decode_frame(data + b"\x00\x00")
    unknown = bytearray(data)
    unknown[4] = 99
    with pytest.raises(p.ProtocolError, match="^unknown message type 99$"):
        p.decode_frame(bytes(unknown))
    parser = p.Parser(p.DIR_TO_MICRO)
    events = parser.feed(data) + parser.flush()
    assert parser.stats["unknown_type"] == 1
    assert events[0].reason == "wrong direction: micro_data is a to-host message"
    parser = p.Parser()
    events = parser.feed(bytes(unknown)) + parser.flush()
    assert events[0].reason == "unknown message type 99", "the parser names the type as decode_frame does"


def test_decoded_fields_are_in_spec_order():
    for m in p.SPEC.serial_messages():
        fields = p.decode_frame(p.encode_frame(m.name, p.defaults(m.name), strict=False))[1]
        assert list(fields) == [f.name for f in m.fields], m.name
        assert list(fields)[0] == "time_tag"
    for m in p.SPEC.rcomm_messages():
        assert list(p.from_bytes(m.name, p.to_bytes(m.name))) == [f.name for f in m.fields], m.name


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
            # a flip in the length word of a hash-carrying type may hold the parser until
            # that many words have arrived (schema-mismatch rule): zeros follow the frame
            events = parser.feed(frame + bytes(2 * p.SPEC.framing["max_frame_words"])) + parser.flush()
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
    r = _navkit("proto", "encode", "micro_cmd", "msg_type=3")
    assert r.returncode == 2 and "micro_cmd.msg_type: is always 1, not 3" in r.stderr
    r = _navkit("proto", "encode", "micro_cmd", "time_tag=5", "--time-tag", "9")
    assert r.returncode == 2 and "time_tag given twice" in r.stderr
    r = _navkit("proto", "encode", "micro_cmd", "speed=1", "speed=2")
    assert r.returncode == 2 and "speed: given twice" in r.stderr
    frame = p.encode_frame("micro_cmd")
    for extra in ([frame.hex()], ["--file", "/dev/null"]):
        r = _navkit("proto", "decode", *extra, "--baud", "9600")
        assert r.returncode == 2 and "--baud applies only to --port" in r.stderr, extra


def test_proto_decode_names_a_foreign_spec_hash():
    foreign = p.foreign_frame("micro_data", 70, 0xCAFEF00D)
    r = _navkit("proto", "decode", (foreign + p.encode_frame("micro_data")).hex())
    assert r.returncode == 1
    lines = r.stdout.splitlines()
    assert lines[0] == (f"error: byte offset 0: 140 byte(s) rejected: schema mismatch: spec hash 0xcafef00d "
                        f"(this spec 0x{p.SPEC_HASH:08x})")
    assert '"message": "micro_data", "offset": 140' in lines[1]


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
        os.write(master, b"\x00\x01\x02" + p.foreign_frame("micro_data", 20, 0xABCD0123))
        os.write(master, p.encode_frame("micro_data", {"status": 1}, time_tag=3)[:-1] + b"\x00")
        time.sleep(1.0)
        # the rejected stretches are out before Ctrl-C: the parser has resynced after them
        os.set_blocking(proc.stdout.fileno(), False)
        early = proc.stdout.read() or ""
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=10)
        out = early + out
    finally:
        proc.kill()
        os.close(master)
        os.close(slave)
    assert out.count('"message": "micro_data"') == 3
    assert "error: byte offset 0" not in out
    assert "3 byte(s) rejected: garbage" in early
    assert "40 byte(s) rejected: schema mismatch: spec hash 0xabcd0123" in early
    assert "rejected: bad CRC" in early
    assert ("3 good frame(s); rejected: 1 bad CRC, 0 unknown type, 0 bad length, 1 schema mismatch, "
            "0 failed spec check; "
            f"{3 + 40 + p.SPEC.messages['micro_data'].size} byte(s) dropped; last foreign spec hash 0xabcd0123") in err


# ------------------------------------------------------------ benchmark

def test_bench_proto_runs_and_prints_figures():
    r = _navkit("bench-proto", "--frames", "50")
    assert r.returncode == 0, r.stderr
    lines = r.stdout.splitlines()
    assert len(lines) == 6, r.stdout
    for lang, line in zip(["py"] * 3 + ["c"] * 3, lines):
        parts = line.split()
        assert parts[0] == lang and "frames/s" in parts
        assert float(parts[parts.index("frames/s") - 1]) > 0, line
    r = _navkit("bench-proto", "--frames", "0")
    assert r.returncode == 2 and "must be at least 1" in r.stderr and "Traceback" not in r.stderr


def test_check_applies_the_specs_constraints_after_the_ranges():
    """protocol.check refuses what the spec's [[message]] constraints refuse (the C
    navkit_<msg>_check does the same: tests/vectors `constraint` cases), naming the
    field and the element, and only once every range holds."""
    geo = p.defaults("micro_cfg_geometry")
    p.check("micro_cfg_geometry", geo | {"gyro_sign": 1})
    with pytest.raises(p.ProtocolError, match=r"^micro_cfg_geometry\.motor_left_sign: 0 breaks the constraint "
                                              r"motor_left_sign != 0$") as e:
        p.check("micro_cfg_geometry", geo | {"motor_left_sign": 0})
    assert e.value.field == "motor_left_sign"
    with pytest.raises(p.ProtocolError, match=r"enc_right_sign: 0 \(unset\) breaks"):
        p.check("micro_cfg_geometry", {k: v for k, v in geo.items() if k != "enc_right_sign"})
    with pytest.raises(p.ProtocolError, match="is outside -1..1"):  # the range first
        p.check("micro_cfg_geometry", geo | {"motor_left_sign": 0, "gyro_sign": 2})
    io = p.defaults("micro_cfg_io")
    io["servo_min"][5] = 1000
    with pytest.raises(p.ProtocolError, match=r"^micro_cfg_io\.servo_max\[5\]: 900 is below servo_min\[5\] 1000 "
                                              r"\(constraint servo_min <= servo_max\)$") as e:
        p.check("micro_cfg_io", io)
    assert e.value.field == "servo_max"
    with pytest.raises(p.ProtocolError):
        p.encode_frame("micro_cfg_io", io)
    assert p.decode_frame(p.encode_frame("micro_cfg_io", io, strict=False))[1]["servo_min"][5] == 1000
    io["servo_max"][5] = 1000  # equal limits hold
    p.check("micro_cfg_io", io)
