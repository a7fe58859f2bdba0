"""Co-simulation: the firmware FMU and the plant FMU coupled in native code, the real
`navkit-host` on a pseudo-terminal, a scripted planner on rcomm, MCAP logs and a summary.

Modules: `mission` (load and check mission TOML files), `coupler` (ctypes binding of the
native `navkit_cosim` library), `links` (the pty port, the lockstep channel, line noise),
`plant` (checking a plant FMU against the firmware's variables), `harness` (one run),
`record` (the MCAP log and its worker process), `results` (reading a run back), `cli`
(`navkit sim`). See docs/cosim.md.
"""

__all__ = ["mission", "coupler", "links", "plant", "harness", "record", "results", "cli"]
