"""Ground effect (gna.ground_effect): the cited formula, the environment option, nothing changed when off."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gna.aircraft import load_aircraft
from gna.atmosphere import ISA, Environment
from gna.eom import Controls, State, aero_coefficients, derivatives, loads, wind_forces
from gna.errors import DomainError, InputError
from gna.ground_effect import GroundEffect, induced_drag_factor, lift_factor
from gna.trim import trim_level

AC = load_aircraft("twin-otter")
B = AC.geometry.b
A = B * B / AC.geometry.S
FREE = Environment(ISA())
GE = Environment(ISA(), ground_effect=GroundEffect(elevation=0.0))


def _state(h, alpha=0.08, q=0.02):
    return State(0.0, 0.0, -h, 45.0, 0.01, 0.2, alpha, 0.03, 0.05, 0.01, q, -0.02)


U = Controls(5000.0, 0.1, 0.02, -0.05, 0.01)


def test_mccormick_factor_values():
    # phi = (16 h/b)^2 / (1 + (16 h/b)^2), McCormick 1995 ch. 7
    assert induced_drag_factor(0.3) == pytest.approx(4.8**2 / (1 + 4.8**2), rel=1e-15)
    assert induced_drag_factor(0.1) == pytest.approx(2.56 / 3.56, rel=1e-15)
    assert induced_drag_factor(10.0) > 0.9999
    K = 2 * math.pi / (math.pi * 0.8 * A)
    assert lift_factor(0.3, A) == pytest.approx((1 + K) / (1 + K * induced_drag_factor(0.3)), rel=1e-15)


def test_lift_and_drag_change_match_formula_at_0p3_span():
    h = 0.3 * B
    s = _state(h)
    free, ge = loads(AC, FREE, s, U), loads(AC, GE, s, U)
    x2 = (16 * 0.3) ** 2
    phi = x2 / (1 + x2)
    K = 2 * math.pi / (math.pi * 0.8 * A)
    kL = (1 + K) / (1 + K * phi)
    CL, CD = free.force_coeffs.CL, free.force_coeffs.CD
    assert ge.force_coeffs.CL / CL == pytest.approx(kL, rel=1e-14)
    assert ge.force_coeffs.CD - CD == pytest.approx((phi * kL * kL - 1) * CL * CL / (math.pi * 0.8 * A), rel=1e-12)
    # the aerodynamic lift force (stability axes, beta rotation leaves it alone) scales by k_L too
    qS = free.qbar * AC.geometry.S
    assert (ge.Za - free.Za) == pytest.approx(-(kL - 1) * qS * CL, rel=1e-12)
    # side force and moment coefficients unchanged
    for c in ("CY", "Cl", "Cm", "Cn"):
        assert getattr(ge.moment_coeffs, c) == getattr(free.moment_coeffs, c)
    assert 1.008 < kL < 1.009 and 0.958 < phi < 0.959


def test_off_changes_nothing():
    s = State(*[np.linspace(0.1, 1.0, 5) * v for v in _state(800.0)])
    a = derivatives(AC, FREE, s, U)
    b = derivatives(AC, Environment(ISA(), ground_effect=None), s, U)
    for x, y in zip(a, b):
        assert np.array_equal(x, y)
    assert FREE.describe() == ISA().describe()
    # the free-air path is the former one: coefficients of the aerodynamic model, forces of wind_forces
    ld, c = loads(AC, FREE, s, U), aero_coefficients(AC, s, U)
    for x, y in zip(ld.force_coeffs, c):
        assert np.array_equal(x, y)
    for x, y in zip(ld[4:7], wind_forces(AC, FREE, s, U, c, ld.qbar)[:3]):
        assert np.array_equal(x, y)


def test_far_from_ground_vanishes_and_arrays_broadcast():
    h = np.array([0.1, 0.3, 1.0, 50.0]) * B
    s = _state(h)
    ratio = loads(AC, GE, s, U).force_coeffs.CL / loads(AC, FREE, s, U).force_coeffs.CL
    assert np.all(np.diff(ratio) < 0) and ratio[-1] == pytest.approx(1.0, abs=1e-6)


def test_series_evaluation_matches_pointwise():
    from planners.series import Series

    z = Series.variable(np.zeros(1), 6) * (-0.5) - 0.3 * B  # climbing at 0.5 m/s from 0.3 span
    ld = loads(AC, GE, _state(0.0)._replace(z=z), U)
    for dt in (0.0, 0.1):
        ref = loads(AC, GE, _state(0.3 * B + 0.5 * dt), U).force_coeffs
        assert float(ld.force_coeffs.CL.eval(dt)[0]) == pytest.approx(ref.CL, rel=1e-12)
        assert float(ld.force_coeffs.CD.eval(dt)[0]) == pytest.approx(ref.CD, rel=1e-12)


def test_trim_in_ground_effect_needs_less_alpha_and_thrust():
    h = 0.3 * B
    tf, tg = trim_level(AC, 45.0, altitude=h, env=FREE), trim_level(AC, 45.0, altitude=h, env=GE)
    assert tg.values["alpha"] < tf.values["alpha"] and tg.values["F"] < tf.values["F"]


def test_bad_input_and_below_ground():
    with pytest.raises(InputError, match="Oswald"):
        GroundEffect(oswald=1.5)
    with pytest.raises(InputError, match="elevation"):
        GroundEffect(elevation=float("nan"))
    with pytest.raises(InputError, match="GroundEffect"):
        Environment(ISA(), ground_effect=0.3)
    env = Environment(ISA(), ground_effect=GroundEffect(elevation=100.0))
    env.check_altitude(100.5, "trim")
    with pytest.raises(DomainError, match="at or below the ground at 100 m"):
        env.check_altitude([150.0, 99.0], "plan node", times=[0.0, 2.0])
