"""Newton's method for square nonlinear systems, batched over many problems.

``fun(x)`` maps an array of shape ``(n, *batch)`` to residuals of the same
shape; the batch axes are independent problems (e.g. the nodes of a time
grid, or a single trim condition with ``batch = ()``) solved together with
array code.  The Jacobian is computed by complex step (exact to rounding when
``fun`` is complex-analytic, which every model function of :mod:`gna.eom` is
for an analytic aerodynamic model) or, on request, by central differences.

This is the pointwise solver of the model package (trim uses it); Newton's
method on truncated power series, built on it, lives in :mod:`planners.newton`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

#: Complex-step size of :func:`jacobian` (no subtractive cancellation, so it can be tiny).
COMPLEX_STEP = 1e-30
#: Relative step of the central differences of :func:`jacobian`.
CENTRAL_STEP = 1e-6


@dataclass
class NewtonResult:
    """Outcome of :func:`newton`.

    Attributes
    ----------
    x : ndarray, shape (n, *batch)
        Final iterate of every problem.
    residual : ndarray, shape batch
        Weighted max-norm of the residual of each problem at ``x``.
    iterations : int
        Newton iterations performed (the same for the whole batch).
    converged : ndarray of bool, shape batch
        ``residual <= tol`` for each problem.
    history : list of float
        Worst residual over the batch, initially and after each iteration.
    """

    x: np.ndarray
    residual: np.ndarray
    iterations: int
    converged: np.ndarray
    history: list = field(default_factory=list)

    @property
    def all_converged(self) -> bool:
        """True when every problem of the batch converged."""
        return bool(np.all(self.converged))


def jacobian(
    fun: Callable[[np.ndarray], np.ndarray], x: np.ndarray, method: str = "complex", f0: np.ndarray | None = None
) -> np.ndarray:
    """Jacobian ``J[i, j, *batch] = d f_i / d x_j`` of a batched function.

    Parameters
    ----------
    fun : callable
        ``fun(x) -> f``, ``(n, *batch) -> (m, *batch)``; with ``method="complex"`` it must accept
        complex arrays and be complex-analytic in ``x``.
    x : ndarray, shape (n, *batch)
        Point of evaluation (units of the unknowns).
    method : {"complex", "complex-batched", "central"}
        Complex step (h = 1e-30, exact to rounding for analytic ``fun``): one call per column, or
        ``"complex-batched"``: all columns from one call on the stacked batch ``(n, n, *batch)`` of
        perturbed points (``fun`` must broadcast over a leading batch axis); or central differences
        with a relative step 1e-6.
    f0 : ndarray, optional
        Unused; accepted for call compatibility (the value at ``x`` is not needed by either method).

    Returns
    -------
    ndarray, shape (m, n, *batch)
        Partial derivatives, in units of ``f`` per unit of ``x``.

    Raises
    ------
    ValueError
        Unknown ``method``.
    """
    n = x.shape[0]
    cols = []
    if method == "complex-batched":
        xs = np.broadcast_to(x.astype(complex), (n,) + x.shape).copy()  # (n_col, n, *batch)
        for j in range(n):
            xs[j, j] += 1j * COMPLEX_STEP
        return np.imag(fun(np.moveaxis(xs, 0, 1))) / COMPLEX_STEP  # (m, n_col, *batch)
    if method == "complex":
        h = COMPLEX_STEP
        xc = x.astype(complex)
        for j in range(n):
            xj = xc.copy()
            xj[j] += 1j * h
            cols.append(np.imag(fun(xj)) / h)
    elif method == "central":
        for j in range(n):
            h = CENTRAL_STEP * np.maximum(1.0, np.abs(x[j]))
            xp, xm = x.astype(float).copy(), x.astype(float).copy()
            xp[j] += h
            xm[j] -= h
            cols.append((fun(xp) - fun(xm)) / (2 * h))
    else:
        raise ValueError(f"unknown Jacobian method {method!r}")
    return np.stack(cols, axis=1)


def batched_solve(J: np.ndarray, f: np.ndarray) -> np.ndarray:
    """Solve ``J dx = f`` for every problem of a batch.

    A batch containing a singular matrix falls back to least squares problem by problem.

    Parameters
    ----------
    J : ndarray, shape (n, n, *batch)
        Matrices, first two axes the rows and columns.
    f : ndarray, shape (n, *batch)
        Right-hand sides.

    Returns
    -------
    ndarray, shape (n, *batch)
        The solutions ``dx``.
    """
    n = J.shape[0]
    batch = f.shape[1:]
    Jm = np.moveaxis(J.reshape(n, n, -1), -1, 0)  # (B, n, n)
    fm = np.moveaxis(f.reshape(n, -1), -1, 0)[..., None]  # (B, n, 1)
    try:
        dx = np.linalg.solve(Jm, fm)[..., 0]
    except np.linalg.LinAlgError:
        dx = np.stack([np.linalg.lstsq(Jm[b], fm[b, :, 0], rcond=None)[0] for b in range(Jm.shape[0])])
    return np.moveaxis(dx, 0, -1).reshape((n,) + batch)


def newton(
    fun: Callable[[np.ndarray], np.ndarray],
    x0,
    *,
    tol: float = 1e-12,
    maxiter: int = 50,
    jac: str = "complex",
    damped: bool = True,
    scale: np.ndarray | None = None,
) -> NewtonResult:
    """Solve ``fun(x) = 0`` by (damped) Newton, for a batch of independent problems.

    Parameters
    ----------
    fun : callable
        ``(n, *batch) -> (n, *batch)``; complex-analytic when ``jac="complex"``.
    x0 : array_like, shape (n, *batch)
        Starting point of every problem.
    tol : float
        Convergence when the weighted ``max|f| <= tol`` for a problem (units of ``fun``).
    maxiter : int
        Maximum number of Newton iterations.
    jac : {"complex", "complex-batched", "central"} or callable
        Jacobian method of :func:`jacobian`, or ``jac(x) -> (n, n, *batch)`` giving it.
    damped : bool
        Backtracking on the residual norm (halving the step up to 10 times).
    scale : ndarray, shape (n,), optional
        Residual weights used for the convergence test and the line search (default: ones).

    Returns
    -------
    NewtonResult
        Never raises for non-convergence; callers decide how to report it.
    """
    x = np.array(x0, dtype=float)
    n = x.shape[0]
    w = np.ones(n) if scale is None else np.asarray(scale, dtype=float)
    wexp = w.reshape((n,) + (1,) * (x.ndim - 1))

    def norm(f):
        return np.max(np.abs(f * wexp), axis=0)

    f = np.real(fun(x))
    res = norm(f)
    history = [float(np.max(res))]
    it = 0
    while it < maxiter and not np.all(res <= tol):
        it += 1
        if not np.all(np.isfinite(f)):
            break
        J = jac(x) if callable(jac) else jacobian(fun, x, jac)
        dx = batched_solve(J, -f)
        active = res > tol
        dx = np.where(active, dx, 0.0)
        step = np.ones_like(res)
        xn = x + dx
        fn = np.real(fun(xn))
        rn = norm(fn)
        if damped:
            for _ in range(10):
                bad = ~(rn < res) & active & ~(rn <= tol)
                bad &= ~np.isfinite(rn) | (rn >= res)
                if not np.any(bad):
                    break
                step = np.where(bad, step * 0.5, step)
                xn = x + dx * step
                fn = np.real(fun(xn))
                rn = norm(fn)
        x, f, res = xn, fn, np.where(np.isfinite(rn), rn, np.inf)
        history.append(float(np.max(res)))
    return NewtonResult(x=x, residual=res, iterations=it, converged=res <= tol, history=history)
