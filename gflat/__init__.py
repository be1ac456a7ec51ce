"""gflat: flatness-based motion planning of aircraft (GNA aerodynamics), validated across dynamics engines.

The public API; each name is imported on first use (PEP 562), so ``import gflat`` is cheap.  The work is
done by the packages behind it: :mod:`gna` (the model), :mod:`planners` (the paper's algorithms),
:mod:`harness` (engines, metrics, validation, the command line) and :mod:`reports` (rendering).

Aircraft and atmosphere
    :func:`load_aircraft`, :func:`list_aircraft`, :class:`Aircraft`; :class:`ISA`,
    :class:`ConstantDensity`, :class:`Environment`.
Trim
    :func:`trim`, :func:`trim_level`, :func:`coordinated_turn`, :func:`sideslip_glide`,
    :func:`stall_speed`, :class:`TrimResult`.
Simulation (the in-house model)
    :func:`simulate`, :class:`SimulationResult`.
Scenarios
    :func:`load_scenario`, :func:`list_scenarios`, :class:`Scenario`.
Planning
    :func:`plan_scenario`, :func:`plan_motion`, :class:`Plan`, :func:`save_plan`, :class:`FlatProblem`,
    :class:`FlatOutput`, :func:`parametrize`, :func:`open_loop_error` (a plan's controls flown open loop on the
    full model).
Tracking (the feedback along a plan)
    :func:`tracking_controller`, :func:`design`, :func:`linearize`, :func:`paper_lambdas`,
    :class:`TrackingController`, :class:`TrackingDesign`.
Engines
    :func:`get_engine`, :func:`engine_names`, :func:`engines_from_names`, :func:`check_engine_names`,
    :class:`Engine`, :class:`InHouseEngine`, :class:`JSBSimEngine`, :func:`fly`.
Validation cases
    :class:`ValidationCase`, :func:`load_case`, :func:`run_case`, :class:`CaseResult`,
    :func:`difference_table`.
Testing helpers
    :func:`assert_trajectories_close`.
Errors
    :class:`GflatError` and its kinds :class:`InputError`, :class:`UnknownAircraftError`,
    :class:`DomainError`, :class:`ConvergenceError`.

The command line is ``gflat`` (or ``python -m gflat``).
"""

import importlib

#: Public name -> the module defining it.
_PUBLIC = {
    "Aircraft": "gna.aircraft",
    "list_aircraft": "gna.aircraft",
    "load_aircraft": "gna.aircraft",
    "ISA": "gna.atmosphere",
    "ConstantDensity": "gna.atmosphere",
    "Environment": "gna.atmosphere",
    "trim": "gna.trim",
    "trim_level": "gna.trim",
    "coordinated_turn": "gna.trim",
    "sideslip_glide": "gna.trim",
    "stall_speed": "gna.trim",
    "TrimResult": "gna.trim",
    "simulate": "gna.simulate",
    "SimulationResult": "gna.trajectory",
    "load_scenario": "planners.scenario",
    "list_scenarios": "planners.scenario",
    "Scenario": "planners.scenario",
    "plan_scenario": "planners.generalized",
    "plan_motion": "planners.generalized",
    "Plan": "planners.plan",
    "save_plan": "planners.plan",
    "FlatProblem": "planners.flat",
    "FlatOutput": "planners.flat",
    "parametrize": "planners.flat",
    "open_loop_error": "planners.verify",
    "tracking_controller": "planners.tracking",
    "design": "planners.tracking",
    "linearize": "planners.tracking",
    "paper_lambdas": "planners.tracking",
    "TrackingController": "planners.tracking",
    "TrackingDesign": "planners.tracking",
    "get_engine": "harness.engines.registry",
    "engine_names": "harness.engines.registry",
    "engines_from_names": "harness.engines.registry",
    "check_engine_names": "harness.engines.registry",
    "Engine": "harness.engines.base",
    "InHouseEngine": "harness.engines.inhouse",
    "JSBSimEngine": "harness.engines.jsbsim.engine",
    "fly": "harness.engines.fly",
    "ValidationCase": "harness.validation.case",
    "load_case": "harness.validation.case",
    "run_case": "harness.validation.run",
    "CaseResult": "harness.validation.result",
    "difference_table": "harness.metrics.tables",
    "assert_trajectories_close": "harness.testing",
    "GflatError": "gna.errors",
    "InputError": "gna.errors",
    "UnknownAircraftError": "gna.errors",
    "DomainError": "gna.errors",
    "ConvergenceError": "gna.errors",
}

__all__ = [*_PUBLIC, "__version__"]


def __getattr__(name: str):
    if name == "__version__":
        from importlib import metadata

        value = metadata.version("gflat")
    elif name in _PUBLIC:
        value = getattr(importlib.import_module(_PUBLIC[name]), name)
    else:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(__all__))
