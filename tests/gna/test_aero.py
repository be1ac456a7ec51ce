"""Term-table aerodynamics: transcription self-check, flat/H split, dispatch."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gna.aero import AERO_VARIABLES, AeroState, TermTable, format_monomial, parse_monomial
from gna.aircraft import load_aircraft
from gna.atmosphere import Environment
from gna.eom import Controls, HValues, State, loads
from gna.errors import InputError

D = math.radians


@pytest.mark.parametrize(
    "name, expected",
    [
        # validation.md of shared/data/gna: computed self-check at alpha 10, beta 5, rates 0.01, de -2, da 3, dr 4 deg.
        ("f16c", (0.13003, -0.07854, 1.04748, -0.01595, -0.14334, 0.01144)),
        ("a7", (0.06875, -0.06981, 0.63406, -0.01443, -0.19733, 0.00069)),
    ],
)
def test_transcription_self_check(name, expected):
    c = load_aircraft(name).aero.coefficients(AeroState(D(10), D(5), 0.01, 0.01, 0.01, D(3), D(-2), D(4)))
    np.testing.assert_allclose(np.array(c, dtype=float), expected, atol=5e-6)


def test_alpha_sweep_self_check():
    a = load_aircraft("f16c").aero
    c = a.coefficients(AeroState(np.array([D(0), D(10), D(30)]), 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0))
    np.testing.assert_allclose(c.CD, [0.0340, 0.0988, 0.8413], atol=5e-5)
    np.testing.assert_allclose(c.CL, [0.0740, 0.7725, 1.7143], atol=5e-5)
    np.testing.assert_allclose(c.Cm, [-0.0240, -0.0744, -0.1819], atol=5e-5)


def test_gna45_structure():
    for name in ("f16c", "a7"):
        t = load_aircraft(name).aero
        assert t.structure == "gna45" and len(t) == 45
        counts = {c: len(t.terms_of(c)) for c in ("CD", "CY", "CL", "Cl", "Cm", "Cn")}
        assert counts == {"CD": 10, "CY": 5, "CL": 8, "Cl": 5, "Cm": 10, "Cn": 7}
        assert [x.index for x in t.terms] == list(range(1, 46))


def test_monomial_round_trip():
    for text in ("1", "alpha", "alpha^2*qhat", "beta^3", "alpha^3*dm"):
        assert format_monomial(parse_monomial(text)) == text
    assert parse_monomial("alpha*de") == parse_monomial("alpha*dm")
    with pytest.raises(InputError, match="unknown aerodynamic variable"):
        parse_monomial("alpha*flap")


def test_bad_term_value_rejected():
    with pytest.raises(InputError, match="value is nan"):
        TermTable.from_records([{"coef": "CD", "monomial": "1", "value": float("nan")}])


def _random_states(n, rng):
    s = State(
        0.0,
        0.0,
        -1000.0,
        rng.uniform(80, 200, n),
        rng.uniform(-0.3, 0.3, n),
        0.0,
        rng.uniform(-0.1, 0.5, n),
        rng.uniform(-0.3, 0.3, n),
        rng.uniform(-1, 1, n),
        rng.uniform(-1, 1, n),
        rng.uniform(-1, 1, n),
        rng.uniform(-1, 1, n),
    )
    u = Controls(
        rng.uniform(0, 5e4, n), 0.0, rng.uniform(-0.3, 0.3, n), rng.uniform(-0.3, 0.3, n), rng.uniform(-0.3, 0.3, n)
    )
    return s, u


@pytest.mark.parametrize("name", ["f16c", "a7"])
def test_simple_force_coefficients_depend_on_alpha_beta_only(name):
    """Simple model: changing rates and surfaces leaves the force coefficients unchanged."""
    a = load_aircraft(name)
    env = Environment()
    rng = np.random.default_rng(1)
    s, u = _random_states(500, rng)
    s2 = s._replace(p=rng.uniform(-1, 1, 500), q=rng.uniform(-1, 1, 500), r=rng.uniform(-1, 1, 500))
    u2 = u._replace(dl=rng.uniform(-0.3, 0.3, 500), dm=rng.uniform(-0.3, 0.3, 500), dn=rng.uniform(-0.3, 0.3, 500))
    l1 = loads(a, env, s, u, model="simple")
    l2 = loads(a, env, s2, u2, model="simple")
    for c1, c2 in zip(l1.force_coeffs[:3], l2.force_coeffs[:3]):
        np.testing.assert_array_equal(c1, c2)
    # ... while in the full model they do change,
    lf1, lf2 = loads(a, env, s, u), loads(a, env, s2, u2)
    assert np.max(np.abs(np.asarray(lf1.force_coeffs.CL) - lf2.force_coeffs.CL)) > 1e-3
    # ... and changing alpha or beta changes them in the simple model.
    l3 = loads(a, env, s._replace(alpha=s.alpha + 0.05, beta=s.beta + 0.05), u, model="simple")
    assert np.all(np.abs(np.asarray(l3.force_coeffs.CL) - l1.force_coeffs.CL) > 0)
    # Only flat terms survive in the force coefficients when the H values are zero.
    flat = [t for t in a.aero.terms if t.coefficient in ("CD", "CY", "CL") and t.is_flat]
    CL_flat = sum(t.value * s.alpha ** t.exponents[0] * s.beta ** t.exponents[1] for t in flat if t.coefficient == "CL")
    np.testing.assert_allclose(l1.force_coeffs.CL, CL_flat, rtol=1e-14)


@pytest.mark.parametrize("name", ["f16c", "a7"])
def test_simple_with_h_values_equals_full(name):
    """With the H terms evaluated at given values, the simple model equals the full model at those values."""
    a = load_aircraft(name)
    env = Environment()
    s, u = _random_states(300, np.random.default_rng(2))
    h = HValues(s.p, s.q, s.r, u.dl, u.dm, u.dn)
    simple = loads(a, env, s, u, model="simple", h=h)
    full = loads(a, env, s, u, model="full")
    for f1, f2 in zip(simple, full):
        np.testing.assert_allclose(np.asarray(f1, dtype=float), np.asarray(f2, dtype=float), rtol=1e-15, atol=0)
    # At other H values they differ.
    other = loads(a, env, s, u, model="simple", h=HValues(dm=0.1))
    assert np.max(np.abs(np.asarray(other.X) - full.X)) > 1.0


def test_complex_step_through_coefficients():
    """The coefficient evaluation is complex-analytic (complex-step derivatives are exact)."""
    a = load_aircraft("f16c").aero
    x, h = 0.2, 1e-30
    c = a.coefficients(AeroState(x + 1j * h, 0.05, 0.01, 0.02, 0.0, 0.0, -0.05, 0.0))
    fd = (
        np.array(a.coefficients(AeroState(x + 1e-7, 0.05, 0.01, 0.02, 0.0, 0.0, -0.05, 0.0)))
        - np.array(a.coefficients(AeroState(x - 1e-7, 0.05, 0.01, 0.02, 0.0, 0.0, -0.05, 0.0)))
    ) / 2e-7
    np.testing.assert_allclose(np.imag(np.array(c)) / h, fd, rtol=1e-6, atol=1e-9)
    assert len(AERO_VARIABLES) == 8
