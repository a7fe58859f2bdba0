"""Co-simulation: the firmware FMU and the plant FMU coupled in native code, the real
`navkit-host` on a pseudo-terminal, a scripted planner on rcomm, MCAP logs and a summary.

Modules: `mission` (load and check mission TOML files), `coupler` (ctypes binding of the
native `navkit_cosim` library), `links` (the pty port, the lockstep channel, line noise),
`plant` (checking a plant FMU against the firmware's variables), `harness` (one run:
`run(opts)`), and the rooms of a run: `options` (SimOptions, paths, the host's config),
`rig` (set-up and tear-down of the run's parts and processes), `fmus` (the two FMU
instances), `planner` (the scripted rcomm planner), `faults` (mission events, faults, line
noise), `lockstep` and `realtime` (the two main loops), `stops` (stop signals held off
between frames), `progress`, `summary`;
`record` (the MCAP log and its worker process), `results` (reading a run back), `cli`
(`navkit sim`). See docs/cosim.md.
"""

__all__ = ["mission", "coupler", "links", "plant", "harness", "options", "rig", "fmus", "planner",
           "faults", "lockstep", "realtime", "stops", "progress", "summary", "record", "results", "cli"]
