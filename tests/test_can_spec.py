"""The spec's CAN mapping ([can] in protocol/navkit.toml): what the model holds, that the
hash covers it, and that a bad mapping is refused naming file:line (each broken spec is a
copy of the spec with one edit)."""

import re

import pytest

from navkit.gen import can_frames, emit_c_header, emit_docs
from navkit.paths import spec_path
from navkit.spec import SpecError, load


def _spec(tmp_path, old: str, new: str):
    text = spec_path().read_text()
    assert text.count(old) == 1, old
    path = tmp_path / "navkit.toml"
    path.write_text(text.replace(old, new, 1))
    return path


def _line_of(path, needle: str) -> int:
    return next(i for i, ln in enumerate(path.read_text().splitlines(), 1) if needle in ln)


def test_every_serial_message_has_its_own_identifiers():
    spec = load(spec_path())
    c = spec.can
    assert list(c.ids) == [m.name for m in spec.serial_messages()]
    ids = [v for i in c.ids.values() for v in (i.id, i.fc_id)]
    assert len(set(ids)) == len(ids) and all(0 <= v < 0x800 for v in ids)
    assert c.by_id(c.ids["micro_data"].id).message == "micro_data" and c.by_id(c.ids["micro_data"].fc_id) is None
    # every frame of this spec is longer than one classic CAN frame: all are segmented
    assert all(can_frames(m.size) > 1 for m in spec.serial_messages())
    assert can_frames(7) == 1 and can_frames(8) == 2 and can_frames(13) == 2 and can_frames(14) == 3


def test_the_hash_covers_the_mapping_and_not_its_docs(tmp_path):
    base = load(spec_path()).hash
    moved = load(_spec(tmp_path, "micro_data = { id = 0x180,", "micro_data = { id = 0x182,"))
    assert moved.hash != base
    for old, new in (("n_cr_ms = 1000", "n_cr_ms = 1001"), ("padding = 0xCC", "padding = 0x55"),
                     ("fc_st_min = 0\n", "fc_st_min = 0xF1\n")):
        assert load(_spec(tmp_path, old, new)).hash != base, old
    reworded = load(_spec(tmp_path, 'transport_doc = "ISO 15765-2 on', 'transport_doc = "ISO-TP on'))
    assert reworded.hash == base


def test_the_mapping_reaches_the_c_header_and_the_docs():
    spec = load(spec_path())
    h = emit_c_header(spec)
    assert re.search(r"#define NAVKIT_CAN_ID_MICRO_CMD 0x110u", h)
    assert re.search(r"#define NAVKIT_CAN_FC_ID_MICRO_DATA 0x181u", h)
    assert f"#define NAVKIT_CAN_MAX_TO_MICRO_BYTES {spec.messages['micro_cmd'].size}u" in h
    assert f"#define NAVKIT_CAN_MAX_TO_HOST_BYTES {spec.messages['micro_data'].size}u" in h
    doc = emit_docs(spec)
    assert "## CAN" in doc and "| micro_data | micro to host | `0x180` | `0x181` | 152 | 1 first + 21 consecutive |" in doc


@pytest.mark.parametrize("old,new,needle,reason", [
    ("micro_cfg_io = { id = 0x124,", "micro_cfg_io = { id = 0x110,", "micro_cfg_io = { id = 0x110",
     "can.ids.micro_cfg_io.id: identifier 0x110 is already can.ids.micro_cmd.id"),
    ("fc_id = 0x181 }", "fc_id = 0x120 }", "fc_id = 0x120 }",
     "can.ids.micro_data.fc_id: identifier 0x120 is already can.ids.micro_cfg_geometry.id"),
    ("micro_data = { id = 0x180,", "micro_data = { id = 0x800,", "id = 0x800",
     "can.ids.micro_data.id: 2048 is not an 11-bit identifier (0..0x7FF)"),
    ("micro_data = { id = 0x180,", "micro_data = { id = -1,", "id = -1",
     "can.ids.micro_data.id: -1 is not an 11-bit identifier"),
    ("micro_data = { id = 0x180,", 'micro_data = { id = "0x180",', 'id = "0x180"',
     "can.ids.micro_data.id: '0x180' is not an 11-bit identifier"),
    ("micro_data = { id = 0x180, fc_id = 0x181 }", "micro_data = { id = 0x180, fc_id = 0x181, ext = 1 }", "ext = 1",
     "can.ids.micro_data: unknown key 'ext'"),
    ("micro_data = { id = 0x180, fc_id = 0x181 }",
     "micro_data = { id = 0x180, fc_id = 0x181 }\nlisp_cmd = { id = 0x200, fc_id = 0x201 }", "lisp_cmd = {",
     "can.ids.lisp_cmd: an rcomm message does not travel on CAN"),
    ("micro_data = { id = 0x180, fc_id = 0x181 }",
     "micro_data = { id = 0x180, fc_id = 0x181 }\nmicro_nothing = { id = 0x200, fc_id = 0x201 }", "micro_nothing",
     "can.ids.micro_nothing: not a message of the spec"),
    ("micro_cfg_motion = { id = 0x122, fc_id = 0x123 }\n", "", "[can.ids]",
     "can.ids: serial message micro_cfg_motion has no identifiers"),
    ("id_bits = 11", "id_bits = 29", "id_bits = 29", "can.id_bits: must be an integer in 11..11, not 29 "
                                                      "(only 11-bit identifiers are supported)"),
    ("padding = 0xCC", "padding = 256", "padding = 256", "can.padding: must be an integer in 0..255"),
    ("fc_st_min = 0\n", "fc_st_min = 0x80\n", "fc_st_min = 0x80", "can.fc_st_min: 0x80 is a reserved STmin"),
    ("n_bs_ms = 1000", "n_bs_ms = true", "n_bs_ms = true", "can.n_bs_ms: must be an integer in 1..60000, not True"),
    ("n_cr_ms = 1000", "n_cr_ms = 1000\nfd = true", "fd = true", "[can]: unknown key 'fd'"),
])
def test_a_bad_mapping_is_refused_at_its_line(tmp_path, old, new, needle, reason):
    path = _spec(tmp_path, old, new)
    with pytest.raises(SpecError) as e:
        load(path)
    assert str(e.value).startswith(f"{path}:{_line_of(path, needle)}: "), str(e.value)
    assert reason in str(e.value), str(e.value)
