"""navkit.tune.design: the wheel and heading designs meet their targets on known plants,
checked with python-control's margins on loops built here from the firmware's law
(wheel.c: duty = kff*sp + kp*e + I, I += ki*dt*e; the plant sampled with a hold at the tick,
its dead time plus one tick of computation as whole ticks of delay)."""

import math

import control
import numpy as np
import pytest

from navkit import protocol
from navkit.tune import design
from navkit.tune.ident import Model

DT = 0.001  # s: the default 1 kHz tick

# python-control warns when its margins switch to the frequency-response method
pytestmark = pytest.mark.filterwarnings("ignore:stability_margins:UserWarning")

PLANTS = {
    "reference": Model("fopdt", 650.0, 0.040, 0.0, 0.005, 0.03),
    "heavy_weak": Model("fopdt", 420.0, 0.110, 0.0, 0.006, 0.06),
    "second_order": Model("sopdt", 600.0, 0.050, 0.012, 0.003, 0.02),
    "slow_tick_delay": Model("fopdt", 650.0, 0.040, 0.0, 0.015, 0.03),
}


def _loop(model: Model, g: design.WheelGains, dt: float = DT):
    """The open loop built from scratch: C(z) P(z) z^-(round(L/dt) + 1)."""
    z = control.tf([1, 0], [1], dt)
    den = np.polymul([model.tau1_s, 1], [model.tau2_s, 1]) if model.kind == "sopdt" else [model.tau1_s, 1]
    p = control.c2d(control.tf([model.gain_mm_s], den), dt, "zoh")
    delay = control.tf([1], [1] + [0] * (round(model.delay_s / dt) + 1), dt)
    c = g.kp + g.ki * dt * z / (z - 1) + (g.kd / dt) * (z - 1) / z
    return c * p * delay


def _scale(name):
    return next(f.scale for f in protocol.SPEC.messages["micro_cfg_motion"].fields if f.name == name)


@pytest.mark.parametrize("name", sorted(PLANTS))
def test_wheel_design_meets_targets(name):
    m = PLANTS[name]
    d = design.design_wheel(m, DT, pm_deg=60.0, speed_mm_s=200.0, ramp_s=0.1)
    gm, pm, _, _, wgc, _ = control.stability_margins(_loop(m, d.quantised))
    assert pm == pytest.approx(60.0, abs=1.5)          # quantisation moves it a little
    assert 20 * math.log10(gm) >= 6.0
    assert d.margins_quantised["phase_margin_deg"] == pytest.approx(pm, abs=0.5)
    assert d.margins_quantised["crossover_hz"] == pytest.approx(wgc / 2 / math.pi, rel=0.02)
    assert d.step_quantised["move"]["overshoot_pct"] <= 5.0
    # the closed loop follows the setpoint: no steady error (integral action)
    assert d.step_quantised["step"]["steady_state"] == pytest.approx(1.0, abs=0.02)


def test_phase_margin_target_is_an_option():
    m = PLANTS["reference"]
    for pm_target in (45.0, 70.0):
        d = design.design_wheel(m, DT, pm_deg=pm_target, overshoot_pct=50.0)
        _, pm, *_ = control.stability_margins(_loop(m, d.gains))
        assert pm == pytest.approx(pm_target, abs=0.5)


def test_bandwidth_option_sets_the_crossover():
    m = PLANTS["reference"]
    d = design.design_wheel(m, DT, pm_deg=60.0, bandwidth_hz=6.0, allow_miss=True)
    _, pm, _, _, wgc, _ = control.stability_margins(_loop(m, d.gains))
    assert wgc / (2 * math.pi) == pytest.approx(6.0, rel=0.01)
    assert pm == pytest.approx(60.0, abs=0.5)


def test_derivative_option():
    m = PLANTS["second_order"]
    d = design.design_wheel(m, DT, derivative=True, speed_mm_s=200.0, ramp_s=0.1)
    assert d.quantised.kd > 0
    _, pm, *_ = control.stability_margins(_loop(m, d.quantised))
    assert pm == pytest.approx(60.0, abs=2.0)


def test_quantised_to_the_spec_units():
    d = design.design_wheel(PLANTS["reference"], DT, speed_mm_s=200.0, ramp_s=0.1)
    for name, attr in zip(design.WHEEL_SCALES, ("kff", "kp", "ki", "kd")):
        raw = d.raw[name]
        assert isinstance(raw, int) and 0 <= raw <= 60000
        assert getattr(d.quantised, attr) == pytest.approx(raw * _scale(name))
        assert abs(getattr(d.gains, attr) - getattr(d.quantised, attr)) <= 0.5 * _scale(name) + 1e-12


@pytest.mark.parametrize("kw,match", [
    ({"bandwidth_hz": 300.0}, "must be above 0 and below a quarter"),
    ({"bandwidth_hz": 60.0}, "out of reach at a 60 Hz crossover"),
    ({"pm_deg": 95.0}, "between 0 and 90"),
])
def test_unreachable_targets(kw, match):
    with pytest.raises(design.DesignError, match=match):
        design.design_wheel(PLANTS["reference"], DT, **kw)


def test_gain_out_of_the_spec_range():
    # a plant so weak that kp would need more than 60000 raw units
    with pytest.raises(design.DesignError, match="outside the spec's 0..60000"):
        design.design_wheel(Model("fopdt", 0.5, 0.040, 0.0, 0.005, 0.0), DT)


@pytest.mark.parametrize("name", ["reference", "heavy_weak"])
def test_heading_design_on_the_wheel_loops(name):
    m = PLANTS[name]
    d = design.design_wheel(m, DT, speed_mm_s=200.0, ramp_s=0.1)
    _, tw = design.wheel_loops(d.quantised, design.plant_d(m, DT))
    h = design.design_heading(tw, pm_deg=60.0)
    # the heading loop built here: kp * T_w * dt/(z - 1)
    loop = h.kp_quantised * tw * control.tf([DT], [1, -1], DT)
    gm, pm, *_ = control.stability_margins(loop)
    assert pm >= 59.0 and 20 * math.log10(gm) >= 6.0
    assert h.step_quantised["step"]["overshoot_pct"] <= 5.0
    assert h.raw == round(h.kp_quantised / 0.01)
    # the HdgSel law's response (rate and acceleration limited) arrives without overshooting 5 %
    t, hdg = design.heading_response(tw, h.kp_quantised, 90.0, 60.0, 180.0, 4.0)
    assert hdg[-1] == pytest.approx(90.0, abs=0.5)
    assert hdg.max() <= 90.0 * 1.05


def test_stability_from_the_characteristic_polynomial():
    # an integrator with gain g in unity feedback: z - 1 + g, stable for 0 < g < 2
    for g, expected in ((0.5, True), (1.9, True), (2.1, False), (-0.1, False)):
        assert design.stable(control.tf([g], [1, -1], DT)) is expected
    # the heavy plant's wheel loop on the corner model: stable, as python-control's own
    # closed loop (whose poles the stability test must agree with) says
    m = design.corner_model(PLANTS["heavy_weak"], 0.2)
    d = design.design_wheel(PLANTS["heavy_weak"], DT, speed_mm_s=200.0, ramp_s=0.1)
    loop, _ = design.wheel_loops(d.quantised, design.plant_d(m, DT))
    assert design.stable(loop) == bool(np.all(np.abs(control.feedback(loop, 1).poles()) < 1.0))
