"""The co-simulation test helpers moved to sim_helpers.py (a helper module, not a test
module); this name stays only until the last test importing it is moved."""

from sim_helpers import require_build, run_mission  # noqa: F401
