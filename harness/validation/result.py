"""The result of a validation case: runs, difference tables, verdict, summary, report text.

:class:`CaseResult` is what :func:`harness.validation.run_case` returns; it
holds the settings the comparison was made with
(:class:`harness.validation.tolerances.CompareSettings`) so that a verdict
always travels with the tolerances that made it.  Nothing here writes files.
"""

from __future__ import annotations

import copy
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..metrics import PERCENT_FLOORS, max_position_error
from .case import ValidationCase
from .closed import ClosedLoopSetup, saturated_seconds
from .tolerances import DEFAULT_SETTLE_TIME, DEFAULT_TRACKING_TOLERANCE, CompareSettings
from .verdicts import VERDICT_NAMES, engines_agree_verdict, flyable_verdict, judge, tracking_verdict

#: Angles summarised in the verdict.
ANGLE_STATES: tuple[str, ...] = ("gamma", "chi", "alpha", "beta", "mu")

#: What the verdict's ``delta_pct`` is (:mod:`harness.metrics.scales`), carried in the verdict itself
#: (``{window}``: the window of the verdict's tables, the whole span unless the windows have none).
DELTA_PCT_DEFINITION = (
    "differences.<engine>.delta_pct: informative, not a verdict; per variable, 100 max|b - a| / scale [%] over "
    "{window}, a = the reference engine; scale = max|a|, or for x, y, z, chi (no physical zero) the "
    "excursion max(a) - min(a) (for position, the largest distance between two points of a's path); null where "
    "the scale is at most the floor of its kind ("
    + ", ".join(f"{v:g} {k}" for k, v in PERCENT_FLOORS.items())
    + ", 1e-09 otherwise)"
)


def _runs_report(runs: Mapping, tables: Mapping) -> str:
    """Status and settings of every run, then every difference table."""
    out = []
    for label, res in runs.items():
        s = res.settings
        extra = (
            f"dt = {s['dt']:.6g} s, integrators {s['integrators']}"
            + (f", earth {s['earth']}" if s.get("earth") else "")
            if s.get("dt") is not None
            else f"{s.get('method')} rtol = {s.get('rtol')}, atol = {s.get('atol')}"
        )
        out.append(f"{label}: {res.status}{(' - ' + res.message) if res.message else ''}; {extra}")
        out += [f"  warning: {w}" for w in res.warnings]
    for per in tables.values():
        for name, t in per.items():
            out.append(f"[{name}]")
            out.append(t.format())
    return "\n".join(out)


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
    settings : CompareSettings or None
        Tolerances, windows, output grid, JSBSim step the comparison was made
        with, and where each came from.
    half_step : dict
        Self-convergence: JSBSim engine name -> its run at half its step.
    self_convergence : dict
        Self-convergence: JSBSim engine name -> {window name -> DifferenceTable
        of the run at half the step against the run at the step} (informative).
    scenario : planners.scenario.Scenario or None
        The scenario flown (its file and aircraft go into the manifest).
    flat_closed_loop : SimulationResult or None
        Closed loop: the reference engine flying the feedback with the flat
        plan's (J = 0) feedforward and reference, from its initial state: the
        paper's dark-blue curve, which starts on the flat plan and converges
        to the generalized one (the same run as ``runs`` when the case's
        feedforward iterate is 0).
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
    settings: CompareSettings | None = None
    half_step: dict = field(default_factory=dict)
    self_convergence: dict = field(default_factory=dict)
    scenario: Any = None
    flat_closed_loop: Any = None

    @property
    def reference_engine(self) -> str:
        """Name of the engine the others are compared with."""
        return next(iter(self.runs))

    @property
    def passed(self) -> bool:
        """True when every engine-against-reference table passes (the tables against the plan inform).

        The engines' agreement only: the case's three verdicts are :meth:`verdicts`.
        """
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
        return {
            label: max_position_error(res, lambda t: self.plan.state(t, J), window) for label, res in self.runs.items()
        }

    def saturated_s(self) -> dict:
        """Per engine, the seconds a control was commanded beyond its limits (closed loop).

        Returns
        -------
        dict
            Engine name -> ``{"F": s, ..., "any": s}``; empty open loop.  Computed once (the controller
        evaluated at every sample) and kept: the verdict, the summary and the report each ask for it.
        """
        if self.closed_loop is None:
            return {}
        key = (id(self.closed_loop), tuple((label, id(res)) for label, res in self.runs.items()))
        memo = self.__dict__.get("_saturated")
        if memo is None or memo[0] != key:
            memo = (key, {label: saturated_seconds(self.closed_loop.controller, r) for label, r in self.runs.items()})
            self.__dict__["_saturated"] = memo
        return {label: dict(v) for label, v in memo[1].items()}

    def verdicts(self) -> dict:
        """The three verdicts of the case (:mod:`harness.validation.verdicts`).

        Returns
        -------
        dict
            ``flyable`` (the plan within the aircraft's limits), ``tracking``
            (closed loop: the distance to the flat outputs after the settle
            time; ``pass`` None open loop), ``engines_agree`` (the difference
            tables), and ``judged`` (:func:`~harness.validation.verdicts.judge`:
            what fails the exit status, what the scenario records).
        """
        return copy.deepcopy(self._memo("_verdicts", self._verdicts))

    def _memo(self, name: str, compute):
        """``compute()``, kept while the result's runs, tables, settings and plan are the same objects (the
        command, its files and its report each ask for the verdicts: judged once)."""
        key = (
            id(self.closed_loop),
            tuple((label, id(res)) for label, res in self.runs.items()),
            id(self.tables),
            id(self.settings),
            id(self.plan),
        )
        memo = self.__dict__.get(name)
        if memo is None or memo[0] != key:
            memo = (key, compute())
            self.__dict__[name] = memo
        return memo[1]

    def _verdicts(self) -> dict:
        known = tuple(getattr(self.scenario, "known", ()) or ())
        s = self.settings
        tol = s.tracking_tolerance if s is not None else DEFAULT_TRACKING_TOLERANCE
        settle = s.settle_time if s is not None else DEFAULT_SETTLE_TIME
        J = self.plan.J
        out = {
            "flyable": flyable_verdict(self.plan, known),
            "tracking": tracking_verdict(
                self.runs,
                lambda t: self.plan.state(t, J),
                (self.plan.t0, self.plan.t1),
                tol,
                settle,
                self.saturated_s() if self.closed_loop is not None else None,
                clipped=self.closed_loop is None or bool(getattr(self.closed_loop.controller, "saturate", True)),
            ),
            "engines_agree": engines_agree_verdict(self.runs, self.tables),
        }
        out["judged"] = judge(out, known)
        return out

    def verdict(self) -> dict:
        """The machine-readable verdict of ``gflat compare --json``.

        Returns
        -------
        dict
            ``scenario``, ``loop``, ``runs`` (engine -> ``status``,
            ``max_position_error_m`` (max over the span of ``|(x, y, z) - flat
            outputs|``), ``max_position_error_after_5s_m``, ``saturated_s``),
            ``differences`` (each engine but the reference -> ``max_position_m``,
            ``max_angle_rad`` over the whole span, ``delta_pct``: the relative
            difference [%] per variable over the whole span, NaN where undefined,
            see :func:`harness.metrics.percent_scale`), ``delta_pct_definition``
            (:data:`DELTA_PCT_DEFINITION`, naming the window),
            ``settings`` (the tolerances and settings that made the verdict),
            ``self_convergence`` (JSBSim engine -> ``max_position_m``,
            ``max_angle_rad`` between its step and half of it; empty unless asked),
            ``verdicts`` (:meth:`verdicts`: ``flyable``, ``tracking``,
            ``engines_agree``, each with its ``pass``, and ``judged``).  ``pass``
            is the exit status's: no verdict fails that the scenario does not
            record (``[verdicts] known``); ``failures`` lists those that do.
        """
        return copy.deepcopy(self._memo("_verdict", self._verdict))

    def _verdict(self) -> dict:
        t0 = self.plan.t0
        whole = self.max_position_error_m()
        after = self.max_position_error_m((t0 + 5.0, None))
        sat = self.saturated_s()
        runs = {
            label: {
                "status": res.status,
                "max_position_error_m": whole[label],
                "max_position_error_after_5s_m": after[label],
                "saturated_s": sat[label]["any"] if label in sat else 0.0,
            }
            for label, res in self.runs.items()
        }
        diffs = {
            label: dict(_maxima(per), delta_pct={r.variable: r.delta_pct for r in _whole(per).rows})
            for label, per in self.tables.items()
        }
        verdicts = self.verdicts()
        where = "the whole span"
        for per in self.tables.values():
            name = "whole span" if "whole span" in per else next(iter(per))
            where = f"the window {name!r}, t in [{per[name].window[0]:g}, {per[name].window[1]:g}] s"
            break
        return {
            "scenario": self.plan.name,
            "loop": self.case.loop,
            "runs": runs,
            "differences": diffs,
            "delta_pct_definition": DELTA_PCT_DEFINITION.format(window=where),
            "pass": verdicts["judged"]["pass"],
            "failures": verdicts["judged"]["unrecorded"],
            "verdicts": {k: verdicts[k] for k in VERDICT_NAMES},
            "recorded": verdicts["judged"]["recorded"],
            "settings": self.settings.to_dict() if self.settings is not None else None,
            "self_convergence": {label: _maxima(per) for label, per in self.self_convergence.items()},
        }

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
            ``scenario``, ``J``, ``engines``, ``passed`` (no verdict fails that the
            scenario does not record), ``verdicts`` and ``failures`` (as
            :meth:`verdict`), ``status`` (engine -> run
            status), ``tables`` (engine -> window -> list of row records, with
            the relative difference ``delta_pct`` [%]), ``figures`` (paths as str),
            ``settings`` (tolerances and settings of the verdict),
            ``self_convergence_tables`` (JSBSim engine -> window -> row records).
        """

        def records(tables):
            return {
                eng: {w: t.to_frame().reset_index().to_dict(orient="records") for w, t in per.items()}
                for eng, per in tables.items()
            }

        verdicts = self.verdicts()
        return {
            "scenario": self.plan.name,
            "J": self.plan.J,
            "engines": list(self.runs),
            "passed": verdicts["judged"]["pass"],
            "verdicts": {k: verdicts[k] for k in VERDICT_NAMES},
            "failures": verdicts["judged"]["unrecorded"],
            "status": {k: r.status for k, r in self.runs.items()},
            "tables": records(self.tables),
            "figures": [str(p) for p in figures],
            "settings": self.settings.to_dict() if self.settings is not None else None,
            "self_convergence_tables": records(self.self_convergence),
        }

    def report_text(self) -> str:
        """The difference report (``differences.txt``).

        Returns
        -------
        str
            Heading, run status and settings, tables against the reference
            engine per window, tables against the plan.
        """
        p = self.plan
        lines = [
            f"{p.name}: {p.aircraft.id}, J = {p.J}, t = {p.t0:g} .. {p.t1:g} s, {self.case.loop} loop",
            _runs_report(self.runs, self.tables),
        ]
        for label, per in self.self_convergence.items():
            for name, tab in per.items():
                lines.append(f"[self-convergence of {label}: step against half the step, {name}]")
                lines.append(tab.format())
        for label, tab in self.vs_plan.items():
            lines.append(f"[{label} against the plan, whole span]")
            lines.append(tab.format())
        return "\n".join(lines)


def _whole(per: Mapping):
    """The whole-span table of a window -> table mapping (else the first)."""
    return per.get("whole span") or next(iter(per.values()))


def _maxima(per: Mapping) -> dict:
    """Largest position [m] and angle [rad] differences over the whole span."""
    tab = _whole(per)
    return {
        "max_position_m": tab.row("position").max_abs,
        "max_angle_rad": max(tab.row(v).max_abs for v in ANGLE_STATES),
    }
