"""Vector Newton (batched, complex-step Jacobian) and Newton on power series."""

from __future__ import annotations

import importlib

import numpy as np

from planners.newton import PAPER_MAXITER, PAPER_TOL, NewtonFailure, jacobian, newton, newton_series
from planners.series import Series


def test_batched_newton_solves_each_problem():
    a = np.array([1.0, 4.0, 9.0, 2.0])

    def f(x):
        return np.stack([x[0] ** 2 - a, x[0] * x[1] - 1.0])

    r = newton(f, np.ones((2, 4)), tol=1e-14)
    assert r.all_converged
    np.testing.assert_allclose(r.x[0], np.sqrt(a), rtol=1e-14)
    np.testing.assert_allclose(r.x[1], 1 / np.sqrt(a), rtol=1e-14)


def test_complex_step_jacobian_exact():
    f = lambda x: np.stack([np.sin(x[0]) * x[1], np.exp(x[1])])  # noqa: E731
    x = np.array([[0.3], [0.7]])
    J = jacobian(f, x)[..., 0]
    np.testing.assert_allclose(J, [[np.cos(0.3) * 0.7, np.sin(0.3)], [0.0, np.exp(0.7)]], rtol=1e-15)


def test_newton_reports_failure_without_raising():
    r = newton(lambda x: x**2 + 1.0, np.ones((1, 3)), maxiter=PAPER_MAXITER)
    assert not r.all_converged and r.iterations == PAPER_MAXITER
    assert np.all(r.residual >= 1.0)


def test_newton_series_sqrt_and_arctan():
    """Solve u^2 = 1 + t and tan(v) = t as series at three nodes; compare with known expansions."""
    t0 = np.array([0.0, 0.5, 1.0])
    order = 9
    t = Series.variable(t0, order)

    def residual(u, k):
        tk = t.truncate(k) if k else t0
        return [u[0] * u[0] - (1 + tk), np.tan(u[1]) - tk]

    (u, v), rep = newton_series(
        residual, [Series.constant(np.ones(3), 0), Series.constant(np.zeros(3), 0)], order, names=("u", "v"), t_nodes=t0
    )
    np.testing.assert_allclose(np.real(u.coeffs), np.sqrt(1 + t).coeffs, atol=1e-13)
    np.testing.assert_allclose(np.real(v.coeffs), np.arctan(t).coeffs, atol=1e-13)
    assert rep.doubling_orders == [1, 2, 4, 9]
    assert rep.worst_residual < 1e-12 and rep.warnings == []


def test_newton_series_paper_warning_names_time():
    t0 = np.array([0.0, 1.0, 2.0])

    def residual(u, k):
        return [u[0] * u[0] + 1.0 + 0 * u[0]]  # no real solution

    _, rep = newton_series(residual, [Series.constant(np.ones(3), 0)], 3, names=("u",), t_nodes=t0)
    assert len(rep.warnings) == 1
    assert "did not reach 1e-3 after 20 iterations at 3 node(s), t = 0 .. 2 s" in rep.warnings[0]


def test_newton_series_failure_is_a_record():
    """The failure is structured: unknowns, node indices and times, worst residual and its time."""
    t0 = np.array([0.0, 1.0, 2.0, 3.0, 4.0])

    def residual(u, k):
        # u^2 + c = 0 has a real root only where c <= 0: nodes 1, 2 and 4 fail
        c = np.array([-1.0, 1.0, 3.0, -4.0, 2.0])
        return [u[0] * u[0] + c]

    _, rep = newton_series(residual, [Series.constant(np.ones(5), 0)], 2, names=("u",), t_nodes=t0)
    assert len(rep.failures) == 1
    f = rep.failures[0]
    assert isinstance(f, NewtonFailure)
    assert f.names == ("u",) and f.tol == PAPER_TOL and f.maxiter == PAPER_MAXITER
    assert list(f.nodes) == [1, 2, 4] and list(f.times) == [1.0, 2.0, 4.0] and f.n_nodes == 3
    assert f.worst_residual == max(f.residuals) and f.worst_time == f.times[np.argmax(f.residuals)]
    assert f.stage is None and f.iterate is None
    assert rep.warnings == [f.message]
    assert "at 3 node(s), t = 1 .. 2, 4 s" in f.message


def test_pointwise_newton_lives_in_the_model_package():

    import gna.solve

    pn = importlib.import_module("planners.newton")  # the package re-exports the function ``newton``
    assert pn.newton is gna.solve.newton and pn.jacobian is gna.solve.jacobian
    assert pn.NewtonResult is gna.solve.NewtonResult


def test_doubling_orders_from_the_top():
    from planners.newton import doubling_orders

    assert doubling_orders(0) == [] and doubling_orders(1) == [1] and doubling_orders(18) == [1, 2, 4, 9, 18]
    for order in range(1, 70):
        ks = doubling_orders(order)
        assert ks[-1] == order and all(b <= 2 * a + 1 for a, b in zip([0] + ks, ks))
        assert len(ks) == order.bit_length()  # as few steps as doubling from 0


def _counting(residual):
    calls = []

    def wrapped(u, k):
        calls.append(k)
        return residual(u, k)

    return wrapped, calls


def test_warm_newton_series_from_a_close_start_matches_the_full_scheme():
    """From the solution of a nearby problem (as the previous generalized-flatness iterate is), Newton
    at the full order gives the full scheme's solution to rounding in a few evaluations, all at the
    working order (no pointwise iterations, no low doubling orders)."""
    t0, order, problem, near, _ = _chord_problem()
    start = [Series.constant(np.ones(4), 0), Series.constant(np.zeros(4), 0)]
    cold_res, cold_calls = _counting(problem(2e-3))
    cold, _ = newton_series(cold_res, start, order, t_nodes=t0)
    warm_res, warm_calls = _counting(problem(2e-3))
    warm, rep = newton_series(warm_res, near, order, t_nodes=t0, warm=True, names=("u", "v"))
    weights = 0.5 ** np.arange(order + 1)  # the tolerance is on coefficients weighted by step^m
    for a, b in zip(cold, warm):
        np.testing.assert_allclose(np.real(b.coeffs) * weights, np.real(a.coeffs) * weights, rtol=0, atol=1e-13)
    assert set(warm_calls) == {order} and len(warm_calls) < len(cold_calls) / 2
    assert rep.doubling_orders == [order] * len(warm_calls) and rep.constant_iterations == 0
    # The tolerance bounds the residual's coefficients weighted by step^m (here 0.5^m).
    assert _weighted_residual(problem(2e-3), warm, order, 0.5) <= 1e-13 and rep.failures == []


def test_warm_newton_series_falls_back_to_the_full_scheme():
    """A start too far for Newton at the full order (here: no real solution at all) runs the full
    scheme, whose failure record (the paper's rule, memory restarts) is reported as without ``warm``."""
    t0 = np.array([0.0, 1.0, 2.0])

    def residual(u, k):
        return [u[0] * u[0] + 1.0 + 0 * u[0]]

    start = [Series(np.ones((3, 4)))]
    _, cold = newton_series(residual, start, 3, names=("u",), t_nodes=t0)
    _, warm = newton_series(residual, start, 3, names=("u",), t_nodes=t0, warm=True)
    assert warm.warnings == cold.warnings and len(warm.warnings) == 1
    assert warm.doubling_orders == [1, 3]


def _chord_problem():
    """u^2 (1 + eps v) = 2 + t, tan v + eps u = t on four nodes (order 12), and a start near its solution."""
    t0 = np.array([0.0, 0.5, 1.0, 1.5])
    order = 12
    t = Series.variable(t0, order)

    def problem(eps):
        def residual(u, k):
            tk = t.truncate(k) if k else t0
            return [u[0] * u[0] * (1 + eps * u[1]) - (2 + tk), np.tan(u[1]) + eps * u[0] - tk]

        return residual

    start = [Series.constant(np.ones(4), 0), Series.constant(np.zeros(4), 0)]
    near, rep = newton_series(problem(1e-3), start, order, t_nodes=t0)
    return t0, order, problem, near, rep


def _kinds(monkeypatch):

    newton_module = importlib.import_module("planners.newton")
    log = []
    rj, ro = newton_module._residual_and_jacobian, newton_module._residual_only
    monkeypatch.setattr(newton_module, "_residual_and_jacobian", lambda r, s, k: log.append("J") or rj(r, s, k))
    monkeypatch.setattr(newton_module, "_residual_only", lambda r, s, k: log.append("R") or ro(r, s, k))
    return log


def _weighted_residual(residual, u, order, step):
    return max(float(np.max(np.abs(np.real(r.coeffs)) * step ** np.arange(order + 1))) for r in residual(u, order))


def test_chord_on_a_carried_jacobian_takes_no_complex_step(monkeypatch):
    """With the Jacobian series of a nearby problem (as the previous generalized-flatness iterate's),
    the warm start takes chord steps only (real evaluations) and stops within the tolerance; the
    report carries the Jacobian on for the next problem."""
    t0, order, problem, near, rep_near = _chord_problem()
    assert rep_near.jacobian.shape == (2, 2, 4, order + 1)
    cold, _ = newton_series(problem(2e-3), near, order, t_nodes=t0)
    log = _kinds(monkeypatch)
    warm, rep = newton_series(problem(2e-3), near, order, t_nodes=t0, warm=True, jacobian=rep_near.jacobian)
    assert log and set(log) == {"R"}, log
    assert _weighted_residual(problem(2e-3), warm, order, 0.5) <= 1e-12
    weights = 0.5 ** np.arange(order + 1)
    for a, b in zip(cold, warm):
        np.testing.assert_allclose(np.real(b.coeffs) * weights, np.real(a.coeffs) * weights, rtol=0, atol=1e-13)
    assert rep.jacobian is not None and rep.constant_iterations == 0


def test_chord_that_contracts_too_slowly_takes_a_fresh_jacobian(monkeypatch):
    """A carried Jacobian far from the true one (its higher terms scaled: the chord contracts by a rate
    of about 0.5) gives way to a fresh complex-step Jacobian after one chord step, and the result is
    the same within the tolerance."""
    t0, order, problem, near, rep_near = _chord_problem()
    bad = np.array(rep_near.jacobian)
    bad[..., 1:] *= 1.5
    bad[..., 1:] += 0.5
    cold, _ = newton_series(problem(2e-3), near, order, t_nodes=t0)
    log = _kinds(monkeypatch)
    warm, rep = newton_series(problem(2e-3), near, order, t_nodes=t0, warm=True, jacobian=bad)
    assert log[:2] == ["R", "R"] and "J" in log, log
    assert _weighted_residual(problem(2e-3), warm, order, 0.5) <= 1e-12
    weights = 0.5 ** np.arange(order + 1)
    for a, b in zip(cold, warm):
        np.testing.assert_allclose(np.real(b.coeffs) * weights, np.real(a.coeffs) * weights, rtol=0, atol=1e-13)


def test_chord_that_diverges_returns_to_its_start_for_a_newton_step(monkeypatch):
    """A carried Jacobian of the wrong sign makes the first chord step worse: back to the start, a
    Newton step there (a fresh Jacobian), and the solution all the same."""
    t0, order, problem, near, rep_near = _chord_problem()
    bad = -3.0 * np.array(rep_near.jacobian)
    log = _kinds(monkeypatch)
    warm, rep = newton_series(problem(2e-3), near, order, t_nodes=t0, warm=True, jacobian=bad)
    assert log[:3] == ["R", "R", "J"], log
    assert _weighted_residual(problem(2e-3), warm, order, 0.5) <= 1e-12


def test_a_jacobian_of_another_shape_is_ignored(monkeypatch):
    t0, order, problem, near, rep_near = _chord_problem()
    log = _kinds(monkeypatch)
    warm, _ = newton_series(
        problem(2e-3), near, order, t_nodes=t0, warm=True, jacobian=np.array(rep_near.jacobian)[..., :order]
    )  # one coefficient short
    assert log[0] == "J"
    assert _weighted_residual(problem(2e-3), warm, order, 0.5) <= 1e-12


def test_contraction_accepts_a_chord_step_without_a_check(monkeypatch):
    """With a carried Jacobian, the last evaluated residual may be above the tolerance when the rate
    measured with that Jacobian proves the next one below it (theta s <= 0.1 tol): the result's own
    residual, evaluated here, is then below 0.1 tol, and no evaluation was spent only to check it."""

    newton_module = importlib.import_module("planners.newton")
    t0, order, problem, near, rep_near = _chord_problem()
    sizes = []
    ro = newton_module._residual_only

    def residual_only(r, s, k):
        G = ro(r, s, k)
        sizes.append(float(np.max(np.abs(G) * 0.5 ** np.arange(k + 1))))
        return G

    monkeypatch.setattr(newton_module, "_residual_only", residual_only)
    residual = problem(2e-3)
    warm, rep = newton_series(residual, near, order, t_nodes=t0, warm=True, jacobian=rep_near.jacobian)
    assert len(sizes) >= 3 and sizes[-1] > 1e-12, sizes
    theta = max(b / a for a, b in zip(sizes, sizes[1:]))
    assert theta * sizes[-1] <= newton_module.CHORD_PROOF * 1e-12
    assert _weighted_residual(residual, warm, order, 0.5) <= newton_module.CHORD_PROOF * 1e-12
