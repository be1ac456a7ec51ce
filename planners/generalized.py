"""Motion planning by flatness and generalized flatness (paper section "Generalized flatness").

Algorithm ``GeneralizedFlatParametrization(v, zeta, J, e)``: the neglected
terms H of the force equations start at given values ``v`` (zero or a
calibration), and are re-evaluated J times from the previous iterate::

    L := 2;  kappa_0 := e + r + J L          (r = 4 stages; 5 + 2J for the controls at order e = 1)
    for j = 0..J:
        X[j] := FlatParametrization(t, kappa_j, zeta, H = X[j-1])
        kappa_{j+1} := kappa_j - L

Every iterate is kept in the returned :class:`~planners.plan.Plan`; all the
nodes of the grid are computed together (array code), and iterate j starts
its Newton iterations from iterate j - 1.
"""

from __future__ import annotations

import logging

import numpy as np

from gna.eom import STATE_NAMES
from gna.errors import DomainError, InputError
from gna.trajectory import domain_bounds, first_domain_violation, ground_violation, inside_domain

from .chained import generalized_parametrization
from .flat import FlatProblem, aircraft_system, check_grid, check_iterations, check_whole, plan_iterate
from .generalized_newton import newton_parametrization, truncate_solution
from .plan import DEFAULT_INTERPOLATION, Plan, check_interpolation
from .singularity import monitor

#: Order lost per iteration (the paper's L = max l_h - 1 = 2 for aircraft).
ORDER_LOSS = 2
#: Number of stages between the flat outputs and the controls.
STAGES = 4
#: Default bound on :func:`plan_cost`: 5e6 node-order^2 units, about 30 s of planning (about 6 us per unit
#: measured on 2 cores; the paper's largest plan, the J = 7 aileron roll on 81 nodes, costs 1.07e5).
MAX_PLAN_COST = 5.0e6
#: Samples per node interval of the height test along the plan's path (:func:`ground_failures`).
GROUND_SAMPLES = 64
#: Plans costing more than this log their progress per iterate (logger ``planners.generalized``, INFO).
PROGRESS_COST = 5.0e5

_log = logging.getLogger(__name__)

#: Largest output order e a plan accepts (the controls' series order in the last iterate).
MAX_E = 10
#: ``J = "auto"``: the rule choosing J from the full-model equation residual at the nodes of each iterate
#: (:meth:`~planners.plan.Plan.iterate_residuals`, max over the 12 equations [m/s^2 for V, rad/s for
#: the angles]): stop at the first iterate whose residual is at most :data:`AUTO_J_TOL`, or, when an
#: iterate decreases it by less than 10 % (ratio to the previous above :data:`AUTO_J_RATIO`), at the
#: iterate of least residual so far; never beyond :data:`AUTO_J_MAX`.
AUTO_J = "auto"
AUTO_J_TOL = 1e-8
AUTO_J_RATIO = 0.9
AUTO_J_MAX = 12
#: ``J = "auto"`` first plans with this J, then, while the rule has not stopped, with the J at which the
#: last ratio of decrease reaches the tolerance (:data:`AUTO_J_STEP` more when no ratio is usable; up
#: to the maximum), the Newton iterations of each iterate starting from the previous attempt's.  The
#: iterates 0..J' of a plan with J >= J' are, truncated, those of the plan with J' (truncated power
#: series: a coefficient depends only on the coefficients below it), so only the last attempt is kept.
AUTO_J_START = 4
AUTO_J_STEP = 4

#: Methods of the generalized flat parametrization: the paper's J iterations, or Newton's method
#: on their fixed point (:mod:`planners.generalized_newton`).
METHODS = ("fixed-point", "newton")


def check_output_order(e, where: str = "plan") -> int:
    """The output order ``e`` (the controls' series order in the last iterate), checked.

    Parameters
    ----------
    e : int
        A whole number in 0..:data:`MAX_E` (a float with a whole value, as TOML may give, is accepted).
    where : str
        What the message names (file, function).

    Returns
    -------
    int

    Raises
    ------
    InputError
        Not a whole number, or outside 0..MAX_E.
    """
    return check_whole(e, "the output order e", MAX_E, where)


def choose_J(residuals, tol: float = AUTO_J_TOL, ratio: float = AUTO_J_RATIO) -> tuple[int | None, str]:
    """The rule of ``J = "auto"`` on the residuals of iterates 0, 1, ... (module constants).

    Parameters
    ----------
    residuals : sequence of float
        Full-model equation residual at the nodes of iterates 0..n [m/s^2, rad/s].
    tol : float
        Stop at the first iterate with a residual at most ``tol``.
    ratio : float
        Stop when an iterate's residual exceeds ``ratio`` times the previous one (or is not finite),
        choosing the iterate of least residual so far.

    Returns
    -------
    J : int or None
        The chosen number of iterations, or None when the rule has not stopped within ``residuals``.
    reason : str
        ``"tolerance"``, ``"stagnation"`` or ``""`` (not stopped).
    """
    res = [float(r) if np.isfinite(r) else np.inf for r in residuals]
    for j, r in enumerate(res):
        if r <= tol:
            return j, "tolerance"
        if j > 0 and not r <= ratio * res[j - 1]:
            return int(np.argmin(res[: j + 1])), "stagnation"
    return None, ""


def plan_cost(nodes: int, J: int, e: int = 1) -> float:
    """Cost estimate of a plan: ``nodes * sum_j kappa_j^2``, ``kappa_j = e + 4 + 2 (J - j)``.

    The truncated-series products at order ``kappa`` cost ``kappa^2`` per
    node; the time of a plan grows like this figure (about 6 us per unit,
    memory like ``nodes * kappa``).

    Parameters
    ----------
    nodes : int
        Number of grid nodes.
    J : int
        Generalized-flatness iterations.
    e : int
        Order of the controls in the last iterate.

    Returns
    -------
    float
        Node-order^2 units.
    """
    kappa0 = e + STAGES + J * ORDER_LOSS
    return float(nodes) * sum((kappa0 - ORDER_LOSS * j) ** 2 for j in range(J + 1))


def plan_motion(
    problem: FlatProblem,
    t_nodes,
    J: int | str = 0,
    e: int = 1,
    name: str = "plan",
    max_cost: float | None = None,
    method: str = "fixed-point",
    newton_tol: float = 1e-12,
    newton_maxiter: int = 8,
    interpolation: str | None = None,
    J_tol: float = AUTO_J_TOL,
    J_max: int = AUTO_J_MAX,
    stop_on_failure: bool = False,
) -> Plan:
    """Plan with J generalized-flatness iterations, or Newton's method on their fixed point.

    Parameters
    ----------
    problem : FlatProblem
        Aircraft, environment, flat outputs and first-iterate H values.
    t_nodes : array, shape (nodes,)
        Increasing grid of at least two nodes [s].
    J : int or "auto"
        Iterations after the plain flat plan (J = 0: flat plan only), or ``"auto"``: chosen by the
        convergence test of :func:`choose_J` on the full-model equation residual at the nodes
        (tolerance ``J_tol``, at most ``J_max``; fixed-point method only).
    e : int
        The paper's output order: the controls' series order in the last iterate (0..:data:`MAX_E`;
        the flat outputs start at order ``kappa_0 = e + 4 + 2 J``).
    name : str
        Name of the plan (for messages and outputs).
    max_cost : float, optional
        Bound on :func:`plan_cost` (default :data:`MAX_PLAN_COST`;
        ``math.inf`` removes it).  Plans above :data:`PROGRESS_COST` log each
        iterate (INFO, logger ``planners.generalized``).
    method : {"fixed-point", "newton"}
        ``"fixed-point"``: the paper's ``GeneralizedFlatParametrization`` (iterate j uses the H
        values of iterate j - 1).  ``"newton"``: Newton's method on ``H = G(H)`` at the same starting
        order ``kappa = e + 4 + 2 J`` (J is then the depth, not the number of iterations), iterates
        truncated to the orders of the fixed point's iterate J (:func:`planners.generalized_newton.newton_parametrization`).
    newton_tol : float
        ``"newton"`` only: stop when ``max |H - G(H)|`` is below this [rad/s, rad].
    newton_maxiter : int
        ``"newton"`` only: Newton steps at most.
    interpolation : {"hermite", "paper"}, optional
        Evaluation between nodes (default :data:`planners.plan.DEFAULT_INTERPOLATION`; see
        :mod:`planners.plan`).
    J_tol : float
        ``J = "auto"`` only: residual tolerance [m/s^2, rad/s] (default :data:`AUTO_J_TOL`).
    J_max : int
        ``J = "auto"`` only: largest J tried (default :data:`AUTO_J_MAX`).
    stop_on_failure : bool
        Fixed-point method with a whole J: end the iterations at the first iterate whose Newton fails
        (the plan is then infeasible and has fewer iterates than J + 1); for callers that only need to
        know whether the plan exists (the bounded planner's candidates), at a fraction of a failure's cost.

    Returns
    -------
    Plan
        Every iterate, the Newton, singularity and envelope warnings, timings; ``plan.generalized``
        holds the method, ``"J_rule"`` (how J was chosen) and ``"J_residuals"`` (the residual of every
        iterate computed), and for Newton its status and fixed-point residual ``max |H - G(H)|`` of
        each iterate; ``plan.e`` and ``plan.interpolation`` the output order and formula.

    Raises
    ------
    InputError
        A grid of fewer than two increasing nodes, J neither a whole number in 0..30 nor ``"auto"``,
        ``"auto"`` with the Newton method, e not in 0..MAX_E, an unknown interpolation, a plan
        costing more than ``max_cost``, or an unknown method.
    DomainError
        The flat output's altitude ``-z`` at a node is outside the
        atmosphere model's range (the ISA's -2 to 20 km).
    """
    auto = isinstance(J, str) and J == AUTO_J
    if auto:
        J_max = check_iterations(J_max, f"plan {name}: J_max")
        if not (isinstance(J_tol, (int, float)) and not isinstance(J_tol, bool) and J_tol >= 0):
            raise InputError(f"plan {name}: J_tol must be a number >= 0 [m/s^2, rad/s], got {J_tol!r}")
        if method != "fixed-point":
            raise InputError(f'plan {name}: J = "auto" needs the fixed-point method, got method {method!r}')
        J = min(AUTO_J_START, J_max)
    else:
        J = check_iterations(J, f"plan {name}")
    e = check_output_order(e, f"plan {name}")
    interpolation = check_interpolation(
        DEFAULT_INTERPOLATION if interpolation is None else interpolation, f"plan {name}"
    )
    t_nodes = check_grid(t_nodes)
    if method not in METHODS:
        raise InputError(f"generalized-flatness method must be one of {', '.join(METHODS)}, got {method!r}")
    with np.errstate(all="ignore"):  # a non-finite z is reported by the parametrization with its cause
        z = np.broadcast_to(np.real(np.asarray(problem.z(t_nodes), dtype=complex)), t_nodes.shape)
    finite = np.isfinite(z)
    problem.env.check_altitude(-z[finite], f"plan {name}, flat output z", times=t_nodes[finite])
    limit = MAX_PLAN_COST if max_cost is None else float(max_cost)
    _check_cost(name, len(t_nodes), J, e, limit)
    if method == "newton":
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            cp = newton_parametrization(
                aircraft_system(problem), t_nodes, None, J, e, tol=newton_tol, maxiter=newton_maxiter
            )
        iterates = [plan_iterate(it) for it in cp.iterates]
        info = {"residual": cp.residuals, "timings": cp.timings, **cp.info}
        plan = Plan(problem, t_nodes, iterates, [], name, info["timings"], interpolation=interpolation, e=e)
        plan.generalized = {"method": method, "depth": J, "J_rule": "given", **info}
        if info["status"] != "converged":
            plan.warnings.append(
                f"Newton on the generalized-flatness fixed point {info['status']} after "
                f"{len(info['residual']) - 1} step(s): max |H - G(H)| = {info['residual'][-1]:.3g} "
                f"(tolerance {newton_tol:g})"
            )
        return _finish(plan)
    if not auto:
        iterates, timings = _fixed_point(problem, t_nodes, J, e, name, stop_on_failure=stop_on_failure)
        plan = Plan(problem, t_nodes, iterates, [], name, timings, interpolation=interpolation, e=e)
        plan.generalized = {"method": method, "J_rule": "given"}
        return _finish(plan)
    iterates, timings, info = _auto_J(problem, t_nodes, J, e, name, J_tol, J_max, limit)
    plan = Plan(problem, t_nodes, iterates, [], name, timings, interpolation=interpolation, e=e)
    plan.generalized = {"method": method, **info}
    if info["J_stop"] in ("J_max", "cost"):
        plan.warnings.append(
            f'J = "auto": the residual {info["J_residuals"][plan.J]:.3g} of iterate J = {plan.J} '
            f"is above the tolerance {J_tol:g} and still decreasing; stopped by "
            f"{'J_max' if info['J_stop'] == 'J_max' else 'the cost bound'}"
        )
    return _finish(plan)


def _check_cost(name: str, nodes: int, J: int, e: int, limit: float) -> float:
    cost = plan_cost(nodes, J, e)
    if cost > limit:
        raise InputError(
            f"plan {name}: J = {J} on {nodes} nodes costs {cost:.3g} node-order^2 units, "
            f"above the bound {limit:.3g} (about {_duration(6e-6 * cost)} of planning); use fewer "
            f"nodes or a smaller J, or raise the bound (--max-cost, max_cost= in Python; inf for none)"
        )
    return cost


def _duration(seconds: float) -> str:
    """``"12 s"`` under a minute, ``"3 min"`` above: an estimate's size in the unit a reader expects."""
    return f"{seconds:.2g} s" if seconds < 60 else f"{seconds / 60:.0f} min"


def _fixed_point(
    problem: FlatProblem,
    t_nodes: np.ndarray,
    J: int,
    e: int,
    name: str,
    guesses: list | None = None,
    stop_on_failure: bool = False,
) -> tuple[list, dict]:
    """The paper's J iterations (:func:`planners.chained.generalized_parametrization` of
    :func:`planners.flat.aircraft_system`): iterates 0..J (orders ``e + 4 + 2 (J - j)``) and their
    wall times.

    Iterate j starts its Newton iterations from ``guesses[j]`` when given (a lower-order solution of
    the same iterate), else from iterate j - 1.
    """
    cost = plan_cost(len(t_nodes), J, e)
    progress = None
    if cost > PROGRESS_COST:
        _log.info(
            "plan %s: J = %d on %d nodes, cost %.3g units (about %.0f s)", name, J, len(t_nodes), cost, 6e-6 * cost
        )
        done = []

        def progress(j, kappa, seconds):
            done.append(seconds)
            share = plan_cost(len(t_nodes), j, e + ORDER_LOSS * (J - j)) / cost
            _log.info(
                "plan %s: iterate j = %d of %d (order %d) in %.1f s; %.1f s so far, about %.0f s left",
                name,
                j,
                J,
                kappa,
                seconds,
                sum(done),
                sum(done) * (1.0 / max(share, 1e-12) - 1.0),
            )

    # Near a singularity Newton may overflow: reported through the Newton and monitor warnings.
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        cp = generalized_parametrization(
            aircraft_system(problem),
            t_nodes,
            None,
            J,
            e,
            guesses=guesses,
            progress=progress,
            stop=_failed if stop_on_failure else None,
        )
    return [plan_iterate(it) for it in cp.iterates], cp.timings


def _failed(sol) -> bool:
    """Whether an iterate's Newton failed somewhere (a stage report with failures)."""
    return any(getattr(rep, "failures", ()) for rep in sol.reports.values())


def _more_iterations(res: list, tol: float) -> int:
    """Iterations to add so that the residual reaches ``tol`` at the last ratio of decrease (at least 1),
    or :data:`AUTO_J_STEP` when there is no usable ratio."""
    if len(res) < 2 or not (tol > 0 and np.isfinite(res[-1]) and np.isfinite(res[-2]) and res[-1] > 0):
        return AUTO_J_STEP
    q = res[-2] / res[-1]
    if not q > 1.0:
        return AUTO_J_STEP
    return max(1, int(np.ceil(np.log(res[-1] / tol) / np.log(q))))


def _auto_J(
    problem: FlatProblem, t_nodes: np.ndarray, J: int, e: int, name: str, tol: float, J_max: int, limit: float
) -> tuple[list, dict, dict]:
    """``J = "auto"``: plans with J, then with the J :func:`_more_iterations` predicts, until :func:`choose_J`
    stops (or J_max, or the cost bound); the chosen iterates, truncated to the orders of a plan with that J."""
    system = aircraft_system(problem)
    attempts, total, guesses = [], 0.0, None
    while True:
        iterates, timings = _fixed_point(problem, t_nodes, J, e, name, guesses)
        total += sum(timings.values())
        attempts.append(J)
        res = Plan(problem, t_nodes, iterates).iterate_residuals()
        chosen, stop = choose_J(res, tol)
        if chosen is None:
            nxt = min(J_max, J + _more_iterations(res, tol))
            if J >= J_max:
                stop = "J_max"
            elif plan_cost(len(t_nodes), nxt, e) > limit:
                stop = "cost"
            else:
                J, guesses = nxt, iterates
                continue
            chosen = int(np.argmin([r if np.isfinite(r) else np.inf for r in res]))
        break
    kept = [
        plan_iterate(truncate_solution(system, it, e + STAGES + ORDER_LOSS * (chosen - j)))
        for j, it in enumerate(iterates[: chosen + 1])
    ]
    rule = (
        f"auto: the first iterate with full-model residual <= {tol:g}, or at a ratio to the previous "
        f"> {AUTO_J_RATIO:g} the least so far, J <= {J_max}"
    )
    info = {
        "J_rule": rule,
        "J_stop": stop,
        "J_residuals": res,
        "J_attempts": attempts,
        "J_tol": tol,
        "J_max": J_max,
        "J_planning_s": total,
    }
    return kept, {j: timings[j] for j in range(chosen + 1)}, info


def _finish(plan: Plan) -> Plan:
    """Newton failures, domain, singularity monitor and envelope checks of a plan (both methods)."""
    plan.warnings.extend(plan.newton_failures)
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        plan.singularities = monitor(plan)
    # a numerically singular stage 2 first: it is the cause of the later iterates' divergence
    plan.domain_failures = plan.singularities.failures + domain_failures(plan) + ground_failures(plan)
    plan.warnings.extend(plan.domain_failures)
    plan.warnings.extend(plan.singularities.warnings)
    if plan.feasible:  # between the nodes too: the grid and the limits of the flyability verdict
        plan.warnings.extend(f"plan (j = {plan.J}): {v.text()}" for v in plan.limit_violations())
    return plan


def domain_failures(plan: Plan) -> list[str]:
    """The iterates whose node values leave the physical domain, one message each (time, variable, value).

    Parameters
    ----------
    plan : Plan
        A plan with its iterates.

    Returns
    -------
    list of str
        ``"iterate j = ...: left the physical domain at t = ... s: ..."`` for
        each iterate with a node outside :data:`gna.trajectory.DOMAIN`.
    """
    t = plan.t_nodes
    states = [_node_states(it.series, t.shape) for it in plan.iterates]
    # All the iterates in one test (the usual case: every node inside); the message of each failed one.
    inside = inside_domain(np.concatenate(states, axis=1)).reshape(len(states), t.size)
    return [f"iterate j = {j}: {first_domain_violation(t, X)}" for j, X in enumerate(states) if not inside[j].all()]


def _node_states(series, shape: tuple) -> np.ndarray:
    """(12, nodes): the real constant terms of the states' node series."""
    cs = [series[n]._c[0] for n in STATE_NAMES]
    if all(c.shape == shape and c.dtype == np.float64 for c in cs):
        return np.stack(cs)
    return np.array([_node_array(series[n], shape) for n in STATE_NAMES])


def _node_array(series, shape: tuple) -> np.ndarray:
    """The real constant terms of a node series, of the grid's shape."""
    c = np.real(series.constant_term)
    return c if c.shape == shape else np.broadcast_to(c, shape)


def ground_failures(plan: Plan) -> list[str]:
    """With ground effect, the iterates whose path between the nodes reaches the ground, one message each.

    The nodes' heights are refused before planning (:meth:`gna.atmosphere.Environment.check_altitude`); the
    path between them (the plan's own interpolation of the node series, :meth:`Plan.piecewise`) can still dip
    to the ground, where the model does not hold (no ground contact): its height ``h = -z - elevation`` is
    sampled at :data:`GROUND_SAMPLES` points per node interval (nodes included).

    Parameters
    ----------
    plan : Plan
        A plan with its iterates (its problem's environment gives the ground).

    Returns
    -------
    list of str
        ``"iterate j = ...: left the physical domain at t = ... s: height above the ground at or below 0 (...)
        (h = ... m, z = ... m); lowest h = ... m at t = ... s"`` (:func:`gna.trajectory.ground_violation`:
        the first sample at or below the ground) for each such iterate; empty in free air.
    """
    bounds = domain_bounds(plan.problem.env)
    if bounds.ground is None:
        return []
    tn = np.asarray(plan.t_nodes, dtype=float)
    frac = np.arange(GROUND_SAMPLES) / GROUND_SAMPLES
    t = np.append((tn[:-1, None] + np.diff(tn)[:, None] * frac).ravel(), tn[-1])
    out = []
    for j in range(plan.J + 1):
        try:
            z = plan.piecewise(("z",), j).evaluate(t)[0]
        except InputError:  # non-finite series: a Newton failure, reported as such
            continue
        h = -z - bounds.ground
        bad = ~(h > 0)
        if bad.any():
            i, k = int(np.argmax(bad)), int(np.argmin(np.where(np.isfinite(h), h, -np.inf)))
            out.append(
                f"iterate j = {j}: {ground_violation(float(t[i]), float(z[i]), bounds)}; "
                f"lowest h = {h[k]:.6g} m at t = {t[k]:.6g} s"
            )
    return out


def plan_scenario(
    scenario,
    J: int | str | None = None,
    max_cost: float | None = None,
    method: str | None = None,
    e: int | None = None,
    interpolation: str | None = None,
    stop_on_failure: bool = False,
) -> Plan:
    """Plan a :class:`~planners.scenario.Scenario`.

    Parameters
    ----------
    scenario : Scenario
        Flat outputs, aircraft, grid, J, e and the evaluation between nodes.
    J : int or "auto", optional
        Generalized-flatness iterations, or ``"auto"`` (:func:`choose_J`, with the scenario's
        ``J_tol`` and ``J_max``); default: the scenario's.
    max_cost : float, optional
        Bound on :func:`plan_cost` (default :data:`MAX_PLAN_COST`).
    method : {"fixed-point", "newton"}, optional
        Generalized-flatness method (default: the scenario's ``[generalized] method`` when it has
        one, else ``"fixed-point"``).
    e : int, optional
        Output order (the controls' series order in the last iterate); default: the scenario's.
    interpolation : {"hermite", "paper"}, optional
        Evaluation between nodes; default: the scenario's.
    stop_on_failure : bool
        End the iterations at the first Newton failure (:func:`plan_motion`).

    Returns
    -------
    Plan
        See :func:`plan_motion`.  A scenario with free parameters (``[parameters]`` with a range) is planned
        bounded (:func:`planners.bounded.plan_bounded`: the parameters minimizing its ``[bounded] cost``
        within the aircraft's limits, every candidate planned by this function); the plan of the optimum
        is returned, ``plan.bounded`` holding the optimizer's outcome.

    Raises
    ------
    InputError
        ``scenario`` is not a Scenario, ``J`` is neither a whole number in 0..30 nor ``"auto"``, ``e``
        is not in 0..MAX_E, an unknown interpolation, or an unknown ``[generalized] method`` in the
        scenario.
    DomainError
        A bounded scenario none of whose parameter vectors gave a plan.
    """
    if not (callable(getattr(scenario, "problem", None)) and hasattr(scenario, "t_nodes")):
        raise InputError(
            f"a Scenario is needed, got {type(scenario).__name__} {scenario!r:.60}; "
            f"planners.scenario.load_scenario(name) makes one"
        )
    if J is not None and not (isinstance(J, str) and J == AUTO_J):
        J = check_iterations(J, f"plan_scenario({scenario.name})")
    if getattr(scenario, "free_parameters", ()):
        from .bounded import plan_bounded

        if method is not None or e is not None or interpolation is not None:
            raise InputError(
                f"plan_scenario({scenario.name}): a scenario with free parameters is planned bounded with its "
                f"own method, e and interpolation"
            )
        result = plan_bounded(scenario, J=J, max_cost=max_cost)
        if result.plan is None:
            raise DomainError(f"{scenario.name}: {result.infeasible_line()}")
        result.plan.bounded = result
        return result.plan
    if method is None:
        gen = (getattr(scenario, "raw", None) or {}).get("generalized", {})
        method = gen.get("method", "fixed-point") if isinstance(gen, dict) else "fixed-point"
        if method not in METHODS:
            raise InputError(
                f"scenario {scenario.name} [generalized]: method must be one of "
                f"{', '.join(repr(m) for m in METHODS)}, got {method!r}"
            )
    e = getattr(scenario, "e", 1) if e is None else check_output_order(e, f"plan_scenario({scenario.name})")
    interpolation = getattr(scenario, "interpolation", None) if interpolation is None else interpolation
    return plan_motion(
        scenario.problem(),
        scenario.t_nodes,
        scenario.J if J is None else J,
        e=e,
        name=scenario.name,
        max_cost=max_cost,
        method=method,
        interpolation=interpolation,
        J_tol=getattr(scenario, "J_tol", AUTO_J_TOL),
        J_max=getattr(scenario, "J_max", AUTO_J_MAX),
        stop_on_failure=stop_on_failure,
    )
