"""Newton's method for square nonlinear systems, batched over many problems.

``fun(x)`` maps an array of shape ``(n, *batch)`` to residuals of the same
shape; the batch axes are independent problems (e.g. the nodes of a time
grid) solved together with array code.  The Jacobian is computed by complex
step (exact to rounding when ``fun`` is complex-analytic, which every model
function of gflat is) or, on request, by central differences.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

#: The paper's failure rule (section "Newton operator with series"):
#: a residual above this after ``PAPER_MAXITER`` iterations is reported.
PAPER_TOL = 1e-3
PAPER_MAXITER = 20


@dataclass
class NewtonResult:
    """Outcome of :func:`newton`.

    Attributes
    ----------
    x : ndarray, shape (n, *batch)
    residual : ndarray, shape batch
        Max-norm of the residual of each problem at ``x``.
    iterations : int
    converged : ndarray of bool, shape batch
    history : list of float
        Worst residual after each iteration.
    """

    x: np.ndarray
    residual: np.ndarray
    iterations: int
    converged: np.ndarray
    history: list = field(default_factory=list)

    @property
    def all_converged(self) -> bool:
        return bool(np.all(self.converged))


def jacobian(fun: Callable[[np.ndarray], np.ndarray], x: np.ndarray, method: str = "complex",
             f0: np.ndarray | None = None) -> np.ndarray:
    """Jacobian ``J[i, j, *batch] = d f_i / d x_j``.

    Parameters
    ----------
    method : {"complex", "central"}
        Complex step (h = 1e-30, exact for analytic ``fun``) or central
        differences with a relative step 1e-6.
    """
    n = x.shape[0]
    cols = []
    if method == "complex":
        h = 1e-30
        xc = x.astype(complex)
        for j in range(n):
            xj = xc.copy()
            xj[j] += 1j * h
            cols.append(np.imag(fun(xj)) / h)
    elif method == "central":
        for j in range(n):
            h = 1e-6 * np.maximum(1.0, np.abs(x[j]))
            xp, xm = x.astype(float).copy(), x.astype(float).copy()
            xp[j] += h
            xm[j] -= h
            cols.append((fun(xp) - fun(xm)) / (2 * h))
    else:
        raise ValueError(f"unknown Jacobian method {method!r}")
    return np.stack(cols, axis=1)


def _solve(J: np.ndarray, f: np.ndarray) -> np.ndarray:
    """Solve J dx = f for every batch element; J (n, n, *batch), f (n, *batch)."""
    n = J.shape[0]
    batch = f.shape[1:]
    Jm = np.moveaxis(J.reshape(n, n, -1), -1, 0)          # (B, n, n)
    fm = np.moveaxis(f.reshape(n, -1), -1, 0)[..., None]  # (B, n, 1)
    try:
        dx = np.linalg.solve(Jm, fm)[..., 0]
    except np.linalg.LinAlgError:
        dx = np.stack([np.linalg.lstsq(Jm[b], fm[b, :, 0], rcond=None)[0] for b in range(Jm.shape[0])])
    return np.moveaxis(dx, 0, -1).reshape((n,) + batch)


def newton(fun: Callable[[np.ndarray], np.ndarray], x0, *, tol: float = 1e-12, maxiter: int = 50,
           jac: str = "complex", damped: bool = True, scale: np.ndarray | None = None) -> NewtonResult:
    """Solve ``fun(x) = 0`` by (damped) Newton, for a batch of independent problems.

    Parameters
    ----------
    fun : callable
        ``(n, *batch) -> (n, *batch)``.
    x0 : array_like, shape (n, *batch)
    tol : float
        Convergence when ``max|f| <= tol`` for a problem.
    maxiter : int
    jac : {"complex", "central"}
    damped : bool
        Backtracking on the residual norm (halving the step up to 10 times).
    scale : array, shape (n,), optional
        Residual weights used for the convergence test and the line search.

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
        J = jacobian(fun, x, jac)
        dx = _solve(J, -f)
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


# --------------------------------------------------------------------------------------------
# Newton's method on truncated power series (paper: "Newton operator with series").
# --------------------------------------------------------------------------------------------


@dataclass
class SeriesNewtonReport:
    """Diagnostics of :func:`newton_series` for one batch of nodes.

    Attributes
    ----------
    names : tuple of str
        The unknowns.
    t_nodes : ndarray
    constant_residual : ndarray (nodes,)
        Max-norm residual of the constant-term (pointwise) Newton at each node.
    constant_iterations : int
    series_residual : ndarray (nodes,)
        Max abs coefficient of the residual series at the final order.
    warnings : list of str
        The paper's rule: residual above 1e-3 after 20 iterations, with time and residual.
    """

    names: tuple
    t_nodes: np.ndarray
    constant_residual: np.ndarray
    constant_iterations: int
    series_residual: np.ndarray
    doubling_orders: list
    warnings: list = field(default_factory=list)

    @property
    def worst_residual(self) -> float:
        return float(max(np.max(self.constant_residual), np.max(self.series_residual)))


def _time_ranges(t: np.ndarray, idx: np.ndarray) -> str:
    """'0 .. 2.5, 7' for consecutive runs of node indices."""
    runs, start = [], idx[0]
    for a, b in zip(idx, list(idx[1:]) + [None]):
        if b is None or b != a + 1:
            runs.append(f"{t[start]:.6g}" if a == start else f"{t[start]:.6g} .. {t[a]:.6g}")
            start = b
    return ", ".join(runs)


def _series_solve(Jc: np.ndarray, Gc: np.ndarray) -> np.ndarray:
    """Solve the series linear system J(t) D(t) = G(t) mod t^(K).

    ``Jc`` has shape (n, n, *batch, K), ``Gc`` (n, *batch, K); returns D (n, *batch, K).
    Order by order: ``J_0 D_m = G_m - sum_{l=1..m} J_l D_{m-l}``.
    """
    n = Jc.shape[0]
    K = Gc.shape[-1]
    batch = Gc.shape[1:-1]
    J0 = np.moveaxis(Jc[..., 0].reshape(n, n, -1), -1, 0)           # (B, n, n)
    try:
        J0inv = np.linalg.inv(J0)
    except np.linalg.LinAlgError:
        # A singular node (reported by the caller's warnings): least-squares step there.
        J0inv = np.linalg.pinv(J0)
    Jr = np.moveaxis(Jc.reshape(n, n, -1, K), 2, 0)                  # (B, n, n, K)
    Gr = np.moveaxis(Gc.reshape(n, -1, K), 1, 0)                     # (B, n, K)
    D = np.zeros_like(Gr)
    for mth in range(K):
        rhs = Gr[..., mth].copy()
        for l in range(1, mth + 1):
            rhs -= np.einsum("bij,bj->bi", Jr[..., l], D[..., mth - l])
        D[..., mth] = np.einsum("bij,bj->bi", J0inv, rhs)
    return np.moveaxis(D, 0, 1).reshape((n,) + batch + (K,))


def newton_series(residual: Callable, u0: list, order: int, *, tol: float = 1e-12,
                  maxiter: int = PAPER_MAXITER, names: tuple = (), t_nodes=None):
    """Solve ``residual(u) = 0`` for power series ``u`` (batched over nodes) up to ``order``.

    First the constant terms are found by a damped Newton iteration on the
    pointwise problem (all nodes at once; nodes that fail start again from
    their nearest converged neighbour's solution, as the paper's "memory"
    Newton).  Then **Newton's iteration on series with precision doubling**
    (Bostan et al., *Algorithmes efficaces en calcul formel*, th. 3.12, the
    paper's reference) lifts the solution from order k to 2k+1 per step: the
    Jacobian series is obtained exactly by a complex step on the series (one
    batched evaluation for all unknowns) and the linear series system is
    solved order by order.  Doubling needs ~log2(order) residual evaluations
    instead of ``order`` for the order-by-order scheme.

    Parameters
    ----------
    residual : callable
        ``residual(u, k) -> list`` (same length as ``u``), evaluated at working order ``k``: the
        unknowns ``u`` are Series of order ``k``, or plain arrays of constant terms when ``k = 0``.
    u0 : list of Series
        Starting values; their constant terms start the pointwise Newton, their
        higher coefficients (if any) are used as the starting guess at each order.
    order : int
    tol : float
        Tolerance on the constant-term residual (max-norm).
    maxiter : int
        Pointwise Newton iterations (the paper's rule: 20).
    names : tuple of str
        Names of the unknowns (for messages).
    t_nodes : ndarray
        Times of the nodes (for messages).

    Returns
    -------
    (list of Series, SeriesNewtonReport)
    """
    from .series import Series

    n = len(u0)
    base = [u if isinstance(u, Series) else Series.constant(np.asarray(u, dtype=float), 0) for u in u0]
    batch = base[0].batch_shape
    t_nodes = np.arange(int(np.prod(batch))) if t_nodes is None else np.asarray(t_nodes)

    def const_fun(x):
        return np.stack([np.broadcast_to(r.coeffs[..., 0] if isinstance(r, Series) else r, x.shape[1:])
                         for r in residual(list(x), 0)])

    x0 = np.stack([np.broadcast_to(np.real(u.constant_term), batch) for u in base]).astype(float)
    res = newton(const_fun, x0, tol=tol, maxiter=maxiter)
    x, cres, its = res.x, res.residual, res.iterations
    # Memory Newton: restart failed nodes from their nearest converged neighbour, sweeping outwards.
    for _ in range(8):
        bad = ~(cres <= tol)
        if not np.any(bad) or np.all(bad) or len(batch) != 1:
            break
        good_idx = np.flatnonzero(~bad)
        bad_idx = np.flatnonzero(bad)
        nearest = good_idx[np.argmin(np.abs(bad_idx[:, None] - good_idx[None, :]), axis=1)]
        xs = x.copy()
        xs[:, bad_idx] = x[:, nearest]
        r2 = newton(const_fun, xs, tol=tol, maxiter=maxiter)
        improved = r2.residual < cres
        if not np.any(improved & bad):
            break
        x = np.where(improved, r2.x, x)
        cres = np.where(improved, r2.residual, cres)
        its = max(its, r2.iterations)
    warnings = []
    flat_t = np.ravel(t_nodes)
    failed = np.flatnonzero(~(np.ravel(cres) <= PAPER_TOL))  # NaN fails too
    if failed.size:
        worst = int(failed[np.argmax(np.ravel(cres)[failed])])
        warnings.append(f"Newton ({', '.join(names)}) did not reach 1e-3 after {maxiter} iterations at "
                        f"{failed.size} node(s), t = {_time_ranges(flat_t, failed)} s; worst residual "
                        f"{np.ravel(cres)[worst]:.3g} at t = {flat_t[worst]:.6g} s (trajectory too close to a "
                        f"singularity of the flat output, or outside what the aircraft can fly?)")

    # Lift to series by precision doubling.
    def padded(u: Series, k: int) -> Series:
        return u.truncate(k) if u.order >= k else u.pad(k)

    u = []
    for j in range(n):
        c = np.array(padded(base[j], order).coeffs, dtype=float)
        c[..., 0] = x[j]
        u.append(Series(c))
    orders = []
    k = 0
    h = 1e-30
    while k < order:
        k = min(2 * k + 1, order)
        orders.append(k)
        cur = [ui.truncate(k) for ui in u]
        stacked = np.stack([np.broadcast_to(ci.coeffs, batch + (k + 1,)) for ci in cur])   # (n, *batch, K)
        pert = np.broadcast_to(stacked, (n + 1,) + stacked.shape).astype(complex).copy()  # (n+1, n, *batch, K)
        for j in range(n):
            pert[j + 1, j, ..., 0] += 1j * h
        us = [Series(pert[:, j]) for j in range(n)]
        rs = residual(us, k)
        R = np.stack([np.broadcast_to(r.coeffs if isinstance(r, Series) else np.asarray(r)[..., None],
                                      (n + 1,) + batch + (k + 1,)) for r in rs])  # (neq, n+1, *batch, K)
        G = np.real(R[:, 0])
        Jc = np.imag(R[:, 1:]) / h                    # (neq, n, *batch, K)
        D = _series_solve(Jc, G)
        u = [Series(stacked[j] - D[j]) for j in range(n)]
        u = [Series(np.concatenate([ui.coeffs, padded(base[j], order).coeffs[..., k + 1:]], axis=-1))
             if k < order else ui for j, ui in enumerate(u)]
    final = residual(u, order)
    sres = np.max(np.stack([np.max(np.abs(np.broadcast_to(r.coeffs, batch + (order + 1,))), axis=-1)
                            for r in final]), axis=0)
    rep = SeriesNewtonReport(tuple(names), t_nodes, cres, its, sres, orders, warnings)
    return u, rep
