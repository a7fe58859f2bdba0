"""The spec validator (navkit.spec) on broken specs, and `navkit gen`'s option rules:
each broken spec is a copy of protocol/navkit.toml with one edit, and the error must be
a SpecError naming the file and the line of the edit (no other exception)."""

import random
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from navkit.paths import build_dir, repo_root, spec_path
from navkit.spec import SpecError, load
from spec_helpers import edited_spec, line_of

NAVKIT = [sys.executable, "-m", "navkit"]


def _refused(path: Path, line: int, reason: str) -> SpecError:
    with pytest.raises(SpecError) as e:
        load(path)
    assert str(e.value).startswith(f"{path}:{line}: "), str(e.value)
    assert reason in str(e.value), str(e.value)
    assert (e.value.path, e.value.line) == (path, line)
    return e.value


@pytest.mark.parametrize("old,new,needle,after,reason", [
    # a TOML boolean is no integer (Python's bool is an int): not as an enum value ...
    ("values = { none = 0, turn = 1, modify = 3, stop = 5, heading_select",
     "values = { none = 0, turn = true, modify = 3, stop = 5, heading_select", "turn = true", None,
     "turn_mode.turn: values must be snake_case = integer, not boolean True"),
    # ... nor as a flag bit, nor as a message id
    ("values = { micro_online = 0,", "values = { micro_online = false,", "micro_online = false", None,
     "host_status.micro_online: values must be snake_case = integer, not boolean False"),
    ("id = 4\n", "id = true\n", "id = true", None, "micro_cfg_io.id: serial messages need an integer id, not True"),
    # a flag bit beyond the field's width (status is uint16) or above its max
    ("hdg_hold = 12,", "hdg_hold = 20,", '{ name = "status", word = 7', None,
     "micro_data.status: flag micro_status.hdg_hold is bit 20, beyond the 16 bits of uint16"),
    ("sonar3 = 7, compass = 8, battery = 9 }", "sonar3 = 7, compass = 8, battery = 10 }",
     '{ name = "sensor_enable"', None, "micro_cfg_io.sensor_enable: flag sensor_enable.battery (bit 10, 1024) "
                                       "exceeds max 1023"),
    # directions belong to links: a serial message between planner and host, an rcomm
    # message between host and micro
    ('direction = "micro_to_host"\nid = 17', 'direction = "planner_to_host"\nid = 17', 'direction = "planner_to_host"',
     None, "micro_data.direction: 'planner_to_host' is not a direction of link serial (serial-framed: "
           "host_to_micro or micro_to_host)"),
    ('name = "lisp_data"\nlink = "rcomm"\ndirection = "host_to_planner"',
     'name = "lisp_data"\nlink = "rcomm"\ndirection = "host_to_micro"', 'direction = "host_to_micro"', 'name = "lisp_data"',
     "lisp_data.direction: 'host_to_micro' is not a direction of link rcomm (unframed (shared-memory): "
     "planner_to_host or host_to_planner)"),
    ('name = "emotion"\nlink = "rcomm"\n', 'name = "emotion"\nlink = "rcomm"\nid = 9\n', "id = 9", None,
     "emotion.id: only serial messages have an id"),
    # entries of `field = [...]` that are not inline tables: the entry's own line
    ('  { name = "speed", word = 7,', '  "speed",\n  { name = "speed", word = 7,', '  "speed",', None,
     "micro_cmd.field 5: must be an inline table { name = ..., word = ..., ... }, not string 'speed'"),
    ('  { name = "talking", word = 7,', '  7,\n  { name = "talking", word = 7,', "  7,", 'name = "emotion"',
     "emotion.field 8: must be an inline table"),
    # names, types and references of the wrong kind are errors, not TypeErrors
    ('{ name = "accel", word = 6, type = "int16", units = "mm/s^2"',
     '{ name = 6, word = 6, type = "int16", units = "mm/s^2"', "{ name = 6,", None,
     "micro_cmd.field 4: field name must be a snake_case string, not 6"),
    ('{ name = "accel", word = 6, type = "int16"', '{ name = "accel", word = 6, type = ["int16"]',
     'type = ["int16"]', None, "micro_cmd.accel: type must be one of"),
    ('enum = "turn_mode", min = 0', 'enum = ["turn_mode"], min = 0', 'enum = ["turn_mode"]', None,
     "lisp_cmd.turn_mode: unknown enum ['turn_mode']"),
    ('name = "emotion"\nlink = "rcomm"', 'name = "emotion"\nlink = ["rcomm"]', 'link = ["rcomm"]', None,
     "emotion.link: unknown link ['rcomm']"),
    ('values = { ok = 0, not_implemented = 1, rejected = 2, planner_timeout = 3 }', 'values = [0, 1]',
     "values = [0, 1]", None, "nav_result.values: must be a table, not array [0, 1]"),
])
def test_broken_spec_is_refused_at_its_line(tmp_path, old, new, needle, after, reason):
    path = edited_spec(tmp_path, old, new)
    _refused(path, line_of(path, needle, after), reason)


def test_a_spec_without_the_planner_links_region_is_refused(tmp_path):
    """The codec and the rcomm client need the one unframed link's region: without it the
    spec is refused at [links], not an AttributeError at import."""
    text = spec_path().read_text()
    start = text.index("[links.rcomm]")
    end = text.index("\n[", start + 1)
    path = tmp_path / "navkit.toml"
    path.write_text(text[:start] + text[end + 1:])
    _refused(path, line_of(path, "[links.serial]"), "[links]: no unframed (shared-memory) link")


def test_a_field_list_that_is_no_array_names_its_line(tmp_path):
    text = spec_path().read_text()
    at = text.index("field = [", text.index('name = "emotion"'))  # the last message
    path = tmp_path / "navkit.toml"
    path.write_text(text[:at] + "field = 3\n")
    _refused(path, line_of(path, "field = 3"), "emotion.field: must be an array of tables, not integer 3")


def test_a_non_table_top_level_entry_names_its_line(tmp_path):
    path = edited_spec(tmp_path, "[flags.micro_status]", "[flags]\nbogus = 5\n\n[flags.micro_status]")
    _refused(path, line_of(path, "bogus = 5"), "flags bogus: must be a table, not integer 5")
    path = edited_spec(tmp_path, "[[seed_slip]]\nslip = \"RC6", "seed_slip_x = 1\n[[seed_slip]]\nslip = \"RC6")
    _refused(path, line_of(path, "seed_slip_x"), "unknown key 'seed_slip_x'")


def test_spec_error_of_an_unreadable_file_has_no_line(tmp_path):
    with pytest.raises(SpecError) as e:
        load(tmp_path / "missing.toml")
    assert e.value.line is None and str(e.value).startswith(f"{tmp_path / 'missing.toml'}: cannot read")


def test_toml_syntax_error_carries_its_line(tmp_path):
    path = edited_spec(tmp_path, "\nversion = 1\n", "\nversion = = 1\n")
    _refused(path, line_of(path, "version = = 1"), "TOML syntax")


def test_any_wrong_kind_of_value_is_a_spec_error(tmp_path):
    """Seeded: 150 copies of the spec, each with one `key = value` (top-level or inside
    an inline table) given a value of another TOML kind: each loads, or raises SpecError
    naming a line of the file; never another exception."""
    text = spec_path().read_text()
    spots = [m for m in re.finditer(r"(?:^|[{,]\s*)([a-z_]+) = (\"[^\"]*\"|-?\d[\w.]*|true|false)", text, re.M)]
    rng = random.Random(7)
    kinds = ["true", "[1, 2]", "{ a = 1 }", '"x"', "-1", "1.5", "70000"]
    n_lines = text.count("\n") + 1
    refused = 0
    for _ in range(150):
        m = rng.choice(spots)
        path = tmp_path / "navkit.toml"
        path.write_text(text[:m.start(2)] + rng.choice(kinds) + text[m.end(2):])
        try:
            load(path)
        except SpecError as e:
            assert 1 <= e.line <= n_lines, str(e)
            refused += 1
    assert refused > 100


def test_seed_slips_list_forever_and_dio_active():
    slips = " ".join(s["slip"] + " " + s["resolution"] for s in load(spec_path()).seed_slips)
    assert "200000000 " in slips and "2000000000" in slips
    assert "DIOcommand" in slips and "dio_active (word 14)" in slips


def test_a_broken_spec_fails_the_codec_import_with_a_spec_error(tmp_path):
    """navkit.protocol loads the spec at import: a broken spec raises SpecError naming
    file:line (what the CLI catches), not some other exception."""
    tree = tmp_path / "repo"
    shutil.copytree(repo_root() / "tools" / "navkit", tree / "tools" / "navkit",
                    ignore=shutil.ignore_patterns("__pycache__"))
    (tree / "protocol").mkdir()
    spec = tree / "protocol" / "navkit.toml"
    spec.write_text(spec_path().read_text().replace("hdg_hold = 12,", "hdg_hold = 20,"))
    code = ("from navkit.spec import SpecError\ntry:\n    import navkit.protocol\n"
            "except SpecError as e:\n    print('LINE', e.line, e)\n")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path,
                       env={"PYTHONPATH": str(tree / "tools"), "PATH": "/usr/bin:/bin"})
    assert r.returncode == 0 and "Traceback" not in r.stderr, r.stderr
    line = line_of(spec, '{ name = "status", word = 7')
    assert r.stdout.startswith(f"LINE {line} {spec}:{line}: micro_data.status: flag micro_status.hdg_hold"), r.stdout


@pytest.mark.parametrize("argv", [["proto", "decode", "a5ff"], ["gen", "--print-hash"]])
def test_the_cli_names_a_broken_specs_line_without_a_traceback(tmp_path, argv):
    """`navkit proto ...` (whose codec loads the spec at import) and `navkit gen` on a broken
    spec: one line `navkit CMD: FILE:LINE: ...` and exit 1."""
    tree = tmp_path / "repo"
    shutil.copytree(repo_root() / "tools" / "navkit", tree / "tools" / "navkit",
                    ignore=shutil.ignore_patterns("__pycache__"))
    (tree / "protocol").mkdir()
    spec = tree / "protocol" / "navkit.toml"
    spec.write_text(spec_path().read_text().replace("hdg_hold = 12,", "hdg_hold = 20,"))
    r = subprocess.run([sys.executable, "-m", "navkit", *argv], capture_output=True, text=True, cwd=tmp_path,
                       env={"PYTHONPATH": str(tree / "tools"), "PATH": "/usr/bin:/bin"})
    line = line_of(spec, '{ name = "status", word = 7')
    assert r.returncode == 1 and "Traceback" not in r.stderr, r.stderr
    assert r.stderr.startswith(f"navkit {argv[0]}: {spec}:{line}: micro_data.status:"), r.stderr


@pytest.mark.parametrize("args,only,others", [
    (["--print-hash", "--c-out", "OUT"], "--print-hash", "--c-out"),
    (["--print-hash", "--docs-out", "OUT/p.md"], "--print-hash", "--docs-out"),
    (["--check-docs", "DOCS", "--c-out", "OUT"], "--check-docs", "--c-out"),
    (["--check-docs", "DOCS", "--docs-out", "OUT/p.md", "--c-out", "OUT"], "--check-docs", "--c-out, --docs-out"),
    (["--print-hash", "--check-docs", "DOCS"], "--print-hash", "--check-docs"),
])
def test_gen_refuses_options_it_would_ignore(tmp_path, args, only, others):
    docs = repo_root() / "docs" / "protocol.md"
    argv = [str(tmp_path / "out") + a[3:] if a.startswith("OUT") else str(docs) if a == "DOCS" else a for a in args]
    r = subprocess.run(NAVKIT + ["gen"] + argv, capture_output=True, text=True)
    assert r.returncode == 2, r.stderr
    assert f"navkit gen: {only} cannot be combined with {others}:" in r.stderr
    assert r.stdout == "" and not (tmp_path / "out").exists()


def test_gen_options_alone_still_work():
    r = subprocess.run(NAVKIT + ["gen", "--print-hash"], capture_output=True, text=True)
    assert r.returncode == 0 and re.fullmatch(r"0x[0-9a-f]{8}\n", r.stdout), r.stderr
    r = subprocess.run(NAVKIT + ["gen", "--check-docs", str(repo_root() / "docs" / "protocol.md")],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr


# ------------------------------------------------------------ the rcomm region in the spec

@pytest.mark.parametrize("old,new,needle,reason", [
    ("planner_heartbeat = 12,", "planner_heartbeat = 13,", "planner_heartbeat = 13",
     "links.rcomm.header.planner_heartbeat: 13 must be a multiple of 4 in 0..60"),
    ("planner_heartbeat = 12,", "planner_heartbeat = 64,", "planner_heartbeat = 64",
     "links.rcomm.header.planner_heartbeat: 64 must be a multiple of 4 in 0..60"),
    ("host_heartbeat = 16 }", "host_heartbeat = 8 }", "host_heartbeat = 8",
     "links.rcomm.header.host_heartbeat: offset 8 is also spec_hash's"),
    (", host_heartbeat = 16 }", " }", "header = {", "links.rcomm.header.host_heartbeat: missing"),
    ("host_heartbeat = 16 }", "host_heartbeat = 16, pulse = 20 }", "pulse = 20",
     "links.rcomm.header: unknown header word 'pulse'"),
    ("slot_align = 64\n", "slot_align = 48\n", "slot_align = 48", "links.rcomm.slot_align: 48 is not a power of two"),
    ("header_bytes = 64\n", "header_bytes = 96\n", "header_bytes = 96",
     "links.rcomm.header_bytes: 96 is not a multiple of slot_align 64"),
    ("slot_words_at = 4\n", "slot_words_at = 6\n", "slot_words_at = 6", "links.rcomm.slot_words_at: 6 is not a multiple of 4"),
    ("magic = 0x43524B4E\n", "magic = true\n", "magic = true", "links.rcomm.magic: must be an integer in 1..4294967295"),
    ("magic = 0x43524B4E\n", "", "[links.rcomm]", "links.rcomm.magic: missing"),
    ('word_bits = 16\nframing = "serial"\n', 'word_bits = 16\nframing = "serial"\nslot_align = 64\n', "slot_align = 64",
     "[links.serial]: unknown key 'slot_align'"),
    ("[links.rcomm]", '[links.shm2]\ndoc = "x"\nword_bits = 32\n\n[links.rcomm]', "[links.rcomm]",
     "links.rcomm: a second unframed link (links.shm2 is one)"),
])
def test_broken_rcomm_layout_is_refused_at_its_line(tmp_path, old, new, needle, reason):
    path = edited_spec(tmp_path, old, new)
    _refused(path, line_of(path, needle), reason)


def test_rcomm_layout_enters_the_hash_and_its_doc_does_not(tmp_path):
    base = load(spec_path())
    assert base.rcomm.slots == {"lisp_cmd": 64, "lisp_data": 192, "emotion": 384} and base.rcomm.size == 448
    assert load(edited_spec(tmp_path, "magic = 0x43524B4E\n", "magic = 0x43524B4F\n")).hash != base.hash
    assert load(edited_spec(tmp_path, "slot_words_at = 4\n", "slot_words_at = 8\n")).hash != base.hash
    assert load(edited_spec(tmp_path, 'layout_doc = "The header', 'layout_doc = "Header')).hash == base.hash


def test_generated_header_and_docs_carry_the_specs_rcomm_layout():
    from navkit.paths import build_dir
    r = load(spec_path()).rcomm
    header = (build_dir() / "gen" / "navkit" / "navkit_proto.h").read_text()
    want = {"MAGIC": f"0x{r.magic:08X}UL", "VERSION": f"{r.version}u", "HEADER_BYTES": f"{r.header_bytes}u",
            "SLOT_ALIGN": f"{r.slot_align}u", "SLOT_WORDS_OFFSET": f"{r.slot_words_at}u", "SIZE": f"{r.size}u"}
    want |= {f"{w.upper()}_OFFSET": f"{off}u" for w, off in (r.header | r.slots).items()}
    got = dict(re.findall(r"^#define NAVKIT_RCOMM_(\w+) (\w+)", header, re.M))
    assert got == want
    docs = (repo_root() / "docs" / "protocol.md").read_text().split("## rcomm shared-memory layout")[1]
    assert "| 0 | `magic` `0x43524B4E` ('NKRC') |" in docs and "| 12 | `planner_heartbeat` |" in docs
    assert "| 192 | `lisp_data` slot: uint32 seqlock sequence, its words from +4 |" in docs


def test_docs_start_word_comes_from_the_spec(tmp_path):
    from navkit.gen import emit_docs
    docs = emit_docs(load(edited_spec(tmp_path, "start_word = 0xFFA5\n", "start_word = 0xFEA5\n")))
    assert "| 0 | *start* | uint16 | | | `0xFEA5` |" in docs and "FFA5" not in docs


def test_python_client_follows_the_specs_rcomm_layout(tmp_path):
    """navkit.rcomm built from a spec with another layout (magic, version, heartbeats
    swapped, words at +8 in 128-byte slots) opens a region laid out that way, reads the
    heartbeats and lisp_data where that spec puts them and writes lisp_cmd there."""
    tree = tmp_path / "repo"
    shutil.copytree(repo_root() / "tools" / "navkit", tree / "tools" / "navkit",
                    ignore=shutil.ignore_patterns("__pycache__"))
    (tree / "protocol").mkdir()
    text = spec_path().read_text()
    for old, new in (("magic = 0x43524B4E", "magic = 0x5A524B4E"), ("layout_version = 1", "layout_version = 7"),
                     ("planner_heartbeat = 12, host_heartbeat = 16", "planner_heartbeat = 16, host_heartbeat = 12"),
                     ("slot_align = 64", "slot_align = 128"), ("header_bytes = 64", "header_bytes = 128"),
                     ("slot_words_at = 4", "slot_words_at = 8")):
        assert text.count(old) == 1, old
        text = text.replace(old, new)
    (tree / "protocol" / "navkit.toml").write_text(text)
    code = r'''
import os, struct
from navkit import protocol, rcomm
r = protocol.SPEC.rcomm
assert (r.magic, r.version, r.slots["lisp_cmd"], r.slots["lisp_data"]) == (0x5A524B4E, 7, 128, 256), r
name = "/navkit-spec-test-%d" % os.getpid()
region = bytearray(r.size)
struct.pack_into("<IIIII", region, 0, r.magic, r.version, protocol.SPEC_HASH, 5, 900)  # 12: host, 16: planner
data = protocol.to_bytes("lisp_data", {"time_tag": 42, "heading": 1234})
struct.pack_into("<I", region, r.slots["lisp_data"], 2)
region[r.slots["lisp_data"] + 8:r.slots["lisp_data"] + 8 + len(data)] = data
with open("/dev/shm" + name, "wb") as f:
    f.write(region)
try:
    with rcomm.Client(name) as c:
        assert c.host_heartbeat() == 5 and c.planner_heartbeat() == 900
        d = c.read_data()
        assert (d["time_tag"], d["heading"]) == (42, 1234), d
        c.write_cmd({"time_tag": 9, "fwd_cmd": 1})
    raw = open("/dev/shm" + name, "rb").read()
    assert struct.unpack_from("<I", raw, 16)[0] == 901            # the planner heartbeat moved to 16
    assert struct.unpack_from("<II", raw, r.slots["lisp_cmd"]) == (2, 0)   # seq, then 4 bytes unused
    assert struct.unpack_from("<iii", raw, r.slots["lisp_cmd"] + 8) == (9, 0, 1)
finally:
    os.unlink("/dev/shm" + name)
print("OK")
'''
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path,
                       env={"PYTHONPATH": str(tree / "tools"), "PATH": "/usr/bin:/bin",
                            "NAVKIT_BUILD_DIR": str(build_dir())})   # the planner library it wraps
    assert r.returncode == 0 and r.stdout == "OK\n", r.stderr


# ------------------------------------------------------------ micro_data.last_reject codes

def test_last_reject_codes_come_from_the_spec():
    from navkit.paths import build_dir
    spec = load(spec_path())
    f = spec.messages["micro_data"].field("last_reject")
    bit = spec.enums[f.flags].values["range"]
    assert f.flags == "reject" and bit == 15
    header = (build_dir() / "gen" / "navkit" / "navkit_proto.h").read_text()
    assert f"#define NAVKIT_REJECT_RANGE (1u << {bit})" in header
    for name in ("link.h", "link.c"):  # the firmware uses the generated name, not its own
        text = (repo_root() / "firmware" / "core" / name).read_text()
        assert "0x8000" not in text and "LINK_REJECT_RANGE" not in text, name
    assert "NAVKIT_REJECT_RANGE | msg_type" in (repo_root() / "firmware" / "core" / "link.c").read_text()
    docs = (repo_root() / "docs" / "protocol.md").read_text()
    assert "### reject (flags)" in docs and f"| `range` | {bit} |" in docs


def test_docs_table_cells_escape_a_bar(tmp_path):
    from navkit.gen import emit_docs
    path = edited_spec(tmp_path, 'doc = "Watchdog stops since reset."', 'doc = "Stops | since reset."')
    assert "| Stops \\| since reset. |" in emit_docs(load(path))


# ------------------------------------------------------------ coded fields

@pytest.mark.parametrize("old,new,needle,reason", [
    ('enum = "fwd_cmd", max = 5', 'enum = "fwd_cmd", min = 6, max = 50', 'enum = "fwd_cmd", min = 6',
     "micro_cmd.fwd_cmd: no value of enum fwd_cmd lies within 6..50"),
    ('enum = "fwd_cmd", max = 5', 'enum = "fwd_cmd", max = 5, default = 2', "default = 2",
     "micro_cmd.fwd_cmd: default 2 is not a value of enum fwd_cmd"),
])
def test_coded_field_needs_codes_in_range(tmp_path, old, new, needle, reason):
    path = edited_spec(tmp_path, old, new)
    _refused(path, line_of(path, needle), reason)


def test_generated_check_refuses_non_codes_of_coded_fields_only():
    """The C check has a membership test for every coded field whose range holds a
    non-code (dg_control, a bit set, and mc_datalog_cmd, excite_mode and excite_wheels, all of whose ranges are codes,
    keep their range check); the codes the firmware receives and refuses (turn_cmd 13,
    15, 20, 23, 25) are codes, so they reach it."""
    from navkit.paths import build_dir
    spec = load(spec_path())
    cmd = spec.messages["micro_cmd"]
    assert [f.name for f in cmd.fields if f.coded] == ["msg_type", "fwd_cmd", "turn_cmd", "mc_datalog_cmd",
                                                         "excite_mode", "excite_wheels"]
    turn = cmd.field("turn_cmd")
    for code in (13, 15, 20, 23, 25):
        assert code in spec.enums["turn_cmd"].values.values() and turn.min <= code <= turn.max
    src = (build_dir() / "gen" / "navkit_proto.c").read_text()
    body = src.split("int navkit_micro_cmd_check(")[1].split("\n}\n")[0]
    assert "m->turn_cmd != 10u && m->turn_cmd != 13u" in body and "m->fwd_cmd != 3u && m->fwd_cmd != 5u" in body
    assert "m->dg_control > 3u" in body and "m->dg_control !=" not in body
    assert "m->mc_datalog_cmd > 6u" in body and "m->mc_datalog_cmd !=" not in body
    data = src.split("int navkit_lisp_data_check(")[1].split("\n}\n")[0]
    assert "m->nav_result != 0L && m->nav_result != 1L" in data


# ------------------------------------------------------------ constraints of a message

_LE = '{ le = ["servo_min", "servo_max"], doc = "Per servo'
_NZ = '{ nonzero = ["enc_left_sign", "enc_right_sign", "motor_left_sign", "motor_right_sign", "gyro_sign"], doc'


@pytest.mark.parametrize("old,new,needle,reason", [
    (_LE, _LE.replace('"servo_max"]', '"servo_maxx"]'), "servo_maxx",
     "micro_cfg_io.constraint 1: unknown field 'servo_maxx' of micro_cfg_io"),
    (_LE, _LE.replace('"servo_min", "servo_max"', '"servo_min"'), 'le = ["servo_min"]',
     "micro_cfg_io.constraint 1: le needs two field names [a, b], not ['servo_min']"),
    (_LE, _LE.replace('"servo_max"]', '"dio_direction"]'), '"dio_direction"]',
     "le binds servo_min (8 elements) and dio_direction (1): arrays of one count, or two scalars"),
    (_LE, _LE.replace('"servo_min", "servo_max"', '"servo_min", "servo_min"'), '"servo_min", "servo_min"',
     "le binds one field twice (servo_min)"),
    (_LE, _LE.replace('"servo_min", "servo_max"', '"servo_center", "servo_min"'), '"servo_center", "servo_min"',
     "the defaults break it: servo_center 1500 > servo_min -900"),
    (_LE, _LE.replace("{ le", "{ ge"), "{ ge", "micro_cfg_io.constraint 1"),
    (_LE, _LE.replace("{ le", '{ nonzero = ["servo_min"], le'), 'nonzero = ["servo_min"], le',
     "needs exactly one of nonzero, le"),
    (_LE, _LE.replace(', doc = "Per servo', ', docs = "Per servo'), "docs =", "micro_cfg_io.constraint 1"),
    ('"servo_max"], doc = "Per servo: the left travel limit is not right of the right one (element by element)." }',
     '"servo_max"] }', '"servo_max"] }', "micro_cfg_io.constraint 1: every constraint needs doc text"),
    (_LE, '"not a table",\n  ' + _LE, '"not a table",', "micro_cfg_io.constraint 1: must be an inline table"),
    (_NZ, _NZ.replace('"enc_left_sign"', '"wheel_diameter"'), '"wheel_diameter"',
     "micro_cfg_geometry.constraint 1: wheel_diameter's range 1000..60000 already excludes 0"),
    (_NZ, _NZ.replace('"enc_left_sign"', '"spec_hash"'), '"spec_hash"',
     "spec_hash is framing, not a field a constraint binds"),
    (_NZ, _NZ.replace('"enc_left_sign"', '"gyro_sign"'), '{ nonzero = ["gyro_sign"',
     "gyro_sign != 0 is stated twice"),
    (_NZ, _NZ.replace('["enc_left_sign", "enc_right_sign", "motor_left_sign", "motor_right_sign", "gyro_sign"]',
                      '"gyro_sign"'), '{ nonzero = "gyro_sign"',
     "nonzero needs a non-empty list of field names, not 'gyro_sign'"),
    ("default = -1, doc = \"Sign that turns", "default = 0, doc = \"Sign that turns", _NZ,
     "gyro_sign's default 0 breaks it (give gyro_sign a default)"),
])
def test_broken_constraint_is_refused_at_its_line(tmp_path, old, new, needle, reason):
    path = edited_spec(tmp_path, old, new)
    _refused(path, line_of(path, needle, "constraint = ["), reason)


def test_a_constraint_list_that_is_no_array_names_its_line(tmp_path):
    block = "constraint = [\n  " + _LE + ': the left travel limit is not right of the right one (element by element)." },\n]'
    path = edited_spec(tmp_path, block, 'constraint = "servo_min <= servo_max"')
    _refused(path, line_of(path, 'constraint = "servo_min'), "micro_cfg_io.constraint: must be an array")


def test_constraints_enter_the_hash_and_their_doc_does_not(tmp_path):
    base = load(spec_path())
    io = base.messages["micro_cfg_io"]
    assert [(c.kind, c.fields) for c in io.constraints] == [("le", ("servo_min", "servo_max"))]
    assert [c.fields[0] for c in base.messages["micro_cfg_geometry"].constraints] == [
        "enc_left_sign", "enc_right_sign", "motor_left_sign", "motor_right_sign", "gyro_sign"]
    assert load(edited_spec(tmp_path, _LE, _LE.replace('"servo_min", "servo_max"', '"servo_min", "servo_center"'))
                ).hash != base.hash
    assert load(edited_spec(tmp_path, _NZ, _NZ.replace(', "gyro_sign"]', "]"))).hash != base.hash
    assert load(edited_spec(tmp_path, 'doc = "Per servo: the left', 'doc = "Each servo: the left')).hash == base.hash


def test_generated_docs_list_the_constraints():
    from navkit.gen import emit_docs
    docs = emit_docs(load(spec_path()))
    assert "- `servo_min <= servo_max` (element by element): Per servo" in docs
    assert "- `gyro_sign != 0`: A sign is +1 or -1" in docs
