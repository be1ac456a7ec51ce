"""Validation: a scenario planned once, flown on several engines, compared with the plan and each other.

A :class:`ValidationCase` is a frozen, picklable value (loadable from TOML), so
a campaign is a map of :func:`run_case` over cases; :func:`run_case` returns a
:class:`CaseResult` (plan, runs, difference tables against the reference
engine and against the plan, provenance).  Nothing here writes files or
prints: rendering and writing belong to :mod:`reports` and the CLI.

Rooms
-----
case
    :class:`ValidationCase`, :func:`load_case`, the engine names a case may use.
tolerances
    The ``[compare]`` settings (tolerances per quantity, windows, output grid,
    JSBSim step, self-convergence): :func:`resolve_compare`, :class:`CompareSettings`.
result
    :class:`CaseResult` (verdict, summary, report text).
run
    :func:`run_case`, :func:`case_settings`, :func:`plan_case`, :func:`provenance`,
    and :func:`compare_engines` (any control source, no scenario).
flights
    A case split into independent flights (:func:`~.flights.case_flights`, to fly
    in any order or process) and their tabulation (:func:`~.flights.finish_case`);
    :func:`run_case` is the two in sequence.
"""

from .case import LOOPS, ValidationCase, load_case
from .result import CaseResult
from .run import EngineComparison, PlannedCase, case_settings, compare_engines, plan_case, provenance, run_case
from .tolerances import QUANTITIES, CompareSettings, parse_compare, resolve_compare

__all__ = [
    "LOOPS",
    "ValidationCase",
    "load_case",
    "CaseResult",
    "CompareSettings",
    "QUANTITIES",
    "EngineComparison",
    "PlannedCase",
    "case_settings",
    "compare_engines",
    "parse_compare",
    "plan_case",
    "provenance",
    "resolve_compare",
    "run_case",
]
