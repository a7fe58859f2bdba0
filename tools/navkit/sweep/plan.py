"""What a sweep runs: `--vary KEY=LO:HI[:N]` ranges of plant parameters, checked against
the plant FMU's parameters, turned into points by a grid or by random sampling (Latin
hypercube or uniform, seeded), times seeds.

Every function here is a pure function of its arguments: the same arguments give the
same runs in the same order (run i is the i-th point with its seeds in order).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path

__all__ = ["SweepError", "Vary", "parse_vary", "plant_parameters", "check_varies", "grid",
           "sample", "SAMPLERS", "DEFAULT_GRID_POINTS"]

DEFAULT_GRID_POINTS = 3          # grid points of a key given without :N
SAMPLERS = ("lhs", "uniform")    # Latin hypercube; independent uniform draws
_NUMBER_TYPES = ("Float64", "Float32")
_INT_TYPES = tuple(f"{u}Int{n}" for u in ("", "U") for n in (8, 16, 32, 64))


class SweepError(ValueError):
    """A sweep that cannot be run as asked; the text names the option or key."""


@dataclass(frozen=True)
class Vary:
    """One varied plant parameter: `key` from `lo` to `hi` (both included, the
    parameter's own units), `n` grid points (None: not given)."""

    key: str
    lo: float
    hi: float
    n: int | None = None
    text: str = ""          # as given on the command line, for errors

    @property
    def where(self) -> str:
        return f"--vary {self.text or self.key!r}"


_VARY = re.compile(r"\s*([A-Za-z_][A-Za-z0-9_]*)\s*=\s*([^:]+):([^:]+)(?::([^:]+))?\s*")


def _float(text: str, what: str, where: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise SweepError(f"{where}: {what} {text.strip()!r} is not a number") from None
    if not math.isfinite(v):
        raise SweepError(f"{where}: {what} {text.strip()!r} is not finite")
    return v


def parse_vary(text: str) -> Vary:
    """`KEY=LO:HI` or `KEY=LO:HI:N` as a Vary; SweepError naming `--vary TEXT` when it is
    malformed (LO above HI, N not a whole number of at least 1, or N > 1 with LO = HI)."""
    where = f"--vary {text!r}"
    m = _VARY.fullmatch(text)
    if not m:
        raise SweepError(f"{where}: expected KEY=LO:HI or KEY=LO:HI:N (e.g. mass_kg=10:14:3)")
    key, lo_t, hi_t, n_t = m.groups()
    lo, hi = _float(lo_t, "LO", where), _float(hi_t, "HI", where)
    if lo > hi:
        raise SweepError(f"{where}: LO {lo:g} is above HI {hi:g}")
    n = None
    if n_t is not None:
        try:
            n = int(n_t)
        except ValueError:
            raise SweepError(f"{where}: N {n_t.strip()!r} is not a whole number of points") from None
        if n < 1:
            raise SweepError(f"{where}: N must be at least 1, not {n}")
        if n > 1 and lo == hi:
            raise SweepError(f"{where}: {n} points between equal ends {lo:g}")
    return Vary(key, lo, hi, n, text)


def plant_parameters(plant_fmu: str | Path) -> dict:
    """{name: FMI type} of the parameters of plant FMU file `plant_fmu` a sweep may vary:
    its numeric (Float and Int) parameters but `seed` and `world_file`, which the harness
    sets (navkit.sim.mission.RESERVED_PLANT_KEYS)."""
    from fmpy import read_model_description

    from navkit.sim.mission import RESERVED_PLANT_KEYS

    md = read_model_description(str(plant_fmu))
    return {v.name: v.type for v in md.modelVariables
            if v.causality == "parameter" and v.name not in RESERVED_PLANT_KEYS
            and v.type in _NUMBER_TYPES + _INT_TYPES}


def check_varies(varies: list, params: dict, plant_fmu: str | Path) -> None:
    """SweepError naming the first `--vary` whose key is given twice, is set by the
    harness, or is not a numeric parameter of the plant (`params`, from plant_parameters
    of `plant_fmu`), and for an integer parameter whose range holds no whole number."""
    from navkit.sim.mission import RESERVED_PLANT_KEYS

    seen = set()
    for v in varies:
        if v.key in seen:
            raise SweepError(f"{v.where}: key {v.key!r} is varied twice")
        seen.add(v.key)
        if v.key in RESERVED_PLANT_KEYS:
            raise SweepError(f"{v.where}: key {v.key!r} is set by the harness: "
                             f"{RESERVED_PLANT_KEYS[v.key]}" +
                             ("; sweep seeds with --seeds N" if v.key == "seed" else ""))
        if v.key not in params:
            import difflib

            near = difflib.get_close_matches(v.key, params, n=4, cutoff=0.6)
            hint = f" (did you mean {', '.join(near[:4])}?)" if near else \
                f" (its numeric parameters: {', '.join(sorted(params))})"
            raise SweepError(f"{v.where}: key {v.key!r} is not a numeric parameter of the plant "
                             f"FMU {plant_fmu}{hint}")
        if params[v.key] in _INT_TYPES and math.floor(v.hi) < math.ceil(v.lo):
            raise SweepError(f"{v.where}: key {v.key!r} is an integer ({params[v.key]}) and "
                             f"{v.lo:g}..{v.hi:g} holds no whole number")


def _value(v: Vary, u: float, params: dict):
    """The value of `v` at fraction `u` (0..1) of its range, as its parameter's type:
    floats exact at the ends, integers rounded into the range."""
    x = v.lo if u <= 0 else v.hi if u >= 1 else v.lo + u * (v.hi - v.lo)
    if params.get(v.key) in _INT_TYPES:
        return min(max(int(round(x)), math.ceil(v.lo)), math.floor(v.hi))
    return float(x)


def grid(varies: list, params: dict) -> list:
    """Every combination of the keys' grid points ([{key: value}, ...], the first key
    slowest): N points (default DEFAULT_GRID_POINTS) evenly from LO to HI, both included
    (1 point: LO). Integer parameters are rounded; points that round to the same value
    are kept once."""
    import itertools

    axes = []
    for v in varies:
        n = v.n or DEFAULT_GRID_POINTS
        values = [_value(v, i / (n - 1) if n > 1 else 0.0, params) for i in range(n)]
        axes.append(list(dict.fromkeys(values)))
    return [dict(zip((v.key for v in varies), combo)) for combo in itertools.product(*axes)]


def sample(varies: list, params: dict, n: int, method: str = "lhs", seed: int = 1) -> list:
    """`n` random points ([{key: value}, ...]) in the keys' ranges, a function of
    (`varies`, `n`, `method`, `seed`): "lhs" is a Latin hypercube (each key's range cut
    into n equal strata, one point in each, the strata paired at random across keys),
    "uniform" n independent uniform draws. Integer parameters are rounded. SweepError if a
    key was given with :N (the grid's point count)."""
    import numpy as np

    if method not in SAMPLERS:
        raise SweepError(f"--sampler {method!r}: one of {', '.join(SAMPLERS)}")
    for v in varies:
        if v.n is not None:
            raise SweepError(f"{v.where}: ':N' is the grid's point count; with --samples give "
                             f"{v.key}={v.lo:g}:{v.hi:g}")
    rng = np.random.default_rng(seed)
    k = len(varies)
    if method == "lhs":
        u = np.empty((n, k))
        for j in range(k):
            u[:, j] = (rng.permutation(n) + rng.random(n)) / n
    else:
        u = rng.random((n, k))
    return [{v.key: _value(v, float(u[i, j]), params) for j, v in enumerate(varies)}
            for i in range(n)]
