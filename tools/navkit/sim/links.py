"""The harness's ends of the host's links: the pseudo-terminal serial port, the lockstep
control channel and seeded line noise.
"""

from __future__ import annotations

import errno
import os
import select
import socket
import struct
import time
import tty
from pathlib import Path

__all__ = ["Port", "Lockstep", "LineNoise", "LinkError", "TICK_MAGIC", "DONE_MAGIC", "READ_WAIT_S",
           "WRITE_WAIT_S", "DONE_WAIT_S"]

TICK_MAGIC = 0x4B544B4E   # 'NKTK' (bytes in memory, little-endian)
DONE_MAGIC = 0x4E444B4E   # 'NKDN' (bytes in memory, little-endian)
READ_WAIT_S = 5.0         # s a read waits for bytes the host reported (Port.read_exact)
WRITE_WAIT_S = 0.2        # s a write waits for room in the pty before the rest is dropped (Port.write)
DONE_WAIT_S = 10.0        # s a tick's send and its done's receive wait (Lockstep.frame)
_TICK = struct.Struct("<IIQII")
_DONE = struct.Struct("<IIII")


class LinkError(RuntimeError):
    """The host broke the lockstep contract or the port failed; the text says how."""


class Port:
    """The host's serial port: a pty whose slave is reached through the symlink `link`
    (the path given to the host with --port). Both ends are in raw mode; the harness
    keeps the master and holds the slave open so the master never sees a hang-up while
    the host re-opens the port. `unplug()` removes the symlink and closes both ends
    (the host sees the device vanish); `plug()` makes a new pty behind the same path."""

    def __init__(self, link: Path):
        self.link = Path(link)
        self.master = self.slave = None
        self.dropped = 0          # bytes not written because the host was not reading
        self.plug()

    @property
    def plugged(self) -> bool:
        return self.master is not None

    def plug(self) -> None:
        """Create a new pty and point the symlink at its slave."""
        if self.plugged:
            return
        master, slave = os.openpty()
        tty.setraw(master)
        tty.setraw(slave)
        os.set_blocking(master, False)
        tmp = self.link.with_name(self.link.name + ".new")
        if tmp.is_symlink():
            tmp.unlink()
        os.symlink(os.ttyname(slave), tmp)
        os.replace(tmp, self.link)
        self.master, self.slave = master, slave

    def unplug(self) -> None:
        """Remove the symlink and close both ends."""
        if self.link.is_symlink():
            self.link.unlink()
        for fd in (self.master, self.slave):
            if fd is not None:
                os.close(fd)
        self.master = self.slave = None

    def write(self, data: bytes) -> int:
        """Write `data` toward the host without blocking; returns bytes written (the rest
        is counted in `dropped`: the host is not reading)."""
        if self.master is None or not data:
            self.dropped += len(data) if data else 0
            return 0
        size = len(data)
        try:
            done = os.write(self.master, data)     # all of it, as a rule: no view, no loop
        except OSError:
            done = 0            # the loop below writes again and judges the error
        if done < size:
            view = memoryview(data)
            while done < size:
                try:
                    done += os.write(self.master, view[done:])
                except BlockingIOError:
                    _, w, _ = select.select([], [self.master], [], WRITE_WAIT_S)
                    if not w:
                        break
                except OSError as e:
                    if e.errno == errno.EIO:
                        break
                    raise
            self.dropped += size - done
        return done

    def read_exact(self, n: int, timeout_s: float = READ_WAIT_S) -> bytes:
        """Read exactly `n` bytes the host wrote (it has written them already in
        lockstep); LinkError after `timeout_s`."""
        if n == 0:
            return b""
        if self.master is None:
            raise LinkError(f"the host reports {n} bytes written while the port is unplugged")
        try:
            first = os.read(self.master, n)        # all of them, as a rule: no buffer, no clock
        except OSError:
            first = b""         # the loop below reads again and judges the error
        if len(first) == n:
            return first
        buf = bytearray(first)
        deadline = time.monotonic() + timeout_s
        while len(buf) < n:
            try:
                chunk = os.read(self.master, n - len(buf))
                if chunk:
                    buf += chunk
                    continue
            except BlockingIOError:
                pass
            except OSError as e:
                if e.errno != errno.EIO:
                    raise
            left = deadline - time.monotonic()
            if left <= 0:
                raise self.short_read(len(buf), n, timeout_s)
            select.select([self.master], [], [], min(left, 0.1))
        return bytes(buf)

    @staticmethod
    def short_read(got: int, n: int, timeout_s: float = READ_WAIT_S) -> LinkError:
        """The error of a read that got `got` of the `n` bytes the host reported within
        `timeout_s` s (read_exact's, and the native lockstep frame's)."""
        return LinkError(f"read {got} of the {n} bytes the host reported within {timeout_s} s")

    def read_available(self) -> bytes:
        """Every byte waiting from the host (real-time mode)."""
        if not self.plugged:
            return b""
        out = bytearray()
        while True:
            try:
                chunk = os.read(self.master, 65536)
            except (BlockingIOError, OSError):
                break
            if not chunk:
                break
            out += chunk
        return bytes(out)

    def close(self) -> None:
        """Unplug for good."""
        self.unplug()


class Lockstep:
    """The harness end of the lockstep socketpair (docs/internals.md)."""

    def __init__(self):
        self.sock, self.host_end = socket.socketpair(socket.AF_UNIX, socket.SOCK_STREAM)
        # A blocking socket with kernel timeouts (SO_RCVTIMEO / SO_SNDTIMEO): a frame is
        # one send and one recv, where Python's own timeouts add a poll before each and an
        # ioctl per settimeout().
        self._timeout = None
        self._done = bytearray(_DONE.size)
        self._done_view = memoryview(self._done)

    def host_fd(self) -> int:
        """The fd to pass to the host (--lockstep-fd)."""
        return self.host_end.fileno()

    def started(self) -> None:
        """The host has its copy: close ours."""
        self.host_end.close()

    def frame(self, frame: int, sim_time_us: int, rx_bytes: int,
              timeout_s: float = DONE_WAIT_S) -> tuple[int, int] | None:
        """Tick one frame and wait for its done: (tx_bytes, flags), or None at EOF (the
        host went away). LinkError if the done is malformed or late."""
        sock = self.sock
        if timeout_s != self._timeout:
            self.set_timeout(timeout_s)
        view, size, got = self._done_view, _DONE.size, 0
        sock.sendall(_TICK.pack(TICK_MAGIC, frame & 0xFFFFFFFF, sim_time_us, rx_bytes, 0))
        try:
            while got < size:
                n = sock.recv_into(view[got:], size - got)
                if not n:
                    return None
                got += n
        except (BlockingIOError, socket.timeout):
            raise self.no_done(frame) from None
        except ConnectionResetError:
            return None
        magic, done_frame, tx_bytes, flags = _DONE.unpack(self._done)
        self.check_done(frame, magic, done_frame)
        return tx_bytes, flags

    def set_timeout(self, timeout_s: float) -> None:
        """Give a tick's send and its done's receive `timeout_s` s (the socket's kernel
        timeouts, which the native lockstep frame's calls have too)."""
        sec = int(timeout_s)
        tv = struct.pack("@ll", sec, int((timeout_s - sec) * 1e6))
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVTIMEO, tv)
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_SNDTIMEO, tv)
        self._timeout = timeout_s

    def no_done(self, frame: int) -> LinkError:
        """The error of a done that did not come within the timeout."""
        return LinkError(f"no done from the host for frame {frame} within {self._timeout} s")

    @staticmethod
    def check_done(frame: int, magic: int, done_frame: int) -> None:
        """LinkError unless a done of `magic` for `done_frame` answers the tick of `frame`."""
        if magic != DONE_MAGIC:
            raise LinkError(f"bad done magic 0x{magic:08X} for frame {frame}")
        if done_frame != frame & 0xFFFFFFFF:
            raise LinkError(f"done for frame {done_frame}, expected {frame}")

    def close(self) -> None:
        """EOF to the host: it shuts down cleanly."""
        for s in (self.sock, self.host_end):
            try:
                s.close()
            except OSError:
                pass


class LineNoise:
    """Seeded line noise on a byte stream: each bit flips with probability `ber`; each
    byte is dropped with probability 4*ber and a random byte is inserted before it with
    probability 4*ber (framing slips, like a loose connector). Events are drawn by
    geometric skipping, so clean stretches cost nothing."""

    def __init__(self, ber: float, rng):
        self.ber = ber
        self.rng = rng
        self.flips = self.drops = self.inserts = 0
        # per-byte probability of any event
        p_flip = 1.0 - (1.0 - ber) ** 8
        self._p = min(1.0, p_flip + 8 * ber)
        self._skip = self._draw()

    def _draw(self) -> int:
        import math

        if self._p <= 0:
            return 1 << 62
        if self._p >= 1:
            return 0
        u = self.rng.random()
        return int(math.log(1.0 - u) / math.log(1.0 - self._p))

    def apply(self, data: bytes) -> bytes:
        """The bytes after the noise."""
        if not data or self._p <= 0:
            return data
        out = bytearray()
        i, n = 0, len(data)
        while i < n:
            if self._skip >= n - i:
                self._skip -= n - i
                out += data[i:]
                break
            out += data[i:i + self._skip]
            i += self._skip
            b = data[i]
            r = self.rng.random() * self._p
            if r < 4 * self.ber:
                self.drops += 1
            elif r < 8 * self.ber:
                self.inserts += 1
                out.append(self.rng.randrange(256))
                out.append(b)
            else:
                bit = self.rng.randrange(8)
                self.flips += 1
                out.append(b ^ (1 << bit))
            i += 1
            self._skip = self._draw()
        return bytes(out)
