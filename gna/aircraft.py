"""Aircraft definitions: geometry, mass, inertia, engines, envelope, aerodynamics.

An aircraft is a TOML file in ``gna/data/aircraft/`` (or any path given by the
user).  Each quantity may be written in SI or in the units it was published
in, the unit being part of the key (``mass_kg`` or ``weight_lb``, ``S_m2`` or
``S_ft2``, ...); conversion to SI uses the exact factors of
:mod:`gna.units`.  Every section carries a ``source`` string and the file a
``[provenance]`` table, so the numbers never travel without their origin.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from . import units
from .aero import TermTable
from .catalogue import bundled
from .errors import InputError, UnknownAircraftError
from .schema import check_name, find_file, load_schema, read_toml, validate

#: Accepted unit suffixes of each kind of quantity, with their factor to SI.
UNIT_FACTORS: dict[str, dict[str, float]] = {
    "mass": {"kg": 1.0, "slug": units.SLUG},
    "weight": {"lb": units.LBM, "N": 1.0 / units.G0},  # -> mass in kg (W/g0)
    "inertia": {"kgm2": 1.0, "slugft2": units.SLUG_FT2},
    "length": {"m": 1.0, "ft": units.FT, "in": units.IN},
    "area": {"m2": 1.0, "ft2": units.FT2},
    "angle": {"rad": 1.0, "deg": units.DEG},
    "force": {"N": 1.0, "lbf": units.LBF},
    "power": {"W": 1.0, "kW": 1000.0, "shp": units.HP},
    "speed": {"ms": 1.0, "kt": units.KT, "fps": units.FT},
    "time": {"s": 1.0},
}


def _get(table: Mapping[str, Any], name: str, kind: str, where: str, default: Any = ...) -> float:
    """Read ``name_<unit>`` from ``table`` and convert to SI."""
    found = [(u, f) for u, f in UNIT_FACTORS[kind].items() if f"{name}_{u}" in table]
    if kind == "mass":
        weights = [("weight_" + u, f) for u, f in UNIT_FACTORS["weight"].items() if f"weight_{u}" in table]
        if found and weights:
            raise InputError(f"{where}: {name}_{found[0][0]} and {weights[0][0]} give the mass twice; keep one")
        if weights:
            key, factor = weights[0]
            return _check(_number(table[key], key, where) * factor, key, where)
    if not found:
        if default is ...:
            keys = ", ".join(f"{name}_{u}" for u in UNIT_FACTORS[kind])
            raise InputError(f"{where}: missing {name!r} (one of {keys})")
        return default
    if len(found) > 1:
        raise InputError(f"{where}: {name!r} given in several units")
    u, factor = found[0]
    return _check(_number(table[f"{name}_{u}"], f"{name}_{u}", where) * factor, f"{name}_{u}", where)


def _curve(e: Mapping[str, Any], where: str) -> tuple:
    """``engine_thrust_curve_speed_ms`` and ``engine_thrust_curve_N``, paired (both or neither)."""
    V, T = e.get("engine_thrust_curve_speed_ms"), e.get("engine_thrust_curve_N")
    if V is None and T is None:
        return ()
    if V is None or T is None or len(V) != len(T) or len(V) < 2:
        raise InputError(
            f"{where}: engine_thrust_curve_speed_ms and engine_thrust_curve_N are two lists of the same length "
            f"(at least 2)"
        )
    return tuple(
        (_number(v, "engine_thrust_curve_speed_ms", where), _number(t, "engine_thrust_curve_N", where))
        for v, t in zip(V, T)
    )


def _number(value: Any, key: str, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise InputError(f"{where}: {key} = {value!r} must be a number")
    return float(value)


@contextmanager
def _naming(where: str):
    """Prefix the file and table to the errors of a section's own checks (positive mass, envelope...)."""
    try:
        yield
    except InputError as exc:
        if str(exc).startswith(where.split(" [")[0]):
            raise
        raise InputError(f"{where}: {exc}") from None


def _plain(table: Mapping[str, Any], key: str, where: str) -> float | None:
    """An optional dimensionless number (Mach, load factor), None when absent."""
    return None if key not in table else _check(_number(table[key], key, where), key, where)


def _check(value: float, key: str, where: str) -> float:
    if not math.isfinite(value):
        raise InputError(f"{where}: {key} is {value}")
    return value


@dataclass(frozen=True)
class MassProperties:
    """Mass [kg] and inertia [kg m^2] in body axes (xz plane of symmetry).

    ``Ixz`` follows the flight-dynamics convention ``Ixz = integral(x z dm)``
    (positive for most aircraft), as in paper eq. (aircraft2).
    """

    mass: float
    Ixx: float
    Iyy: float
    Izz: float
    Ixz: float
    source: str = ""

    def __post_init__(self):
        if not self.mass > 0:
            raise InputError(f"mass must be positive, got {self.mass} kg")
        for k in ("Ixx", "Iyy", "Izz"):
            if not getattr(self, k) > 0:
                raise InputError(f"{k} must be positive, got {getattr(self, k)} kg m^2")
        det = self.Ixx * self.Izz - self.Ixz**2
        if not det > 0:
            raise InputError(f"inertia matrix not positive definite (Ixx Izz - Ixz^2 = {det})")
        # Triangle inequalities of a physical body.
        a, b, c = self.Ixx, self.Iyy, self.Izz
        if a + b < c * (1 - 1e-9) or a + c < b * (1 - 1e-9) or b + c < a * (1 - 1e-9):
            raise InputError(f"inertias violate the triangle inequality: Ixx={a}, Iyy={b}, Izz={c}")

    @property
    def inertia_matrix(self) -> np.ndarray:
        return np.array([[self.Ixx, 0.0, -self.Ixz], [0.0, self.Iyy, 0.0], [-self.Ixz, 0.0, self.Izz]])


@dataclass(frozen=True)
class Geometry:
    """Reference geometry.

    ``x_cg`` and ``x_ref`` are positions along the body x axis, measured *aft*
    of the leading edge of the mean aerodynamic chord, in metres; the moments
    of the aerodynamic model are about ``x_ref`` and are transferred to the
    centre of gravity ``x_cg``.
    """

    S: float
    b: float
    cbar: float
    x_cg: float = 0.0
    x_ref: float = 0.0
    source: str = ""

    def __post_init__(self):
        for k in ("S", "b", "cbar"):
            if not getattr(self, k) > 0:
                raise InputError(f"{k} must be positive, got {getattr(self, k)}")


@dataclass(frozen=True)
class Propulsion:
    """Propulsion layout.

    ``count`` is 1 (on the symmetry plane) or 2 (at ``y = -y_p`` for engine 1,
    left, and ``y = +y_p`` for engine 2, right).  The thrust line is tilted by
    ``epsilon`` nose-up from the body x axis: body-axis direction
    ``(cos eps, 0, -sin eps)``.

    Propulsive moments (:func:`gna.eom.body_moments`): the thrust line passes ``thrust_line_offset`` below
    the centre of gravity (pitching moment ``+thrust_line_offset * F``, nose up) and the propellers' torque
    gives a rolling moment ``torque_arm * F`` (positive right wing down), both 0 by default.  ``thrust_lag``
    is the first-order time constant of the thrust response [s] (0: immediate), ``thrust_curve`` the
    thrust of ONE engine at full throttle against airspeed, ``((V [m/s], T [N]), ...)`` (empty: unrated).
    """

    count: int = 1
    y_p: float = 0.0
    epsilon: float = 0.0
    max_thrust: float | None = None
    source: str = ""
    #: Rating of ONE engine: shaft power [W], propeller efficiency [-] and static thrust [N] (None: unrated),
    #: with its source; the thrust one engine can give at speed V is min(static, eff * power / V).
    engine_power: float | None = None
    propeller_efficiency: float | None = None
    engine_static_thrust: float | None = None
    engine_source: str = ""
    thrust_line_offset: float = 0.0
    torque_arm: float = 0.0
    thrust_lag: float = 0.0
    thrust_curve: tuple = ()

    def engine_thrust_limit(self, V: float) -> float | None:
        """Largest thrust of one engine at airspeed ``V`` from its rating.

        A propeller engine is power-limited in flight, ``T <= eff P / V``
        (e.g. Raymer, *Aircraft Design: A Conceptual Approach*, sec. 13.6),
        and capped by its static thrust; a measured :attr:`thrust_curve` is interpolated linearly (held at
        its ends) and caps both.

        Parameters
        ----------
        V : float
            Airspeed [m/s].

        Returns
        -------
        float or None
            Thrust [N]; None when the engine has no rating.
        """
        lims = []
        if self.thrust_curve:
            Vs, Ts = zip(*self.thrust_curve)
            lims.append(float(np.interp(V, Vs, Ts)))
        if self.engine_static_thrust is not None:
            lims.append(self.engine_static_thrust)
        if self.engine_power is not None and V > 0:
            lims.append((self.propeller_efficiency or 1.0) * self.engine_power / V)
        return min(lims) if lims else None

    def engine_thrust_limits(self, V) -> np.ndarray | None:
        """:meth:`engine_thrust_limit` at many airspeeds at once (the same values, element by element).

        Parameters
        ----------
        V : array_like, shape (n,)
            Airspeeds [m/s].

        Returns
        -------
        ndarray, shape (n,), or None
            Thrust of one engine [N]; None when the engine has no rating.
        """
        V = np.asarray(V, dtype=float)
        lims = []
        if self.thrust_curve:
            Vs, Ts = zip(*self.thrust_curve)
            lims.append(np.interp(V, Vs, Ts))
        if self.engine_static_thrust is not None:
            lims.append(np.full(V.shape, float(self.engine_static_thrust)))
        if self.engine_power is not None:
            with np.errstate(divide="ignore", invalid="ignore"):
                power = (self.propeller_efficiency or 1.0) * self.engine_power / V
            lims.append(np.where(V > 0, power, np.inf))  # no power limit at V <= 0, as the scalar rule
        if not lims:
            return None
        return np.minimum.reduce(lims) if len(lims) > 1 else lims[0]

    def __post_init__(self):
        if self.count not in (1, 2):
            raise InputError(f"engine count must be 1 or 2, got {self.count}")
        if self.y_p < 0:
            raise InputError(f"engine lateral offset y_p must be >= 0, got {self.y_p}")
        if self.count == 1 and self.y_p != 0:
            raise InputError("a single engine sits on the symmetry plane (y_p = 0)")
        if self.max_thrust is not None and not self.max_thrust > 0:
            raise InputError(f"max thrust must be positive, got {self.max_thrust}")
        for k in ("engine_power", "engine_static_thrust"):
            if getattr(self, k) is not None and not getattr(self, k) > 0:
                raise InputError(f"{k} must be positive, got {getattr(self, k)}")
        if not (math.isfinite(self.thrust_lag) and self.thrust_lag >= 0):
            raise InputError(f"thrust_lag must be >= 0 s, got {self.thrust_lag}")
        for k in ("thrust_line_offset", "torque_arm"):
            if not math.isfinite(getattr(self, k)):
                raise InputError(f"{k} must be finite, got {getattr(self, k)}")
        if self.thrust_curve:
            Vs = [v for v, _ in self.thrust_curve]
            if any(b <= a for a, b in zip(Vs, Vs[1:])) or any(not t >= 0 for _, t in self.thrust_curve):
                raise InputError("thrust curve: speeds must increase and thrusts be >= 0")
        if self.propeller_efficiency is not None and not 0 < self.propeller_efficiency <= 1:
            raise InputError(f"propeller_efficiency must lie in (0, 1], got {self.propeller_efficiency}")


@dataclass(frozen=True)
class Envelope:
    """Validity domain of the aerodynamic model [rad], control limits, and the optional Mach and load-factor ranges.

    ``mach_min``/``mach_max`` bound the Mach number of the data the aerodynamics were fitted or published
    on, ``nz_min``/``nz_max`` the structural load factor; None leaves that side unchecked.  The checks of
    all the limits are :mod:`gna.limits`.  ``declared`` is False when the aircraft file has no ``[envelope]``
    table (the defaults assumed: :class:`gna.limits.ValidityWarnings` says its validity is unknown).
    """

    alpha_min: float = math.radians(-10.0)
    alpha_max: float = math.radians(30.0)
    beta_max: float = math.radians(20.0)
    control_limits: Mapping[str, float] = field(default_factory=dict)
    source: str = ""
    mach_min: float | None = None
    mach_max: float | None = None
    nz_min: float | None = None
    nz_max: float | None = None
    declared: bool = True

    def __post_init__(self):
        if not self.alpha_min < self.alpha_max:
            raise InputError(
                f"alpha_min = {math.degrees(self.alpha_min):.6g} deg must be below "
                f"alpha_max = {math.degrees(self.alpha_max):.6g} deg"
            )
        if not 0 < self.beta_max <= math.pi / 2:
            raise InputError(f"beta_max = {math.degrees(self.beta_max):.6g} deg must be in (0, 90] deg")
        for name, lim in self.control_limits.items():
            if not lim > 0:
                raise InputError(f"{name}_max = {lim} rad must be positive")
        if self.mach_min is not None and not self.mach_min >= 0:
            raise InputError(f"mach_min = {self.mach_min:g} must be >= 0")
        for lo, hi in (("mach_min", "mach_max"), ("nz_min", "nz_max")):
            a, b = getattr(self, lo), getattr(self, hi)
            if a is not None and b is not None and not a < b:
                raise InputError(f"{lo} = {a:g} must be below {hi} = {b:g}")

    def violations(self, alpha, beta) -> list[str]:
        """Human-readable list of envelope violations (empty when inside).

        Parameters
        ----------
        alpha, beta : float or array_like
            Angle of attack and sideslip [rad], any matching shapes.

        Returns
        -------
        list of str
            One line per violated bound, with the extreme value reached [deg].
        """
        out = []
        a, b = np.asarray(alpha, dtype=float), np.asarray(beta, dtype=float)
        if np.any(a < self.alpha_min) or np.any(a > self.alpha_max):
            out.append(
                f"alpha outside [{math.degrees(self.alpha_min):.1f}, {math.degrees(self.alpha_max):.1f}] deg "
                f"(reached {math.degrees(float(np.min(a))):.2f} .. {math.degrees(float(np.max(a))):.2f} deg)"
            )
        if np.any(np.abs(b) > self.beta_max):
            out.append(
                f"|beta| above {math.degrees(self.beta_max):.1f} deg "
                f"(reached {math.degrees(float(np.max(np.abs(b)))):.2f} deg)"
            )
        return out


@dataclass(frozen=True)
class Aircraft:
    """A complete aircraft: the stateless vehicle model's parameters.

    Attributes
    ----------
    id : str
        Short identifier (``f16c``).
    name : str
    mass : MassProperties
    geometry : Geometry
    propulsion : Propulsion
    envelope : Envelope
    aero : TermTable
        The aerodynamic model (any object with ``coefficients(AeroState)``).
    provenance : dict
        Source, transformation and date of the data set.
    """

    id: str
    name: str
    mass: MassProperties
    geometry: Geometry
    propulsion: Propulsion
    envelope: Envelope
    aero: TermTable
    provenance: Mapping[str, str] = field(default_factory=dict)
    path: str | None = None

    def __post_init__(self):
        check_name(self.id, "id", f"aircraft {self.name!r}")
        if isinstance(self.aero, TermTable) and len(self.aero) == 0:
            raise InputError(f"aircraft {self.id}: the aerodynamic model has no terms")

    def summary(self) -> str:
        """One line: id, name, mass, reference geometry, engines and aerodynamic terms.

        Returns
        -------
        str
        """
        return (
            f"{self.id}: {self.name}; m = {self.mass.mass:.1f} kg, S = {self.geometry.S:.3f} m^2, "
            f"b = {self.geometry.b:.3f} m, cbar = {self.geometry.cbar:.3f} m, "
            f"{self.propulsion.count} engine(s), {len(self.aero)} aero terms ({self.aero.structure})"
        )


def aircraft_from_dict(data: Mapping[str, Any], where: str = "aircraft file", path: str | None = None) -> Aircraft:
    """Build an :class:`Aircraft` from the parsed TOML structure.

    Parameters
    ----------
    data : mapping
        The parsed file (see ``docs/scenarios.md`` and ``gna/data/schemas/aircraft.schema.json``).
    where : str
        The file's name, for messages.
    path : str, optional
        The file's path, kept on the aircraft.

    Returns
    -------
    Aircraft

    Raises
    ------
    InputError
        A key unknown to the schema, a conflicting or repeated key, a value of the wrong type or
        out of range, an unsafe ``id``: one line naming the file, the table, the key and the value.
    """
    if not isinstance(data, Mapping):
        raise InputError(f"{where}: an aircraft file is a table of tables, got {type(data).__name__}")
    validate(data, load_schema("gna", "data", "schemas", "aircraft.schema.json"), where)
    ident = check_name(data["id"], "id", where)
    where = f"{where} ({ident})"
    m = data["mass"]
    with _naming(where + " [mass]"):
        mass = MassProperties(
            mass=_get(m, "mass", "mass", where + " [mass]"),
            Ixx=_get(m, "Ixx", "inertia", where + " [mass]"),
            Iyy=_get(m, "Iyy", "inertia", where + " [mass]"),
            Izz=_get(m, "Izz", "inertia", where + " [mass]"),
            Ixz=_get(m, "Ixz", "inertia", where + " [mass]", 0.0),
            source=str(m.get("source", "")),
        )
    g = data["geometry"]
    cbar = _get(g, "cbar", "length", where + " [geometry]")
    if "x_cg_cbar" in g or "x_ref_cbar" in g:
        x_cg = _number(g.get("x_cg_cbar", g.get("x_ref_cbar", 0.0)), "x_cg_cbar", where + " [geometry]") * cbar
        x_ref = _number(g.get("x_ref_cbar", g.get("x_cg_cbar", 0.0)), "x_ref_cbar", where + " [geometry]") * cbar
    else:
        x_cg = _get(g, "x_cg", "length", where + " [geometry]", 0.0)
        x_ref = _get(g, "x_ref", "length", where + " [geometry]", x_cg)
    with _naming(where + " [geometry]"):
        geometry = Geometry(
            S=_get(g, "S", "area", where + " [geometry]"),
            b=_get(g, "b", "length", where + " [geometry]"),
            cbar=cbar,
            x_cg=x_cg,
            x_ref=x_ref,
            source=str(g.get("source", "")),
        )
    e = data.get("engines", {})
    with _naming(where + " [engines]"):
        w = where + " [engines]"
        propulsion = Propulsion(
            count=int(e.get("count", 1)),
            y_p=_get(e, "y_p", "length", w, 0.0),
            epsilon=_get(e, "epsilon", "angle", w, 0.0),
            max_thrust=_get(e, "max_thrust", "force", w, None),
            source=str(e.get("source", "")),
            engine_power=_get(e, "engine_power", "power", w, None),
            propeller_efficiency=(
                None
                if "propeller_efficiency" not in e
                else _check(_number(e["propeller_efficiency"], "propeller_efficiency", w), "propeller_efficiency", w)
            ),
            engine_static_thrust=_get(e, "engine_static_thrust", "force", w, None),
            engine_source=str(e.get("engine_source", "")),
            thrust_line_offset=_get(e, "thrust_line_offset", "length", w, 0.0),
            torque_arm=_get(e, "torque_arm", "length", w, 0.0),
            thrust_lag=_get(e, "thrust_lag", "time", w, 0.0),
            thrust_curve=_curve(e, w),
        )
    v = data.get("envelope", {})
    limits = {}
    for name in ("dl", "dm", "dn"):
        lim = _get(v, f"{name}_max", "angle", where + " [envelope]", None)
        if lim is not None:
            limits[name] = lim
    with _naming(where + " [envelope]"):
        envelope = Envelope(
            alpha_min=_get(v, "alpha_min", "angle", where + " [envelope]", math.radians(-10.0)),
            alpha_max=_get(v, "alpha_max", "angle", where + " [envelope]", math.radians(30.0)),
            beta_max=_get(v, "beta_max", "angle", where + " [envelope]", math.radians(20.0)),
            control_limits=limits,
            source=str(v.get("source", "")),
            **{k: _plain(v, k, where + " [envelope]") for k in ("mach_min", "mach_max", "nz_min", "nz_max")},
            declared="envelope" in data,
        )
    a = data["aero"]
    aero = TermTable.from_records(
        a["terms"], structure=str(a.get("structure", "custom")), where=f"{where} [aero.terms]"
    )
    aero.check_unique(f"{where} [aero.terms]")
    aero.check_structure(f"{where} [aero.terms]")
    prov = {k: str(val) for k, val in data.get("provenance", {}).items()}
    return Aircraft(
        id=ident,
        name=str(data.get("name", ident)),
        mass=mass,
        geometry=geometry,
        propulsion=propulsion,
        envelope=envelope,
        aero=aero,
        provenance=prov,
        path=path,
    )


def _catalogue() -> dict[str, Path]:
    return bundled("gna", "data", "aircraft")


def list_aircraft() -> list[str]:
    """Identifiers of the bundled aircraft.

    Returns
    -------
    list of str
    """
    return list(_catalogue())


def load_aircraft(name_or_path: str | Path, base: str | Path | None = None) -> Aircraft:
    """Load a bundled aircraft by identifier, or an aircraft TOML file by path.

    Parameters
    ----------
    name_or_path : str or pathlib.Path
        A bundled identifier (``f16c``) or the path of a ``.toml`` file.
    base : str or pathlib.Path, optional
        Folder a relative path is resolved from (a scenario's folder); default the current directory.

    Returns
    -------
    Aircraft

    Raises
    ------
    UnknownAircraftError
        If ``name_or_path`` is neither a bundled identifier nor a path.
    InputError
        A missing file, a folder, a file not named ``.toml``, an unreadable or non-UTF-8 file,
        invalid TOML, or a file that does not follow the aircraft schema.
    """
    cat = _catalogue()
    path = find_file(name_or_path, cat, "aircraft", base)
    if path is None:
        raise UnknownAircraftError(str(name_or_path), list(cat))
    return aircraft_from_dict(read_toml(path), where=str(path.name), path=str(path))
