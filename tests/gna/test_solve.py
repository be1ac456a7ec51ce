"""The model package's pointwise batched Newton (gna.solve)."""

from __future__ import annotations

import numpy as np
import pytest

from gna.solve import batched_solve, jacobian, newton


def test_batched_solve_with_a_singular_member_falls_back_to_least_squares():
    J = np.zeros((2, 2, 3))
    J[0, 0], J[1, 1] = [1.0, 2.0, 1.0], [1.0, 4.0, 0.0]  # third matrix singular
    f = np.array([[1.0, 2.0, 3.0], [1.0, 8.0, 0.0]])
    dx = batched_solve(J, f)
    assert np.allclose(dx[:, 0], [1.0, 1.0]) and np.allclose(dx[:, 1], [1.0, 2.0])
    assert np.allclose(dx[:, 2], [3.0, 0.0])


def test_complex_step_and_central_jacobians_agree():
    def fun(x):
        return np.stack([np.sin(x[0]) * x[1], x[0] ** 2 + np.exp(x[1])])

    x = np.array([[0.3, -1.0], [0.7, 2.0]])
    Jc = jacobian(fun, x)
    Jd = jacobian(fun, x, "central")
    exact = np.array([[np.cos(x[0]) * x[1], np.sin(x[0])], [2 * x[0], np.exp(x[1])]])
    assert np.allclose(Jc, exact, rtol=1e-14, atol=0)
    assert np.allclose(Jd, exact, rtol=1e-8)
    with pytest.raises(ValueError, match="unknown Jacobian method"):
        jacobian(fun, x, "forward")


def test_newton_single_problem_without_batch_axes():
    r = newton(lambda x: np.stack([x[0] ** 2 - 2.0, x[1] - x[0]]), np.array([1.0, 0.0]), tol=1e-14)
    assert r.all_converged and np.allclose(r.x, np.sqrt(2.0))
