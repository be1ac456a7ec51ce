"""Newton's method on truncated power series (paper section "Newton operator with series").

The pointwise batched Newton, its complex-step Jacobian and the batched
linear solve live in the model package (:mod:`gna.solve`) and are re-exported
here (``planners.newton.newton`` keeps working); this module adds the Newton
operator on series (:func:`newton_series`) and its report.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from gna.solve import COMPLEX_STEP, NewtonResult, batched_solve, jacobian, newton

from . import series as _series_kernels

__all__ = [
    "PAPER_TOL",
    "PAPER_MAXITER",
    "NewtonResult",
    "NewtonFailure",
    "ResidualEvaluator",
    "SeriesNewtonReport",
    "batched_solve",
    "doubling_orders",
    "jacobian",
    "newton",
    "newton_series",
    "series_jacobian",
]

#: The paper's failure rule (section "Newton operator with series"):
#: a residual above this after ``PAPER_MAXITER`` iterations is reported.
PAPER_TOL = 1e-3
PAPER_MAXITER = 20

#: Full-order Newton steps tried from a close start (``newton_series(..., warm=True)``) before the
#: full scheme (pointwise Newton, precision doubling) takes over.
WARM_MAXSTEPS = 8

#: Chord steps (the Jacobian of the last Newton step, or one carried from the previous generalized-flatness
#: iterate) go on while the rate of decrease they show reaches the tolerance within this many more steps;
#: else the next step is a Newton step.  Measured on the bundled roll: 2 gives 8 complex-step and 42 real
#: series evaluations, 3 gives 7 and 47 (the Newton step taken earlier leaves a Jacobian nearer the
#: solution for the next iterates), 5 gives 6 and 62.
CHORD_STEPS = 2

#: A chord step's result is accepted without evaluating its residual when the residual ``s`` it started
#: from, times the largest rate of decrease ``theta`` measured with the same Jacobian, is at most this
#: fraction of the tolerance (``theta s <= CHORD_PROOF tol``: the contraction bounds the new residual,
#: with a margin of 10 for a rate that varies from step to step).
CHORD_PROOF = 0.1


def _exponent_form(x: float) -> str:
    """``1e-3`` rather than ``0.001`` (the paper's way of writing its tolerance)."""
    mant, exp = f"{x:.0e}".split("e")
    return f"{mant}e{int(exp)}"


def _time_ranges(times: np.ndarray, idx: np.ndarray) -> str:
    """'0 .. 2.5, 7' for the consecutive runs of node indices ``idx`` (times ``times`` aligned with ``idx``)."""
    runs, start = [], 0
    for pos in range(len(idx)):
        if pos + 1 == len(idx) or idx[pos + 1] != idx[pos] + 1:
            runs.append(f"{times[start]:.6g}" if pos == start else f"{times[start]:.6g} .. {times[pos]:.6g}")
            start = pos + 1
    return ", ".join(runs)


@dataclass(frozen=True, eq=False)  # array fields: compare records by their fields, not with ==
class NewtonFailure:
    """Nodes where the pointwise Newton broke the paper's rule (residual above ``tol`` after ``maxiter``).

    Attributes
    ----------
    names : tuple of str
        The unknowns of the failed system (e.g. ``("alpha", "beta", "mu", "F")`` for stage 2).
    nodes : ndarray of int, shape (k,)
        Indices of the failed nodes in the (flattened) node grid.
    times : ndarray, shape (k,)
        Their times [s].
    residuals : ndarray, shape (k,)
        Max-norm of the constant-term residual at each failed node (NaN for a diverged node).
    worst_residual : float
        Largest of ``residuals``.
    worst_time : float
        Time of the node with the worst residual [s].
    maxiter : int
        Pointwise Newton iterations allowed (the paper's 20).
    tol : float
        The paper's failure threshold (1e-3).
    stage : str or None
        Stage of the flat parametrization (``"stage2"``, ``"stage4"``) when known.
    iterate : int or None
        Generalized-flatness iterate j when known.
    """

    names: tuple
    nodes: np.ndarray
    times: np.ndarray
    residuals: np.ndarray
    worst_residual: float
    worst_time: float
    maxiter: int
    tol: float
    stage: str | None = None
    iterate: int | None = None

    @property
    def n_nodes(self) -> int:
        """Number of failed nodes."""
        return int(len(self.nodes))

    @property
    def message(self) -> str:
        """The warning text: unknowns, failed times, worst residual and its time."""
        return (
            f"Newton ({', '.join(self.names)}) did not reach {_exponent_form(self.tol)} after {self.maxiter} "
            f"iterations at {self.n_nodes} node(s), t = {_time_ranges(self.times, self.nodes)} s; worst "
            f"residual {self.worst_residual:.3g} at t = {self.worst_time:.6g} s (trajectory too close to a "
            f"singularity of the flat output, or outside what the aircraft can fly?)"
        )


@dataclass
class SeriesNewtonReport:
    """Diagnostics of :func:`newton_series` for one batch of nodes.

    Attributes
    ----------
    names : tuple of str
        The unknowns.
    t_nodes : ndarray
        Times of the nodes [s].
    constant_residual : ndarray (nodes,)
        Max-norm residual of the constant-term (pointwise) Newton at each node (``warm``: of the
        constant term at the start of the last step, or its bound ``theta`` times that when the
        contraction rate accepted the step's result).
    constant_iterations : int
        Pointwise Newton iterations (the largest over the memory restarts).
    series_residual : ndarray (nodes,)
        Max abs coefficient of the residual series at the final order.  A check of the
        solution, not needed to produce it: evaluated on first access (one more residual
        evaluation), then kept; a report is pickled with it evaluated.
    doubling_orders : list of int
        Working orders of the precision-doubling steps.
    warnings : list of str
        Messages of ``failures``, for printing.
    failures : list of NewtonFailure
        The paper's rule broken (residual above 1e-3 after 20 iterations): empty, or one
        record naming the failed nodes, their times and the worst residual.
    jacobian : ndarray or None
        Jacobian series (neq, n, *batch, order + 1) of the last step, for the chord steps of
        the next generalized-flatness iterate (``newton_series(..., jacobian=)``); not pickled.
    """

    names: tuple
    t_nodes: np.ndarray
    constant_residual: np.ndarray
    constant_iterations: int
    _series_residual: object  # ndarray, or a callable computing it on first access
    doubling_orders: list
    warnings: list = field(default_factory=list)
    failures: list = field(default_factory=list)
    jacobian: object = field(default=None, repr=False, compare=False)  # not pickled (None once unpickled)

    @property
    def series_residual(self) -> np.ndarray:
        """Max abs coefficient of the residual series at the final order, per node.

        Evaluated on first access (one more residual evaluation), then kept.

        Returns
        -------
        ndarray, shape (nodes,)
        """
        if callable(self._series_residual):
            self._series_residual = self._series_residual()
        return self._series_residual

    @property
    def worst_residual(self) -> float:
        """Largest of the constant-term and series residuals over the nodes."""
        return float(max(np.max(self.constant_residual), np.max(self.series_residual)))

    def __getstate__(self) -> dict:
        state = dict(self.__dict__)
        state["_series_residual"] = self.series_residual
        state["jacobian"] = None
        return state


def _series_solve(Jc: np.ndarray, Gc: np.ndarray) -> np.ndarray:
    """Solve the series linear system J(t) D(t) = G(t) mod t^(K).

    ``Jc`` has shape (n, n, *batch, K), ``Gc`` (n, *batch, K); returns D (n, *batch, K).
    Order by order: ``J_0 D_m = G_m - sum_{l=1..m} J_l D_{m-l}``.
    """
    n = Jc.shape[0]
    K = Gc.shape[-1]
    batch = Gc.shape[1:-1]
    B = Gc[0, ..., 0].size
    J0 = Jc[..., 0].reshape(n, n, B).transpose(2, 0, 1)  # (B, n, n), a view
    try:
        J0inv = np.linalg.inv(J0)
    except np.linalg.LinAlgError:
        # A singular node (reported by the caller's warnings): least-squares step there.
        J0inv = np.linalg.pinv(J0)
    Jr = Jc.reshape(n, n, B, K).transpose(2, 0, 1, 3)  # (B, n, n, K), a view
    Gr = Gc.reshape(n, B, K).transpose(1, 0, 2)  # (B, n, K), a view
    D = _series_kernels._K.series_solve(Jr, J0inv, Gr)
    return D.transpose(1, 0, 2).reshape((n,) + batch + (K,))


def series_jacobian(residual: Callable, stacked: np.ndarray, k: int) -> np.ndarray:
    """Jacobian series ``(neq, n, *batch, K)`` of ``residual(list of Series, k) -> list`` at the coefficients
    ``stacked`` (n, *batch, K) of its n inputs (working order ``k = K - 1``): one batched complex step on
    the series, exact to rounding (:func:`_residual_and_jacobian`; the stages' partials of
    :mod:`planners.generalized_newton`, the tracking linearization).

    Parameters
    ----------
    residual : callable
        ``residual(us, k)`` on Series of batch shape ``(n, *batch)`` (pointwise in t: no time
        derivatives inside), outputs Series of order k, arrays or floats.
    stacked : ndarray, shape (n, *batch, K)
        Taylor coefficients of the inputs.
    k : int
        Working order.

    Returns
    -------
    ndarray, shape (neq, n, *batch, K)
        ``[a, b, ..., m]``: coefficient m of ``d residual_a / d input_b``.
    """
    return _residual_and_jacobian(residual, stacked, k)[1]


def _residual_and_jacobian(residual: Callable, stacked: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """Residual series ``G`` (neq, *batch, K) and Jacobian series ``Jc`` (neq, n, *batch, K) at the
    unknowns' coefficients ``stacked`` (n, *batch, K), working order ``k = K - 1``.

    One evaluation on the batch of the n complex steps (one per unknown): the imaginary parts
    give the Jacobian series, the real part of any of them the residual itself (the step's
    effect on it is O(h^2) = 1e-60 relative).
    """
    from .series import Series

    n = stacked.shape[0]
    batch = stacked.shape[1:-1]
    h = COMPLEX_STEP
    pert = np.broadcast_to(stacked, (n,) + stacked.shape).astype(complex)  # (n, n, *batch, K)
    for j in range(n):
        pert[j, j, ..., 0] += 1j * h
    us = [Series(pert[:, j]) for j in range(n)]
    rs = residual(us, k)
    R = np.stack(
        [
            np.broadcast_to(r.coeffs if isinstance(r, Series) else np.asarray(r)[..., None], (n,) + batch + (k + 1,))
            for r in rs
        ]
    )  # (neq, n, *batch, K)
    return np.real(R[:, 0]), np.imag(R) / h


def _usable_jacobian(jacobian, neq: int, n: int, batch: tuple, K: int):
    """``jacobian`` (neq, n, *batch, K' >= K) truncated to K coefficients, or None when its shape does not fit."""
    if jacobian is None:
        return None
    Jc = np.asarray(jacobian)
    if (
        Jc.ndim != 3 + len(batch)
        or Jc.shape[:2] != (neq, n)
        or tuple(Jc.shape[2:-1]) != tuple(batch)
        or Jc.shape[-1] < K
        or not np.all(np.isfinite(Jc[..., :K]))
    ):
        return None
    return Jc[..., :K]


def _warm_newton(
    residual: Callable,
    base: list,
    order: int,
    t_nodes: np.ndarray,
    tol: float,
    names: tuple,
    maxsteps: int = WARM_MAXSTEPS,
    carried=None,
    evaluator=None,
):
    """Newton's iteration on series at the full working order from a close start, or None.

    From a start close in every coefficient (the previous generalized-flatness iterate, whose H
    differs little), a Newton step at working order ``order`` (complex-step Jacobian series, the
    linear series system solved order by order, as in the precision-doubling steps) squares the
    error of every coefficient (Bostan et al., th. 3.12), so a few steps replace the pointwise
    Newton and the doubling steps.  Chord steps (the linear system of a Jacobian computed earlier,
    one real evaluation of the residual each, without the complex steps) go on while the rate of
    decrease they show reaches ``tol`` within :data:`CHORD_STEPS` more steps; else the next step is a
    Newton step (a fresh Jacobian).  With ``carried`` (the Jacobian series of a nearby problem, e.g.
    the previous generalized-flatness iterate's, truncated) the first steps are chord steps with it,
    its constant term replaced by the Jacobian of ``const_fun`` (the residual's constant term on plain
    arrays) at the start: one pointwise complex-step evaluation, far cheaper than one on series.  On
    the paper's plans that chord's first step decreases the residual as much as a Newton step (the
    Jacobian's constant term is what changes most between iterates) and the following ones by 1e-3
    to 1e-6 each.

    The test: after a step from a residual series whose coefficients, each weighted by ``step^m``
    (step = the smallest node spacing: its contribution over one node interval), are all at most
    ``tol``, the solution is accepted; with ``carried``, so is the result of a chord step from a
    residual ``s`` when ``theta s <= CHORD_PROOF tol``, theta the largest rate of decrease measured
    with the same Jacobian (a contraction of rate theta leaves a residual of at most about
    ``theta s``: no evaluation only to check it).  Without ``carried`` (a caller that differentiates
    the solution with respect to its data, as :mod:`planners.generalized_newton` does, needs it far
    below the tolerance) the last step always starts from a residual at most ``tol``.  None -- the
    caller then runs the full scheme -- when a residual
    is not finite, a Newton step does not decrease it, or it is still above ``tol`` after
    ``maxsteps`` evaluations.

    Returns
    -------
    (list of Series, SeriesNewtonReport) or None
    """
    from .series import Series

    ev = ResidualEvaluator(residual) if evaluator is None else evaluator
    n = len(base)
    batch = base[0].batch_shape
    K = order + 1
    t = np.ravel(np.asarray(t_nodes, dtype=float))
    dt = np.diff(t)
    step = float(np.min(dt)) if t.size > 1 and np.all(dt > 0) else 1.0
    native = getattr(ev, "warm_newton_series", None)
    if native is not None and len(batch) == 1:
        # the steps below, whole in native code (planners.program.NativeStageEvaluator) on the coefficient-first
        # storage; status 2 (a singular node) leaves them to the numpy steps, which take a least-squares step
        status, u, Jn, cres, steps = native(base, order, step, carried, tol, maxsteps, CHORD_STEPS, CHORD_PROOF)
        if status == 1:
            return None
        if status == 0:

            def native_residual() -> np.ndarray:
                return ev.series_residual(u, order, batch)

            rep = SeriesNewtonReport(
                tuple(names), np.asarray(t_nodes), cres, 0, native_residual, [order] * steps, jacobian=Jn
            )
            return u, rep
    stacked = np.stack(
        [
            np.broadcast_to(
                np.real(u.truncate(order).coeffs if u.order >= order else u.pad(order).coeffs), batch + (K,)
            )
            for u in base
        ]
    ).astype(float)
    weights = step ** np.arange(K)
    # Jc: the Jacobian of the steps; last: residual size where the last step with Jc started (None: no
    # step with Jc yet); theta: largest rate of decrease measured with Jc; newton_step: the last step
    # used a Jacobian computed at its start.
    Jc = _usable_jacobian(carried, n, n, batch, K)
    proof = Jc is not None
    if Jc is not None:
        # The constant term of the carried Jacobian at this start: one pointwise complex-step evaluation
        # on plain arrays (no series); the carried higher terms change less between iterates.
        Jc = Jc.copy()
        Jc[..., 0] = ev.const_jacobian(stacked[..., 0])
        if not np.all(np.isfinite(Jc[..., 0])):
            Jc = None
    last, theta, before, orders, newton_step = None, 0.0, None, [], False
    for _ in range(maxsteps):
        fresh = Jc is None
        if fresh:
            G, Jc = ev.residual_and_jacobian(stacked, order)
            if not np.all(np.isfinite(Jc)):
                return None
        else:
            G = ev.residual_only(stacked, order)
        orders.append(order)
        if not np.all(np.isfinite(G)):
            return None
        size = float(np.max(np.abs(G) * weights))
        if last is not None and not size < last:
            if newton_step:
                return None  # a Newton step that does not decrease the residual
            # A chord step that made it worse: back to where the residual was smaller, a Newton step there.
            stacked, Jc, last, theta = before, None, None, 0.0
            continue
        if fresh:
            last, theta = None, 0.0
        if last is not None:
            theta = max(theta, size / last)
        before, newton_step = stacked, fresh
        stacked = stacked - _series_solve(Jc, G)
        if size <= tol:
            bound = 1.0
            break
        if proof and last is not None and theta * size <= CHORD_PROOF * tol:
            bound = theta  # the contraction bounds the residual of the new point
            break
        if last is not None and np.log(tol / size) / np.log(theta) > CHORD_STEPS:
            Jc, last = None, size  # the chord contracts too slowly: a Newton step next
        else:
            last = size
    else:
        return None  # still above the tolerance after maxsteps evaluations
    if not np.all(np.isfinite(stacked)):
        return None
    u = [Series(stacked[j]) for j in range(n)]
    cres = bound * np.max(np.abs(G[..., 0]), axis=0)

    def series_residual() -> np.ndarray:
        return ev.series_residual(u, order, batch)

    rep = SeriesNewtonReport(tuple(names), np.asarray(t_nodes), cres, 0, series_residual, orders, jacobian=Jc)
    return u, rep


def _residual_only(residual: Callable, stacked: np.ndarray, k: int) -> np.ndarray:
    """Residual series ``G`` (neq, *batch, K) at the unknowns' coefficients ``stacked`` (n, *batch, K)."""
    from .series import Series

    batch = stacked.shape[1:-1]
    rs = residual([Series(stacked[j]) for j in range(stacked.shape[0])], k)
    return np.stack(
        [
            np.broadcast_to(
                np.real(r.coeffs) if isinstance(r, Series) else np.real(np.asarray(r))[..., None], batch + (k + 1,)
            )
            for r in rs
        ]
    )


class ResidualEvaluator:
    """The evaluations Newton's method on series needs from a residual, on the numpy path (the reference).

    ``residual(us, k) -> list`` is evaluated on :class:`~planners.series.Series` (complex-step Jacobians);
    :class:`planners.program.StageEvaluator` provides the same methods by compiled programs.

    Parameters
    ----------
    residual : callable
        ``residual(us, k) -> list``: unknowns as Series of order k (plain arrays at k = 0).
    """

    def __init__(self, residual: Callable) -> None:
        self.residual = residual

    def residual_and_jacobian(self, stacked: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
        """Residual series and Jacobian series at the unknowns' coefficients.

        Parameters
        ----------
        stacked : ndarray, shape (n, *batch, K)
            Taylor coefficients of the n unknowns (coefficient last).
        k : int
            Working order, ``K - 1``.

        Returns
        -------
        (ndarray, ndarray)
            ``G`` (neq, *batch, K) and ``Jc`` (neq, n, *batch, K): coefficient m of ``d r_a / d u_b``.
        """
        return _residual_and_jacobian(self.residual, stacked, k)

    def residual_only(self, stacked: np.ndarray, k: int) -> np.ndarray:
        """Residual series at the unknowns' coefficients.

        Parameters
        ----------
        stacked : ndarray, shape (n, *batch, K)
            Taylor coefficients of the n unknowns (coefficient last).
        k : int
            Working order, ``K - 1``.

        Returns
        -------
        ndarray, shape (neq, *batch, K)
        """
        return _residual_only(self.residual, stacked, k)

    def const_fun(self, x: np.ndarray) -> np.ndarray:
        """Constant term of the residual at constant unknowns (the pointwise problem).

        Parameters
        ----------
        x : ndarray, shape (n, *batch)
            Values of the unknowns.

        Returns
        -------
        ndarray, shape (neq, *batch)
        """
        from .series import Series

        return np.stack(
            [
                np.broadcast_to(r.coeffs[..., 0] if isinstance(r, Series) else r, x.shape[1:])
                for r in self.residual(list(x), 0)
            ]
        )

    def const_jacobian(self, x: np.ndarray) -> np.ndarray:
        """Jacobian of :meth:`const_fun`.

        Parameters
        ----------
        x : ndarray, shape (n, *batch)
            Values of the unknowns.

        Returns
        -------
        ndarray, shape (neq, n, *batch)
        """
        return jacobian(self.const_fun, x, "complex-batched")

    def series_residual(self, u: list, order: int, batch: tuple) -> np.ndarray:
        """Max abs coefficient of the residual series at ``u``, per node.

        Parameters
        ----------
        u : list of Series
            The unknowns at order ``order``.
        order : int
            Working order.
        batch : tuple of int
            Batch shape of the nodes.

        Returns
        -------
        ndarray, shape batch
        """
        return _series_residual_of(self.residual, u, order, batch)


def _series_residual_of(residual: Callable, u: list, order: int, batch: tuple) -> np.ndarray:
    """Max abs coefficient of the residual series at ``u`` (working order ``order``), per node."""
    from .series import Series

    final = residual(u, order)
    return np.max(
        np.stack(
            [
                np.max(
                    np.abs(
                        np.broadcast_to(
                            r.coeffs if isinstance(r, Series) else np.asarray(r)[..., None], batch + (order + 1,)
                        )
                    ),
                    axis=-1,
                )
                for r in final
            ]
        ),
        axis=0,
    )


def doubling_orders(order: int) -> list:
    """Working orders of Newton's iteration on series with precision doubling, up to ``order``.

    A step at working order ``K`` from a solution exact to order ``k`` gives one exact to ``K`` when
    ``K <= 2 k + 1`` (Bostan et al., th. 3.12).  The orders are chosen from the top,
    ``k = ceil((K - 1) / 2)``, so that each step is as low as the next one allows: as few steps as
    doubling from 0 (``1, 3, 7, 15, ...``) but at lower working orders (18: ``1, 2, 4, 9, 18``
    instead of ``1, 3, 7, 15, 18``).

    Parameters
    ----------
    order : int
        Final order (>= 0).

    Returns
    -------
    list of int
        Increasing working orders ending at ``order`` (empty for ``order = 0``).
    """
    out = []
    k = int(order)
    while k > 0:
        out.append(k)
        k = k // 2  # ceil((k - 1) / 2)
    return out[::-1]


def newton_series(
    residual: Callable,
    u0: list,
    order: int,
    *,
    tol: float = 1e-12,
    maxiter: int = PAPER_MAXITER,
    names: tuple = (),
    t_nodes=None,
    warm: bool = False,
    jacobian=None,
    evaluator=None,
):
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
        Times of the nodes [s] (for messages; their smallest spacing weights the series test of ``warm``).
    warm : bool
        ``u0`` is close to the solution in every coefficient (e.g. the previous generalized-flatness
        iterate): try Newton steps at the full working order from it first (up to
        :data:`WARM_MAXSTEPS`; every coefficient of the residual series, weighted by step^m, at most
        ``tol`` before the last step), and run the full scheme only when they fail.  Then the report
        lists ``order`` once per step in ``doubling_orders`` and 0 pointwise iterations.
    jacobian : ndarray, shape (neq, n, *batch, K >= order + 1), optional
        ``warm`` only: the Jacobian series of a nearby problem at a nearby point (the previous
        generalized-flatness iterate's, :attr:`SeriesNewtonReport.jacobian`), truncated to the working
        order: the warm start begins with chord steps on it (real evaluations, no complex steps) and
        computes a fresh Jacobian only when they contract too slowly.  Ignored when its shape does not fit.
    evaluator : ResidualEvaluator or planners.program.StageEvaluator, optional
        How the residual is evaluated (default: ``ResidualEvaluator(residual)``, the numpy path); a
        compiled :class:`planners.program.StageEvaluator` gives the same values to 1e-12.

    Returns
    -------
    (list of Series, SeriesNewtonReport)
    """
    from .series import Series

    n = len(u0)
    base = [u if isinstance(u, Series) else Series.constant(np.asarray(u, dtype=float), 0) for u in u0]
    batch = base[0].batch_shape
    t_nodes = np.arange(int(np.prod(batch))) if t_nodes is None else np.asarray(t_nodes)

    ev = ResidualEvaluator(residual) if evaluator is None else evaluator
    const_fun = ev.const_fun

    if warm and order > 0:
        done = _warm_newton(residual, base, order, t_nodes, tol, names, carried=jacobian, evaluator=ev)
        if done is not None:
            return done
    x0 = np.stack([np.broadcast_to(np.real(u.constant_term), batch) for u in base]).astype(float)
    native = getattr(ev, "pointwise_newton", None) if len(batch) == 1 else None

    def pointwise(start):
        # the same iteration in native code when the evaluator has it (None at a singular node: numpy's)
        done = native(start, tol, maxiter) if native is not None else None
        return done if done is not None else newton(const_fun, start, tol=tol, maxiter=maxiter, jac=ev.const_jacobian)

    res = pointwise(x0)
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
        r2 = pointwise(xs)
        improved = r2.residual < cres
        if not np.any(improved & bad):
            break
        x = np.where(improved, r2.x, x)
        cres = np.where(improved, r2.residual, cres)
        its = max(its, r2.iterations)
    failures = []
    flat_t = np.ravel(t_nodes)
    flat_r = np.ravel(cres)
    failed = np.flatnonzero(~(flat_r <= PAPER_TOL))  # NaN fails too
    if failed.size:
        worst = int(failed[np.argmax(flat_r[failed])])
        failures.append(
            NewtonFailure(
                tuple(names),
                failed,
                flat_t[failed],
                flat_r[failed],
                float(flat_r[worst]),
                float(flat_t[worst]),
                maxiter,
                PAPER_TOL,
            )
        )

    # Lift to series by precision doubling.
    def padded(u: Series, k: int) -> Series:
        return u.truncate(k) if u.order >= k else u.pad(k)

    u = []
    for j in range(n):
        c = np.array(padded(base[j], order).coeffs, dtype=float)
        c[..., 0] = x[j]
        u.append(Series(c))
    orders = doubling_orders(order)
    Jc = None
    native = getattr(ev, "doubling", None)
    if native is not None and orders and len(batch) == 1:
        # the same steps whole in native code; status 2 (a singular node) leaves them to the numpy steps
        status, xs, Jn = native(np.stack([np.broadcast_to(ui.coeffs, batch + (order + 1,)) for ui in u]), orders)
        if status == 0:
            u, Jc, orders_left = [Series(np.ascontiguousarray(xs[j])) for j in range(n)], Jn, []
        else:
            orders_left = orders
    else:
        orders_left = orders
    for k in orders_left:
        cur = [ui.truncate(k) for ui in u]
        stacked = np.stack([np.broadcast_to(ci.coeffs, batch + (k + 1,)) for ci in cur])  # (n, *batch, K)
        G, Jc = ev.residual_and_jacobian(stacked, k)
        D = _series_solve(Jc, G)
        u = [Series(stacked[j] - D[j]) for j in range(n)]
        u = [
            Series(np.concatenate([ui.coeffs, padded(base[j], order).coeffs[..., k + 1 :]], axis=-1))
            if k < order
            else ui
            for j, ui in enumerate(u)
        ]

    def series_residual() -> np.ndarray:
        return ev.series_residual(u, order, batch)

    rep = SeriesNewtonReport(
        tuple(names), t_nodes, cres, its, series_residual, orders, [f.message for f in failures], failures, jacobian=Jc
    )
    return u, rep
