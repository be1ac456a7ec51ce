"""Running a validation case: plan once, fly every engine, tabulate; the result object.

:func:`run_case` plans the scenario once (or reuses a given plan), flies the
plan's controls on every engine (:func:`harness.engines.fly`) from the planned
initial state and returns a :class:`CaseResult`.  :func:`compare_engines` is
the same comparison for any control source, without a scenario.  Nothing here
writes files or prints.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any, Mapping

import numpy as np

from gna.errors import DomainError, InputError
from planners.generalized import plan_scenario
from planners.scenario import load_scenario

from ..engines import fly, get_engine
from ..metrics import DifferenceTable, difference_table, engine_tables, max_position_error
from .case import ValidationCase
from .provenance import provenance
from .closed import ClosedLoopSetup, closed_loop_setup, saturated_seconds


# --------------------------------------------------------------------------- results

def _runs_report(runs: Mapping, tables: Mapping) -> str:
    """Status and settings of every run, then every difference table."""
    out = []
    for label, res in runs.items():
        s = res.settings
        extra = (f"dt = {s['dt']:.6g} s, integrators {s['integrators']}"
                 + (f", earth {s['earth']}" if s.get("earth") else "")
                 if s.get("dt") is not None else
                 f"{s.get('method')} rtol = {s.get('rtol')}, atol = {s.get('atol')}")
        out.append(f"{label}: {res.status}{(' - ' + res.message) if res.message else ''}; {extra}")
        out += [f"  warning: {w}" for w in res.warnings]
    for per in tables.values():
        for name, t in per.items():
            out.append(f"[{name}]")
            out.append(t.format())
    return "\n".join(out)


@dataclass
class EngineComparison:
    """Result of :func:`compare_engines`.

    Attributes
    ----------
    results : dict
        Engine label -> SimulationResult.
    tables : dict
        Engine label (every engine but the reference) -> {window name -> DifferenceTable}.
    reference_engine : str
        Label of the engine the others are compared with (the first).
    """

    results: dict
    tables: dict
    reference_engine: str

    @property
    def passed(self) -> bool:
        """True when every table passes."""
        return all(t.passed for per in self.tables.values() for t in per.values())

    def table(self, window: str = "whole span", engine: str | None = None) -> DifferenceTable:
        """One difference table.

        Parameters
        ----------
        window : str
            Window name (a key of the ``windows`` compared).
        engine : str, optional
            Compared engine; default the only one.

        Returns
        -------
        DifferenceTable

        Raises
        ------
        InputError
            No engine named while several were compared.
        """
        if engine is None:
            if len(self.tables) != 1:
                raise InputError(f"several engines compared ({', '.join(self.tables)}): name one")
            engine = next(iter(self.tables))
        return self.tables[engine][window]

    def report(self) -> str:
        """All tables, with the run status and settings of each engine.

        Returns
        -------
        str
        """
        return _runs_report(self.results, self.tables)


def compare_engines(aircraft, controls, t_span=None, x0=None, *, engines=("inhouse", "jsbsim"), env=None,
                    controller=None, dt_out: float = 0.02, tolerances=None,
                    windows: Mapping[str, float | None] | None = None) -> EngineComparison:
    """Fly one problem on several engines and compare each with the first.

    Parameters
    ----------
    aircraft : gna.aircraft.Aircraft
        The aircraft flown by every engine.
    controls : control source
        Callable ``t -> 5 controls`` (F [N], eta [-], dl, dm, dn [rad]), a plan
        exposing ``controls(t)``, ``initial_state``, ``env``, ``t0`` and ``t1``
        (:class:`planners.plan.Plan`), or 5 constants.
    t_span : (t0, t1) or None
        Span flown [s]; default the plan's ``(t0, t1)``.
    x0 : array of shape (12,), optional
        Initial wind-frame state (SI, radians); default the control source's
        ``initial_state``.
    engines : iterable or mapping
        See :func:`harness.engines.fly`; the first is the reference.
    env : Environment, optional
        Default the control source's (a plan's), else ISA.
    controller : Controller, optional
        Feedback added to the controls (:mod:`gna.controller`).
    dt_out : float
        Output grid step [s], the same for every engine.
    tolerances : None, float or mapping
        See :func:`harness.metrics.difference_table` (default
        :data:`harness.metrics.DEFAULT_TOLERANCES`).
    windows : mapping name -> duration [s] or None, optional
        Default :data:`harness.metrics.DEFAULT_WINDOWS` (first 10 s, whole span).

    Returns
    -------
    EngineComparison
        Runs (label -> SimulationResult) and tables of each engine against the first.

    Raises
    ------
    InputError
        No time span, fewer than two engines, or bad inputs of the engines.
    """
    if t_span is None:
        t_span = (getattr(controls, "t0", None), getattr(controls, "t1", None))
        if None in t_span:
            raise InputError("no time span: pass t_span or a plan with t0 and t1")
    results = fly(engines, aircraft, x0, controls, t_span, env=env, controller=controller, dt_out=dt_out)
    if len(results) < 2:
        raise InputError("compare_engines needs at least two engines")
    tables = engine_tables(results, t_span, tolerances, windows)
    return EngineComparison(results=results, tables=tables, reference_engine=next(iter(results)))


@dataclass
class PlannedCase:
    """A case's scenario and its plan (:func:`plan_case`).

    Attributes
    ----------
    scenario : planners.scenario.Scenario
    plan : planners.plan.Plan
    planning_time_s : float
        Wall time of the planning [s].
    """

    scenario: Any
    plan: Any
    planning_time_s: float


def plan_case(case: ValidationCase, max_cost: float | None = None) -> PlannedCase:
    """Load a case's scenario and plan it (flatness, then J generalized-flatness iterations).

    Parameters
    ----------
    case : ValidationCase
        Its ``scenario`` and ``J`` are used.
    max_cost : float, optional
        Bound on the plan's cost (:func:`planners.generalized.plan_cost`; default its ``MAX_PLAN_COST``).

    Returns
    -------
    PlannedCase
        The loaded scenario, its plan and the planning wall time.

    Raises
    ------
    InputError
        Unknown or malformed scenario.
    """
    sc = load_scenario(case.scenario, J=case.J)
    t0 = time.perf_counter()
    plan = plan_scenario(sc, max_cost=max_cost)
    return PlannedCase(scenario=sc, plan=plan, planning_time_s=time.perf_counter() - t0)


@dataclass
class CaseResult:
    """Outcome of :func:`run_case`.

    Attributes
    ----------
    case : ValidationCase
    plan : planners.plan.Plan
    runs : dict
        Engine name -> SimulationResult, the reference first.
    tables : dict
        Engine name (every engine but the reference) -> {window name -> DifferenceTable}.
    vs_plan : dict
        Engine name -> DifferenceTable against the plan's J-th iterate over the
        whole span (informative: no tolerances).
    provenance : dict
        See :func:`provenance`.
    planning_time_s : float or None
        Wall time of the planning [s]; None when the plan was given.
    closed_loop : ClosedLoopSetup or None
        Closed loop: the tracking controller, the aircraft and initial state flown.
    open_loop : SimulationResult or None
        Closed loop: the reference engine flying the plan's J-th controls open
        loop (the paper's cyan curve), for the figures.
    """

    case: ValidationCase
    plan: Any
    runs: dict
    tables: dict
    vs_plan: dict
    provenance: dict = field(default_factory=dict)
    planning_time_s: float | None = None
    closed_loop: ClosedLoopSetup | None = None
    open_loop: Any = None

    @property
    def reference_engine(self) -> str:
        """Name of the engine the others are compared with."""
        return next(iter(self.runs))

    @property
    def passed(self) -> bool:
        """True when every engine-against-reference table passes (the tables against the plan inform)."""
        return all(t.passed for per in self.tables.values() for t in per.values())

    def max_position_error_m(self, window: tuple[float | None, float | None] | None = None) -> dict:
        """Per engine, the largest distance between its position and the planned flat outputs.

        Parameters
        ----------
        window : (t_lo, t_hi), optional
            Time window [s] (``None`` ends: the run's span).

        Returns
        -------
        dict
            Engine name -> max ``|(x, y, z) - (x, y, z)_plan|`` [m] (NaN for a run holding NaN);
            see :func:`harness.metrics.max_position_error`.
        """
        J = self.plan.J
        return {label: max_position_error(res, lambda t: self.plan.state(t, J), window)
                for label, res in self.runs.items()}

    def saturated_s(self) -> dict:
        """Per engine, the seconds a control was commanded beyond its limits (closed loop).

        Returns
        -------
        dict
            Engine name -> ``{"F": s, ..., "any": s}``; empty open loop.
        """
        if self.closed_loop is None:
            return {}
        return {label: saturated_seconds(self.closed_loop.controller, res) for label, res in self.runs.items()}

    def verdict(self) -> dict:
        """The machine-readable verdict of ``gflat compare --json``.

        Returns
        -------
        dict
            ``scenario``, ``loop``, ``runs`` (engine -> ``status``,
            ``max_position_error_m`` (max over the span of ``|(x, y, z) - flat
            outputs|``), ``max_position_error_after_5s_m``, ``saturated_s``),
            ``differences`` (each engine but the reference -> ``max_position_m``,
            ``max_angle_rad`` over the whole span), ``pass`` (every run
            completed and every engine agrees with the reference within the
            tolerances).
        """
        t0 = self.plan.t0
        whole = self.max_position_error_m()
        after = self.max_position_error_m((t0 + 5.0, None))
        sat = self.saturated_s()
        runs = {label: {"status": res.status, "max_position_error_m": whole[label],
                        "max_position_error_after_5s_m": after[label],
                        "saturated_s": sat[label]["any"] if label in sat else 0.0}
                for label, res in self.runs.items()}
        diffs = {}
        for label, per in self.tables.items():
            tab = per.get("whole span") or next(iter(per.values()))
            diffs[label] = {"max_position_m": tab.row("position").max_abs,
                            "max_angle_rad": max(tab.row(v).max_abs for v in ("gamma", "chi", "alpha", "beta", "mu"))}
        ok = self.passed and all(r.status == "completed" for r in self.runs.values())
        return {"scenario": self.plan.name, "loop": self.case.loop, "runs": runs, "differences": diffs, "pass": ok}

    def reference_frame(self):
        """The plan's J-th iterate at the reference engine's output times.

        Returns
        -------
        pandas.DataFrame
            States and controls indexed by ``t`` [s].
        """
        times = np.asarray(self.runs[self.reference_engine].df.index, dtype=float)
        return self.plan.to_dataframe(times, j=self.plan.J)

    def summary(self, figures=()) -> dict:
        """The machine-readable summary (the content of ``summary.json``).

        Parameters
        ----------
        figures : sequence of path
            Figures written from this result, if any.

        Returns
        -------
        dict
            ``scenario``, ``J``, ``engines``, ``passed``, ``status`` (engine -> run
            status), ``tables`` (engine -> window -> list of row records),
            ``figures`` (paths as str).
        """
        return {"scenario": self.plan.name, "J": self.plan.J, "engines": list(self.runs), "passed": self.passed,
                "status": {k: r.status for k, r in self.runs.items()},
                "tables": {eng: {w: t.to_frame().reset_index().to_dict(orient="records") for w, t in per.items()}
                           for eng, per in self.tables.items()},
                "figures": [str(p) for p in figures]}

    def report_text(self) -> str:
        """The difference report (``differences.txt``).

        Returns
        -------
        str
            Heading, run status and settings, tables against the reference
            engine per window, tables against the plan.
        """
        p = self.plan
        lines = [f"{p.name}: {p.aircraft.id}, J = {p.J}, t = {p.t0:g} .. {p.t1:g} s, {self.case.loop} loop",
                 _runs_report(self.runs, self.tables)]
        for label, tab in self.vs_plan.items():
            lines.append(f"[{label} against the plan, whole span]")
            lines.append(tab.format())
        return "\n".join(lines)


def run_case(case: ValidationCase, *, plan=None, scenario=None) -> CaseResult:
    """Plan a case's scenario (once), fly it on every engine and tabulate the differences.

    Parameters
    ----------
    case : ValidationCase
        What to plan, fly and compare.
    plan : planners.plan.Plan, optional
        A plan of the case's scenario, reused instead of planning again (its J
        must match the case's when the case sets one).
    scenario : planners.scenario.Scenario, optional
        The loaded scenario (its ``[tracking]`` settings serve the closed loop);
        loaded again from ``case.scenario`` when needed and not given.

    Returns
    -------
    CaseResult
        Runs on the grid ``t0, t0 + dt_out, ...`` of the plan's span, tables of
        every engine against the first per window and against the plan.  Closed
        loop (``case.loop == "closed"``): every engine flies the feedforward of
        the scenario's iterate plus the tracking feedback
        (:func:`harness.validation.closed.closed_loop_setup`), and the reference
        engine also flies the plan open loop (``CaseResult.open_loop``).

    Raises
    ------
    InputError
        Not a case, unknown scenario, or a plan whose J differs from the case's.
    DomainError
        The plan is not feasible (Newton failed): there is nothing to fly.
    """
    if not isinstance(case, ValidationCase):
        raise InputError(f"run_case needs a ValidationCase, got {type(case).__name__}")
    planning_time = None
    if plan is None:
        planned = plan_case(case)
        plan, planning_time, scenario = planned.plan, planned.planning_time_s, planned.scenario
    elif case.J is not None and plan.J != case.J:
        raise InputError(f"the plan given has J = {plan.J}, the case asks for J = {case.J}")
    if not plan.feasible:
        raise DomainError(f"{plan.name}: the plan is not feasible, nothing to fly: {plan.newton_failures[0]}")
    J = plan.J
    span = (plan.t0, plan.t1)
    engines = {n: get_engine(n) for n in case.engines}
    setup, open_loop = None, None
    if case.loop == "closed":
        if scenario is None:
            scenario = load_scenario(case.scenario, J=case.J)
        setup = closed_loop_setup(plan, scenario)
        ctl = setup.controller
        runs = fly(engines, setup.aircraft, setup.x0, ctl.controls, span, env=plan.env, controller=ctl,
                   dt_out=case.dt_out)
        ref = case.engines[0]
        open_loop = fly({ref: engines[ref]}, setup.aircraft, setup.x0, plan.control_function(J), span,
                        env=plan.env, dt_out=case.dt_out)[ref]
    else:
        runs = fly(engines, plan.aircraft, plan.initial_state(J), plan.control_function(J), span, env=plan.env,
                   dt_out=case.dt_out)
    tables = engine_tables(runs, span, case.tolerance_spec, case.window_spec)
    grid = np.arange(plan.t0, plan.t1 + 0.5 * case.dt_out, case.dt_out)
    plan_df = plan.to_dataframe(grid[grid <= plan.t1 + 1e-9], j=J)
    # no tolerances: the open-loop drift from the plan is information, not a pass/fail criterion
    vs_plan = {label: difference_table(plan_df, res.df, tolerances={}, labels=("plan", label))
               for label, res in runs.items()}
    return CaseResult(case=case, plan=plan, runs=runs, tables=tables, vs_plan=vs_plan, provenance=provenance(),
                      planning_time_s=planning_time, closed_loop=setup, open_loop=open_loop)
