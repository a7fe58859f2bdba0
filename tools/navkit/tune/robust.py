"""Robustness of a design over plant variations (Monte Carlo).

Each sample scales the plant's physical parameters by independent uniform factors in
[1 - v, 1 + v] (v = 0.2 by default), grouped as the issue names them: `mass` (mass_kg),
`motor` (motor_kt_nm_a and motor_ke_v_s_rad together: one motor constant), `friction`
(friction_coulomb_n and friction_viscous_n_s_m) and `battery` (battery_ocv_v).

Analytic part: the identified model is scaled by what the plant's physics (docs/plant.md,
"Motors and drive train") says each sample changes. Per wheel, with G = gear/r,
c = kt*ke*G^2/R + viscous (N.s/m) and m = mass/2 + J_rotor*G^2 (kg):
gain K ~ kt*G*V/R / c, time constant tau ~ m / c, dead band d0 ~ coulomb / (kt*G*V/R).
The identified K, tau and d0 are multiplied by each quantity's ratio to its nominal value
(so what the identification saw stays the reference), and the design's quantised gains are
analysed on each scaled model: margins and the move's overshoot; the worst case is kept.

Co-simulated part: the same samples as [plant] overrides of a verification mission, run by
navkit.sweep.run_sweep (interface 4), overshoot from each run's /truth speed.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

__all__ = ["GROUPS", "plant_nominal", "draw", "model_ratios", "overrides"]

GROUPS = {
    "mass": ("mass_kg",),
    "motor": ("motor_kt_nm_a", "motor_ke_v_s_rad"),
    "friction": ("friction_coulomb_n", "friction_viscous_n_s_m"),
    "battery": ("battery_ocv_v",),
}
_NEEDED = ("wheel_diameter_mm", "gear_ratio", "motor_r_ohm", "motor_rotor_inertia_kg_m2") + \
    tuple(k for keys in GROUPS.values() for k in keys)


def plant_nominal(plant_fmu: Path, mission_plant: dict) -> dict | None:
    """The plant's parameters (the FMU's start values under the mission's [plant] table) that
    the analytic part needs; None if the FMU lacks any (a plant of the user's own)."""
    import fmpy

    md = fmpy.read_model_description(str(plant_fmu))
    starts = {v.name: v.start for v in md.modelVariables if v.causality == "parameter"}
    out = {}
    for k in _NEEDED:
        if k in mission_plant:
            out[k] = float(mission_plant[k])
        elif k in starts and starts[k] is not None:
            out[k] = float(starts[k])
        else:
            return None
    return out


def draw(n: int, seed: int, variation: float) -> list[dict]:
    """n samples of {group: factor}, factors uniform in [1 - variation, 1 + variation]."""
    rng = np.random.default_rng(seed)
    return [{g: float(rng.uniform(1.0 - variation, 1.0 + variation)) for g in GROUPS} for _ in range(n)]


def overrides(nominal: dict, factors: dict) -> dict:
    """[plant] values of one sample: each group's parameters times its factor."""
    return {k: nominal[k] * factors[g] for g, keys in GROUPS.items() for k in keys}


def _quantities(p: dict) -> tuple[float, float, float]:
    """(K m/s per duty, tau s, d0 duty) of the plant's physics with parameters p."""
    g = p["gear_ratio"] / (p["wheel_diameter_mm"] / 2000.0)
    drive = p["motor_kt_nm_a"] * g * p["battery_ocv_v"] / p["motor_r_ohm"]  # N per duty
    c = p["motor_kt_nm_a"] * p["motor_ke_v_s_rad"] * g * g / p["motor_r_ohm"] + p["friction_viscous_n_s_m"]
    m = p["mass_kg"] / 2.0 + p["motor_rotor_inertia_kg_m2"] * g * g
    return drive / c, m / c, p["friction_coulomb_n"] / drive


def model_ratios(nominal: dict, factors: dict) -> tuple[float, float, float]:
    """(gain, tau, dead band) ratios of one sample to the nominal plant."""
    k0, t0, d0 = _quantities(nominal)
    p = dict(nominal)
    p.update(overrides(nominal, factors))
    k1, t1, d1 = _quantities(p)
    return k1 / k0, t1 / t0, (d1 / d0) if d0 > 0 else 1.0


def worst(values: list, key: str, lowest: bool) -> float:
    """min (lowest) or max of the finite values[i][key]; nan if none."""
    xs = [v[key] for v in values if v.get(key) is not None and math.isfinite(v[key])]
    if not xs:
        return math.nan
    return min(xs) if lowest else max(xs)
