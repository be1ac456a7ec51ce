"""Loading a JSBSim aircraft, capturing its log, integrator settings and exact initial conditions.

Facts used here (``docs/jsbsim.md``): ``fdm.set_dt`` sets the step (writing
``simulation/dt`` is ignored); the integrators are chosen per state group
through ``simulation/integrator/{rate,position}/{rotational,translational}``;
the initial condition is exact through the Euler angles and body velocities.
"""

from __future__ import annotations

import math
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from gna import units
from gna.atmosphere import ISA, ConstantDensity, Environment
from gna.errors import InputError, describe
from gna.frames import euler_from_wind
from gna.schema import check_name

from ..base import EngineError
from . import export as jx

#: WGS84 semi-axes as JSBSim defines them [ft].
WGS84_A_FT = 20925646.32546
WGS84_B_FT = 20855486.5951


#: JSBSim integrator codes (``simulation/integrator/...``).
INTEGRATOR_CODES: dict[str, int] = {
    "none": 0,
    "Euler": 1,
    "trapezoidal": 2,
    "AB2": 3,
    "AB3": 4,
    "AB4": 5,
    "Buss1": 6,
    "Buss2": 7,
    "local-linearization": 8,
    "AB5": 9,
}
_QUATERNION_ONLY = ("Buss1", "Buss2", "local-linearization")


@dataclass(frozen=True)
class Integrators:
    """JSBSim's four integrator choices (names of :data:`INTEGRATOR_CODES`).

    The default, Adams-Bashforth 4 with Buss's second-order quaternion
    integrator, is second order overall with smooth inputs and the most
    accurate in the convergence study of ``docs/jsbsim.md``.

    Parameters
    ----------
    rotational_rate, translational_rate : str
        Integrators of the body rates and of the velocity.
    rotational_position : str
        Integrator of the attitude quaternion (also Buss1, Buss2, local-linearization).
    translational_position : str
        Integrator of the position.
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
        """The four choices by role.

        Returns
        -------
        dict of str to str
            ``rotational_rate``, ``translational_rate``, ``rotational_position``,
            ``translational_position`` -> integrator name.
        """
        return {
            "rotational_rate": self.rotational_rate,
            "translational_rate": self.translational_rate,
            "rotational_position": self.rotational_position,
            "translational_position": self.translational_position,
        }

    def properties(self) -> dict[str, int]:
        """The JSBSim property writes selecting these integrators.

        Returns
        -------
        dict of str to int
            ``simulation/integrator/...`` property -> integrator code (:data:`INTEGRATOR_CODES`).
        """
        return {
            "simulation/integrator/rate/rotational": INTEGRATOR_CODES[self.rotational_rate],
            "simulation/integrator/rate/translational": INTEGRATOR_CODES[self.translational_rate],
            "simulation/integrator/position/rotational": INTEGRATOR_CODES[self.rotational_position],
            "simulation/integrator/position/translational": INTEGRATOR_CODES[self.translational_position],
        }


#: JSBSim's default integrators (Euler, AB2, Euler, AB3), for comparisons.
JSBSIM_DEFAULT_INTEGRATORS = Integrators("Euler", "AB2", "Euler", "AB3")


class LogCapture:
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
        """Non-empty WARN, ERROR and FATAL records.

        Returns
        -------
        list of str
            The texts of JSBSim's warnings and errors, in the order they came.
        """
        warn = int(self._jsbsim.LogLevel.WARN)
        stdout = int(self._jsbsim.LogLevel.STDOUT)
        return [text for level, text in self.logger.records if warn <= level < stdout]


def import_jsbsim():
    """The ``jsbsim`` module.

    Returns
    -------
    module

    Raises
    ------
    EngineError
        If the package is not installed.
    """
    try:
        import jsbsim
    except ImportError as exc:  # pragma: no cover - jsbsim is a declared dependency
        raise EngineError(f"the JSBSim engine needs the 'jsbsim' package ({describe(exc)})") from None
    return jsbsim


def load_fdm(xml_text: str, aircraft_id: str):
    """Load an aircraft file into a new ``jsbsim.FGFDMExec``, its console output captured.

    Parameters
    ----------
    xml_text : str
        The aircraft file.
    aircraft_id : str
        Its identifier (file name ``aircraft/<id>/<id>.xml`` in a temporary root).

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
    InputError
        If ``aircraft_id`` is not a safe identifier (it names the temporary file).
    """
    check_name(aircraft_id, "aircraft id", "JSBSim engine")  # the file stays inside the temporary folder
    jsbsim = import_jsbsim()
    capture = LogCapture(jsbsim)
    with tempfile.TemporaryDirectory(prefix="gflat-jsbsim-") as root, capture:
        path = Path(root) / "aircraft" / aircraft_id / f"{aircraft_id}.xml"
        path.parent.mkdir(parents=True)
        path.write_text(xml_text, encoding="utf-8")
        fdm = jsbsim.FGFDMExec(root)
        try:
            ok = fdm.load_model(aircraft_id)
        except Exception as exc:  # JSBSim raises its own exception types
            raise EngineError(
                f"JSBSim could not load aircraft {aircraft_id!r}: {describe(exc)}; "
                f"messages: {' | '.join(capture.problems()) or 'none'}"
            ) from None
    if not ok:
        raise EngineError(
            f"JSBSim could not load aircraft {aircraft_id!r}: "
            f"{' | '.join(capture.problems()) or 'load_model returned False'}"
        )
    return fdm, capture.problems(), capture


def density_settings(env: Environment) -> dict[str, float]:
    """The properties selecting the file's density model for ``env``'s atmosphere.

    Parameters
    ----------
    env : Environment
        ISA or constant density.

    Returns
    -------
    dict
        Property name -> value.

    Raises
    ------
    InputError
        For an atmosphere the exported file cannot reproduce.
    """
    atm = env.atmosphere
    if isinstance(atm, ConstantDensity):
        return {jx.DENSITY_MODEL_PROPERTY: 1.0, jx.DENSITY_CONSTANT_PROPERTY: atm.rho / units.SLUG_FT3}
    if isinstance(atm, ISA):
        return {jx.DENSITY_MODEL_PROPERTY: 0.0}
    raise InputError(
        f"the JSBSim engine has no counterpart of the atmosphere model {type(atm).__name__}; "
        f"use gna.atmosphere.ISA or ConstantDensity"
    )


def initial_condition_properties(
    x0: np.ndarray, latitude: float = 0.0, longitude: float = 0.0, geodetic_altitude: bool = False
) -> list[tuple[str, float]]:
    """The ``ic/*`` writes (in order) that put JSBSim exactly at the wind-frame state ``x0``.

    Position at (``latitude``, ``longitude``) and altitude ``-z``; attitude
    through the Euler angles of ``C_bn = C_bw(alpha, beta) C_wn(gamma, chi, mu)``;
    body velocity ``V (cos a cos b, sin b, sin a cos b)``; body rates.  This
    route is exact and independent of order (``docs/jsbsim.md``).  With
    ``geodetic_altitude`` the altitude is written as ``ic/h-agl-ft`` (height
    above the WGS84 ellipsoid, the terrain being at zero: ``ic/geod-alt-ft``
    is read-only and ``ic/h-sl-ft`` geocentric).

    Parameters
    ----------
    x0 : ndarray, shape (12,)
        Wind-frame state (SI, rad).
    latitude, longitude : float
        Initial position [rad].
    geodetic_altitude : bool
        Write the altitude above the WGS84 ellipsoid.

    Returns
    -------
    list of (str, float)
        Property and value, in writing order.
    """
    x, y, z, V, gamma, chi, alpha, beta, mu, p, q, r = (float(v) for v in x0)
    phi, theta, psi = euler_from_wind(gamma, chi, mu, alpha, beta)
    Vf = V / units.FT
    return [
        ("ic/lat-geod-rad", latitude),
        ("ic/long-gc-rad", longitude),
        ("ic/h-agl-ft" if geodetic_altitude else "ic/h-sl-ft", -z / units.FT),
        ("ic/phi-rad", phi),
        ("ic/theta-rad", theta),
        ("ic/psi-true-rad", psi),
        ("ic/u-fps", Vf * math.cos(alpha) * math.cos(beta)),
        ("ic/v-fps", Vf * math.sin(beta)),
        ("ic/w-fps", Vf * math.sin(alpha) * math.cos(beta)),
        ("ic/p-rad_sec", p),
        ("ic/q-rad_sec", q),
        ("ic/r-rad_sec", r),
    ]


def set_stepping(fdm, integrators: Integrators, dt: float, *, flat: bool) -> None:
    """What every JSBSim engine sets before its initial condition: debug records off, gravity, integrators, step.

    Parameters
    ----------
    fdm : jsbsim.FGFDMExec
        A loaded aircraft.
    integrators : Integrators
        Integrator choice.
    dt : float
        Step [s].
    flat : bool
        A flat-earth planet: ``simulation/gravity-model`` 0 (``GM/r^2``, no J2); else JSBSim's WGS84 gravity.
    """
    fdm.set_debug_level(0)  # no per-step debug records (10 % of a step); warnings still reach the capture
    if flat:
        fdm["simulation/gravity-model"] = 0
    for prop, code in integrators.properties().items():
        fdm[prop] = code
    fdm.set_dt(dt)


def prepare(
    fdm,
    integrators: Integrators,
    dt: float,
    env: Environment,
    x0: np.ndarray,
    *,
    wgs84: bool = False,
    latitude: float = 0.0,
    longitude: float = 0.0,
    planet_radius_ft: float = jx.PLANET_RADIUS_FT,
) -> None:
    """Set gravity model, integrators, step, density model and the exact initial condition; verify them.

    Parameters
    ----------
    fdm : jsbsim.FGFDMExec
        A loaded aircraft (:func:`load_fdm`).
    integrators : Integrators
        Integrator choice.
    dt : float
        Step [s].
    env : Environment
        Atmosphere (:func:`density_settings`).
    x0 : ndarray, shape (12,)
        Initial wind-frame state.
    wgs84 : bool
        JSBSim's rotating WGS84 Earth (else the file's flat planet and gravity model 0).
    latitude, longitude : float
        Initial position on the WGS84 Earth [rad].
    planet_radius_ft : float
        Radius of the flat planet [ft] (bounds the altitude quantisation).

    Raises
    ------
    InputError
        For an atmosphere the file cannot reproduce.
    EngineError
        If JSBSim did not accept an initial condition (read-back differs).
    """
    density = density_settings(env)
    set_stepping(fdm, integrators, dt, flat=not wgs84)
    for prop, value in density.items():
        fdm[prop] = value
    lat0, lon0 = (latitude, longitude) if wgs84 else (0.0, 0.0)
    writes = initial_condition_properties(x0, lat0, lon0, geodetic_altitude=wgs84)
    for prop, value in writes:
        fdm[prop] = value
    check_initial_condition(fdm, writes, max(planet_radius_ft, WGS84_A_FT))


def check_initial_condition(fdm, writes: list[tuple[str, float]], radius_ft: float) -> None:
    """Read the ``ic/*`` writes back (a write to a read-only property is silently ignored).

    Parameters
    ----------
    fdm : jsbsim.FGFDMExec
        The FDM the writes went to.
    writes : list of (str, float)
        :func:`initial_condition_properties`.
    radius_ft : float
        Planet radius [ft]: altitudes are quantised by the ECEF position of that radius (8 ulp allowed).

    Raises
    ------
    EngineError
        If a property reads back another value.
    """
    ulp_ft = 8.0 * float(np.spacing(radius_ft))
    for prop, value in writes:
        got = fdm[prop]
        tol = 1e-9 * max(1.0, abs(value)) + (ulp_ft if prop.startswith("ic/h-") else 0.0)
        diff = math.remainder(got - value, 2.0 * math.pi) if prop.endswith("-rad") else got - value
        if not abs(diff) <= tol:
            raise EngineError(f"JSBSim did not accept the initial condition {prop} = {value!r} (reads {got!r})")
