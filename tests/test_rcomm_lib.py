"""libnavkit_rcomm.so, the planner library (planner/include/navkit_rcomm.h), driven from
Python ctypes as any language with a C FFI would: its exported symbols are the header's
functions, its layout is the spec's, it drives a real navkit-host in lockstep, and it
refuses bad names, links and regions cut short with one line saying why."""

import ctypes
import os
import re
import struct
import subprocess

import pytest

from navkit import protocol, rcomm
from navkit.paths import repo_root
from host_helpers import Micro, rcomm_region

pytestmark = pytest.mark.timeout(60)

HEADER = repo_root() / "planner" / "include" / "navkit_rcomm.h"
R = protocol.SPEC.rcomm
FWD = protocol.SPEC.enums["fwd_cmd"].values
WORDS = {m: protocol.SPEC.messages[m].size // 4 for m in ("lisp_cmd", "lisp_data", "emotion")}


class Layout(ctypes.Structure):
    """navkit_rcomm_layout_t as the header declares it (every field a uint32)."""
    _fields_ = [(f, ctypes.c_uint32) for f in (
        "magic", "version", "spec_hash", "size",
        "magic_at", "version_at", "spec_hash_at", "planner_heartbeat_at", "host_heartbeat_at",
        "slot_words_at", "lisp_cmd_at", "lisp_data_at", "emotion_at",
        "lisp_cmd_words", "lisp_data_words", "emotion_words")]


@pytest.fixture(scope="module")
def lib():
    """The library with the prototypes of navkit_rcomm.h."""
    path = rcomm.library_path()
    assert path.is_file(), f"{path} is not built (cmake --build BUILD --target navkit_rcomm)"
    lib = ctypes.CDLL(str(path))
    h, i, u32p = ctypes.c_void_p, ctypes.c_int, ctypes.POINTER(ctypes.c_uint32)
    i32p = ctypes.POINTER(ctypes.c_int32)
    for name, args, res in (
            ("navkit_rcomm_layout", [], ctypes.POINTER(Layout)),
            ("navkit_rcomm_open", [ctypes.c_char_p], h),
            ("navkit_rcomm_open_layout", [ctypes.c_char_p, ctypes.POINTER(Layout)], h),
            ("navkit_rcomm_close", [h], None),
            ("navkit_rcomm_error", [h], ctypes.c_char_p),
            ("navkit_rcomm_write_cmd", [h, i32p], i),
            ("navkit_rcomm_write_emotion", [h, i32p], i),
            ("navkit_rcomm_read_data", [h, i32p], i),
            ("navkit_rcomm_read_cmd", [h, i32p], i),
            ("navkit_rcomm_heartbeat", [h], i),
            ("navkit_rcomm_host_heartbeat", [h, u32p], i),
            ("navkit_rcomm_planner_heartbeat", [h, u32p], i)):
        f = getattr(lib, name)
        f.argtypes, f.restype = args, res
    return lib


def _words(name: str, fields: dict):
    return (ctypes.c_int32 * WORDS[name])(*protocol.pack_words(name, fields))


def test_the_library_exports_the_headers_functions_and_nothing_else():
    declared = set(re.findall(r"NAVKIT_RCOMM_API [^;]*?\b(navkit_rcomm_\w+)\(", HEADER.read_text()))
    out = subprocess.run(["nm", "-D", "--defined-only", str(rcomm.library_path())], capture_output=True,
                         text=True, check=True).stdout
    exported = {line.split()[-1] for line in out.splitlines() if line.split()[1] in "TDBR"}
    assert "navkit_rcomm_open" in declared and exported == declared, exported ^ declared


def test_the_libraries_layout_is_the_specs(lib):
    got = lib.navkit_rcomm_layout().contents
    h = R.header
    want = Layout(R.magic, R.version, protocol.SPEC_HASH, R.size, h["magic"], h["version"], h["spec_hash"],
                  h["planner_heartbeat"], h["host_heartbeat"], R.slot_words_at, R.slots["lisp_cmd"],
                  R.slots["lisp_data"], R.slots["emotion"], *WORDS.values())
    assert {f: getattr(got, f) for f, _ in Layout._fields_} == {f: getattr(want, f) for f, _ in Layout._fields_}


def test_a_planner_drives_a_real_host_in_lockstep(lib, host_factory):
    h, m = host_factory(), Micro()
    h.configure(m)
    r = lib.navkit_rcomm_open(h.shm.encode())
    try:
        assert lib.navkit_rcomm_error(r) == b""
        assert lib.navkit_rcomm_write_cmd(r, _words("lisp_cmd", {"time_tag": 1, "fwd_cmd": FWD["start"],
                                                                 "speed": 200, "distance": 5000})) == 0
        msgs, _ = h.step(m)
        assert msgs[0][0] == "micro_cmd" and msgs[0][1]["fwd_cmd"] == FWD["start"], msgs
        assert msgs[0][1]["distance"] == 5000
        h.step(m)
        data = (ctypes.c_int32 * WORDS["lisp_data"])()
        assert lib.navkit_rcomm_read_data(r, data) == 1
        fields = protocol.unpack_words("lisp_data", list(data))
        hb = ctypes.c_uint32()
        assert lib.navkit_rcomm_host_heartbeat(r, ctypes.byref(hb)) == 0
        assert fields["frame"] == hb.value == h.frame - 1, "the frame just run, in lisp_data and the heartbeat"
        assert lib.navkit_rcomm_heartbeat(r) == 0
        assert lib.navkit_rcomm_planner_heartbeat(r, ctypes.byref(hb)) == 0 and hb.value == 2, \
            "write_cmd beat once, heartbeat once"
    finally:
        lib.navkit_rcomm_close(r)


def test_the_seqlock_never_returns_a_write_in_progress(lib, shm_name):
    path = rcomm_region(shm_name)
    r = lib.navkit_rcomm_open(shm_name.encode())
    try:
        assert lib.navkit_rcomm_error(r) == b""
        cmd = (ctypes.c_int32 * WORDS["lisp_cmd"])()
        assert lib.navkit_rcomm_read_cmd(r, cmd) == 0, "never written"
        assert lib.navkit_rcomm_write_cmd(r, _words("lisp_cmd", {"time_tag": 9, "distance": -5})) == 0
        assert lib.navkit_rcomm_read_cmd(r, cmd) == 1
        assert protocol.unpack_words("lisp_cmd", list(cmd))["distance"] == -5
        assert lib.navkit_rcomm_write_emotion(r, _words("emotion", {"happiness": -100})) == 0
        with open(path, "r+b") as f:
            f.seek(R.slots["lisp_cmd"])
            assert struct.unpack("<I", f.read(4))[0] == 2, "odd while writing, +2 per message"
            f.seek(R.slots["emotion"] + R.slot_words_at)
            assert protocol.from_bytes("emotion", f.read(WORDS["emotion"] * 4))["happiness"] == -100
            f.seek(R.slots["lisp_cmd"])
            f.write(struct.pack("<I", 3))            # a writer stopped half way
        assert lib.navkit_rcomm_read_cmd(r, cmd) == 0, "a write in progress is never returned"
    finally:
        lib.navkit_rcomm_close(r)


def _refusal(lib, name: str, layout=None) -> str:
    r = (lib.navkit_rcomm_open(name.encode()) if layout is None
         else lib.navkit_rcomm_open_layout(name.encode(), ctypes.byref(layout)))
    try:
        return lib.navkit_rcomm_error(r).decode()
    finally:
        lib.navkit_rcomm_close(r)


def test_bad_names_links_and_layouts_are_refused_with_one_line(lib, shm_name):
    assert _refusal(lib, shm_name) == f"rcomm {shm_name}: No such file or directory"
    assert "is not a POSIX shared-memory name" in _refusal(lib, shm_name.lstrip("/"))
    assert "is not a POSIX shared-memory name" in _refusal(lib, "/../" + shm_name.lstrip("/"))
    rcomm_region(shm_name)
    os.symlink("/dev/shm" + shm_name, "/dev/shm" + shm_name + "-link")
    assert _refusal(lib, shm_name + "-link") == \
        f"rcomm {shm_name}-link: /dev/shm{shm_name}-link is a symbolic link: refused"
    bad = Layout.from_buffer_copy(lib.navkit_rcomm_layout().contents)
    bad.emotion_at = bad.size - 4
    assert "layout: the slot at" in _refusal(lib, shm_name, bad)
    os.chmod("/dev/shm" + shm_name, 0o666)
    assert _refusal(lib, shm_name) == f"rcomm {shm_name}: world-writable (mode 666): refused"


def test_a_region_cut_short_is_closed_never_a_sigbus(lib, shm_name):
    path = rcomm_region(shm_name)
    r = lib.navkit_rcomm_open(shm_name.encode())
    try:
        assert lib.navkit_rcomm_error(r) == b""
        os.truncate(path, 0)
        data = (ctypes.c_int32 * WORDS["lisp_data"])()
        assert lib.navkit_rcomm_read_data(r, data) == -1
        assert lib.navkit_rcomm_error(r).decode() == (f"rcomm {shm_name}: the region was cut to 0 bytes by another "
                                                      f"process (the layout needs {R.size}): closed")
        assert lib.navkit_rcomm_heartbeat(r) == -1 and lib.navkit_rcomm_write_cmd(r, _words("lisp_cmd", {})) == -1
    finally:
        lib.navkit_rcomm_close(r)


def test_the_clients_per_frame_calls_refuse_a_cut_region_and_a_closed_client(shm_name):
    """navkit.rcomm.Client's beat and lisp_data read (the lockstep driver's calls every frame,
    made without ctypes argtypes): they work on a whole region, raise RcommError with the
    library's reason once it is cut short, and after close()."""
    path = rcomm_region(shm_name)
    c = rcomm.Client(shm_name)
    before = c.planner_heartbeat()
    c.beat()
    assert c.planner_heartbeat() == before + 1
    raw = c.read_data_raw_still()
    assert raw is None or len(raw) == protocol.SPEC.messages["lisp_data"].size
    os.truncate(path, 0)
    for call in (c.beat, c.read_data_raw):
        with pytest.raises(rcomm.RcommError, match="the region was cut to 0 bytes"):
            call()
    c.close()
    for call in (c.beat, c.read_data_raw):
        with pytest.raises(rcomm.RcommError, match="closed"):
            call()
