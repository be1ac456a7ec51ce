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
:attr:`ChainedSystem.inputs`.  The aircraft is the instance :func:`planners.flat.aircraft_system`
(r = 4, Z_1 = {x, y, z}, Z_3 = {zeta}, H = H_2(p, q, r, dl, dm, dn)): :func:`planners.generalized.plan_motion`
is :func:`generalized_parametrization` on it; :mod:`planners.systems` bundles others; Newton's method on
the fixed point is :mod:`planners.generalized_newton`.

The speed of a plan comes from reuse between iterates: iterate j starts each Newton stage from iterate
j - 1 at the full working order (chord steps on its Jacobians), and truncates the series that do not
depend on the neglected terms (flat outputs, prescribed inputs, the stages before the first with
neglected terms, :attr:`ChainedSystem.derived`) instead of recomputing them.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import numpy as np

from gna.errors import InputError

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
    warm : bool
        Newton at the full working order from the start even without a previous iterate (equations
        affine in the unknowns: one step solves them; :func:`planners.newton.newton_series` ``warm``).
    check : callable, optional
        ``check(v, t_nodes)``: the checks :attr:`solve` makes of its data (raising their errors), run before
        the compiled :attr:`solve_series` (which makes none).
    solve_series : callable, optional
        The closed form :attr:`solve` written with plain arithmetic on series (no other operations, no
        truncations), ``solve_series(v) -> list``: ``v`` maps every variable known so far to its series at
        the working order ``k + 1``, and the first ``k + 1`` coefficients of each result are the unknowns at
        order ``k``.  The native evaluator runs it as a traced program (:mod:`planners.program`).
    """

    unknowns: tuple
    residual: Callable
    neglected: tuple = ()
    ell: int = 1
    solve: Callable | None = None
    start: Callable | None = None
    post: Callable | None = None
    warm: bool = False
    solve_series: Callable | None = None
    check: Callable | None = None


@dataclass(frozen=True)
class StateSpaceModel:
    """Explicit form ``x' = f(x, u)`` of a chained system, for the tracking feedback
    (paper section "Design of the feed-back"; :func:`planners.tracking.design`).

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
        Sequential decoupling: ``((integral indices), (input indices))`` per stage.
    inputs : tuple of str, optional
        The controls the feedback acts on (default: all; the others stay at their planned values).
    """

    states: tuple
    controls: tuple
    rhs: Callable
    integrands: Callable
    degrees: tuple
    stages: tuple
    inputs: tuple | None = None


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
    derived : callable, optional
        ``derived(v, order) -> dict`` of Series that depend only on the flat outputs, the inputs and
        the stages before the first with neglected terms (``v``, for flat outputs at ``order``):
        computed once per plan and truncated in later iterates by the orders they lose; every stage
        sees them (e.g. the aircraft's dynamic pressure).
    derived_series : callable, optional
        :attr:`derived` for the native evaluator: ``derived_series(order) -> (function, orders)``, the
        function ``f(v) -> list`` written with plain arithmetic on series of ``v`` (untruncated: traced as a
        program), ``orders`` the order of each result in :attr:`derived`'s dict (its keys, in order).
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
    derived: Callable | None = None
    derived_series: Callable | None = None

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


def check_grid(t_nodes) -> np.ndarray:
    """The planning grid as a float array: at least two increasing nodes.

    Parameters
    ----------
    t_nodes : array_like, shape (N,)
        Node times [s].

    Returns
    -------
    ndarray, shape (N,)

    Raises
    ------
    InputError
        Not a 1-D sequence of at least two increasing times.
    """
    t = np.asarray(t_nodes, dtype=float)
    if t.ndim != 1 or len(t) < 2 or np.any(np.diff(t) <= 0):
        raise InputError("the planning grid needs at least two increasing nodes")
    return t


@dataclass
class NodeSolution(Mapping):
    """Series of every variable at every node, for one iterate (a mapping name -> Series).

    Attributes
    ----------
    series : dict of str -> Series
        Batch shape (nodes,); the order of each depends on its stage.
    order : int
        Order kappa of the flat outputs of stage 1 for this iterate.
    reports : dict of str -> SeriesNewtonReport
        Newton diagnostics of the stages solved by Newton (``"stage2"``, ``"stage4"`` ...).
    """

    series: dict
    order: int
    reports: dict = field(default_factory=dict)
    # The series that do not depend on the neglected terms (flat outputs, prescribed inputs and the
    # stages before the first with neglected terms), at the highest order computed so far: a later
    # iterate (lower order) truncates them (a coefficient depends only on the coefficients below it).
    _inputs: dict | None = field(default=None, repr=False, compare=False)

    def __getstate__(self) -> dict:
        state = dict(self.__dict__)
        state["_inputs"] = None
        return state

    def __getitem__(self, name: str) -> Series:
        return self.series[name]

    def __iter__(self):
        return iter(self.series)

    def __len__(self) -> int:
        return len(self.series)

    def h_values(self):
        """The aircraft's rates and surfaces of this iterate, as H values for the next one.

        Returns
        -------
        gna.eom.HValues
            Series of ``p, q, r`` [rad/s] and ``dl, dm, dn`` [rad].
        """
        from gna.eom import H_NAMES, HValues

        return HValues(*(self.series[n] for n in H_NAMES))


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


def _first_neglecting_stage(system: ChainedSystem) -> int:
    """Index h (1-based) of the first stage with neglected terms (r + 1 when none has any)."""
    return next((h for h, s in enumerate(system.stages, start=1) if s.neglected), system.r + 1)


#: Grids whose traced programs a system keeps (the latest ones): plans of one problem on one grid trace once.
PROGRAM_GRIDS = 4


def _programs_of(system: ChainedSystem, zeta, t_nodes: np.ndarray, cached: dict) -> dict:
    """The dict of the stages' traced programs for this plan: kept on the system for its default flat outputs
    and this grid (the programs depend on nothing else: their numbers are parameters of the system's model,
    their decisions read the static data of these flat outputs on this grid), else for this plan only."""
    programs = cached.get("programs")
    if programs is not None:
        return programs
    if zeta is not None:  # other flat-output functions: traced for this plan
        programs = cached["programs"] = {}
        return programs
    store = system.__dict__.setdefault("_programs", {})  # a frozen dataclass: its __dict__ holds the cache
    key = t_nodes.tobytes()
    programs = store.pop(key, None)
    if programs is None:
        programs = {}
    store[key] = programs  # the latest grid last
    while len(store) > PROGRAM_GRIDS:
        store.pop(next(iter(store)))
    cached["programs"] = programs
    return programs


def _stage_evaluator(programs, h, stage, data, static, nodes):
    """The compiled evaluator of stage h for this call (its program traced on first use in the plan), or None."""
    if programs is None:
        return None
    if h not in programs:
        from .program import trace

        programs[h] = trace(stage.residual, stage.unknowns, data, static)
    prog, _reason = programs[h]
    if prog is None or set(prog.data_names) - set(data):
        return None
    from .program import NativeStageEvaluator, StageEvaluator

    return (NativeStageEvaluator if program_backend() == "native" else StageEvaluator)(prog, data, nodes)


def _solve_compiled(programs, h, stage, data, static, nodes, k):
    """A closed-form stage by its traced :attr:`Stage.solve_series` on the native evaluator (the unknowns at
    order k), or None (no such form, another backend, or the form could not be traced)."""
    if programs is None or stage.solve_series is None or program_backend() != "native":
        return None
    key = ("solve", h)
    if key not in programs:
        from .program import trace

        programs[key] = trace(lambda v: stage.solve_series(v), (), data, static)
    prog, _reason = programs[key]
    if prog is None or set(prog.data_names) - set(data):
        return None
    from .program import NativeStageEvaluator

    ev = NativeStageEvaluator(prog, data, nodes)
    out = ev.nat.evaluate(np.zeros((0, k + 2, nodes)), ev._data_for(k + 2), k + 2)
    return [Series(np.ascontiguousarray(out[j, : k + 1].T)) for j in range(out.shape[0])]


def _derived_compiled(system, programs, known, order, nodes):
    """:attr:`ChainedSystem.derived` by its traced :attr:`ChainedSystem.derived_series` on the native evaluator
    (the series truncated to the orders it names), or None (no such form, another backend, not traceable)."""
    if programs is None or system.derived_series is None or program_backend() != "native":
        return None
    fun, orders = system.derived_series(order)
    if "derived" not in programs:
        from .program import trace

        programs["derived"] = trace(fun, (), known, set(known))
    prog, _reason = programs["derived"]
    if prog is None or set(prog.data_names) - set(known) or len(prog.outputs) != len(orders):
        return None
    from .program import NativeStageEvaluator

    M = order + 1
    ev = NativeStageEvaluator(prog, known, nodes)
    out = ev.nat.evaluate(np.zeros((0, M, nodes)), ev._data_for(M), M)
    return {name: Series._wrap(out[j, : k + 1]) for j, (name, k) in enumerate(orders.items())}


def _solve_stage(system, h, stage, known, derivs, hat, guess, t_nodes, order, tol, carry, programs=None, static=()):
    """Stage h at order ``order - h``: its unknowns (list of Series) and its Newton report (or None).

    ``programs`` (a dict kept for the plan, or None for the numpy path): the stages' compiled programs
    (:mod:`planners.program`), traced at their first call; ``static``: the names of the data that do not
    change during the plan."""
    nodes = len(t_nodes)
    k = order - h
    data = dict(known)
    data.update(derivs)
    for name in stage.neglected:
        v = (hat or {}).get(name, system.neglected_start(name))
        data[name] = _as_series(v, nodes, k)
    rep = None
    if stage.solve is not None:
        u = None
        if programs is not None and stage.solve_series is not None and program_backend() == "native":
            if stage.check is not None:
                stage.check(data, t_nodes)
            u = _solve_compiled(programs, h, stage, data, static, nodes, k)
        if u is None:
            v = {n: s.truncate(min(s.order, k + 1)) for n, s in data.items()}
            u = [_as_series(s, nodes, k) for s in stage.solve(v, t_nodes)]
            u = [s.truncate(k) if s.order > k else s for s in u]
    else:
        cache: dict[int, dict] = {}

        def residual(u, kk):
            if kk not in cache:
                cache[kk] = _at_order(data, kk)
            v = dict(cache[kk])
            v.update(zip(stage.unknowns, u))
            return stage.residual(v)

        jac = None
        if guess is not None and all(n in guess for n in stage.unknowns):
            u0, warm = [guess[n] for n in stage.unknowns], True
            if carry and isinstance(guess, NodeSolution):  # the previous iterate's Jacobian, for chord steps
                jac = getattr(guess.reports.get(f"stage{h}"), "jacobian", None)
        elif stage.start is not None:
            u0 = [
                Series.constant(np.broadcast_to(np.asarray(c, dtype=float), (nodes,)), 0)
                for c in stage.start(_at_order(data, 0), t_nodes)
            ]
            warm = stage.warm
        else:
            u0 = [Series.constant(np.full(nodes, float(system.guess.get(n, 0.0))), 0) for n in stage.unknowns]
            warm = stage.warm
        ev = _stage_evaluator(programs, h, stage, data, static, nodes)
        u, rep = newton_series(
            residual, u0, k, tol=tol, names=stage.unknowns, t_nodes=t_nodes, warm=warm, jacobian=jac, evaluator=ev
        )
    if stage.post is not None:
        u = list(stage.post(list(u)))
    return u, rep


def program_backend() -> str | None:
    """How the stages' compiled programs (:mod:`planners.program`) are run, or None for the numpy path.

    Returns
    -------
    str or None
        ``"native"`` (the default series backend ``"native"``, ``GFLAT_SERIES_BACKEND``, when the native
        evaluator could be compiled or loaded: :mod:`planners._native`), ``"numba"`` (backend ``"compiled"``,
        numba importable), or None (backend ``"numpy"``, or the compiled evaluator unavailable).
    """
    from . import series

    if series.BACKEND == "native":
        from . import _native

        return "native" if _native.library() is not None else None
    if series.BACKEND == "compiled":
        from .program import available

        return "numba" if available() else None
    return None


def compiled_programs() -> bool:
    """Whether the stages run as compiled programs (:mod:`planners.program`): :func:`program_backend` is not None.

    Returns
    -------
    bool
    """
    return program_backend() is not None


def _add_known(known: dict, derivs: dict, names, values, derivatives: bool = True) -> None:
    for name, v in zip(names, values):
        known[name] = v
        if derivatives and v.order >= 1:
            derivs[name + "'"] = v.derivative()


def flat_parametrization(
    system: ChainedSystem,
    t_nodes,
    order: int,
    zeta: Mapping[str, Callable] | None = None,
    hat: Mapping | None = None,
    guess: Mapping | None = None,
    newton_tol: float | None = None,
    carry: bool = True,
) -> NodeSolution:
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
    guess : mapping of str -> Series, or NodeSolution, optional
        A nearby solution (the previous iterate): the Newton stages start from it at the full working
        order (:func:`planners.newton.newton_series` ``warm``).  A :class:`NodeSolution` of the same
        system, grid and flat outputs at an order at least ``order`` also lends the series that do not
        depend on the neglected terms (truncated) and, with ``carry``, its stages' last Jacobians
        for chord steps.
    newton_tol : float, optional
        Tolerance of the pointwise Newton (units of the residuals); default the system's.
    carry : bool
        Use the Jacobians of ``guess`` (a caller differentiating the solution with respect to ``hat``
        sets False: the last Newton step then starts from a residual at most the tolerance).

    Returns
    -------
    NodeSolution
        Every variable, batch shape (nodes,), and the Newton reports per stage solved by Newton
        (keys ``"stage<h>"``).

    Raises
    ------
    InputError
        A missing flat output, or ``order`` below the number of stages.
    """
    t_nodes = np.asarray(t_nodes, dtype=float)
    tol = system.newton_tol if newton_tol is None else newton_tol
    if order < system.r:
        raise InputError(f"{system.name}: order {order} below the number of stages {system.r}")
    h0 = _first_neglecting_stage(system)
    cached = guess._inputs if isinstance(guess, NodeSolution) else None
    if not (
        cached is not None
        and cached["system"] is system
        and cached["zeta"] is zeta
        and cached["order"] >= order
        and np.array_equal(cached["t_nodes"], t_nodes)
    ):
        cached = _static_part(system, zeta, t_nodes, order, tol, carry, h0)
    loss = cached["order"] - order  # every reused series loses the order the flat outputs lose
    programs = _programs_of(system, zeta, t_nodes, cached) if compiled_programs() else None
    if programs is not None and carry and isinstance(guess, NodeSolution) and guess._inputs is cached:
        sol = _native_iterate(system, cached, programs, t_nodes, order, hat, guess, tol, h0)
        if sol is not None:
            return sol
    if programs is not None and guess is None and not loss:
        sol = _native_first_iterate(system, cached, programs, t_nodes, order, hat, tol, h0)
        if sol is not None:
            return sol
    known = {n: v.truncate(v.order - loss) if loss else v for n, v in cached["known"].items()}
    derivs = {n: v.truncate(v.order - loss) if loss else v for n, v in cached["derivs"].items()}
    reports = dict(cached["reports"])
    static = set(known) | set(derivs)
    for h, stage in enumerate(system.stages[h0 - 1 :], start=h0):
        u, rep = _solve_stage(
            system, h, stage, known, derivs, hat, guess, t_nodes, order, tol, carry, programs=programs, static=static
        )
        _add_known(known, derivs, stage.unknowns, u, derivatives=h < system.r)  # no stage reads the last's
        if rep is not None:
            reports[f"stage{h}"] = rep
    return NodeSolution(known, order, reports, cached)


def _static_part(system, zeta, t_nodes, order, tol, carry, h0) -> dict:
    """The part of :func:`flat_parametrization` that reads neither the neglected terms nor a previous iterate:
    the flat outputs and prescribed inputs on series, the stages before the first with neglected terms and the
    derived series, as a plan's ``cached`` inputs (a new dict per plan: the plan's native buffers go there).

    For the system's default flat outputs on the compiled programs these series are kept on the system (as its
    programs are), keyed by everything they are computed from besides the system itself: the grid, the order,
    the tolerance, ``carry``, the program backend and the series kernels; the system is that of a frozen problem
    (:func:`planners.flat.aircraft_system`), and the series are read-only (:meth:`Series._wrap`).  The stage-2
    starting values of iterate 0 are kept with them (``"starts"``, filled by :func:`_native_first_iterate`)."""
    from . import series

    compiled = compiled_programs()
    store = key = None
    if zeta is None and compiled:
        store = system.__dict__.setdefault("_static_parts", {})  # a frozen dataclass: its __dict__ holds it
        # everything the series below are computed from besides the system: the grid, the order, the stage
        # tolerance, carry, the program backend and the series kernels (both switchable within a process)
        key = (t_nodes.shape, t_nodes.tobytes(), order, tol, bool(carry), program_backend(), series._K)
        hit = store.pop(key, None)
        if hit is not None:
            store[key] = hit  # the latest last
            programs = _programs_of(system, zeta, t_nodes, {})
            return {
                "system": system,
                "zeta": zeta,
                "order": order,
                "t_nodes": t_nodes.copy(),
                "known": dict(hit["known"]),
                "derivs": dict(hit["derivs"]),
                "reports": dict(hit["reports"]),
                "programs": programs,
                "starts": hit["starts"],
            }
    nodes = len(t_nodes)
    funcs = _flat_outputs(system, zeta)
    missing = [z for z in system.flat_outputs if z not in funcs]
    if missing:
        raise InputError(f"{system.name}: no function given for the flat output(s) {', '.join(missing)}")
    known, derivs, reports = {}, {}, {}
    first = _programs_of(system, zeta, t_nodes, {}) if compiled else None
    for z, h in system.flat_outputs.items():
        k = order - int(h) + 1
        _add_known(known, derivs, [z], [_as_series(funcs[z](Series.variable(t_nodes, k)), nodes, k)])
    for name, f in system.inputs.items():
        _add_known(known, derivs, [name], [_as_series(f(Series.variable(t_nodes, order)), nodes, order)])
    for h, stage in enumerate(system.stages[: h0 - 1], start=1):
        static0 = set(known) | set(derivs)  # the stages before the first with neglected terms: static data
        u, rep = _solve_stage(system, h, stage, known, derivs, None, None, t_nodes, order, tol, carry, first, static0)
        _add_known(known, derivs, stage.unknowns, u)
        if rep is not None:
            reports[f"stage{h}"] = rep
    if system.derived is not None:  # data of the stages, not variables of the solution
        more = _derived_compiled(system, first, known, order, nodes)
        derivs.update(system.derived(dict(known), order) if more is None else more)
    cached = {
        "system": system,
        "zeta": zeta,
        "order": order,
        "t_nodes": t_nodes.copy(),
        "known": known,
        "derivs": derivs,
        "reports": reports,
    }
    if first is not None:
        cached["programs"] = first
    if store is not None and all(
        isinstance(v, Series) and not v._c.flags.writeable for v in (*known.values(), *derivs.values())
    ):
        cached["starts"] = {}
        store[key] = {
            "known": dict(known),
            "derivs": dict(derivs),
            "reports": dict(reports),
            "starts": cached["starts"],
        }
        while len(store) > PROGRAM_GRIDS:
            store.pop(next(iter(store)))
    return cached


class _NativeStage:
    """One stage of :func:`_native_iterate`: its program, and its data as one buffer (D, M, S) kept for the
    plan: the static rows filled once at the plan's top order (later iterates read fewer coefficients, and
    the coefficients above a truncated series' order are zeroed), the other rows written at each iterate."""

    def __init__(self, h, stage, prog, solve, cached, M, nodes):
        self.h, self.stage, self.prog, self.solve = h, stage, prog, solve
        self.nat = prog.native()
        self.names = list(prog.data_names)
        self.B = np.zeros((len(self.names) + len(prog.extra), M, nodes))
        self.static = []  # (row, order of the series at the plan's top order)
        self.var = []  # (row, name)
        self.top = {}  # row -> the static series at the top order
        top = {**cached["known"], **cached["derivs"]}
        for r, n in enumerate(self.names):
            if n in top:
                self.static.append((r, top[n].order))
                self.top[r] = top[n]
            else:
                self.var.append((r, n))
        for r, s in enumerate(prog.extra, start=len(self.names)):
            self.static.append((r, s.order))
            self.top[r] = s
        self.lowest = min((o for _, o in self.static), default=None)
        self.loss = None  # the largest loss the static rows were truncated for (their tails zeroed)
        self.refill()

    def refill(self) -> None:
        """The static rows at the top order again (a later plan from this plan's iterates: a smaller loss)."""
        for r, s in self.top.items():
            _fill(self.B[r], s)
        self.loss = 0

    def data(self, M: int, loss: int, values: Mapping) -> np.ndarray:
        """The buffer at this iterate: static rows truncated by ``loss``, the others from ``values``."""
        B = self.B
        if loss < self.loss:
            self.refill()
        self.loss = loss
        for r, n in self.var:
            _fill(B[r, :M], values[n])
        if self.lowest is not None and self.lowest - loss + 1 < M:
            for r, o in self.static:
                if o - loss + 1 < M:
                    B[r, max(o - loss + 1, 0) : M] = 0.0
        return B


def _fill(row: np.ndarray, v) -> None:
    """``row`` (M, S) := the coefficients of ``v`` (a Series of batch (S,) or (), or a number), zero-padded."""
    if isinstance(v, _LazyDerivative):  # (k + 1) c_(k+1), as Series.derivative
        c = v.v._c
        m = min(c.shape[0] - 1, row.shape[0])
        d = c[1 : m + 1] * np.arange(1, m + 1, dtype=float)[:, None] if c.ndim == 2 else None
        if d is None:
            d = (c[1 : m + 1] * np.arange(1, m + 1, dtype=float))[:, None]
        row[:m] = np.real(d)
        row[m:] = 0.0
    elif isinstance(v, Series):
        c = v._c
        m = min(c.shape[0], row.shape[0])
        if c.dtype.kind == "c":
            c = c.real
        row[:m] = c[:m] if c.ndim == 2 else c[:m, None]
        if m < row.shape[0]:
            row[m:] = 0.0
    else:
        row[:] = 0.0
        row[0] = np.real(v)


def _native_iterate(system, cached, programs, t_nodes, order, hat, guess, tol, h0):
    """A generalized-flatness iterate after the first on the native evaluator, from the previous one: the stages
    of :func:`flat_parametrization` (warm Newton with its carried Jacobians, the closed forms) on the plan's
    data buffers, without the series objects between them.  None (the caller takes the general path, whose
    result this is) when a stage has no native program, its Newton steps need the full scheme or the numpy
    steps, or the previous iterate lacks what a warm start needs."""
    from . import newton as nw

    if program_backend() != "native":
        return None
    nodes = len(t_nodes)
    loss = cached["order"] - order
    state = _native_state(system, cached, programs, order, nodes, h0)
    if not state:
        return None
    t = np.asarray(t_nodes, dtype=float)
    weights = _native_weights(cached, t)
    values = dict(hat or {})
    for n in system.neglected:
        if n not in values:
            values[n] = system.neglected_start(n)
    out, reports = {}, dict(cached["reports"])
    for h, st in state.items():
        stage, k = st.stage, order - h
        M = k + (2 if st.solve else 1)
        if st.B.shape[1] < M:
            return None
        if st.solve:
            B = st.data(M, loss, values)
            res = st.nat.evaluate(np.zeros((0, M, nodes)), B, M)
            u = [Series._wrap(res[j, : k + 1]) for j in range(res.shape[0])]
        else:
            if not all(n in guess for n in stage.unknowns):
                return None
            rep0 = guess.reports.get(f"stage{h}")
            Jn = getattr(getattr(rep0, "jacobian", None), "base", None)
            n = len(stage.unknowns)
            if not (isinstance(Jn, np.ndarray) and Jn.shape[:2] == (n, n) and Jn.shape[2] >= M):
                return None
            B = st.data(M, loss, values)
            x = np.empty((n, M, nodes))
            for j, name in enumerate(stage.unknowns):
                _fill(x[j], guess[name])
            Jc = np.ascontiguousarray(Jn[:, :, :M])
            if not np.all(np.isfinite(Jc)):
                return None
            status, cres, steps = st.nat.warm_newton(
                x, B, Jc, True, tol, weights[:M], nw.WARM_MAXSTEPS, nw.CHORD_STEPS, nw.CHORD_PROOF
            )
            if status != 0:
                return None
            u = [Series._wrap(x[j]) for j in range(n)]
            reports[f"stage{h}"] = nw.SeriesNewtonReport(
                tuple(stage.unknowns),
                t,
                cres,
                0,
                _lazy_series_residual(st.nat, x, np.array(B[:, :M], order="C", copy=True), M),  # B is reused
                [k] * steps,
                jacobian=np.swapaxes(Jc, 2, 3),
            )
        _keep_stage(system, h, stage, u, values, out)
    known = {n: v.truncate(v.order - loss) if loss else v for n, v in cached["known"].items()}
    known.update(out)
    return NodeSolution(known, order, reports, cached)


def _native_first_iterate(system, cached, programs, t_nodes, order, hat, tol, h0):
    """The first iterate's stages h >= h0 on the native evaluator and the plan's data buffers (:class:`_NativeStage`,
    sized here for the later iterates too), without the series objects and evaluators between them: the steps of
    :func:`_solve_stage` (a Newton stage from its :attr:`Stage.start`: the pointwise Newton, then the doubling
    steps; a warm stage: Newton at the working order; both from :attr:`Stage.start`, else :attr:`ChainedSystem.guess`;
    a closed form: its traced program), with the same reports.  None (the caller takes the general path, whose result this is) when a stage
    has no traced program yet (the first plan of a system and grid traces them there) or a check, a pointwise
    Newton leaves a node above the tolerance (the memory restarts), or the native steps hand back (a singular
    node, a warm start that needs the full scheme)."""
    from . import newton as nw

    if program_backend() != "native" or cached.get("native_stages") is not None:
        return None
    stages = list(enumerate(system.stages[h0 - 1 :], start=h0))
    for h, stage in stages:
        entry = programs.get(("solve", h) if stage.solve is not None else h)
        if entry is None or entry[0] is None or stage.check is not None:
            return None
    nodes = len(t_nodes)
    state = _native_state(system, cached, programs, order, nodes, h0)
    if not state:
        return None
    t = np.asarray(t_nodes, dtype=float)
    weights = _native_weights(cached, t)
    values = {}
    for n in system.neglected:
        values[n] = _as_series((hat or {}).get(n, system.neglected_start(n)), nodes, 0)
    out, reports = {}, dict(cached["reports"])
    for h, st in state.items():
        stage, k = st.stage, order - h
        M = k + (2 if st.solve else 1)
        if st.B.shape[1] < M:
            return None
        if any(name not in values for _r, name in st.var):
            return None
        B = st.data(M, 0, values)
        if st.solve:
            res = st.nat.evaluate(np.zeros((0, M, nodes)), B, M)
            u = [Series._wrap(res[j, : k + 1]) for j in range(res.shape[0])]
        else:
            n = len(stage.unknowns)
            x = np.zeros((n, M, nodes))
            # the starting values of _solve_stage; with the neglected terms at the system's start values and no
            # stage of this iterate before, a function of the static series only: kept with them
            starts = cached.get("starts") if not hat and not out else None
            start = None if starts is None else starts.get(h)
            if start is not None:
                pass
            elif stage.start is not None:
                data = {**cached["known"], **cached["derivs"], **out}
                for name in stage.neglected:
                    data[name] = values[name]
                start = stage.start(_at_order(data, 0), t_nodes)
                if starts is not None:
                    start = tuple(_frozen(c) for c in start)
                    starts[h] = start
            else:
                start = [system.guess.get(name, 0.0) for name in stage.unknowns]
            if len(start) != n:
                return None
            for j, c in enumerate(start):
                x[j, 0] = np.broadcast_to(np.asarray(c, dtype=float), (nodes,))
            if not stage.warm:  # the pointwise Newton, then the doubling steps
                x0 = np.array(x[:, 0])
                status, cres, its = st.nat.pointwise_newton(x0, B, tol, nw.PAPER_MAXITER)
                if status != 0 or not np.all(cres <= tol):
                    return None
                x[:, 0] = x0
                orders = nw.doubling_orders(k)
                if not orders:
                    return None
                Jc = np.empty((n, n, M, nodes))
                if st.nat.doubling(x, B, np.asarray(orders, dtype=np.int64), Jc) != 0:
                    return None
                steps = orders
            elif k > 0:  # warm: Newton at the working order from the starting values
                Jc = np.empty((n, n, M, nodes))
                status, cres, nsteps = st.nat.warm_newton(
                    x, B, Jc, False, tol, weights[:M], nw.WARM_MAXSTEPS, nw.CHORD_STEPS, nw.CHORD_PROOF
                )
                if status != 0:
                    return None
                its, steps = 0, [k] * nsteps
            else:
                return None
            u = [Series._wrap(x[j]) for j in range(n)]
            reports[f"stage{h}"] = nw.SeriesNewtonReport(
                tuple(stage.unknowns),
                t,
                cres,
                its,
                _lazy_series_residual(st.nat, x, np.array(B[:, :M], order="C", copy=True), M),  # B is reused
                steps,
                jacobian=np.swapaxes(Jc, 2, 3),
            )
        _keep_stage(system, h, stage, u, values, out)
    known = dict(cached["known"])
    known.update(out)
    return NodeSolution(known, order, reports, cached)


def _frozen(c) -> np.ndarray:
    """A read-only float copy of a starting value (kept for the later plans of a problem)."""
    a = np.array(c, dtype=float)
    a.flags.writeable = False
    return a


def _native_state(system, cached, programs, order, nodes, h0):
    """The plan's :class:`_NativeStage` per stage h >= h0 (made at the first iterate that asks, whose working
    orders size the buffers), or False when a stage has no native program."""
    state = cached.get("native_stages")
    if state is None:
        state = {}
        for h, stage in enumerate(system.stages[h0 - 1 :], start=h0):
            solve = stage.solve is not None
            prog, _ = programs.get(("solve", h) if solve else h, (None, ""))
            if prog is None:
                state = None
                break
            M = order - h + (2 if solve else 1)
            state[h] = _NativeStage(h, stage, prog, solve, cached, M, nodes)
        state = cached["native_stages"] = state if state is not None else False
    return state


def _native_run(system, t_nodes, iterates, orders, tol, timings):
    """Iterates ``len(iterates)`` .. ``len(orders) - 1`` of :func:`generalized_parametrization` in one native call
    (:func:`planners._native.iterates`, the stages of :func:`_native_iterate`), appended to ``iterates`` with
    their wall times in ``timings``.  Stops (the caller goes on iterate by iterate) where a Newton stage needs
    the full scheme or the numpy steps, where a stage's :attr:`Stage.post` changes its result (it ran after
    the native stages), or at once when the plan is not on the native evaluator."""
    from . import _native
    from . import newton as nw

    prev = iterates[-1]
    cached = prev._inputs
    j0, j1 = len(iterates), len(orders)
    if j0 >= j1 or not cached or program_backend() != "native":
        return
    nodes = len(t_nodes)
    state = cached.get("native_stages")
    if state is None and cached.get("programs") is not None:  # iterate 1: the buffers sized at its orders
        state = _native_state(system, cached, cached["programs"], orders[j0], nodes, _first_neglecting_stage(system))
    if not state:
        return
    lay = _native_layout(state, cached, orders, j0, j1, nodes)
    if lay is None:
        return  # a datum the native iterates do not provide
    slots, slot_h, sid, newton_stages = lay["slots"], lay["slot_h"], lay["sid"], lay["newton_stages"]
    ptrs = lay["ptrs"].copy()
    ptrs[:, 4] = [st.B.ctypes.data for st in state.values()]
    for st in state.values():  # the static rows as at iterate j0 - 1 or before (the native run zeroes them on)
        if cached["order"] - orders[j0] < st.loss:
            st.refill()
        st.loss = cached["order"] - orders[j1 - 1]
    nst, ns = len(state), len(slots)
    keep = []  # the arrays whose addresses the native call reads
    slot_ptrs = np.zeros((j1, ns), dtype=np.int64)
    for i, name in enumerate(slots):
        a = np.ascontiguousarray(np.real(prev[name]._c), dtype=float)
        if a.ndim != 2 or a.shape != (orders[j0 - 1] - slot_h[i] + 1, nodes):
            return
        keep.append(a)
        slot_ptrs[j0 - 1, i] = a.ctypes.data
    jac_ptrs = np.zeros((j1, nst), dtype=np.int64)
    cres_ptrs = np.zeros((j1, nst), dtype=np.int64)
    states = list(state.values())
    for i in newton_stages:
        st = states[i]
        rep = prev.reports.get(f"stage{st.h}")
        jac = getattr(rep, "jacobian", None)
        n = len(st.stage.unknowns)
        if jac is None or np.shape(jac) != (n, n, nodes, orders[j0 - 1] - st.h + 1):
            return
        a = np.ascontiguousarray(np.swapaxes(jac, 2, 3), dtype=float)
        keep.append(a)
        jac_ptrs[j0 - 1, i] = a.ctypes.data
    # the outputs of iterates j0 .. j1 - 1 in three blocks (one allocation each), addressed by offsets
    sizes, off, jsizes, joff = lay["sizes"], lay["off"], lay["jsizes"], lay["joff"]
    slot_buf, jac_buf = np.empty(lay["slot_total"]), np.empty(lay["jac_total"])
    cres_buf = np.empty((j1 - j0, len(newton_stages), nodes))
    slot_ptrs[j0:] = (slot_buf.ctypes.data + 8 * off).reshape(j1 - j0, ns)
    jac_ptrs[j0:, newton_stages] = (jac_buf.ctypes.data + 8 * joff).reshape(j1 - j0, len(newton_stages))
    cres_ptrs[j0:, newton_stages] = cres_buf.ctypes.data + 8 * nodes * lay["cres_index"]
    steps = np.zeros((j1, nst), dtype=np.int64)
    seconds = np.zeros(j1)
    weights = cached.get("native_weights")
    if weights is None:
        t = np.asarray(t_nodes, dtype=float)
        dt = np.diff(t)
        step = float(np.min(dt)) if t.size > 1 and np.all(dt > 0) else 1.0
        weights = cached["native_weights"] = step ** np.arange(cached["order"] + 2, dtype=float)
    done = _native.iterates(
        nst, lay["meta"], ptrs.reshape(-1), lay["var_rows"], lay["static_rows"], ns, lay["slot_h_arr"],
        lay["unk"], nodes, j0, j1, lay["orders"], cached["order"], slot_ptrs, jac_ptrs, cres_ptrs, steps, seconds,
        tol, weights, nw.WARM_MAXSTEPS, nw.CHORD_STEPS, nw.CHORD_PROOF,
    )  # fmt: skip
    out_slots, out_jac, out_cres = {}, {}, {}
    q = 0
    for j in range(j0, done):
        for i in range(ns):
            out_slots[j, i] = slot_buf[off[q] : off[q] + sizes[q]].reshape(-1, nodes)
            q += 1
    q = 0
    for j in range(j0, done):
        for c, i in enumerate(newton_stages):
            n = len(states[i].stage.unknowns)
            out_jac[j, i] = jac_buf[joff[q] : joff[q] + jsizes[q]].reshape(n, n, -1, nodes)
            out_cres[j, i] = cres_buf[j - j0, c]
            q += 1
    del keep
    t = np.asarray(t_nodes, dtype=float)
    top = cached["known"]
    for j in range(j0, done):
        loss = cached["order"] - orders[j]
        known = _truncated(top, loss)
        reports = dict(cached["reports"])
        changed = False
        for i, (h, st) in enumerate(state.items()):
            stage = st.stage
            u = [Series._wrap(out_slots[j, sid[n]]) for n in stage.unknowns]
            if stage.post is not None and any(a is not b for a, b in zip(stage.post(list(u)), u)):
                changed = True  # the native stages ran without it: this iterate and the later ones again
                break
            known.update(zip(stage.unknowns, u))
            if not st.solve:
                k = orders[j] - h
                reports[f"stage{h}"] = nw.SeriesNewtonReport(
                    tuple(stage.unknowns),
                    t,
                    out_cres[j, i],
                    0,
                    _lazy_residual_of(st, j, known, iterates, cached, loss, orders, nodes),
                    [k] * int(steps[j, i]),
                    jacobian=np.swapaxes(out_jac[j, i], 2, 3),
                )
        if changed:
            break
        iterates.append(NodeSolution(known, orders[j], reports, cached))
        timings[j] = float(seconds[j])


def _native_layout(state, cached, orders, j0, j1, nodes):
    """The arrays of :func:`_native_run` that depend on the stages' structure and the plan's orders only (the
    slots, the stages' rows and programs, the output blocks' sizes and offsets), made once per programs (system
    and grid), orders and buffer sizes (kept on the system beside its programs, which they point into), or None
    when a stage reads a datum the native iterates do not provide."""
    programs = cached.get("programs")
    store = cached["system"].__dict__.setdefault("_native_layouts", {})  # a frozen dataclass: its __dict__ holds it
    key = (id(programs), cached["order"], tuple(orders), j0, j1, nodes,
           tuple((h, st.solve, st.B.shape) for h, st in state.items()))  # fmt: skip
    hit = store.get(key)
    if hit is not None and hit[0] is programs:
        return hit[1]
    slots, slot_h = [], []
    for h, st in state.items():
        for name in st.stage.unknowns:
            slots.append(name)
            slot_h.append(h)
    sid = {n: i for i, n in enumerate(slots)}
    meta, ptrs, var_rows, static_rows, unk = [], [], [], [], []
    for h, st in state.items():
        stage = st.stage
        for r, name in st.var:
            base = name[:-1] if name.endswith("'") else name
            if name in stage.neglected and name in sid:
                var_rows.append((r, sid[name], 0, 1))  # the previous iterate's value
            elif base in sid and slot_h[sid[base]] < h:
                var_rows.append((r, sid[base], int(name != base), 0))
            else:
                return None
        static_rows.extend(st.static)
        unk.extend(sid[n] for n in stage.unknowns)
        nat = st.nat
        n_unk = 0 if st.solve else len(stage.unknowns)
        meta.append((int(st.solve), n_unk, nat.neq, nat.code.shape[0], nat.nreg, st.B.shape[0], st.B.shape[1],
                     len(st.var), len(st.static), h))  # fmt: skip
        ptrs.append((*(int(a.ctypes.data) for a in (nat.code, nat.params, nat.outs, nat.outs_unk)), 0))
    states = list(state.values())
    newton_stages = [i for i, st in enumerate(states) if not st.solve]
    ns, nn = len(slots), [len(states[i].stage.unknowns) ** 2 for i in newton_stages]
    sizes = [(orders[j] - slot_h[i] + 1) * nodes for j in range(j0, j1) for i in range(ns)]
    jsizes = [q * (orders[j] - states[i].h + 1) * nodes for j in range(j0, j1) for i, q in zip(newton_stages, nn)]
    lay = {
        "slots": slots,
        "slot_h": slot_h,
        "sid": sid,
        "newton_stages": newton_stages,
        "ptrs": np.array(ptrs, dtype=np.int64).reshape(len(states), 5),
        "sizes": sizes,
        "jsizes": jsizes,
        "off": np.concatenate(([0], np.cumsum(sizes)[:-1])).astype(np.int64),
        "joff": np.concatenate(([0], np.cumsum(jsizes)[:-1])).astype(np.int64),
        "slot_total": int(sum(sizes)),
        "jac_total": int(sum(jsizes)),
        "cres_index": np.arange((j1 - j0) * len(newton_stages), dtype=np.int64).reshape(j1 - j0, len(newton_stages)),
        "orders": np.array(orders, dtype=np.int64),
    }
    for name, v in (("meta", meta), ("var_rows", var_rows), ("static_rows", static_rows), ("slot_h_arr", slot_h),
                    ("unk", unk)):  # fmt: skip
        lay[name] = np.array(v, dtype=np.int64).reshape(-1)
    if programs is not None:  # the programs' code, parameters and outputs live as long as the programs
        store[key] = (programs, lay)
        while len(store) > 4 * PROGRAM_GRIDS:
            store.pop(next(iter(store)))
    return lay


def _truncated(series: Mapping, loss: int) -> dict:
    """Every series of ``series`` truncated by ``loss`` orders (:meth:`Series.truncate`'s views, without its
    checks where the order stays >= 0)."""
    if not loss:
        return dict(series)
    out = {}
    for n, v in series.items():
        c = v._c
        out[n] = Series._wrap(c[: c.shape[0] - loss]) if c.shape[0] > loss else v.truncate(v.order - loss)
    return out


def _lazy_residual_of(st, j, known, iterates, cached, loss, orders, nodes):
    """A native iterate's Newton report's series residual, evaluated on first access from the iterate's own
    series (the stage's data rebuilt: the plan's buffers hold the last iterate's)."""

    def series_residual() -> np.ndarray:
        from .program import NativeStageEvaluator

        prev = iterates[j - 1]
        data = {**{n: v.truncate(v.order - loss) if loss else v for n, v in cached["derivs"].items()}, **known}
        for name in st.stage.neglected:
            data[name] = prev[name]
        for _r, name in st.var:
            if name not in data and name.endswith("'") and name[:-1] in known:
                data[name] = known[name[:-1]].derivative()
        ev = NativeStageEvaluator(st.prog, data, nodes)
        u = [known[n] for n in st.stage.unknowns]
        return ev.series_residual(u, orders[j] - st.h, (nodes,))

    return series_residual


class _LazyDerivative:
    """A series' derivative computed when a stage's data first reads it."""

    __slots__ = ("v", "d")

    def __init__(self, v: Series) -> None:
        self.v, self.d = v, None


def _lazy_series_residual(nat, x, data, M):
    """The report's series residual (max abs coefficient per node), evaluated on first access."""

    def series_residual() -> np.ndarray:
        return np.max(np.abs(nat.evaluate(x, data, M)), axis=(0, 1))

    return series_residual


@dataclass
class ChainedPlan:
    """The iterates of :func:`generalized_parametrization`, evaluated anywhere by the paper's two-sided formula.

    Attributes
    ----------
    system : ChainedSystem
        The system planned.
    t_nodes : ndarray, shape (nodes,)
        Node times.
    iterates : list of NodeSolution
        Series of every variable, per iterate j = 0..J.
    timings : dict
        Wall time [s] per iterate.
    residuals : list of float
        Newton only: ``max |X^ - G~(X^)|`` per iterate.
    info : dict
        Newton only: ``"status"`` (``"converged"``, ``"stagnated"``, ``"diverged"``, ``"maxiter"``),
        ``"damping"`` (smallest step factor of each step) and ``"order"`` (kappa).
    """

    system: ChainedSystem
    t_nodes: np.ndarray
    iterates: list
    timings: dict = field(default_factory=dict)
    residuals: list = field(default_factory=list)
    info: dict = field(default_factory=dict)

    @property
    def J(self) -> int:
        """Index of the last iterate."""
        return len(self.iterates) - 1

    @property
    def reports(self) -> list:
        """Newton reports per iterate (dict ``"stage<h>"`` -> report)."""
        return [it.reports for it in self.iterates]

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
        from .plan import _horner, interval_coefficients

        s = self.iterates[j].get(name)
        if s is None:
            raise InputError(f"unknown variable {name!r}; known: {', '.join(self.iterates[j])}")
        tn = self.t_nodes
        c = np.broadcast_to(np.real(np.asarray(s.coeffs)), (len(tn), s.order + 1))[:, None, :]
        t_arr = np.atleast_1d(np.asarray(t, dtype=float))
        if np.any(t_arr < tn[0] - 1e-12) or np.any(t_arr > tn[-1] + 1e-12):
            raise InputError(f"time outside the plan [{tn[0]:g}, {tn[-1]:g}]")
        poly = interval_coefficients(c[:-1], c[1:], np.diff(tn), "paper")  # (intervals, 1, K + 2)
        i = np.clip(np.searchsorted(tn, t_arr, side="right") - 1, 0, len(tn) - 2)
        out = _horner(poly[i], t_arr - tn[i], derivative)
        return out[0] if np.ndim(t) else float(out[0][0])


def generalized_parametrization(
    system: ChainedSystem,
    t_nodes,
    zeta: Mapping[str, Callable] | None = None,
    J: int = 0,
    e: int = 1,
    v: Mapping | None = None,
    newton_tol: float | None = None,
    guesses: list | None = None,
    progress: Callable | None = None,
    stop: Callable | None = None,
) -> ChainedPlan:
    """``GeneralizedFlatParametrization(v, zeta, J, e)`` of the paper for a chained system.

    Iterate j starts its Newton iterations from iterate j - 1 (and truncates its series that do not
    depend on the neglected terms, and carries its Jacobians: :func:`flat_parametrization`).

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
    guesses : list of NodeSolution, optional
        Starting points of the iterates (``guesses[j]`` for iterate j, e.g. a plan with a smaller J:
        the same iterate at a lower order) instead of the previous iterate.
    progress : callable, optional
        ``progress(j, kappa, seconds)`` after each iterate.
    stop : callable, optional
        ``stop(sol) -> bool`` after each iterate: True ends the iterations there (e.g. at a Newton failure,
        when only whether the plan exists matters).

    Returns
    -------
    ChainedPlan
        Every iterate j = 0..J (iterate j at ``kappa_0 - j L``, ``kappa_0 = e + r + J L``), or up to the
        one ``stop`` ended at.

    Raises
    ------
    InputError
        Fewer than two increasing nodes or a negative J.
    """
    t_nodes = check_grid(t_nodes)
    if J < 0:
        raise InputError(f"J must be >= 0, got {J}")
    kappa = e + system.r + J * system.L
    iterates, timings = [], {}
    hat, prev = dict(v or {}), None
    orders = [kappa - j * system.L for j in range(J + 1)]
    tol = system.newton_tol if newton_tol is None else newton_tol
    j = 0
    while j <= J:
        if j >= 1 and guesses is None:  # the remaining iterates in one native call (when the plan is native)
            _native_run(system, t_nodes, iterates, orders, tol, timings)
            if len(iterates) > j:
                for jj in range(j, len(iterates)):
                    if progress is not None:
                        progress(jj, orders[jj], timings[jj])
                j = len(iterates)
                prev = iterates[-1]
                hat = {n: prev[n] for n in system.neglected}
                continue
        t0 = time.perf_counter()
        guess = guesses[j] if guesses is not None and j < len(guesses) else prev
        sol = flat_parametrization(system, t_nodes, orders[j], zeta, hat=hat, guess=guess, newton_tol=newton_tol)
        timings[j] = time.perf_counter() - t0
        if progress is not None:
            progress(j, orders[j], timings[j])
        iterates.append(sol)
        if stop is not None and stop(sol):
            break
        hat = {n: sol[n] for n in system.neglected}
        prev = sol
        j += 1
    return ChainedPlan(system, t_nodes, iterates, timings)


def _native_weights(cached: dict, t: np.ndarray) -> np.ndarray:
    """step^m for m = 0 .. order + 1, step the smallest node spacing (planners.newton._warm_newton's test), kept
    in ``cached``."""
    weights = cached.get("native_weights")
    if weights is None:
        dt = np.diff(t)
        step = float(np.min(dt)) if t.size > 1 and np.all(dt > 0) else 1.0
        weights = cached["native_weights"] = step ** np.arange(cached["order"] + 2, dtype=float)
    return weights


def _keep_stage(system, h: int, stage, u: list, values: dict, out: dict) -> None:
    """A native stage's solved unknowns (after :attr:`Stage.post`) kept in ``values`` and ``out``, with the lazy
    derivatives the later stages read (stages below ``system.r``)."""
    if stage.post is not None:
        u = list(stage.post(list(u)))
    for name, v in zip(stage.unknowns, u):
        values[name] = out[name] = v
        if h < system.r and v.order >= 1:
            values[name + "'"] = _LazyDerivative(v)
