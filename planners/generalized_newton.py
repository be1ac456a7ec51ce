"""Newton's method on the fixed point of generalized flatness (the question of the paper's conclusion).

The J iterations of ``GeneralizedFlatParametrization`` (paper section "From calibration to time
varying controls") are a fixed-point iteration ``H := G(H)`` on the neglected terms
``H = (p, q, r, dl, dm, dn)``: ``G`` runs the flat parametrization (:func:`planners.flat.parametrize`)
with the force coefficients evaluated at ``H`` and returns the rates and surfaces it finds.

At a node, with the flat outputs at order ``kappa`` and ``H`` at the stage-2 order ``N = kappa - 2``,
``G`` returns ``p, q, r`` at order ``N - 1`` and ``dl, dm, dn`` at ``N - 2`` (the paper's order loss
L = 2).  ``G~`` pads these with zero coefficients up to ``N``; the paper's iterate ``j`` agrees with
the j-th iterate of ``H := G~(H)`` on every coefficient it keeps (the padded coefficients reach the
kept ones only after more than J iterations), so the fixed point of ``G~`` is the limit of the
paper's iteration at that starting order.  This module solves ``F(H) = H - G~(H) = 0`` by Newton's
method, node by node, on the coefficient vectors of the six series.

**The exact series Jacobian.**  ``dG`` is a linear differential operator of order 2 with series
coefficients: stage 2 is algebraic in ``H`` (implicit function theorem on the force equations:
``du = -R_u^-1 R_H dH``), stage 3 differentiates ``alpha, beta, mu`` once and stage 4 differentiates
``p, q, r`` once more.  Each stage's partial derivatives are series obtained exactly by a complex
step on the series (as in :func:`planners.newton.newton_series`), with constant directions, and a
direction ``t - t_i`` for the one derivative stage 3 takes; the stages are composed as matrices on
the truncated coefficients (multiplication by a series: a lower-triangular Toeplitz block;
``d/dt``: a shift).  The Newton matrix ``I - dG~`` has size ``6 (N + 1)`` per node.

The plan keeps the iterates: iterate 0 is the flat plan at order ``kappa`` (identical to the
fixed-point method's iterate 0); iterate ``n >= 1`` is the flat parametrization at the n-th Newton
iterate of ``H``, truncated to the orders of the fixed-point method's iterate J (controls at
order ``e``): the same output orders.
"""

from __future__ import annotations

import time

import numpy as np

from gna.eom import Controls, HValues, State, aero_coefficients, body_moments, rotational_dynamics
from gna.ground_effect import ground_effect_coefficients

from .flat import STAGE_OF, FlatProblem, NodeSolution, force_residuals, parametrize, stage1, stage3
from .series import Series

#: The neglected terms H, in the order of :class:`gna.eom.HValues`.
H_NAMES = ("p", "q", "r", "dl", "dm", "dn")
#: Complex step (the derivative is exact to rounding: no subtraction).
_STEP = 1e-30
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


def _derivative_matrix(n: int, k_in: int) -> np.ndarray:
    """``d/dt`` of n series of order ``k_in`` (to order ``k_in - 1``), on coefficients."""
    D = np.zeros((n, k_in, n, k_in + 1))
    for i in range(n):
        for k in range(k_in):
            D[i, k, i, k + 1] = k + 1
    return D.reshape(n * k_in, n * (k_in + 1))


def _resize_matrix(n: int, k_in: int, k_out: int) -> np.ndarray:
    """Truncation (``k_out < k_in``) or zero padding (``k_out > k_in``) of n series, on coefficients."""
    R = np.zeros((n, k_out + 1, n, k_in + 1))
    for i in range(n):
        for k in range(min(k_in, k_out) + 1):
            R[i, k, i, k] = 1.0
    return R.reshape(n * (k_out + 1), n * (k_in + 1))


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


def _series_matmul(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """Product of matrices of series (n, p, nodes, K + 1) x (p, q, nodes, K + 1), truncated."""
    K = min(A.shape[-1], B.shape[-1])
    out = np.zeros(A.shape[:1] + B.shape[1:2] + A.shape[2:3] + (K,))
    for m in range(K):
        out[..., m] = np.einsum("ipbl,pqbl->iqb", A[..., : m + 1], B[..., m::-1])
    return out


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
    """max |F| per node of (6, nodes, K) coefficients; non-finite -> inf."""
    r = np.max(np.abs(F), axis=(0, 2))
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


def _cs_jacobian(fun, inputs: list, order: int, coefficient: int = 0) -> np.ndarray:
    """Complex-step partial derivatives of ``fun(inputs) -> list`` along ``inputs[j] + i h t^coefficient``.

    Returns (n_out, n_in, nodes, order + 1): the series of ``d fun_i`` for the direction ``t^c`` on
    input j (for ``c = 0``: the partial derivative series; all inputs in one batched call).
    """
    n = len(inputs)
    nodes = inputs[0].batch_shape[0]
    base = np.stack(
        [np.broadcast_to(np.asarray(u.truncate(order).coeffs, dtype=complex), (nodes, order + 1)) for u in inputs]
    )  # (n, nodes, K)
    pert = np.broadcast_to(base, (n,) + base.shape).copy()  # (n dirs, n, nodes, K)
    for j in range(n):
        pert[j, j, :, coefficient] += 1j * _STEP
    outs = fun([Series(pert[:, j]) for j in range(n)])
    jac = []
    for o in outs:
        c = o.coeffs if isinstance(o, Series) else np.asarray(o)[..., None]
        c = np.broadcast_to(c, (n, nodes, c.shape[-1]))
        full = np.zeros((n, nodes, order + 1))
        m = min(order + 1, c.shape[-1])
        full[..., :m] = np.imag(c[..., :m]) / _STEP
        jac.append(full)
    return np.stack(jac)


# ----------------------------------------------------------------------------- the map G and its Jacobian


def pad_h(h: HValues, nodes: int, order: int) -> np.ndarray:
    """Coefficients (6, nodes, order + 1) of H values (floats or series), zero-padded: ``G~``'s padding.

    Parameters
    ----------
    h : HValues
        Rates [rad/s] and surfaces [rad]: floats, arrays (nodes,) or series.
    nodes : int
        Number of nodes.
    order : int
        Order of the result (the stage-2 order ``N``).

    Returns
    -------
    ndarray, shape (6, nodes, order + 1)
        Taylor coefficients of ``p, q, r, dl, dm, dn``.
    """
    return np.stack([_coeffs(v, nodes, order) for v in h])


def _as_h(c: np.ndarray) -> HValues:
    return HValues(*(Series(ci) for ci in c))


def h_jacobian(problem: FlatProblem, t_nodes: np.ndarray, order: int, sol: NodeSolution, H: np.ndarray) -> np.ndarray:
    """Exact Jacobian of ``G~`` at the H that produced ``sol``, on the truncated coefficients.

    Parameters
    ----------
    problem : FlatProblem
        The flat problem.
    t_nodes : ndarray, shape (nodes,)
        Node times [s].
    order : int
        Order ``kappa`` of the flat outputs of ``sol`` (H at order ``N = kappa - 2``).
    sol : NodeSolution
        :func:`planners.flat.parametrize` at ``order`` with the H values ``H``.
    H : ndarray, shape (6, nodes, N + 1)
        Coefficients of ``p, q, r, dl, dm, dn`` [rad/s, rad] at which to linearize.

    Returns
    -------
    ndarray, shape (nodes, 6 (N + 1), 6 (N + 1))
        ``dG~/dH``: row ``i (N + 1) + k`` is coefficient k of output i (``p, q, r, dl, dm, dn``),
        column ``j (N + 1) + l`` coefficient l of input j.  Rows of padded coefficients are zero.
    """
    ac, env = problem.aircraft, problem.env
    m, g = ac.mass.mass, env.g
    nodes = len(t_nodes)
    N = order - 2
    K4 = order - 4
    s = sol.series
    # Stage-2 inputs, as in planners.flat.parametrize.
    t = Series.variable(np.asarray(t_nodes, dtype=float), order)
    x, y, z = problem.x(t), problem.y(t), problem.z(t)
    V, gamma, chi = stage1(x, y, z)
    Vd, gd, chid = V.derivative(), gamma.derivative(), chi.derivative()
    z2, V2, gamma2, chi2 = z.truncate(N), V.truncate(N), gamma.truncate(N), chi.truncate(N)
    zeta = problem.zeta
    tz = Series.variable(t_nodes, N)
    zv = zeta.value(tz)
    f1 = zeta.f1(tz) if zeta.kind == "mix" else None
    f2 = zeta.f2(tz) if zeta.kind == "mix" else None
    eta_pres = problem.eta(Series.variable(t_nodes, order)) if problem.eta is not None else None
    eta2 = eta_pres.truncate(N) if eta_pres is not None else 0.0

    def r2(v):
        alpha, beta, mu, F = v[:4]
        h = HValues(*v[4:])
        out = list(force_residuals(ac, env, z2, V2, gamma2, chi2, Vd, gd, chid, eta2, h, alpha, beta, mu, F))
        if zeta.kind == "beta":
            out.append(beta - zv)
        elif zeta.kind == "mu":
            out.append(mu - zv)
        elif zeta.kind == "F":
            out.append((F - zv) / (m * g))
        else:
            out.append(f1 * beta + f2 * mu - zv)
        return out

    u2 = [s[k].truncate(N) for k in ("alpha", "beta", "mu", "F")]
    jac2 = _cs_jacobian(r2, u2 + [Series(c) for c in H], N)  # (4, 10, nodes, N+1)
    S2 = -_block_toeplitz(_series_matmul(_series_inverse(jac2[:, :4]), jac2[:, 4:]), N, N)  # d(a, b, mu, F)/dH

    def r3(v):
        return list(stage3(v[0], v[1], v[2], gamma2, chi2))

    P0 = _cs_jacobian(r3, u2[:3], N)[..., :N]  # (3, 3, nodes, N): order N-1
    Pt = _cs_jacobian(r3, u2[:3], N, coefficient=1)[..., :N]
    P1 = Pt.copy()
    P1[..., 1:] -= P0[..., :-1]  # direction t: P0 t + P1
    M3 = _block_toeplitz(P0, N - 1, N) + _mm(_block_toeplitz(P1, N - 1, N - 1), _derivative_matrix(3, N))
    Spqr = _mm(M3, S2[:, : 3 * (N + 1)])  # (nodes, 3N, 6(N+1))

    # Stage 4: moment equations at order K4 (full model), as in planners.flat.parametrize.
    p, q, r = s["p"], s["q"], s["r"]
    pd, qd, rd = p.derivative(), q.derivative(), r.derivative()
    z4, V4, g4, c4 = z.truncate(K4), V.truncate(K4), gamma.truncate(K4), chi.truncate(K4)
    qbar4 = 0.5 * env.density(z4) * V4 * V4
    eta4 = eta_pres.truncate(K4) if eta_pres is not None else None
    dn4 = problem.dn(Series.variable(t_nodes, order)).truncate(K4) if problem.dn is not None else None

    def r4(v):
        alpha, beta, mu, F, pp, qq, rr, pdd, qdd, rdd, c1, c2, c3 = v
        st = State(0.0, 0.0, z4, V4, g4, c4, alpha, beta, mu, pp, qq, rr)
        ctl = Controls(F, eta4, c1, c2, c3) if problem.eta is not None else Controls(F, c3, c1, c2, dn4)
        full = ground_effect_coefficients(ac, env, st.z, aero_coefficients(ac, st, ctl))
        L, M, Nm = body_moments(ac, st, ctl, full, qbar4)
        a_p, a_q, a_r = rotational_dynamics(ac, st.p, st.q, st.r, L, M, Nm)
        return [a_p - pdd, a_q - qdd, a_r - rdd]

    names4 = ("dl", "dm", "dn") if problem.eta is not None else ("dl", "dm", "eta")
    in4 = (
        [s[k].truncate(K4) for k in ("alpha", "beta", "mu", "F", "p", "q", "r")]
        + [pd.truncate(K4), qd.truncate(K4), rd.truncate(K4)]
        + [s[k].truncate(K4) for k in names4]
    )
    jac4 = _cs_jacobian(r4, in4, K4)  # (3, 13, nodes, K4+1)
    rhs = (
        _mm(_block_toeplitz(jac4[:, :4], K4, K4), _mm(_resize_matrix(4, N, K4), S2))
        + _mm(_block_toeplitz(jac4[:, 4:7], K4, K4), _mm(_resize_matrix(3, N - 1, K4), Spqr))
        + _mm(_block_toeplitz(jac4[:, 7:10], K4, K4), _mm(_derivative_matrix(3, N - 1), Spqr))
    )
    Sv = -_mm(_block_toeplitz(_series_inverse(jac4[:, 10:]), K4, K4), rhs)  # (nodes, 3(K4+1), 6(N+1))

    n_surf = 3 if problem.eta is not None else 2  # a fixed rudder is not an unknown
    dG = np.zeros((nodes, 6, N + 1, 6 * (N + 1)))
    dG[:, :3, :N] = Spqr.reshape(nodes, 3, N, -1)
    dG[:, 3 : 3 + n_surf, : K4 + 1] = Sv.reshape(nodes, 3, K4 + 1, -1)[:, :n_surf]
    return dG.reshape(nodes, 6 * (N + 1), 6 * (N + 1))


def truncate_solution(sol: NodeSolution, order: int) -> NodeSolution:
    """A node solution with every series truncated to its stage's order for flat outputs at ``order``.

    Parameters
    ----------
    sol : NodeSolution
        Solution at an order ``>= order``.
    order : int
        Order kappa of the flat outputs of the result (controls at ``order - 4``).

    Returns
    -------
    NodeSolution
        Same reports; ``x`` at ``order``, ``V`` at ``order - 1``, ..., the controls at ``order - 4``.
    """
    out = {k: v.truncate(min(v.order, order - STAGE_OF.get(k, 4))) for k, v in sol.series.items()}
    return NodeSolution(out, order, sol.reports)


def g_residual(sol: NodeSolution, H: np.ndarray) -> np.ndarray:
    """``F(H) = H - G~(H)`` on the coefficients, from the solution ``sol = parametrize(..., h=H)``.

    Parameters
    ----------
    sol : NodeSolution
        Flat parametrization computed with the H values ``H``.
    H : ndarray, shape (6, nodes, N + 1)
        The coefficients of ``p, q, r, dl, dm, dn`` it was computed with.

    Returns
    -------
    ndarray, shape (6, nodes, N + 1)
        ``H`` minus the zero-padded rates and surfaces of ``sol`` [rad/s, rad].
    """
    nodes, N = H.shape[1], H.shape[2] - 1
    return H - pad_h(sol.h_values(), nodes, N)


def plan_newton(problem: FlatProblem, t_nodes: np.ndarray, J: int, e: int = 1, tol: float = 1e-12, maxiter: int = 8):
    """Iterates of Newton's method on ``H = G~(H)`` at the fixed-point method's starting order.

    Parameters
    ----------
    problem : FlatProblem
        The flat problem (its ``h`` starts the iteration, as for the fixed point).
    t_nodes : ndarray, shape (nodes,)
        Node times [s].
    J : int
        Depth: the starting order ``kappa = e + 4 + 2 J`` of the fixed-point method with J iterations.
    e : int
        Order of the controls in the returned iterates.
    tol : float
        Stop when ``max |H - G~(H)|`` over nodes and coefficients is below this [rad/s, rad].  A step
        that does not decrease a node's residual is halved there (at most :data:`HALVINGS` times).
    maxiter : int
        Newton steps at most.

    Returns
    -------
    iterates : list of NodeSolution
        Iterate 0 (the flat plan, order ``kappa``), then one per Newton step, truncated to order ``e + 4``.
    info : dict
        ``"residual"``: ``max |H - G~(H)|`` of each iterate; ``"timings"``: wall time [s] per iterate;
        ``"order"``: ``kappa``; ``"status"``: ``"converged"`` (below ``tol``), ``"stagnated"`` (a step
        that does not decrease the residual even damped), ``"diverged"`` (non-finite) or ``"maxiter"``;
        ``"damping"``: the smallest step factor of each step (1: full Newton steps).
    """
    from .generalized import ORDER_LOSS, STAGES

    kappa = e + STAGES + J * ORDER_LOSS
    N = kappa - 2
    nodes = len(t_nodes)
    t_start = time.perf_counter()
    H = pad_h(problem.h, nodes, N)
    sol = parametrize(problem, t_nodes, kappa, h=None)
    iterates, residuals, timings = [sol], [], {0: time.perf_counter() - t_start}
    F = g_residual(sol, H)
    residuals.append(float(np.max(np.abs(F))))
    status, damping = "converged", []
    for n in range(1, maxiter + 1):
        if not residuals[-1] > tol:
            break
        t_start = time.perf_counter()
        dG = h_jacobian(problem, t_nodes, kappa, sol, H)
        A = np.eye(6 * (N + 1))[None] - dG
        rhs = np.moveaxis(F, 1, 0).reshape(nodes, -1)
        step = np.moveaxis(_gauss_solve(A, rhs).reshape(nodes, 6, N + 1), 0, 1)
        # Damped per node (the nodes are independent problems): halve the step where the node's
        # residual max |H - G(H)| does not decrease, at most HALVINGS times.
        r_node = _node_residual(F)
        lam = np.ones(nodes)
        for attempt in range(HALVINGS + 1):
            H_try = H - lam[None, :, None] * np.nan_to_num(step)
            sol_try = parametrize(problem, t_nodes, kappa, h=_as_h(H_try), guess=sol.series)
            F_try = g_residual(sol_try, H_try)
            ok = (_node_residual(F_try) < r_node) | (r_node <= tol)
            if np.all(ok) or attempt == HALVINGS:
                break
            lam = np.where(ok, lam, lam / 2)
        damping.append(float(np.min(lam)))
        H, sol, F = H_try, sol_try, F_try
        residuals.append(float(np.max(np.abs(F))))
        iterates.append(sol)
        timings[n] = time.perf_counter() - t_start
        if not np.isfinite(residuals[-1]):
            status = "diverged"
            break
        if not residuals[-1] < residuals[-2]:
            status = "stagnated"
            break
    else:
        if residuals[-1] > tol:
            status = "maxiter"
    if residuals[-1] > tol and status == "converged":
        status = "maxiter"
    out = [iterates[0]] + [truncate_solution(s, e + STAGES) for s in iterates[1:]]
    return out, {"residual": residuals, "timings": timings, "order": kappa, "status": status, "damping": damping}


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
