"""The bus played out while the host shuts down (`--link can`): its last frame is a stop.

At a run's end (the loop done, or interrupted) the harness ends the host (lockstep: the
channel's EOF; real time: SIGINT) and the host's last message to the micro is a stop
micro_cmd (docs/host.md, shutdown). Over a serial line the host writes it and is done.
Over CAN it is a segmented ISO-TP message (every frame of the spec is longer than 7
bytes): its first frame goes out and the host waits up to N_Bs (`[can] n_bs_ms`, 1 s) for
the micro's flow control before the consecutive frames follow. The harness, which is
the USB-CAN adapter, the bus and (through the firmware FMU) the micro, must therefore go
on carrying frames until the host has exited, or the stop never reaches the bus whole.

`play_out(rig)` does that: it reads the host's SLCAN lines from the pty and puts their
frames on the bus (navkit.can_gateway: can.log, run.mcap /can, the serial frames they
carry to /micro/cmd), answers with the adapter's replies, and when the host's frames
include a first frame it steps the FMUs one STEP_S at a time until the micro's flow
control for it comes out (FC_WAIT_STEPS at most), which goes back to the host; once the
host has exited, the frames it sent after the last flow control (the stop's last ones)
go to the micro, stepping until it begins its reply (the host, gone, never takes it). The
FMUs advance only for that: the number of steps and the log times follow from the frames
alone (what the host sends before a first frame's flow control is fixed by ISO-TP), so a
lockstep run stays a pure function of its inputs. With the firmware's serial build behind
the gateway (the AVR image), the gateway's own ISO-TP answers at once and the FMUs are not
stepped: the run ends with the stop on the bus.
"""

from __future__ import annotations

import select
import time

from navkit.sim.options import STEP_S

__all__ = ["play_out", "PLAY_OUT_S", "FC_WAIT_STEPS"]

# s of wall time at most: the host waits at most 2 x N_Bs for a flow control (its clock
# guard in micro_link.cpp can_flush), after which it says the stop went out unsent and exits
PLAY_OUT_S = 3.0
# FMU steps (STEP_S each) at most for the micro's flow control after a first frame: its
# link answers at its next poll, within a control period (a few ms)
FC_WAIT_STEPS = 100
_IDLE_WAIT_S = 0.01     # s between looks at the port while the host writes nothing


def _fc_ids() -> dict:
    """CAN identifier of each message's frames -> identifier of its receiver's flow control."""
    from navkit import can as nc

    return {c.id: c.fc_id for c in nc.CAN.ids.values()}


def play_out(rig, deliver: bool = True) -> bytes:
    """Carry the bus of `rig` (a navkit.sim.rig.SimRig whose host is ending) until the host
    has exited, its port is empty, or PLAY_OUT_S of wall time have passed. Nothing to do
    unless the run is over CAN, the host still ran and its port is plugged. A firmware FMU
    that fails (CouplerError) ends it: the host then says its stop went unsent. `deliver`:
    the frames the host sent after the last flow control go to the micro here; else they
    are returned (the firmware FMU's records) for the caller's next step, as the lockstep
    loop does for a host that quit mid-run."""
    gw, port, coupler, log, proc = rig.gateway, rig.port, rig.coupler, rig.log, rig.proc
    if gw is None or proc is None or coupler is None or log is None or port is None \
            or not port.plugged or rig.host_state != "running":
        return b""      # before the imports: navkit.can's load is most of a serial run's stop
    from navkit import can as nc
    from navkit.can_gateway import RECORD
    from navkit.sim.record import log_ns

    fc_of = _fc_ids()
    data_id = nc.CAN.ids["micro_data"].id
    t_ns = log_ns(coupler.time_s)       # where the FMUs are: the bus's time
    pending = bytearray()       # for the micro: delivered with its next step
    deadline = time.monotonic() + PLAY_OUT_S
    while time.monotonic() < deadline:
        data = port.read_available()
        if not data:
            if proc.poll() is not None:
                data = port.read_available()        # written just before it exited
                if not data:
                    break
            else:
                select.select([port.master], [], [], _IDLE_WAIT_S)
                continue
        back, to_micro = gw.from_host(data, t_ns / 1e9)
        serial = gw.h2m_serial if gw.firmware_can else to_micro
        log.host(t_ns, serial)
        if serial:      # on the bus: the micro's controller has them (a chunk without a
            log.received("h2m", None)   # whole frame, e.g. a first frame alone, has none)
        port.write(back)
        if not gw.firmware_can:
            continue                        # the gateway's ISO-TP answered in `back`
        pending += to_micro
        # the host's first frames wait for the micro's flow control: step until it comes
        waiting = {fc_of.get(can_id & 0x7FF) for can_id, dlc, d in RECORD.iter_unpack(to_micro)
                   if dlc and d[0] >> 4 == nc.FIRST}
        if waiting:
            t_ns = _step_until(rig, t_ns, pending, lambda tx: _answered(waiting, tx))
            if t_ns is None:
                return b""
    if not deliver:
        return bytes(pending)
    if pending and gw.firmware_can:
        # the frames after the last flow control (the stop's last ones) reach the micro: it
        # has every message the bus carried, and begins its reply to the last (a first frame)
        _step_until(rig, t_ns, pending,
                    lambda tx: any(dlc and d[0] >> 4 in (nc.SINGLE, nc.FIRST) and (can_id & 0x7FF) == data_id
                                   for can_id, dlc, d in RECORD.iter_unpack(tx)))
    return b""


def _answered(waiting: set, tx: bytes) -> bool:
    """Drop from `waiting` (flow control identifiers) those of the flow controls among the
    firmware's CAN frame records `tx`; True when none is left."""
    from navkit import can as nc
    from navkit.can_gateway import RECORD

    waiting -= {can_id & 0x7FF for can_id, dlc, d in RECORD.iter_unpack(tx) if dlc and d[0] >> 4 == nc.FLOW}
    return not waiting


def _step_until(rig, t_ns: int, pending: bytearray, done) -> int | None:
    """Step the FMUs of `rig` one STEP_S at a time from `t_ns` (ns), `pending` (emptied)
    arriving with the first, until `done(tx)` says the firmware's frames of a step are what
    was awaited, FC_WAIT_STEPS at most; each step's frames go on the bus and to the host's
    port as in the loop. Returns the time reached (ns), None if the firmware FMU failed."""
    from navkit.sim.coupler import CouplerError

    gw, port, coupler, log = rig.gateway, rig.port, rig.coupler, rig.log
    step_ns = round(STEP_S * 1e9)
    for _ in range(FC_WAIT_STEPS):
        try:
            tx, rows = coupler.run_raw(1, bytes(pending))
        except CouplerError:
            return None
        pending.clear()
        t_ns += step_ns
        log.truth(rows)
        if not tx:
            continue
        lines = gw.from_micro(tx, t_ns / 1e9)
        log.micro(t_ns, gw.m2h_serial)
        if port.write(lines) == len(lines) and gw.m2h_serial:
            log.received("m2h", None)
        if done(tx):
            break
    return t_ns
