"""`navkit.rcomm`: the planner's end of the host's rcomm shared memory (the seed's
RComm.dll), a ctypes wrapper over the planner library libnavkit_rcomm.so
(planner/include/navkit_rcomm.h), laid out as protocol/navkit.toml [links.rcomm] says.

    >>> with Client("/navkit") as c:                     # doctest: +SKIP
    ...     c.write_cmd({"time_tag": 1, "fwd_cmd": 1, "speed": 200, "distance": 1000})
    ...     c.heartbeat()
    ...     data = c.read_data()                          # dict of lisp_data, or None

Values are raw integers as in the spec (mm, mm/s, mm/s^2, deg x 10, deg/s x 10; see
docs/protocol.md). The host creates the region; a client only opens it. Every rule of
the client lives in the library, once, and this module only converts: the name check
("/" then 1..255 characters, no other "/", not "." or ".."), opening without following
a symbolic link, the owner rule (ours; another user's only when its group is one of
ours with read and write, the host's `shm_group`, mode 0660; never world-writable),
the magic, layout version and spec hash, the seqlock of lisp_cmd, emotion and
lisp_data (the one navkit-host runs too: planner/include/navkit_rcomm_slot.h), the
atomic heartbeat, and the size check before every access (a region cut short by
another process raises RcommError instead of a SIGBUS; a cut in the microseconds
between that check and the access still ends the process).

The layout passed to the library is this package's spec's (protocol.SPEC.rcomm), so a
client follows the spec it reads. The library is `<build>/planner/libnavkit_rcomm.so`
(`$NAVKIT_BUILD_DIR` or `<repo>/build`, navkit.paths.build_dir); words are exchanged as
the region's little-endian bytes: little-endian hosts only (x86-64, aarch64 Linux).
"""

from __future__ import annotations

import ctypes
import errno
import sys

from navkit import protocol

__all__ = ["Client", "RcommError", "library_path", "name_refusal", "owner_refusal"]

_LAYOUT = protocol.SPEC.rcomm      # the region as the spec lays it out ([links.rcomm]), bytes
_SLOTS = ("lisp_cmd", "lisp_data", "emotion")
_BYTES = {m: protocol.SPEC.messages[m].size for m in _SLOTS}   # bytes per message
_WHY_BYTES = 320                    # a refusal text's buffer, bytes


class RcommError(ConnectionError):
    """The region is missing, refused (name, link, owner rule), of another layout or
    spec, cut short or closed; the text says why."""


class _Layout(ctypes.Structure):
    """navkit_rcomm_layout_t: every field a uint32, byte offsets and sizes."""
    _fields_ = [(f, ctypes.c_uint32) for f in (
        "magic", "version", "spec_hash", "size",
        "magic_at", "version_at", "spec_hash_at", "planner_heartbeat_at", "host_heartbeat_at",
        "slot_words_at", "lisp_cmd_at", "lisp_data_at", "emotion_at",
        "lisp_cmd_words", "lisp_data_words", "emotion_words")]


def _spec_layout() -> _Layout:
    """This package's spec's layout, for navkit_rcomm_open_layout."""
    h = _LAYOUT.header
    return _Layout(_LAYOUT.magic, _LAYOUT.version, protocol.SPEC_HASH, _LAYOUT.size,
                   h["magic"], h["version"], h["spec_hash"], h["planner_heartbeat"], h["host_heartbeat"],
                   _LAYOUT.slot_words_at, *(_LAYOUT.slots[m] for m in _SLOTS),
                   *(_BYTES[m] // 4 for m in _SLOTS))


def library_path():
    """Where the planner library is: `<build>/planner/libnavkit_rcomm.so` (pathlib.Path)."""
    from navkit.paths import build_dir
    return build_dir() / "planner" / "libnavkit_rcomm.so"


_lib = None


def _library():
    """The loaded library with its prototypes (once). FileNotFoundError (not an
    RcommError: nothing to wait for) when it is not built."""
    global _lib
    if _lib is not None:
        return _lib
    if sys.byteorder != "little":
        raise RcommError("rcomm: the Python client exchanges little-endian words: little-endian hosts only")
    path = library_path()
    if not path.is_file():
        raise FileNotFoundError(errno.ENOENT, "the planner library is not built (make build, or cmake --build "
                                "BUILD --target navkit_rcomm)", str(path))
    lib = ctypes.CDLL(str(path))
    h, u32, i, p = ctypes.c_void_p, ctypes.c_uint32, ctypes.c_int, ctypes.c_char_p
    for name, args, res in (
            ("navkit_rcomm_open_layout", [p, ctypes.POINTER(_Layout)], h),
            ("navkit_rcomm_close", [h], None),
            ("navkit_rcomm_error", [h], p),
            ("navkit_rcomm_write_cmd", [h, p], i),
            ("navkit_rcomm_write_emotion", [h, p], i),
            ("navkit_rcomm_read_data", [h, ctypes.c_void_p], i),
            ("navkit_rcomm_read_cmd", [h, ctypes.c_void_p], i),
            ("navkit_rcomm_heartbeat", [h], i),
            ("navkit_rcomm_host_heartbeat", [h, ctypes.POINTER(u32)], i),
            ("navkit_rcomm_planner_heartbeat", [h, ctypes.POINTER(u32)], i),
            ("navkit_rcomm_owner_check", [ctypes.c_uint, ctypes.c_uint, ctypes.c_uint, p, ctypes.c_size_t], i),
            ("navkit_rcomm_name_check", [p, p, ctypes.c_size_t], i)):
        f = getattr(lib, name)
        f.argtypes, f.restype = args, res
    _lib = lib
    return lib


def _untyped(lib, name: str):
    """A function object of `name` of its own without argtypes (int result): its callers
    pass ctypes objects of the prototype's types."""
    fn = lib[name]
    fn.argtypes, fn.restype = None, ctypes.c_int
    return fn


def _text(b: bytes) -> str:
    return b.decode(errors="surrogateescape")


def owner_refusal(uid: int, gid: int, mode: int) -> str:
    """Why a client may not use a region of owner uid, group gid and mode (st_mode),
    or "" when it may (the library's owner rule, navkit_rcomm_owner_check)."""
    why = ctypes.create_string_buffer(_WHY_BYTES)
    _library().navkit_rcomm_owner_check(uid, gid, mode, why, _WHY_BYTES)
    return _text(why.value)


def name_refusal(name: str) -> str:
    """Why `name` is not a POSIX shared-memory name the host takes, or "" when it is
    (the library's rule, navkit_rcomm_name_check)."""
    raw = name.encode(errors="surrogateescape")
    if b"\0" in raw:
        return f"{name!r} is not a POSIX shared-memory name (a NUL character)"
    why = ctypes.create_string_buffer(_WHY_BYTES)
    _library().navkit_rcomm_name_check(raw, why, _WHY_BYTES)
    return _text(why.value)


class Client:
    """An open rcomm region `name` (e.g. "/navkit", the host's --shm). One Client per
    thread, as the library's handle (its copy buffers are the client's own)."""

    def __init__(self, name: str = "/navkit"):
        self.name = name
        self._h = None
        lib = self._lib = _library()
        why = name_refusal(name)
        if why:
            raise RcommError(f"rcomm {why}")
        h = lib.navkit_rcomm_open_layout(name.encode(errors="surrogateescape"), ctypes.byref(_spec_layout()))
        if not h:
            raise MemoryError("rcomm: no memory for a handle")
        error = _text(lib.navkit_rcomm_error(h))
        if error:
            lib.navkit_rcomm_close(h)
            raise RcommError(error)
        self._h = h
        # the calls a lockstep driver makes every host frame, without argtypes (their
        # per-call conversions cost more than the calls): the handle as a c_void_p, made once
        self._h_arg = ctypes.c_void_p(h)
        self._beat_call, self._read_data_call = (_untyped(lib, f) for f in (
            "navkit_rcomm_heartbeat", "navkit_rcomm_read_data"))
        self._data = ctypes.create_string_buffer(_BYTES["lisp_data"])   # read_data's copy
        self._cmd = ctypes.create_string_buffer(_BYTES["lisp_cmd"])
        self._word = ctypes.c_uint32()

    def _handle(self) -> int:
        """The open handle; RcommError after close()."""
        if self._h is None:
            raise RcommError(f"rcomm {self.name}: closed")
        return self._h

    def _failed(self) -> RcommError:
        """The library's reason for a -1 (the region was cut short: it is closed)."""
        return RcommError(_text(self._lib.navkit_rcomm_error(self._h)))

    def _read(self, fn, buf) -> bytes | None:
        got = fn(self._handle(), buf)
        if got < 0:
            raise self._failed()
        return buf.raw if got else None

    # ------------------------------------------------------------ planner API
    def write_cmd(self, fields: dict) -> None:
        """Write one whole lisp_cmd (unset fields 0; values must fit int32, the host
        range-checks them) and bump the heartbeat. A changed time_tag (ms) marks a new
        command for the host."""
        if self._lib.navkit_rcomm_write_cmd(self._handle(), protocol.to_bytes("lisp_cmd", fields)) < 0:
            raise self._failed()

    def write_emotion(self, fields: dict) -> None:
        """Write one whole emotion message (unset fields 0) for the face."""
        if self._lib.navkit_rcomm_write_emotion(self._handle(), protocol.to_bytes("emotion", fields)) < 0:
            raise self._failed()

    def read_data_raw(self) -> bytes | None:
        """The little-endian bytes of the host's latest lisp_data, or None before the
        host's first frame (or if every bounded retry met a write in progress)."""
        # _read's steps written out: a lockstep driver reads it every host frame
        if self._h is None:
            self._handle()
        got = self._read_data_call(self._h_arg, self._data)
        if got < 0:
            raise self._failed()
        return self._data.raw if got else None

    # A lockstep driver's read between a frame's done and its next tick: the library's
    # seqlock read is one call already, so it is read_data_raw.
    read_data_raw_still = read_data_raw

    def read_data(self) -> dict | None:
        """The host's latest lisp_data as a dict of raw values, or None (see read_data_raw)."""
        raw = self.read_data_raw()
        return None if raw is None else protocol.from_bytes("lisp_data", raw)

    def read_cmd(self) -> dict | None:
        """The lisp_cmd currently in the region (what the host will read), or None."""
        raw = self._read(self._lib.navkit_rcomm_read_cmd, self._cmd)
        return None if raw is None else protocol.from_bytes("lisp_cmd", raw)

    def heartbeat(self) -> None:
        """Bump the planner heartbeat word (the host stops the robot when it stays
        unchanged for planner_timeout seconds)."""
        if self._h is None:     # _handle() written out: a lockstep driver beats every frame
            self._handle()
        if self._beat_call(self._h_arg) < 0:
            raise self._failed()

    beat = heartbeat  # the co-simulation harness's name

    def native(self) -> tuple:
        """For native code that beats and reads every frame itself (the harness's
        navkit_cosim lockstep frames): (the open handle, the addresses of
        navkit_rcomm_heartbeat and navkit_rcomm_read_data, lisp_data's size in bytes, a
        function giving the RcommError to raise when one of them returned -1). They stay
        valid until close()."""
        def addr(fn) -> int:
            return ctypes.cast(fn, ctypes.c_void_p).value

        return (self._handle(), addr(self._beat_call), addr(self._read_data_call),
                _BYTES["lisp_data"], self._failed)

    def _get(self, fn) -> int:
        if fn(self._handle(), ctypes.byref(self._word)) < 0:
            raise self._failed()
        return self._word.value

    def host_heartbeat(self) -> int:
        """The host's frame counter (it advances once per host frame)."""
        return self._get(self._lib.navkit_rcomm_host_heartbeat)

    def planner_heartbeat(self) -> int:
        """The planner heartbeat word as it is in the region (every client's beats)."""
        return self._get(self._lib.navkit_rcomm_planner_heartbeat)

    def close(self) -> None:
        """Unmap the region (the host owns it and removes it at shutdown)."""
        if self._h is not None:
            self._lib.navkit_rcomm_close(self._h)
            self._h = None

    def __del__(self):
        self.close()

    def __enter__(self) -> "Client":
        return self

    def __exit__(self, *exc) -> None:
        self.close()
