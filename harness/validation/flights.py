"""A validation case split into independent flights and the tabulation of their runs.

:func:`case_flights` sets a case up (settings, engines, closed-loop
controller) and returns its flights as zero-argument callables that depend on
nothing but the set-up, so that a caller may fly them in any order or in other
processes (the ``gflat paper`` command does); :func:`finish_case` turns their
runs into the :class:`harness.validation.CaseResult`.
:func:`harness.validation.run_case` is the two in sequence.  Nothing here
writes files or prints.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from gna.errors import DomainError, InputError
from planners.generalized import plan_scenario
from planners.plan import Plan
from planners.scenario import Scenario, load_scenario, with_tracking_design

from ..engines import fly, get_engine
from ..metrics import difference_table, engine_tables
from .case import ValidationCase
from .closed import ClosedLoopSetup, closed_loop_setup, sampled_engines
from .provenance import provenance
from .result import CaseResult
from .tolerances import CompareSettings

#: Name of the reference engine's open-loop flight of a closed-loop case (the paper's cyan curve).
OPEN_LOOP = "open loop"
#: Name of the reference engine's closed-loop flight with the flat plan's feedforward (the dark-blue curve).
FLAT_LOOP = "flat closed loop"


@dataclass
class CaseFlights:
    """A case set up for flying: its settings, engines, closed loop and flights.

    Attributes
    ----------
    case : ValidationCase
    plan : planners.plan.Plan
        A feasible plan of the case's scenario.
    scenario : planners.scenario.Scenario
    settings : CompareSettings
        The comparison settings (:func:`harness.validation.case_settings`).
    engines : dict
        Engine label -> engine, the reference first.
    problem : tuple
        ``(args, kwargs)`` of :func:`harness.engines.fly` flown by every engine.
    flights : dict
        Flight name -> zero-argument callable returning a
        :class:`gna.trajectory.SimulationResult`: every engine label, and in
        closed loop :data:`OPEN_LOOP` (unless a run was reused) and
        :data:`FLAT_LOOP` (when the feedforward iterate is not 0).  The
        callables share no mutable state: any order, or another process, gives
        the same runs.
    planning_time_s : float or None
        Wall time of the planning [s] when the plan was made here.
    closed_loop : ClosedLoopSetup or None
        Closed loop: the tracking controller, aircraft and initial state flown.
    reused : dict
        Flight name -> run given by the caller instead of flying it.
    """

    case: ValidationCase
    plan: Any
    scenario: Any
    settings: CompareSettings
    engines: dict
    problem: tuple
    flights: dict
    planning_time_s: float | None = None
    closed_loop: ClosedLoopSetup | None = None
    reused: dict = field(default_factory=dict)


def _fly_one(label: str, engine, problem: tuple) -> Callable[[], Any]:
    args, kwargs = problem
    return lambda: fly({label: engine}, *args, **kwargs)[label]


def _same_open_loop(run, plan, setup: ClosedLoopSetup, ref: str, dt_out: float) -> bool:
    """True when ``run`` is the reference engine's open-loop flight the closed-loop case would make."""
    if run is None or setup.perturbation is not None or setup.feedforward_iterate != plan.J:
        return False
    if getattr(run.settings, "engine", None) != ref or not np.array_equal(setup.x0, plan.initial_state(plan.J)):
        return False
    t = np.asarray(run.df.index, dtype=float)
    return (
        run.status != "completed"
        or t.size == 0
        or (abs(t[0] - plan.t0) < 1e-9 and (t.size < 2 or abs(t[1] - t[0] - dt_out) < 1e-9))
    )


def reusable_open_loop(flights: CaseFlights, run) -> bool:
    """Whether a run is the open-loop flight of a closed-loop case (so that it need not be flown again).

    Parameters
    ----------
    flights : CaseFlights
        A closed-loop case set up by :func:`case_flights`.
    run : gna.trajectory.SimulationResult
        A run of the reference engine, e.g. the open-loop case's.

    Returns
    -------
    bool
        True when the closed loop flies the nominal aircraft from the plan's
        last iterate's initial state, so that its open-loop curve is the plan's
        last controls flown from there: the same flight as ``run`` if ``run``
        was made by the reference engine on the case's output grid.
    """
    setup = flights.closed_loop
    if setup is None:
        return False
    return _same_open_loop(run, flights.plan, setup, flights.case.engines[0], flights.settings.dt_out)


def case_flights(case: ValidationCase, *, plan=None, scenario=None, open_loop=None) -> CaseFlights:
    """Set a case up: settings, engines, closed-loop controller, and its flights (not flown).

    Parameters
    ----------
    case : ValidationCase
        What to plan, fly and compare.
    plan : planners.plan.Plan, optional
        A plan of the case's scenario (its J must match the case's when the
        case sets one); planned here when not given.
    scenario : planners.scenario.Scenario, optional
        The loaded scenario; loaded from ``case.scenario`` when not given.
    open_loop : gna.trajectory.SimulationResult, optional
        Closed loop: the reference engine's open-loop run of the plan's last
        iterate from its initial state on the case's output grid (the
        open-loop case's run), reused as the paper's cyan curve instead of
        flying it again when the closed loop flies the nominal aircraft from
        that state; otherwise ignored.

    Returns
    -------
    CaseFlights

    Raises
    ------
    InputError
        Not a case, unknown scenario, a plan or scenario of the wrong type, or a plan whose J differs
        from the case's.
    DomainError
        The plan is not feasible (Newton failed, or it leaves the physical domain): there is nothing to fly.
    """
    from .run import case_settings, with_step

    if not isinstance(case, ValidationCase):
        raise InputError(f"run_case needs a ValidationCase, got {type(case).__name__}")
    if plan is not None and not isinstance(plan, Plan):
        raise InputError(
            f"plan must be a planners.plan.Plan, got {type(plan).__name__} {plan!r:.60}; "
            f"planners.generalized.plan_scenario(scenario) makes one"
        )
    if scenario is not None and not isinstance(scenario, Scenario):
        raise InputError(
            f"scenario must be a planners.scenario.Scenario, got {type(scenario).__name__} "
            f"{scenario!r:.60}; planners.scenario.load_scenario(name) makes one"
        )
    planning_time = None
    if scenario is None:
        scenario = load_scenario(case.scenario, J=case.J)
    scenario = with_tracking_design(scenario, case.tracking)  # --tracking over [tracking] design
    settings = case_settings(case, scenario)  # a bad [compare] table is refused before planning
    if plan is None:
        t_start = time.perf_counter()
        plan = plan_scenario(scenario)
        planning_time = time.perf_counter() - t_start
    elif isinstance(case.J, int) and plan.J != case.J:
        raise InputError(f"the plan given has J = {plan.J}, the case asks for J = {case.J}")
    if not plan.feasible:
        singular = plan.singularities.failures if plan.singularities is not None else []  # the cause first
        why = (singular or plan.newton_failures or plan.domain_failures[-1:] or ["not feasible"])[0]
        raise DomainError(f"{plan.name}: the plan is not feasible, nothing to fly: {why}")
    J = plan.J
    span = (plan.t0, plan.t1)
    dt_out = settings.dt_out
    engines = {n: with_step(get_engine(n), settings.jsbsim_dt) for n in case.engines}
    setup, reused = None, {}
    if case.loop == "closed":
        setup = closed_loop_setup(plan, scenario)
        ctl = setup.controller
        engines = sampled_engines(engines, scenario.tracking.controller_dt)
        problem = ((setup.aircraft, setup.x0, ctl.controls, span), dict(env=plan.env, controller=ctl, dt_out=dt_out))
        flights = {label: _fly_one(label, e, problem) for label, e in engines.items()}
        ref = case.engines[0]
        if _same_open_loop(open_loop, plan, setup, ref, dt_out):
            reused[OPEN_LOOP] = open_loop
        else:
            flights[OPEN_LOOP] = _fly_one(
                ref,
                engines[ref],
                ((setup.aircraft, setup.x0, plan.control_function(J), span), dict(env=plan.env, dt_out=dt_out)),
            )
        if setup.feedforward_iterate != 0:  # the paper's dark-blue run: the flat plan's feedforward
            flat = closed_loop_setup(plan, scenario, feedforward_iterate=0)
            flights[FLAT_LOOP] = _fly_one(
                ref,
                engines[ref],
                (
                    (flat.aircraft, flat.x0, flat.controller.controls, span),
                    dict(env=plan.env, controller=flat.controller, dt_out=dt_out),
                ),
            )
    else:
        problem = (
            (plan.aircraft, plan.initial_state(J), plan.control_function(J), span),
            dict(env=plan.env, dt_out=dt_out),
        )
        flights = {label: _fly_one(label, e, problem) for label, e in engines.items()}
    return CaseFlights(
        case=case,
        plan=plan,
        scenario=scenario,
        settings=settings,
        engines=engines,
        problem=problem,
        flights=flights,
        planning_time_s=planning_time,
        closed_loop=setup,
        reused=reused,
    )


def finish_case(flights: CaseFlights, runs: Mapping[str, Any]) -> CaseResult:
    """Tabulate a case's runs: every engine against the first per window, and against the plan.

    Parameters
    ----------
    flights : CaseFlights
        The case as set up by :func:`case_flights`.
    runs : mapping
        Flight name -> its :class:`gna.trajectory.SimulationResult` (every
        name of ``flights.flights``).

    Returns
    -------
    CaseResult
        As :func:`harness.validation.run_case`.  With ``self_convergence``,
        every JSBSim engine flies again here at half its step.

    Raises
    ------
    InputError
        A flight of the case has no run.
    """
    from .run import _self_convergence

    missing = [name for name in flights.flights if name not in runs]
    if missing:
        raise InputError(f"{flights.case.scenario}: no run for the flight(s) {', '.join(missing)}")
    plan, settings, case = flights.plan, flights.settings, flights.case
    every = {**runs, **flights.reused}
    main = {label: every[label] for label in flights.engines}
    span = (plan.t0, plan.t1)
    dt_out = settings.dt_out
    tables = engine_tables(main, span, settings.tolerances, settings.windows, rtol=settings.rtol or None)
    half, self_conv = (
        _self_convergence(flights.engines, main, flights.problem, span, settings)
        if settings.self_convergence
        else ({}, {})
    )
    grid = np.arange(plan.t0, plan.t1 + 0.5 * dt_out, dt_out)
    plan_df = plan.to_dataframe(grid[grid <= plan.t1 + 1e-9], j=plan.J)
    # no tolerances: the open-loop drift from the plan is information, not a pass/fail criterion
    vs_plan = {
        label: difference_table(plan_df, res.df, tolerances={}, labels=("plan", label)) for label, res in main.items()
    }
    open_loop = flat_loop = None
    if flights.closed_loop is not None:
        ref = case.engines[0]
        open_loop = every[OPEN_LOOP]
        flat_loop = every.get(FLAT_LOOP, main[ref])
    return CaseResult(
        case=case,
        plan=plan,
        runs=main,
        tables=tables,
        vs_plan=vs_plan,
        provenance=provenance(),
        planning_time_s=flights.planning_time_s,
        closed_loop=flights.closed_loop,
        open_loop=open_loop,
        settings=settings,
        half_step=half,
        self_convergence=self_conv,
        scenario=flights.scenario,
        flat_closed_loop=flat_loop,
    )
