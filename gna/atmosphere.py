"""Atmosphere and environment models.

Two density models are provided: a constant density, and the International
Standard Atmosphere (ISO 2533:1975 / U.S. Standard Atmosphere 1976) for the
troposphere and the lower stratosphere (0--20 km).  Density is a function of
the altitude ``h = -z`` only (geometric altitude is used as geopotential
altitude; the difference is below 0.2 % at 10 km and is documented).

Both models evaluate on floats, numpy arrays and truncated power series (the
ISA troposphere is a real power of an affine function of ``h``).  The
stratosphere branch is exponential; inside a power series, the branch is
chosen node by node from the series' constant term.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import InputError
from .units import G0

# ISA constants (ISO 2533).
T0 = 288.15          #: sea-level temperature, K
P0 = 101325.0        #: sea-level pressure, Pa
R_AIR = 287.05287    #: specific gas constant of dry air, J/(kg K)
LAPSE = 0.0065       #: tropospheric lapse rate, K/m
H_TROPO = 11000.0    #: tropopause altitude, m
RHO0 = P0 / (R_AIR * T0)  #: sea-level density, 1.225 kg/m^3
_EXP_TROPO = G0 / (R_AIR * LAPSE) - 1.0
T_TROPO = T0 - LAPSE * H_TROPO
RHO_TROPO = RHO0 * (T_TROPO / T0) ** _EXP_TROPO


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
        """Density [kg/m^3] at altitude ``h`` [m] (ignored)."""
        return self.rho + 0.0 * h

    def describe(self) -> str:
        return f"constant density {self.rho:.6g} kg/m^3"


@dataclass(frozen=True)
class ISA:
    """International Standard Atmosphere density, 0 to 20 km.

    Troposphere: ``rho = rho0 (1 - L h / T0)^(g0/(R L) - 1)``;
    lower stratosphere (11--20 km): ``rho = rho11 exp(-g0 (h - 11000)/(R T11))``.
    Altitude is geometric and used as geopotential (documented approximation).
    """

    def density(self, h):
        """Density [kg/m^3] at altitude ``h`` [m]."""
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
        return np.where(h <= H_TROPO,
                        RHO0 * (1.0 - LAPSE * np.minimum(h, H_TROPO) / T0) ** _EXP_TROPO,
                        RHO_TROPO * np.exp(-G0 * (np.maximum(h, H_TROPO) - H_TROPO) / (R_AIR * T_TROPO)))

    def describe(self) -> str:
        return "ISA (ISO 2533) density, geometric altitude as geopotential"


@dataclass(frozen=True)
class Environment:
    """Gravity and atmosphere (no wind): the world the aircraft flies in.

    Parameters
    ----------
    atmosphere : ConstantDensity or ISA
    g : float
        Gravity acceleration [m/s^2], uniform (flat Earth).
    """

    atmosphere: ConstantDensity | ISA = ISA()
    g: float = G0

    def __post_init__(self):
        if not (np.isfinite(self.g) and self.g > 0):
            raise InputError(f"gravity must be positive and finite, got {self.g}")

    def density(self, z):
        """Density at NED coordinate ``z`` (altitude ``-z``)."""
        return self.atmosphere.density(-z)

    @classmethod
    def constant(cls, altitude: float = 0.0, g: float = G0) -> "Environment":
        """Constant density equal to the ISA density at ``altitude`` [m]."""
        return cls(ConstantDensity(float(ISA().density(float(altitude)))), g)
