"""Identification of a wheel's speed response to its PWM duty (numpy least squares).

Two model structures, both with a dead time L and a duty dead band d0 (Coulomb friction:
the duty a wheel needs before it moves), from duty u (-1..1) to wheel speed y (mm/s):

    FOPDT  y = K e^{-Ls} / (tau1 s + 1)                  * db(u)
    SOPDT  y = K e^{-Ls} / ((tau1 s + 1)(tau2 s + 1))    * db(u)
    db(u)  = sign(u) * max(|u| - d0, 0)

K in mm/s per duty, tau1/tau2/L in s, d0 in duty. The data are experiments from rest
(Segment): the duty on a fine grid of period ts (held over each period: the micro's tick)
and the speed sampled at some of the grid's instants (a log has a sample per host frame,
e.g. every 20 ms, but knows each sample's tick); `fit(u, y, ts)` is the case of a speed
sample at every grid point.

The fit is output-error: the model is simulated over each experiment on the grid
(exactly, with the dead time's fraction of a period included by the modified
z-transform), read at the sample instants, and its parameters move by Levenberg-Marquardt
steps (numpy lstsq on a finite-difference Jacobian) to minimise the squared output error;
the starts come from equation-error (ARX) least squares on the samples at every
whole-sample delay. Fit quality: NRMSE = ||y - y_model|| / ||y - mean(y)|| over all
samples (0 = perfect, 1 = no better than the mean).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

__all__ = ["Model", "Fit", "Segment", "IdentError", "simulate", "fit", "fit_both", "fit_segments",
           "fit_both_segments", "nrmse"]


class IdentError(ValueError):
    """Data that cannot be fitted (too short, no excitation, a model that does not converge)."""


@dataclass(frozen=True)
class Model:
    """A wheel model; kind 'fopdt' or 'sopdt'. gain_mm_s (mm/s per duty), tau1_s and tau2_s
    (s; tau2_s 0 for fopdt), delay_s (s), deadband (duty)."""

    kind: str
    gain_mm_s: float
    tau1_s: float
    tau2_s: float = 0.0
    delay_s: float = 0.0
    deadband: float = 0.0

    def tf(self):
        """The delay-free linear part as a python-control continuous TransferFunction
        (duty -> mm/s)."""
        import control

        den = np.polymul([self.tau1_s, 1.0], [self.tau2_s, 1.0]) if self.kind == "sopdt" else [self.tau1_s, 1.0]
        return control.tf([self.gain_mm_s], list(den))

    def scaled(self, gain: float = 1.0, tau: float = 1.0, deadband: float = 1.0) -> "Model":
        """The same structure with K, both time constants and d0 multiplied by the factors."""
        return Model(self.kind, self.gain_mm_s * gain, self.tau1_s * tau, self.tau2_s * tau,
                     self.delay_s, self.deadband * deadband)

    def as_dict(self) -> dict:
        """JSON-ready: the fields with their units in the names."""
        return asdict(self)


@dataclass(frozen=True)
class Fit:
    """A fitted model and its quality: nrmse (1), the record's sample period ts_s (s) and
    length n, and the model's output y_model (mm/s) at the samples."""

    model: Model
    nrmse: float
    ts_s: float
    n: int
    y_model: np.ndarray


def nrmse(y: np.ndarray, y_model: np.ndarray) -> float:
    """||y - y_model|| / ||y - mean(y)|| (1); inf for a constant y."""
    den = float(np.linalg.norm(y - np.mean(y)))
    return float(np.linalg.norm(y - y_model)) / den if den > 0 else math.inf


def _deadband(u: np.ndarray, d0: float) -> np.ndarray:
    return np.sign(u) * np.maximum(np.abs(u) - d0, 0.0)


def _ss(model: Model):
    """Continuous state space (A, B, C) of the delay-free part."""
    if model.kind == "sopdt":
        a = np.array([[-1.0 / model.tau1_s, 0.0], [1.0 / model.tau2_s, -1.0 / model.tau2_s]])
        b = np.array([[model.gain_mm_s / model.tau1_s], [0.0]])
        c = np.array([[0.0, 1.0]])
    else:
        a = np.array([[-1.0 / model.tau1_s]])
        b = np.array([[model.gain_mm_s / model.tau1_s]])
        c = np.array([[1.0]])
    return a, b, c


def _expm(m: np.ndarray) -> np.ndarray:
    """e^M of a small matrix: scaling and squaring of a 14-term Taylor series (the fit calls
    this thousands of times on 2x2 and 3x3 matrices, where a general routine's set-up
    dominates)."""
    norm = float(np.abs(m).sum(axis=1).max())
    s = max(0, int(math.ceil(math.log2(norm / 0.25))) if norm > 0.25 else 0)
    a = m / (2.0 ** s)
    term = np.eye(len(m))
    e = term.copy()
    for k in range(1, 15):
        term = term @ a / k
        e = e + term
    for _ in range(s):
        e = e @ e
    return e


def _hold(a: np.ndarray, b: np.ndarray, t: float):
    """(e^{A t}, integral_0^t e^{A s} ds B) by one matrix exponential."""
    expm = _expm
    n = a.shape[0]
    m = np.zeros((n + 1, n + 1))
    m[:n, :n] = a * t
    m[:n, n:] = b * t
    e = expm(m)
    return e[:n, :n], e[:n, n:]


def discrete(model: Model, ts: float) -> tuple[np.ndarray, np.ndarray]:
    """(num, den) in powers of z^-1 of the model sampled at ts (s) with a held input,
    dead time included (modified z-transform for its fraction of a sample)."""
    a, b, c = _ss(model)
    n_whole = int(math.floor(model.delay_s / ts + 1e-9))
    frac = model.delay_s / ts - n_whole
    if frac < 1e-9:
        frac = 0.0
    phi, _ = _hold(a, b, ts)
    # over one sample the input is u[k-n-1] for frac*ts, then u[k-n] for the rest
    e_rest, g_rest = _hold(a, b, (1.0 - frac) * ts)
    _, g_first = _hold(a, b, frac * ts)
    g_late = g_rest                 # multiplies u[k-n]
    g_early = e_rest @ g_first      # multiplies u[k-n-1]
    # single input, single output: C (zI - Phi)^-1 G = (det(zI - Phi + G C) - det(zI - Phi)) / det(zI - Phi)
    den = np.poly(phi)
    num_late = np.poly(phi - g_late @ c) - den
    num_early = np.poly(phi - g_early @ c) - den
    ns = a.shape[0]
    num = np.zeros(n_whole + ns + 2)
    num[n_whole:n_whole + ns + 1] += num_late
    num[n_whole + 1:n_whole + ns + 2] += num_early
    return num, den


def simulate(model: Model, u: np.ndarray, ts: float, _tf=None) -> np.ndarray:
    """Model output (mm/s) at the samples of duty u (held for ts s each), from rest."""
    from scipy.signal import lfilter

    num, den = _tf if _tf is not None else discrete(model, ts)
    return lfilter(num, den, _deadband(np.asarray(u, float), model.deadband))


@dataclass
class Segment:
    """One experiment from rest: duty u (1) on a fine grid of the fit's period ts (held over
    each period), and the speed samples y (mm/s) taken at grid indices `at` (a record
    sampled on the grid itself has at = 0, 1, 2, ...)."""

    u: np.ndarray
    y: np.ndarray
    at: np.ndarray


def _arx_start(segs: list, ts: float, max_delay_s: float) -> list[Model]:
    """FOPDT starts from equation-error least squares y[k+1] = a y[k] + b u[k-n] + c sign(u[k-n])
    on the samples (the duty taken at the sample instants), stacked over the segments, for
    each whole-sample delay n (numpy lstsq)."""
    tc = ts * float(np.median(np.concatenate([np.diff(sg.at) for sg in segs if len(sg.at) > 1])))
    starts = []
    for n in range(0, max(1, int(round(max_delay_s / tc))) + 1):
        rows, rhs = [], []
        for sg in segs:
            uc, y = sg.u[sg.at], sg.y
            if len(y) - n - 1 < 2:
                continue
            uk = uc[:len(uc) - n - 1]
            rows.append(np.column_stack([y[n:-1], uk, np.sign(uk)]))
            rhs.append(y[n + 1:])
        if not rows or sum(len(r) for r in rhs) < 10:
            break
        theta, *_ = np.linalg.lstsq(np.vstack(rows), np.concatenate(rhs), rcond=None)
        a, b, c = (float(v) for v in theta)
        if not (0.0 < a < 1.0) or b <= 0.0:
            continue
        tau = -tc / math.log(a)
        d0 = min(max(-c / b, 0.0), 0.5)
        for frac in (0.0, 0.25, 0.5, 0.75):  # where in the sample period the response starts
            starts.append(Model("fopdt", b / (1.0 - a), tau, 0.0, (n + frac) * tc, d0))
    return starts


def _sim_at(model: Model, segs: list, ts: float) -> np.ndarray:
    """The model's output at every segment's sample instants, concatenated."""
    tf = discrete(model, ts)
    return np.concatenate([simulate(model, sg.u, ts, tf)[sg.at] for sg in segs])


# parameter vectors: log K, log tau1, [log tau2], delay (s), dead band (duty)
def _pack(m: Model) -> np.ndarray:
    p = [math.log(m.gain_mm_s), math.log(m.tau1_s)]
    if m.kind == "sopdt":
        p.append(math.log(m.tau2_s))
    return np.array(p + [m.delay_s, m.deadband])


def _unpack(kind: str, p: np.ndarray) -> Model:
    if kind == "sopdt":
        return Model(kind, math.exp(p[0]), math.exp(p[1]), math.exp(p[2]), max(float(p[3]), 0.0),
                     max(float(p[4]), 0.0))
    return Model(kind, math.exp(p[0]), math.exp(p[1]), 0.0, max(float(p[2]), 0.0), max(float(p[3]), 0.0))


def _refine(m: Model, segs: list, y: np.ndarray, ts: float, iters: int = 60) -> Model:
    """Levenberg-Marquardt on the output error from model m (y: the segments' samples)."""
    kind = m.kind
    p = _pack(m)
    steps = np.array([1e-4] * (len(p) - 2) + [ts * 1e-2, 1e-4])

    def resid(q):
        q = q.copy()
        q[-2] = max(q[-2], 0.0)
        q[-1] = max(q[-1], 0.0)
        return _sim_at(_unpack(kind, q), segs, ts) - y

    r = resid(p)
    cost = float(r @ r)
    lam = 1e-3
    for _ in range(iters):
        jac = np.column_stack([(resid(p + np.eye(len(p))[i] * steps[i]) - r) / steps[i] for i in range(len(p))])
        jtj = jac.T @ jac
        g = jac.T @ r
        improved = False
        for _ in range(8):
            a = jtj + lam * np.diag(np.diag(jtj) + 1e-12)
            dp, *_ = np.linalg.lstsq(a, -g, rcond=None)
            q = p + dp
            q[-2] = max(q[-2], 0.0)
            q[-1] = min(max(q[-1], 0.0), 0.9)
            rq = resid(q)
            cq = float(rq @ rq)
            if math.isfinite(cq) and cq < cost:
                improved = abs(cost - cq) > 1e-10 * cost
                p, r, cost = q, rq, cq
                lam = max(lam / 3.0, 1e-9)
                break
            lam *= 4.0
        if not improved:
            break
    return _unpack(kind, p)


def fit(u, y, ts: float, kind: str = "fopdt", max_delay_s: float = 0.1) -> Fit:
    """Fit a `kind` model ('fopdt' or 'sopdt') to duty u (1) and speed y (mm/s) sampled every
    ts (s) from rest; dead times up to max_delay_s (s) are searched. Raises IdentError."""
    u = np.asarray(u, float)
    y = np.asarray(y, float)
    if len(u) != len(y) or len(u) < 20:
        raise IdentError(f"need at least 20 samples of duty and speed, got {len(u)} and {len(y)}")
    return fit_segments([Segment(u, y, np.arange(len(y)))], ts, kind, max_delay_s)


def fit_segments(segs: list, ts: float, kind: str = "fopdt", max_delay_s: float = 0.1) -> Fit:
    """Fit a `kind` model to experiments `segs` (Segment: duty on the grid of ts s, speed
    samples at grid indices), all from rest; y_model of the Fit is at the samples, the
    segments' concatenated. Raises IdentError."""
    if kind not in ("fopdt", "sopdt"):
        raise IdentError(f"unknown model kind {kind!r} (fopdt or sopdt)")
    segs = [Segment(np.asarray(sg.u, float), np.asarray(sg.y, float), np.asarray(sg.at, int)) for sg in segs]
    y = np.concatenate([sg.y for sg in segs]) if segs else np.zeros(0)
    u_all = np.concatenate([sg.u for sg in segs]) if segs else np.zeros(0)
    if len(y) < 20:
        raise IdentError(f"need at least 20 speed samples, got {len(y)}")
    if not (np.all(np.isfinite(u_all)) and np.all(np.isfinite(y))):
        raise IdentError("the record holds non-finite duty or speed values")
    if np.ptp(u_all) < 1e-3 or np.ptp(y) < 1e-6:
        raise IdentError("the record has no excitation (duty or speed constant)")
    starts = _arx_start(segs, ts, max_delay_s)
    if not starts:
        raise IdentError("no stable first-order model fits the record (equation-error least squares "
                         "found no pole in 0..1 with a positive gain)")
    # the best few starts by simulation error, each refined
    starts.sort(key=lambda m: nrmse(y, _sim_at(m, segs, ts)))
    best, best_e = None, math.inf
    for s in starts[:3]:
        cands = [s]
        if kind == "sopdt":
            cands = [Model("sopdt", s.gain_mm_s, 0.8 * s.tau1_s, max(0.2 * s.tau1_s, 0.3 * ts), s.delay_s, s.deadband),
                     Model("sopdt", s.gain_mm_s, 0.5 * s.tau1_s, 0.5 * s.tau1_s, max(s.delay_s - ts, 0.0), s.deadband)]
        for c in cands:
            m = _refine(c, segs, y, ts)
            e = nrmse(y, _sim_at(m, segs, ts))
            if e < best_e:
                best, best_e = m, e
    if best is None or not math.isfinite(best_e):
        raise IdentError(f"the {kind} fit did not converge")
    if best.kind == "sopdt" and best.tau2_s > best.tau1_s:
        best = Model("sopdt", best.gain_mm_s, best.tau2_s, best.tau1_s, best.delay_s, best.deadband)
    return Fit(best, best_e, ts, len(y), _sim_at(best, segs, ts))


def fit_both(u, y, ts: float, max_delay_s: float = 0.1) -> dict:
    """{'fopdt': Fit, 'sopdt': Fit} of the same record."""
    return {k: fit(u, y, ts, k, max_delay_s) for k in ("fopdt", "sopdt")}


def fit_both_segments(segs: list, ts: float, max_delay_s: float = 0.1) -> dict:
    """{'fopdt': Fit, 'sopdt': Fit} of the same experiments."""
    return {k: fit_segments(segs, ts, k, max_delay_s) for k in ("fopdt", "sopdt")}
