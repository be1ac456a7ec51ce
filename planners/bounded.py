"""Plans within the aircraft's limits: free parameters, a cost and scipy.optimize around the planner.

A scenario with free parameters (``[parameters] name = {value, min, max}``, used by its flat-output
expressions or spline coefficients, :mod:`planners.splines`) describes a family of manoeuvres.  The bounded
planner picks the member that minimizes a cost subject to the aircraft's limits::

    minimize    cost(p)                                     over p in [min, max] (each parameter)
    subject to  lower_L(t) + margin s_L <= L(t) <= upper_L(t) - margin s_L
                for every limit L of gna.limits.aircraft_limits and every t of the verdict's grid

* **The plan inside the loop** is the scenario's generalized-flat plan of the full model
  (:func:`planners.generalized.plan_scenario`: J iterations, the scenario's grid, e and interpolation) at
  ``p`` (:meth:`planners.scenario.Scenario.at`), so the optimum's controls fly the full model.
* **The limits** are those of the flyability verdict, one definition (:mod:`gna.limits`: every surface,
  thrust per engine, eta, the alpha/beta/Mach validity box, the load factor), on the verdict's grid
  (:meth:`planners.plan.Plan.limit_frame`: step ``min(0.01 s, node step / 8)``, the controls as an engine
  flies them).  Each limit's distance to its bound, over its scale ``s_L`` (half its range; thrust over
  ``m g``), is taken at its least in each of :data:`WINDOWS` windows of the span: the constraints of
  the optimizer.  ``margin`` (default :data:`DEFAULT_MARGIN`) keeps the optimum strictly inside, so that
  the verdict's exact comparison holds at every point of the grid.
* **A plan that fails** (Newton, the physical domain, a singular parametrization, a boundary trim that does
  not converge) is a violation of every constraint (value :data:`FAILED`), not an error: the optimizer steps back.
* **Gradients** by forward differences over the planner (step :data:`FD_STEP` of each parameter's range),
  every plan evaluated once (a cache by parameter vector); SLSQP (default) or trust-constr
  (:func:`scipy.optimize.minimize`) on the parameters scaled to [0, 1].
* **Costs** (:data:`COSTS`): ``deviation`` sum of ((p - value) / (max - min))^2 [-]; ``control_rate`` the
  mean over the span of sum_c (du_c/dt / s_c)^2 [1/s^2], ``s_c`` the half range of each control
  (:func:`gna.limits.control_ranges`; thrust without a limit: ``m g``); ``thrust`` the integral of F [N s];
  ``duration`` t1 - t0 [s].
* **Infeasible bounds**: when no parameter value meets every limit, the least worst violation is sought
  (minimize ``w`` subject to every scaled constraint ``>= -w``) and :meth:`BoundedResult.infeasible_line`
  names the binding limit and the best value it reaches.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from gna.errors import GflatError, InputError

from .singularity import monitor

_log = logging.getLogger(__name__)

#: Costs the bounded planner minimizes (``[bounded] cost``).
COSTS: tuple[str, ...] = ("deviation", "control_rate", "thrust", "duration")
#: Optimizers (:func:`scipy.optimize.minimize` methods).
METHODS: tuple[str, ...] = ("SLSQP", "trust-constr")
#: Keys of the ``[bounded]`` table.
BOUNDED_KEYS: tuple[str, ...] = ("cost", "method", "maxiter", "margin", "singular_margin", "tol")
#: Default share of each limit's scale kept between the optimum and the bound.
DEFAULT_MARGIN = 1e-3
#: Default share of the stage-2 condition's largest magnitude (the nominal plan's) it keeps at every node.
DEFAULT_SINGULAR_MARGIN = 0.1
#: Default iterations of the optimizer.
DEFAULT_MAXITER = 60
#: Default tolerance of the optimizer (SLSQP's ``ftol``; trust-constr's ``gtol`` and ``xtol``).
DEFAULT_TOL = 1e-7
#: Forward-difference step on the parameters scaled to [0, 1].
FD_STEP = 1e-6
#: Windows of the span each limit's least distance is taken over (at most one per node interval).
WINDOWS = 40
#: A limit is reported active when its least scaled distance to the bound is at most this plus the margin.
ACTIVE_TOL = 2e-3
#: Scaled distances beyond the bound by more than one scale are compressed (``-1 - log(-d)``: continuous, slope 1
#: at -1, monotone, so that the least-worst-violation phase still sees a violation shrink) and floored here, the
#: value of a plan that failed (1000 scales beyond a bound: a plan near a singularity, whose values are wild).
FAILED = -1.0 - math.log(1000.0)


@dataclass(frozen=True)
class BoundedSettings:
    """The ``[bounded]`` table of a scenario: what the bounded planner minimizes and how.

    Attributes
    ----------
    cost : {"deviation", "control_rate", "thrust", "duration"}
        The cost (:data:`COSTS`, module docstring).
    method : {"SLSQP", "trust-constr"}
        The optimizer.
    maxiter : int
        Its iterations at most.
    margin : float
        Share of each limit's scale kept inside the bound (0 <= margin < 0.5).
    singular_margin : float
        Share of the largest magnitude of the flat output's stage-2 condition along the nominal plan
        (:func:`planners.singularity.monitor` of the last iterate) its magnitude keeps at every node
        (0 <= singular_margin < 1; 0: no constraint).
    tol : float
        Its tolerance.
    """

    cost: str = "deviation"
    method: str = "SLSQP"
    maxiter: int = DEFAULT_MAXITER
    margin: float = DEFAULT_MARGIN
    singular_margin: float = DEFAULT_SINGULAR_MARGIN
    tol: float = DEFAULT_TOL


def bounded_settings(table: Mapping, where: str) -> BoundedSettings:
    """Parse the ``[bounded]`` table (keys :data:`BOUNDED_KEYS`).

    Parameters
    ----------
    table : mapping
        The table (types checked by the scenario schema).
    where : str
        File and table, for messages.

    Returns
    -------
    BoundedSettings

    Raises
    ------
    InputError
        An unknown key, cost or method; ``maxiter`` not a positive whole number; ``margin`` outside
        [0, 0.5), ``singular_margin`` outside [0, 1); ``tol`` not positive.
    """
    from gna.schema import unknown_key_message

    if not isinstance(table, Mapping):
        raise InputError(f"{where}: must be a table, got {table!r}")
    for key in table:
        if key not in BOUNDED_KEYS:
            raise InputError(unknown_key_message(key, BOUNDED_KEYS, where))
    cost = table.get("cost", "deviation")
    if cost not in COSTS:
        raise InputError(f"{where}: cost must be one of {', '.join(COSTS)}, got {cost!r}")
    method = table.get("method", "SLSQP")
    if method not in METHODS:
        raise InputError(f"{where}: method must be one of {', '.join(METHODS)}, got {method!r}")
    maxiter = table.get("maxiter", DEFAULT_MAXITER)
    if isinstance(maxiter, bool) or not isinstance(maxiter, int) or maxiter < 1:
        raise InputError(f"{where}: maxiter must be a whole number >= 1, got {maxiter!r}")
    margin = table.get("margin", DEFAULT_MARGIN)
    if isinstance(margin, bool) or not isinstance(margin, (int, float)) or not 0 <= margin < 0.5:
        raise InputError(f"{where}: margin must be a number in [0, 0.5) (share of each limit's scale), got {margin!r}")
    sm = table.get("singular_margin", DEFAULT_SINGULAR_MARGIN)
    if isinstance(sm, bool) or not isinstance(sm, (int, float)) or not 0 <= sm < 1:
        raise InputError(
            f"{where}: singular_margin must be a number in [0, 1) (share of the stage-2 condition kept), got {sm!r}"
        )
    tol = table.get("tol", DEFAULT_TOL)
    if isinstance(tol, bool) or not isinstance(tol, (int, float)) or not (math.isfinite(tol) and tol > 0):
        raise InputError(f"{where}: tol must be a positive number, got {tol!r}")
    return BoundedSettings(str(cost), str(method), int(maxiter), float(margin), float(sm), float(tol))


@dataclass(frozen=True)
class _Side:
    """One side of one limit, a row group of the constraints."""

    name: str
    side: str
    unit: str
    scale: float


@dataclass
class _Evaluation:
    """The plan at one parameter vector, its cost and the scaled distances of its limits."""

    x: np.ndarray
    values: dict
    member: object | None
    plan: object | None
    cost: float
    slack: np.ndarray  # (sides, points): scaled distance to each bound (negative beyond it)
    failure: str | None = None
    seconds: float = 0.0
    cond: np.ndarray | None = None  # the stage-2 condition at the nodes (last iterate)
    condition: str = ""


@dataclass
class BoundedResult:
    """The outcome of :func:`plan_bounded`.

    Attributes
    ----------
    scenario : planners.scenario.Scenario
        The member of the family at the optimum (every parameter fixed, :meth:`Scenario.at`).
    plan : planners.plan.Plan or None
        Its plan (None when no parameter vector gave a plan).
    optimum : dict
        Free parameter -> its value at the optimum.
    nominal : dict
        Free parameter -> its nominal value (the starting point).
    bounds : dict
        Free parameter -> (min, max).
    cost : float
        The cost at the optimum (unit of :attr:`cost_unit`).
    cost_kind : str
        One of :data:`COSTS`.
    cost_unit : str
    feasible : bool
        Every limit of :mod:`gna.limits` met at every point of the verdict's grid
        (:meth:`planners.plan.Plan.limit_violations` of the optimum's plan empty).
    active : list of dict
        The limits at their bound at the optimum (least scaled distance at most the margin plus
        :data:`ACTIVE_TOL`): ``name``, ``side``, ``bound``, ``value``, ``time`` (SI, rad), ``slack``.
    binding : dict or None
        Infeasible bounds: the violation left at the least worst violation (``name``, ``side``,
        ``limit``, ``worst``, ``time``, ``text``), else None.
    plans_evaluated : int
        Plans computed (each parameter vector once).
    plans_failed : int
        Of those, plans that failed (Newton, domain, trim): counted as violating every limit.
    iterations : int
        Optimizer iterations (both phases).
    success : bool
        The optimizer's verdict.
    message : str
        The optimizer's message.
    seconds : float
        Wall time [s].
    """

    scenario: object
    plan: object | None
    optimum: dict
    nominal: dict
    bounds: dict
    cost: float
    cost_kind: str
    cost_unit: str
    feasible: bool
    active: list
    binding: dict | None
    plans_evaluated: int
    plans_failed: int
    iterations: int
    success: bool
    message: str
    seconds: float = 0.0
    history: list = field(default_factory=list, repr=False)

    def infeasible_line(self) -> str | None:
        """One line naming the binding limit and the best value it reaches, or None when the bounds are met.

        Returns
        -------
        str or None
        """
        if self.feasible:
            return None
        where = ", ".join(f"{k} = {v:.6g}" for k, v in self.optimum.items())
        if self.binding is None:
            return (
                f"{self.scenario.name}: no parameter values within their bounds give a plan "
                f"({self.plans_evaluated} plans tried, all failed)"
            )
        return (
            f"{self.scenario.name}: no parameter values within their bounds meet the limits; binding limit "
            f"{self.binding['name']}: {self.binding['text']} at the best parameters ({where})"
        )

    def to_dict(self) -> dict:
        """The result as JSON-ready data (``gflat plan --json``'s ``bounded``).

        Returns
        -------
        dict
            ``optimum``, ``nominal``, ``bounds``, ``cost``, ``cost_kind``, ``cost_unit``, ``feasible``,
            ``active_limits``, ``binding``, ``plans_evaluated``, ``plans_failed``, ``iterations``, ``success``,
            ``message``, ``seconds``, ``infeasible``.
        """
        return {
            "optimum": dict(self.optimum),
            "nominal": dict(self.nominal),
            "bounds": {k: list(v) for k, v in self.bounds.items()},
            "cost": self.cost,
            "cost_kind": self.cost_kind,
            "cost_unit": self.cost_unit,
            "feasible": self.feasible,
            "active_limits": list(self.active),
            "binding": self.binding,
            "infeasible": self.infeasible_line(),
            "plans_evaluated": self.plans_evaluated,
            "plans_failed": self.plans_failed,
            "iterations": self.iterations,
            "success": self.success,
            "message": self.message,
            "seconds": self.seconds,
        }

    def text(self) -> str:
        """A few lines for ``gflat plan``: the optimum, the cost, the active limits, the plans evaluated.

        Returns
        -------
        str
        """
        rows = [
            f"  bounded plan ({self.cost_kind} cost, {self.plans_evaluated} plans evaluated, "
            f"{self.plans_failed} failed, {self.iterations} iterations, {self.seconds:.1f} s): "
            + ("within every limit" if self.feasible else "INFEASIBLE")
        ]
        for k, v in self.optimum.items():
            lo, hi = self.bounds[k]
            rows.append(f"    {k} = {v:.8g} (nominal {self.nominal[k]:.8g}, range [{lo:g}, {hi:g}])")
        rows.append(f"    cost {self.cost:.6g} {self.cost_unit}".rstrip())
        if self.active:
            for a in self.active:
                rows.append(
                    f"    active limit {a['name']} ({a['side']}): {_shown(a['value'], a['unit'])} at t = "
                    f"{a['time']:.4g} s against {_shown(a['bound'], a['unit'])}"
                )
        else:
            rows.append("    no limit active")
        line = self.infeasible_line()
        if line:
            rows.append(f"    {line}")
        return "\n".join(rows)


def _shown(v: float, unit: str) -> str:
    if unit == "rad":
        return f"{math.degrees(v):.3f} deg"
    if unit == "N":
        return f"{v:.1f} N"
    return f"{v:.5g}"


def _cost_unit(kind: str) -> str:
    return {"deviation": "", "control_rate": "1/s^2", "thrust": "N s", "duration": "s"}[kind]


def control_scales(aircraft, env) -> np.ndarray:
    """Scales of the five controls in the ``control_rate`` cost: half their ranges (thrust without one: m g).

    Parameters
    ----------
    aircraft : gna.aircraft.Aircraft
    env : gna.atmosphere.Environment
        Gravity.

    Returns
    -------
    ndarray, shape (5,)
        ``(F [N], eta [-], dl, dm, dn [rad])`` (:func:`gna.limits.control_ranges`; eta: 1).
    """
    from gna.eom import CONTROL_NAMES
    from gna.limits import control_ranges

    ranges = control_ranges(aircraft)
    out = np.ones(5)
    for i, c in enumerate(CONTROL_NAMES):
        if c in ranges:
            lo, hi = ranges[c]
            out[i] = 0.5 * (hi - lo) if c != "F" else hi - lo
    if "F" not in ranges:
        out[0] = aircraft.mass.mass * env.g
    return out


def control_rate_cost(t: np.ndarray, rates: np.ndarray, scales: np.ndarray) -> float:
    """The ``control_rate`` cost: the mean over the span of ``sum_c (du_c/dt / s_c)^2`` (trapezoidal rule).

    Parameters
    ----------
    t : ndarray, shape (N,)
        Times [s].
    rates : ndarray, shape (5, N)
        Control rates (SI per s).
    scales : ndarray, shape (5,)
        :func:`control_scales`.

    Returns
    -------
    float
        [1/s^2].
    """
    y = np.sum((rates / scales[:, None]) ** 2, axis=0)
    return float(np.trapezoid(y, t) / (t[-1] - t[0]))


def _sides(aircraft, env) -> list:
    """The bounded sides of every limit of the aircraft, each with its scale."""
    from gna.limits import aircraft_limits

    out = []
    weight = aircraft.mass.mass * env.g
    for lim in aircraft_limits(aircraft):
        for side, bound in (("lower", lim.lower), ("upper", lim.upper)):
            if bound is None and not (side == "upper" and lim.upper_of is not None):
                continue
            if lim.unit == "N":
                scale = weight
            elif lim.lower is not None and lim.upper is not None:
                scale = 0.5 * (lim.upper - lim.lower)
            else:
                scale = max(abs(bound if bound is not None else 0.0), 1.0)
            out.append(_Side(lim.name, side, lim.unit, float(scale)))
    return out


def limit_slack(aircraft, env, frame, sides=None) -> np.ndarray:
    """Scaled distance of every bounded limit side to its bound on a trajectory (negative beyond it).

    Parameters
    ----------
    aircraft : gna.aircraft.Aircraft
        Its limits (:func:`gna.limits.aircraft_limits`, the flyability verdict's).
    env : gna.atmosphere.Environment
        For the load factor.
    frame : pandas.DataFrame
        The trajectory (:meth:`planners.plan.Plan.limit_frame`).
    sides : list, optional
        The sides (default every bounded side of the aircraft's limits).

    Returns
    -------
    ndarray, shape (sides, N)
        ``(value - lower) / scale`` or ``(upper - value) / scale``.
    """
    from gna.limits import aircraft_limits

    sides = _sides(aircraft, env) if sides is None else sides
    lims = {lim.name: lim for lim in aircraft_limits(aircraft)}
    cache = {}
    rows = []
    for s in sides:
        lim = lims[s.name]
        if s.name not in cache:
            v = np.asarray(lim.value_of(frame, env), dtype=float)
            cache[s.name] = (v, *lim.bounds(frame))
        v, lo, hi = cache[s.name]
        d = (v - lo) if s.side == "lower" else (hi - v)
        rows.append(np.where(np.isfinite(d), d, -np.inf if not np.all(np.isfinite(v)) else np.inf) / s.scale)
    return np.array(rows) if rows else np.zeros((0, len(frame)))


class _Problem:
    """The optimization problem: parameters scaled to [0, 1], plans cached by parameter vector."""

    def __init__(self, scenario, J=None, max_cost=None):
        self.scenario = scenario
        self.free = scenario.free_parameters
        self.lower = np.array([p.lower for p in self.free])
        self.upper = np.array([p.upper for p in self.free])
        self.nominal = np.array([p.value for p in self.free])
        self.settings = scenario.bounded
        self.J, self.max_cost = J, max_cost
        self.aircraft, self.env = scenario.aircraft, scenario.env
        self.sides = _sides(self.aircraft, self.env)
        self.scales = control_scales(self.aircraft, self.env)
        self.cache: dict = {}
        self.evaluated = 0
        self.failed = 0
        self.history: list = []
        self.n_windows = max(1, min(WINDOWS, len(scenario.t_nodes) - 1))
        self.cost_scale = 1.0
        self.cond_ref = None

    def values(self, x) -> dict:
        p = self.lower + np.clip(np.asarray(x, dtype=float), 0.0, 1.0) * (self.upper - self.lower)
        return {q.name: float(v) for q, v in zip(self.free, p)}

    def x_of(self, values) -> np.ndarray:
        return np.array([(values[q.name] - q.lower) / (q.upper - q.lower) for q in self.free])

    def evaluate(self, x) -> _Evaluation:
        x = np.clip(np.asarray(x, dtype=float), 0.0, 1.0)
        key = np.round(x, 13).tobytes()  # the optimizer's last point is its best one to within rounding
        if key in self.cache:
            return self.cache[key]
        from .generalized import plan_scenario

        values = self.values(x)
        start = time.perf_counter()
        self.evaluated += 1
        member, plan, failure = None, None, None
        try:
            with np.errstate(all="ignore"):
                member = self.scenario.at(values)
                plan = plan_scenario(member, J=self.J, max_cost=self.max_cost, stop_on_failure=True)
            if not plan.feasible:
                failure = (plan.newton_failures + plan.domain_failures + ["not feasible"])[0]
            else:
                frame = plan.limit_frame()
                slack = limit_slack(self.aircraft, self.env, frame, self.sides)
                cost = self._cost(plan, member, values, frame)
                report = monitor(plan, j=plan.J)
                cond = np.real(np.asarray(report.table[report.condition], dtype=float))
                if not (np.all(np.isfinite(slack) | (slack == np.inf)) and math.isfinite(cost)):
                    failure = "non-finite controls or states"
                elif not np.all(np.isfinite(cond)) or len({np.sign(c) for c in cond if c != 0}) > 1:
                    failure = (
                        f"the stage-2 condition {report.condition} of the last iterate changes sign: a singularity"
                    )
        except GflatError as exc:
            failure = str(exc)
        seconds = time.perf_counter() - start
        if failure is not None:
            self.failed += 1
            ev = _Evaluation(x, values, member, plan, math.nan, np.zeros((0, 0)), failure, seconds)
        else:
            ev = _Evaluation(x, values, member, plan, cost, slack, None, seconds, cond, report.condition)
            if self.cond_ref is None:
                self.cond_ref = max(float(np.max(np.abs(cond))), 1e-300)
        self.cache[key] = ev
        self.history.append(ev)
        _log.log(
            logging.INFO if self.evaluated % 10 == 1 else logging.DEBUG,
            "bounded %s: plan %d (%s) in %.2f s: %s",
            self.scenario.name,
            self.evaluated,
            ", ".join(f"{k} = {v:.8g}" for k, v in values.items()),
            ev.seconds,
            f"failed: {failure}" if failure else f"cost {ev.cost:.6g}, least slack {float(np.min(ev.slack)):.4g}",
        )
        return ev

    def _cost(self, plan, member, values, frame) -> float:
        kind = self.settings.cost
        if kind == "deviation":
            return float(sum(((values[q.name] - q.value) / (q.upper - q.lower)) ** 2 for q in self.free))
        if kind == "duration":
            return float(member.t1 - member.t0)
        t = frame.index.to_numpy(dtype=float)
        if kind == "thrust":
            return float(np.trapezoid(frame["F"].to_numpy(dtype=float), t))
        from gna.eom import CONTROL_NAMES

        rates = np.array([plan.evaluate(c, t, derivative=1) for c in CONTROL_NAMES])
        return control_rate_cost(t, rates, self.scales)

    # the optimizer's functions -------------------------------------------------------------------
    def n_constraints(self) -> int:
        return (len(self.sides) + (self.settings.singular_margin > 0)) * self.n_windows

    def singular_slack(self, ev: _Evaluation) -> np.ndarray:
        """The stage-2 condition's least magnitude over the nominal plan's largest, per window of nodes."""
        groups = np.array_split(np.abs(ev.cond), self.n_windows)
        return np.array([float(np.min(g)) if g.size else np.inf for g in groups]) / self.cond_ref

    def constraints_of(self, ev: _Evaluation) -> np.ndarray:
        """Each side's least scaled distance to its bound in each window, less the margin (-1: no plan); then
        the singularity margin per window."""
        if ev.failure is not None:
            return np.full(self.n_constraints(), FAILED)
        n = ev.slack.shape[1]
        edges = np.linspace(0, n, self.n_windows + 1).round().astype(int)
        edges[1:] = np.maximum(edges[1:], edges[:-1] + 1)
        starts = np.minimum(edges[:-1], n - 1)
        g = np.minimum.reduceat(ev.slack, starts, axis=1).ravel()
        # A quantity held exactly at its bound (a glide's zero thrust) meets it: no margin there.
        exact = np.maximum.reduceat(np.abs(ev.slack), starts, axis=1).ravel() == 0.0
        # Far from a bound (10 scales): inactive; beyond it by more than a scale: compressed (_compressed), so that
        # one wild node (a plan near a singularity) does not swamp the optimizer's model, yet a violation that
        # shrinks is seen (the least worst violation of infeasible bounds).
        out = np.where(exact, 0.0, _compressed(g) - self.settings.margin)
        if self.settings.singular_margin > 0:
            sing = _compressed(self.singular_slack(ev)) - self.settings.singular_margin
            out = np.concatenate([out, sing])
        return out

    def constraints(self, x) -> np.ndarray:
        return self.constraints_of(self.evaluate(x))

    def objective_of(self, ev: _Evaluation) -> float:
        if self.settings.cost == "deviation":
            return self._cost(None, None, ev.values, None) / self.cost_scale
        if ev.failure is not None:
            return self._worst_cost() / self.cost_scale
        return ev.cost / self.cost_scale

    def objective(self, x) -> float:
        return self.objective_of(self.evaluate(x))

    def _worst_cost(self) -> float:
        done = [e.cost for e in self.history if e.failure is None]
        return 2.0 * max(done) if done else 1.0

    def _jacobian(self, fun, x) -> np.ndarray:
        x = np.clip(np.asarray(x, dtype=float), 0.0, 1.0)
        f0 = np.atleast_1d(fun(x))
        J = np.zeros((f0.size, x.size))
        for i in range(x.size):
            h = FD_STEP if x[i] + FD_STEP <= 1.0 else -FD_STEP
            xi = x.copy()
            xi[i] += h
            J[:, i] = (np.atleast_1d(fun(xi)) - f0) / h
        return J

    def objective_grad(self, x) -> np.ndarray:
        return self._jacobian(self.objective, x)[0]

    def constraints_jac(self, x) -> np.ndarray:
        return self._jacobian(self.constraints, x)


def _compressed(d: np.ndarray) -> np.ndarray:
    """Scaled distances to the bounds as the optimizer sees them: at most 10, below -1 ``-1 - log(-d)``, at
    least :data:`FAILED`."""
    d = np.minimum(np.asarray(d, dtype=float), 10.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        far = -1.0 - np.log(np.maximum(-d, 1.0))
    return np.maximum(np.where(d < -1.0, far, d), FAILED)


def _minimize(problem: _Problem, fun, jac, cons, cons_jac, x0, n_bounds: int, settings: BoundedSettings):
    from scipy.optimize import Bounds, NonlinearConstraint, minimize

    bounds = Bounds(np.zeros(n_bounds), np.ones(n_bounds))
    bounds.ub[problem.lower.size :] = np.inf
    bounds.lb[problem.lower.size :] = -np.inf
    if settings.method == "SLSQP":
        return minimize(
            fun,
            x0,
            jac=jac,
            method="SLSQP",
            bounds=bounds,
            constraints=[{"type": "ineq", "fun": cons, "jac": cons_jac}],
            options={"maxiter": settings.maxiter, "ftol": settings.tol},
        )
    return minimize(
        fun,
        x0,
        jac=jac,
        method="trust-constr",
        bounds=bounds,
        constraints=[NonlinearConstraint(cons, 0.0, np.inf, jac=cons_jac)],
        options={"maxiter": settings.maxiter, "gtol": settings.tol, "xtol": settings.tol},
    )


def plan_bounded(scenario, J=None, max_cost: float | None = None) -> BoundedResult:
    """Plan a scenario with free parameters: the parameters minimizing its cost within the aircraft's limits.

    Parameters
    ----------
    scenario : planners.scenario.Scenario
        With free parameters (:attr:`~planners.scenario.Scenario.free_parameters`) and its ``[bounded]``
        settings.
    J : int or "auto", optional
        Generalized-flatness iterations of every plan (default the scenario's).
    max_cost : float, optional
        Bound on each plan's cost (:func:`planners.generalized.plan_cost`).

    Returns
    -------
    BoundedResult
        The optimum, its plan and cost, the active limits, the plans evaluated; for bounds no parameter
        value can meet, ``feasible`` False and the binding limit at the least worst violation
        (:meth:`BoundedResult.infeasible_line`).

    Raises
    ------
    InputError
        A scenario without free parameters.
    """
    start = time.perf_counter()
    if not getattr(scenario, "free_parameters", ()):
        raise InputError(f"{getattr(scenario, 'name', scenario)!r}: no free parameter to plan bounded")
    pb = _Problem(scenario, J, max_cost)
    settings = scenario.bounded
    n = len(pb.free)
    x0 = pb.x_of({q.name: q.value for q in pb.free})
    ev0 = pb.evaluate(x0)
    if settings.cost != "deviation" and ev0.failure is None and ev0.cost > 0:
        pb.cost_scale = ev0.cost
    res = _minimize(pb, pb.objective, pb.objective_grad, pb.constraints, pb.constraints_jac, x0, n, settings)
    iterations = int(getattr(res, "nit", 0) or 0)
    best = _best(pb, res.x)
    message, success = str(res.message), bool(res.success)
    if best is None or _worst(pb, best) < -1e-9:
        # Phase 1: the least worst violation, minimize w subject to every constraint >= -w.
        xs = best.x if best is not None else x0
        w0 = max(0.0, -float(np.min(pb.constraints(xs)))) + 1e-3

        def fun(z):
            return z[-1]

        def jac(z):
            g = np.zeros(z.size)
            g[-1] = 1.0
            return g

        def cons(z):
            return pb.constraints(z[:-1]) + z[-1]

        def cons_jac(z):
            return np.hstack([pb.constraints_jac(z[:-1]), np.ones((pb.n_constraints(), 1))])

        r1 = _minimize(pb, fun, jac, cons, cons_jac, np.append(xs, w0), n + 1, settings)
        iterations += int(getattr(r1, "nit", 0) or 0)
        phase1 = pb.evaluate(r1.x[:-1])
        if phase1.failure is None and (best is None or _worst(pb, phase1) > _worst(pb, best)):
            best = phase1
        if best is not None and _worst(pb, best) >= 0:  # phase 1 found a point within the limits
            res = _minimize(
                pb, pb.objective, pb.objective_grad, pb.constraints, pb.constraints_jac, best.x, n, settings
            )
            iterations += int(getattr(res, "nit", 0) or 0)
            message, success = str(res.message), bool(res.success)
            best = _best(pb, res.x) or best
    return _result(pb, best, iterations, success, message, time.perf_counter() - start)


def _worst(pb: _Problem, ev: _Evaluation) -> float:
    """The least scaled distance to a bound, margin included (negative: violated)."""
    return float(np.min(pb.constraints_of(ev)))


def _best(pb: _Problem, x) -> _Evaluation | None:
    """The optimizer's point when it gave a plan, else the best of the evaluations (within the limits first)."""
    ev = pb.evaluate(x)
    if ev.failure is None:
        return ev
    ok = [e for e in pb.history if e.failure is None]
    if not ok:
        return None
    inside = [e for e in ok if _worst(pb, e) >= 0]
    if inside:
        return min(inside, key=pb.objective_of)
    return max(ok, key=lambda e: _worst(pb, e))


def _result(pb: _Problem, best, iterations: int, success: bool, message: str, seconds: float) -> BoundedResult:
    sc = pb.scenario
    nominal = {q.name: q.value for q in pb.free}
    bounds = {q.name: (q.lower, q.upper) for q in pb.free}
    kind = sc.bounded.cost
    if best is None:
        return BoundedResult(
            sc, None, nominal, nominal, bounds, math.nan, kind, _cost_unit(kind), False, [], None,
            pb.evaluated, pb.failed, iterations, success, message, seconds, pb.history,
        )  # fmt: skip
    plan, member = best.plan, best.member
    violations = plan.limit_violations()
    frame = plan.limit_frame()
    t = frame.index.to_numpy(dtype=float)
    active = []
    from gna.limits import aircraft_limits

    lims = {lim.name: lim for lim in aircraft_limits(pb.aircraft)}
    for s, row in zip(pb.sides, best.slack):
        i = int(np.argmin(row))
        if row[i] <= sc.bounded.margin + ACTIVE_TOL:
            v = np.asarray(lims[s.name].value_of(frame, pb.env), dtype=float)
            lo, hi = lims[s.name].bounds(frame)
            active.append(
                {
                    "name": s.name,
                    "side": s.side,
                    "unit": s.unit,
                    "bound": float((lo if s.side == "lower" else hi)[i]),
                    "value": float(v[i]),
                    "time": float(t[i]),
                    "slack": float(row[i]),
                }
            )
    if sc.bounded.singular_margin > 0 and best.cond is not None:
        rel = np.abs(best.cond) / pb.cond_ref
        i = int(np.argmin(rel))
        if rel[i] <= sc.bounded.singular_margin + ACTIVE_TOL:
            active.append(
                {
                    "name": best.condition,
                    "side": "singularity",
                    "unit": "-",
                    "bound": float(sc.bounded.singular_margin * pb.cond_ref * np.sign(best.cond[i])),
                    "value": float(best.cond[i]),
                    "time": float(plan.t_nodes[i]),
                    "slack": float(rel[i] - sc.bounded.singular_margin),
                }
            )
    binding = None
    if violations:
        scale = {(s.name, s.side): s.scale for s in pb.sides}
        worst = max(violations, key=lambda v: abs(v.worst - v.limit) / scale.get((v.name, v.side), 1.0))
        binding = {**worst.to_dict(), "text": worst.text()}
    return BoundedResult(
        scenario=member,
        plan=plan,
        optimum=dict(best.values),
        nominal=nominal,
        bounds=bounds,
        cost=float(best.cost),
        cost_kind=kind,
        cost_unit=_cost_unit(kind),
        feasible=not violations,
        active=active,
        binding=binding,
        plans_evaluated=pb.evaluated,
        plans_failed=pb.failed,
        iterations=iterations,
        success=success,
        message=message,
        seconds=seconds,
        history=pb.history,
    )
