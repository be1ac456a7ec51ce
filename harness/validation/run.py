"""Running a validation case: plan once, fly every engine, tabulate; the result object.

:func:`run_case` plans the scenario once (or reuses a given plan), flies the
plan's controls on every engine (:func:`harness.engines.fly`) from the planned
initial state and returns a :class:`CaseResult`.  :func:`compare_engines` is
the same comparison for any control source, without a scenario.  Nothing here
writes files or prints.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from gna.errors import InputError
from planners.generalized import plan_scenario
from planners.scenario import load_scenario, with_tracking_design

from ..engines import fly
from ..metrics import DifferenceTable, difference_table, engine_tables, window_span
from ..progress import stage
from .case import ValidationCase
from .flights import case_flights, finish_case
from .provenance import provenance  # noqa: F401  (re-exported by the package)
from .result import CaseResult, _runs_report
from .tolerances import CompareSettings, resolve_compare


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


def compare_engines(
    aircraft,
    controls,
    t_span=None,
    x0=None,
    *,
    engines=("inhouse", "jsbsim"),
    env=None,
    controller=None,
    dt_out: float = 0.02,
    tolerances=None,
    windows: Mapping[str, float | None] | None = None,
) -> EngineComparison:
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
        Its ``scenario``, ``J`` and ``tracking`` (the design, over the scenario's) are used.
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
    sc = with_tracking_design(load_scenario(case.scenario, J=case.J), case.tracking)
    t0 = time.perf_counter()
    plan = plan_scenario(sc, max_cost=max_cost)
    return PlannedCase(scenario=sc, plan=plan, planning_time_s=time.perf_counter() - t0)


def case_settings(case: ValidationCase, scenario) -> CompareSettings:
    """The comparison settings of a case: the case's (command line) > the scenario's ``[compare]`` > defaults.

    Parameters
    ----------
    case : ValidationCase
        Its tolerances, windows, dt_out, jsbsim_dt and self_convergence (None: unset).
    scenario : planners.scenario.Scenario
        Its ``compare`` table (raw ``[compare]`` of the file).

    Returns
    -------
    CompareSettings

    Raises
    ------
    InputError
        An unknown key (with a suggestion) or a bad value in either source; engine ``jsbsim-source`` for an
        aircraft fitted from no JSBSim aircraft (before any plan is made: a bounded plan takes seconds).
    """
    where = f"{scenario.path or scenario.name} [compare]"
    settings = resolve_compare(getattr(scenario, "compare", None) or {}, case.overrides, where=where)
    if "jsbsim-source" in case.engines and getattr(scenario, "aircraft", None) is not None:
        from ..engines.jsbsim.source import source_model

        source_model(scenario.aircraft)
    return settings


def with_step(engine, dt: float):
    """A JSBSim engine with its step set to ``dt``; any other engine unchanged.

    Parameters
    ----------
    engine : Engine
        An engine object.
    dt : float
        JSBSim step [s].

    Returns
    -------
    Engine
    """
    if dataclasses.is_dataclass(engine) and hasattr(engine, "dt") and str(engine.name).startswith("jsbsim"):
        return dataclasses.replace(engine, dt=dt)
    return engine


def _self_convergence(engines, runs, problem, span, settings: CompareSettings):
    """Every JSBSim engine again at half its step, and the tables of that run against the run at the step."""
    half, tables = {}, {}
    for label, e in engines.items():
        if not (dataclasses.is_dataclass(e) and hasattr(e, "dt") and str(e.name).startswith("jsbsim")):
            continue
        half[label] = fly({label: with_step(e, e.dt / 2)}, *problem[0], **problem[1])[label]
        tables[label] = {
            name: difference_table(
                runs[label],
                half[label],
                tolerances={},
                window=window_span(span, dur),
                labels=(f"{label} dt", f"{label} dt/2"),
            )
            for name, dur in settings.windows.items()
        }
    return half, tables


def run_case(case: ValidationCase, *, plan=None, scenario=None, open_loop=None, progress=None) -> CaseResult:
    """Plan a case's scenario (once), fly it on every engine and tabulate the differences.

    Parameters
    ----------
    case : ValidationCase
        What to plan, fly and compare.
    plan : planners.plan.Plan, optional
        A plan of the case's scenario, reused instead of planning again (its J
        must match the case's when the case sets one).
    scenario : planners.scenario.Scenario, optional
        The loaded scenario (its ``[compare]`` table sets the comparison,
        :func:`case_settings`; its ``[tracking]`` settings serve the closed
        loop); loaded from ``case.scenario`` when not given.
    open_loop : gna.trajectory.SimulationResult, optional
        Closed loop: the open-loop case's run on the reference engine, reused
        as the open-loop curve instead of flying it again when it is the same
        flight (:func:`harness.validation.flights.case_flights`).
    progress : harness.progress.Progress, optional
        The plan, each flight and the tables are stages.

    Returns
    -------
    CaseResult
        Runs on the grid ``t0, t0 + dt_out, ...`` of the plan's span, tables of
        every engine against the first per window and against the plan.  Closed
        loop (``case.loop == "closed"``): every engine flies the feedforward of
        the scenario's iterate plus the tracking feedback
        (:func:`harness.validation.closed.closed_loop_setup`), and the reference
        engine also flies the plan open loop (``CaseResult.open_loop``).
        With ``self_convergence``, every JSBSim engine flies again at half its
        step (``CaseResult.half_step``, ``CaseResult.self_convergence``).
        The flights are those of :func:`harness.validation.flights.case_flights`,
        flown in sequence, and tabulated by :func:`harness.validation.flights.finish_case`.

    Raises
    ------
    InputError
        Not a case, unknown scenario, a plan or scenario of the wrong type, or a plan whose J differs
        from the case's.
    DomainError
        The plan is not feasible (Newton failed, or it leaves the physical domain): there is nothing to fly.
    """
    what = getattr(scenario, "name", None) or getattr(case, "scenario", case)  # not a case: refused below
    with stage(progress, f"planning {what}" if plan is None else f"setting {what} up"):
        flights = case_flights(case, plan=plan, scenario=scenario, open_loop=open_loop)
    what = flights.scenario.name
    runs = {}
    for name, fly_it in flights.flights.items():
        with stage(progress, f"flying {what} ({case.loop} loop, {name})"):
            runs[name] = fly_it()
    with stage(progress, f"comparing the engines of {what}"):
        return finish_case(flights, runs)
