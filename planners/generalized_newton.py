"""Newton's method on the fixed point of generalized flatness (the question of the paper's conclusion).

The J iterations of ``GeneralizedFlatParametrization`` (paper section "From calibration to time
varying controls") are a fixed-point iteration ``X^ := G(X^)`` on the neglected variables ``X^`` of an
almost chained system (:mod:`planners.chained`; for the aircraft ``H = (p, q, r, dl, dm, dn)``):
``G`` runs the flat parametrization (:func:`planners.chained.flat_parametrization`) with the
neglected terms at ``X^`` and returns the values of those variables it finds.

Each neglected variable is used at the order of the stage that first uses it (``kappa - h``; the
aircraft's H at ``N = kappa - 2``); ``G`` returns it ``L`` orders lower and ``G~`` pads it with zero
coefficients up to that order.  The paper's iterate ``j`` agrees with the j-th iterate of
``X^ := G~(X^)`` on every coefficient it keeps (the padded coefficients reach the kept ones only
after more than J iterations), so the fixed point of ``G~`` is the limit of the paper's iteration at
that starting order.  This module solves ``F(X^) = X^ - G~(X^) = 0`` by Newton's method, node by
node, on the coefficient vectors of the neglected variables.

**The exact series Jacobian.**  ``dG`` is a linear differential operator with series coefficients:
each stage is solved for its unknowns (implicit function theorem on its equations, ``du = -R_u^-1
(R_in d in)``), its inputs being the earlier unknowns, their first derivatives and the neglected
variables.  The partial derivatives of a stage's residual are series obtained exactly by a complex
step on the series (as in :func:`planners.newton.newton_series`), with constant directions; the
stages are composed as matrices on the truncated coefficients (multiplication by a series: a
lower-triangular Toeplitz block; ``d/dt``: a shift).

The plan keeps the iterates: iterate 0 is the flat parametrization at order ``kappa`` (identical to
the fixed-point method's iterate 0); iterate ``n >= 1`` is the flat parametrization at the n-th Newton
iterate of ``X^``, truncated to the orders of the fixed-point method's iterate J (the last stage's
unknowns at order ``e``): the same output orders.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping

import numpy as np

from gna.errors import InputError

from .chained import ChainedPlan, ChainedSystem, _at_order, check_grid, flat_parametrization
from .flat import FlatProblem
from .newton import series_jacobian
from .series import Series

#: Step halvings per Newton step where a node's residual does not decrease.
HALVINGS = 5


# ----------------------------------------------------------------------------- coefficient-space operators


def _block_toeplitz(jac: np.ndarray, k_out: int, k_in: int) -> np.ndarray:
    """Multiplication by a matrix of series as a matrix on coefficients.

    ``jac`` (n_out, n_in, nodes, K + 1) -> (nodes, n_out (k_out + 1), n_in (k_in + 1)); entry
    ``[i k, j l] = jac[i, j, :, k - l]`` for ``0 <= k - l <= K``.
    """
    n_out, n_in, nodes, kk = jac.shape
    k = np.arange(k_out + 1)[:, None]
    l_ = np.arange(k_in + 1)[None, :]
    d = np.broadcast_to(k - l_, (k_out + 1, k_in + 1))
    mask = (d >= 0) & (d < kk)
    out = np.zeros((nodes, n_out, k_out + 1, n_in, k_in + 1))
    for i in range(n_out):
        for j in range(n_in):
            blk = np.zeros((nodes, k_out + 1, k_in + 1))
            blk[:, mask] = jac[i, j][:, d[mask]]
            out[:, i, :, j, :] = blk
    return out.reshape(nodes, n_out * (k_out + 1), n_in * (k_in + 1))


def _mm(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Matrix product, batched over a leading node axis of either factor, in numpy's own loops.

    Not BLAS: these are many mid-size products, for which multi-threaded BLAS on a loaded machine
    (the shared 2-core machine of this project) was measured 5 to 20 times slower.
    """
    if a.ndim == 2:
        return np.einsum("ij,njk->nik", a, b)
    if b.ndim == 2:
        return np.einsum("nij,jk->nik", a, b)
    return np.einsum("nij,njk->nik", a, b)


def _series_inverse(A: np.ndarray) -> np.ndarray:
    """Inverse of a matrix of series ``A`` (n, n, nodes, K + 1), exactly lower triangular in the coefficients.

    ``W_0 = A_0^-1``, ``W_m = -W_0 sum_{l=1..m} A_l W_{m-l}`` (no fill-in above the diagonal, unlike a
    dense solve of the Toeplitz matrix).
    """
    Ab = np.moveaxis(A, (0, 1), (-2, -1))  # (nodes, K+1, n, n)
    W = np.zeros_like(Ab)
    W[:, 0] = np.linalg.inv(Ab[:, 0])
    for m in range(1, Ab.shape[1]):
        acc = np.einsum("blij,bljk->bik", Ab[:, 1 : m + 1], W[:, m - 1 :: -1][:, :m])
        W[:, m] = -W[:, 0] @ acc
    return np.moveaxis(W, (-2, -1), (0, 1))


def _gauss_solve(A: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Solve ``A x = b`` for a batch (B, n, n), (B, n) by Gaussian elimination with partial pivoting.

    Written in numpy (vectorised over the batch) rather than with LAPACK's batched ``gesv``: on a
    loaded machine multi-threaded BLAS made that call up to 50 times slower than this loop.  A
    zero pivot (singular node) gives non-finite values there, reported by the caller's residual.
    """
    A = np.array(A, dtype=float)
    x = np.array(b, dtype=float)
    B, n, _ = A.shape
    rows = np.arange(B)
    for k in range(n):
        piv = k + np.argmax(np.abs(A[:, k:, k]), axis=1)
        if np.any(piv != k):
            A[rows, k], A[rows, piv] = A[rows, piv], A[rows, k].copy()
            x[rows, k], x[rows, piv] = x[rows, piv], x[rows, k].copy()
        with np.errstate(divide="ignore", invalid="ignore"):
            f = A[:, k + 1 :, k] / A[:, k : k + 1, k]
        A[:, k + 1 :, k:] -= f[:, :, None] * A[:, None, k, k:]
        x[:, k + 1 :] -= f * x[:, k : k + 1]
    for k in range(n - 1, -1, -1):
        with np.errstate(divide="ignore", invalid="ignore"):
            x[:, k] = (x[:, k] - np.einsum("bj,bj->b", A[:, k, k + 1 :], x[:, k + 1 :])) / A[:, k, k]
    return x


def _node_residual(F: np.ndarray) -> np.ndarray:
    """max |F| per node of (nodes, size) coefficients; non-finite -> inf."""
    r = np.max(np.abs(F), axis=1)
    return np.where(np.isfinite(r), r, np.inf)


def _coeffs(values, nodes: int, order: int) -> np.ndarray:
    """Coefficients (nodes, order + 1) of a float, array or series, truncated or zero-padded."""
    out = np.zeros((nodes, order + 1))
    if isinstance(values, Series):
        c = np.real(np.broadcast_to(values.coeffs, (nodes, values.order + 1)))
        m = min(order, values.order) + 1
        out[:, :m] = c[:, :m]
    else:
        out[:, 0] = np.real(np.broadcast_to(np.asarray(values, dtype=complex), (nodes,)))
    return out


def _hat_orders(system: ChainedSystem, order: int) -> dict:
    """Order of each neglected variable where it is first used: ``kappa - h`` for stage h."""
    out = {}
    for h, s in enumerate(system.stages, start=1):
        for n in s.neglected:
            out.setdefault(n, order - h)
    return out


def hat_jacobian(system: ChainedSystem, order: int, sol: Mapping, hat: Mapping) -> np.ndarray:
    """Exact Jacobian ``dG~/dX^`` of the fixed-point map at the neglected values that produced ``sol``.

    Parameters
    ----------
    system : ChainedSystem
        The system.
    order : int
        Order kappa of ``sol``'s flat outputs.
    sol : NodeSolution or mapping of str -> Series
        :func:`planners.chained.flat_parametrization` at ``order`` with the neglected values ``hat``.
    hat : mapping of str -> Series
        The neglected values (:func:`_hat_dict` of a coefficient vector).

    Returns
    -------
    ndarray, shape (nodes, size, size)
        Rows and columns: the coefficients of the neglected variables in the order of
        :func:`_hat_orders` (each at the order of the stage first using it); rows of padded
        coefficients are zero.
    """
    horders = _hat_orders(system, order)
    names = list(horders)
    offsets, size = {}, 0
    for n in names:
        offsets[n] = size
        size += horders[n] + 1
    nodes = next(iter(sol.values())).batch_shape[0]
    sens = {}  # variable -> (nodes, K + 1, size): d variable / d hat, for the variables depending on hat
    orders = {}
    # the data independent of the neglected terms: flat outputs, inputs, derived series, and the unknowns
    # of the stages none of whose inputs depends on them (for the aircraft, stage 1)
    given = list(system.flat_outputs) + list(system.inputs)
    fixed = {z: sol[z] for z in given}
    fixed.update({z + "'": sol[z].derivative() for z in given if sol[z].order >= 1})
    if system.derived is not None:
        fixed.update(system.derived(dict(sol), order))
    for h, stage in enumerate(system.stages, start=1):
        k = order - h
        inputs = {}
        for n in sens:
            inputs[n] = (sol[n], _rows(sens[n], k))
            if orders[n] >= 1:  # d/dt on the coefficients: row m is (m + 1) times row m + 1
                d = sens[n][:, 1:] * np.arange(1.0, orders[n] + 1)[:, None]
                inputs[n + "'"] = (sol[n].derivative(), _rows(d, k))
        upstream = len(inputs)
        for n in stage.neglected:  # d hat_n / d hat: a selection of columns (placed below, no product)
            inputs[n] = (hat[n], None)
        if not inputs:  # nothing upstream depends on the neglected terms
            fixed.update({u: sol[u] for u in stage.unknowns})
            fixed.update({u + "'": sol[u].derivative() for u in stage.unknowns if sol[u].order >= 1})
            continue
        pnames = list(stage.unknowns) + list(inputs)
        base = [sol[u] for u in stage.unknowns] + [inputs[p][0] for p in inputs]
        base = [b.truncate(k) if b.order >= k else b.pad(k) for b in base]
        fixed_k = _at_order(fixed, k)

        def fun(vals, pnames=pnames, fixed_k=fixed_k, stage=stage):
            v = dict(fixed_k)
            v.update(zip(pnames, vals))
            return stage.residual(v)

        stacked = np.stack([np.broadcast_to(np.real(b.coeffs), (nodes, k + 1)) for b in base])
        jac = series_jacobian(lambda us, kk: fun(us), stacked, k)  # (n_eq, n_in, nodes, k+1)
        nu = len(stage.unknowns)
        # d residual / d hat: through the upstream unknowns (a product), and directly (columns placed)
        rhs = np.zeros((nodes, jac.shape[0] * (k + 1), size))
        if upstream:
            dinputs = np.concatenate([d for _, d in list(inputs.values())[:upstream]], axis=1)
            rhs += _mm(_block_toeplitz(jac[:, nu : nu + upstream], k, k), dinputs)
        for i, n in enumerate(list(inputs)[upstream:]):
            m = min(k, horders[n]) + 1
            rhs[:, :, offsets[n] : offsets[n] + m] += _block_toeplitz(
                jac[:, nu + upstream + i : nu + upstream + i + 1], k, k
            )[:, :, :m]
        S = -_mm(_block_toeplitz(_series_inverse(jac[:, :nu]), k, k), rhs)
        for i, u in enumerate(stage.unknowns):
            sens[u] = S[:, i * (k + 1) : (i + 1) * (k + 1)]
            orders[u] = k
    dG = np.zeros((nodes, size, size))
    for n in names:
        if n in sens:  # a prescribed input does not depend on them
            dG[:, offsets[n] : offsets[n] + horders[n] + 1] = _rows(sens[n], horders[n])
    return dG


def _rows(S: np.ndarray, k: int) -> np.ndarray:
    """Sensitivities ``S`` (nodes, rows, size) of a series truncated or zero-padded to order k: (nodes, k + 1, size)."""
    if S.shape[1] >= k + 1:
        return S[:, : k + 1]
    return np.concatenate([S, np.zeros((S.shape[0], k + 1 - S.shape[1], S.shape[2]))], axis=1)


def _hat_vector(system, order, values: Mapping, nodes: int) -> np.ndarray:
    """(nodes, size) coefficients of the neglected variables (series or constants), zero-padded."""
    horders = _hat_orders(system, order)
    parts = [_coeffs(values.get(n, system.neglected_start(n)), nodes, horders[n]) for n in horders]
    return np.concatenate(parts, axis=1)


def _hat_dict(system, order, vec: np.ndarray) -> dict:
    out, i = {}, 0
    for n, K in _hat_orders(system, order).items():
        out[n] = Series(vec[:, i : i + K + 1])
        i += K + 1
    return out


def newton_parametrization(
    system: ChainedSystem,
    t_nodes,
    zeta: Mapping[str, Callable] | None = None,
    J: int = 0,
    e: int = 1,
    v: Mapping | None = None,
    tol: float = 1e-13,
    maxiter: int = 8,
) -> ChainedPlan:
    """Newton's method on the fixed point of :func:`planners.chained.generalized_parametrization`
    (same starting order ``kappa = e + r + J L``).

    The neglected variables ``X^`` are the unknowns of ``F(X^) = X^ - G~(X^)``; the Jacobian is exact
    (:func:`hat_jacobian`).  A step that does not decrease a node's residual ``max |F|`` is halved
    there, at most :data:`HALVINGS` times (the nodes are independent problems).

    Parameters
    ----------
    system : ChainedSystem
        The system.
    t_nodes : array, shape (nodes,)
        Increasing node times.
    zeta : mapping of str -> callable, optional
        The flat outputs as functions of t (default: the system's :attr:`ChainedSystem.outputs`).
    J : int
        Depth: the starting order ``kappa = e + r + J L`` of the fixed point with J iterations.
    e : int
        Order of the last stage's unknowns in the returned iterates.
    v : mapping, optional
        Starting values of the neglected variables (default: :meth:`ChainedSystem.neglected_start`).
    tol : float
        Stop when ``max |X^ - G~(X^)|`` over nodes and coefficients is below this.
    maxiter : int
        Newton steps at most.

    Returns
    -------
    ChainedPlan
        Iterate 0 (the flat parametrization at ``kappa``), then one per Newton step truncated to the
        fixed point's last-iterate orders; ``timings`` per iterate; ``residuals``: ``max |X^ - G~(X^)|``
        per iterate; ``info``: ``"status"`` (``"converged"`` below ``tol``, ``"stagnated"`` a step
        that does not decrease the residual even damped, ``"diverged"`` non-finite, ``"maxiter"``),
        ``"damping"`` (the smallest step factor of each step) and ``"order"`` (kappa).

    Raises
    ------
    InputError
        Fewer than two increasing nodes or a negative J.
    """
    t_nodes = check_grid(t_nodes)
    if J < 0:
        raise InputError(f"J must be >= 0, got {J}")
    kappa = e + system.r + J * system.L
    nodes = len(t_nodes)
    names = list(_hat_orders(system, kappa))
    t0 = time.perf_counter()
    x = _hat_vector(system, kappa, dict(v or {}), nodes)
    sol = flat_parametrization(system, t_nodes, kappa, zeta, hat=_hat_dict(system, kappa, x))
    iterates, timings = [sol], {0: time.perf_counter() - t0}

    def residual(sol, x):
        return x - _hat_vector(system, kappa, {n: sol[n] for n in names}, nodes)

    F = residual(sol, x)
    res = [float(np.max(np.abs(F)))]
    status, damping = "converged", []
    for n in range(1, maxiter + 1):
        if not res[-1] > tol:
            break
        t0 = time.perf_counter()
        dG = hat_jacobian(system, kappa, sol, _hat_dict(system, kappa, x))
        step = np.nan_to_num(_gauss_solve(np.eye(x.shape[1])[None] - dG, F))
        r_node = _node_residual(F)
        lam = np.ones(nodes)
        for attempt in range(HALVINGS + 1):
            x_try = x - lam[:, None] * step
            # carry=False: the last Newton step of each stage starts within the tolerance (dG is exact there)
            sol_try = flat_parametrization(
                system, t_nodes, kappa, zeta, hat=_hat_dict(system, kappa, x_try), guess=sol, carry=False
            )
            F_try = residual(sol_try, x_try)
            ok = (_node_residual(F_try) < r_node) | (r_node <= tol)
            if np.all(ok) or attempt == HALVINGS:
                break
            lam = np.where(ok, lam, lam / 2)
        damping.append(float(np.min(lam)))
        x, sol, F = x_try, sol_try, F_try
        res.append(float(np.max(np.abs(F))))
        iterates.append(sol)
        timings[n] = time.perf_counter() - t0
        if not np.isfinite(res[-1]):
            status = "diverged"
            break
        if not res[-1] < res[-2]:
            status = "stagnated"
            break
    if res[-1] > tol and status == "converged":
        status = "maxiter"
    k_last = e + system.r
    out = [iterates[0]] + [truncate_solution(system, it, k_last) for it in iterates[1:]]
    return ChainedPlan(system, t_nodes, out, timings, res, {"status": status, "damping": damping, "order": kappa})


def truncate_solution(system: ChainedSystem, sol, order: int):
    """A node solution with every series truncated to its stage's order for flat outputs at ``order``.

    Parameters
    ----------
    system : ChainedSystem
        The system of ``sol``.
    sol : NodeSolution
        Solution at an order ``>= order``.
    order : int
        Order kappa of the flat outputs of stage 1 in the result.

    Returns
    -------
    NodeSolution
        Same reports; a variable of stage h (:meth:`ChainedSystem.stage_of`) at ``order - h + 1``.
    """
    from .chained import NodeSolution

    out = {k: s.truncate(min(s.order, order - system.stage_of(k) + 1)) for k, s in sol.items()}
    return NodeSolution(out, order, sol.reports)


class ModelCounter:
    """An aerodynamic model that counts its evaluations (wraps the aircraft's model).

    Parameters
    ----------
    aero : object
        The model (``coefficients(AeroState)``), e.g. a :class:`gna.aero.TermTable`.

    Attributes
    ----------
    calls : int
        Number of ``coefficients`` calls (one batched evaluation each).
    points : int
        Number of series (or numbers) evaluated: the sum over calls of the batch sizes.
    """

    def __init__(self, aero):
        self._aero = aero
        self.calls = 0
        self.points = 0

    def coefficients(self, state):
        """Count, then evaluate the wrapped model.

        Parameters
        ----------
        state : AeroState
            Aerodynamic variables (floats, arrays or series).

        Returns
        -------
        Coefficients
            The wrapped model's coefficients.
        """
        self.calls += 1
        size = 1
        for v in state:
            shape = v.batch_shape if isinstance(v, Series) else np.shape(v)
            size = max(size, int(np.prod(shape)) if len(shape) else 1)
        self.points += size
        return self._aero.coefficients(state)

    def __getattr__(self, name):
        return getattr(self._aero, name)

    def __len__(self) -> int:
        return len(self._aero)


def counted(problem: FlatProblem) -> tuple[FlatProblem, ModelCounter]:
    """The same problem on an aircraft whose aerodynamic model counts its evaluations.

    Parameters
    ----------
    problem : FlatProblem
        Any flat problem.

    Returns
    -------
    (FlatProblem, ModelCounter)
        The problem with the counting model, and the counter.
    """
    from dataclasses import replace

    counter = ModelCounter(problem.aircraft.aero)
    return replace(problem, aircraft=replace(problem.aircraft, aero=counter)), counter
