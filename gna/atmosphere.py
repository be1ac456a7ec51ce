"""Atmosphere and environment models.

Two density models are provided: a constant density, and the International
Standard Atmosphere (ISO 2533:1975 / U.S. Standard Atmosphere 1976) for the
troposphere and the lower stratosphere (0--20 km; ISO 2533's troposphere
starts at -2 km, so :data:`ISA_RANGE` is -2 to 20 km).  Altitudes outside that
range are refused by :meth:`Environment.check_altitude` (trim, every plan node)
rather than extrapolated: above 20 km the standard's temperature rises again
and the isothermal formula no longer holds.  Density is a function of
the altitude ``h = -z`` only (geometric altitude is used as geopotential
altitude; the difference is below 0.2 % at 10 km and is documented).

Both models evaluate on floats, numpy arrays and truncated power series (the
ISA troposphere is a real power of an affine function of ``h``).  The
stratosphere branch is exponential; inside a power series, the branch is
chosen node by node from the series' constant term.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from .errors import DomainError, InputError
from .ground_effect import GroundEffect
from .units import G0

# ISA constants (ISO 2533).
T0 = 288.15  #: sea-level temperature, K
P0 = 101325.0  #: sea-level pressure, Pa
R_AIR = 287.05287  #: specific gas constant of dry air, J/(kg K)
LAPSE = 0.0065  #: tropospheric lapse rate, K/m
H_TROPO = 11000.0  #: tropopause altitude, m
RHO0 = P0 / (R_AIR * T0)  #: sea-level density, 1.225 kg/m^3
_EXP_TROPO = G0 / (R_AIR * LAPSE) - 1.0
T_TROPO = T0 - LAPSE * H_TROPO
RHO_TROPO = RHO0 * (T_TROPO / T0) ** _EXP_TROPO
#: Altitudes [m] the ISA model covers: ISO 2533's lowest tabulated altitude to the top of the isothermal layer.
ISA_RANGE = (-2000.0, 20000.0)


#: Ratio of specific heats of air (speed of sound of the ISA).
GAMMA_AIR = 1.4


def speed_of_sound(h) -> np.ndarray:
    """ISA speed of sound ``a = sqrt(gamma R T(h))`` [m/s], troposphere and lower stratosphere.

    Parameters
    ----------
    h : array_like
        Altitude [m].

    Returns
    -------
    ndarray
        Speed of sound [m/s] (ISO 2533 temperature: ``T0 - L h`` up to 11 km, constant above).
    """
    h = np.asarray(h, dtype=float)
    T = T0 - LAPSE * np.minimum(h, H_TROPO)
    return np.sqrt(GAMMA_AIR * R_AIR * T)


def _altitude_values(h) -> np.ndarray:
    """Altitudes [m] as a float array (constant terms of series)."""
    return np.atleast_1d(np.asarray(_constant_term(h), dtype=float))


def _constant_term(x):
    """Value of x, or of its constant term for a truncated power series."""
    c = getattr(x, "constant_term", None)
    return np.real(c if c is not None else x)


@dataclass(frozen=True)
class ConstantDensity:
    """Air density independent of altitude.

    Parameters
    ----------
    rho : float
        Density in kg/m^3.
    """

    rho: float = RHO0

    def __post_init__(self):
        if not (np.isfinite(self.rho) and self.rho > 0):
            raise InputError(f"air density must be positive and finite, got {self.rho}")

    def density(self, h):
        """Density, the same at every altitude.

        Parameters
        ----------
        h : float, ndarray or Series
            Altitude [m] (used only for the result's type and shape).

        Returns
        -------
        float, ndarray or Series
            ``rho`` [kg/m^3], shaped like ``h``.
        """
        return self.rho + 0.0 * h

    def check_altitude(self, h, where: str = "") -> None:
        """Constant density holds at any finite altitude.

        Parameters
        ----------
        h : float or array_like
            Altitude [m].
        where : str
            What the altitude is (for the message).

        Raises
        ------
        DomainError
            A non-finite altitude.
        """
        _check_range(h, (-np.inf, np.inf), where, self.describe())

    def describe(self) -> str:
        """One line naming the model and its density (run settings, reports).

        Returns
        -------
        str
            E.g. ``"constant density 1.225 kg/m^3"``.
        """
        return f"constant density {self.rho:.6g} kg/m^3"


@dataclass(frozen=True)
class ISA:
    """International Standard Atmosphere density, 0 to 20 km.

    Troposphere: ``rho = rho0 (1 - L h / T0)^(g0/(R L) - 1)``;
    lower stratosphere (11--20 km): ``rho = rho11 exp(-g0 (h - 11000)/(R T11))``.
    Altitude is geometric and used as geopotential (documented approximation).
    """

    def density(self, h):
        """Density of the ISA troposphere (h <= 11 km) or isothermal lower stratosphere (ISO 2533).

        The range is not checked here (:meth:`check_altitude` does). A float or array takes each
        altitude's layer; a series takes each node's layer from its constant term.

        Parameters
        ----------
        h : float, ndarray or Series
            Geometric altitude [m], used as geopotential altitude.

        Returns
        -------
        float, ndarray or Series
            Density [kg/m^3], shaped like ``h``.
        """
        h0 = _constant_term(h)
        if np.all(h0 <= H_TROPO):
            return RHO0 * (1.0 - LAPSE * h / T0) ** _EXP_TROPO
        if np.all(h0 > H_TROPO):
            return RHO_TROPO * np.exp(-G0 * (h - H_TROPO) / (R_AIR * T_TROPO))
        if hasattr(h, "coeffs"):
            # Series at nodes on both sides of the tropopause: each node takes its own layer's formula.
            tropo = RHO0 * (1.0 - LAPSE * h / T0) ** _EXP_TROPO
            strato = RHO_TROPO * np.exp(-G0 * (h - H_TROPO) / (R_AIR * T_TROPO))
            below = np.asarray(h0 <= H_TROPO)[..., None]
            return type(h)(np.where(below, np.asarray(tropo.coeffs), np.asarray(strato.coeffs)))
        h = np.asarray(h, dtype=float)
        return np.where(
            h <= H_TROPO,
            RHO0 * (1.0 - LAPSE * np.minimum(h, H_TROPO) / T0) ** _EXP_TROPO,
            RHO_TROPO * np.exp(-G0 * (np.maximum(h, H_TROPO) - H_TROPO) / (R_AIR * T_TROPO)),
        )

    #: Altitudes [m] of the model (:data:`ISA_RANGE`).
    altitude_range: ClassVar[tuple[float, float]] = ISA_RANGE

    def check_altitude(self, h, where: str = "") -> None:
        """Refuse altitudes outside :data:`ISA_RANGE` (-2 to 20 km).

        Parameters
        ----------
        h : float or array_like
            Altitude(s) [m] (constant terms of series).
        where : str
            What the altitude is, e.g. ``"trim"`` or ``"plan node at t = 3 s"`` (for the message).

        Raises
        ------
        DomainError
            An altitude outside the range or not finite (``variable = "altitude"``).
        """
        _check_range(h, self.altitude_range, where, "the ISA model (ISO 2533, troposphere and isothermal layer)")

    def describe(self) -> str:
        """One line naming the model (run settings, reports).

        Returns
        -------
        str
            The model and its altitude approximation.
        """
        return "ISA (ISO 2533) density, geometric altitude as geopotential"


def _check_range(h, bounds: tuple[float, float], where: str, model: str, times=None) -> None:
    hv = _altitude_values(h)
    bad = ~(np.isfinite(hv) & (hv >= bounds[0]) & (hv <= bounds[1]))
    if bad.any():
        i = int(np.argmax(bad))
        at = f" ({where})" if where else ""
        if times is not None:
            at = f" at t = {float(np.atleast_1d(times)[i]):g} s" + at
        rng = "finite" if not np.isfinite(bounds[1]) else f"{bounds[0]:g} to {bounds[1]:g} m"
        raise DomainError(
            f"altitude {hv[i]:g} m{at} is outside {model}: valid {rng}",
            variable="altitude",
            value=float(hv[i]),
            time=None if times is None else float(np.atleast_1d(times)[i]),
        )


@dataclass(frozen=True)
class Environment:
    """Gravity and atmosphere (no wind): the world the aircraft flies in.

    Parameters
    ----------
    atmosphere : ConstantDensity or ISA
    g : float
        Gravity acceleration [m/s^2], uniform (flat Earth).
    ground_effect : GroundEffect, optional
        Ground effect on lift and induced drag over a flat ground (:mod:`gna.ground_effect`);
        default None: free air.
    """

    atmosphere: ConstantDensity | ISA = ISA()
    g: float = G0
    ground_effect: GroundEffect | None = None

    def __post_init__(self):
        if not (np.isfinite(self.g) and self.g > 0):
            raise InputError(f"gravity must be positive and finite, got {self.g}")
        if self.ground_effect is not None and not isinstance(self.ground_effect, GroundEffect):
            raise InputError(
                f"ground_effect must be a gna.ground_effect.GroundEffect or None, "
                f"got {type(self.ground_effect).__name__}"
            )

    def describe(self) -> str:
        """The atmosphere's description, and the ground effect's when there is one (run settings).

        Returns
        -------
        str
            One line, the two descriptions joined by ``"; "``.
        """
        d = self.atmosphere.describe()
        return d if self.ground_effect is None else f"{d}; {self.ground_effect.describe()}"

    def density(self, z):
        """Air density at a NED down coordinate.

        Parameters
        ----------
        z : float, ndarray or Series
            NED down position [m]; the altitude is ``-z``.

        Returns
        -------
        float, ndarray or Series
            Density [kg/m^3] of the atmosphere model at altitude ``-z``, shaped like ``z``.
        """
        return self.atmosphere.density(-z)

    def check_altitude(self, h, where: str = "", times=None) -> None:
        """Refuse altitudes outside the atmosphere model's range (the ISA's -2 to 20 km).

        Parameters
        ----------
        h : float or array_like
            Altitude(s) [m] (``-z``).
        where : str
            What the altitude is (for the message).
        times : array_like, optional
            Times [s] of the altitudes (the message names the first bad one).

        Raises
        ------
        DomainError
            An altitude outside the range or not finite, or at or below the ground with ground effect;
            the message names it (and its time).
        """
        atm = self.atmosphere
        if isinstance(atm, ISA):
            _check_range(
                h, atm.altitude_range, where, "the ISA model (ISO 2533, troposphere and isothermal layer)", times
            )
        else:
            _check_range(h, (-np.inf, np.inf), where, atm.describe(), times)
        if self.ground_effect is not None:
            self.ground_effect.check_height(h, where, times)

    @classmethod
    def constant(cls, altitude: float = 0.0, g: float = G0) -> Environment:
        """An environment of constant density equal to the ISA density at ``altitude``.

        Parameters
        ----------
        altitude : float
            Altitude [m] whose ISA density is used, within :data:`ISA_RANGE`.
        g : float
            Gravity acceleration [m/s^2].

        Returns
        -------
        Environment
            With :class:`ConstantDensity` atmosphere and no ground effect.

        Raises
        ------
        DomainError
            ``altitude`` outside :data:`ISA_RANGE` or not finite (from :meth:`check_altitude`).
        InputError
            ``g`` not positive and finite.
        """
        cls().check_altitude(altitude, "constant-density environment")
        return cls(ConstantDensity(float(ISA().density(float(altitude)))), g)
