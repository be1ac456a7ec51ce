"""Comparison settings the user controls: tolerances, windows, output grid, JSBSim step, self-convergence.

A scenario file may carry a ``[compare]`` table; the command line and a
:class:`harness.validation.ValidationCase` override it, which overrides the
defaults (precedence: command line / case > scenario > defaults)::

    [compare]
    dt_out = 0.05                 # output grid of every engine and of the plan comparison [s]
    jsbsim_dt = 0.0020833333      # JSBSim's own step [s], independent of dt_out
    self_convergence = true       # also fly JSBSim at half its step and report that difference
    tolerances = { position = 0.02, angle = 2e-4 }   # absolute, per quantity or per variable
    rtol = { position = 1e-6 }                       # relative to max |reference| over the window
    windows = { "first 10 s" = 10.0, "whole span" = "all" }
    tracking_tolerance = 1.0      # closed loop: largest distance to the flat outputs after settle_time [m]
    settle_time = 5.0             # closed loop: from t0, before the tracking verdict measures [s]

A variable passes when ``max |u - u_ref| <= atol + rtol * max |u_ref|`` over
the window.  Quantities: ``position`` (the distance and x, y, z [m]),
``velocity`` (V [m/s]), ``angle`` (gamma, chi, alpha, beta, mu [rad]),
``rate`` (p, q, r [rad/s]); any trajectory column may be named too (a
variable overrides its quantity).  ``tolerances`` may also be one number (the
same absolute tolerance for every compared variable).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from gna.errors import InputError
from gna.schema import unknown_key_message
from gna.trajectory import COLUMNS, POSITION
from planners.scenario import COMPARE_KEYS  # the keys of a [compare] table: one definition, checked there

from ..metrics import DEFAULT_TOLERANCES, DEFAULT_VARIABLES, DEFAULT_WINDOWS

#: Quantities of the tolerance settings and the variables each covers.
QUANTITIES: dict[str, tuple[str, ...]] = {
    "position": (POSITION, "x", "y", "z"),
    "velocity": ("V",),
    "angle": ("gamma", "chi", "alpha", "beta", "mu"),
    "rate": ("p", "q", "r"),
}


#: Output grid step [s] when neither the command line nor the scenario sets one.
DEFAULT_DT_OUT = 0.05

#: JSBSim's step [s] when neither the command line nor the scenario sets one (the engine's default).
DEFAULT_JSBSIM_DT = 1.0 / 480.0

#: Closed loop: the tracking verdict's tolerance [m] on the largest distance to the flat outputs after the
#: settle time, when the scenario's ``[compare]`` sets none (the 1 m the paper's figures are read at).
DEFAULT_TRACKING_TOLERANCE = 1.0

#: Closed loop: the time from t0 [s] the feedback is given to bring the aircraft onto the flat outputs
#: before the tracking verdict measures, when the scenario's ``[compare]`` sets none.
DEFAULT_SETTLE_TIME = 5.0


def unknown_key(key: str, known, where: str) -> InputError:
    """The error refusing an unknown key, with a "did you mean" suggestion (difflib).

    Parameters
    ----------
    key : str
        The key found.
    known : iterable of str
        The accepted keys.
    where : str
        File and table, for the message.

    Returns
    -------
    InputError
        To raise.
    """
    return InputError(unknown_key_message(key, known, where))


def _number(value, what: str, *, positive: bool) -> float:
    if (
        isinstance(value, bool)
        or not isinstance(value, (int, float))
        or not math.isfinite(value)
        or value < 0
        or (positive and value == 0)
    ):
        raise InputError(f"{what} must be a {'positive' if positive else 'non-negative'} finite number, got {value!r}")
    return float(value)


def expand_tolerances(spec, where: str = "tolerances") -> dict[str, float] | None:
    """Per-variable tolerances of a spec naming quantities or variables.

    Parameters
    ----------
    spec : None, float or mapping str -> float
        ``None``: nothing set; a number: every compared variable
        (:data:`harness.metrics.DEFAULT_VARIABLES`); a mapping quantity
        (:data:`QUANTITIES`) or variable (a trajectory column, or
        ``"position"``) -> tolerance in the variable's SI unit; a variable
        overrides its quantity.
    where : str
        Source, for messages.

    Returns
    -------
    dict or None
        Variable -> tolerance; None when ``spec`` is None.

    Raises
    ------
    InputError
        An unknown key (with a suggestion) or a negative, non-finite or non-numeric value.
    """
    if spec is None:
        return None
    if not isinstance(spec, Mapping):
        v = _number(spec, where, positive=False)
        return {k: v for k in DEFAULT_VARIABLES}
    known = list(QUANTITIES) + [POSITION] + [c for c in COLUMNS if c != POSITION]
    out: dict[str, float] = {}
    for key in spec:
        if key not in known:
            raise unknown_key(key, list(QUANTITIES) + list(DEFAULT_VARIABLES[1:]), where)
    for key, value in spec.items():  # quantities first, variables override them
        if key in QUANTITIES:
            v = _number(value, f"{where}: {key}", positive=False)
            out.update({var: v for var in QUANTITIES[key]})
    for key, value in spec.items():
        if key not in QUANTITIES:
            out[key] = _number(value, f"{where}: {key}", positive=False)
    return out


def parse_windows(spec, where: str = "windows") -> dict[str, float | None] | None:
    """Comparison windows of a spec.

    Parameters
    ----------
    spec : None or mapping str -> float or "all"
        Window name -> duration from t0 [s], or ``"all"`` / None for the whole span.
    where : str
        Source, for messages.

    Returns
    -------
    dict or None
        Name -> duration [s] or None; None when ``spec`` is None.

    Raises
    ------
    InputError
        Not a table, no window, or a bad duration.
    """
    if spec is None:
        return None
    if not isinstance(spec, Mapping):
        raise InputError(f'{where} must be a table name -> duration [s] or "all", got {spec!r}')
    if not spec:
        raise InputError(f"{where}: at least one comparison window is needed")
    return {
        str(k): None if v is None or v == "all" else _number(v, f"{where}: window {k!r}", positive=True)
        for k, v in spec.items()
    }


def parse_compare(table: Mapping[str, Any] | None, where: str = "[compare]") -> dict[str, Any]:
    """Check a ``[compare]`` table (or the same settings from the command line) and normalise it.

    Parameters
    ----------
    table : mapping or None
        Keys of :data:`COMPARE_KEYS` (None values are ignored).
    where : str
        Source, for messages (file and table).

    Returns
    -------
    dict
        The keys given: ``tolerances`` and ``rtol`` (variable -> value),
        ``windows`` (name -> duration [s] or None), ``dt_out``,
        ``jsbsim_dt`` [s], ``self_convergence`` (bool), ``tracking_tolerance`` [m], ``settle_time`` [s].

    Raises
    ------
    InputError
        Not a table, an unknown key (with a "did you mean" suggestion) or a bad value.
    """
    if table is None:
        return {}
    if not isinstance(table, Mapping):
        raise InputError(f"{where} must be a table, got {table!r}")
    out: dict[str, Any] = {}
    for key, value in table.items():
        if key not in COMPARE_KEYS:
            raise unknown_key(key, COMPARE_KEYS, where)
        if value is None:
            continue
        if key in ("tolerances", "rtol"):
            out[key] = expand_tolerances(value, f"{where} {key}")
        elif key == "windows":
            out[key] = parse_windows(value, f"{where} windows")
        elif key in ("dt_out", "jsbsim_dt", "tracking_tolerance"):
            out[key] = _number(value, f"{where} {key}", positive=True)
        elif key == "settle_time":
            out[key] = _number(value, f"{where} {key}", positive=False)
        elif not isinstance(value, bool):
            raise InputError(f"{where} self_convergence must be true or false, got {value!r}")
        else:
            out[key] = value
    return out


@dataclass(frozen=True)
class CompareSettings:
    """The settings a comparison was made with, and where each came from.

    Attributes
    ----------
    tolerances : dict
        Variable -> absolute tolerance (SI unit of the variable).
    rtol : dict
        Variable -> relative tolerance (fraction of ``max |u_ref|`` over the window).
    windows : dict
        Window name -> duration from t0 [s] (None: whole span).
    dt_out : float
        Output grid step [s].
    jsbsim_dt : float
        JSBSim's step [s].
    self_convergence : bool
        JSBSim also flown at half its step.
    tracking_tolerance : float
        Closed loop: the tracking verdict's bound on the distance to the flat outputs after ``settle_time`` [m].
    settle_time : float
        Closed loop: from t0, before the tracking verdict measures [s].
    sources : dict
        Setting -> ``"command line"``, ``"scenario"`` or ``"default"``.
    """

    tolerances: dict
    rtol: dict
    windows: dict
    dt_out: float
    jsbsim_dt: float
    self_convergence: bool
    sources: dict
    tracking_tolerance: float = DEFAULT_TRACKING_TOLERANCE
    settle_time: float = DEFAULT_SETTLE_TIME

    def to_dict(self) -> dict:
        """The settings as JSON-ready data (``summary.json``, ``manifest.json``).

        Returns
        -------
        dict
            The attributes; windows as name -> seconds or ``"all"``.
        """
        return {
            "tolerances": dict(self.tolerances),
            "rtol": dict(self.rtol),
            "windows": {k: "all" if v is None else v for k, v in self.windows.items()},
            "dt_out": self.dt_out,
            "jsbsim_dt": self.jsbsim_dt,
            "self_convergence": self.self_convergence,
            "tracking_tolerance": self.tracking_tolerance,
            "settle_time": self.settle_time,
            "sources": dict(self.sources),
        }


def resolve_compare(
    scenario_table: Mapping | None = None,
    overrides: Mapping | None = None,
    *,
    where: str = "[compare]",
    override_source: str = "command line",
) -> CompareSettings:
    """Merge the defaults, a scenario's ``[compare]`` table and the overrides (command line or case).

    Parameters
    ----------
    scenario_table : mapping, optional
        The scenario's raw ``[compare]`` table.
    overrides : mapping, optional
        The same keys from the command line or a :class:`ValidationCase` (None values: not set).
    where : str
        Source of the scenario table, for messages.
    override_source : str
        Name of the overrides' source in :attr:`CompareSettings.sources`.

    Returns
    -------
    CompareSettings
        Tolerances merged variable by variable (overrides > scenario >
        :data:`harness.metrics.DEFAULT_TOLERANCES`); the other settings taken whole.

    Raises
    ------
    InputError
        As :func:`parse_compare`, for either source.
    """
    scen = parse_compare(scenario_table, where)
    over = parse_compare(overrides, override_source)
    sources = {}
    tol, rtol = dict(DEFAULT_TOLERANCES), {}
    sources["tolerances"] = "default"
    sources["rtol"] = "default"
    for src, d in (("scenario", scen), (override_source, over)):
        if "tolerances" in d:
            tol.update(d["tolerances"])
            sources["tolerances"] = src
        if "rtol" in d:
            rtol.update(d["rtol"])
            sources["rtol"] = src
    defaults = {
        "windows": dict(DEFAULT_WINDOWS),
        "dt_out": DEFAULT_DT_OUT,
        "jsbsim_dt": DEFAULT_JSBSIM_DT,
        "self_convergence": False,
        "tracking_tolerance": DEFAULT_TRACKING_TOLERANCE,
        "settle_time": DEFAULT_SETTLE_TIME,
    }
    values = {}
    for key, default in defaults.items():
        if key in over:
            values[key], sources[key] = over[key], override_source
        elif key in scen:
            values[key], sources[key] = scen[key], "scenario"
        else:
            values[key], sources[key] = default, "default"
    return CompareSettings(tolerances=tol, rtol=rtol, sources=sources, **values)
