"""navkit.tune.config: the tuned copy of a config folder changes only the tuned keys'
values and adds one provenance block per tuning kind; everything else is byte-identical."""

import difflib
import shutil

import pytest

from navkit.paths import repo_root
from navkit.tune.config import ConfigError, INI_NAME, motion_value, read_values, write_tuned

SRC = repo_root() / "config"
VALUES = {"wheel_kff": 123, "wheel_kp": 669, "wheel_ki": 445, "wheel_kd": 0}


def test_copy_changes_only_the_tuned_values(tmp_path):
    dst = tmp_path / "config"
    write_tuned(SRC, dst, VALUES, "wheel", ["navkit tune wheel, test", "previous: wheel_kp 400"])
    for f in SRC.iterdir():
        if f.is_file() and f.name != INI_NAME:
            assert (dst / f.name).read_bytes() == f.read_bytes(), f.name
    old = (SRC / INI_NAME).read_text().splitlines()
    new = (dst / INI_NAME).read_text().splitlines()
    removed = [ln[1:] for ln in difflib.ndiff(old, new) if ln.startswith("- ")]
    added = [ln[1:].strip() for ln in difflib.ndiff(old, new) if ln.startswith("+ ")]
    # each removed line is one tuned key's old line; the added ones are the new values and the block
    assert removed and all(r.split("=")[0].strip() in VALUES for r in removed)
    assert all(a.startswith(";") or a.split("=")[0].strip() in VALUES for a in added)
    for k, v in VALUES.items():
        assert motion_value(dst, k) == v
    assert "; --- navkit tune wheel: begin" in added and "; navkit tune wheel, test" in added
    # the block sits right under the section header
    i = new.index("[micro_cfg_motion]")
    assert new[i + 1] == "; --- navkit tune wheel: begin"
    # every other key keeps its value
    a, b = read_values(SRC), read_values(dst)
    assert {k: v[0] for k, v in a.items() if k[1] not in VALUES} == {k: v[0] for k, v in b.items()
                                                                     if k[1] not in VALUES}


def test_second_tuning_replaces_its_block_and_keeps_the_other(tmp_path):
    one, two, three = tmp_path / "a", tmp_path / "b", tmp_path / "c"
    write_tuned(SRC, one, VALUES, "wheel", ["first"])
    write_tuned(one, two, {"heading_kp": 1190}, "heading", ["heading one"])
    write_tuned(two, three, {**VALUES, "wheel_kp": 700}, "wheel", ["second"])
    text = (three / INI_NAME).read_text()
    assert text.count("navkit tune wheel: begin") == 1 and "; second" in text and "; first" not in text
    assert "; heading one" in text
    assert motion_value(three, "wheel_kp") == 700 and motion_value(three, "heading_kp") == 1190


def test_errors(tmp_path):
    with pytest.raises(ConfigError, match="no such file"):
        write_tuned(tmp_path / "nowhere", tmp_path / "out", VALUES, "wheel", [])
    with pytest.raises(ConfigError, match="is the input one"):
        write_tuned(SRC, SRC, VALUES, "wheel", [])
    bare = tmp_path / "bare"
    bare.mkdir()
    shutil.copy(SRC / INI_NAME, bare / INI_NAME)
    text = (bare / INI_NAME).read_text().replace("\nwheel_kd = 0\n", "\n")
    (bare / INI_NAME).write_text(text)
    with pytest.raises(ConfigError, match=r"\[micro_cfg_motion\] lacks wheel_kd"):
        write_tuned(bare, tmp_path / "out2", VALUES, "wheel", [])
