"""Helpers of the navkit-host integration tests (no tests here; conftest.py's
`host_factory` fixture makes their Hosts): the real binary in lockstep mode against a
pseudo-terminal whose other end is a test-side micro written with the Python codec, and
the planner through navkit.rcomm. Frame k runs at simulated time k * 100 ms."""

from __future__ import annotations

import os
import re
import select
import shutil
import signal
import socket
import struct
import subprocess
import time
import tty
import uuid
from pathlib import Path

import pytest

from navkit import protocol
from navkit.hostconfig import host_binary
from navkit.paths import repo_root
from spec_helpers import bit

__all__ = ["host_binary", "require_host", "run_host", "rcomm_region", "Micro", "Host", "RawHost", "FRAME_US"]

FRAME_US = 100_000          # simulated frame period, us
_TICK = struct.Struct("<IIQII")
_DONE = struct.Struct("<IIII")
_OK_BITS = {f"micro_cfg_{c}": bit("micro_status", f"cfg_{c}_ok") for c in ("geometry", "motion", "io")}
_REJECT_RANGE = bit("reject", "range")


def run_host(args, timeout: float = 20, **kw) -> subprocess.CompletedProcess:
    """The host binary run once with `args` (str or Path; text output captured, at most
    `timeout` s); `kw` go to subprocess.run (stdin, input, env, ...)."""
    return subprocess.run([str(require_host()), *map(str, args)], capture_output=True, text=True, timeout=timeout,
                          **kw)


def rcomm_region(name: str, magic: int = protocol.SPEC.rcomm.magic, spec_hash: int = protocol.SPEC_HASH) -> str:
    """/dev/shm`name` made as the host lays a region out (the spec's size, header words at
    their spec offsets, `magic` and `spec_hash` there for a test to spoil), nothing else
    written yet; returns its path."""
    r = protocol.SPEC.rcomm
    path = "/dev/shm" + name
    with open(path, "wb") as f:
        f.write(bytes(r.size))
    with open(path, "r+b") as f:
        for word, value in (("magic", magic), ("version", r.version), ("spec_hash", spec_hash)):
            f.seek(r.header[word])
            f.write(struct.pack("<I", value))
    return path


def require_host() -> Path:
    """The binary, or skip the test when it is not built."""
    p = host_binary()
    if not p.exists():
        pytest.skip(f"{p} not built")
    return p


class Micro:
    """The test-side micro: remembers which config messages it accepted and answers a
    host frame with one micro_data (raw values as on the wire)."""

    def __init__(self, spec_hash: int = protocol.SPEC_HASH):
        self.spec_hash = spec_hash
        self.cfg: set[str] = set()
        self.refuse: set[str] = set()   # config messages it refuses (as a field out of range)
        self.rejected = 0               # micro_data.cmd_rejected
        self.last_reject = 0            # micro_data.last_reject: reject.range bit | msg_type of a refused config
        self.tag = 0
        self.fields: dict = {}          # extra micro_data fields
        self.received: list = []        # (name, fields) of every frame the host sent

    def reset(self) -> None:
        """A micro reset: the config is lost."""
        self.cfg.clear()

    @property
    def status(self) -> int:
        """micro_data.status bits: configured + one bit per config message accepted."""
        s = sum(_OK_BITS[c] for c in self.cfg)
        return s | (bit("micro_status", "configured") if len(self.cfg) == 3 else 0)

    def handle(self, msgs: list) -> None:
        """Take the host's frames; configs carrying our spec hash are accepted, but
        those in `refuse` are counted as the firmware counts a config out of range."""
        for name, f in msgs:
            self.received.append((name, f))
            if name in self.refuse:
                self.rejected = (self.rejected + 1) & 0xFFFF
                self.last_reject = _REJECT_RANGE | f["msg_type"]
            elif name in _OK_BITS and f["spec_hash"] == self.spec_hash:
                self.cfg.add(name)

    def data(self, **fields) -> bytes:
        """One micro_data frame (fields override the micro's state)."""
        self.tag = (self.tag + 1) & 0xFFFF
        f = {"status": self.status, "spec_hash": self.spec_hash, "fw_version": 0x0100,
             "cmd_rejected": self.rejected, "last_reject": self.last_reject}
        f.update(self.fields)
        f.update(fields)
        return protocol.encode_frame("micro_data", f, time_tag=self.tag, strict=False)


class Host:
    """navkit-host in lockstep mode on a pty (reached through a symlink, so the test can
    unplug and replug it) with a unique rcomm name."""

    def __init__(self, tmp: Path, ini: dict | None = None, args: tuple = (), lockstep: bool = True,
                 stdin=subprocess.PIPE):
        """ini: {file name: {key: value}} replacing the first `key = ...` line of the
        shipped file. stdin: a pipe the test writes keys to (proc.stdin), a file, or
        "closed" (the host starts with fd 0 closed)."""
        self.tmp = Path(tmp)
        self.cfg = self.tmp / "config"
        self.cfg.mkdir()
        for name in ("NavAndControl.ini", "sensors.ini"):
            shutil.copy(repo_root() / "config" / name, self.cfg / name)
        for name, keys in (ini or {}).items():
            path = self.cfg / name
            text = path.read_text()
            for key, value in keys.items():
                text, n = re.subn(rf"^{key} = .*$", f"{key} = {value}", text, count=1, flags=re.M)
                assert n == 1, f"{name} has no key {key}"
            path.write_text(text)
        self.link = self.tmp / "ttyNK"
        self.master = self.slave = None
        self.plug()
        self.shm = f"/nk-test-{os.getpid()}-{uuid.uuid4().hex[:8]}"
        self.frame = 0
        self.rx = 0                 # bytes written toward the host since the last tick
        self.log = open(self.tmp / "host.log", "wb")
        cmd = [str(require_host()), "--port", str(self.link), "--shm", self.shm,
               "--config", str(self.cfg), "--log-dir", str(self.tmp), *args]
        fds = ()
        self.sock = None
        if lockstep:
            self.sock, theirs = socket.socketpair(socket.AF_UNIX, socket.SOCK_STREAM)
            cmd[1:1] = ["--clock", "lockstep", "--lockstep-fd", str(theirs.fileno())]
            fds = (theirs.fileno(),)
        closed = isinstance(stdin, str) and stdin == "closed"
        self.proc = subprocess.Popen(cmd, stdin=subprocess.DEVNULL if closed else stdin, stdout=self.log,
                                     stderr=subprocess.STDOUT, pass_fds=fds,
                                     preexec_fn=(lambda: os.close(0)) if closed else None)
        if lockstep:
            theirs.close()
        self.client = self._attach()

    # ------------------------------------------------------------ port
    def plug(self) -> None:
        """A new pty behind the symlink."""
        self.master, self.slave = os.openpty()
        tty.setraw(self.master)
        tty.setraw(self.slave)
        os.set_blocking(self.master, False)
        tmp = self.link.with_name("ttyNK.new")
        os.symlink(os.ttyname(self.slave), tmp)
        os.replace(tmp, self.link)

    def unplug(self) -> None:
        """The port vanishes: symlink removed, both ends closed."""
        self.link.unlink()
        os.close(self.master)
        os.close(self.slave)
        self.master = self.slave = None
        self.rx = 0

    def write(self, data: bytes) -> None:
        """Bytes from the micro to the host (counted for the next tick)."""
        os.write(self.master, data)
        self.rx += len(data)

    def read_exact(self, n: int) -> bytes:
        buf = b""
        deadline = time.monotonic() + 5
        while len(buf) < n:
            try:
                buf += os.read(self.master, n - len(buf))
            except BlockingIOError:
                assert time.monotonic() < deadline, f"read {len(buf)} of {n} bytes"
                select.select([self.master], [], [], 0.1)
        return buf

    def read_available(self, wait_s: float = 0.0) -> bytes:
        if wait_s:
            select.select([self.master], [], [], wait_s)
        out = b""
        while True:
            try:
                chunk = os.read(self.master, 4096)
            except (BlockingIOError, OSError):
                break
            if not chunk:
                break
            out += chunk
        return out

    # ------------------------------------------------------------ lockstep
    def _attach(self):
        from navkit import rcomm

        deadline = time.monotonic() + 10
        while True:
            try:
                return rcomm.Client(self.shm)
            except rcomm.RcommError:
                if self.proc.poll() is not None or time.monotonic() > deadline:
                    raise AssertionError(f"host did not create {self.shm}: {self.output()}")
                time.sleep(0.01)

    def tick(self) -> tuple[list, int]:
        """Run one host frame: ([(name, fields)] the host sent in it, done flags)."""
        self.sock.sendall(_TICK.pack(0x4B544B4E, self.frame, self.frame * FRAME_US, self.rx, 0))
        self.rx = 0
        buf = b""
        self.sock.settimeout(10)
        while len(buf) < _DONE.size:
            chunk = self.sock.recv(_DONE.size - len(buf))
            assert chunk, f"host closed the lockstep socket: {self.output()}"
            buf += chunk
        magic, frame, tx, flags = _DONE.unpack(buf)
        assert magic == 0x4E444B4E and frame == self.frame
        self.frame += 1
        data = self.read_exact(tx) if tx else b""
        return self.decode(data), flags

    @staticmethod
    def decode(data: bytes) -> list:
        p = protocol.Parser(protocol.DIR_TO_MICRO)
        events = p.feed(data) + p.flush()
        assert all(isinstance(e, protocol.Frame) for e in events), events
        return [(e.name, e.fields) for e in events]

    def step(self, micro: Micro, reply: bool = True, **fields) -> tuple[list, int]:
        """One frame; the micro takes the host's messages and (reply) answers them."""
        msgs, flags = self.tick()
        micro.handle(msgs)
        if reply and self.master is not None:
            self.write(micro.data(**fields))
        return msgs, flags

    def configure(self, micro: Micro, frames: int = 10) -> list:
        """Frames until the host sends micro_cmd; returns every message sent."""
        out = []
        for _ in range(frames):
            msgs, _ = self.step(micro)
            out += msgs
            if msgs and msgs[-1][0] == "micro_cmd":
                return out
        raise AssertionError(f"no micro_cmd after {frames} frames: {out}")

    def output(self) -> str:
        self.log.flush()
        return (self.tmp / "host.log").read_text(errors="replace")

    def stop(self, sig: int | None = None) -> int:
        """End the host (EOF on the lockstep socket, or a signal); its exit status."""
        if self.client is not None:
            self.client.close()
            self.client = None
        if sig is not None:
            self.proc.send_signal(sig)
        elif self.sock is not None:
            self.sock.close()
            self.sock = None
        try:
            rc = self.proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            rc = self.proc.wait()
        return rc

    def close(self) -> None:
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGKILL)
            self.proc.wait()
        if self.client is not None:
            self.client.close()
        if self.sock is not None:
            self.sock.close()
        for fd in (self.master, self.slave):
            if fd is not None:
                os.close(fd)
        self.master = self.slave = None
        self.log.close()
        try:
            os.unlink("/dev/shm" + self.shm)
        except OSError:
            pass


class RawHost(Host):
    """A Host whose tick() returns the raw bytes the host wrote (SLCAN lines on a CAN link)."""

    @staticmethod
    def decode(data: bytes) -> bytes:
        return data
