"""`navkit.rcomm`: the planner's end of the host's rcomm shared memory (the seed's
RComm.dll), laid out as docs/internals.md says.

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
"""

from __future__ import annotations

import mmap
import os
import struct

from navkit import protocol

__all__ = ["Client", "RcommError"]

_U32 = struct.Struct("<I")
_HEADER = struct.Struct("<III")     # magic, version, spec hash at offset 0
_PLANNER_HEARTBEAT = 12             # byte offsets of the header words
_HOST_HEARTBEAT = 16
_RETRIES = 1000


class RcommError(ConnectionError):
    """The region is missing, not ours, or of another layout or spec; the text says why."""


def _path(name: str) -> str:
    return "/dev/shm/" + name.lstrip("/")


class Client:
    """An open rcomm region `name` (e.g. "/navkit", the host's --shm)."""

    def __init__(self, name: str = "/navkit"):
        self.name = name
        try:
            fd = os.open(_path(name), os.O_RDWR)
        except OSError as e:
            raise RcommError(f"rcomm {name}: {e.strerror}") from None
        try:
            st = os.fstat(fd)
            if st.st_uid != os.geteuid():
                raise RcommError(f"rcomm {name}: owned by uid {st.st_uid}, not us: refused")
            if st.st_size < protocol.RCOMM_SIZE:
                raise RcommError(f"rcomm {name}: {st.st_size} bytes, the layout needs "
                                 f"{protocol.RCOMM_SIZE}")
            self._mm = mmap.mmap(fd, protocol.RCOMM_SIZE)
        finally:
            os.close(fd)
        magic, version, spec = _HEADER.unpack_from(self._mm, 0)
        if magic != protocol.RCOMM_MAGIC or version != protocol.RCOMM_VERSION:
            self._mm.close()
            raise RcommError(f"rcomm {name}: magic 0x{magic:08X} version {version}, expected "
                             f"0x{protocol.RCOMM_MAGIC:08X} version {protocol.RCOMM_VERSION}")
        if spec != protocol.SPEC_HASH:
            self._mm.close()
            raise RcommError(f"rcomm {name}: spec hash 0x{spec:08X}, ours 0x{protocol.SPEC_HASH:08X}")
        self._off = protocol.RCOMM_OFFSETS
        self._beats = _U32.unpack_from(self._mm, _PLANNER_HEARTBEAT)[0]

    # ------------------------------------------------------------ seqlock
    def _write(self, slot: str, data: bytes) -> None:
        off = self._off[slot]
        seq = _U32.unpack_from(self._mm, off)[0]
        seq += seq & 1                     # a writer that died mid-write left it odd
        _U32.pack_into(self._mm, off, (seq + 1) & 0xFFFFFFFF)
        self._mm[off + 4:off + 4 + len(data)] = data
        _U32.pack_into(self._mm, off, (seq + 2) & 0xFFFFFFFF)

    def _read(self, slot: str, size: int) -> bytes | None:
        off = self._off[slot]
        for _ in range(_RETRIES):
            s1 = _U32.unpack_from(self._mm, off)[0]
            if s1 & 1:
                continue
            data = bytes(self._mm[off + 4:off + 4 + size])
            if _U32.unpack_from(self._mm, off)[0] == s1:
                return data if s1 else None
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
        return self._read("lisp_data", protocol.SPEC.messages["lisp_data"].size)

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
        self._beats = (self._beats + 1) & 0xFFFFFFFF
        _U32.pack_into(self._mm, _PLANNER_HEARTBEAT, self._beats)

    beat = heartbeat  # the co-simulation harness's name

    def host_heartbeat(self) -> int:
        """The host's frame counter (it advances once per host frame)."""
        return _U32.unpack_from(self._mm, _HOST_HEARTBEAT)[0]

    def close(self) -> None:
        """Unmap the region (the host owns it and removes it at shutdown)."""
        if self._mm is not None:
            self._mm.close()
            self._mm = None

    def __enter__(self) -> "Client":
        return self

    def __exit__(self, *exc) -> None:
        self.close()
