"""Generalized flatness for an almost chained system (the paper's eq. chained-sys).

The paper (section "From calibration to time varying controls") states the algorithm for any
system of the form::

    (Z_h', X_h') = G_h(Z_1, ..., Z_(h+1), X_1, ..., X_(h+1)) + H_h(X_(h+2), ..., X_(h+l_h)),  1 <= h <= r,

with ``#X_h + #Z_h = #X_(h+1)``, ``#X_1 = 0`` and ``Z`` the (generalized) flat outputs.  Neglecting H
(or evaluating it at known values ``X^``), stage h solves its equations for ``X_(h+1)`` from the
derivatives of ``Z_h`` and ``X_h``: that is ``FlatParametrization(t0, kappa, zeta, X^)``, with
``X_(h+1)`` at order ``kappa - h``.  ``GeneralizedFlatParametrization`` repeats it J times with the
previous iterate as ``X^``, the order decreasing by ``L = max l_h - 1`` per iterate.

Here a system is a :class:`ChainedSystem`: its flat outputs with their stage, and one
:class:`Stage` per h with a residual function written once with plain arithmetic (it runs on
truncated power series, batched over the nodes), solved by Newton's method on series
(:func:`planners.newton.newton_series`), or in closed form when the stage gives one
(:attr:`Stage.solve`).  Prescribed functions of time that are neither flat outputs nor unknowns
(the aircraft's thrust asymmetry ``eta(t)`` or fixed rudder ``dn(t)``) are the system's
:attr:`ChainedSystem.inputs`.  The aircraft (:mod:`planners.flat`) is the instance
:func:`planners.systems.aircraft.aircraft_system` with r = 4, Z_1 = {x, y, z}, Z_3 = {zeta} and
H = H_2(p, q, r, dl, dm, dn); :mod:`planners.systems` bundles others.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import numpy as np

from gna.errors import InputError

from .flat import check_grid
from .newton import newton_series
from .series import Series


@dataclass(frozen=True)
class Stage:
    """Stage h of an almost chained system: its equations, solved for ``X_(h+1)``.

    Attributes
    ----------
    unknowns : tuple of str
        The variables ``X_(h+1)`` found by this stage.
    residual : callable
        ``residual(v) -> list`` with as many entries as ``unknowns``: the equations
        ``(Z_h', X_h') - G_h - H_h``.  ``v`` maps every variable known so far, the unknowns, the first
        derivative ``name + "'"`` of every variable of earlier stages, and the neglected variables
        ``hat`` to Series of the working order (or plain arrays of constant terms at order 0).
    neglected : tuple of str
        Variables of ``H_h`` (they appear in ``v`` with their values from the previous iterate).
    ell : int
        ``l_h``: H_h depends on ``X_(h+2) .. X_(h+l_h)`` (1: no neglected terms).
    solve : callable, optional
        Closed form of the stage, ``solve(v, t_nodes) -> list`` of the unknowns at the stage's order
        ``k``: ``v`` maps every variable known so far (and the neglected ones) to its Series truncated
        to order ``k + 1`` (never padded).  The residual then only serves the Jacobians (Newton on
        the fixed point, linearizations).
    start : callable, optional
        Node-wise starting values of the Newton iterations when no previous iterate is given,
        ``start(v, t_nodes) -> list`` of arrays (nodes,); ``v`` maps the known variables to their
        constant terms.  Default: the system's :attr:`ChainedSystem.guess`.
    post : callable, optional
        ``post(list of Series) -> list of Series`` applied to the stage's solution (e.g. angles made
        continuous along the nodes).
    """

    unknowns: tuple
    residual: Callable
    neglected: tuple = ()
    ell: int = 1
    solve: Callable | None = None
    start: Callable | None = None
    post: Callable | None = None


@dataclass(frozen=True)
class StateSpaceModel:
    """Explicit form ``x' = f(x, u)`` of a chained system, for the tracking feedback
    (paper section "Design of the feed-back"; :func:`planners.tracking.design_chained`).

    Attributes
    ----------
    states : tuple of str
        State variables (variables of the system's plans).
    controls : tuple of str
        Control variables.
    rhs : callable
        ``rhs(x, u, hat) -> list`` of the state derivatives, on floats, arrays and Series alike:
        ``hat=None`` gives the exact model; ``hat`` a mapping of the neglected variables gives the
        design model, where the neglected terms H take those values (the model the plan solves, as
        the aircraft's force coefficients with H frozen along the plan).
    integrands : callable
        ``integrands(ref) -> rows``: the tracking integrals ``I_p' = sum_b C[p][b] (x_b - x~_b)``, one
        row of ``len(states)`` coefficients per integral (floats or Series), given the reference
        ``ref`` (a mapping of the plan's variables; floats or Series).
    degrees : tuple of int
        Relative degree of each integral with respect to its inputs in the design model.
    stages : tuple
        Sequential decoupling: ``((integral indices), (control indices))`` per stage.
    """

    states: tuple
    controls: tuple
    rhs: Callable
    integrands: Callable
    degrees: tuple
    stages: tuple


@dataclass(frozen=True)
class ChainedSystem:
    """An almost chained system (paper eq. chained-sys).

    Attributes
    ----------
    name : str
        Name of the system.
    flat_outputs : mapping of str -> int
        Each flat output ``Z`` with its stage h (``Z_h``).
    stages : tuple of Stage
        Stages h = 1..r.
    guess : mapping of str -> float
        Starting values of the unknowns and of the neglected variables (default 0).
    description : str
        What the system is.
    inputs : mapping of str -> callable
        Prescribed functions of t (floats, arrays, Series) that are neither flat outputs nor
        unknowns; every stage sees them, and they are part of the solution.
    outputs : mapping of str -> callable, optional
        Default functions of t of the flat outputs (used when a planner is given none).
    neglected_values : mapping of str -> float or Series, optional
        Values of the neglected variables in iterate 0 (the paper's ``v``: zero or a calibration);
        default :attr:`guess`.
    newton_tol : float
        Tolerance of the pointwise Newton of the stages (units of the residuals).
    model : StateSpaceModel, optional
        The explicit model, for tracking.
    """

    name: str
    flat_outputs: Mapping
    stages: tuple
    guess: Mapping = field(default_factory=dict)
    description: str = ""
    inputs: Mapping = field(default_factory=dict)
    outputs: Mapping | None = None
    neglected_values: Mapping | None = None
    newton_tol: float = 1e-13
    model: StateSpaceModel | None = None

    @property
    def r(self) -> int:
        """Number of stages."""
        return len(self.stages)

    @property
    def L(self) -> int:
        """Order lost per generalized-flatness iterate, ``max l_h - 1``."""
        return max(s.ell for s in self.stages) - 1

    @property
    def variables(self) -> tuple:
        """Flat outputs, then the unknowns of every stage, then the prescribed inputs."""
        return (
            tuple(self.flat_outputs)
            + tuple(u for s in self.stages for u in s.unknowns)
            + tuple(n for n in self.inputs if n not in self.flat_outputs)
        )

    @property
    def neglected(self) -> tuple:
        """The neglected variables of all stages, in order of first use."""
        return tuple(dict.fromkeys(n for s in self.stages for n in s.neglected))

    def neglected_start(self, name: str):
        """Value of a neglected variable in iterate 0 (:attr:`neglected_values`, else :attr:`guess`, else 0).

        Parameters
        ----------
        name : str
            A neglected variable.

        Returns
        -------
        float or Series
        """
        if self.neglected_values is not None and name in self.neglected_values:
            return self.neglected_values[name]
        return self.guess.get(name, 0.0)

    def stage_of(self, name: str) -> int:
        """Stage h of a variable: ``Z_h`` for a flat output, ``X_h`` (found by stage h - 1) otherwise.

        Parameters
        ----------
        name : str
            A variable of the system.

        Returns
        -------
        int
            Its stage index h (1 for a prescribed input).

        Raises
        ------
        InputError
            An unknown variable.
        """
        if name in self.flat_outputs:
            return int(self.flat_outputs[name])
        for h, s in enumerate(self.stages, start=1):
            if name in s.unknowns:
                return h + 1
        if name in self.inputs:
            return 1
        raise InputError(f"{self.name}: unknown variable {name!r}; known: {', '.join(self.variables)}")


def _at_order(data: Mapping, k: int) -> dict:
    """Every Series of ``data`` truncated (or padded) to order k; constant-term arrays at k = 0."""
    out = {}
    for name, v in data.items():
        if isinstance(v, Series):
            if k == 0:
                out[name] = np.asarray(v.constant_term)
            else:
                out[name] = v.truncate(k) if v.order >= k else v.pad(k)
        else:
            out[name] = v
    return out


def _as_series(v, nodes: int, order: int) -> Series:
    """A Series of batch shape (nodes,): a Series as is, a float or array as a constant series."""
    if isinstance(v, Series):
        return v
    return Series.constant(np.broadcast_to(np.asarray(v, dtype=float), (nodes,)), order)


def _flat_outputs(system: ChainedSystem, zeta: Mapping | None) -> Mapping:
    """The flat-output functions to use: ``zeta``, else the system's defaults."""
    if zeta is None:
        if system.outputs is None:
            raise InputError(
                f"{system.name}: no functions given for the flat outputs "
                f"{', '.join(system.flat_outputs)} and the system has no default ones"
            )
        return system.outputs
    return zeta


def flat_parametrization(
    system: ChainedSystem,
    t_nodes,
    order: int,
    zeta: Mapping[str, Callable] | None = None,
    hat: Mapping | None = None,
    guess: Mapping | None = None,
    newton_tol: float | None = None,
) -> tuple[dict, dict]:
    """``FlatParametrization(t0, kappa, zeta, X^)`` of the paper at every node.

    Parameters
    ----------
    system : ChainedSystem
        The system.
    t_nodes : array, shape (nodes,)
        Node times.
    order : int
        kappa: order of the flat outputs of stage 1; ``X_(h+1)`` comes out at ``kappa - h``, a flat
        output of stage h at ``kappa - h + 1``, the prescribed inputs at ``kappa``.
    zeta : mapping of str -> callable, optional
        Each flat output as a function of t (floats, arrays, Series); default the system's
        :attr:`ChainedSystem.outputs`.
    hat : mapping of str -> Series or float, optional
        Values of the neglected variables (default: :meth:`ChainedSystem.neglected_start`).
    guess : mapping of str -> Series, optional
        Starting values of the Newton iterations (a previous iterate).
    newton_tol : float, optional
        Tolerance of the pointwise Newton (units of the residuals); default the system's.

    Returns
    -------
    series : dict of str -> Series
        Every variable, batch shape (nodes,).
    reports : dict of int -> SeriesNewtonReport
        Newton diagnostics per stage solved by Newton.

    Raises
    ------
    InputError
        A missing flat output, or ``order`` below the number of stages.
    """
    t_nodes = np.asarray(t_nodes, dtype=float)
    tol = system.newton_tol if newton_tol is None else newton_tol
    if order < system.r:
        raise InputError(f"{system.name}: order {order} below the number of stages {system.r}")
    zeta = _flat_outputs(system, zeta)
    missing = [z for z in system.flat_outputs if z not in zeta]
    if missing:
        raise InputError(f"{system.name}: no function given for the flat output(s) {', '.join(missing)}")
    nodes = len(t_nodes)
    known = {}
    for z, h in system.flat_outputs.items():
        k = order - int(h) + 1
        known[z] = _as_series(zeta[z](Series.variable(t_nodes, k)), nodes, k)
    for name, f in system.inputs.items():
        known[name] = _as_series(f(Series.variable(t_nodes, order)), nodes, order)
    reports = {}
    for h, stage in enumerate(system.stages, start=1):
        k = order - h
        data = dict(known)
        for name, v in known.items():
            if v.order >= 1:
                data[name + "'"] = v.derivative()
        for name in stage.neglected:
            v = (hat or {}).get(name, system.neglected_start(name))
            data[name] = _as_series(v, nodes, k)
        if stage.solve is not None:
            v = {n: s.truncate(min(s.order, k + 1)) for n, s in data.items()}
            u = [_as_series(s, nodes, k) for s in stage.solve(v, t_nodes)]
            u = [s.truncate(k) if s.order > k else s for s in u]
        else:
            cache: dict[int, dict] = {}

            def residual(u, kk, stage=stage, data=data, cache=cache):
                if kk not in cache:
                    cache[kk] = _at_order(data, kk)
                v = dict(cache[kk])
                v.update(zip(stage.unknowns, u))
                return stage.residual(v)

            if guess is not None and all(n in guess for n in stage.unknowns):
                u0 = [guess[n] for n in stage.unknowns]
            elif stage.start is not None:
                u0 = [
                    Series.constant(np.broadcast_to(np.asarray(c, dtype=float), (nodes,)), 0)
                    for c in stage.start(_at_order(data, 0), t_nodes)
                ]
            else:
                u0 = [Series.constant(np.full(nodes, float(system.guess.get(n, 0.0))), 0) for n in stage.unknowns]
            u, reports[h] = newton_series(residual, u0, k, tol=tol, names=stage.unknowns, t_nodes=t_nodes)
        if stage.post is not None:
            u = list(stage.post(list(u)))
        known.update(zip(stage.unknowns, u))
    return known, reports


@dataclass
class ChainedPlan:
    """The iterates of :func:`generalized_parametrization`, evaluated anywhere by the paper's two-sided formula.

    Attributes
    ----------
    system : ChainedSystem
        The system planned.
    t_nodes : ndarray, shape (nodes,)
        Node times.
    iterates : list of dict
        Series of every variable, per iterate j = 0..J.
    reports : list of dict
        Newton reports per iterate and stage.
    timings : dict
        Wall time [s] per iterate.
    residuals : list of float
        Newton only: ``max |X^ - G~(X^)|`` per iterate.
    """

    system: ChainedSystem
    t_nodes: np.ndarray
    iterates: list
    reports: list = field(default_factory=list)
    timings: dict = field(default_factory=dict)
    residuals: list = field(default_factory=list)

    @property
    def J(self) -> int:
        """Index of the last iterate."""
        return len(self.iterates) - 1

    def evaluate(self, name: str, t, j: int = -1, derivative: int = 0) -> np.ndarray:
        """A variable (or its derivative) at times ``t`` by the two-sided interpolation of the node series.

        Parameters
        ----------
        name : str
            A variable of the system.
        t : float or array, shape (N,)
            Times within the nodes' span.
        j : int
            Iterate (default: the last).
        derivative : int
            Order of the time derivative.

        Returns
        -------
        float or ndarray, shape (N,)
            Values at ``t`` (a float for a scalar ``t``).

        Raises
        ------
        InputError
            An unknown variable or a time outside the plan.
        """
        from .plan import _taylor_derivative

        s = self.iterates[j].get(name)
        if s is None:
            raise InputError(f"unknown variable {name!r}; known: {', '.join(self.iterates[j])}")
        c = np.real(np.asarray(s.coeffs))[None]  # (1, nodes, K)
        t_arr = np.atleast_1d(np.asarray(t, dtype=float))
        tn = self.t_nodes
        if np.any(t_arr < tn[0] - 1e-12) or np.any(t_arr > tn[-1] + 1e-12):
            raise InputError(f"time outside the plan [{tn[0]:g}, {tn[-1]:g}]")
        i = np.clip(np.searchsorted(tn, t_arr, side="right") - 1, 0, len(tn) - 2)
        ti, tj = tn[i], tn[i + 1]
        dt = tj - ti
        w = (t_arr - ti) / dt
        out = (1 - w) * _taylor_derivative(c[:, i], t_arr - ti, derivative) + w * _taylor_derivative(
            c[:, i + 1], t_arr - tj, derivative
        )
        if derivative > 0:
            out = (
                out
                + derivative
                * (
                    _taylor_derivative(c[:, i + 1], t_arr - tj, derivative - 1)
                    - _taylor_derivative(c[:, i], t_arr - ti, derivative - 1)
                )
                / dt
            )
        return out[0] if np.ndim(t) else float(out[0][0])


def generalized_parametrization(
    system: ChainedSystem,
    t_nodes,
    zeta: Mapping[str, Callable] | None = None,
    J: int = 0,
    e: int = 1,
    v: Mapping | None = None,
    newton_tol: float | None = None,
) -> ChainedPlan:
    """``GeneralizedFlatParametrization(v, zeta, J, e)`` of the paper for a chained system.

    Parameters
    ----------
    system : ChainedSystem
        The system.
    t_nodes : array, shape (nodes,)
        Increasing node times.
    zeta : mapping of str -> callable, optional
        The flat outputs as functions of t (default: the system's :attr:`ChainedSystem.outputs`).
    J : int
        Iterations after the plain flat parametrization.
    e : int
        Order of the last stage's unknowns in the last iterate.
    v : mapping, optional
        Values of the neglected variables for iterate 0 (default:
        :meth:`ChainedSystem.neglected_start`).
    newton_tol : float, optional
        Tolerance of the stages' pointwise Newton (default: the system's).

    Returns
    -------
    ChainedPlan
        Every iterate j = 0..J (iterate j at ``kappa_0 - j L``, ``kappa_0 = e + r + J L``).

    Raises
    ------
    InputError
        Fewer than two increasing nodes or a negative J.
    """
    t_nodes = check_grid(t_nodes)
    if J < 0:
        raise InputError(f"J must be >= 0, got {J}")
    kappa = e + system.r + J * system.L
    iterates, reports, timings = [], [], {}
    hat, guess = dict(v or {}), None
    for j in range(J + 1):
        t0 = time.perf_counter()
        sol, rep = flat_parametrization(system, t_nodes, kappa, zeta, hat=hat, guess=guess, newton_tol=newton_tol)
        timings[j] = time.perf_counter() - t0
        iterates.append(sol)
        reports.append(rep)
        hat = {n: sol[n] for n in system.neglected}
        guess = sol
        kappa -= system.L
    return ChainedPlan(system, t_nodes, iterates, reports, timings)


# ----------------------------------------------------------------------------- Newton on the fixed point


def _hat_orders(system: ChainedSystem, order: int) -> dict:
    """Order of each neglected variable where it is first used: ``kappa - h`` for stage h."""
    out = {}
    for h, s in enumerate(system.stages, start=1):
        for n in s.neglected:
            out.setdefault(n, order - h)
    return out


def _chained_jacobian(system: ChainedSystem, order: int, sol: Mapping, hat: Mapping) -> np.ndarray:
    """Exact ``dG~/d hat`` on the coefficients (nodes, size, size), stages composed as in
    :func:`planners.generalized_newton.h_jacobian` (complex-step partials, constant directions)."""
    from .generalized_newton import (
        _block_toeplitz,
        _cs_jacobian,
        _derivative_matrix,
        _mm,
        _resize_matrix,
        _series_inverse,
    )

    horders = _hat_orders(system, order)
    names = list(horders)
    offsets, size = {}, 0
    for n in names:
        offsets[n] = size
        size += horders[n] + 1
    nodes = next(iter(sol.values())).batch_shape[0]
    sens = {}  # variable -> (nodes, K + 1, size): d variable / d hat
    orders = {}
    for z in system.flat_outputs:
        orders[z] = sol[z].order
    for h, stage in enumerate(system.stages, start=1):
        k = order - h
        earlier = [n for n in sens]  # unknowns of earlier stages
        inputs = {}
        for n in earlier:
            inputs[n] = (sol[n], _mm(_resize_matrix(1, orders[n], k), sens[n]))
            if orders[n] >= 1:
                inputs[n + "'"] = (
                    sol[n].derivative(),
                    _mm(_resize_matrix(1, orders[n] - 1, k), _mm(_derivative_matrix(1, orders[n]), sens[n])),
                )
        for n in stage.neglected:
            sel = np.zeros((horders[n] + 1, size))
            sel[:, offsets[n] : offsets[n] + horders[n] + 1] = np.eye(horders[n] + 1)
            v = hat[n]
            inputs[n] = (v, _resize_matrix(1, horders[n], k) @ sel)
        given = list(system.flat_outputs) + list(system.inputs)  # independent of the neglected terms
        fixed = {z: sol[z] for z in given}
        fixed.update({z + "'": sol[z].derivative() for z in given if sol[z].order >= 1})
        pnames = list(stage.unknowns) + list(inputs)
        base = [sol[u] for u in stage.unknowns] + [inputs[p][0] for p in inputs]
        base = [b.truncate(k) if b.order >= k else b.pad(k) for b in base]
        fixed_k = _at_order(fixed, k)

        def fun(vals, pnames=pnames, fixed_k=fixed_k, stage=stage):
            v = dict(fixed_k)
            v.update(zip(pnames, vals))
            return stage.residual(v)

        jac = _cs_jacobian(fun, base, k)  # (n_eq, n_in, nodes, k+1)
        nu = len(stage.unknowns)
        rhs = 0.0
        for i, p in enumerate(inputs):
            rhs = rhs + _mm(_block_toeplitz(jac[:, nu + i : nu + i + 1], k, k), inputs[p][1])
        if np.ndim(rhs):
            S = -_mm(_block_toeplitz(_series_inverse(jac[:, :nu]), k, k), rhs)
        else:  # nothing upstream depends on the neglected terms
            S = np.zeros((nodes, nu * (k + 1), size))
        for i, u in enumerate(stage.unknowns):
            sens[u] = S[:, i * (k + 1) : (i + 1) * (k + 1)]
            orders[u] = k
    dG = np.zeros((nodes, size, size))
    for n in names:
        if n in sens:  # a prescribed input does not depend on them
            dG[:, offsets[n] : offsets[n] + horders[n] + 1] = _mm(_resize_matrix(1, orders[n], horders[n]), sens[n])
    return dG


def _hat_vector(system, order, values: Mapping, nodes: int) -> np.ndarray:
    """(nodes, size) coefficients of the neglected variables (series or constants), zero-padded."""
    from .generalized_newton import _coeffs

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
    """Newton's method on the fixed point of :func:`generalized_parametrization` (same starting order).

    The neglected variables ``X^`` are the unknowns of ``F(X^) = X^ - G~(X^)``, ``G~`` the flat
    parametrization's values of those variables zero-padded to the order they are used at; the
    Jacobian is exact (complex-step partials of each stage's residual, composed on the Taylor
    coefficients), as for the aircraft (:mod:`planners.generalized_newton`).

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
        Starting values of the neglected variables (default: the system's guesses).
    tol : float
        Stop when ``max |X^ - G~(X^)|`` is below this.
    maxiter : int
        Newton steps at most.

    Returns
    -------
    ChainedPlan
        Iterate 0 (the flat parametrization at ``kappa``), then one per Newton step truncated to the
        fixed point's last-iterate orders; ``timings`` per iterate; the residuals
        ``max |X^ - G~(X^)|`` in ``plan.residuals``.

    Raises
    ------
    InputError
        Fewer than two increasing nodes or a negative J.
    """
    t_nodes = check_grid(t_nodes)
    if J < 0:
        raise InputError(f"J must be >= 0, got {J}")
    from .generalized_newton import _gauss_solve

    kappa = e + system.r + J * system.L
    nodes = len(t_nodes)
    t0 = time.perf_counter()
    x = _hat_vector(system, kappa, dict(v or {}), nodes)
    sol, rep = flat_parametrization(system, t_nodes, kappa, zeta, hat=_hat_dict(system, kappa, x))
    iterates, reports, timings = [sol], [rep], {0: time.perf_counter() - t0}

    def residual(sol):
        return x - _hat_vector(system, kappa, {n: sol[n] for n in _hat_orders(system, kappa)}, nodes)

    F = residual(sol)
    res = [float(np.max(np.abs(F)))]
    for n in range(1, maxiter + 1):
        if not res[-1] > tol:
            break
        t0 = time.perf_counter()
        dG = _chained_jacobian(system, kappa, sol, _hat_dict(system, kappa, x))
        x = x - _gauss_solve(np.eye(x.shape[1])[None] - dG, F)
        sol, rep = flat_parametrization(system, t_nodes, kappa, zeta, hat=_hat_dict(system, kappa, x), guess=sol)
        F = residual(sol)
        res.append(float(np.max(np.abs(F))))
        iterates.append(sol)
        reports.append(rep)
        timings[n] = time.perf_counter() - t0
        if not res[-1] < res[-2]:
            break
    k_last = e + system.r
    out = [iterates[0]] + [
        {name: s.truncate(min(s.order, k_last - system.stage_of(name) + 1)) for name, s in it.items()}
        for it in iterates[1:]
    ]
    plan = ChainedPlan(system, t_nodes, out, reports, timings)
    plan.residuals = res
    return plan
