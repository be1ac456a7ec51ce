"""The per-step conversions of the JSBSim loop: the fused step is the domain test then the state, bit for bit."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gna.trajectory import DOMAIN, domain_margins
from harness.engines.jsbsim.states import StateConverter, inside_test

BOUNDS = (
    DOMAIN,
    DOMAIN.__class__(ground=12.0, h_min=-2000.0, h_max=20000.0, atmosphere="the ISA"),
    DOMAIN.__class__(h_min=-2000.0),
)


def _states(rng, n=400):
    """Wind-frame states around and across every bound, with non-finite values among them."""
    X = np.zeros((n, 12))
    X[:, 2] = rng.choice([-1e3, -12.0, -11.9, -12.1, 2000.0, 1999.0, -20001.0, -19999.0], n)
    X[:, 3] = rng.choice([0.5, 1.0, 1.5, 100.0, 2999.0, 3000.0, 3001.0], n)
    X[:, 4] = rng.choice([0.1, 0.5 * math.pi, 0.5 * math.pi - 1e-7, -1.2], n)
    X[:, 6] = rng.choice([0.1, 0.5 * math.pi, 1.6, -1.6, -0.3], n)
    X[:, 7] = rng.choice([0.0, 0.5 * math.pi, 0.35, -0.5 * math.pi + 1e-7], n)
    bad = rng.random((n, 12)) < 0.03
    X[bad] = rng.choice([math.nan, math.inf, -math.inf], int(bad.sum()))
    return X


@pytest.mark.parametrize("bounds", BOUNDS)
def test_inside_test_is_every_domain_margin_positive(bounds):
    inside = inside_test(bounds)
    for x in _states(np.random.default_rng(1)).tolist():
        expected = all(m > 0 for m in domain_margins(x, bounds))
        assert inside(x[2], x[3], x[4], x[6], x[7]) is expected, x


def _raw(rng, x0):
    """JSBSim raw outputs (position nodes then STATE_NODES) of a state near x0, in JSBSim's units."""
    ft = 0.3048
    lat, lon = rng.normal(0.0, 1e-5, 2)
    h = -x0[2] / ft + rng.normal(0.0, 10.0)
    angles = rng.normal(0.0, 0.3, 8) + np.r_[0.0, x0[5], 0.05, 0.0, 0.2, 0.05, x0[5], 0.0][:8]
    rates = rng.normal(0.0, 0.1, 3)
    return [lat, lon, h, x0[3] / ft + rng.normal(0.0, 5.0), *angles[:7], *rates]


@pytest.mark.parametrize("bounds", BOUNDS)
def test_step_is_check_then_scalar(bounds):
    rng = np.random.default_rng(2)
    x0 = np.array([10.0, -5.0, -1000.0, 90.0, 0.02, 3.0, 0.05, 0.01, 0.3, 0.0, 0.0, 0.0])
    fused, apart = StateConverter(x0, 2.09e7, None, bounds), StateConverter(x0, 2.09e7, None, bounds)
    for k in range(300):
        raw = _raw(rng, x0)
        if k % 7 == 0:
            raw[3 + rng.integers(0, 7)] = rng.choice([math.nan, math.inf, 0.1])  # outside, or not finite
        if k % 11 == 0:
            raw[5] += 2 * math.pi * rng.integers(-2, 3)  # the track wraps
        t = 0.01 * k
        bad, x = fused.step(t, raw)
        expected_bad = apart.check(t, raw[3:10] + raw[2:3])
        assert bad == expected_bad
        if bad is None:
            assert np.array_equal(np.array(x), apart.scalar(raw), equal_nan=True)
        else:
            assert x is None
            # a stop ends the run: start both again from the same continued angles
            fused, apart = StateConverter(x0, 2.09e7, None, bounds), StateConverter(x0, 2.09e7, None, bounds)
        assert np.array_equal([fused.chi, fused.mu], [apart.chi, apart.mu], equal_nan=True)
