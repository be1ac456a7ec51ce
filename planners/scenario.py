"""Scenario files: a manoeuvre to plan, as TOML.

A scenario names the aircraft, the time span and grid, the flat outputs as
expressions of ``t`` (parsed safely, :mod:`planners.expressions`), the fourth
flat output, the thrust asymmetry (or a fixed rudder), the number J of
generalized-flatness iterations and the values of the neglected terms for the
first iterate (zero or a full-model calibration).  Bundled scenarios live in
``planners/scenarios/``; any path to a ``.toml`` file works too.

Example (the paper's forward slip)::

    name = "gtm-forward-slip"
    aircraft = "gtm"
    [time]
    t0 = 0.0
    t1 = 120.0
    step = 1.0
    [flat_outputs]
    x = "29.10852587*t + 50*sin(t/60)"
    y = "60*cos(t/100 + 2)"
    z = "-1000 + 5.983293200*t + 70*sin(t/70)"
    zeta = "F"
    zeta_value = "0"
    eta = "0"
    [generalized]
    J = 6                  # or "auto" (J_tol, J_max: planners.generalized.choose_J)
    e = 1                  # output order: the controls' series order in the last iterate
    interpolation = "hermite"   # between nodes; or "paper" (the two-sided formula)
    [calibration]          # H values of the first iterate from a full-model trim
    alpha = 0.15
    beta = 0.35
    F = 0.0
    chi_dot = 0.0
    [tracking]             # the closed loop (planners.tracking.tracking_controller)
    design = "paper"       # or "lqr" (planners.lqr.lqr_controller)
    lambdas = 0.5          # or a table: I1 = [..], I2 = [..], I3 = [..], I4 = [..]
    tolerances = { position = 1.0 }   # the LQR's Bryson weights (velocity, angle, rate too)
    feedforward_iterate = -1
    saturate = true
    [tracking.perturbation]   # optional, for robustness runs (gna.perturbation)
    aero_spread = 0.1
    mass_scale = 1.05
    position_m = 5.0
    speed_mps = 1.0
    angle_rad = 0.0174533
    seed = 1

The ``[tracking]`` table
------------------------
``design``
    ``"paper"`` (default: the paper's pole placement, :func:`planners.tracking.tracking_controller`,
    with ``lambdas``) or ``"lqr"`` (finite-horizon time-varying LQR along the plan,
    :func:`planners.lqr.lqr_controller`); ``--tracking`` on ``gflat compare``, ``gflat paper`` and
    ``gflat campaign run`` overrides it.
``tolerances``
    Largest acceptable tracking errors, by quantity: ``position`` [m], ``velocity`` [m/s],
    ``angle`` [rad], ``rate`` [rad/s] (:class:`planners.lqr.TrackingTolerances`, defaults
    :data:`planners.lqr.DEFAULT_TOLERANCES`); the LQR's weights by Bryson's rule.
``lambdas``
    Positive pole magnitudes [1/s] of the tracking feedback: one number for
    every factor, or a table of lists ``I1``, ``I2``, ``I3``, ``I4`` of lengths
    3, 5, 5, 3 (5, 5, 5 for ``I1..I3`` when the fourth flat output is the thrust
    ``F``, without ``I4``).  The closed loop obeys ``prod (d/dt + lambda) I_p = 0``.
    Default 1.0 everywhere.
``feedforward_iterate``
    Plan iterate ``j`` whose controls are the feedforward (default -1, the
    last; 0 = the flat plan).
``saturate``
    Clip the applied controls at the aircraft's limits (default true).
``perturbation``
    Optional sub-table, :func:`gna.perturbation.perturbation_from_dict`:
    ``aero_spread`` (every aerodynamic term times a seeded random factor in
    ``[1 - s, 1 + s]``), ``aero_scale`` (table of factors by term index or
    coefficient name), ``mass_scale``, ``inertia_scale``, ``position_m``,
    ``speed_mps``, ``angle_rad``, ``state_offsets`` (table by state name),
    ``seed``.

Unknown keys of ``[tracking]`` and of its sub-tables are refused by name.

The ``[compare]`` table
-----------------------
Engine comparison settings (``gflat compare``, ``gflat paper``): keys
:data:`COMPARE_KEYS`, checked here whatever the command (an unknown key is
refused with the closest known one); their values are checked by
:func:`harness.validation.parse_compare`.

The ``[verdicts]`` table
------------------------
``known``
    A list of violations the scenario records, each ``{name = ..., reason =
    ...}``: ``name`` a limit of the flyability verdict (:data:`gna.limits.LIMIT_NAMES`:
    ``"dl"``, ``"thrust[1]"``, ``"alpha"``, ``"mach"``, ``"nz"``, ...) or a whole
    verdict (:data:`KNOWN_VERDICTS`: ``"tracking"``, ``"engines_agree"``);
    ``reason`` why the scenario keeps it (non-empty).  A recorded violation is
    still computed and shown; it only stops failing the command's exit status::

        [verdicts]
        known = [{ name = "dl", reason = "the paper's path asks for that roll moment" }]
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from gna.aircraft import Aircraft, load_aircraft
from gna.atmosphere import ISA, ConstantDensity, Environment
from gna.catalogue import bundled
from gna.eom import HValues
from gna.errors import GflatError, InputError
from gna.ground_effect import GroundEffect
from gna.perturbation import Perturbation, perturbation_from_dict
from gna.schema import check_name, find_file, load_schema, read_toml, unknown_key_message, validate

from .bounded import BoundedSettings, bounded_settings
from .expressions import CONSTANTS, FUNCTIONS, Expression, compile_expression
from .flat import FLAT_KINDS, FlatOutput, FlatProblem, check_iterations
from .generalized import AUTO_J, AUTO_J_MAX, AUTO_J_TOL, check_output_order
from .lqr import DEFAULT_TOLERANCES, TrackingTolerances, check_design
from .plan import DEFAULT_INTERPOLATION, check_interpolation
from .splines import BASES, bezier_expression, bezier_points, steady_derivatives

#: Largest grid accepted (memory: every node carries ~20 series of order up to 5 + 2J).
MAX_NODES = 20000


#: Most times of the ``[report] times`` table (each is a row of the plan report, evaluated on every iterate).
MAX_REPORT_TIMES = 1000

#: Largest |time| of a scenario [s] (about 30 years: beyond it a grid step loses its meaning in float64).
MAX_TIME = 1e9

#: Keys of the ``[tracking]`` table.
TRACKING_KEYS: tuple[str, ...] = (
    "design",
    "tolerances",
    "lambdas",
    "feedforward_iterate",
    "saturate",
    "controller_dt",
    "perturbation",
)

#: Keys of the ``[compare]`` table (engine comparison settings): the one list, checked here for every command
#: (the scenario schema is generated from it) and read by :func:`harness.validation.parse_compare`, which
#: checks the values.
COMPARE_KEYS: tuple[str, ...] = (
    "tolerances",
    "rtol",
    "windows",
    "dt_out",
    "jsbsim_dt",
    "self_convergence",
    "tracking_tolerance",
    "settle_time",
)

#: Verdicts a ``known`` record may name whole (besides the limits of the flyability verdict).
KNOWN_VERDICTS: tuple[str, ...] = ("tracking", "engines_agree")


@dataclass(frozen=True)
class KnownViolation:
    """A violation a scenario records (``[verdicts] known``): still shown, it does not fail the exit status.

    Attributes
    ----------
    name : str
        A limit (:data:`gna.limits.LIMIT_NAMES`) or a verdict (:data:`KNOWN_VERDICTS`).
    reason : str
        Why the scenario keeps it.
    """

    name: str
    reason: str


#: Keys of a parameter of the ``[parameters]`` table.
PARAMETER_KEYS: tuple[str, ...] = ("value", "min", "max", "description")

#: Keys of a spline flat output (``x = {basis = "bezier", ...}``).
SPLINE_KEYS: tuple[str, ...] = ("basis", "coefficients", "start", "end")

#: Keys of a side of the ``[boundary]`` table besides the trim variables.
BOUNDARY_KEYS: tuple[str, ...] = ("altitude", "x", "y", "chi")

#: Trim variables a side of ``[boundary]`` fixes when it gives fewer than four, in this order (level,
#: straight, coordinated).
BOUNDARY_DEFAULTS: tuple[tuple[str, float], ...] = (("gamma", 0.0), ("chi_dot", 0.0), ("beta", 0.0))

#: Default highest derivative of x, y, z matched at a boundary (4: the controls start and end at the trims').
DEFAULT_BOUNDARY_ORDER = 4


@dataclass(frozen=True)
class Parameter:
    """A parameter of a scenario (``[parameters] name = {value = ..., min = ..., max = ...}``).

    Attributes
    ----------
    name : str
        The name the expressions use.
    value : float
        Its value (the nominal one; the bounded planner's starting point and the ``deviation`` cost's
        reference).
    lower, upper : float
        Its range (``lower <= value <= upper``).
    free : bool
        The bounded planner chooses it (``lower < upper`` in a scenario as loaded; False in the scenario of
        one member of the family, :meth:`Scenario.at`).
    description : str
    """

    name: str
    value: float
    lower: float
    upper: float
    free: bool = True
    description: str = ""


@dataclass(frozen=True)
class BoundaryState:
    """One end of a point-to-point manoeuvre: a steady flight (trim) at a position and heading.

    Attributes
    ----------
    side : {"start", "end"}
    time : float
        ``t0`` or ``t1`` [s].
    trim : gna.trim.TrimResult
        The full-model trim (``gflat trim``'s solution) with the side's four fixed variables.
    x, y, chi, altitude : float
        Position [m], heading [rad] and altitude [m] of the point.
    derivatives : dict
        ``"x"``, ``"y"``, ``"z"`` -> values and derivatives ``0..order`` of the steady flight there (SI).
    """

    side: str
    time: float
    trim: Any
    x: float
    y: float
    chi: float
    altitude: float
    derivatives: dict

    def state(self) -> np.ndarray:
        """The 12 states of the steady flight at the point (SI, rad; :data:`gna.eom.STATE_NAMES` order).

        Returns
        -------
        ndarray, shape (12,)
        """
        v = self.trim.values
        return np.array(
            [self.x, self.y, -self.altitude, v["V"], v["gamma"], self.chi]
            + [v[k] for k in ("alpha", "beta", "mu", "p", "q", "r")]
        )

    def controls(self) -> np.ndarray:
        """The trim's controls ``(F, eta, dl, dm, dn)`` [N, -, rad, rad, rad].

        Returns
        -------
        ndarray, shape (5,)
        """
        return np.array(list(self.trim.controls), dtype=float)

    def to_dict(self) -> dict:
        """The boundary as JSON-ready data (SI, rad).

        Returns
        -------
        dict
            ``side``, ``time``, ``x``, ``y``, ``chi``, ``altitude``, ``trim_fixed``, ``trim`` (the 13 trim values).
        """
        return {
            "side": self.side,
            "time": self.time,
            "x": self.x,
            "y": self.y,
            "chi": self.chi,
            "altitude": self.altitude,
            "trim_fixed": dict(self.trim.fixed),
            "trim": dict(self.trim.values),
        }


#: Default sampling interval [s] of the feedback on sampled engines (JSBSim): None, every engine step.  A
#: sampled feedback is another system than the in-house engine's continuous one: measured (dispersed Twin
#: Otter and roll, controls saturating 1-2 s), the engines then differ by 0.8 / 0.2 mm sampled every step,
#: 8 / 20 mm at 60 Hz.  ``controller_dt = 1/60`` keeps 52-71 % of JSBSim's open-loop speed against 17 %
#: (docs/tracking.md), for runs where that fidelity is not needed.
DEFAULT_CONTROLLER_DT: float | None = None


@dataclass(frozen=True)
class Tracking:
    """The ``[tracking]`` table of a scenario: the closed loop's settings.

    Attributes
    ----------
    lambdas : float or tuple of tuple of float
        Pole magnitudes [1/s] (one number for all, or one tuple per integral),
        as :func:`planners.tracking.tracking_controller` takes them.
    feedforward_iterate : int
        Plan iterate of the feedforward (-1 = the last, 0 = the flat plan).
    saturate : bool
        Clip the applied controls at the aircraft's limits.
    controller_dt : float or None
        Sampling interval [s] of the feedback on sampled engines (JSBSim), the
        output held in between; None samples at every engine step.  The
        in-house engine evaluates the feedback continuously.
    perturbation : Perturbation or None
        Optional model and initial-state perturbation (:mod:`gna.perturbation`).
    design : {"paper", "lqr"}
        The tracking design (:data:`planners.lqr.DESIGNS`).
    tolerances : planners.lqr.TrackingTolerances
        Largest acceptable tracking errors (the LQR's Bryson weights).
    """

    lambdas: float | tuple = 1.0
    feedforward_iterate: int = -1
    saturate: bool = True
    controller_dt: float | None = DEFAULT_CONTROLLER_DT
    perturbation: Perturbation | None = None
    design: str = "paper"
    tolerances: TrackingTolerances = field(default_factory=TrackingTolerances)


def with_tracking_design(scenario: Scenario, design: str | None) -> Scenario:
    """The scenario with its ``[tracking] design`` replaced (``--tracking``); itself when ``design`` is None.

    Parameters
    ----------
    scenario : Scenario
    design : {"paper", "lqr"} or None

    Returns
    -------
    Scenario

    Raises
    ------
    InputError
        Another design name.
    """
    if design is None or design == scenario.tracking.design:
        return scenario
    from dataclasses import replace

    return replace(scenario, tracking=replace(scenario.tracking, design=check_design(design, "--tracking")))


@dataclass
class Scenario:
    """A parsed scenario (see module docstring for the file format)."""

    name: str
    description: str
    aircraft: Aircraft
    env: Environment
    t0: float
    t1: float
    step: float
    x: Expression
    y: Expression
    z: Expression
    zeta: FlatOutput
    eta: Expression | None
    dn: Expression | None
    J: int | str
    h: HValues
    calibration: dict | None
    e: int = 1
    interpolation: str = DEFAULT_INTERPOLATION
    J_tol: float = AUTO_J_TOL
    J_max: int = AUTO_J_MAX
    start: dict | None = None
    report_times: list = field(default_factory=list)
    report_variables: list = field(default_factory=list)
    raw: dict = field(default_factory=dict, repr=False)
    path: str | None = None
    tracking: Tracking = field(default_factory=Tracking)
    compare: Mapping = field(default_factory=dict)
    known: tuple = ()
    parameters: tuple = ()
    boundary: Mapping = field(default_factory=dict)
    bounded: BoundedSettings = field(default_factory=BoundedSettings)

    @property
    def t_nodes(self) -> np.ndarray:
        n = int(round((self.t1 - self.t0) / self.step))
        return np.linspace(self.t0, self.t1, n + 1)

    @property
    def free_parameters(self) -> tuple:
        """The parameters the bounded planner chooses (:class:`Parameter` with ``free``), in file order."""
        return tuple(p for p in self.parameters if p.free)

    def parameter_values(self) -> dict:
        """Every parameter's value.

        Returns
        -------
        dict
            Name -> value.
        """
        return {p.name: p.value for p in self.parameters}

    def at(self, values: Mapping[str, float]) -> Scenario:
        """The member of the scenario's family with the given parameter values, every parameter fixed.

        The flat outputs, the time span and grid, the boundary trims and the calibration are rebuilt
        from the file with the values; the aircraft (possibly perturbed), tracking, comparison settings
        and recorded violations are this scenario's.

        Parameters
        ----------
        values : mapping
            Parameter name -> value (the others keep theirs); each within its range.

        Returns
        -------
        Scenario
            With no free parameter (:attr:`free_parameters` empty): its plan is a plain plan.

        Raises
        ------
        InputError
            An unknown parameter, a value outside its range, or an expression or grid the values make
            invalid.
        gna.errors.GflatError
            A boundary trim or the calibration that does not converge at these values.
        """
        from dataclasses import replace

        known = {p.name: p for p in self.parameters}
        for k, v in values.items():
            if k not in known:
                raise InputError(unknown_key_message(k, tuple(known), f"{self.name} parameters"))
            p = known[k]
            if not (isinstance(v, (int, float)) and p.lower - 1e-12 * max(1.0, abs(p.lower)) <= v):
                raise InputError(f"{self.name}: parameter {k} = {v!r} is outside [{p.lower:g}, {p.upper:g}]")
            if not v <= p.upper + 1e-12 * max(1.0, abs(p.upper)):
                raise InputError(f"{self.name}: parameter {k} = {v!r} is outside [{p.lower:g}, {p.upper:g}]")
        data = dict(self.raw)
        table = {k: dict(v) for k, v in (self.raw.get("parameters") or {}).items()}
        for k, v in values.items():
            table[k]["value"] = min(max(float(v), known[k].lower), known[k].upper)
        data["parameters"] = table
        new = scenario_from_dict(
            data, where=self.path or self.name, J=self.J, path=self.path, aircraft=self.aircraft, member=True
        )
        return replace(
            self,
            t1=new.t1,
            step=new.step,
            x=new.x,
            y=new.y,
            z=new.z,
            zeta=new.zeta,
            eta=new.eta,
            dn=new.dn,
            h=new.h,
            start=new.start,
            calibration=new.calibration,
            parameters=new.parameters,
            boundary=new.boundary,
            raw=data,
        )

    def problem(self) -> FlatProblem:
        """The flat planning problem of this scenario.

        Returns
        -------
        FlatProblem
            Aircraft, environment, flat outputs, eta or fixed rudder, first-iterate H values and
            stage-2 starting values.
        """
        fields = (self.aircraft, self.env, self.x, self.y, self.z, self.zeta, self.eta, self.dn, self.h, self.start)
        kept = self.__dict__.get("_problem")
        if kept is not None and len(kept[0]) == len(fields) and all(a is b for a, b in zip(kept[0], fields)):
            return kept[1]  # the same problem (immutable): its system and traced programs are reused
        prob = FlatProblem(*fields)
        self.__dict__["_problem"] = (fields, prob)
        return prob


def _catalogue() -> dict[str, Path]:
    return bundled("planners", "scenarios")


def list_scenarios() -> list[str]:
    """Names of the bundled scenarios.

    Returns
    -------
    list of str
    """
    return list(_catalogue())


def _num(table: Mapping, key: str, where: str, default: Any = ...) -> float:
    if key not in table:
        if default is ...:
            raise InputError(f"{where}: missing {key!r}")
        return default
    v = table[key]
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(float(v)):
        raise InputError(f"{where}: {key} must be a finite number, got {v!r}")
    return float(v)


def load_scenario(name_or_path: str | Path, J: int | None = None) -> Scenario:
    """Load a bundled scenario by name, or a scenario TOML file by path.

    Parameters
    ----------
    name_or_path : str or pathlib.Path
        A bundled name (``gtm-aileron-roll``) or the path of a ``.toml`` file.
    J : int or "auto", optional
        Number of generalized-flatness iterations (or ``"auto"``: the convergence test of
        :func:`planners.generalized.choose_J`), instead of the file's.

    Returns
    -------
    Scenario

    Raises
    ------
    InputError
        Unknown scenario name; a missing file, a folder or a file not named ``.toml``; an
        unreadable or non-UTF-8 file; invalid TOML; a file that does not follow the scenario
        schema (``docs/scenarios.md``); a bad expression or inconsistent options.
    """
    cat = _catalogue()
    path = find_file(name_or_path, cat, "scenario")
    if path is None:
        raise InputError(
            f"unknown scenario {str(name_or_path)!r}; bundled scenarios: {', '.join(cat)} "
            f"(or give the path of a .toml file)"
        )
    return scenario_from_dict(read_toml(path), where=path.name, J=J, path=str(path))


def scenario_from_dict(
    data: Mapping[str, Any],
    where: str = "scenario",
    J: int | None = None,
    path: str | None = None,
    *,
    aircraft: Aircraft | None = None,
    member: bool = False,
) -> Scenario:
    """Build a :class:`Scenario` from the parsed TOML structure.

    Parameters
    ----------
    data : mapping
        The parsed file (``planners/schemas/scenario.schema.json``).
    where : str
        The file's name, for messages.
    J : int or "auto", optional
        Number of generalized-flatness iterations (or ``"auto"``: the convergence test of
        :func:`planners.generalized.choose_J`), instead of the file's.
    path : str, optional
        The file's path: an aircraft path in the file is resolved from its folder.
    aircraft : Aircraft, optional
        The aircraft, instead of loading the file's (:meth:`Scenario.at`: the same, possibly perturbed).
    member : bool
        The data of one member of a family (:meth:`Scenario.at`): already checked against the schema, and
        every parameter fixed at its value.

    Returns
    -------
    Scenario

    Raises
    ------
    InputError
        One line naming the file, the table, the key and the value: an unknown key (with the closest
        known one), conflicting keys, a wrong type, an unsafe ``name``, a constant or parameter shadowing
        a built-in name, a parameter outside its range, a bad expression, spline, boundary or grid, or a
        boundary trim that does not converge.
    """
    if not isinstance(data, Mapping):
        raise InputError(f"{where}: a scenario is a table of tables, got {type(data).__name__}")
    if not member:
        validate(data, load_schema("planners", "schemas", "scenario.schema.json"), where)
    if "name" in data:
        name = check_name(data["name"], "name", where)
    else:
        name = check_name(Path(path).stem if path else "scenario", "name (from the file name)", where)
    if "aircraft" not in data:
        raise InputError(f"{where}: missing 'aircraft'")
    if aircraft is None:
        aircraft = load_aircraft(str(data["aircraft"]), base=Path(path).parent if path else None)
    consts = data.get("constants", {})
    reserved = set(CONSTANTS) | set(FUNCTIONS) | {"t"}
    for k, v in consts.items():
        _num(consts, k, f"{where} [constants]")
        if k in reserved:
            kind = "function" if k in FUNCTIONS else ("time variable" if k == "t" else "built-in constant")
            raise InputError(f"{where} [constants]: {k} = {v!r} would shadow the {kind} {k!r}; choose another name")
    parameters = _parameters(data.get("parameters", {}), consts, reserved, f"{where} [parameters]", member)
    consts = {**consts, **{p.name: p.value for p in parameters}}
    tm = data["time"]
    t0, t1 = _time_value(tm, "t0", consts, f"{where} [time]"), _time_value(tm, "t1", consts, f"{where} [time]")
    if ("step" in tm) == ("nodes" in tm):
        raise InputError(f"{where} [time]: give either step (the node step [s]) or nodes (their number), not both")
    if "nodes" in tm:
        nodes = tm["nodes"]
        if isinstance(nodes, bool) or not isinstance(nodes, int) or not 2 <= nodes <= MAX_NODES + 1:
            raise InputError(f"{where} [time]: nodes must be a whole number in 2..{MAX_NODES + 1}, got {nodes!r}")
        step = (t1 - t0) / (nodes - 1) if t1 > t0 else 0.0
    else:
        step = _num(tm, "step", f"{where} [time]")
    for key, v in (("t0", t0), ("t1", t1)):
        if abs(v) > MAX_TIME:
            raise InputError(f"{where} [time]: {key} = {v:g} s is beyond +-{MAX_TIME:g} s")
    if not t1 > t0:
        raise InputError(f"{where} [time]: t1 = {t1} must be after t0 = {t0}")
    if not step > 0 or step > t1 - t0:
        raise InputError(f"{where} [time]: step must be in (0, t1 - t0], got {step}")
    n_steps = (t1 - t0) / step
    if n_steps > MAX_NODES:
        raise InputError(
            f"{where} [time]: {n_steps:.0f} steps exceed the limit of {MAX_NODES} nodes; use a larger step"
        )
    if abs(n_steps - round(n_steps)) > 1e-9 * n_steps:
        raise InputError(
            f"{where} [time]: step {step:g} s does not divide the span {t1 - t0:g} s ({n_steps:.6g} steps)"
        )
    env = _environment(data.get("environment", {}), f"{where} [environment]")
    fo = data["flat_outputs"]
    ends = {}  # the boundary trims, once eta is known

    def expr(key, default=...):
        if key not in fo:
            if default is ...:
                raise InputError(f"{where} [flat_outputs]: missing {key!r}")
            return default
        w = f"{where} [flat_outputs] {key}"
        if isinstance(fo[key], Mapping):
            return _spline(fo[key], key, consts, t0, t1, ends, w)
        return compile_expression(fo[key], consts, where=w)

    kind = str(fo.get("zeta", "beta"))
    if kind not in FLAT_KINDS:
        raise InputError(f"{where} [flat_outputs]: zeta must be one of {', '.join(FLAT_KINDS)}, got {kind!r}")
    for key in ("f1", "f2"):
        if key in fo and kind != "mix":
            raise InputError(
                f"{where} [flat_outputs]: {key} = {fo[key]!r} is used only with zeta = 'mix' (here zeta = {kind!r})"
            )
    zeta = FlatOutput(
        kind,
        expr("zeta_value", compile_expression(0.0)),
        expr("f1", None) if kind == "mix" else None,
        expr("f2", None) if kind == "mix" else None,
    )
    eta = expr("eta", None)
    dn = expr("dn", None)
    if eta is None and dn is None:
        eta = compile_expression(0.0)
    if "boundary" in data:
        ends.update(_boundary(data["boundary"], aircraft, env, eta, zeta, consts, (t0, t1), f"{where} [boundary]"))
    x_out, y_out, z_out = expr("x"), expr("y"), expr("z")
    gen = data.get("generalized", {})
    J_file = _iterations(gen.get("J", 0), f"{where} [generalized]")
    stray = [k for k in ("J_tol", "J_max") if k in gen and J_file != AUTO_J]
    if stray:
        raise InputError(
            f'{where} [generalized]: {" and ".join(stray)} {"apply" if len(stray) > 1 else "applies"} only to J = "auto" (here J = '
            f'{J_file}); remove {"them" if len(stray) > 1 else "it"} or set J = "auto"'
        )
    J = J_file if J is None else _iterations(J, "J (given instead of the file's)")
    e = check_output_order(gen.get("e", 1), f"{where} [generalized]")
    interpolation = check_interpolation(gen.get("interpolation", DEFAULT_INTERPOLATION), f"{where} [generalized]")
    J_tol = _num(gen, "J_tol", f"{where} [generalized]", AUTO_J_TOL)
    if J_tol < 0:
        raise InputError(f"{where} [generalized]: J_tol must be >= 0 [m/s^2, rad/s], got {J_tol:g}")
    J_max = check_iterations(gen.get("J_max", AUTO_J_MAX), f"{where} [generalized] J_max")
    cal = data.get("calibration")
    h = HValues()
    start = None
    if "h" in data:
        hv = data["h"]
        h = HValues(*(_num(hv, k, f"{where} [h]", 0.0) for k in ("p", "q", "r", "dl", "dm", "dn")))
    if cal is not None:
        h, start = _calibrate(
            aircraft,
            env,
            cal,
            f"{where} [calibration]",
            -float(np.mean(np.broadcast_to(z_out(np.linspace(t0, t1, 5)), (5,)))),
        )
    rep = data.get("report", {})
    times = rep.get("times", [])
    if not isinstance(times, list) or not all(
        isinstance(v, (int, float)) and not isinstance(v, bool) and t0 <= v <= t1 for v in times
    ):
        raise InputError(f"{where} [report]: times must be a list of numbers within [{t0:g}, {t1:g}], got {times!r}")
    from .plan import PLAN_VARIABLES

    rvars = rep.get("variables", ["F", "dl", "dm", "dn"])
    if not isinstance(rvars, list) or any(v not in PLAN_VARIABLES for v in rvars):
        raise InputError(f"{where} [report]: variables must be among {', '.join(PLAN_VARIABLES)}, got {rvars!r}")
    return Scenario(
        name=name,
        description=str(data.get("description", "")),
        aircraft=aircraft,
        env=env,
        t0=t0,
        t1=t1,
        step=step,
        x=x_out,
        y=y_out,
        z=z_out,
        zeta=zeta,
        eta=eta,
        dn=dn,
        J=J,
        h=h,
        e=e,
        interpolation=interpolation,
        J_tol=J_tol,
        J_max=J_max,
        calibration=dict(cal) if cal is not None else None,
        start=start,
        report_times=[float(v) for v in times],
        report_variables=[str(v) for v in rvars],
        raw=dict(data),
        path=path,
        tracking=_tracking(data.get("tracking", {}), kind, J_max if J == AUTO_J else J, f"{where} [tracking]"),
        compare=_compare(data.get("compare", {}), f"{where} [compare]"),
        known=_known(data.get("verdicts", {}), f"{where} [verdicts]"),
        parameters=parameters,
        boundary={e.side: e for e in ends.values()},
        bounded=bounded_settings(data.get("bounded", {}), f"{where} [bounded]"),
    )


def _parameters(table: Mapping, consts: Mapping, reserved: set, where: str, member: bool) -> tuple:
    """The ``[parameters]`` table: each ``{value, min, max}`` checked (names, order of the bounds)."""
    out = []
    for name, spec in table.items():
        w = f"{where} {name}"
        if name in reserved:
            kind = "function" if name in FUNCTIONS else ("time variable" if name == "t" else "built-in constant")
            raise InputError(f"{w}: the parameter would shadow the {kind} {name!r}; choose another name")
        if name in consts:
            raise InputError(f"{w}: the name is also a constant of [constants]; choose another name")
        if not isinstance(spec, Mapping):
            raise InputError(f"{w}: a parameter is a table {{value = ..., min = ..., max = ...}}, got {spec!r}")
        for key in spec:
            if key not in PARAMETER_KEYS:
                raise InputError(unknown_key_message(key, PARAMETER_KEYS, w))
        value, lo, hi = (_num(spec, k, w) for k in ("value", "min", "max"))
        if not lo <= hi:
            raise InputError(f"{w}: min = {lo:g} is above max = {hi:g}")
        if not lo <= value <= hi:
            raise InputError(f"{w}: value = {value:g} is outside [min, max] = [{lo:g}, {hi:g}]")
        out.append(
            Parameter(name, value, lo, hi, free=(lo < hi) and not member, description=str(spec.get("description", "")))
        )
    return tuple(out)


def _time_value(table: Mapping, key: str, consts: Mapping, where: str) -> float:
    """``[time] t0`` or ``t1``: a number, or an expression of the constants and parameters (not of t)."""
    if key not in table:
        raise InputError(f"{where}: missing {key!r}")
    v = table[key]
    if isinstance(v, str):
        e = compile_expression(v, consts, where=f"{where} {key}")
        if e.depends_on_t:
            raise InputError(f"{where}: {key} = {v!r} may use constants and parameters, not t")
        v = float(e(0.0))
        if not math.isfinite(v):
            raise InputError(f"{where}: {key} = {table[key]!r} is {v}")
        return v
    return _num(table, key, where)


def _values(spec: Any, consts: Mapping, what: str, where: str) -> list:
    """A list of numbers or expressions of the constants and parameters (not of t), as floats."""
    if not isinstance(spec, list):
        raise InputError(f"{where}: {what} must be a list of numbers or expressions of the parameters, got {spec!r}")
    out = []
    for i, v in enumerate(spec):
        e = compile_expression(v, consts, where=f"{where} {what} item {i + 1}")
        if e.depends_on_t:
            raise InputError(f"{where}: {what} item {i + 1} = {v!r} may use constants and parameters, not t")
        out.append(float(e(0.0)))
    return out


def _spline(spec: Mapping, key: str, consts: Mapping, t0: float, t1: float, ends: Mapping, where: str) -> Expression:
    """A spline flat output ``{basis, coefficients, start, end}`` (:mod:`planners.splines`)."""
    for k in spec:
        if k not in SPLINE_KEYS:
            raise InputError(unknown_key_message(k, SPLINE_KEYS, where))
    basis = spec.get("basis", "bezier")
    if basis not in BASES:
        raise InputError(f"{where}: basis must be one of {', '.join(BASES)}, got {basis!r}")
    conditions = {}
    for side in ("start", "end"):
        given = spec.get(side, "boundary" if side in ends else [])
        if isinstance(given, str) and given == "boundary":
            if key not in ("x", "y", "z"):
                raise InputError(f"{where}: {side} = 'boundary' applies to x, y and z only; give a list of derivatives")
            if side not in ends:
                raise InputError(f"{where}: {side} = 'boundary' needs a [boundary.{side}] table")
            conditions[side] = list(ends[side].derivatives[key])
        else:
            conditions[side] = _values(given, consts, f"{side} (value and derivatives)", where)
    interior = _values(spec.get("coefficients", []), consts, "coefficients", where)
    try:
        points = bezier_points(conditions["start"], conditions["end"], interior, t0, t1)
    except InputError as exc:
        raise InputError(f"{where}: {exc}") from None
    n = points.size - 1
    return bezier_expression(
        points,
        t0,
        t1,
        f"bezier(degree {n} on [{t0:g}, {t1:g}] s; {len(conditions['start'])} start and "
        f"{len(conditions['end'])} end conditions, {len(interior)} coefficients)",
    )


def _boundary(
    table: Mapping, aircraft: Aircraft, env: Environment, eta, zeta: FlatOutput, consts: Mapping, span, where: str
) -> dict:
    """The ``[boundary]`` table: each side a full-model trim at a position and heading (:class:`BoundaryState`)."""
    from gna.trim import TRIM_VARIABLES, trim

    keys = ("order", "start", "end")
    for k in table:
        if k not in keys:
            raise InputError(unknown_key_message(k, keys, where))
    order = table.get("order", DEFAULT_BOUNDARY_ORDER)
    if isinstance(order, bool) or not isinstance(order, int) or not 0 <= order <= 8:
        raise InputError(
            f"{where}: order must be a whole number in 0..8 (derivatives of x, y, z matched), got {order!r}"
        )
    if eta is None:
        raise InputError(f"{where}: boundary trims need a prescribed eta (not a fixed rudder dn)")
    out = {}
    for side, t in zip(("start", "end"), span):
        if side not in table:
            continue
        spec, w = table[side], f"{where[:-1]}.{side}]"
        if not isinstance(spec, Mapping):
            raise InputError(f"{w}: must be a table of trim variables, altitude, x, y, chi")
        for k in spec:
            if k not in TRIM_VARIABLES + BOUNDARY_KEYS:
                raise InputError(unknown_key_message(k, TRIM_VARIABLES + BOUNDARY_KEYS, w))
        val = {k: _values([spec[k]], consts, k, w)[0] for k in spec}
        if "altitude" not in val:
            raise InputError(f"{w}: missing 'altitude'")
        fixed = {k: val[k] for k in TRIM_VARIABLES if k in val}
        for k, v in BOUNDARY_DEFAULTS:
            if len(fixed) < 4 and k not in fixed:
                fixed[k] = v
        if len(fixed) != 4:
            raise InputError(
                f"{w}: fix at most four of the trim variables ({', '.join(TRIM_VARIABLES)}), got {', '.join(fixed)}"
            )
        eta_t = float(np.real(eta(t)))
        try:
            tr = _boundary_trim(trim, aircraft, fixed, val["altitude"], env, eta_t)
        except GflatError as exc:
            raise InputError(f"{w}: the trim failed: {exc}") from None
        v = tr.values
        zv = float(np.real(zeta.value(t)))
        if zeta.kind in ("beta", "mu", "F") and abs(v[zeta.kind] - zv) > 1e-9 * max(1.0, abs(zv)):
            raise InputError(
                f"{w}: the fourth flat output {zeta.kind} = {zv:g} at t = {t:g} s differs from the trim's "
                f"{zeta.kind} = {v[zeta.kind]:g}; fix {zeta.kind} in the trim or change zeta_value"
            )
        pos = (val.get("x", 0.0), val.get("y", 0.0), -val["altitude"])
        der = steady_derivatives(v["V"], v["gamma"], val.get("chi", 0.0), v["chi_dot"], pos, order)
        out[side] = BoundaryState(side, float(t), tr, pos[0], pos[1], val.get("chi", 0.0), val["altitude"], der)
    return out


#: The boundary trims of the latest members (:meth:`Scenario.at`): a bounded plan's members share their ends
#: unless a parameter moves them, and a trim costs more than a third of a member's plan.
_TRIMS: dict = {}
_TRIMS_KEPT = 64


def _boundary_trim(trim, aircraft: Aircraft, fixed: Mapping, altitude: float, env: Environment, eta: float):
    """``trim(aircraft, fixed, altitude, env, eta, model="full")``, kept for the same aircraft, environment and
    values (objects by identity, kept alive with the entry)."""
    key = (id(aircraft), id(env), tuple(sorted((k, float(v)) for k, v in fixed.items())), float(altitude), eta)
    hit = _TRIMS.get(key)
    if hit is not None and hit[0] is aircraft and hit[1] is env:
        return hit[2]
    tr = trim(aircraft, fixed, altitude=altitude, env=env, eta=eta, model="full")
    if len(_TRIMS) >= _TRIMS_KEPT:
        _TRIMS.pop(next(iter(_TRIMS)))
    _TRIMS[key] = (aircraft, env, tr)
    return tr


def _known(table: Mapping, where: str) -> tuple:
    """The ``[verdicts]`` table's ``known`` records (:class:`KnownViolation`; keys, names and the reason's
    presence checked by the schema), each name once and each reason said."""
    out = []
    for i, rec in enumerate(table.get("known", [])):
        name, reason = rec["name"], rec["reason"].strip()
        if not reason:
            raise InputError(f"{where} known #{i + 1} ({name}): the reason is blank; say why the scenario keeps it")
        if name in [k.name for k in out]:
            raise InputError(f"{where} known #{i + 1}: {name!r} recorded twice")
        out.append(KnownViolation(name, reason))
    return tuple(out)


def _compare(table: Any, where: str) -> Mapping:
    """The ``[compare]`` table, its keys checked (:data:`COMPARE_KEYS`); the values are the harness's."""
    if not isinstance(table, Mapping):
        raise InputError(f"{where}: must be a table, got {table!r}")
    for key in table:
        if key not in COMPARE_KEYS:
            raise InputError(unknown_key_message(key, COMPARE_KEYS, where))
    return table


def _iterations(J, where: str) -> int | str:
    """``[generalized] J``: a whole number in 0..30 or ``"auto"``."""
    if isinstance(J, str) and J == AUTO_J:
        return J
    if isinstance(J, str):
        raise InputError(f'{where}: J must be a whole number, got {J!r} (0 to 30, or "auto")')
    return check_iterations(J, where)


def _tracking(table: Mapping[str, Any], kind: str, J: int, where: str) -> Tracking:
    """Parse the ``[tracking]`` table (lambdas checked against the fourth flat output ``kind``)."""
    for key in table:
        if key not in TRACKING_KEYS:
            raise InputError(unknown_key_message(key, TRACKING_KEYS, where))
    names = ("I1", "I2", "I3") if kind == "F" else ("I1", "I2", "I3", "I4")
    lengths = (5, 5, 5) if kind == "F" else (3, 5, 5, 3)
    lam = table.get("lambdas", 1.0)
    if isinstance(lam, Mapping):
        for key in lam:
            if key not in names:
                raise InputError(
                    unknown_key_message(key, names, f"{where} lambdas")
                    + (" (no I4 with the thrust flat output F)" if key == "I4" else "")
                )
        lists = []
        for name, n in zip(names, lengths):
            if name not in lam:
                raise InputError(f"{where} lambdas: missing {name} (a list of {n} positive numbers)")
            v = lam[name]
            if not isinstance(v, list) or len(v) != n:
                raise InputError(f"{where} lambdas: {name} must be a list of {n} positive numbers, got {v!r}")
            lists.append(tuple(_lambda(x, f"{where} lambdas {name}") for x in v))
        lam = tuple(lists)
    else:
        lam = _lambda(lam, f"{where} lambdas")
    it = table.get("feedforward_iterate", -1)
    if isinstance(it, bool) or not isinstance(it, int):
        raise InputError(f"{where}: feedforward_iterate must be a whole number, got {it!r}")
    if not -(J + 1) <= it <= J:
        raise InputError(
            f"{where}: feedforward_iterate = {it} is not an iterate of the plan (0..{J}, or -1 for the last)"
        )
    sat = table.get("saturate", True)
    if not isinstance(sat, bool):
        raise InputError(f"{where}: saturate must be true or false, got {sat!r}")
    cdt = table.get("controller_dt", "step" if DEFAULT_CONTROLLER_DT is None else DEFAULT_CONTROLLER_DT)
    if isinstance(cdt, str) and cdt == "step":
        cdt = None
    elif isinstance(cdt, bool) or not isinstance(cdt, (int, float)) or not (math.isfinite(cdt) and cdt > 0):
        raise InputError(
            f'{where}: controller_dt must be a positive number of seconds or "step" (every engine step), got {cdt!r}'
        )
    pert = table.get("perturbation")
    if pert is not None:
        pert = perturbation_from_dict(pert, f"{where[:-1]}.perturbation]")
    design = check_design(table.get("design", "paper"), f"{where} design")
    tol = table.get("tolerances", {})
    tw = f"{where[:-1]}.tolerances]"
    if not isinstance(tol, Mapping):
        raise InputError(f"{tw} must be a table position/velocity/angle/rate -> number, got {tol!r}")
    for key in tol:
        if key not in DEFAULT_TOLERANCES:
            raise InputError(unknown_key_message(key, tuple(DEFAULT_TOLERANCES), tw))
    try:
        tolerances = TrackingTolerances(**tol)
    except InputError as exc:
        raise InputError(f"{tw}: {exc}") from None
    return Tracking(
        design=design,
        tolerances=tolerances,
        lambdas=lam,
        feedforward_iterate=int(it),
        saturate=sat,
        controller_dt=None if cdt is None else float(cdt),
        perturbation=pert,
    )


def _lambda(v: Any, where: str) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(float(v)) or not v > 0:
        raise InputError(f"{where}: pole magnitudes must be positive finite numbers [1/s], got {v!r}")
    return float(v)


def _environment(table: Mapping[str, Any], where: str) -> Environment:
    kind = str(table.get("density", "isa")).lower()
    g = _num(table, "g", where, 9.80665)
    ge = None
    if "ground_effect" in table:  # [environment.ground_effect]: present = on (gna.ground_effect)
        t, w = table["ground_effect"], f"{where[:-1]}.ground_effect]"
        ge = GroundEffect(
            _num(t, "elevation", w, 0.0), _num(t, "oswald", w, 0.8), _num(t, "section_lift_slope", w, 2.0 * math.pi)
        )
    if kind == "isa":
        if "rho" in table:
            raise InputError(
                f"{where}: rho = {table['rho']!r} is used only with density = 'constant' (here density = 'isa')"
            )
        return Environment(ISA(), g, ge)
    if kind == "constant":
        return Environment(ConstantDensity(_num(table, "rho", where)), g, ge)
    raise InputError(f"{where}: density must be 'isa' or 'constant', got {kind!r}")


def _calibrate(
    aircraft: Aircraft, env: Environment, cal: Mapping[str, Any], where: str, altitude: float
) -> tuple[HValues, dict]:
    """H values from a full-model steady-flight calibration (paper: "calibration functions"),
    and the calibration's alpha, beta, mu as stage-2 starting values."""
    from gna.trim import trim

    fixed = {k: _num(cal, k, where) for k in cal if k not in ("altitude",)}
    alt = _num(cal, "altitude", where, altitude)
    try:
        t = trim(aircraft, fixed, altitude=alt, env=env, model="full", check_envelope=False)
    except GflatError as exc:
        raise InputError(f"{where}: calibration failed: {exc}") from None
    v = t.values
    return (HValues(v["p"], v["q"], v["r"], v["dl"], v["dm"], v["dn"]), {k: v[k] for k in ("alpha", "beta", "mu")})
