"""Co-simulation: the firmware FMU and the plant FMU coupled in native code, the real
`navkit-host` on a pseudo-terminal, a scripted planner on rcomm, MCAP logs and a summary.

Modules: `mission` (load and check mission TOML files), `coupler` (ctypes binding of the
native `navkit_cosim` library), `harness` (one run), `record` (MCAP writer), `cli`
(`navkit sim`).
"""

__all__ = ["mission", "coupler", "harness", "links", "record", "results", "cli"]
