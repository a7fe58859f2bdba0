"""navkit.tune.ident: the least-squares fits recover known wheel models from synthetic
records with measurement noise, within stated tolerances."""

import numpy as np
import pytest

from navkit.tune.ident import IdentError, Model, fit, fit_both, nrmse, simulate

TS = 0.01  # s: a 100 Hz record


def _duty(n: int = 700) -> np.ndarray:
    """Steps of both signs held for 0.7 s each, from rest (the shape of a step experiment)."""
    u = np.zeros(n)
    for i, v in enumerate((0.2, 0.5, 0.3, -0.4, 0.6, 0.1, -0.2, 0.35, 0.0)):
        u[30 + i * 70:30 + (i + 1) * 70] = v
    return u


def _noisy(model: Model, seed: int, rel: float = 0.03):
    u = _duty()
    y = simulate(model, u, TS)
    rng = np.random.default_rng(seed)
    return u, y + rng.normal(0.0, rel * np.std(y), len(y))


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_fopdt_recovered(seed):
    # tolerances: gain 2 %, time constant 5 %, dead time 1.5 ms, dead band 0.005 duty
    true = Model("fopdt", 650.0, 0.040, 0.0, 0.013, 0.03)
    u, y = _noisy(true, seed)
    f = fit(u, y, TS, "fopdt")
    m = f.model
    assert m.gain_mm_s == pytest.approx(true.gain_mm_s, rel=0.02)
    assert m.tau1_s == pytest.approx(true.tau1_s, rel=0.05)
    assert abs(m.delay_s - true.delay_s) < 1.5e-3
    assert abs(m.deadband - true.deadband) < 0.005
    assert f.nrmse < 0.05  # the noise alone is 3 % of the output's spread


@pytest.mark.parametrize("seed", [1, 2])
def test_sopdt_recovered(seed):
    # second order: gain 2 %, the slow pole 10 %, the sum tau1 + tau2 + L (the lag) 5 %
    true = Model("sopdt", 500.0, 0.060, 0.015, 0.004, 0.02)
    u, y = _noisy(true, seed, rel=0.02)
    both = fit_both(u, y, TS)
    m = both["sopdt"].model
    assert m.gain_mm_s == pytest.approx(true.gain_mm_s, rel=0.02)
    assert m.tau1_s == pytest.approx(true.tau1_s, rel=0.10)
    lag = lambda x: x.tau1_s + x.tau2_s + x.delay_s  # noqa: E731
    assert lag(m) == pytest.approx(lag(true), rel=0.05)
    # the second-order model explains a second-order record better than the first-order one
    assert both["sopdt"].nrmse < both["fopdt"].nrmse


def test_fit_at_the_datalog_rate():
    # a 50 Hz record (the co-simulated datalog's rate) of a 40 ms plant still gives K and tau
    true = Model("fopdt", 650.0, 0.040, 0.0, 0.005, 0.03)
    u = np.repeat(_duty(350)[::2], 1)
    y = simulate(true, u, 0.02) + np.random.default_rng(5).normal(0, 3.0, len(u))
    m = fit(u, y, 0.02, "fopdt").model
    assert m.gain_mm_s == pytest.approx(650.0, rel=0.03)
    assert m.tau1_s == pytest.approx(0.040, rel=0.10)


def test_simulate_holds_fractional_delay():
    # a dead time of half a sample gives the average of the neighbouring whole-sample responses
    # for a first-order lag sampled with a hold: its first sample after the step is in between
    u = np.r_[0.0, np.ones(100)]
    y0 = simulate(Model("fopdt", 100.0, 0.05, 0.0, 0.0), u, TS)
    y1 = simulate(Model("fopdt", 100.0, 0.05, 0.0, TS), u, TS)
    yh = simulate(Model("fopdt", 100.0, 0.05, 0.0, TS / 2), u, TS)
    assert y1[2] < yh[2] < y0[2]
    assert yh[-1] == pytest.approx(y0[-1], rel=1e-3)


def test_nrmse():
    y = np.array([1.0, 2.0, 3.0])
    assert nrmse(y, y) == 0.0
    assert nrmse(y, np.full(3, 2.0)) == pytest.approx(1.0)


@pytest.mark.parametrize("u,y,match", [
    (np.zeros(100), np.zeros(100), "no excitation"),
    (np.ones(5), np.ones(5), "at least 20 samples"),
    (np.r_[np.zeros(50), np.ones(50)], np.r_[np.zeros(50), np.full(50, np.nan)], "non-finite"),
])
def test_unfittable(u, y, match):
    with pytest.raises(IdentError, match=match):
        fit(u, y, TS)


def test_no_stable_model():
    # speed that grows without bound under a constant duty is not a stable wheel
    u = np.r_[np.zeros(10), np.ones(90)]
    y = np.r_[np.zeros(10), np.exp(np.arange(90) * 0.1)]
    with pytest.raises(IdentError, match="no stable first-order model"):
        fit(u, y, TS)
