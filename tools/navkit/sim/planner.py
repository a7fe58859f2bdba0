"""The mission's planner: a scripted client of the host's rcomm region (navkit.rcomm)
that writes the mission's [[command]]s as whole lisp_cmds and bumps the heartbeat; the
loops read lisp_data through its `client`."""

from __future__ import annotations

import time

from navkit.sim.mission import COMMAND_FIELDS

__all__ = ["ScriptedPlanner"]

# attach()'s looks for the host's region: every _POLL_FAST_S (s) for the first _FAST_FOR_S
# (s), then every _POLL_SLOW_S (s)
_POLL_FAST_S, _FAST_FOR_S, _POLL_SLOW_S = 0.0005, 0.1, 0.005


class ScriptedPlanner:
    """The mission's planner on rcomm through the planner client navkit.rcomm (`client`,
    None before attach()): writes whole lisp_cmds, bumps the heartbeat."""

    def __init__(self, shm_name: str):
        self.shm_name = shm_name
        self.client = None
        self.time_tag = 0

    def attach(self, timeout_s: float, alive=lambda: True) -> bool:
        """Open the host's region, waiting up to `timeout_s` (s) for it to appear while
        `alive()` says the host still runs. It is looked for every _POLL_FAST_S for the
        first _FAST_FOR_S (a host just started makes it within some ms, and the run waits
        for it), then every _POLL_SLOW_S."""
        from navkit import rcomm

        start = time.monotonic()
        deadline = start + timeout_s
        while True:
            try:
                self.client = rcomm.Client(self.shm_name)
                return True
            except ConnectionError:          # navkit.rcomm.RcommError: not there (yet)
                now = time.monotonic()
                if now >= deadline or not alive():
                    return False
                time.sleep(_POLL_FAST_S if now - start < _FAST_FOR_S else _POLL_SLOW_S)

    def command(self, fields: dict, t_ms: int) -> dict:
        """Write a whole lisp_cmd (unset fields 0) with a new time tag; returns it."""
        self.time_tag = max(self.time_tag + 1, t_ms)
        msg = dict.fromkeys(COMMAND_FIELDS, 0)
        msg.update(fields, time_tag=self.time_tag, msg_type=0)
        if self.client is not None:
            self.client.write_cmd(msg)
        return msg

    def beat(self) -> None:
        """Bump the planner's heartbeat (nothing before the region is attached)."""
        if self.client is not None:
            self.client.heartbeat()

    def close(self) -> None:
        """Detach from the region (the host removes it)."""
        if self.client is not None:
            self.client.close()
            self.client = None

