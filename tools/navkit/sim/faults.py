"""The mission's timed events acted out during a run, and the faults in force.

An event takes effect at the first host frame (lockstep) or 5 ms chunk (real time) that
starts at or after its t (s): a [[command]] is written to the planner's lisp_cmd slot, a
key to the host's stdin, a [[fault]] applied (kill_host, micro_reset, unplug, line_noise,
planner_silent). Faults with a duration end by themselves (expire). The bytes between host
and micro pass through `Faults.to_host` and `Faults.to_micro`, which apply the line noise
in force and count what each receiving end gets in the log; over CAN the line is the
simulated bus (navkit.can_gateway), which carries the noise as error frames."""

from __future__ import annotations

import math
import random
import signal
import time

from navkit.sim.mission import Mission, MissionError

__all__ = ["Faults", "n_frames", "timeline", "check_timeline"]


def n_frames(mission: Mission, frame_s: float) -> int:
    """Host frames in the run: round(duration_s / frame_s); frame k starts at k * frame_s."""
    return int(round(mission.duration_s / frame_s))


def timeline(mission: Mission) -> list:
    """The mission's events in the order they act: (t in s, order, what, entry), what
    "command", "key" or "fault"; at one t commands first, then keys, then faults."""
    ev = [(c.t, 0, "command", c) for c in mission.commands]
    ev += [(k.t, 1, "key", k) for k in mission.keys]
    ev += [(f.t, 2, "fault", f) for f in mission.faults]
    ev.sort(key=lambda e: (e[0], e[1]))
    return ev


def check_timeline(mission: Mission, frame_s: float) -> None:
    """Every event takes effect at the first host frame (of `frame_s` s) that starts at or
    after its t (lockstep; in real time at the first 5 ms chunk, which is never later):
    MissionError naming the entry if that frame is not in the run, or if two commands
    would share a frame."""
    n, frame = n_frames(mission, frame_s), frame_s
    last = (n - 1) * frame
    if n < 1:
        raise MissionError(f"{mission.path}: key 'duration_s': {mission.duration_s:g} s is less than "
                           f"half a host frame ({frame * 1000:g} ms): the run would have no frame")
    taken = {}              # host frame -> the [[command]] written in it
    for c in mission.commands:
        k = math.ceil(c.t / frame - 1e-9)
        if k in taken:      # one lisp_cmd slot: the second would replace the first unread
            raise MissionError(
                f"{c.where}: key 't': {c.t:g} s takes effect in the same host frame "
                f"({k * frame:g} s) as {taken[k].where.rsplit(': ', 1)[1]} (t = {taken[k].t:g} s): "
                f"the planner has one command slot a frame; put them at least one frame "
                f"({frame * 1000:g} ms) apart")
        taken[k] = c
    for _t, _order, _what, e in timeline(mission):
        k = math.ceil(e.t / frame - 1e-9)
        if k >= n:
            raise MissionError(
                f"{e.where}: key 't': {e.t:g} s would take effect at the first host frame "
                f"at or after it ({k * frame:g} s), but the last frame of the run starts "
                f"at {last:g} s (duration_s = {mission.duration_s:g} s, "
                f"{frame * 1000:g} ms frames): use t <= {last:g} or a longer duration_s")


class Faults:
    """The events of `rig`'s mission (a navkit.sim.rig.SimRig) applied to its parts, and
    the faults in force: `unplug_until`, `noise_until`, `silent_until` (s of simulated
    time; None when not in force), `noise` (navkit.sim.links.LineNoise, seeded from the
    run's seed) and its counts so far (`noise_stats`); `events`, the mission's timeline."""

    def __init__(self, rig):
        self.rig = rig
        self.command_index = {id(c): i + 1 for i, c in enumerate(rig.m.commands)}  # [[command]] #
        self.noise_rng = random.Random(f"navkit-noise-{rig.opts.seed}")
        self.silent_until = None
        self.noise = None
        self.noise_until = None
        self.noise_stats = {"flips": 0, "drops": 0, "inserts": 0}
        self.unplug_until = None
        self.events = timeline(rig.m)
        self.next_event = 0     # index in `events` of the first not acted out yet
        self.due_ns = self._due()

    def _due(self) -> float:
        """The earliest t_ns (ns) at which act_due has an event to act out (inf: none left):
        the next event's t (s) in ns, less 1 ns of rounding slack; t * 1e9 - 1 is exact for
        any t of a run (below 2**53 ns)."""
        i = self.next_event
        return self.events[i][0] * 1e9 - 1 if i < len(self.events) else float("inf")

    def act_due(self, t_ns: int) -> None:
        """Act out, in timeline order, the mission's events not acted out yet that are due
        at `t_ns` (ns of simulated time): those whose t (s) is at or before it (`due_ns`)."""
        while t_ns >= self.due_ns:
            e = self.events[self.next_event]
            self.apply(t_ns, e[2], e[3])
            self.next_event += 1
            self.due_ns = self._due()

    def apply(self, t_ns: int, what: str, e) -> None:
        """Act out event `e` of kind `what` (timeline) at `t_ns` (ns of simulated time)."""
        rig = self.rig
        if what == "command":
            if self.silent_until is not None:
                return          # a silent planner writes nothing
            msg = rig.planner.command(e.fields, t_ns // 1_000_000)
            rig.log.command(t_ns, msg, (self.command_index[id(e)], e.t, e.where))
        elif what == "key":
            rig.log.event(t_ns, "key", {"key": e.key})
            if rig.proc is not None and rig.host_state == "running":
                try:
                    rig.proc.stdin.write(e.key.encode())
                    rig.proc.stdin.flush()
                except OSError:
                    pass
        else:
            self._fault(t_ns, e)

    def _fault(self, t_ns: int, f) -> None:
        """Apply [[fault]] `f` at `t_ns` (ns), logged as an event of its kind."""
        rig = self.rig
        t = t_ns / 1e9
        rig.log.event(t_ns, f.kind, dict(f.params))
        if f.kind == "kill_host":
            if rig.proc is not None and rig.proc.poll() is None:
                rig.proc.send_signal(signal.SIGKILL)
                rig.proc.wait()
            rig.host_state = "killed"
            if rig.lock is not None:
                rig.lock.close()
        elif f.kind == "micro_reset":
            rig.fmus.reset_firmware(t)
            rig.coupler.firmware_restart(t)
            rig.coupler.exchange()
            rig.log.receiver_restart("h2m")     # the micro's frame parser starts afresh
        elif f.kind == "unplug":
            rig.port.unplug()
            rig.rx_count = 0       # bytes still in the pty are gone with it
            self.unplug_until = t + f.duration_s
        elif f.kind == "line_noise":
            from navkit.sim.links import LineNoise

            self.end_noise()
            self.noise = LineNoise(f.params["ber"], self.noise_rng)
            self.noise_until = t + f.duration_s
            if rig.gateway is not None:
                rig.gateway.noise(f.params["ber"], self.noise_rng)
        elif f.kind == "planner_silent":
            self.silent_until = t + f.duration_s if f.duration_s else float("inf")

    def end_noise(self) -> None:
        """End the line noise in force, adding its counts to `noise_stats`."""
        if self.rig.gateway is not None:
            self.rig.gateway.noise(0.0)
        if self.noise is not None:
            for k in self.noise_stats:
                self.noise_stats[k] += getattr(self.noise, k)
            self.noise = None

    def expire(self, t_ns: int) -> None:
        """End the faults whose time is up at `t_ns` (ns), each logged as an event."""
        rig = self.rig
        t = t_ns / 1e9
        if self.unplug_until is not None and t >= self.unplug_until - 1e-9:
            rig.port.plug()
            rig.log.receiver_restart("m2h")     # the host opens a new port
            rig.log.event(t_ns, "plug", {})
            self.unplug_until = None
        if self.noise is not None and t >= self.noise_until - 1e-9:
            self.end_noise()
            rig.log.event(t_ns, "line_noise_end", {})
        if self.silent_until is not None and t >= self.silent_until - 1e-9:
            self.silent_until = None
            rig.log.event(t_ns, "planner_resumes", {})

    def to_host(self, tx: bytes, micro: bytes | None = None) -> int:
        """The micro's bytes (after line noise) to the host's port; returns how many went.
        What the host receives goes to the log's receiver count ("m2h"). Over CAN `tx` is
        SLCAN lines and `micro` the chunk's serial bytes they carry (the log's count: the
        host gets those frames, or none of a chunk that had none)."""
        rig = self.rig
        sent = tx
        if self.noise is not None and rig.gateway is None:  # over CAN: the gateway's error frames
            tx = self.noise.apply(tx)
        port = rig.port
        if rig.host_state != "running" or port.master is None:      # gone, or unplugged
            return 0
        if micro:
            # over CAN the chunk's bytes reach the host whole, as ISO-TP lets them go (its
            # frame may still be on the way when the chunk's lines are written)
            rig.log.received("m2h", None)
        if not tx:
            return 0
        pc = time.perf_counter
        t1 = pc()
        n = port.write(tx)
        rig.times["pty"] += pc() - t1
        if micro is None:
            rig.log.received("m2h", None if tx is sent and n == len(tx) else tx[:n])
        return n

    def to_micro(self, host_bytes: bytes) -> bytes:
        """The host's bytes after line noise, as the micro receives them ("h2m")."""
        if not host_bytes:
            return host_bytes
        if self.noise is None or self.rig.gateway is not None:
            self.rig.log.received("h2m", None)
            return host_bytes
        rx = self.noise.apply(host_bytes)
        self.rig.log.received("h2m", rx)
        return rx

    def can_out(self, back: bytes, tx: bytes, t_ns: int) -> tuple:
        """to_host's arguments for the micro's bytes `tx`: (tx,); over CAN (the adapter's
        answers and frames due, `back`, then the micro's frames as ISO-TP SLCAN lines, tx).
        The log keeps the micro's serial frames (log.micro): the host gets those either way."""
        gateway = self.rig.gateway
        if gateway is None:
            return (tx,)
        lines = back + gateway.from_micro(tx, t_ns / 1e9)
        # the firmware FMU's CAN build sends frame records: the log keeps what they carry
        return lines, (gateway.m2h_serial if gateway.firmware_can else tx)
