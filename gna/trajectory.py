"""The trajectory contract shared by the model, the planners and every engine.

* Names and units of the columns of every trajectory gflat writes or compares:
  the 12 wind-frame states, the 5 controls and the derived quantities
  (:data:`COLUMNS`, :data:`UNITS`).  SI units, angles in radians; frames as in
  ``docs/conventions.md`` (NED position, wind-axis forces, body-axis moments
  about the CG).
* Control sources: :data:`ControlFunction`, :func:`control_function` (a
  function of time, a plan, or five constants) and :func:`controls_on_grid`.
* The input checks every engine shares: :func:`initial_state`,
  :func:`check_span`, :func:`output_grid`, :func:`environment_of`.
* The physical domain every engine stops at: :data:`DOMAIN`,
  :func:`domain_margins` and :func:`domain_violation`; with ground effect
  (:func:`domain_bounds`) also a CG at or below the ground.
* The outcome of a run on any engine: :class:`SimulationResult` with its typed
  settings record :class:`RunSettings`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field, fields, replace
from typing import Any

import numpy as np
import pandas as pd

from .atmosphere import Environment
from .eom import CONTROL_NAMES, STATE_NAMES
from .errors import InputError

#: Derived columns of every engine's trajectory, after the states and controls.
DERIVED_NAMES: tuple[str, ...] = (
    "qbar",
    "rho",
    "nx",
    "ny",
    "nz",
    "X",
    "Y",
    "Z",
    "L",
    "M",
    "N",
    "CD",
    "CY",
    "CL",
    "Cl",
    "Cm",
    "Cn",
)

#: Columns of every engine's DataFrame, in order.
COLUMNS: tuple[str, ...] = STATE_NAMES + CONTROL_NAMES + DERIVED_NAMES

#: Composite variable of comparisons: Euclidean distance between the positions.
POSITION = "position"

#: Unit of every named quantity (states, controls, derived columns, trim variables).
UNITS: dict[str, str] = {
    POSITION: "m",
    "x": "m",
    "y": "m",
    "z": "m",
    "V": "m/s",
    "gamma": "rad",
    "chi": "rad",
    "alpha": "rad",
    "beta": "rad",
    "mu": "rad",
    "p": "rad/s",
    "q": "rad/s",
    "r": "rad/s",
    "chi_dot": "rad/s",
    "F": "N",
    "eta": "-",
    "dl": "rad",
    "dm": "rad",
    "dn": "rad",
    "qbar": "Pa",
    "rho": "kg/m^3",
    "nx": "-",
    "ny": "-",
    "nz": "-",
    "X": "N",
    "Y": "N",
    "Z": "N",
    "L": "N m",
    "M": "N m",
    "N": "N m",
    "CD": "-",
    "CY": "-",
    "CL": "-",
    "Cl": "-",
    "Cm": "-",
    "Cn": "-",
}

#: Variables that are angles (their differences are wrapped into (-pi, pi]).
ANGLES: frozenset[str] = frozenset({"gamma", "chi", "alpha", "beta", "mu"})

#: A control source as a function of time: ``t [s] -> (F [N], eta [-], dl, dm, dn [rad])``.
ControlFunction = Callable[[float], Sequence[float]]


# --------------------------------------------------------------------------- control sources and input checks


def control_function(source) -> ControlFunction:
    """A callable ``t -> 5 controls`` from any control source.

    Parameters
    ----------
    source : callable, object with ``controls(t)``, or sequence of 5 floats
        A function of time ``t [s] -> (F [N], eta [-], dl, dm, dn [rad])``, a
        plan (its ``control_function()`` when it has one -- a plan's cheap
        piecewise polynomial -- else its ``controls`` method), or constant controls.

    Returns
    -------
    ControlFunction

    Raises
    ------
    InputError
        If ``source`` is none of these, or constants are not 5 numbers.
    """
    factory = getattr(source, "control_function", None)
    if callable(factory):
        return factory()
    method = getattr(source, "controls", None)
    if callable(method):
        return method
    if callable(source):
        return source
    try:
        arr = np.asarray(source, dtype=float)
    except (TypeError, ValueError):
        raise InputError(
            f"controls must be a function of t, a plan with controls(t), or 5 numbers; got {type(source).__name__}"
        ) from None
    if arr.shape != (5,):
        raise InputError(f"constant controls need 5 values (F, eta, dl, dm, dn), got shape {arr.shape}")
    return lambda t: arr


def initial_state(source=None, x0=None) -> np.ndarray:
    """The checked 12-state initial condition of a run.

    Parameters
    ----------
    source : object, optional
        A control source; when ``x0`` is None its ``initial_state`` is used (an
        attribute, or a method called without arguments as a plan's).
    x0 : array_like, shape (12,), optional
        Initial wind-frame state (:data:`gna.eom.STATE_NAMES`, SI, rad).

    Returns
    -------
    ndarray, shape (12,)

    Raises
    ------
    InputError
        No initial state, not 12 values, a non-finite value, or ``V <= 0``.
    """
    if x0 is None:
        x0 = getattr(source, "initial_state", None)
        if callable(x0):
            x0 = x0()
        if x0 is None:
            raise InputError("no initial state: pass x0 or a plan with an initial_state")
    try:
        arr = np.asarray(x0, dtype=float)
    except (TypeError, ValueError):
        arr = None
    if arr is None or arr.shape not in ((12,), (12, 1)):
        shape = "not numbers" if arr is None else f"shape {arr.shape}"
        raise InputError(
            f"the initial state must be the 12 wind-frame values {', '.join(STATE_NAMES)} "
            f"(shape (12,) or (12, 1)), got {shape}"
        )
    y0 = arr.reshape(12)
    bad = [n for n, v in zip(STATE_NAMES, y0) if not math.isfinite(v)]
    if bad:
        raise InputError(f"initial state has non-finite values: {', '.join(bad)}")
    if not y0[3] > 0:
        raise InputError(f"initial speed must be positive, got V = {y0[3]} m/s")
    return y0


def check_span(t_span) -> tuple[float, float]:
    """``(t0, t1)`` as floats, checked finite and increasing.

    Parameters
    ----------
    t_span : pair of float
        Start and end time [s].

    Returns
    -------
    tuple of float

    Raises
    ------
    InputError
        If ``t_span`` is not two finite numbers with ``t1 > t0``.
    """
    try:
        t0, t1 = (float(v) for v in t_span)
    except (TypeError, ValueError):
        raise InputError(f"t_span must be two numbers (t0, t1), got {t_span!r}") from None
    if not (math.isfinite(t0) and math.isfinite(t1) and t1 > t0):
        raise InputError(f"t_span must be finite and increasing, got {t_span}")
    return t0, t1


#: Most intervals of a uniform output grid (:func:`output_grid`): its times alone take 8 GB.
MAX_OUTPUT_INTERVALS = 1e9


def output_grid(t0: float, t1: float, dt_out: float = 0.02, t_eval=None) -> np.ndarray:
    """The output times of a run: ``t_eval`` checked, or the uniform grid of step ``dt_out``.

    A ``dt_out`` that does not divide the span is refused rather than changed
    (the grid would otherwise silently use another interval).

    Parameters
    ----------
    t0, t1 : float
        Span [s] (checked by :func:`check_span`).
    dt_out : float
        Output interval [s]; it must divide ``t1 - t0`` (relative tolerance
        1e-6 on the number of intervals).  Ignored when ``t_eval`` is given.
    t_eval : array_like, shape (n,), optional
        Output times [s]: non-empty, finite, increasing, inside the span.

    Returns
    -------
    ndarray, shape (n,)
        Output times [s]; the uniform grid is ``t0 + k dt_out``, ``k = 0 .. N``.

    Raises
    ------
    InputError
        ``dt_out`` not a positive finite number, longer than the span, not dividing it, or making more than
        :data:`MAX_OUTPUT_INTERVALS` intervals; ``t_eval`` empty, not finite, not increasing or outside the
        span.
    """
    if t_eval is not None:
        try:
            te = np.asarray(t_eval, dtype=float).ravel()
        except (TypeError, ValueError):
            raise InputError(f"t_eval must be a sequence of times [s], got {type(t_eval).__name__}") from None
        if te.size == 0 or not np.all(np.isfinite(te)) or np.any(np.diff(te) <= 0):
            raise InputError("t_eval must be a non-empty increasing sequence of finite times")
        tol = 1e-12 * max(1.0, abs(t0), abs(t1))
        if te[0] < t0 - tol or te[-1] > t1 + tol:
            raise InputError(f"t_eval must lie in t_span [{t0:g}, {t1:g}] s, got times from {te[0]:g} to {te[-1]:g} s")
        return te
    try:
        dt_out = float(dt_out)
    except (TypeError, ValueError):
        raise InputError(f"dt_out must be a number [s], got {dt_out!r}") from None
    if not (math.isfinite(dt_out) and dt_out > 0):
        raise InputError(f"dt_out must be a positive finite interval [s], got {dt_out}")
    ratio = (t1 - t0) / dt_out
    n = int(round(ratio))
    if not ratio <= MAX_OUTPUT_INTERVALS:
        raise InputError(
            f"dt_out = {dt_out:g} s makes {ratio:.3g} output intervals over the span [{t0:g}, {t1:g}] s, above "
            f"the bound {MAX_OUTPUT_INTERVALS:.0e}"
        )
    if ratio < 1 - 1e-6:
        raise InputError(
            f"dt_out = {dt_out:g} s is longer than the span [{t0:g}, {t1:g}] s, its bound; choose a divisor of "
            f"{t1 - t0:g} s"
        )
    if n < 1 or abs(ratio - n) > 1e-6 * max(1.0, ratio):
        raise InputError(
            f"dt_out = {dt_out:g} s does not divide the span [{t0:g}, {t1:g}] s "
            f"({ratio:.6g} intervals); choose a divisor of {t1 - t0:g} s"
        )
    return np.linspace(t0, t1, n + 1)


# --------------------------------------------------------------------------- the physical domain of a run


@dataclass(frozen=True)
class DomainBounds:
    """Where a trajectory of the wind-frame model still means something; engines stop outside.

    These are not the aerodynamic envelope (an excursion there is a warning):
    they mark a run that has diverged, reached a singular chart or left the
    atmosphere model.  The one definition trim, the planners' checks and both
    engines use: :func:`domain_bounds` makes it for an environment.

    Parameters
    ----------
    V_min : float
        Smallest airspeed [m/s]: 1 m/s.  Below it alpha, beta and the wind
        frame are ill-defined (V = 0 is the chart's singularity) and no
        aircraft of the catalogue flies; a run down there has stalled out.
    V_max : float
        Largest airspeed [m/s]: 3000 m/s (about Mach 9 in the ISA), beyond
        every aircraft flown here; a run above it has blown up.
    cos_min : float
        Smallest ``cos(beta)`` and ``cos(gamma)`` [-]: 1e-6.  At
        ``cos(beta) = 0`` or ``cos(gamma) = 0`` the wind-frame chart is
        singular (the model's equations divide by them).
    alpha_max : float
        Largest ``|alpha|`` [rad]: pi/2.  Beyond it the air comes from behind
        the wing; the aerodynamic models are fitted over tens of degrees and
        the JSBSim angle swings through +-pi when a run tumbles.
    ground : float or None
        Altitude ``-z`` of the ground plane [m] when the environment has
        ground effect (:func:`domain_bounds`): a CG height ``h = -z - ground``
        at or below 0 has reached the ground, and neither engine models ground
        contact.  None (default, free air): no height test.
    h_min, h_max : float
        Altitudes ``-z`` [m] the atmosphere model holds between
        (:func:`domain_bounds`: the ISA's ``altitude_range``, -2 to 20 km, the
        range :meth:`gna.atmosphere.Environment.check_altitude` refuses outside
        for trim and plan nodes); infinite (default, and a constant density):
        no altitude test.
    atmosphere : str
        The model the altitude range belongs to, for the messages.
    """

    V_min: float = 1.0
    V_max: float = 3000.0
    cos_min: float = 1e-6
    alpha_max: float = 0.5 * math.pi
    ground: float | None = None
    h_min: float = -math.inf
    h_max: float = math.inf
    atmosphere: str = ""


#: The bounds of the wind-frame chart alone (no atmosphere, no ground): :func:`domain_bounds` adds those.
DOMAIN = DomainBounds()

#: Domain tests: (state name, what its margin measures); margins are positive inside the domain.
DOMAIN_TESTS: tuple[tuple[str, str], ...] = (
    ("V", "airspeed V below the domain's {V_min:g} m/s"),
    ("V", "airspeed V above the domain's {V_max:g} m/s"),
    ("beta", "|beta| at pi/2 (cos(beta) below {cos_min:g}: the wind-frame chart is singular)"),
    ("gamma", "cos(gamma) below {cos_min:g} (vertical flight path: the wind-frame chart is singular)"),
    ("alpha", "|alpha| above the domain's {alpha_max_deg:g} deg"),
    ("z", "height above the ground at or below 0 (ground at {ground:g} m altitude; no ground contact is modelled)"),
    ("z", "altitude below {h_min:g} m, the lower end of {atmosphere}"),
    ("z", "altitude above {h_max:g} m, the upper end of {atmosphere}"),
)

#: Index of the height test (ground effect only) in :data:`DOMAIN_TESTS`.
GROUND_TEST = 5


def domain_bounds(env: Environment | None) -> DomainBounds:
    """The domain of a run in ``env``: :data:`DOMAIN` with the atmosphere's altitude range and the ground's height.

    Parameters
    ----------
    env : Environment or None
        The run's environment (None: the default, ISA in free air).

    Returns
    -------
    DomainBounds
        :data:`DOMAIN` with ``h_min``, ``h_max`` the atmosphere model's ``altitude_range`` (the ISA's -2 to
        20 km; none for a constant density) and, with ground effect, ``ground`` at the ground elevation [m].
    """
    env = env if env is not None else Environment()
    ge = getattr(env, "ground_effect", None)
    lo, hi = getattr(env.atmosphere, "altitude_range", (-math.inf, math.inf))
    return replace(
        DOMAIN,
        ground=None if ge is None else float(ge.elevation),
        h_min=float(lo),
        h_max=float(hi),
        atmosphere=f"the {type(env.atmosphere).__name__} atmosphere model",
    )


def check_initial_domain(t0: float, y0, bounds: DomainBounds) -> None:
    """Refuse an initial state outside the domain (every engine, before it flies).

    Parameters
    ----------
    t0 : float
        Start time [s].
    y0 : sequence of float, shape (12,)
        Initial wind-frame state.
    bounds : DomainBounds
        The run's domain (:func:`domain_bounds`).

    Raises
    ------
    InputError
        ``the initial state is outside the physical domain: left the physical domain at t = t0 s: ...``
        naming the variable and its value.
    """
    start = domain_violation(t0, y0, bounds)
    if start is not None:
        raise InputError(f"the initial state is outside the physical domain: {start}")


def ground_violation(t: float, z: float, bounds: DomainBounds = DOMAIN) -> str | None:
    """The domain's height test alone: None above the ground (or without one), else :func:`domain_text`'s message.

    Parameters
    ----------
    t : float
        Time [s] (for the message).
    z : float
        NED down coordinate of the CG [m].
    bounds : DomainBounds
        The bounds (their ``ground``; None: no test).

    Returns
    -------
    str or None
        ``"left the physical domain at t = ... s: height above the ground at or below 0 (...) (h = ... m, z = ... m)"``.
    """
    if bounds.ground is None or -z - bounds.ground > 0:
        return None
    return domain_text(t, GROUND_TEST, z, bounds)


def domain_margins(state, bounds: DomainBounds = DOMAIN) -> list[float]:
    """The margins of a state to the domain's bounds, in the order of :data:`DOMAIN_TESTS`.

    Parameters
    ----------
    state : sequence of float, shape (12,) or more
        Wind-frame state (:data:`gna.eom.STATE_NAMES`, SI, rad); extra
        components (controller states) are ignored.
    bounds : DomainBounds
        The bounds (default :data:`DOMAIN`).

    Returns
    -------
    list of float
        One margin per test, positive inside the domain (NaN for a non-finite state).
    """
    V, gamma, alpha, beta = state[3], state[4], state[6], state[7]
    if not (math.isfinite(gamma) and math.isfinite(beta)):
        return [math.nan] * len(DOMAIN_TESTS)
    return _margins(state[2], V, gamma, alpha, beta, bounds, math.cos, abs)


def _margins(z, V, gamma, alpha, beta, bounds: DomainBounds, cos, absolute) -> list:
    """The margins of :data:`DOMAIN_TESTS` (one formula for floats and for arrays of samples)."""
    return [
        V - bounds.V_min,
        bounds.V_max - V,
        cos(beta) - bounds.cos_min,
        cos(gamma) - bounds.cos_min,
        bounds.alpha_max - absolute(alpha),
        math.inf if bounds.ground is None else -z - bounds.ground,
        math.inf if bounds.h_min == -math.inf else -z - bounds.h_min,
        math.inf if bounds.h_max == math.inf else bounds.h_max + z,
    ]


def inside_domain(states, bounds: DomainBounds = DOMAIN) -> np.ndarray:
    """Which of many states lie inside the physical domain (the test of :func:`domain_violation`, vectorised).

    Parameters
    ----------
    states : array_like, shape (12, n) or more rows
        Wind-frame states (:data:`gna.eom.STATE_NAMES`, SI, rad), one column per sample; extra rows
        (controller states) are ignored.
    bounds : DomainBounds
        The bounds (default :data:`DOMAIN`; :func:`domain_bounds` adds the ground's height test).

    Returns
    -------
    ndarray of bool, shape (n,)
        True where every state is finite and every margin of :func:`domain_margins` is positive.
    """
    X = np.asarray(states, dtype=float)[:12]
    with np.errstate(invalid="ignore"):
        margins = _margins(X[2], X[3], X[4], X[6], X[7], bounds, np.cos, np.abs)
        inside = np.isfinite(X).all(axis=0)
        for m in margins:
            inside &= m > 0
    return inside


def domain_text(t: float, test: int, value: float, bounds: DomainBounds = DOMAIN) -> str:
    """The message of a domain stop: time, test, variable and value.

    Parameters
    ----------
    t : float
        Time of the stop [s].
    test : int
        Index into :data:`DOMAIN_TESTS`.
    value : float
        Value of the variable (SI, rad).
    bounds : DomainBounds
        The bounds named in the message.

    Returns
    -------
    str
        ``"left the physical domain at t = ... s: <test> (<name> = <value> <unit>)"``.
    """
    name, text = DOMAIN_TESTS[test]
    text = text.format(
        V_min=bounds.V_min,
        V_max=bounds.V_max,
        cos_min=bounds.cos_min,
        alpha_max_deg=math.degrees(bounds.alpha_max),
        ground=math.nan if bounds.ground is None else bounds.ground,
        h_min=bounds.h_min,
        h_max=bounds.h_max,
        atmosphere=bounds.atmosphere or "the atmosphere model",
    )
    if test == GROUND_TEST:  # the height test: the height above the ground, then z itself
        return (
            f"left the physical domain at t = {t:.6g} s: {text} "
            f"(h = {-value - (bounds.ground or 0.0):.6g} m, z = {value:.6g} m)"
        )
    if name == "z":  # the altitude tests
        return f"left the physical domain at t = {t:.6g} s: {text} (altitude = {-value:.6g} m, z = {value:.6g} m)"
    shown = f"{value:.6g} {UNITS[name]}" if name == "V" else f"{value:.6g} rad = {math.degrees(value):.4g} deg"
    return f"left the physical domain at t = {t:.6g} s: {text} ({name} = {shown})"


def domain_violation(t: float, state, bounds: DomainBounds = DOMAIN) -> str | None:
    """Whether a state lies outside the physical domain, and the message naming time, variable and value.

    The one test both engines apply (the in-house integrator locates the
    crossing with its dense output; JSBSim checks every step).

    Parameters
    ----------
    t : float
        Time [s] (for the message).
    state : sequence of float, shape (12,) or more
        Wind-frame state (:data:`gna.eom.STATE_NAMES`, SI, rad).
    bounds : DomainBounds
        The bounds (default :data:`DOMAIN`).

    Returns
    -------
    str or None
        None inside the domain; otherwise the message (non-finite states
        first, then the tests of :data:`DOMAIN_TESTS` in order).
    """
    bad = [f"{n} = {v}" for n, v in zip(STATE_NAMES, state) if not math.isfinite(v)]
    if bad:
        return f"left the physical domain at t = {t:.6g} s: non-finite state ({', '.join(bad)})"
    for i, m in enumerate(domain_margins(state, bounds)):
        if not m > 0:
            name = DOMAIN_TESTS[i][0]
            return domain_text(t, i, float(state[STATE_NAMES.index(name)]), bounds)
    return None


def first_domain_violation(t, states, bounds: DomainBounds = DOMAIN) -> str | None:
    """:func:`domain_violation` over a sequence of states: the message of the first one outside, or None.

    Parameters
    ----------
    t : array_like, shape (n,)
        Times [s].
    states : array_like, shape (12, n)
        Wind-frame states (:data:`gna.eom.STATE_NAMES`, SI, rad).
    bounds : DomainBounds
        The bounds (default :data:`DOMAIN`).

    Returns
    -------
    str or None
        The message of the earliest state outside the domain.
    """
    t = np.atleast_1d(np.asarray(t, dtype=float))
    X = np.asarray(states, dtype=float).reshape(12, t.size)
    inside = inside_domain(X, bounds)
    if inside.all():
        return None
    i = int(np.argmin(inside))
    return domain_violation(float(t[i]), X[:, i].tolist(), bounds)


def environment_of(source, env: Environment | None = None) -> Environment:
    """The environment of a run: ``env`` if given, else the source's ``env`` (a plan's), else the ISA.

    Parameters
    ----------
    source : object
        A control source (a plan carries the environment it was planned for).
    env : Environment, optional
        Explicit environment.

    Returns
    -------
    Environment
    """
    if env is not None:
        return env
    env = getattr(source, "env", None)
    return env if isinstance(env, Environment) else Environment()


def controls_on_grid(f: ControlFunction, t) -> np.ndarray:
    """``f`` evaluated at the times ``t``.

    A vectorised call ``f(t)`` is tried first and accepted only if it agrees
    with scalar calls at three sample times; otherwise ``f`` is called at each
    time.

    Parameters
    ----------
    f : ControlFunction
        ``t [s] -> (F, eta, dl, dm, dn)``.
    t : array_like, shape (n,)
        Times [s].

    Returns
    -------
    ndarray, shape (5, n)

    Raises
    ------
    InputError
        If ``f`` does not return 5 values.
    """
    t = np.asarray(t, dtype=float)
    try:
        with np.errstate(all="ignore"):
            out = f(t)
            if len(out) == 5:
                U = np.array([np.broadcast_to(np.asarray(c, dtype=float), t.shape) for c in out])
            else:
                U = None
    except Exception:  # any failure of a vectorised call means: not vectorisable, evaluate pointwise
        U = None
    if U is not None and U.shape == (5, t.size):
        probe = sorted({0, t.size // 2, t.size - 1})
        ok = True
        for i in probe:
            ui = np.asarray(f(float(t[i])), dtype=float).reshape(5)
            both_nan = np.isnan(ui) & np.isnan(U[:, i])
            if not np.all(both_nan | (np.abs(ui - U[:, i]) <= 1e-12 * (1.0 + np.abs(ui)))):
                ok = False
                break
        if ok:
            return U
    rows = [f(ti) for ti in t.tolist()]
    try:
        U = np.array(rows, dtype=float)
    except (TypeError, ValueError):
        U = None
    if U is None or U.shape != (t.size, 5):
        for ti, ui in zip(t.tolist(), rows):
            shape = np.shape(ui)
            if shape != (5,):
                raise InputError(
                    f"controls(t) must return 5 values (F, eta, dl, dm, dn); got shape {shape} at t = {ti:g} s"
                )
        raise InputError("controls(t) must return 5 numbers (F, eta, dl, dm, dn)")
    return U.T.copy()


# --------------------------------------------------------------------------- the result of a run


@dataclass(frozen=True)
class RunSettings(Mapping):
    """Everything that determines the numbers of a run, typed; also a read-only mapping.

    ``settings["dt"]`` and ``settings.get("earth")`` work: keys are the field
    names (fields left at None are omitted) followed by the keys of ``extra``.

    Parameters
    ----------
    engine : str
        Engine name (a registry name such as ``"inhouse"``, ``"jsbsim"``).
    method : str or None
        Variable-step integrator of the aircraft states (scipy name, e.g. ``"DOP853"``).
    rtol, atol : float or None
        Its tolerances.
    max_step : float or None
        Its largest step [s].
    model : str
        ``"full"`` or ``"simple"`` equations of motion.
    environment : str
        Atmosphere description.
    g : float or None
        Gravity [m/s^2].
    dt : float or None
        Fixed step of a sampled engine [s].
    integrators : mapping or None
        Per-state-group integrators of a fixed-step engine.
    controller : str or None
        How the feedback is evaluated (None: open loop).
    controller_states : int
        Number of controller states.
    controller_scheme : str or None
        How the controller states are integrated, with its order of accuracy.
    controller_dt : float or None
        Controller update interval [s] (None: continuous).
    extra : mapping
        Engine-specific records (JSBSim version, planet, wall times, ...).
    """

    engine: str
    method: str | None = None
    rtol: float | None = None
    atol: float | None = None
    max_step: float | None = None
    model: str = "full"
    environment: str = ""
    g: float | None = None
    dt: float | None = None
    integrators: Mapping[str, str] | None = None
    controller: str | None = None
    controller_states: int = 0
    controller_scheme: str | None = None
    controller_dt: float | None = None
    extra: Mapping[str, Any] = field(default_factory=dict)

    def _keys(self) -> list[str]:
        own = [f.name for f in fields(self) if f.name != "extra" and getattr(self, f.name) is not None]
        return own + [k for k in self.extra if k not in own]

    def __getitem__(self, key: str):
        if key != "extra" and key in self.__dataclass_fields__ and getattr(self, key) is not None:
            return getattr(self, key)
        if key in self.extra:
            return self.extra[key]
        raise KeyError(key)

    def __iter__(self) -> Iterator[str]:
        return iter(self._keys())

    def __len__(self) -> int:
        return len(self._keys())

    __hash__ = None  # extra is a mutable mapping

    def as_dict(self) -> dict[str, Any]:
        """A plain dict of the non-None fields and the extra records.

        Returns
        -------
        dict
            Key -> value, in the mapping's order.
        """
        return {k: self[k] for k in self}


@dataclass
class SimulationResult:
    """Outcome of a run on any engine.

    Parameters
    ----------
    df : pandas.DataFrame
        Indexed by time ``t`` [s]; columns exactly :data:`COLUMNS`: the 12
        states, the 5 applied controls (reference + feedback) and derived
        quantities (``qbar``, ``rho``, load factors, wind-axis forces ``X, Y,
        Z``, body moments ``L, M, N``, coefficients).
    status : {"completed", "domain", "failed"}
        How the run ended ("domain": it left the physical domain of
        :func:`domain_violation` -- the same test on every engine -- or met
        non-finite values; "failed": the integrator gave up inside the domain).
    message : str
        Empty when completed; otherwise names the time, variable and value.
    warnings : list of str
        Envelope excursions (time, variable, value).
    settings : RunSettings
        Engine, integrator, step, tolerances, model, environment, controller.
    t_end : float
        Last time reached [s].
    controller_states : pandas.DataFrame or None
        Controller states on ``df``'s index (one column per state, none for a
        static feedback); None for an open-loop run.
    feedback : pandas.DataFrame or None
        Feedback part ``delta_u`` of the applied controls on ``df``'s index,
        columns :data:`gna.eom.CONTROL_NAMES`; None for an open-loop run.
    """

    df: pd.DataFrame
    status: str
    message: str = ""
    warnings: list = field(default_factory=list)
    settings: RunSettings = field(default_factory=lambda: RunSettings(engine=""))
    t_end: float = float("nan")
    controller_states: pd.DataFrame | None = None
    feedback: pd.DataFrame | None = None

    @property
    def completed(self) -> bool:
        """True when the run reached the end of its span."""
        return self.status == "completed"

    def to_timeresponse(self):
        """The run as python-control's ``control.TimeResponseData`` (optional extra ``gflat[control]``).

        Signals, SI units, angles in radians (:data:`UNITS`):

        * ``states`` (12): x, y, z [m] (NED), V [m/s], gamma, chi, alpha, beta, mu [rad], p, q, r [rad/s];
        * ``inputs`` (5): the applied controls F [N], eta [-], dl, dm, dn [rad];
        * ``outputs`` (29): the 12 states, then the derived ``qbar`` [Pa], ``rho`` [kg/m^3], load factors
          ``nx, ny, nz`` [-], wind-axis forces ``X, Y, Z`` [N], body moments ``L, M, N`` [N m] and the
          coefficients ``CD, CY, CL, Cl, Cm, Cn`` [-] (:data:`DERIVED_NAMES`).

        Labels are the column names; ``sysname`` is the engine, ``success`` and ``message`` the run's status.

        Returns
        -------
        control.TimeResponseData
            ``time`` shape (n,), ``outputs`` (29, n), ``states`` (12, n), ``inputs`` (5, n).

        Raises
        ------
        ImportError
            When python-control is not installed (``pip install "gflat[control]"``).
        """
        try:
            import control
        except ImportError as exc:
            raise ImportError(
                "SimulationResult.to_timeresponse needs python-control: install the optional "
                'extra with pip install "gflat[control]" (or pip install "control>=0.10")'
            ) from exc
        df = self.df
        outputs = STATE_NAMES + DERIVED_NAMES
        return control.TimeResponseData(
            df.index.to_numpy(dtype=float),
            df[list(outputs)].to_numpy(dtype=float).T,
            states=df[list(STATE_NAMES)].to_numpy(dtype=float).T,
            inputs=df[list(CONTROL_NAMES)].to_numpy(dtype=float).T,
            output_labels=list(outputs),
            state_labels=list(STATE_NAMES),
            input_labels=list(CONTROL_NAMES),
            title=f"gflat run on {self.settings.engine or 'an engine'}",
            sysname=self.settings.engine or None,
            success=self.completed,
            message=self.message or None,
            issiso=False,
        )


def controller_frames(index, names: Sequence[str], Xc: np.ndarray, dU: np.ndarray) -> tuple[pd.DataFrame, pd.DataFrame]:
    """The ``controller_states`` and ``feedback`` frames of a closed-loop result.

    Parameters
    ----------
    index : array_like, shape (n,)
        Output times [s].
    names : sequence of str
        Controller state names.
    Xc : ndarray, shape (n_states, n)
        Controller states.
    dU : ndarray, shape (5, n)
        Feedback part of the applied controls (F [N], eta [-], dl, dm, dn [rad]).

    Returns
    -------
    controller_states, feedback : pandas.DataFrame
    """
    idx = pd.Index(np.asarray(index, dtype=float), name="t")
    xc = pd.DataFrame({n: np.asarray(Xc[i], dtype=float) for i, n in enumerate(names)}, index=idx)
    fb = pd.DataFrame({n: np.asarray(dU[i], dtype=float) for i, n in enumerate(CONTROL_NAMES)}, index=idx)
    return xc, fb
