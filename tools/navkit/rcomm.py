"""`navkit.rcomm`: the planner's end of the host's rcomm shared memory (the seed's
RComm.dll), laid out as protocol/navkit.toml [links.rcomm] says (docs/protocol.md).

    >>> with Client("/navkit") as c:                     # doctest: +SKIP
    ...     c.write_cmd({"time_tag": 1, "fwd_cmd": 1, "speed": 200, "distance": 1000})
    ...     c.heartbeat()
    ...     data = c.read_data()                          # dict of lisp_data, or None

Values are raw integers as in the spec (mm, mm/s, mm/s^2, deg x 10, deg/s x 10; see
docs/protocol.md). The host creates the region; a client only opens it, checks its
magic, layout version, spec hash and owner, and then:

- writes `lisp_cmd` and `emotion` behind a seqlock (seq odd, words, seq even, +2 per
  message), so the host never reads a torn message;
- reads `lisp_data` behind the same seqlock (bounded retries);
- bumps the planner heartbeat word, which the host watches (planner_timeout, s).
A planner should call heartbeat() at least once per host frame while it lives;
write_cmd() bumps it too.

Names are POSIX shared-memory names as the host takes them (`--shm`, shm_name): "/"
then 1..255 characters, no other "/", not "." or ".."; the region is opened without
following a symbolic link. Another process of the host's user can cut the region short
(ftruncate) while it is in use: every access first checks its size, and a region shorter
than the layout raises RcommError instead of a SIGBUS (a cut in the microseconds between
that check and the access still ends the process: Python cannot guard a mapped access).

Owner rule (the same as rcomm.h's): a region owned by our user is accepted; one of
another user only when its group is one of ours and its mode gives that group read and
write (the host's `shm_group = NAME`, mode 0660); a world-writable region never.

Memory model, and what this module relies on: every shared word (seqlock counters,
message words, heartbeats) is read and written as one aligned 4-byte atomic access
with sequentially consistent ordering, through GCC's libatomic (`__atomic_load_4`,
`__atomic_store_4`, `__atomic_fetch_add_4`, called with ctypes; libatomic1 comes with
the GCC runtime on every Linux this kit supports). Python has no fence and CPython's
mmap slice and struct writes are byte copies of no stated width or order, so they are
used for nothing shared (one exception, read_data_raw_still(), for a caller that knows
the host is not running). With every access sequentially consistent the seqlock is
correct on weakly ordered CPUs too (aarch64), not only on x86's TSO: a reader that sees
any word of a new message also sees the odd counter before it. The heartbeat is an
atomic read-modify-write of the shared word (fetch-add), so two writers never lose a
beat. Words are native-endian, and the region is little-endian: little-endian hosts
only (x86-64, aarch64 Linux).
"""

from __future__ import annotations

import ctypes
import ctypes.util
import errno
import mmap
import os
import stat
import struct

from navkit import protocol

__all__ = ["Client", "RcommError", "name_refusal", "owner_refusal"]

_LAYOUT = protocol.SPEC.rcomm      # the region as the spec lays it out ([links.rcomm]), bytes
_MAGIC, _VERSION, _SPEC = (_LAYOUT.header[w] for w in ("magic", "version", "spec_hash"))
_PLANNER_HEARTBEAT = _LAYOUT.header["planner_heartbeat"]
_HOST_HEARTBEAT = _LAYOUT.header["host_heartbeat"]
_WORDS_AT = _LAYOUT.slot_words_at  # a slot's words, after its seq at +0
_RETRIES = 1000
_LISP_DATA_SIZE = protocol.SPEC.messages["lisp_data"].size   # bytes
_SEQ_CST = 5                        # __ATOMIC_SEQ_CST


def _libatomic():
    """GCC's libatomic: 4-byte atomic load, store and fetch-add (see the module docstring)."""
    lib = ctypes.CDLL(ctypes.util.find_library("atomic") or "libatomic.so.1")
    load = getattr(lib, "__atomic_load_4")
    load.argtypes, load.restype = [ctypes.c_void_p, ctypes.c_int], ctypes.c_uint32
    store = getattr(lib, "__atomic_store_4")
    store.argtypes, store.restype = [ctypes.c_void_p, ctypes.c_uint32, ctypes.c_int], None
    fetch_add = getattr(lib, "__atomic_fetch_add_4")
    fetch_add.argtypes = [ctypes.c_void_p, ctypes.c_uint32, ctypes.c_int]
    fetch_add.restype = ctypes.c_uint32
    return load, store, fetch_add


_load4, _store4, _fetch_add4 = _libatomic()


class RcommError(ConnectionError):
    """The region is missing, refused by the owner rule, or of another layout or spec;
    the text says why."""


def owner_refusal(uid: int, gid: int, mode: int) -> str:
    """Why a client may not use a region of owner uid, group gid and mode (st_mode),
    or "" when it may (the owner rule of the module docstring)."""
    if mode & 0o002:
        return f"world-writable (mode {mode & 0o777:03o})"
    if uid == os.geteuid():
        return ""
    if mode & 0o060 == 0o060 and (gid == os.getegid() or gid in os.getgroups()):
        return ""
    return (f"owned by uid {uid}, not us, and group {gid} is not ours with rw "
            f"(mode {mode & 0o777:03o})")


_NAME_MAX = 255                     # bytes of a shared-memory name after its "/" (NAME_MAX)


def name_refusal(name: str) -> str:
    """Why `name` is not a POSIX shared-memory name the host takes, or "" when it is
    (the rule of the module docstring)."""
    rest = name[1:]
    if (not name.startswith("/") or not rest or "/" in rest or rest in (".", "..")
            or len(rest.encode(errors="surrogateescape")) > _NAME_MAX or "\0" in rest):
        return (f"{name!r} is not a POSIX shared-memory name ('/' then 1..{_NAME_MAX} characters, "
                "no other '/', not . or ..)")
    return ""


def _path(name: str) -> str:
    return "/dev/shm" + name


class Client:
    """An open rcomm region `name` (e.g. "/navkit", the host's --shm)."""

    def __init__(self, name: str = "/navkit"):
        self.name = name
        self._mm = None
        self._anchor = None
        self._fd = -1
        why = name_refusal(name)
        if why:
            raise RcommError(f"rcomm {why}")
        try:
            fd = os.open(_path(name), os.O_RDWR | os.O_NOFOLLOW | os.O_CLOEXEC | os.O_NONBLOCK)
        except OSError as e:
            if e.errno == errno.ELOOP:
                raise RcommError(f"rcomm {name}: {_path(name)} is a symbolic link: refused") from None
            raise RcommError(f"rcomm {name}: {e.strerror}") from None
        try:
            st = os.fstat(fd)
            if not stat.S_ISREG(st.st_mode):
                raise RcommError(f"rcomm {name}: {_path(name)} is not a shared-memory region: refused")
            why = owner_refusal(st.st_uid, st.st_gid, st.st_mode)
            if why:
                raise RcommError(f"rcomm {name}: {why}: refused")
            if st.st_size < _LAYOUT.size:
                raise RcommError(f"rcomm {name}: {st.st_size} bytes, the layout needs {_LAYOUT.size}")
            self._mm = mmap.mmap(fd, _LAYOUT.size)
        except BaseException:
            os.close(fd)
            raise
        self._fd = fd                      # kept open: every access checks the region's size
        # the mapping's address for libatomic; released in close() before the unmap
        self._anchor = ctypes.c_char.from_buffer(self._mm)
        self._base = ctypes.addressof(self._anchor)
        magic, version, spec = (self._word(o) for o in (_MAGIC, _VERSION, _SPEC))
        if magic != _LAYOUT.magic or version != _LAYOUT.version:
            self.close()
            raise RcommError(f"rcomm {name}: magic 0x{magic:08X} version {version}, expected "
                             f"0x{_LAYOUT.magic:08X} version {_LAYOUT.version}")
        if spec != protocol.SPEC_HASH:
            self.close()
            raise RcommError(f"rcomm {name}: spec hash 0x{spec:08X}, ours 0x{protocol.SPEC_HASH:08X}")
        self._off = _LAYOUT.slots

    # ------------------------------------------------------------ shared words
    def _open(self) -> None:
        """Raise RcommError after close() (the mapping's address is gone), or when the
        region is shorter than the layout now (cut by another process: the access would
        end this process with SIGBUS); the client is closed then."""
        if self._mm is None:
            raise RcommError(f"rcomm {self.name}: closed")
        size = os.fstat(self._fd).st_size
        if size < _LAYOUT.size:
            self.close()
            raise RcommError(f"rcomm {self.name}: the region was cut to {size} bytes by another process "
                             f"(the layout needs {_LAYOUT.size}): closed")

    def _word(self, off: int) -> int:
        """Atomic load of the uint32 at byte offset off (seq_cst)."""
        return _load4(self._base + off, _SEQ_CST)

    def _set_word(self, off: int, value: int) -> None:
        """Atomic store of a uint32 at byte offset off (seq_cst)."""
        _store4(self._base + off, value & 0xFFFFFFFF, _SEQ_CST)

    # ------------------------------------------------------------ seqlock
    def _write(self, slot: str, data: bytes) -> None:
        """Seqlock write of whole little-endian words: seq odd, words, seq even (+2)."""
        self._open()
        off = self._off[slot]
        words = struct.unpack(f"<{len(data) // 4}I", data)
        seq = self._word(off)
        seq += seq & 1                     # a writer that died mid-write left it odd
        self._set_word(off, seq + 1)
        for i, w in enumerate(words):
            self._set_word(off + _WORDS_AT + 4 * i, w)
        self._set_word(off, seq + 2)

    def _read(self, slot: str, size: int) -> bytes | None:
        """Seqlock read: the words between two equal even reads of seq (bounded retries)."""
        self._open()
        off = self._off[slot]
        n = size // 4
        for _ in range(_RETRIES):
            s1 = self._word(off)
            if s1 & 1:
                continue
            words = [self._word(off + _WORDS_AT + 4 * i) for i in range(n)]
            if self._word(off) == s1:
                return struct.pack(f"<{n}I", *words) if s1 else None
        return None

    # ------------------------------------------------------------ planner API
    def write_cmd(self, fields: dict) -> None:
        """Write one whole lisp_cmd (unset fields 0; values must fit int32, the host
        range-checks them) and bump the heartbeat. A changed time_tag (ms) marks a new
        command for the host."""
        self._write("lisp_cmd", protocol.to_bytes("lisp_cmd", fields))
        self.heartbeat()

    def write_emotion(self, fields: dict) -> None:
        """Write one whole emotion message (unset fields 0) for the face."""
        self._write("emotion", protocol.to_bytes("emotion", fields))

    def read_data_raw(self) -> bytes | None:
        """The little-endian bytes of the host's latest lisp_data, or None before the
        host's first frame (or if every bounded retry met a write in progress)."""
        return self._read("lisp_data", _LISP_DATA_SIZE)

    def read_data_raw_still(self) -> bytes | None:
        """read_data_raw() in one copy, for a caller that knows the host is not running
        (a lockstep driver between a frame's done and its next tick): the slot's bytes
        are one plain slice of the mapping taken between two atomic reads of an even,
        unchanged seq, instead of one atomic call per word. If seq says a write was in
        progress after all, the seqlock read of read_data_raw() answers."""
        self._open()
        off = self._off["lisp_data"]
        s1 = self._word(off)
        data = self._mm[off + _WORDS_AT:off + _WORDS_AT + _LISP_DATA_SIZE]
        if s1 & 1 or self._word(off) != s1:
            return self.read_data_raw()
        return data if s1 else None

    def read_data(self) -> dict | None:
        """The host's latest lisp_data as a dict of raw values, or None (see read_data_raw)."""
        raw = self.read_data_raw()
        return None if raw is None else protocol.from_bytes("lisp_data", raw)

    def read_cmd(self) -> dict | None:
        """The lisp_cmd currently in the region (what the host will read), or None."""
        raw = self._read("lisp_cmd", protocol.SPEC.messages["lisp_cmd"].size)
        return None if raw is None else protocol.from_bytes("lisp_cmd", raw)

    def heartbeat(self) -> None:
        """Bump the planner heartbeat word (the host stops the robot when it stays
        unchanged for planner_timeout seconds)."""
        self._open()
        _fetch_add4(self._base + _PLANNER_HEARTBEAT, 1, _SEQ_CST)

    beat = heartbeat  # the co-simulation harness's name

    def host_heartbeat(self) -> int:
        """The host's frame counter (it advances once per host frame)."""
        self._open()
        return self._word(_HOST_HEARTBEAT)

    def planner_heartbeat(self) -> int:
        """The planner heartbeat word as it is in the region (every client's beats)."""
        self._open()
        return self._word(_PLANNER_HEARTBEAT)

    def close(self) -> None:
        """Unmap the region (the host owns it and removes it at shutdown)."""
        self._anchor = None                # the buffer export must end before the unmap
        if self._mm is not None:
            self._mm.close()
            self._mm = None
        if self._fd >= 0:
            os.close(self._fd)
            self._fd = -1

    def __enter__(self) -> "Client":
        return self

    def __exit__(self, *exc) -> None:
        self.close()
