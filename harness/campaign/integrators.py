"""Integrators of the batched simulation (:func:`harness.campaign.batch.simulate_batch`).

``per_sample``: scipy's DOP853 step, error norm and step-size rule (Hairer,
Norsett & Wanner, *Solving ODEs I*, sec. II.10) vectorised over the samples,
each with its own time, step and error control, all evaluated in one call of
the batched right-hand side.  ``stacked``: scipy's DOP853 on the stacked
system (one step for all; cheap for smooth runs, but every sample's
saturation switch shortens everyone's steps).  ``fixed``: explicit Runge-Kutta
steps of a given size (accurate only for smooth right-hand sides).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.integrate import DOP853

from gna.errors import InputError

__all__ = ["per_sample", "stacked", "fixed", "TABLEAUS"]


def stacked(system, grid, t0, t1, rtol, atol):
    """scipy's DOP853 on the stacked system (tolerances divided by sqrt(n): RMS error norm over all samples).

    Parameters
    ----------
    system : harness.campaign.batch's stacked system
        ``rows`` x ``n`` states, ``rhs(t, Y[, cols])``, the domain bookkeeping.
    grid : ndarray, shape (m,)
        Output times [s], increasing, within ``[t0, t1]``.
    t0, t1 : float
        Span [s].
    rtol, atol : float
        Per-sample tolerances.

    Returns
    -------
    ndarray, shape (m, rows, n)
        States on the grid (dense output).

    Raises
    ------
    InputError
        The integrator failed.
    """
    rows, n = system.rows, system.n
    scale = math.sqrt(n)
    out = np.empty((len(grid), rows, n))
    gi = 0
    while gi < len(grid) and grid[gi] <= t0:
        out[gi] = system.Y0
        gi += 1

    def fun(t, y):
        return system.rhs(t, y.reshape(rows, n)).reshape(-1)

    solver = DOP853(fun, t0, system.Y0.reshape(-1), t1, rtol=rtol / scale, atol=atol / scale)
    while solver.status == "running":
        t_prev = solver.t
        msg = solver.step()
        if solver.status == "failed":
            raise InputError(f"batched integration failed at t = {t_prev:.6g} s: {msg}")
        dense = solver.dense_output()
        while gi < len(grid) and grid[gi] <= solver.t + 1e-12:
            out[gi] = dense(grid[gi]).reshape(rows, n)
            gi += 1
        if system.check(solver.t, solver.y.reshape(rows, n)):
            solver = DOP853(fun, solver.t, solver.y, t1, rtol=rtol / scale, atol=atol / scale)
    return out


def fixed(system, grid, t0, t1, max_step, tableau):
    """Explicit Runge-Kutta steps of at most ``max_step`` landing on every output time.

    Parameters
    ----------
    system : harness.campaign.batch's stacked system
        ``rows`` x ``n`` states, ``rhs(t, Y[, cols])``, the domain bookkeeping.
    grid : ndarray, shape (m,)
        Output times [s], increasing, within ``[t0, t1]``.
    t0, t1 : float
        Span [s].
    max_step : float
        Largest step [s].
    tableau : (A, B, C)
        Butcher tableau (:data:`TABLEAUS`).

    Returns
    -------
    ndarray, shape (m, rows, n)
        States on the grid.
    """
    A, B, C = tableau
    out = np.empty((len(grid), system.rows, system.n))
    Y, t = system.Y0.copy(), t0
    K = [None] * len(B)
    for gi, tg in enumerate(grid):
        if tg > t:
            m = max(int(math.ceil((tg - t) / max_step - 1e-9)), 1)
            h = (tg - t) / m
            for _ in range(m):
                for s in range(len(B)):
                    Ys = Y
                    for j in range(s):
                        if A[s][j] != 0.0:
                            Ys = Ys + (h * A[s][j]) * K[j]
                    K[s] = system.rhs(t + C[s] * h, Ys)
                step = sum((h * b) * k for b, k in zip(B, K) if b != 0.0)
                Y = Y + step
                t = t + h
                system.check(t, Y)
        out[gi] = Y
    return out


def _rk4():
    return ([[], [0.5], [0.0, 0.5], [0.0, 0.0, 1.0]], [1 / 6, 1 / 3, 1 / 3, 1 / 6], [0.0, 0.5, 0.5, 1.0])


def _dop853():
    # The 12-stage, 8th-order Dormand-Prince pair's propagating tableau (Hairer, Norsett & Wanner, ODEs I, II.10).
    from scipy.integrate._ivp import dop853_coefficients as c

    return (c.A[:12, :12].tolist(), c.B.tolist(), c.C[:12].tolist())


#: Fixed-step tableaus ``(A, B, C)``: classic RK4, and the 8th-order DOP853 propagating tableau.
TABLEAUS = {"rk4": _rk4, "rk8": _dop853}


def per_sample(system, grid, t0, t1, rtol, atol, max_steps=None):
    """DOP853 with a step size, error control and time per sample, all samples evaluated together.

    scipy's DOP853 step, error norm and step-size rule (Hairer, Norsett & Wanner, ODEs I, II.10),
    vectorised over the samples: a sample's steps depend on its own error only, like a single run;
    the output times are interpolated with DOP853's dense output.

    Parameters
    ----------
    system : harness.campaign.batch's stacked system
        ``rows`` x ``n`` states, ``rhs(t, Y[, cols])``, the domain bookkeeping.
    grid : ndarray, shape (m,)
        Output times [s], increasing, within ``[t0, t1]``.
    t0, t1 : float
        Span [s].
    rtol, atol : float
        Per-sample tolerances (scipy's meaning).
    max_steps : int, optional
        Steps (accepted or not) after which a sample is stopped and marked stalled
        (``system.stalled``): a sliding mode of the conditional integration can
        shrink the steps without end, for the single-run engine alike.

    Returns
    -------
    ndarray, shape (m, rows, n)
        States on the grid; a sample frozen out of the domain keeps its last state.
    """
    from scipy.integrate._ivp import dop853_coefficients as c

    A, B, C, E3, E5 = c.A[:12, :12], c.B, c.C[:12], c.E3, c.E5
    A_extra, C_extra, D = c.A[13:], c.C[13:], c.D
    rows, n, G = system.rows, system.n, len(grid)
    Y = system.Y0.copy()
    t = np.full(n, t0)
    out = np.empty((G, rows, n))
    gi = np.zeros(n, dtype=int)
    first = int(np.searchsorted(grid, t0 + 1e-12, side="right"))
    out[:first] = Y
    gi[:] = first
    h = np.full(n, min(1e-3, t1 - t0))
    rejected = np.zeros(n, dtype=bool)
    F = np.zeros((rows, n))
    system.steps = np.zeros(n, dtype=int)
    idx = np.nonzero(system.alive & (gi < G))[0]
    if idx.size:
        F[:, idx] = system.rhs(t[idx], Y[:, idx], idx)
    while idx.size:
        ti, yi, fi = t[idx], Y[:, idx], F[:, idx]
        hi = np.minimum(h[idx], t1 - ti)
        last = h[idx] >= t1 - ti
        K = np.empty((16, rows, idx.size))
        K[0] = fi
        for s in range(1, 12):
            K[s] = system.rhs(ti + C[s] * hi, yi + np.tensordot(A[s, :s], K[:s], axes=1) * hi, idx)
        ynew = yi + hi * np.tensordot(B, K[:12], axes=1)
        tnew = np.where(last, t1, ti + hi)
        K[12] = system.rhs(tnew, ynew, idx)
        scale = atol + np.maximum(np.abs(yi), np.abs(ynew)) * rtol
        e5 = ((np.tensordot(E5, K[:13], axes=1) / scale) ** 2).sum(axis=0)
        e3 = ((np.tensordot(E3, K[:13], axes=1) / scale) ** 2).sum(axis=0)
        denom = e5 + 0.01 * e3
        with np.errstate(divide="ignore", invalid="ignore"):
            norm = np.where(denom > 0, hi * e5 / np.sqrt(denom * rows), 0.0)
            grow = np.where(norm > 0, 0.9 * norm ** (-1 / 8), 10.0)
        ok = norm < 1.0
        factor = np.where(ok, np.minimum(10.0, grow), np.maximum(0.2, np.nan_to_num(grow, nan=0.2)))
        factor = np.where(ok & rejected[idx], np.minimum(factor, 1.0), factor)
        h[idx] = np.where(ok & last, np.maximum(hi * factor, h[idx]), hi * factor)
        rejected[idx] = ~ok
        system.steps[idx] += 1
        # Output times inside the accepted steps: DOP853's 7th-order dense output (3 more stages).
        dense = ok & (grid[np.minimum(gi[idx], G - 1)] <= tnew + 1e-12) & (gi[idx] < G)
        if dense.any():
            sub, cols = np.nonzero(dense)[0], idx[dense]
            Ks, hs = K[:, :, sub], hi[sub]
            for s, (a, cc) in enumerate(zip(A_extra, C_extra), start=13):
                Ks[s] = system.rhs(ti[sub] + cc * hs, yi[:, sub] + np.tensordot(a[:s], Ks[:s], axes=1) * hs, cols)
            dy = ynew[:, sub] - yi[:, sub]
            P = np.concatenate(
                [[dy, hs * Ks[0] - dy, 2 * dy - hs * (Ks[12] + Ks[0])], hs * np.tensordot(D, Ks, axes=1)]
            )
            todo = np.ones(sub.size, dtype=bool)
            while todo.any():
                k = np.nonzero(todo)[0]
                g = gi[cols[k]]
                x = (grid[g] - ti[sub[k]]) / hs[k]
                y = np.zeros((rows, k.size))
                for i, f in enumerate(P[::-1, :, k]):
                    y = (y + f) * (x if i % 2 == 0 else 1 - x)
                out[g, :, cols[k]] = (y + yi[:, sub[k]]).T
                gi[cols[k]] += 1
                todo[k] = (gi[cols[k]] < G) & (grid[np.minimum(gi[cols[k]], G - 1)] <= tnew[sub[k]] + 1e-12)
        acc = idx[ok]
        Y[:, acc], t[acc], F[:, acc] = ynew[:, ok], tnew[ok], K[12][:, ok]
        system.check_columns(t, Y, acc)
        if max_steps is not None:
            over = idx[system.alive[idx] & (system.steps[idx] >= max_steps)]
            system.alive[over], system.stalled[over], system.t_end[over] = False, True, t[over]
        idx = np.nonzero(system.alive & (gi < G))[0]
    for j in np.nonzero(gi < G)[0]:  # frozen samples keep their last state
        out[gi[j] :, :, j] = Y[:, j]
    return out
