"""The real-time loop (`navkit sim --realtime`): the host runs on its own clock and the
FMUs are paced to the wall clock in chunks of 5 ms (5 steps of STEP_S).

Per chunk at simulated time t: faults whose time is up end and mission events due at t
act (navkit.sim.faults); whatever the host wrote to the pty goes to the firmware with
the chunk's first step; the firmware's bytes go to the pty; then the loop sleeps until
the wall clock reaches the chunk's end. Once per host frame (frame_s) it bumps the
planner's heartbeat and logs lisp_data and the host's frame counter."""

from __future__ import annotations

import array
import time

from navkit.sim.options import STEP_S
from navkit.sim.progress import Progress

__all__ = ["run_realtime"]


def _lisp_raw(rig):
    """The host's lisp_data as raw bytes, None before the planner is attached."""
    c = rig.planner.client
    return None if c is None else c.read_data_raw()


def run_realtime(rig, faults) -> None:
    """Run the mission of `rig` (a started navkit.sim.rig.SimRig) paced to the wall clock,
    acting out its events through `faults` (navkit.sim.faults.Faults); sets rig.frames
    (the host's own frame count), rig.t_ns and rig.sim_time_s (s)."""
    chunk_steps = 5
    chunk_ns = chunk_steps * 1_000_000
    n_chunks = int(round(rig.m.duration_s / (chunk_steps * STEP_S)))
    rig.log.truth(array.array("d", rig.coupler.sample()).tobytes())
    wall0 = time.monotonic()
    next_frame_ns = 0
    rx = tx_host = 0        # bytes to / from the host's port since the last /host/frame
    last_frame, gone = None, False
    progress = rig.progress = Progress(rig.m.duration_s) if rig.opts.progress else None
    for c in range(n_chunks):
        t_ns = c * chunk_ns
        rig.t_ns = t_ns        # where an interrupted run stopped
        faults.expire(t_ns)
        faults.act_due(t_ns)
        if rig.host_state == "running" and rig.proc.poll() is not None:
            rig.host_state = "exited"
        host_bytes = rig.port.read_available()
        tx_host += len(host_bytes)
        back = b""
        logged = host_bytes
        if rig.gateway is not None:  # SLCAN lines in; the micro's frames, back
            back, host_bytes = rig.gateway.from_host(host_bytes, t_ns / 1e9)
            logged = rig.gateway.h2m_serial if rig.gateway.firmware_can else host_bytes
        rig.log.host(t_ns, logged)
        host_bytes = faults.to_micro(host_bytes)
        tx, rows = rig.coupler.run_raw(chunk_steps, host_bytes)
        rig.log.truth(rows)
        out = faults.can_out(back, tx, t_ns + chunk_ns)
        rig.log.micro(t_ns + chunk_ns, out[-1])
        rx += faults.to_host(*out)
        if t_ns >= next_frame_ns:
            if rig.host_state == "running":
                if faults.silent_until is None:
                    rig.planner.beat()
                raw = _lisp_raw(rig)
                rig.log.lisp(t_ns, raw)
                if raw is not None:      # the host's own frame counter
                    frame = rig.protocol.from_bytes("lisp_data", raw)["frame"]
                    rig.frames = frame + 1
                    if frame != last_frame:
                        rig.log.frame(frame, t_ns, rx, tx_host, None, b"", None,
                                      "running" if faults.unplug_until is None
                                      else "unplugged")
                        rx = tx_host = 0
                        last_frame = frame
                rig.log.console(t_ns, rig.console.read())
            elif not gone:           # the first frame without the host
                rig.log.frame(rig.frames, t_ns, rx, tx_host, None, b"", None,
                              rig.host_state)
                gone = True
            next_frame_ns += round(rig.frame_s * 1e9)
            # the next frame's chunk ends about then (the log splits finer if need be)
            rig.log.end_frame(next_frame_ns + chunk_ns)
        if progress is not None and c & 63 == 0:
            progress.at(t_ns / 1e9)
        sleep = wall0 + (t_ns + chunk_ns) / 1e9 - time.monotonic()
        if sleep > 0:
            time.sleep(sleep)
    rig.sim_time_s = n_chunks * chunk_steps * STEP_S
