"""Scenario files of the chained systems (``gflat plan first-order-lag``, ``gflat plan my-lag.toml``).

A chained-system scenario is a TOML file with a ``system`` key naming a system of
:data:`SPECS` (the aircraft scenarios of :mod:`planners.scenario` have none)::

    name = "first-order-lag"
    description = "..."
    system = "first-order-lag"

    [parameters]          # the system's (defaults in SPECS)
    eps = 0.1

    [constants]           # optional names for the expressions
    w = 1.0

    [time]
    t0 = 0.0
    t1 = 3.0
    step = 0.25

    [flat_outputs]        # expressions of t (planners.expressions)
    x = "sin(w*t)"

    [generalized]
    J = 12                # iterations (fixed point) or depth (Newton)
    e = 1                 # order of the last stage's unknowns in the last iterate
    method = "fixed-point"   # or "newton"

Unknown keys are refused with the closest known one, as in the aircraft scenarios.  Bundled
files live in ``planners/systems/scenarios/``.  Each system has its exact check of a plan
(:attr:`SystemSpec.check`): the lag's planned ``y`` against the exact ``(1 + eps d/dt)^-1 x'``
(:func:`planners.systems.first_order_lag.lag_exact`), the car's exact off-axle model flown open
loop with the planned controls.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from gna.catalogue import bundled
from gna.errors import InputError
from gna.schema import SAFE_NAME, check_name, did_you_mean, find_file, read_toml, validate

from ..chained import ChainedPlan, ChainedSystem, generalized_parametrization
from ..expressions import CONSTANTS, FUNCTIONS, Expression, compile_expression
from ..flat import check_iterations
from ..generalized_newton import newton_parametrization
from ..scenario import _num
from .car_trailers import CarTrailers, car_two_trailers, open_loop_error
from .first_order_lag import first_order_lag, lag_exact

#: Generalized-flatness methods of a chained scenario.
METHODS = ("fixed-point", "newton")
#: At most this many grid steps (the aircraft scenarios' bound).
MAX_STEPS = 20000


@dataclass(frozen=True)
class SystemSpec:
    """What a scenario file may set for one system, and how a plan of it is checked.

    Attributes
    ----------
    build : callable
        ``build(parameters: dict) -> ChainedSystem``.
    parameters : mapping of str -> (float, str, str)
        Each parameter's default, unit and description.
    check : callable
        ``check(plan, scenario) -> dict`` of named errors of the plan against the exact model; raises
        :class:`gna.errors.DomainError` when the exact model cannot be evaluated along the plan.
    description : str
        The system.
    verdict : callable, optional
        ``verdict(checks, scenario) -> str or None``: why the plan is not a solution of the exact
        model (None: it is, or the system has no limit, e.g. the car's open-loop error is reported only).
    """

    build: Callable
    parameters: Mapping
    check: Callable
    description: str
    verdict: Callable | None = None


_LAG_ERROR = "max |y - (1 + eps d/dt)^-1 x'| at the nodes"
_LAG_SCALE = "max |(1 + eps d/dt)^-1 x'| at the nodes"
#: Largest relative error of the lag's planned y accepted as a solution (the series of the bundled
#: scenario reaches 1e-13; a diverging one is off by orders of magnitude).
LAG_RTOL = 1e-6


def _lag_check(plan: ChainedPlan, sc: ChainedScenario) -> dict:
    tn = plan.t_nodes
    y = np.real(plan.iterates[-1]["y"].constant_term)
    ref = lag_exact(sc.flat_outputs["x"], sc.parameters["eps"], tn)
    return {_LAG_ERROR: float(np.max(np.abs(y - ref))), _LAG_SCALE: float(np.max(np.abs(ref)))}


def _lag_verdict(checks: Mapping, sc: ChainedScenario) -> str | None:
    err, scale = checks[_LAG_ERROR], max(checks[_LAG_SCALE], 1e-300)
    if np.isfinite(err) and err <= LAG_RTOL * scale:
        return None
    return (
        f"the planned y is not the lag's output: {_LAG_ERROR} = {err:.3g}, {err / scale:.3g} of its size "
        f"(> {LAG_RTOL:g}); the series (1 + eps d/dt)^-1 = sum (-eps d/dt)^k converges only where eps "
        f"times the frequencies of x' stays below 1 (eps = {sc.parameters['eps']:g} s)"
    )


def _car_geometry(p: Mapping) -> CarTrailers:
    return CarTrailers(l0=p["l0"], d1=p["d1"], L1=p["L1"], d2=p["d2"], L2=p["L2"])


def _car_check(plan: ChainedPlan, sc: ChainedScenario) -> dict:
    err = open_loop_error(plan, _car_geometry(sc.parameters), sc.flat_outputs["x2"], sc.flat_outputs["y2"])
    return {"open-loop error of the exact off-axle model [m]": err}


#: The chained systems a scenario file may name.
SPECS: dict[str, SystemSpec] = {
    "first-order-lag": SystemSpec(
        build=lambda p: first_order_lag(p["eps"]),
        parameters={"eps": (0.1, "s", "time constant of the lag x' = y + eps y'")},
        check=_lag_check,
        verdict=_lag_verdict,
        description="x' = y + eps y', x a generalized flat output (paper, 'Generalized flatness from the "
        "theoretical standpoint')",
    ),
    "car-two-trailers": SystemSpec(
        build=lambda p: car_two_trailers(_car_geometry(p), p["speed"]),
        parameters={
            "l0": (2.7, "m", "car wheelbase"),
            "d1": (0.8, "m", "trailer 1 hitch offset behind the car's rear axle (0: on-axle)"),
            "L1": (3.0, "m", "trailer 1 hitch-to-axle length"),
            "d2": (0.6, "m", "trailer 2 hitch offset behind trailer 1's axle (0: on-axle)"),
            "L2": (3.0, "m", "trailer 2 hitch-to-axle length"),
            "speed": (5.0, "m/s", "typical forward speed: Newton's starting value of the speeds"),
        },
        check=_car_check,
        description="car with two trailers hitched off-axle (Rouchon, Fliess, Levine and Martin 1993), flat "
        "output (x2, y2) of the on-axle approximation",
    ),
}


def _schema(system: str | None) -> dict:
    """JSON Schema of a chained scenario file (the parameters of ``system``, or any when unknown)."""
    num = {"type": "number"}
    spec = SPECS.get(system) if system else None
    params = (
        {k: dict(num, description=f"{d} [{u}], default {v:g}") for k, (v, u, d) in spec.parameters.items()}
        if spec
        else {}
    )
    flat = {
        z: {"type": ["string", "number"], "description": "flat output, expression of t"}
        for z in (spec.build({k: v[0] for k, v in spec.parameters.items()}).flat_outputs if spec else ())
    }

    def table(props, required=()):
        out = {"type": "object", "properties": props, "additionalProperties": False}
        if required:
            out["required"] = list(required)
        return out

    return {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "type": "object",
        "additionalProperties": False,
        "required": ["system", "time", "flat_outputs"],
        "properties": {
            "name": {"type": "string", "pattern": SAFE_NAME.pattern},
            "description": {"type": "string"},
            "system": {"type": "string", "enum": list(SPECS)},
            "parameters": table(params),
            "constants": {"type": "object", "additionalProperties": num},
            "time": table({"t0": num, "t1": num, "step": dict(num, exclusiveMinimum=0)}, ("t0", "t1", "step")),
            "flat_outputs": table(flat, tuple(flat)),
            "generalized": table(
                {
                    "J": {"type": "integer", "minimum": 0},
                    "e": {"type": "integer", "minimum": 1, "maximum": 20},
                    "method": {"type": "string", "enum": list(METHODS)},
                }
            ),
        },
    }


@dataclass
class ChainedScenario:
    """A parsed chained-system scenario.

    Attributes
    ----------
    name : str
        Name (output folder).
    description : str
        Free text.
    system_name : str
        A key of :data:`SPECS`.
    parameters : dict of str -> float
        The system's parameters, defaults filled in.
    system : ChainedSystem
        The system built from them.
    t0, t1, step : float
        Span and grid step [s].
    flat_outputs : dict of str -> Expression
        The flat outputs as expressions of t.
    J : int
        Iterations (fixed point) or depth (Newton).
    e : int
        Order of the last stage's unknowns in the last iterate.
    method : str
        ``"fixed-point"`` or ``"newton"``.
    path : str or None
        The file read.
    raw : dict
        The parsed file.
    """

    name: str
    description: str
    system_name: str
    parameters: dict
    system: ChainedSystem
    t0: float
    t1: float
    step: float
    flat_outputs: dict
    J: int
    e: int = 1
    method: str = "fixed-point"
    path: str | None = None
    raw: dict = field(default_factory=dict, repr=False)

    @property
    def t_nodes(self) -> np.ndarray:
        """The grid nodes [s]."""
        n = int(round((self.t1 - self.t0) / self.step))
        return np.linspace(self.t0, self.t1, n + 1)

    @property
    def spec(self) -> SystemSpec:
        """The system's :class:`SystemSpec`."""
        return SPECS[self.system_name]


def _catalogue() -> dict[str, Path]:
    return bundled("planners", "systems", "scenarios")


def list_chained_scenarios() -> list[str]:
    """Names of the bundled chained-system scenarios.

    Returns
    -------
    list of str
    """
    return list(_catalogue())


def is_chained_scenario(name_or_path: str | Path) -> bool:
    """Whether a scenario argument names a chained-system scenario (bundled, or a TOML file with a ``system`` key).

    Parameters
    ----------
    name_or_path : str or pathlib.Path
        What the user gave ``gflat plan``.

    Returns
    -------
    bool
        False for anything else (an aircraft scenario, or a file that cannot be read: its loader
        reports why).
    """
    key = str(name_or_path)
    if key in _catalogue():
        return True
    path = Path(key)
    if path.suffix != ".toml" or not path.is_file():
        return False
    try:
        return "system" in read_toml(path)
    except InputError:
        return False


def load_chained_scenario(name_or_path: str | Path, J: int | None = None) -> ChainedScenario:
    """Load a bundled chained-system scenario by name, or a chained scenario TOML file by path.

    Parameters
    ----------
    name_or_path : str or pathlib.Path
        A bundled name (``first-order-lag``) or the path of a ``.toml`` file.
    J : int, optional
        Iterations (or Newton depth) instead of the file's.

    Returns
    -------
    ChainedScenario

    Raises
    ------
    InputError
        Unknown name, missing or unreadable file, invalid TOML, an unknown key (with the closest
        known one), a wrong type, a bad expression or grid.
    """
    cat = _catalogue()
    path = find_file(name_or_path, cat, "scenario")
    if path is None:
        raise InputError(
            f"unknown chained-system scenario {str(name_or_path)!r}; bundled: {', '.join(cat)} "
            f"(or give the path of a .toml file)"
        )
    return chained_scenario_from_dict(read_toml(path), where=path.name, J=J, path=str(path))


def chained_scenario_from_dict(
    data: Mapping[str, Any], where: str = "scenario", J: int | None = None, path: str | None = None
) -> ChainedScenario:
    """Build a :class:`ChainedScenario` from a parsed TOML document.

    Parameters
    ----------
    data : mapping
        The parsed file (see the module docstring).
    where : str
        The file's name, for messages.
    J : int, optional
        Iterations instead of the file's.
    path : str, optional
        The file's path.

    Returns
    -------
    ChainedScenario

    Raises
    ------
    InputError
        One line naming the file, the table, the key and the value.
    """
    if not isinstance(data, Mapping):
        raise InputError(f"{where}: a scenario is a table of tables, got {type(data).__name__}")
    system = data.get("system")
    if not isinstance(system, str) or system not in SPECS:
        raise InputError(
            f"{where}: system = {system!r} is not a chained system{did_you_mean(system, SPECS)}; "
            f"known: {', '.join(SPECS)}"
        )
    validate(data, _schema(system), where)
    spec = SPECS[system]
    name = (
        check_name(data["name"], "name", where)
        if "name" in data
        else check_name(Path(path).stem if path else system, "name (from the file name)", where)
    )
    params = {k: v[0] for k, v in spec.parameters.items()}
    for k in data.get("parameters", {}):
        params[k] = _num(data["parameters"], k, f"{where} [parameters]")
    consts = dict(data.get("constants", {}))
    reserved = set(CONSTANTS) | set(FUNCTIONS) | {"t"}
    for k in consts:
        _num(consts, k, f"{where} [constants]")
        if k in reserved:
            raise InputError(f"{where} [constants]: {k} would shadow the built-in name {k!r}; choose another name")
    tm = data["time"]
    t0, t1, step = (_num(tm, k, f"{where} [time]") for k in ("t0", "t1", "step"))
    if not t1 > t0:
        raise InputError(f"{where} [time]: t1 = {t1:g} must be after t0 = {t0:g}")
    n_steps = (t1 - t0) / step
    if step > t1 - t0 or n_steps > MAX_STEPS or abs(n_steps - round(n_steps)) > 1e-9 * n_steps:
        raise InputError(
            f"{where} [time]: step {step:g} s must divide the span {t1 - t0:g} s into at most {MAX_STEPS} steps"
        )
    flat = {
        z: compile_expression(v, consts, where=f"{where} [flat_outputs] {z}") for z, v in data["flat_outputs"].items()
    }
    gen = data.get("generalized", {})
    J_file = check_iterations(gen.get("J", 0), f"{where} [generalized]")
    J = J_file if J is None else check_iterations(J, where)
    try:
        sysm = spec.build(params)
    except (ValueError, ZeroDivisionError) as exc:
        raise InputError(f"{where} [parameters]: {exc}") from None
    return ChainedScenario(
        name=name,
        description=str(data.get("description", "")),
        system_name=system,
        parameters=params,
        system=sysm,
        t0=t0,
        t1=t1,
        step=step,
        flat_outputs=flat,
        J=J,
        e=int(gen.get("e", 1)),
        method=str(gen.get("method", "fixed-point")),
        path=path,
        raw=dict(data),
    )


def plan_chained_scenario(sc: ChainedScenario, J: int | None = None, method: str | None = None) -> ChainedPlan:
    """Plan a chained-system scenario by generalized flatness (:mod:`planners.chained`).

    Parameters
    ----------
    sc : ChainedScenario
        The scenario.
    J : int, optional
        Iterations (fixed point) or depth (Newton), default the scenario's.
    method : {"fixed-point", "newton"}, optional
        Default the scenario's.

    Returns
    -------
    ChainedPlan

    Raises
    ------
    InputError
        An unknown method or a bad J.
    """
    method = sc.method if method is None else method
    if method not in METHODS:
        raise InputError(f"method must be one of {', '.join(METHODS)}, got {method!r}")
    J = sc.J if J is None else check_iterations(J, f"plan {sc.name}")
    zeta: dict[str, Expression] = dict(sc.flat_outputs)
    if method == "newton":
        return newton_parametrization(sc.system, sc.t_nodes, zeta, J=J, e=sc.e)
    return generalized_parametrization(sc.system, sc.t_nodes, zeta, J=J, e=sc.e)
