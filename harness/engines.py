"""Dynamics engines with one interface: the in-house wind-frame model and JSBSim.

Every engine is an object with a ``name`` and a method
``simulate(aircraft, controls, t_span, x0, *, env=None, controller=None,
dt_out=0.02, t_eval=None) -> gna.simulate.SimulationResult``; the result's
``df`` has the same columns for every engine (12 states, 5 applied controls,
``qbar, rho, nx, ny, nz, X, Y, Z, L, M, N`` and the six coefficients) and its
``settings`` record everything that determines the numbers (integrators, step,
environment, planet).

* ``controls`` is any control source: a callable ``t -> (F, eta, dl, dm, dn)``,
  an object with a ``controls(t)`` method (a plan), or five constants.
* ``controller(t, x) -> 5 corrections`` (``x`` the 12 wind-frame states) is
  added to the controls by both engines; the in-house engine evaluates it
  continuously, JSBSim at every step on the propagated state (see
  :class:`JSBSimEngine`).

:func:`fly` runs several engines on the same problem and output grid.
"""

from __future__ import annotations

import math
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, ClassVar, Mapping, Sequence

import numpy as np
import pandas as pd

from gna import units
from gna.aircraft import Aircraft
from gna.atmosphere import ISA, ConstantDensity, Environment
from gna.eom import CONTROL_NAMES, STATE_NAMES
from gna.errors import GflatError, InputError
from gna.frames import euler_from_wind
from gna.simulate import SimulationResult, envelope_warnings, simulate
from gna.trajectory import COLUMNS, DERIVED_NAMES

from . import jsbsim_export as jx

ControlFunction = Callable[[float], Sequence[float]]
Controller = Callable[[float, np.ndarray], Sequence[float]]

class EngineError(GflatError):
    """An engine could not be set up (JSBSim refused the model, bad settings)."""


# --------------------------------------------------------------------------- control sources

def control_function(source) -> ControlFunction:
    """A callable ``t -> 5 controls`` from any control source.

    Parameters
    ----------
    source : callable, object with ``controls(t)``, or 5 numbers
        A function of time, a plan (anything exposing a ``controls`` method),
        or constant controls ``(F, eta, dl, dm, dn)``.
    """
    method = getattr(source, "controls", None)
    if callable(method):
        return method
    if callable(source):
        return source
    try:
        arr = np.asarray(source, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"controls must be a function of t, a plan with controls(t), or 5 numbers; "
                         f"got {type(source).__name__}") from None
    if arr.shape != (5,):
        raise InputError(f"constant controls need 5 values (F, eta, dl, dm, dn), got shape {arr.shape}")
    return lambda t: arr


def initial_state(source, x0=None) -> np.ndarray:
    """The 12-state initial condition: ``x0`` if given, else the source's ``initial_state``
    (an attribute, or a method called without arguments as :meth:`planners.plan.Plan.initial_state`)."""
    if x0 is None:
        x0 = getattr(source, "initial_state", None)
        if callable(x0):
            x0 = x0()
        if x0 is None:
            raise InputError("no initial state: pass x0 or a plan with an initial_state")
    try:
        y0 = np.asarray(x0, dtype=float).reshape(12)
    except (TypeError, ValueError):
        raise InputError(f"the initial state must have the 12 wind-frame values {', '.join(STATE_NAMES)}") from None
    bad = [n for n, v in zip(STATE_NAMES, y0) if not math.isfinite(v)]
    if bad:
        raise InputError(f"initial state has non-finite values: {', '.join(bad)}")
    if not y0[3] > 0:
        raise InputError(f"initial speed must be positive, got V = {y0[3]} m/s")
    return y0


def environment_of(source, env: Environment | None = None) -> Environment:
    """``env`` if given, else the control source's ``env`` (a plan's), else the ISA."""
    if env is not None:
        return env
    env = getattr(source, "env", None)
    return env if isinstance(env, Environment) else Environment()


def controls_on_grid(f: ControlFunction, t: np.ndarray) -> np.ndarray:
    """``f`` evaluated at the times ``t``: array (5, len(t)).

    A vectorised call ``f(t)`` is tried first and accepted only if it agrees
    with scalar calls at three sample times; otherwise ``f`` is called at each
    time.
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
                raise InputError(f"controls(t) must return 5 values (F, eta, dl, dm, dn); got shape {shape} "
                                 f"at t = {ti:g} s")
        raise InputError("controls(t) must return 5 numbers (F, eta, dl, dm, dn)")
    return U.T.copy()


def _check_span(t_span) -> tuple[float, float]:
    try:
        t0, t1 = (float(v) for v in t_span)
    except (TypeError, ValueError):
        raise InputError(f"t_span must be two numbers (t0, t1), got {t_span!r}") from None
    if not (math.isfinite(t0) and math.isfinite(t1) and t1 > t0):
        raise InputError(f"t_span must be finite and increasing, got {t_span}")
    return t0, t1


# --------------------------------------------------------------------------- in-house engine

@dataclass(frozen=True)
class InHouseEngine:
    """The in-house 12-state wind-frame model (:func:`gna.simulate.simulate`).

    Parameters
    ----------
    method, rtol, atol, max_step
        scipy integrator settings (DOP853 at 1e-10 by default: a reference).
    model : {"full", "simple"}
    """

    method: str = "DOP853"
    rtol: float = 1e-10
    atol: float = 1e-10
    max_step: float = math.inf
    model: str = "full"
    name: ClassVar[str] = "inhouse"

    def simulate(self, aircraft: Aircraft, controls, t_span, x0=None, *, env: Environment | None = None,
                 controller: Controller | None = None, dt_out: float = 0.02,
                 t_eval: np.ndarray | None = None) -> SimulationResult:
        """Integrate the wind-frame equations (:func:`gna.simulate.simulate`).

        Parameters
        ----------
        aircraft : Aircraft
        controls : control source
            Callable ``t -> (F, eta, dl, dm, dn)``, an object with ``controls(t)``
            (a plan), or 5 constants.
        t_span : (t0, t1)
        x0 : array of 12, optional
            Initial wind-frame state; default the source's ``initial_state``.
        env : Environment, optional
            Default the source's ``env`` (a plan's), else the ISA.
        controller : callable ``(t, x) -> 5 corrections``, optional
            Added to the controls, evaluated continuously.
        dt_out, t_eval
            Output grid.

        Returns
        -------
        gna.simulate.SimulationResult
            ``settings["engine"] == "inhouse"``.
        """
        y0 = initial_state(controls, x0)
        env = environment_of(controls, env)
        res = simulate(aircraft, control_function(controls), t_span, y0, env=env, model=self.model,
                       controller=controller, dt_out=dt_out, t_eval=t_eval, rtol=self.rtol, atol=self.atol,
                       method=self.method, max_step=self.max_step)
        res.settings = {"engine": self.name, **res.settings, "controller": controller is not None}
        return res


# --------------------------------------------------------------------------- JSBSim engine

#: JSBSim integrator codes (``simulation/integrator/...``).
INTEGRATOR_CODES: dict[str, int] = {"none": 0, "Euler": 1, "trapezoidal": 2, "AB2": 3, "AB3": 4, "AB4": 5,
                                    "Buss1": 6, "Buss2": 7, "local-linearization": 8, "AB5": 9}
_QUATERNION_ONLY = ("Buss1", "Buss2", "local-linearization")


@dataclass(frozen=True)
class Integrators:
    """JSBSim's four integrator choices (names of :data:`INTEGRATOR_CODES`).

    The default, Adams-Bashforth 4 with Buss's second-order quaternion
    integrator, is second order overall with smooth inputs and the most
    accurate in the convergence study of ``docs/jsbsim.md``.
    """

    rotational_rate: str = "AB4"
    translational_rate: str = "AB4"
    rotational_position: str = "Buss2"
    translational_position: str = "AB4"

    def __post_init__(self):
        for k, v in self.as_dict().items():
            if v not in INTEGRATOR_CODES:
                raise InputError(f"unknown JSBSim integrator {v!r} for {k}; choose from {', '.join(INTEGRATOR_CODES)}")
            if v in _QUATERNION_ONLY and k != "rotational_position":
                raise InputError(f"{v} integrates the attitude quaternion only; it cannot be used for {k}")

    def as_dict(self) -> dict[str, str]:
        return {"rotational_rate": self.rotational_rate, "translational_rate": self.translational_rate,
                "rotational_position": self.rotational_position,
                "translational_position": self.translational_position}

    def properties(self) -> dict[str, int]:
        return {"simulation/integrator/rate/rotational": INTEGRATOR_CODES[self.rotational_rate],
                "simulation/integrator/rate/translational": INTEGRATOR_CODES[self.translational_rate],
                "simulation/integrator/position/rotational": INTEGRATOR_CODES[self.rotational_position],
                "simulation/integrator/position/translational": INTEGRATOR_CODES[self.translational_position]}


#: JSBSim's default integrators (Euler, AB2, Euler, AB3), for comparisons.
JSBSIM_DEFAULT_INTEGRATORS = Integrators("Euler", "AB2", "Euler", "AB3")

#: WGS84 semi-axes as JSBSim defines them [ft].
_WGS84_A_FT = 20925646.32546
_WGS84_B_FT = 20855486.5951

# Raw outputs read at each output time (their order is the order of the raw arrays).
_STATE_NODES_FLAT = ("position/lat-gc-rad", "position/long-gc-rad", "position/h-sl-ft")
_STATE_NODES_WGS84 = ("position/lat-geod-rad", "position/long-gc-rad", "position/geod-alt-ft")
_STATE_NODES = ("velocities/vt-fps", "flight-path/gamma-rad", "flight-path/psi-gt-rad", "aero/alpha-rad",
                "aero/beta-rad", "attitude/phi-rad", "attitude/theta-rad", "attitude/psi-rad",
                "velocities/p-rad_sec", "velocities/q-rad_sec", "velocities/r-rad_sec")
_DERIVED_NODES = (jx.QBAR_PROPERTY, jx.RHO_PROPERTY) + tuple(jx.COEFFICIENT_PROPERTIES.values()) + (
    "forces/fbx-total-lbs", "forces/fby-total-lbs", "forces/fbz-total-lbs",
    "forces/fbx-weight-lbs", "forces/fby-weight-lbs", "forces/fbz-weight-lbs",
    "moments/l-total-lbsft", "moments/m-total-lbsft", "moments/n-total-lbsft")


class _LogCapture:
    """A JSBSim logger keeping the records (level, text) instead of printing them."""

    def __init__(self, jsbsim_module):
        class Capture(jsbsim_module.FGLogger):
            def __init__(self):
                super().__init__()
                self.records: list[tuple[int, str]] = []
                self._level, self._text = 0, []

            def set_level(self, level):
                self._level, self._text = int(level), []

            def file_location(self, filename, line):
                self._text.append(f"[{Path(filename).name}:{line}] ")

            def message(self, message):
                self._text.append(message)

            def format(self, fmt):
                pass

            def flush(self):
                text = "".join(self._text).strip()
                if text:
                    self.records.append((self._level, text))
                self._text = []

        self.logger = Capture()
        self._jsbsim = jsbsim_module
        self._previous = None

    def __enter__(self):
        self._previous = self._jsbsim.get_logger()
        self._jsbsim.set_logger(self.logger)
        return self

    def __exit__(self, *exc):
        if self._previous is not None:
            self._jsbsim.set_logger(self._previous)
        return False

    def problems(self) -> list[str]:
        """Non-empty WARN, ERROR and FATAL records."""
        warn = int(self._jsbsim.LogLevel.WARN)
        stdout = int(self._jsbsim.LogLevel.STDOUT)
        return [text for level, text in self.logger.records if warn <= level < stdout]


def _import_jsbsim():
    try:
        import jsbsim
    except ImportError as exc:  # pragma: no cover - jsbsim is a declared dependency
        raise EngineError(f"the JSBSim engine needs the 'jsbsim' package ({exc})") from None
    return jsbsim


def load_fdm(xml_text: str, aircraft_id: str):
    """Load an aircraft file into a new ``jsbsim.FGFDMExec``, its console output captured.

    Returns
    -------
    fdm : jsbsim.FGFDMExec
    problems : list of str
        JSBSim's WARN/ERROR messages while loading (empty for our files).
    capture : object
        The logger the FDM reports to; keep it alive as long as the FDM.

    Raises
    ------
    EngineError
        If JSBSim refuses the file (its messages are quoted).
    """
    jsbsim = _import_jsbsim()
    capture = _LogCapture(jsbsim)
    with tempfile.TemporaryDirectory(prefix="gflat-jsbsim-") as root, capture:
        path = jx.xml_path(Path(root) / "aircraft", aircraft_id)
        path.parent.mkdir(parents=True)
        path.write_text(xml_text, encoding="utf-8")
        fdm = jsbsim.FGFDMExec(root)
        try:
            ok = fdm.load_model(aircraft_id)
        except Exception as exc:  # JSBSim raises its own exception types
            raise EngineError(f"JSBSim could not load aircraft {aircraft_id!r}: {exc}; "
                              f"messages: {' | '.join(capture.problems()) or 'none'}") from None
    if not ok:
        raise EngineError(f"JSBSim could not load aircraft {aircraft_id!r}: "
                          f"{' | '.join(capture.problems()) or 'load_model returned False'}")
    return fdm, capture.problems(), capture


def _density_settings(env: Environment) -> dict[str, float]:
    atm = env.atmosphere
    if isinstance(atm, ConstantDensity):
        return {jx.DENSITY_MODEL_PROPERTY: 1.0, jx.DENSITY_CONSTANT_PROPERTY: atm.rho / units.SLUG_FT3}
    if isinstance(atm, ISA):
        return {jx.DENSITY_MODEL_PROPERTY: 0.0}
    raise InputError(f"the JSBSim engine has no counterpart of the atmosphere model {type(atm).__name__}; "
                     f"use gna.atmosphere.ISA or ConstantDensity")


def initial_condition_properties(x0: np.ndarray, latitude: float = 0.0, longitude: float = 0.0,
                                 geodetic_altitude: bool = False) -> list[tuple[str, float]]:
    """The ``ic/*`` writes (in order) that put JSBSim exactly at the wind-frame state ``x0``.

    Position at (``latitude``, ``longitude``) and altitude ``-z``; attitude
    through the Euler angles of ``C_bn = C_bw(alpha, beta) C_wn(gamma, chi, mu)``;
    body velocity ``V (cos a cos b, sin b, sin a cos b)``; body rates.  This
    route is exact and independent of order (``docs/jsbsim.md``).  With
    ``geodetic_altitude`` the altitude is written as ``ic/h-agl-ft`` (height
    above the WGS84 ellipsoid, the terrain being at zero: ``ic/geod-alt-ft``
    is read-only and ``ic/h-sl-ft`` geocentric).
    """
    x, y, z, V, gamma, chi, alpha, beta, mu, p, q, r = (float(v) for v in x0)
    phi, theta, psi = euler_from_wind(gamma, chi, mu, alpha, beta)
    Vf = V / units.FT
    return [("ic/lat-geod-rad", latitude), ("ic/long-gc-rad", longitude),
            ("ic/h-agl-ft" if geodetic_altitude else "ic/h-sl-ft", -z / units.FT),
            ("ic/phi-rad", phi), ("ic/theta-rad", theta), ("ic/psi-true-rad", psi),
            ("ic/u-fps", Vf * math.cos(alpha) * math.cos(beta)), ("ic/v-fps", Vf * math.sin(beta)),
            ("ic/w-fps", Vf * math.sin(alpha) * math.cos(beta)),
            ("ic/p-rad_sec", p), ("ic/q-rad_sec", q), ("ic/r-rad_sec", r)]


def _mu(alpha, beta, phi, theta, sin=np.sin, cos=np.cos, atan2=np.arctan2):
    """Wind-axis bank from the body Euler angles and alpha, beta: ``atan2(C_wn[1,2], C_wn[2,2])``.

    ``C_wn = C_wb C_bn`` with the third column of ``C_bn`` equal to
    ``(-sin th, sin ph cos th, cos ph cos th)`` and rows 1, 2 of ``C_wb``
    ``(-ca sb, cb, -sa sb)``, ``(-sa, 0, ca)``.
    """
    ca, sa, cb, sb = cos(alpha), sin(alpha), cos(beta), sin(beta)
    sth, cth, sph, cph = sin(theta), cos(theta), sin(phi), cos(phi)
    num = ca * sb * sth + cb * sph * cth - sa * sb * cph * cth
    den = sa * sth + ca * cph * cth
    return atan2(num, den)


def _align(angle: np.ndarray, reference: float) -> np.ndarray:
    """Unwrap an angle history and shift it by whole turns so that it starts nearest ``reference``."""
    a = np.unwrap(np.asarray(angle, dtype=float))
    if a.size:
        a = a + 2.0 * math.pi * np.round((reference - a[0]) / (2.0 * math.pi))
    return a


@dataclass(frozen=True)
class JSBSimEngine:
    """JSBSim 1.3 flying the exported aircraft file.

    Parameters
    ----------
    dt : float
        Largest step [s]; the step used divides the output interval exactly
        and is recorded in ``settings["dt"]``.
    integrators : Integrators
    earth : {"flat", "wgs84"}
        ``"flat"``: the file's flat-earth planet (non-rotating sphere of radius
        ``planet_radius_ft``, no J2, ``GM`` giving ``env.g`` exactly at the
        initial altitude) and ``simulation/gravity-model`` 0.  ``"wgs84"``:
        no planet element, JSBSim's default rotating WGS84 Earth with J2
        gravity, starting at (``latitude``, ``longitude``): shows what the
        flat-earth assumption costs.
    planet_radius_ft : float
    latitude, longitude : float
        Initial position on the WGS84 Earth [rad] (ignored on the flat earth).

    Notes
    -----
    Control timing (``docs/jsbsim.md``): JSBSim's ``run()`` first integrates
    with the derivatives of the previous frame, then evaluates the models at
    the new state.  So ``u(t_k)`` is written before the ``run()`` that reaches
    ``t_k`` and ``u(t0)`` before ``run_ic()``: JSBSim samples the controls at
    every step.  With a controller, each step runs, reads the propagated state
    ``x_k``, computes ``controller(t_k, x_k)``, writes the corrected controls
    and re-evaluates the derivatives at ``x_k`` with the integration suspended
    (which leaves the state and the integrators' history untouched): the
    feedback is sampled at every step without delay.

    Positions are read as latitude, longitude and altitude and mapped to the
    NED plane of the initial point: ``x = x0 + (R + h) lat``,
    ``y = y0 + (R + h) cos(lat) lon`` (spherical arcs, so that level flight on
    the huge sphere is level in NED), ``z = -h``.  On the WGS84 Earth the
    meridian and normal radii of curvature at the initial latitude are used.
    ``chi`` and ``mu`` are unwrapped and start at ``x0``'s values.
    """

    dt: float = 1.0 / 480.0
    integrators: Integrators = field(default_factory=Integrators)
    earth: str = "flat"
    planet_radius_ft: float = jx.PLANET_RADIUS_FT
    latitude: float = 0.0
    longitude: float = 0.0
    name: ClassVar[str] = "jsbsim"

    def __post_init__(self):
        if not (math.isfinite(self.dt) and self.dt > 0):
            raise InputError(f"JSBSim step dt must be positive, got {self.dt}")
        if self.earth not in ("flat", "wgs84"):
            raise InputError(f"earth must be 'flat' or 'wgs84', got {self.earth!r}")
        if not (abs(self.latitude) < math.pi / 2 and math.isfinite(self.longitude)):
            raise InputError(f"bad initial latitude/longitude ({self.latitude}, {self.longitude}) rad")

    # ---- setup -----------------------------------------------------------------------------------
    def xml(self, aircraft: Aircraft, env: Environment, x0: np.ndarray) -> str:
        """The aircraft file this engine flies from ``x0`` (the flat planet's g is exact at ``-z0``)."""
        planet = (jx.FlatPlanet(g=env.g, h_ref=-float(x0[2]), radius_ft=self.planet_radius_ft)
                  if self.earth == "flat" else None)
        return jx.aircraft_xml(aircraft, planet)

    def _grid(self, t0: float, t1: float, dt_out: float, t_eval) -> tuple[int, float, np.ndarray]:
        """Number of steps, step, and the step indices of the output times."""
        if t_eval is not None:
            te = np.asarray(t_eval, dtype=float).ravel()
            if te.size == 0 or not np.all(np.isfinite(te)) or np.any(np.diff(te) <= 0):
                raise InputError("t_eval must be a non-empty increasing sequence of finite times")
            if te[0] < t0 - 1e-12 or te[-1] > t1 + 1e-12:
                raise InputError(f"t_eval must lie in t_span [{t0:g}, {t1:g}] s")
            gaps = np.diff(np.concatenate([[t0], te, [t1]]))
            gaps = gaps[gaps > 1e-12]
            h = float(np.min(gaps)) if gaps.size else t1 - t0
            n_out = max(int(round((t1 - t0) / h)), 1)
        else:
            if not (math.isfinite(dt_out) and dt_out > 0):
                raise InputError(f"dt_out must be positive, got {dt_out}")
            n_out = max(int(round((t1 - t0) / dt_out)), 1)
        m = max(int(math.ceil((t1 - t0) / n_out / self.dt - 1e-9)), 1)
        n = n_out * m
        dt = (t1 - t0) / n
        if t_eval is None:
            return n, dt, np.arange(0, n + 1, m)
        k = np.round((te - t0) / dt).astype(int)
        off = np.abs(t0 + k * dt - te)
        if np.any(off > 1e-9 * max(1.0, abs(t1))):
            i = int(np.argmax(off))
            raise InputError(f"t_eval time {te[i]:.12g} s is not on JSBSim's step grid (dt = {dt:.6g} s from "
                             f"t0 = {t0:g} s); use a uniform t_eval or dt_out")
        return n, dt, k

    # ---- run -------------------------------------------------------------------------------------
    def simulate(self, aircraft: Aircraft, controls, t_span, x0=None, *, env: Environment | None = None,
                 controller: Controller | None = None, dt_out: float = 0.02,
                 t_eval: np.ndarray | None = None) -> SimulationResult:
        """Fly ``aircraft`` in JSBSim from ``x0`` with the control source ``controls``.

        Parameters
        ----------
        aircraft : Aircraft
            Exported on the fly (:func:`harness.jsbsim_export.aircraft_xml`), so
            variants built in memory fly too.
        controls : control source
            Callable ``t -> (F, eta, dl, dm, dn)``, an object with ``controls(t)``
            (a plan), or 5 constants; sampled at every JSBSim step.
        t_span : (t0, t1)
        x0 : array of 12, optional
            Initial wind-frame state; default the source's ``initial_state``.
        env : Environment, optional
            ISA or constant density, and g; default the source's ``env``, else the ISA.
        controller : callable ``(t, x) -> 5 corrections``, optional
            Added to the controls, sampled at every step (see the class notes).
        dt_out : float
            Output interval; the step divides it exactly.
        t_eval : array, optional
            Output times, on the step grid (a uniform grid always is).

        Returns
        -------
        gna.simulate.SimulationResult
            Same columns as the in-house engine; ``settings`` records the step,
            integrators, planet, environment and timing.  A divergence
            (non-finite or vanishing airspeed, JSBSim stopping, non-finite
            controls) ends the run with ``status == "domain"``, a message
            naming the time, variable and value, and the outputs up to then.

        Raises
        ------
        InputError
            Bad span, state, controls at t0, step grid or atmosphere model.
        EngineError
            JSBSim refused the file or an initial condition.
        """
        env = environment_of(controls, env)
        y0 = initial_state(controls, x0)
        t0, t1 = _check_span(t_span)
        ufun = control_function(controls)
        density = _density_settings(env)
        n, dt, out_steps = self._grid(t0, t1, dt_out, t_eval)
        times = t0 + np.arange(n + 1) * dt
        U = controls_on_grid(ufun, times)

        t_setup = time.perf_counter()
        fdm, load_problems, capture = load_fdm(self.xml(aircraft, env, y0), aircraft.id)
        with capture:
            return self._run(fdm, capture, load_problems, aircraft, env, y0, t0, t1, n, dt, out_steps, times, U,
                             density, controller, t_setup)

    def _run(self, fdm, capture, load_problems, aircraft, env, y0, t0, t1, n, dt, out_steps, times, U, density,
             controller, t_setup) -> SimulationResult:
        wgs84 = self.earth == "wgs84"
        fdm.set_debug_level(0)  # no per-step debug records (10 % of a step); warnings still reach the capture
        if not wgs84:
            fdm["simulation/gravity-model"] = 0
        for prop, code in self.integrators.properties().items():
            fdm[prop] = code
        fdm.set_dt(dt)
        for prop, value in density.items():
            fdm[prop] = value
        lat0, lon0 = (self.latitude, self.longitude) if wgs84 else (0.0, 0.0)
        for prop, value in initial_condition_properties(y0, lat0, lon0, geodetic_altitude=wgs84):
            fdm[prop] = value
        # Verify (a write to a read-only property is silently ignored); altitudes are quantised by the
        # ECEF position of the planet's radius.
        ulp_ft = 8.0 * float(np.spacing(max(self.planet_radius_ft, _WGS84_A_FT)))
        for prop, value in initial_condition_properties(y0, lat0, lon0, geodetic_altitude=wgs84):
            got = fdm[prop]
            tol = 1e-9 * max(1.0, abs(value)) + (ulp_ft if prop.startswith("ic/h-") else 0.0)
            diff = math.remainder(got - value, 2.0 * math.pi) if prop.endswith("-rad") else got - value
            if not abs(diff) <= tol:
                raise EngineError(f"JSBSim did not accept the initial condition {prop} = {value!r} (reads {got!r})")

        pm = fdm.get_property_manager()

        def node(name):
            nd = pm.get_node(name, False)
            if nd is None:
                raise EngineError(f"JSBSim property {name!r} does not exist in the loaded model")
            return nd

        writers = [node(p).set_double_value for p in (*jx.THRUST_PROPERTIES, *jx.CONTROL_PROPERTIES.values())]
        pos_nodes = _STATE_NODES_WGS84 if wgs84 else _STATE_NODES_FLAT
        state_readers = [node(p).get_double_value for p in pos_nodes + _STATE_NODES]
        derived_readers = [node(p).get_double_value for p in _DERIVED_NODES]
        vt = node("velocities/vt-fps").get_double_value

        lbf = units.LBF
        F = U[0]
        eta = U[1]
        # Engine thrusts (lbf), surfaces: precomputed on the step grid when there is no feedback.
        F1 = (F * (1.0 + eta) * 0.5 / lbf).tolist()
        F2 = (F * (1.0 - eta) * 0.5 / lbf).tolist()
        DL, DM, DN = U[2].tolist(), U[3].tolist(), U[4].tolist()
        applied = U.copy()
        radius_ft = fdm["inertial/sea-level-radius_ft"]

        def write(uvec):
            Fk, ek = uvec[0], uvec[1]
            writers[0](Fk * (1.0 + ek) * 0.5 / lbf)
            writers[1](Fk * (1.0 - ek) * 0.5 / lbf)
            writers[2](uvec[2])
            writers[3](uvec[3])
            writers[4](uvec[4])

        geo = (self.latitude, self.longitude) if wgs84 else None
        to_state = _StateConverter(y0, radius_ft, geo)
        status, message = "completed", ""
        raw_states, raw_derived, out_index = [], [], []
        out_set = np.zeros(n + 1, dtype=bool)
        out_set[out_steps] = True
        out_list = out_set.tolist()

        bad_u = ~np.all(np.isfinite(U), axis=0)
        k_bad = int(np.argmax(bad_u)) if bad_u.any() else n + 1
        if controller is not None:
            applied[:, 0] = U[:, 0] + np.asarray(controller(t0, y0.copy()), dtype=float).reshape(5)
        if not np.all(np.isfinite(applied[:, 0])):
            names = [f"{c} = {v}" for c, v in zip(CONTROL_NAMES, applied[:, 0]) if not math.isfinite(v)]
            raise InputError(f"controls at t0 = {t0:g} s are not finite ({', '.join(names)})")
        write(applied[:, 0])
        fdm.set_sim_time(t0)
        try:
            ok = fdm.run_ic()
        except Exception as exc:
            raise EngineError(f"JSBSim run_ic failed for {aircraft.id}: {exc}") from None
        if not ok:
            raise EngineError(f"JSBSim run_ic failed for {aircraft.id}: {' | '.join(capture.problems())}")
        if out_list[0]:
            raw_states.append([r() for r in state_readers])
            raw_derived.append([r() for r in derived_readers])
            out_index.append(0)

        run = fdm.run
        k = 0
        t_loop = time.perf_counter()
        t_end = t1
        try:
            if controller is None:
                w0, w1, w2, w3, w4 = writers
                for k in range(1, n + 1):
                    if k >= k_bad:
                        raise _Stop(k, "control", U[:, k])
                    w0(F1[k]); w1(F2[k]); w2(DL[k]); w3(DM[k]); w4(DN[k])
                    if not run():
                        raise _Stop(k, "jsbsim", None)
                    v = vt()
                    if not (0.0 < v < math.inf):
                        raise _Stop(k, "V", v)
                    if out_list[k]:
                        raw_states.append([r() for r in state_readers])
                        raw_derived.append([r() for r in derived_readers])
                        out_index.append(k)
            else:
                ucols = U.T.tolist()
                tlist = times.tolist()
                isfinite = math.isfinite
                for k in range(1, n + 1):
                    if not run():
                        raise _Stop(k, "jsbsim", None)
                    v = vt()
                    if not (0.0 < v < math.inf):
                        raise _Stop(k, "V", v)
                    xk = to_state.scalar([r() for r in state_readers])
                    corr = np.asarray(controller(tlist[k], xk), dtype=float).reshape(5).tolist()
                    uk = [a + b for a, b in zip(ucols[k], corr)]
                    applied[:, k] = uk
                    if not all(isfinite(c) for c in uk):
                        raise _Stop(k, "control", uk)
                    write(uk)
                    fdm.suspend_integration()
                    try:
                        run()
                    finally:
                        fdm.resume_integration()
                    if out_list[k]:
                        raw_states.append([r() for r in state_readers])
                        raw_derived.append([r() for r in derived_readers])
                        out_index.append(k)
        except _Stop as stop:
            status = "domain"
            t_end = float(times[out_index[-1]]) if out_index else t0
            message = stop.describe(times[stop.k]) + f"; result kept up to t = {t_end:.6g} s"
        except _import_jsbsim().BaseError as exc:  # JSBSim's own exceptions (e.g. geographic errors on divergence)
            status = "domain"
            t_fail = float(times[k])
            t_end = float(times[out_index[-1]]) if out_index else t0
            message = (f"JSBSim stopped at t = {t_fail:.6g} s with {type(exc).__name__}: {exc}; "
                       f"result kept up to t = {t_end:.6g} s")

        t_post = time.perf_counter()
        idx = np.asarray(out_index, dtype=int)
        S = to_state.vector(np.array(raw_states, dtype=float).T.reshape(len(pos_nodes) + len(_STATE_NODES), -1))
        D = np.array(raw_derived, dtype=float).T.reshape(len(_DERIVED_NODES), -1)
        df = _frame(aircraft, env, times[idx], S, applied[:, idx], D)
        warnings = envelope_warnings(aircraft, df) + [f"JSBSim: {p}" for p in load_problems]
        near = np.abs(df["gamma"].to_numpy()) > 0.5 * math.pi - 1e-3
        if near.any():
            warnings.append(f"the flight path came within 1e-3 rad of vertical at t = {df.index[near.argmax()]:.4g} s: "
                            f"the wind-frame chart is singular there (chi and mu are ill-defined; the in-house "
                            f"engine stops)")
        settings = {
            "engine": self.name, "jsbsim_version": _import_jsbsim().__version__,
            "dt": dt, "dt_max": self.dt, "steps": n, "integrators": self.integrators.as_dict(),
            "earth": self.earth,
            "planet": ({"radius_ft": self.planet_radius_ft, "GM_ft3_s2": jx.FlatPlanet(env.g, -float(y0[2]),
                                                                                         self.planet_radius_ft).GM,
                        "h_ref_m": -float(y0[2]), "rotation_rad_s": 0.0, "J2": 0.0, "gravity_model": 0}
                       if not wgs84 else {"model": "JSBSim default WGS84, rotating, J2 gravity",
                                          "latitude_rad": self.latitude, "longitude_rad": self.longitude}),
            "environment": env.atmosphere.describe() + " (written into the aircraft file)", "g": env.g,
            "control_timing": "u(t_k) written before the run() reaching t_k; u(t0) before run_ic()",
            "controller": None if controller is None else "sampled every step at the propagated state",
            "wall_time_s": {"setup": t_loop - t_setup, "stepping": t_post - t_loop,
                            "conversion": time.perf_counter() - t_post},
        }
        return SimulationResult(df=df, status=status, message=message, warnings=warnings, settings=settings,
                                t_end=t_end if status != "completed" else t1)


class _Stop(Exception):
    def __init__(self, k: int, what: str, value):
        self.k, self.what, self.value = k, what, value

    def describe(self, t: float) -> str:
        if self.what == "V":
            return f"JSBSim diverged at t = {t:.6g} s: airspeed V = {self.value * units.FT:.6g} m/s"
        if self.what == "control":
            bad = [f"{n} = {v}" for n, v in zip(CONTROL_NAMES, self.value) if not math.isfinite(v)]
            return f"non-finite control at t = {t:.6g} s ({', '.join(bad)})"
        return f"JSBSim asked to stop (run() returned false) at t = {t:.6g} s"


class _StateConverter:
    """JSBSim raw outputs -> the 12 wind-frame states (scalar per step, or vectorised)."""

    def __init__(self, x0: np.ndarray, radius_ft: float, wgs84: tuple[float, float] | None):
        self.x0 = np.asarray(x0, dtype=float)
        self.wgs84 = wgs84
        if wgs84 is None:
            self.rm = self.rn = radius_ft
            self.lat0 = self.lon0 = 0.0
        else:
            lat0, lon0 = wgs84
            a, b = _WGS84_A_FT, _WGS84_B_FT
            e2 = 1.0 - (b / a) ** 2
            w = 1.0 - e2 * math.sin(lat0) ** 2
            self.rn = a / math.sqrt(w)                  # normal (prime vertical) radius
            self.rm = a * (1.0 - e2) / w ** 1.5          # meridian radius
            self.lat0, self.lon0 = lat0, lon0
        self._chi, self._mu = float(self.x0[5]), float(self.x0[8])

    def _states(self, raw, sin, cos, atan2):
        lat, lon, h, vt, gamma, psi_gt, alpha, beta, phi, theta, psi, p, q, r = raw
        ft = units.FT
        x = self.x0[0] + ft * (self.rm + h) * (lat - self.lat0)
        y = self.x0[1] + ft * (self.rn + h) * cos(lat if self.wgs84 is None else self.lat0) * (lon - self.lon0)
        return [x, y, -ft * h, vt * ft, gamma, psi_gt, alpha, beta, _mu(alpha, beta, phi, theta, sin, cos, atan2),
                p, q, r]

    def vector(self, raw: np.ndarray) -> np.ndarray:
        """Raw outputs (14, n) -> states (12, n); chi and mu unwrapped from x0's values."""
        s = np.array(self._states(raw, np.sin, np.cos, np.arctan2), dtype=float).reshape(12, -1)
        s[5] = _align(s[5], self.x0[5])
        s[8] = _align(s[8], self.x0[8])
        return s

    def scalar(self, raw: Sequence[float]) -> np.ndarray:
        """One step (pure-Python arithmetic), chi and mu continued from the previous call."""
        s = self._states(raw, math.sin, math.cos, math.atan2)
        s[5] = self._chi + math.remainder(s[5] - self._chi, 2.0 * math.pi)
        s[8] = self._mu + math.remainder(s[8] - self._mu, 2.0 * math.pi)
        self._chi, self._mu = s[5], s[8]
        return np.array(s)


def _frame(aircraft: Aircraft, env: Environment, t: np.ndarray, S: np.ndarray, U: np.ndarray,
           D: np.ndarray) -> pd.DataFrame:
    """The common DataFrame from JSBSim's states and its own derived outputs."""
    qbar, rho = D[0] * (units.LBF / units.FT2), D[1] * units.SLUG_FT3
    coeffs = D[2:8]
    fb = D[8:11] * units.LBF          # aerodynamic + thrust, body axes
    wb = D[11:14] * units.LBF         # weight, body axes
    mom = D[14:17] * (units.LBF * units.FT)
    alpha, beta = S[6], S[7]
    ca, sa, cb, sb = np.cos(alpha), np.sin(alpha), np.cos(beta), np.sin(beta)
    tot = fb + wb

    def to_wind(v):
        return (ca * cb * v[0] + sb * v[1] + sa * cb * v[2],
                -ca * sb * v[0] + cb * v[1] - sa * sb * v[2],
                -sa * v[0] + ca * v[2])

    X, Y, Z = to_wind(tot)
    mg = aircraft.mass.mass * env.g
    data = {n: S[i] for i, n in enumerate(STATE_NAMES)}
    data.update({n: U[i] for i, n in enumerate(CONTROL_NAMES)})
    data.update(qbar=qbar, rho=rho, nx=fb[0] / mg, ny=fb[1] / mg, nz=-fb[2] / mg, X=X, Y=Y, Z=Z,
                L=mom[0], M=mom[1], N=mom[2])
    data.update({n: coeffs[i] for i, n in enumerate(("CD", "CY", "CL", "Cl", "Cm", "Cn"))})
    return pd.DataFrame({k: np.asarray(data[k], dtype=float) for k in COLUMNS}, index=pd.Index(t, name="t"))


# --------------------------------------------------------------------------- registry and fly()

ENGINES: dict[str, type] = {"inhouse": InHouseEngine, "jsbsim": JSBSimEngine}


def get_engine(engine) -> object:
    """An engine object from a name (``"inhouse"``, ``"jsbsim"``) or an engine object."""
    if isinstance(engine, str):
        try:
            return ENGINES[engine]()
        except KeyError:
            raise InputError(f"unknown engine {engine!r}; choose from {', '.join(ENGINES)}") from None
    if not callable(getattr(engine, "simulate", None)):
        raise InputError(f"{engine!r} is not an engine (it has no simulate method)")
    return engine


def fly(engines, aircraft: Aircraft, x0, controls, t_span, *, env: Environment | None = None,
        controller: Controller | None = None, dt_out: float = 0.02,
        t_eval: np.ndarray | None = None) -> dict[str, SimulationResult]:
    """Fly the same problem on several engines, on the same output grid.

    Parameters
    ----------
    engines : iterable of str or engine objects, or mapping label -> engine
        E.g. ``("inhouse", "jsbsim")``, or
        ``{"flat": JSBSimEngine(), "wgs84": JSBSimEngine(earth="wgs84")}``.
    aircraft : Aircraft
    x0 : array of 12, or None
        Initial wind-frame state (``None``: the control source's ``initial_state``).
    controls : control source
        Callable ``t -> 5 controls``, a plan exposing ``controls(t)`` (and
        ``initial_state``), or 5 constants.
    t_span : (t0, t1)
    env : Environment, optional
        Default: the control source's ``env`` (a plan's), else ISA.
    controller : callable ``(t, x) -> 5 corrections``, optional
    dt_out, t_eval
        Output grid, the same for every engine.

    Returns
    -------
    dict
        Label (engine name unless a mapping was given) -> :class:`gna.simulate.SimulationResult`,
        in the order given.
    """
    env = environment_of(controls, env)  # a plan flies in the environment it was planned for
    if isinstance(engines, Mapping):
        pairs = [(str(k), get_engine(e)) for k, e in engines.items()]
    else:
        pairs = [(o.name, o) for o in (get_engine(e) for e in engines)]
    if not pairs:
        raise InputError("no engine to fly")
    labels = [p[0] for p in pairs]
    if len(set(labels)) != len(labels):
        raise InputError(f"engine labels must be distinct, got {', '.join(labels)}; pass a mapping label -> engine")
    y0 = initial_state(controls, x0)
    return {label: e.simulate(aircraft, controls, t_span, y0, env=env, controller=controller, dt_out=dt_out,
                              t_eval=t_eval) for label, e in pairs}
