"""Evaluation between nodes (Hermite / paper), the output order e, J = "auto" and the plan's accuracy.

The accuracy definition is the issue's: :func:`planners.verify.open_loop_error` (full model, DOP853,
rtol = atol = 1e-10, from ``plan.initial_state()``, distance to the exact flat outputs).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from gna.errors import InputError
from gna.piecewise import PiecewisePolynomial
from planners.flat import NodeSolution
from planners.generalized import AUTO_J_RATIO, choose_J, plan_scenario
from planners.plan import HERMITE_MAX_ORDER, Plan, hermite_matrix, interval_coefficients
from planners.series import Series

from .conftest import make_scenario


def _poly_plan(coeffs, t_nodes, order, interpolation):
    """A plan with one variable ``x`` whose node series are the Taylor series of the polynomial ``coeffs``."""
    P = np.polynomial.Polynomial(coeffs)
    tn = np.asarray(t_nodes, dtype=float)
    taylor = np.zeros((len(tn), order + 1))
    d = P
    for k in range(order + 1):
        taylor[:, k] = d(tn) / math.factorial(k)
        d = d.deriv()
    sol = NodeSolution({"x": Series(taylor)}, order + 4)
    return Plan(None, tn, [sol], interpolation=interpolation), P


@pytest.mark.parametrize("m", [0, 1, 2, 3, 5])
def test_hermite_is_exact_on_polynomials_of_degree_2m_plus_1(m):
    rng = np.random.default_rng(m)
    tn = np.cumsum(np.r_[0.0, rng.uniform(0.3, 1.7, 7)]) - 2.0  # non-uniform grid
    plan, P = _poly_plan(rng.normal(size=2 * m + 2), tn, m, "hermite")
    t = np.linspace(tn[0], tn[-1], 301)
    for k in range(2 * m + 3):
        ref = P.deriv(k)(t) if k else P(t)
        np.testing.assert_allclose(
            plan.evaluate("x", t, derivative=k), ref, rtol=0, atol=1e-11 * 10**k * max(1.0, float(np.max(np.abs(ref))))
        )
    # and the degree is 2m + 1: one more degree is not reproduced between the nodes
    plan2, P2 = _poly_plan(np.r_[np.zeros(2 * m + 2), 1.0], tn, m, "hermite")
    assert np.max(np.abs(plan2.evaluate("x", t) - P2(t))) > 1e-6


def test_hermite_matches_the_series_derivatives_at_both_ends():
    """C^m at the nodes: on each interval the k-th Taylor coefficients at both ends are the series'."""
    from numpy.polynomial import polynomial as npp

    m = 3
    tn = np.array([0.0, 0.4, 1.1, 1.5])
    rng = np.random.default_rng(3)
    a = rng.normal(size=(3, 2, m + 1))
    b = rng.normal(size=(3, 2, m + 1))
    h = np.diff(tn)
    c = interval_coefficients(a, b, h, "hermite")
    assert c.shape == (3, 2, 2 * m + 2)
    for i in range(3):
        for v in range(2):
            for k in range(m + 1):
                dk = npp.polyder(c[i, v], k) / math.factorial(k)
                assert npp.polyval(0.0, dk) == pytest.approx(a[i, v, k], rel=1e-10, abs=1e-10)
                assert npp.polyval(h[i], dk) == pytest.approx(b[i, v, k], rel=1e-10, abs=1e-10)


def test_hermite_matrix_is_rational_exact_and_capped():
    M = hermite_matrix(1)  # the cubic Hermite basis
    np.testing.assert_array_equal(M, [[1, 0, 0, 0], [0, 1, 0, 0], [-3, -2, 3, -1], [2, 1, -2, 1]])
    assert HERMITE_MAX_ORDER >= 4
    with pytest.raises(InputError):
        hermite_matrix(-1)


def test_paper_formula_is_the_two_sided_blend():
    rng = np.random.default_rng(1)
    a, b = rng.normal(size=(1, 1, 4)), rng.normal(size=(1, 1, 4))
    h = np.array([0.7])
    c = interval_coefficients(a, b, h, "paper")[0, 0]
    for s in (0.0, 0.1, 0.35, 0.7):
        A = np.polynomial.polynomial.polyval(s, a[0, 0])
        B = np.polynomial.polynomial.polyval(s - 0.7, b[0, 0])
        assert np.polynomial.polynomial.polyval(s, c) == pytest.approx(((0.7 - s) * A + s * B) / 0.7, rel=1e-13)
    with pytest.raises(InputError, match="interpolation"):
        interval_coefficients(a, b, h, "linear")


def test_control_function_is_a_piecewise_polynomial(weave_plan):
    _, plan = weave_plan
    f = plan.control_function()
    assert isinstance(f, PiecewisePolynomial) and f.n_functions == 5
    assert f.degree == 2 * plan.e + 1  # every control with the surfaces' e derivatives at both ends
    assert f(np.array([plan.t0, plan.t1])).shape == (5, 2)  # arrays of times (batched integrators)
    t = np.linspace(plan.t0, plan.t1, 173)
    np.testing.assert_allclose(np.stack([f(v) for v in t], axis=1), plan.controls(t), rtol=1e-13, atol=1e-13)
    np.testing.assert_allclose(
        f.evaluate(t, derivative=1),
        np.stack([plan.evaluate(n, t, derivative=1) for n in ("F", "eta", "dl", "dm", "dn")]),
        rtol=1e-12,
        atol=1e-12,
    )
    assert plan.interpolation == "hermite" and plan.e == 1
    with pytest.raises(InputError, match="not in the plan"):
        plan.control_function(j=99)


def test_both_formulas_agree_at_the_nodes_and_differ_between(weave_plan):
    sc, _ = weave_plan
    paper = plan_scenario(sc, J=1, interpolation="paper")
    herm = plan_scenario(sc, J=1, interpolation="hermite")
    tn = paper.t_nodes
    np.testing.assert_allclose(paper.controls(tn), herm.controls(tn), rtol=1e-13, atol=1e-12)
    mid = 0.5 * (tn[:-1] + tn[1:])
    assert np.max(np.abs(paper.controls(mid) - herm.controls(mid))) > 1e-8
    with pytest.raises(InputError, match="interpolation"):
        plan_scenario(sc, J=1, interpolation="spline")


def test_output_order_e_sets_the_series_orders(weave_plan):
    sc, _ = weave_plan
    for e in (0, 2):
        plan = plan_scenario(sc, J=1, e=e)
        assert plan.e == e and plan.iterates[-1]["dm"].order == e and plan.iterates[-1]["alpha"].order == e + 2
        assert plan.iterates[0]["x"].order == e + 4 + 2
    for bad in (-1, 1.5, "2", 11):
        with pytest.raises(InputError, match="output order e"):
            plan_scenario(sc, J=1, e=bad)


def test_initial_state_is_the_last_iterates_state_at_t0(weave_plan):
    """plan.initial_state() is the last iterate's node state at t0, and the full model's derivative there
    (with the same iterate's controls) is the series' own derivative to the iterate's residual."""
    from gna.eom import STATE_NAMES, derivatives

    _, plan = weave_plan
    s = plan.iterates[-1].series
    np.testing.assert_array_equal(plan.initial_state(), [np.real(s[n].constant_term[0]) for n in STATE_NAMES])
    st, ct = plan.node_values()
    f = np.array(derivatives(plan.aircraft, plan.env, st, ct, "full"))[:, 0]
    d = np.array(plan.node_derivatives())[:, 0]
    assert np.max(np.abs(f - d)) <= plan.iterate_residuals()[-1] * (1 + 1e-9)


def test_choose_J_rule():
    assert choose_J([1e-2, 1e-4, 1e-9, 1e-12], tol=1e-8) == (2, "tolerance")
    # stagnation: the least residual so far
    assert choose_J([1e-2, 1e-3, 1e-4, 2e-4], tol=1e-8) == (2, "stagnation")
    assert choose_J([1e-2, 1e-3, 1e-4, 0.95e-4], tol=1e-8) == (3, "stagnation")
    assert choose_J([1e-2, 1e-3, float("nan")], tol=1e-8) == (1, "stagnation")
    assert choose_J([1e-2, 1e-3, 1e-4], tol=1e-8) == (None, "")
    assert AUTO_J_RATIO == 0.9


def test_auto_J_plan_is_the_fixed_J_plan(weave_plan):
    sc, _ = weave_plan
    auto = plan_scenario(sc, J="auto")
    g = auto.generalized
    J = auto.J
    assert g["J_stop"] in ("tolerance", "stagnation") and "auto" in g["J_rule"]
    assert choose_J(g["J_residuals"], g["J_tol"]) == (J, g["J_stop"])
    assert auto.iterate_residuals() == pytest.approx(g["J_residuals"][: J + 1], rel=1e-6)
    fixed = plan_scenario(sc, J=J)
    assert [it.order for it in auto.iterates] == [it.order for it in fixed.iterates]
    t = np.linspace(sc.t0, sc.t1, 77)
    np.testing.assert_allclose(auto.controls(t), fixed.controls(t), rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(auto.state(t), fixed.state(t), rtol=1e-9, atol=1e-9)
    # the scenario key and the limits
    sc_auto = make_scenario(generalized={"J": "auto", "J_tol": 1e-3, "J_max": 6})
    p = plan_scenario(sc_auto)
    assert p.generalized["J_tol"] == 1e-3 and p.J <= 2 and p.generalized["J_stop"] == "tolerance"
    capped = plan_scenario(make_scenario(generalized={"J": "auto", "J_tol": 0.0, "J_max": 1}))
    assert capped.J == 1 and capped.generalized["J_stop"] == "J_max" and any("J_max" in w for w in capped.warnings)
    for bad in (
        {"J": "many"},
        {"J": "auto", "J_max": -1},
        {"J": "auto", "J_tol": -1.0},
        {"e": 99},
        {"interpolation": "cubic"},
    ):
        with pytest.raises(InputError):
            make_scenario(generalized=bad)
    with pytest.raises(InputError, match="fixed-point"):
        plan_scenario(sc, J="auto", method="newton")


#: The issue's accuracy targets at the bundled settings [m]: measured (docs/planning.md, "Accuracy
#: between nodes") 0.34 mm, 25 um and 3.1 mm, so each target leaves a margin of 2.9x, 4x and 3.2x.
ACCURACY_TARGETS = {
    "gtm-aileron-roll": 1e-3,
    "twin-otter-single-engine": 1e-4,
    "gtm-forward-slip": 1e-2,
}


@pytest.mark.parametrize("name", sorted(ACCURACY_TARGETS))
def test_open_loop_accuracy_at_the_bundled_settings(name):
    from planners.scenario import load_scenario
    from planners.verify import open_loop_error

    sc = load_scenario(name)
    plan = plan_scenario(sc)
    assert plan.feasible and plan.interpolation == "hermite"
    chk = open_loop_error(plan)
    assert chk.status == "completed", chk.message
    assert chk.max_position_error_m <= ACCURACY_TARGETS[name], (name, chk.max_position_error_m)
