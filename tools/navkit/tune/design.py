"""Loop design with python-control on the discretised loops the firmware runs.

The wheel loop (firmware/core/wheel.c, every tick of dt = 1/control_rate s):

    e = sp - meas                      (mm/s)
    I += ki*dt * e                     (duty; clamped, conditional anti-windup)
    duty = kff*sp + kp*e + I + (kd/dt)*(e - e_prev)

so C(z) = kp + ki*dt*z/(z-1) + (kd/dt)*(z-1)/z and the feed-forward kff acts on sp alone.
The plant is the identified model (duty -> measured wheel speed, so the firmware's speed
estimate is part of it) sampled with a zero-order hold at dt, its dead time rounded to
whole ticks, times z^-c for the tick's computation delay (c ticks, default 1: the duty a
tick computes from the encoders read at its start reaches the motor at its end, which on a
slow target can be a whole tick later). Open loop L = C*P; setpoint -> speed
T = P*(kff + C)/(1 + C*P).

Design: for a phase margin PM at crossover wc, C(e^{j wc dt}) must equal
e^{j(-180 + PM)} / P(e^{j wc dt}); with kd = kp*td (td fixed) this is linear in (kp, ki).
Given a bandwidth (crossover) the two real equations give kp and ki; otherwise the PI zero
sits at wc/integral_ratio (ki = kp*wc/ratio) and wc is the frequency where the loop's
phase is -180 + PM (kp from |L| = 1 there). kff = w/K with a weight w in 0..1
(design_wheel searches the ratio and w against the overshoot and gain-margin limits).

The heading loop (turn.c, HdgSel): turn rate = heading_kp * heading error, followed by the
tuned wheel loops (each wheel gets +-rate * track/2), and the gyro heading integrates the
rate: G_h(z) = T_w(z) * dt/(z - 1) (deg per deg/s), L_h = heading_kp * G_h.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

__all__ = ["DesignError", "WheelGains", "WheelDesign", "HeadingDesign", "plant_d", "controller_d",
           "move_response", "heading_response",
           "wheel_loops", "design_wheel", "heading_plant", "design_heading", "margins", "step_info",
           "quantise_wheel", "quantise_heading", "corner_model", "stable", "lsim", "WHEEL_SCALES",
           "HEADING_SCALE"]


def _field(name: str):
    """micro_cfg_motion's field `name` in the spec (protocol/navkit.toml): its raw unit
    (scale) and range are the config's."""
    from navkit import protocol

    for f in protocol.SPEC.messages["micro_cfg_motion"].fields:
        if f.name == name:
            return f
    raise KeyError(name)


def _scale(name: str) -> float:
    return float(_field(name).scale)


def _range(name: str) -> tuple[int, int]:
    f = _field(name)
    return int(f.min), int(f.max)


WHEEL_SCALES = ("wheel_kff", "wheel_kp", "wheel_ki", "wheel_kd")
HEADING_SCALE = "heading_kp"


class DesignError(ValueError):
    """Targets out of reach or an unstable result; the text says which and why."""


@dataclass(frozen=True)
class WheelGains:
    """kff and kp in duty/(mm/s), ki in duty/mm, kd in duty/(mm/s^2)."""

    kff: float
    kp: float
    ki: float
    kd: float = 0.0

    def as_dict(self) -> dict:
        return {"kff": self.kff, "kp": self.kp, "ki": self.ki, "kd": self.kd}


def plant_d(model, dt: float, compute_delay: int = 1):
    """The model sampled at dt (s) with a zero-order hold, times z^-(round(L/dt) + compute_delay)."""
    import control

    p = control.c2d(model.tf(), dt, "zoh")
    n = int(round(model.delay_s / dt)) + int(compute_delay)
    if n > 0:
        p = p * control.tf([1.0], [1.0] + [0.0] * n, dt)
    return p


def controller_d(g: WheelGains, dt: float):
    """C(z) = kp + ki*dt*z/(z-1) + (kd/dt)*(z-1)/z of wheel.c."""
    import control

    c = control.tf([g.kp], [1.0], dt) + control.tf([g.ki * dt, 0.0], [1.0, -1.0], dt)
    if g.kd:
        c = c + control.tf([g.kd / dt, -g.kd / dt], [1.0, 0.0], dt)
    return c


def wheel_loops(g: WheelGains, plant):
    """(open loop L = C*P, closed loop setpoint -> speed T = P*(kff + C)/(1 + C*P))."""
    import control

    dt = plant.dt
    c = controller_d(g, dt)
    loop = c * plant
    t = control.minreal(plant * (control.tf([g.kff], [1.0], dt) + c) / (1 + loop), verbose=False)
    return loop, t


def stable(loop) -> bool:
    """True if unity feedback around discrete open loop `loop` is stable: every root of
    1 + L(z) inside the unit circle (from L's own numerator and denominator, so no
    near-cancellation of the integrator's pole can fake an unstable closed loop)."""
    num = np.asarray(loop.num[0][0], float)
    den = np.asarray(loop.den[0][0], float)
    n = max(len(num), len(den))
    char = np.r_[np.zeros(n - len(den)), den] + np.r_[np.zeros(n - len(num)), num]
    return bool(np.all(np.abs(np.roots(char)) < 1.0))


def margins(loop) -> dict:
    """Gain margin (dB, inf if none), phase margin (deg), crossover (Hz), phase crossover (Hz),
    stability margin (1/peak sensitivity) of open loop `loop`."""
    import warnings

    import control

    with warnings.catch_warnings():  # python-control says when it switches to its frequency-response method
        warnings.simplefilter("ignore", UserWarning)
        gm, pm, sm, wpc, wgc, _ = control.stability_margins(loop)
    return {"gain_margin_db": 20 * math.log10(gm) if gm and math.isfinite(gm) and gm > 0 else math.inf,
            "phase_margin_deg": float(pm),
            "crossover_hz": float(wgc) / (2 * math.pi) if math.isfinite(wgc) else math.nan,
            "phase_crossover_hz": float(wpc) / (2 * math.pi) if math.isfinite(wpc) else math.nan,
            "stability_margin": float(sm)}


def step_info(sys_or_t, y=None, t_end: float | None = None, ramp_s: float = 0.0) -> dict:
    """control.step_info of a system's response to a unit setpoint reaching 1 after a ramp of
    ramp_s s (0: a step), t_end s long, or of a response y at times t: rise time (s,
    10-90 %), settling time (s, 2 %), overshoot (%), peak, steady state."""
    import control

    if y is None:
        sysd = sys_or_t
        n = int(round((t_end or 0.5) / sysd.dt)) + 1
        tt = np.arange(n) * sysd.dt
        yy = lsim(sysd, np.minimum(tt / ramp_s, 1.0) if ramp_s > 0 else np.ones_like(tt))
    else:
        tt, yy = np.asarray(sys_or_t, float), np.asarray(y, float)
    info = control.step_info(yy, T=tt)
    return {"rise_time_s": float(info["RiseTime"]), "settling_time_s": float(info["SettlingTime"]),
            "overshoot_pct": float(info["Overshoot"]), "peak": float(info["Peak"]),
            "steady_state": float(info["SteadyStateValue"])}


def lsim(sysd, u: np.ndarray) -> np.ndarray:
    """Response of SISO discrete transfer function sysd to input samples u, from rest
    (scipy lfilter on its coefficients: the same numbers as control.forced_response, in C)."""
    from scipy.signal import lfilter

    num = np.atleast_1d(np.asarray(sysd.num[0][0], float))
    den = np.atleast_1d(np.asarray(sysd.den[0][0], float))
    n = max(len(num), len(den))
    num = np.r_[np.zeros(n - len(num)), num]
    den = np.r_[np.zeros(n - len(den)), den]
    return lfilter(num, den, np.asarray(u, float))


def _gain_margin_db(loop) -> float:
    """Gain margin (dB) of discrete open loop `loop` on a dense frequency grid: 1/|L| where
    its phase first falls through -180 deg; inf if it never does below Nyquist."""
    w = np.geomspace(1e-2, np.pi / loop.dt * 0.999, 3000)
    h = _freqs(loop, w)
    ph = np.unwrap(np.angle(h))
    i = np.nonzero(ph <= -np.pi)[0]
    if len(i) == 0:
        return math.inf
    return -20.0 * math.log10(abs(h[i[0]]))


def _freqs(sysd, w: np.ndarray) -> np.ndarray:
    z = np.exp(1j * w * sysd.dt)
    return np.polyval(np.asarray(sysd.num[0][0], float), z) / np.polyval(np.asarray(sysd.den[0][0], float), z)


def _freq(sysd, w: float) -> complex:
    return complex(sysd(np.exp(1j * w * sysd.dt)))


def _solve_pi(target: complex, w: float, dt: float, td: float) -> tuple[float, float]:
    """kp, ki with (kp*(1 + td/dt*(1 - e^-jwdt)) + ki*dt/(1 - e^-jwdt)) = target."""
    q = 1.0 - np.exp(-1j * w * dt)
    a = 1.0 + td / dt * q
    b = dt / q
    m = np.array([[a.real, b.real], [a.imag, b.imag]])
    kp, ki = np.linalg.solve(m, np.array([target.real, target.imag]))
    return float(kp), float(ki)


@dataclass
class _LoopDesign:
    """What a loop design of either kind carries: margins (margins()) and predicted step
    figures (step_info()) of the loop as designed and with the quantised gain(s), the
    targets it was designed for, and the plant it was designed on."""

    margins: dict
    margins_quantised: dict
    step: dict
    step_quantised: dict
    targets: dict
    plant: object = field(repr=False)


@dataclass
class WheelDesign(_LoopDesign):
    """A wheel design: the gains (continuous values and as quantised raw config values)."""

    gains: WheelGains
    quantised: WheelGains
    raw: dict


def quantise_wheel(g: WheelGains) -> tuple[dict, WheelGains]:
    """Raw config values of the gains (spec units, rounded, checked against the spec range)
    and the gains those raw values stand for. Raises DesignError out of range."""
    raw = {}
    for name, v in zip(WHEEL_SCALES, (g.kff, g.kp, g.ki, g.kd)):
        r = int(round(v / _scale(name)))
        lo, hi = _range(name)
        if not lo <= r <= hi:
            raise DesignError(f"{name} = {v:.6g} is raw {r}, outside the spec's {lo}..{hi} "
                              f"(units of {_scale(name):g})")
        raw[name] = r
    return raw, WheelGains(*(raw[n] * _scale(n) for n in WHEEL_SCALES))


def quantise_heading(kp: float) -> tuple[int, float]:
    """Raw heading_kp and the gain it stands for ((deg/s)/deg). Raises DesignError out of range."""
    r = int(round(kp / _scale(HEADING_SCALE)))
    lo, hi = _range(HEADING_SCALE)
    if not lo < r <= hi:
        raise DesignError(f"heading_kp = {kp:.6g} (deg/s)/deg is raw {r}, outside the spec's {lo + 1}..{hi}")
    return r, r * _scale(HEADING_SCALE)


def _phase_crossing(f, target_deg: float, w_lo: float, w_hi: float) -> float | None:
    """Lowest w in [w_lo, w_hi] where the unwrapped phase of f(w) (deg) falls through target;
    f takes an array of w (rad/s)."""
    ws = np.geomspace(w_lo, w_hi, 2000)
    ph = np.degrees(np.unwrap(np.angle(f(ws))))
    below = np.nonzero(ph <= target_deg)[0]
    if len(below) == 0 or below[0] == 0:
        return None
    i = below[0]
    lo, hi = ws[i - 1], ws[i]
    for _ in range(60):
        mid = math.sqrt(lo * hi)
        pm = math.degrees(float(np.angle(f(np.array([mid]))[0])))
        # compare on the same branch as the grid
        ref = ph[i - 1]
        pm += 360.0 * round((ref - pm) / 360.0)
        if pm > target_deg:
            lo = mid
        else:
            hi = mid
    return math.sqrt(lo * hi)


def _pi_for(p, model, dt: float, pm_deg: float, bandwidth_hz, ratio: float, derivative: bool):
    """(kp, ki, kd, wc rad/s) giving phase margin pm_deg on plant p: at the crossover
    bandwidth_hz if given, else with the PI zero at wc/ratio; kd = kp*TD_WC/wc with
    `derivative`. Raises DesignError."""
    nyq = math.pi / dt
    target_arg = math.radians(-180.0 + pm_deg)

    def td_of(w):
        return TD_WC / w if derivative else 0.0

    if bandwidth_hz is not None:
        wc = 2 * math.pi * bandwidth_hz
        if not 0 < wc < 0.5 * nyq:
            raise DesignError(f"bandwidth {bandwidth_hz:g} Hz: must be above 0 and below a quarter of the "
                              f"control rate ({0.25 / dt:g} Hz)")
        pw = _freq(p, wc)
        kp, ki = _solve_pi(np.exp(1j * target_arg) / pw, wc, dt, td_of(wc))
        if kp <= 0 or ki < 0:
            raise DesignError(f"a {pm_deg:g} deg phase margin is out of reach at a {bandwidth_hz:g} Hz crossover: "
                              f"the plant's phase there is {math.degrees(np.angle(pw)):.0f} deg (a PI needs "
                              f"kp > 0 and ki >= 0; got kp {kp:.3g}, ki {ki:.3g}); try a lower --bandwidth")
    else:
        def shape(w):
            q = 1.0 - np.exp(-1j * w * dt)
            return (1.0 + w / ratio * dt / q + td_of(w) / dt * q) * _freqs(p, w)

        wc = _phase_crossing(shape, -180.0 + pm_deg, 1e-3 / model.tau1_s, 0.45 * nyq)
        if wc is None:
            raise DesignError(f"no crossover gives a {pm_deg:g} deg phase margin below a quarter of the "
                              f"control rate (the loop's phase never reaches {-180 + pm_deg:g} deg)")
        kp = 1.0 / abs(shape(np.array([wc]))[0])
        ki = kp * wc / ratio
    return kp, ki, kp * td_of(wc), wc


def corner_model(model, spread: float):
    """The model of a motor constant `spread` weaker (a fraction): the back-EMF damping falls
    with its square, so the gain rises by 1/(1 - spread) and the time constants by
    1/(1 - spread)^2 (docs/plant.md's drive train, friction aside), the corner the design
    also has to hold on."""
    f = 1.0 - spread
    return model.scaled(gain=1.0 / f, tau=1.0 / (f * f))


def move_response(g: WheelGains, plant, model, speed_mm_s: float, ramp_s: float, t_end: float,
                  deadband: bool = True, loop=None, t=None) -> tuple[np.ndarray, np.ndarray]:
    """(t s, speed mm/s) of the linear wheel loop following the setpoint a move gives (a
    ramp of ramp_s s to speed_mm_s), with the model's dead band as a duty disturbance (the
    Coulomb friction the integral takes up) if `deadband`. loop and t: wheel_loops(g, plant)
    if already computed."""
    import control

    if loop is None or t is None:
        loop, t = wheel_loops(g, plant)
    dt = plant.dt
    tt = np.arange(int(round(t_end / dt)) + 1) * dt
    ref = speed_mm_s * (np.minimum(tt / ramp_s, 1.0) if ramp_s > 0 else np.ones_like(tt))
    yy = lsim(t, ref)
    if deadband and model.deadband > 0:
        sp = control.minreal(plant / (1 + loop), verbose=False)
        yy -= lsim(sp, np.full_like(tt, model.deadband))
    return tt, yy


# derivative time with `derivative`: td = TD_WC/wc (about 14 deg of lead at the crossover)
TD_WC = 0.25

# the search of design_wheel: PI zero at wc/ratio, feed-forward weight (kff = weight/K)
RATIOS = (3.0, 4.0, 6.0, 8.0, 12.0, 16.0, 24.0, 32.0, 48.0)
FF_WEIGHTS = tuple(round(0.1 * i, 1) for i in range(10, -1, -1))


def design_wheel(model, dt: float, pm_deg: float = 60.0, bandwidth_hz: float | None = None,
                 integral_ratio: float | None = None, ff_weight: float | None = None, derivative: bool = False,
                 compute_delay: int = 1, overshoot_pct: float = 5.0, ramp_s: float = 0.1, speed_mm_s: float = 0.0,
                 gm_min_db: float = 6.0, gain_spread: float = 0.0, allow_miss: bool = False,
                 step_s: float | None = None) -> WheelDesign:
    """PI(D)+FF for `model` (ident.Model) at tick dt (s) with phase margin pm_deg: kp and ki
    from the crossover condition (see the module doc); kd = kp*TD_WC/wc with `derivative`.

    Unless given, the PI zero's ratio (integral_ratio) and the feed-forward weight
    (kff = ff_weight/K, 0..1) are searched (RATIOS x FF_WEIGHTS) for the least integrated
    absolute error (IAE) in following the setpoint the profile gives a move (a ramp of
    ramp_s s to speed_mm_s, against the model's dead band as a duty disturbance; speed 0:
    the linear part alone) among the designs that overshoot it by at most overshoot_pct,
    also on corner_model(model, gain_spread) (the feed-forward then over-drives and the
    wheel lags more), with a gain margin of at least gm_min_db, all judged with the
    quantised gains. `step` (unit step) and `move` (the ramp, dead band included) responses
    are reported; they last step_s s (default: the ramp plus 8 times the model's lag, at
    least 0.5 s); overshoot is measured against the setpoint. Raises DesignError when the
    targets cannot be met (allow_miss: return the least-overshoot design instead)."""
    if not (0.0 < pm_deg < 90.0):
        raise DesignError(f"phase margin target {pm_deg:g} deg: must be between 0 and 90")
    p = plant_d(model, dt, compute_delay)
    if step_s is None:
        step_s = max(0.5, ramp_s + 8.0 * (model.tau1_s + model.tau2_s + model.delay_s))
    model_hi = corner_model(model, gain_spread)
    p_hi = plant_d(model_hi, dt, compute_delay)
    ratios = (integral_ratio,) if integral_ratio else RATIOS
    weights = (ff_weight,) if ff_weight is not None else FF_WEIGHTS
    chosen, fallback, last_err, tried = None, None, None, 0
    for ratio in ratios:
        try:
            kp, ki, kd, wc = _pi_for(p, model, dt, pm_deg, bandwidth_hz, ratio, derivative)
        except DesignError as e:
            last_err = e
            continue
        for w in weights:
            g = WheelGains(w / model.gain_mm_s, kp, ki, kd)
            try:
                raw, gq = quantise_wheel(g)
            except DesignError as e:
                last_err = e
                continue
            loop, t = wheel_loops(gq, p)
            if not stable(loop):
                continue
            tried += 1
            tt, yy = move_response(gq, p, model, speed_mm_s or 1.0, ramp_s, step_s, deadband=speed_mm_s > 0,
                                   loop=loop, t=t)
            ref = np.minimum(tt / ramp_s, 1.0) if ramp_s > 0 else np.ones_like(tt)
            yy = yy / (speed_mm_s or 1.0)
            ov = max(float(yy.max()) - 1.0, 0.0) * 100.0
            if gain_spread > 0 and ov <= overshoot_pct:
                _, yh = move_response(gq, p_hi, model_hi, speed_mm_s or 1.0, ramp_s, step_s,
                                      deadband=speed_mm_s > 0)
                ov = max(ov, (float(yh.max()) / (speed_mm_s or 1.0) - 1.0) * 100.0)
            iae = float(np.sum(np.abs(ref - yy)) * dt)
            gm = _gain_margin_db(loop)
            cand = (g, raw, gq, wc, ratio, w)
            if fallback is None or ov < fallback[0]:
                fallback = (ov, cand)
            if ov <= overshoot_pct and gm >= gm_min_db and (chosen is None or iae < chosen[0]):
                chosen = (iae, cand)
        if bandwidth_hz is not None:
            break
    if chosen is None:
        if fallback is None:
            raise last_err or DesignError("no stable wheel design")
        if not allow_miss:
            raise DesignError(f"no design within the {overshoot_pct:g} % overshoot limit and a {gm_min_db:g} dB "
                              f"gain margin at a {pm_deg:g} deg phase margin ({tried} candidates; the least "
                              f"overshoot was {fallback[0]:.1f} %)")
        chosen = (None, fallback[1])
    g, raw, gq, wc, ratio, w = chosen[1]
    out = []
    for gg in (g, gq):
        loop, t = wheel_loops(gg, p)
        if not stable(loop):
            raise DesignError(f"the designed wheel loop is unstable (kp {gg.kp:.4g}, ki {gg.ki:.4g})")
        tt, yy = move_response(gg, p, model, speed_mm_s or 1.0, ramp_s, step_s, deadband=speed_mm_s > 0,
                               loop=loop, t=t)
        move = step_info(tt, yy / (speed_mm_s or 1.0))
        move["overshoot_pct"] = max(move["peak"] - 1.0, 0.0) * 100.0  # against the setpoint
        out.append((margins(loop), {"step": step_info(t, t_end=step_s), "move": move}))
    targets = {"phase_margin_deg": pm_deg, "bandwidth_hz": bandwidth_hz, "overshoot_pct": overshoot_pct,
               "ramp_s": ramp_s, "speed_mm_s": speed_mm_s, "gain_margin_min_db": gm_min_db,
               "gain_spread": gain_spread,
               "integral_ratio": ratio, "ff_weight": w, "derivative": derivative,
               "compute_delay_ticks": compute_delay, "control_rate_hz": 1.0 / dt,
               "crossover_design_hz": wc / (2 * math.pi)}
    return WheelDesign(gains=g, quantised=gq, raw=raw, margins=out[0][0], margins_quantised=out[1][0],
                       step=out[0][1], step_quantised=out[1][1], targets=targets, plant=p)


def heading_plant(wheel_t):
    """G_h(z) = T_w(z) * dt/(z - 1): turn-rate reference (deg/s) -> heading (deg), with the
    closed wheel loop T_w (setpoint -> speed) carrying the rate."""
    import control

    dt = wheel_t.dt
    return control.minreal(wheel_t * control.tf([dt], [1.0, -1.0], dt), verbose=False)


@dataclass
class HeadingDesign(_LoopDesign):
    """heading_kp ((deg/s)/deg) as designed and quantised, and its raw config value."""

    kp: float
    kp_quantised: float
    raw: int


def design_heading(wheel_t, pm_deg: float = 60.0, bandwidth_hz: float | None = None,
                   overshoot_pct: float = 5.0, gm_min_db: float = 6.0, also_on=(),
                   step_s: float = 2.0) -> HeadingDesign:
    """heading_kp for a phase margin pm_deg (or a crossover bandwidth_hz) on top of the
    closed wheel loop wheel_t; if that gain's unit heading step overshoots by more than
    overshoot_pct or its gain margin is below gm_min_db, on wheel_t or on any closed wheel
    loop of `also_on` (e.g. of corner_model), the largest smaller gain that meets both
    everywhere (bisection: the phase margin then exceeds the target). Raises DesignError."""
    import control

    gh = heading_plant(wheel_t)
    dt = gh.dt
    if not (0.0 < pm_deg < 90.0):
        raise DesignError(f"phase margin target {pm_deg:g} deg: must be between 0 and 90")
    if bandwidth_hz is not None:
        wc = 2 * math.pi * bandwidth_hz
        if not 0 < wc < 0.25 * math.pi / dt:
            raise DesignError(f"bandwidth {bandwidth_hz:g} Hz: must be above 0 and below an eighth of the control rate")
    else:
        wc = _phase_crossing(lambda w: _freqs(gh, w), -180.0 + pm_deg, 1e-3, 0.45 * math.pi / dt)
        if wc is None:
            raise DesignError(f"no heading gain gives a {pm_deg:g} deg phase margin")
    kp = 1.0 / abs(_freq(gh, wc))

    plants = [gh] + [heading_plant(w) for w in also_on]

    def ok(k):
        for g in plants:
            if not stable(k * g):
                return False
            t = control.feedback(k * g, 1)
            if step_info(t, t_end=step_s)["overshoot_pct"] > overshoot_pct or _gain_margin_db(k * g) < gm_min_db:
                return False
        return True

    if not ok(quantise_heading(kp)[1]):
        lo, hi = 0.0, kp
        for _ in range(30):
            mid = 0.5 * (lo + hi)
            if ok(mid):
                lo = mid
            else:
                hi = mid
        kp = lo
        if kp <= 0:
            raise DesignError(f"no heading gain keeps the heading step within {overshoot_pct:g} % overshoot "
                              f"with a {gm_min_db:g} dB gain margin")
    raw, kq = quantise_heading(kp)
    while raw > 1 and not ok(kq):  # rounding up may cross a limit
        raw -= 1
        kq = raw * _scale(HEADING_SCALE)
    out = []
    for k in (kp, kq):
        loop = k * gh
        t = control.feedback(loop, 1)
        if not stable(loop):
            raise DesignError(f"the designed heading loop is unstable (heading_kp {k:.4g})")
        out.append((margins(loop), {"step": step_info(t, t_end=step_s)}))
    targets = {"phase_margin_deg": pm_deg, "bandwidth_hz": bandwidth_hz, "overshoot_pct": overshoot_pct,
               "gain_margin_min_db": gm_min_db, "crossover_design_hz": wc / (2 * math.pi)}
    return HeadingDesign(kp=kp, kp_quantised=kq, raw=raw, margins=out[0][0], margins_quantised=out[1][0],
                         step=out[0][1], step_quantised=out[1][1], targets=targets, plant=gh)


def heading_response(wheel_t, kp: float, target_deg: float, rate_dps: float, accel_dps2: float,
                     t_end: float) -> tuple[np.ndarray, np.ndarray]:
    """(t s, heading deg) of a heading select from 0 to target_deg as the firmware's HdgSel
    law shapes it (turn.c, profile.c), on the linear closed wheel loop wheel_t: the rate
    reference moves toward min(kp*|e|, rate_dps, the braking speed sqrt(2*accel*|e|)) in the
    error's direction by at most accel_dps2*dt per tick."""
    import control

    ss = control.tf2ss(wheel_t)
    a, b, c, d = (np.asarray(m, float) for m in (ss.A, ss.B, ss.C, ss.D))
    dt = wheel_t.dt
    n = int(round(t_end / dt)) + 1
    x = np.zeros((a.shape[0], 1))
    ref = 0.0
    hdg = 0.0
    out = np.zeros(n)
    dv = accel_dps2 * dt
    for k in range(n):
        out[k] = hdg
        e = target_deg - hdg
        goal = min(kp * abs(e), rate_dps, math.sqrt(2.0 * accel_dps2 * abs(e))) * (1.0 if e >= 0 else -1.0)
        ref += min(max(goal - ref, -dv), dv)
        rate = float((c @ x + d * ref)[0, 0])
        x = a @ x + b * ref
        hdg += rate * dt
    return np.arange(n) * dt, out
