"""The generic almost chained system (planners.chained) and its first instance, the first-order lag."""

from __future__ import annotations

import numpy as np
import pytest

from gna.errors import InputError
from planners.chained import generalized_parametrization
from planners.systems import SYSTEMS, first_order_lag, lag_reference

EPS, W = 0.1, 1.0


def test_lag_matches_the_inverse_operator_series_to_1e_10():
    """x = sin(w t), eps w = 0.1: iterate J is the partial sum of (1 + eps d/dt)^-1 x', within
    (eps w)^(J+1) of the exact y = (x' - eps x'')/(1 + eps^2 w^2) (the operator relation of the paper,
    from (1 + eps D)(1 - eps D) = 1 + eps^2 w^2 - eps^2 (D^2 + w^2))."""
    tn = np.linspace(0.0, 3.0, 13)
    ref = lag_reference((W, 0.0), EPS, W)
    plan = generalized_parametrization(first_order_lag(EPS), tn, {"x": lambda t: np.sin(W * t)}, J=12, e=6)
    y = np.real(plan.iterates[-1]["y"].coeffs)
    assert np.max(np.abs(y[:, 0] - ref(tn))) < 1e-10
    # the derivatives at the nodes too, and the two-sided interpolation between them
    assert (
        np.max(np.abs(y[:, 1] - (-W * W * np.sin(W * tn) + EPS * W**3 * np.cos(W * tn)) / (1 + (EPS * W) ** 2))) < 1e-10
    )
    tm = np.linspace(0.0, 3.0, 61)
    assert np.max(np.abs(plan.evaluate("y", tm) - ref(tm))) < 1e-8
    # geometric convergence with ratio eps w, as the paper's series
    err = [np.max(np.abs(np.real(it["y"].constant_term) - ref(tn))) for it in plan.iterates]
    ratios = np.array(err[1:8]) / np.array(err[:7])
    assert np.allclose(ratios, EPS * W, rtol=1e-2)


def test_lag_polynomial_output_is_exact_after_finitely_many_iterations():
    """x = t^3: (d/dt)^4 x = 0, so y = 3 t^2 - 6 eps t + 6 eps^2 exactly from J = 2 on."""
    tn = np.linspace(-1.0, 1.0, 5)
    plan = generalized_parametrization(first_order_lag(EPS), tn, {"x": lambda t: t**3}, J=3)
    exact = 3 * tn**2 - 6 * EPS * tn + 6 * EPS**2
    for j, it in enumerate(plan.iterates):
        err = np.max(np.abs(np.real(it["y"].constant_term) - exact))
        assert (err < 1e-13) == (j >= 2), (j, err)


def test_api_and_errors():
    sysm = SYSTEMS["first-order-lag"](eps=0.2)
    assert sysm.r == 2 and sysm.L == 1 and sysm.variables == ("x", "y", "y1")
    assert sysm.stage_of("x") == 1 and sysm.stage_of("y") == 2 and sysm.stage_of("y1") == 3
    with pytest.raises(InputError, match="unknown variable"):
        sysm.stage_of("z")
    with pytest.raises(InputError, match="flat output"):
        generalized_parametrization(sysm, [0.0, 1.0], {}, J=1)
    with pytest.raises(InputError, match="nodes"):
        generalized_parametrization(sysm, [1.0, 0.0], {"x": np.sin})
    plan = generalized_parametrization(sysm, [0.0, 1.0], {"x": lambda t: t}, J=2)
    assert plan.J == 2 and len(plan.timings) == 3
    with pytest.raises(InputError, match="outside"):
        plan.evaluate("y", 2.0)


def test_constant_flat_output():
    """A flat output given as a constant (not a function of t) becomes a constant series."""
    plan = generalized_parametrization(first_order_lag(EPS), [0.0, 1.0], {"x": lambda t: 2.0}, J=1)
    assert np.allclose(np.real(plan.iterates[-1]["y"].coeffs), 0.0)


def _nonlinear_lag(eps):
    """x' = y + eps sin(y'): a nonlinear almost chained system (H_1 = eps sin(y1), l_1 = 2)."""
    from planners.chained import ChainedSystem, Stage

    return ChainedSystem(
        "nonlinear-lag",
        {"x": 1},
        (
            Stage(("y",), lambda v: [v["x'"] - v["y"] - eps * np.sin(v["y1"])], ("y1",), 2),
            Stage(("y1",), lambda v: [v["y'"] - v["y1"]]),
        ),
    )


def test_newton_on_the_chained_fixed_point():
    """Newton on X^ = G~(X^) for a chained system: exact Jacobian (central differences agree), quadratic
    convergence on the nonlinear lag, one step on the linear one, node equation solved to rounding."""
    from planners.chained import flat_parametrization
    from planners.generalized_newton import _hat_dict, _hat_vector, hat_jacobian, newton_parametrization

    tn = np.linspace(0.0, 3.0, 7)
    zeta = {"x": np.sin}
    sysm = _nonlinear_lag(0.1)
    kappa, nodes = 7, len(tn)
    x0 = _hat_vector(sysm, kappa, {}, nodes) + 0.1
    sol = flat_parametrization(sysm, tn, kappa, zeta, hat=_hat_dict(sysm, kappa, x0))
    dG = hat_jacobian(sysm, kappa, sol, _hat_dict(sysm, kappa, x0))
    d = np.random.default_rng(0).standard_normal(x0.shape) * 0.1

    def G(x):
        s = flat_parametrization(sysm, tn, kappa, zeta, hat=_hat_dict(sysm, kappa, x))
        return _hat_vector(sysm, kappa, {"y1": s["y1"]}, nodes)

    fd = (G(x0 + 1e-5 * d) - G(x0 - 1e-5 * d)) / 2e-5
    assert np.max(np.abs(fd - np.einsum("nij,nj->ni", dG, d))) < 1e-8
    plan = newton_parametrization(sysm, tn, zeta, J=4)
    r = plan.residuals
    assert r[-1] < 1e-13 and len(r) <= 6 and r[3] < r[2] ** 1.5 and plan.info["status"] == "converged"
    y = np.real(plan.iterates[-1]["y"].coeffs)
    assert np.max(np.abs(np.cos(tn) - y[:, 0] - 0.1 * np.sin(y[:, 1]))) < 1e-13
    lin = newton_parametrization(first_order_lag(EPS), tn, {"x": lambda t: np.sin(W * t)}, J=12)
    assert len(lin.residuals) == 2 and lin.residuals[-1] < 1e-15
    ref = lag_reference((W, 0.0), EPS, W)
    assert np.max(np.abs(np.real(lin.iterates[-1]["y"].constant_term) - ref(tn))) < 1e-14
