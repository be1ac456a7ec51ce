"""Newton's method on the fixed point of generalized flatness (planners.generalized_newton)."""

from __future__ import annotations

import numpy as np
import pytest

from gna.errors import InputError
from planners.chained import flat_parametrization
from planners.flat import aircraft_system
from planners.generalized import plan_motion, plan_scenario
from planners.generalized_newton import _hat_dict, _hat_vector, counted, hat_jacobian
from planners.scenario import load_scenario, scenario_from_dict

from .conftest import WEAVE


@pytest.fixture(scope="module")
def roll():
    return load_scenario("gtm-aileron-roll")


def node_residual(plan, j):
    return float(plan.equation_residuals("full", j).abs().max().max())


def test_series_jacobian_matches_finite_differences(roll):
    """dG/dH of the aircraft, built from the stages' complex-step partials, equals central differences of G."""
    pb, tn = roll.problem(), roll.t_nodes[::8]
    system = aircraft_system(pb)
    kappa, nodes = 9, len(tn)
    N = kappa - 2
    H = _hat_vector(system, kappa, dict(flat_parametrization(system, tn, kappa)), nodes)  # (nodes, 6 (N + 1))
    sol = flat_parametrization(system, tn, kappa, hat=_hat_dict(system, kappa, H))
    dG = hat_jacobian(system, kappa, sol, _hat_dict(system, kappa, H))
    d = np.random.default_rng(1).standard_normal((nodes, 6, N + 1)) * 1e-3 / (1 + np.arange(N + 1)) ** 2
    d = d.reshape(nodes, -1)
    eps = 1e-3

    def G(x):
        s = flat_parametrization(system, tn, kappa, hat=_hat_dict(system, kappa, x), guess=sol, carry=False)
        return _hat_vector(system, kappa, dict(s), nodes)

    fd = (G(H + eps * d) - G(H - eps * d)) / (2 * eps)
    lin = np.einsum("nij,nj->ni", dG, d)
    assert np.max(np.abs(fd)) > 1e-5
    assert np.max(np.abs(fd - lin)) < 1e-9 * max(1.0, np.max(np.abs(fd)))
    # causality of the order loss: output coefficient k depends on input coefficients <= k + 2 only
    blocks = dG.reshape(nodes, 6, N + 1, 6, N + 1)
    k, l_ = np.meshgrid(np.arange(N + 1), np.arange(N + 1), indexing="ij")
    assert np.all(blocks.transpose(0, 2, 4, 1, 3)[:, l_ > k + 2] == 0)


def test_newton_reaches_1e_10_where_the_fixed_point_stalls(roll):
    """The aileron roll: Newton's full-model node residual <= 1e-10 in a few steps; the paper's
    iteration stalls near 2e-6 and then grows (its J-th iterate is the J-th partial sum of an
    asymptotic series), at every J up to 10."""
    newton = plan_scenario(roll, J=2, method="newton")
    res_n = [node_residual(newton, j) for j in range(newton.J + 1)]
    assert res_n[-1] <= 1e-10, res_n
    assert newton.generalized["residual"][-1] <= 1e-12
    assert newton.J <= 4
    # quadratic convergence of max |H - G(H)|
    r = newton.generalized["residual"]
    assert r[2] < r[1] ** 1.5 and r[3] < 1e-12
    fixed = plan_scenario(roll, J=10)
    res_f = [node_residual(fixed, j) for j in range(fixed.J + 1)]
    assert min(res_f) > 1e-7, res_f
    assert res_f[-1] > min(res_f)  # diverging beyond the best J


def test_newton_cheaper_than_fixed_point_to_the_fixed_points_best(roll):
    """To the fixed point's best residual (its J = 8 iterate), Newton needs fewer model evaluations (what each
    costs in time is measured in docs/performance.md, never asserted: a loaded machine would fail it)."""
    pb, counter = counted(roll.problem())
    fixed = plan_motion(pb, roll.t_nodes, 8)
    evals_f = counter.calls
    best = node_residual(fixed, 8)
    pb, counter = counted(roll.problem())
    newton = plan_motion(pb, roll.t_nodes, 0, method="newton")
    res = [node_residual(newton, j) for j in range(newton.J + 1)]
    assert res[-1] < best * 1e-3
    assert counter.calls < evals_f, (counter.calls, evals_f)


def test_newton_iterates_and_orders(roll):
    """Iterate 0 is the fixed point's iterate 0; the Newton iterates have the fixed point's output orders;
    at the same depth the two agree to the fixed point's own convergence."""
    J = 3
    fixed = plan_scenario(roll, J=J)
    newton = plan_scenario(roll, J=J, method="newton")
    assert newton.generalized["method"] == "newton" and fixed.generalized["method"] == "fixed-point"
    for k, s in fixed.iterates[0].series.items():
        assert np.array_equal(s.coeffs, newton.iterates[0].series[k].coeffs), k
    for k, s in fixed.iterates[-1].series.items():
        assert newton.iterates[-1].series[k].order == s.order, k
    a = fixed.convergence_table(times=[-1.9]).iloc[:, -1].to_numpy()
    b = newton.convergence_table(times=[-1.9]).iloc[:, -1].to_numpy()
    step = np.abs(fixed.convergence_table(times=[-1.9]).diff(axis=1).iloc[:, -1].to_numpy())
    assert np.all(np.abs(a - b) <= 5 * step + 1e-12), (a, b, step)


def test_scenario_method_key():
    data = {k: (dict(v) if isinstance(v, dict) else v) for k, v in WEAVE.items()}
    data["time"] = {"t0": 0.0, "t1": 4.0, "step": 1.0}
    data["generalized"] = {"J": 1, "method": "newton"}
    plan = plan_scenario(scenario_from_dict(data))
    assert plan.generalized["method"] == "newton"
    assert plan.generalized["residual"][-1] <= 1e-12
    data["generalized"] = {"J": 1, "method": "secant"}
    with pytest.raises(InputError, match="secant"):
        plan_scenario(scenario_from_dict(data))
    with pytest.raises(InputError, match="method"):
        plan_motion(scenario_from_dict(data).problem(), [0.0, 1.0], method="bisection")
