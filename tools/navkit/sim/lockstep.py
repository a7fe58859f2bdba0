"""The lockstep loop (the default mode): the co-simulation drives the host frame by frame.

Per host frame k at simulated time t = k * frame_s:

1. faults whose time is up end; mission events due at t act (navkit.sim.faults);
2. planner heartbeat; tick k to the host carrying the micro's bytes written since the
   last tick; wait for done; read exactly its tx_bytes from the pty, and the lines it
   printed in the frame from host.log (navkit.sim.host_console);
3. the FMUs advance one frame (frame_s / STEP_S steps) in native code in two calls, with
   the host's bytes arriving at the firmware with the first step; after each call the
   firmware's bytes go to the pty;
4. everything decoded goes to the log (run.mcap) with log time = simulated time.

If the host exits or is killed, the FMUs keep stepping frame by frame without it; a host
that quits (its done's flag) gets the frame's answers first, and over CAN the bus is played
until it has exited (navkit.sim.playout), its last frames reaching the micro next frame. Wall
time per part (s) is added to `rig.times`: "fmus", "pty", "host" and "harness" (the rest
of the loop).

Over the serial link, with the host running and no fault in force, steps 2 and 3 run in
two native calls (navkit.sim.coupler.NativeFrames, fmu/cosim/lockstep.h) that do what
the Python calls do (lisp_data read before the host's bytes, which gives the same data:
the host does not run before the next tick); the loop logs what they return."""

from __future__ import annotations

import array
import gc
import time

from navkit.sim.coupler import CouplerError, NativeFrames
from navkit.sim.faults import n_frames
from navkit.sim.options import STEP_S
from navkit.sim.progress import Progress
from navkit.sim.stops import DeferredStops

__all__ = ["run_lockstep"]


def run_lockstep(rig, faults) -> None:
    """Run the mission of `rig` (a started navkit.sim.rig.SimRig) in lockstep, acting out
    its events through `faults` (navkit.sim.faults.Faults); sets rig.frames, rig.t_ns,
    rig.sim_time_s (s) and rig.times."""
    pc = time.perf_counter
    frames_in_run = n_frames(rig.m, rig.frame_s)
    frame_ns = rig.steps_per_frame * 1_000_000
    rig.rx_count = 0
    log, coupler, port, console = rig.log, rig.coupler, rig.port, rig.console
    spf = rig.steps_per_frame
    split = min(spf, max(1, round(0.040 / STEP_S)))
    times = rig.times
    gateway, lock = rig.gateway, rig.lock
    row = coupler.sample()
    log.truth(array.array("d", row).tobytes())
    # between a frame's done and the next tick the host does not run: one copy
    client = rig.planner.client
    lisp_raw = (lambda: None) if client is None else client.read_data_raw_still
    beat = (lambda: None) if client is None else client.heartbeat     # rig.planner.beat, bound once
    # A frame of the serial link with no fault in force runs in two native calls
    # (navkit.sim.coupler.NativeFrames): what the Python path below does, without its
    # Python calls; the logging stays here.
    native = None
    if gateway is None and port.master is not None:
        native = NativeFrames(coupler, lock, port.master, spf, split,
                              None if client is None else client.native())
    # The objects made so far (modules, FMU descriptions) never become garbage: keep
    # the collector from walking them again at every full collection of the loop.
    gc.freeze()
    gone = False            # the /host/frame saying the host is gone is written
    progress = rig.progress = Progress(rig.m.duration_s) if rig.opts.progress else None
    can_back = b""          # --link can: the adapter's answers and frames due for the host
    carry = b""             # --link can: the quitting host's last frames, for the micro's next step
    quitting = False        # over CAN the host's done said it quits: it still reads the port
    loop0 = pc()
    t_host = t_pty = t_fmus = 0.0      # s: added to times at the end (to_host adds its own)
    t1_ns, t2_ns = split * 1_000_000, frame_ns     # ns after a frame's start: its chunks' ends
    try:
        # A stop signal (Ctrl-C, SIGTERM) is held off while a frame is half done (the host's
        # bytes read but not yet on the bus, a tick sent but its done not read) and delivered
        # between frames, so the host's stop follows a whole frame.
        with DeferredStops() as stops:
            stopped = stops.pending
            for k in range(frames_in_run):
                t_ns = k * frame_ns
                rig.t_ns = t_ns        # where an interrupted run stopped
                if faults.unplug_until is not None or faults.noise is not None or \
                        faults.silent_until is not None:
                    faults.expire(t_ns)
                if t_ns >= faults.due_ns:
                    faults.act_due(t_ns)
                host_bytes, carried, carry = b"", carry, b""
                # the native frame: serial, the host running, no fault in force
                fast = native is not None and rig.host_state == "running" and \
                    faults.unplug_until is None and faults.noise is None and faults.silent_until is None
                if rig.host_state == "running":
                    if fast:
                        if port.master != native.pty:     # a new pty since the last
                            native.port(port.master)
                        done = native.host(k, rig.rx_count)
                        if done is not None:
                            done, host_bytes, lisp = done[:2], done[2], done[3]
                            if host_bytes is None:      # more than the native buffer
                                fast = False
                                host_bytes, lisp = port.read_exact(done[0]), lisp_raw()
                    else:
                        if faults.silent_until is None:
                            beat()
                        t1 = pc()
                        done = lock.frame(k, t_ns // 1000, rig.rx_count)
                        t2 = pc()
                        t_host += t2 - t1
                        if done is not None:
                            host_bytes = port.read_exact(done[0])
                            t_pty += pc() - t2
                            lisp = lisp_raw()
                    if done is None:
                        rig.host_state = "exited"
                        rig.proc.wait()
                        log.event(t_ns, "host_exited", {"status": rig.proc.returncode})
                        log.frame(k, t_ns, rig.rx_count, 0, None, b"", None, "exited")
                        gone = True
                    else:
                        tx_bytes, flags = done
                        logged = host_bytes
                        if gateway is not None:  # SLCAN lines in; the micro's frames, back
                            back, host_bytes = gateway.from_host(host_bytes, t_ns / 1e9)
                            can_back += back
                            logged = gateway.h2m_serial if gateway.firmware_can else host_bytes
                        log.frame(k, t_ns, rig.rx_count, tx_bytes, flags, logged,
                                  lisp, "running" if faults.unplug_until is None else "unplugged")
                        if flags & 1:   # over CAN it still reads the port, for its stop's flow control
                            quitting = gateway is not None
                            rig.host_state = "running" if quitting else "exited"
                    rig.frames += 1
                    lines = console.read()         # all the host printed in the frame
                    if lines:
                        log.console(t_ns, lines)
                elif not gone:             # the first frame without the host
                    log.frame(k, t_ns, rig.rx_count, 0, None, b"", None, rig.host_state)
                    gone = True
                host_bytes = faults.to_micro(host_bytes) + carried     # carried: logged by play_out
                # The frame's FMU chunk runs in two calls: the micro answers within the first
                # tens of ms, so its bytes go to the pty while the rest of the chunk computes
                # and the kernel moves them meanwhile. All are written before the next tick
                # either way, so the split changes nothing the host sees; /micro/data is
                # stamped with the end of the call that completed each frame. Each call's truth
                # rows are logged before its micro bytes (log-time order), so the log can close
                # a chunk between the rows of a frame longer than a chunk's 1 s span.
                if fast and rig.host_state == "running":
                    # the native frame wrote the micro's bytes to the pty: logged as to_host does
                    try:
                        rows, tx, wrote, rows2, tx2, wrote2 = native.micro()
                    except CouplerError as e:
                        if e.done is not None:          # the first chunk completed
                            _sent(rig, log, t_ns + t1_ns, *e.done)
                        raise
                    rig.rx_count = _sent(rig, log, t_ns + t1_ns, rows, tx, wrote)
                    if split < spf:
                        rig.rx_count += _sent(rig, log, t_ns + t2_ns, rows2, tx2, wrote2)
                else:
                    t1 = pc()
                    tx, rows = coupler.run_raw(split, host_bytes)
                    t_fmus += pc() - t1
                    log.truth(rows)
                    out = faults.can_out(can_back, tx, t_ns + t1_ns)
                    log.micro(t_ns + t1_ns, out[-1])
                    rig.rx_count = faults.to_host(*out)
                    can_back = b""
                    if split < spf:
                        t1 = pc()
                        tx2, rows2 = coupler.run_raw(spf - split)
                        t_fmus += pc() - t1
                        log.truth(rows2)
                        out = faults.can_out(b"", tx2, t_ns + t2_ns)
                        log.micro(t_ns + t2_ns, out[-1])
                        rig.rx_count += faults.to_host(*out)
                if quitting:
                    # the micro's answers of this frame reached the host, which shuts down now: over
                    # CAN its stop still needs the bus (navkit.sim.playout); the frames it sends go
                    # to the micro with the next frame's step
                    from navkit.sim.playout import play_out

                    carry = play_out(rig, deliver=False)
                    rig.host_state = "exited"
                    quitting = False
                log.end_frame(t_ns + 2 * frame_ns)      # the next frame ends there
                if progress is not None and k & 63 == 0:
                    progress.at(t_ns / 1e9)
                if stopped:
                    stops.deliver()         # a stop signal lands here
    finally:
        if native is not None:
            n_host, n_pty, n_fmus = native.times_s()
            t_host, t_pty, t_fmus = t_host + n_host, t_pty + n_pty, t_fmus + n_fmus
            native.close()
        times["host"] += t_host
        times["pty"] += t_pty
        times["fmus"] += t_fmus
    rig.sim_time_s = frames_in_run * rig.frame_s
    times["harness"] = pc() - loop0 - times["fmus"] - times["pty"] - times["host"]


def _sent(rig, log, t_ns: int, rows: bytes, tx: bytes, wrote: int) -> int:
    """Log a native chunk ending at `t_ns` (ns) as the Python path does: its truth `rows`,
    the micro's bytes `tx`, and of them `wrote` written to the host's port, as
    faults.Faults.to_host logs and counts them (the serial link without line noise); returns
    `wrote`."""
    log.truth(rows)
    log.micro(t_ns, tx)
    if tx:
        log.received("m2h", None if wrote == len(tx) else tx[:wrote])
        rig.port.dropped += len(tx) - wrote
    return wrote
