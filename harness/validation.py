"""Validation cases: plan a scenario, fly it on several engines, tabulate the differences.

A :class:`ValidationCase` names everything a validation run needs (scenario,
number of generalized-flatness iterations J, engines with the reference first,
open or closed loop, tolerances, comparison windows, output grid); it is a
frozen, picklable value, loadable from TOML (:meth:`ValidationCase.from_toml`),
so a campaign is a map of :func:`run_case` over cases.

:func:`run_case` plans the scenario once (or reuses a given plan), flies the
plan's controls on every engine (:func:`harness.engines.fly`) from the planned
initial state, and returns a :class:`CaseResult`: the plan, the runs, the
difference tables of each engine against the reference engine per window and
of each engine against the plan, and the provenance.  Nothing here writes
files or prints: rendering and writing belong to :mod:`reports` and the CLI.

:func:`compare_engines` is the same comparison for any control source
(constants, a function of t, a plan) without a scenario.
"""

from __future__ import annotations

import datetime
import importlib.metadata
import math
import platform
import subprocess
import time
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from gna.errors import DomainError, InputError
from planners.generalized import plan_scenario
from planners.scenario import load_scenario

from .engines import ENGINES, JSBSimEngine, fly, get_engine
from .metrics import (DEFAULT_WINDOWS, DifferenceTable, difference_table, engine_tables, max_position_error,
                      resolve_tolerances)

#: Loop kinds of a case: the plan's controls alone, or with the tracking feedback.
LOOPS: tuple[str, ...] = ("open", "closed")

_CASE_KEYS = ("scenario", "J", "engines", "loop", "tolerances", "windows", "dt_out")


# --------------------------------------------------------------------------- engine names
# Placeholder for the engine registry (harness.engines.registry: engine_names / get_engine);
# these two functions go once it is merged, their callers switch to the registry.

def engine_names() -> tuple[str, ...]:
    """Names of the engines a case can fly (the first is the default reference).

    Returns
    -------
    tuple of str
    """
    return tuple(ENGINES) + ("jsbsim-wgs84",)


def engine_by_name(name: str):
    """A new engine object from its name (see :func:`engine_names`).

    Parameters
    ----------
    name : str

    Returns
    -------
    engine
        An object with a ``simulate`` method.

    Raises
    ------
    InputError
        Unknown name.
    """
    if name == "jsbsim-wgs84":
        return JSBSimEngine(earth="wgs84")
    if name not in ENGINES:
        raise InputError(f"unknown engine {name!r}; choose from {', '.join(engine_names())}")
    return get_engine(name)


# --------------------------------------------------------------------------- the case

def _positive(value, what: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
        raise InputError(f"{what} must be a positive number, got {value!r}")
    return float(value)


@dataclass(frozen=True)
class ValidationCase:
    """One validation run: a scenario planned and flown on several engines.

    Attributes
    ----------
    scenario : str
        Bundled scenario name or path of a scenario TOML file.
    J : int or None
        Generalized-flatness iterations (``None``: the scenario's).
    engines : tuple of str
        Engine names (:func:`engine_names`); the first is the reference.
    loop : {"open", "closed"}
        ``"open"``: the plan's controls alone.  ``"closed"``: with the paper's
        tracking feedback; reserved, :func:`run_case` refuses it until the
        tracking controller exists.
    tolerances : None, float or tuple of (str, float) pairs
        Tolerance spec of the engine-against-reference tables (see
        :func:`harness.metrics.resolve_tolerances`); a mapping given to the
        constructor is stored as sorted pairs (the case stays hashable).
    windows : tuple of (str, float or None) pairs
        Comparison windows: name -> duration from t0 [s] (``None``: whole span);
        a mapping given to the constructor is stored as pairs, in order.
    dt_out : float
        Output grid step of every engine and of the plan comparison [s].
    """

    scenario: str
    J: int | None = None
    engines: tuple = ("inhouse", "jsbsim")
    loop: str = "open"
    tolerances: Any = None
    windows: Any = tuple(DEFAULT_WINDOWS.items())
    dt_out: float = 0.05

    def __post_init__(self):
        set_ = object.__setattr__
        if isinstance(self.scenario, Path):
            set_(self, "scenario", str(self.scenario))
        if not isinstance(self.scenario, str) or not self.scenario:
            raise InputError(f"scenario must be a name or a path, got {self.scenario!r}")
        if self.J is not None and (isinstance(self.J, bool) or not isinstance(self.J, int) or self.J < 0):
            raise InputError(f"J must be an integer >= 0 or None, got {self.J!r}")
        engines = (self.engines,) if isinstance(self.engines, str) else tuple(self.engines)
        bad = [e for e in engines if e not in engine_names()]
        if not engines or bad:
            raise InputError(f"engines must be names among {', '.join(engine_names())}; got {list(engines)}")
        if len(set(engines)) != len(engines):
            raise InputError(f"engines must be distinct, got {', '.join(engines)}")
        set_(self, "engines", engines)
        if self.loop not in LOOPS:
            raise InputError(f"loop must be one of {', '.join(LOOPS)}, got {self.loop!r}")
        tol = self.tolerances
        if isinstance(tol, Mapping):
            tol = tuple(sorted((str(k), None if v is None else float(v)) for k, v in tol.items()))
        elif isinstance(tol, (list, tuple)):
            tol = tuple((str(k), None if v is None else float(v)) for k, v in tol)
        set_(self, "tolerances", tol)
        resolve_tolerances(self.tolerance_spec, ())  # refuse bad values now, not after flying
        win = self.windows.items() if isinstance(self.windows, Mapping) else self.windows
        win = tuple((str(k), None if d is None else _positive(d, f"window {k!r}")) for k, d in win)
        if not win:
            raise InputError("a case needs at least one comparison window")
        set_(self, "windows", win)
        set_(self, "dt_out", _positive(self.dt_out, "dt_out"))

    @property
    def tolerance_spec(self):
        """The tolerances as :func:`harness.metrics.difference_table` takes them (None, float or dict)."""
        return dict(self.tolerances) if isinstance(self.tolerances, tuple) else self.tolerances

    @property
    def window_spec(self) -> dict:
        """The windows as a dict name -> duration [s] or None."""
        return dict(self.windows)

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], where: str = "case", base: Path | None = None) -> ValidationCase:
        """A case from a mapping (a TOML table).

        Parameters
        ----------
        data : mapping
            Keys ``scenario`` (required), ``J``, ``engines`` (list of names),
            ``loop``, ``tolerances`` (number or table variable -> number),
            ``windows`` (table name -> duration [s], or ``"all"`` for the
            whole span), ``dt_out`` [s].
        where : str
            Name of the source, for messages.
        base : Path, optional
            Folder a relative scenario path (``*.toml``) is resolved against.

        Returns
        -------
        ValidationCase

        Raises
        ------
        InputError
            Unknown or missing keys, or bad values (naming the key).
        """
        unknown = sorted(k for k in data if k not in _CASE_KEYS)
        if unknown:
            raise InputError(f"{where}: unknown key(s) {', '.join(map(repr, unknown))}; "
                             f"known keys: {', '.join(_CASE_KEYS)}")
        if "scenario" not in data:
            raise InputError(f"{where}: missing 'scenario'")
        kw = dict(data)
        sc = str(kw["scenario"])
        if base is not None and sc.endswith(".toml") and not Path(sc).is_absolute():
            sc = str(base / sc)
        kw["scenario"] = sc
        if "engines" in kw:
            kw["engines"] = tuple(kw["engines"]) if isinstance(kw["engines"], list) else kw["engines"]
        if isinstance(kw.get("windows"), Mapping):
            kw["windows"] = {k: (None if v == "all" else v) for k, v in kw["windows"].items()}
        try:
            return cls(**kw)
        except InputError as exc:
            raise InputError(f"{where}: {exc}") from None

    @classmethod
    def from_toml(cls, path: str | Path) -> ValidationCase:
        """A case from a TOML file (keys as :meth:`from_dict`; scenario paths relative to the file).

        Parameters
        ----------
        path : str or Path

        Returns
        -------
        ValidationCase

        Raises
        ------
        InputError
            Missing file, invalid TOML, unknown keys or bad values.
        """
        p = Path(path)
        try:
            data = tomllib.loads(p.read_text(encoding="utf-8"))
        except OSError as exc:
            raise InputError(f"cannot read the case file {p}: {exc.strerror}") from None
        except tomllib.TOMLDecodeError as exc:
            raise InputError(f"{p.name}: not valid TOML ({exc})") from None
        return cls.from_dict(data, where=p.name, base=p.parent)


def load_case(path: str | Path) -> ValidationCase:
    """A :class:`ValidationCase` from a TOML file (:meth:`ValidationCase.from_toml`).

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    ValidationCase

    Raises
    ------
    InputError
        Missing file, invalid TOML, unknown keys or bad values.
    """
    return ValidationCase.from_toml(path)


# --------------------------------------------------------------------------- results

def _runs_report(runs: Mapping, tables: Mapping) -> str:
    """Status and settings of every run, then every difference table."""
    out = []
    for label, res in runs.items():
        s = res.settings
        extra = (f"dt = {s['dt']:.6g} s, integrators {s['integrators']}, earth {s['earth']}"
                 if s.get("engine") == "jsbsim" else
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
        """One table (``engine`` defaults to the only compared engine)."""
        if engine is None:
            if len(self.tables) != 1:
                raise InputError(f"several engines compared ({', '.join(self.tables)}): name one")
            engine = next(iter(self.tables))
        return self.tables[engine][window]

    def report(self) -> str:
        """All tables, with the run status and settings of each engine."""
        return _runs_report(self.results, self.tables)


def compare_engines(aircraft, controls, t_span=None, x0=None, *, engines=("inhouse", "jsbsim"), env=None,
                    controller=None, dt_out: float = 0.02, tolerances=None,
                    windows: Mapping[str, float | None] | None = None) -> EngineComparison:
    """Fly one problem on several engines and compare each with the first.

    Parameters
    ----------
    aircraft : gna.aircraft.Aircraft
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


def plan_case(case: ValidationCase) -> PlannedCase:
    """Load a case's scenario and plan it (flatness, then J generalized-flatness iterations).

    Parameters
    ----------
    case : ValidationCase

    Returns
    -------
    PlannedCase

    Raises
    ------
    InputError
        Unknown or malformed scenario.
    """
    sc = load_scenario(case.scenario, J=case.J)
    t0 = time.perf_counter()
    plan = plan_scenario(sc)
    return PlannedCase(scenario=sc, plan=plan, planning_time_s=time.perf_counter() - t0)


def provenance() -> dict:
    """Versions, date and source revision a result was computed with.

    Returns
    -------
    dict
        ``gflat``, ``jsbsim``, ``numpy``, ``python`` versions (None when a
        package is not installed), ``date_utc`` (ISO 8601, seconds) and
        ``git_commit`` of the source tree (None outside a git checkout).
    """
    def version(pkg):
        try:
            return importlib.metadata.version(pkg)
        except importlib.metadata.PackageNotFoundError:
            return None
    try:
        r = subprocess.run(["git", "rev-parse", "HEAD"], cwd=Path(__file__).resolve().parent, capture_output=True,
                           text=True, timeout=5)
        commit = r.stdout.strip() if r.returncode == 0 else None
    except (OSError, subprocess.SubprocessError):
        commit = None
    return {"gflat": version("gflat"), "jsbsim": version("jsbsim"), "numpy": np.__version__,
            "python": platform.python_version(),
            "date_utc": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
            "git_commit": commit or None}


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
    """

    case: ValidationCase
    plan: Any
    runs: dict
    tables: dict
    vs_plan: dict
    provenance: dict = field(default_factory=dict)
    planning_time_s: float | None = None

    @property
    def reference_engine(self) -> str:
        """Name of the engine the others are compared with."""
        return next(iter(self.runs))

    @property
    def passed(self) -> bool:
        """True when every engine-against-reference table passes (the tables against the plan inform)."""
        return all(t.passed for per in self.tables.values() for t in per.values())

    def max_position_error_m(self, window: tuple[float | None, float | None] | None = None) -> dict:
        """Per engine, the largest distance [m] between its position and the planned flat outputs."""
        J = self.plan.J
        return {label: max_position_error(res, lambda t: self.plan.state(t, J), window)
                for label, res in self.runs.items()}

    def reference_frame(self):
        """The plan's J-th iterate (states and controls) at the reference engine's output times."""
        times = np.asarray(self.runs[self.reference_engine].df.index, dtype=float)
        return self.plan.to_dataframe(times, j=self.plan.J)

    def summary(self, figures=()) -> dict:
        """The machine-readable summary (``summary.json``): scenario, J, engines, pass, status, tables.

        ``figures`` lists the paths of figures written from this result, if any.
        """
        return {"scenario": self.plan.name, "J": self.plan.J, "engines": list(self.runs), "passed": self.passed,
                "status": {k: r.status for k, r in self.runs.items()},
                "tables": {eng: {w: t.to_frame().reset_index().to_dict(orient="records") for w, t in per.items()}
                           for eng, per in self.tables.items()},
                "figures": [str(p) for p in figures]}

    def report_text(self) -> str:
        """The difference report: runs, tables against the reference engine, tables against the plan."""
        p = self.plan
        lines = [f"{p.name}: {p.aircraft.id}, J = {p.J}, t = {p.t0:g} .. {p.t1:g} s, {self.case.loop} loop",
                 _runs_report(self.runs, self.tables)]
        for label, tab in self.vs_plan.items():
            lines.append(f"[{label} against the plan, whole span]")
            lines.append(tab.format())
        return "\n".join(lines)


def _feedback(case: ValidationCase, plan):
    """The controller flown with the plan's controls: none open loop."""
    if case.loop == "closed":
        # The paper's tracking feedback (linearization along the plan, integral states) plugs in here.
        raise InputError("closed loop needs a tracking controller; only loop = 'open' is available")
    return None


def run_case(case: ValidationCase, *, plan=None) -> CaseResult:
    """Plan a case's scenario (once), fly it on every engine and tabulate the differences.

    Parameters
    ----------
    case : ValidationCase
    plan : planners.plan.Plan, optional
        A plan of the case's scenario, reused instead of planning again (its J
        must match the case's when the case sets one).

    Returns
    -------
    CaseResult
        Runs on the grid ``t0, t0 + dt_out, ...`` of the plan's span, tables of
        every engine against the first per window and against the plan.

    Raises
    ------
    InputError
        Not a case, unknown scenario, a plan whose J differs from the case's,
        or ``loop = "closed"`` (no tracking controller yet).
    DomainError
        The plan is not feasible (Newton failed): there is nothing to fly.
    """
    if not isinstance(case, ValidationCase):
        raise InputError(f"run_case needs a ValidationCase, got {type(case).__name__}")
    planning_time = None
    if plan is None:
        planned = plan_case(case)
        plan, planning_time = planned.plan, planned.planning_time_s
    elif case.J is not None and plan.J != case.J:
        raise InputError(f"the plan given has J = {plan.J}, the case asks for J = {case.J}")
    if not plan.feasible:
        raise DomainError(f"{plan.name}: the plan is not feasible, nothing to fly: {plan.newton_failures[0]}")
    controller = _feedback(case, plan)
    J = plan.J
    span = (plan.t0, plan.t1)
    runs = fly({n: engine_by_name(n) for n in case.engines}, plan.aircraft, plan.initial_state(J),
               plan.control_function(J), span, env=plan.env, controller=controller, dt_out=case.dt_out)
    tables = engine_tables(runs, span, case.tolerance_spec, case.window_spec)
    grid = np.arange(plan.t0, plan.t1 + 0.5 * case.dt_out, case.dt_out)
    plan_df = plan.to_dataframe(grid[grid <= plan.t1 + 1e-9], j=J)
    # no tolerances: the open-loop drift from the plan is information, not a pass/fail criterion
    vs_plan = {label: difference_table(plan_df, res.df, tolerances={}, labels=("plan", label))
               for label, res in runs.items()}
    return CaseResult(case=case, plan=plan, runs=runs, tables=tables, vs_plan=vs_plan, provenance=provenance(),
                      planning_time_s=planning_time)
