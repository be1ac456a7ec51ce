"""Flying the fit against its source: level-flight trim with both aerodynamic models.

The fitted aircraft and the same aircraft with its ``aero`` replaced by the
source model (``dataclasses.replace``) are trimmed by :func:`gna.trim.trim_level`
with the same equations of motion, mass, geometry and engines, so the
difference is due to the aerodynamics alone.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

from ..aircraft import Aircraft
from ..errors import InputError
from ..trim import TrimResult, trim_level


@dataclass(frozen=True)
class ReferenceCondition:
    """A straight, level, wings-level flight condition.

    Parameters
    ----------
    V : float
        True airspeed [m/s].
    altitude : float
        Altitude [m] (ISA density).
    label : str
        How the condition was stated (e.g. ``"75 kt EAS at sea level"``).

    Raises
    ------
    InputError
        A speed that is not positive and finite, or a non-finite altitude.
    """

    V: float
    altitude: float
    label: str

    def __post_init__(self):
        if not (math.isfinite(self.V) and self.V > 0):
            raise InputError(f"reference speed must be positive, got {self.V} m/s")
        if not math.isfinite(self.altitude):
            raise InputError(f"reference altitude must be finite, got {self.altitude} m")

    def to_dict(self) -> dict:
        """The condition as plain data (``[fit.reference]`` of an aircraft file).

        Returns
        -------
        dict
            ``V_ms`` [m/s], ``altitude_m`` [m] and ``label``.
        """
        return {"V_ms": self.V, "altitude_m": self.altitude, "label": self.label}


def trim_record(t: TrimResult) -> dict:
    """The quantities the quality table compares, in degrees and newtons.

    Parameters
    ----------
    t : TrimResult
        A level trim (:func:`gna.trim.trim_level`).

    Returns
    -------
    dict
        ``alpha_deg``, ``dm_deg``, ``dl_deg``, ``dn_deg``, ``mu_deg`` [deg], ``thrust_N`` [N] and the
        trim's ``max_residual``.
    """
    v = t.values
    return {
        "alpha_deg": math.degrees(v["alpha"]),
        "dm_deg": math.degrees(v["dm"]),
        "thrust_N": v["F"],
        "dl_deg": math.degrees(v["dl"]),
        "dn_deg": math.degrees(v["dn"]),
        "mu_deg": math.degrees(v["mu"]),
        "max_residual": t.max_residual,
    }


def trim_comparison(aircraft: Aircraft, source, reference: ReferenceCondition) -> dict:
    """Level trim of the fitted aircraft and of its source model at ``reference``.

    Parameters
    ----------
    aircraft : Aircraft
        The fitted aircraft (:func:`gna.fit.document.fitted_aircraft`).
    source : object
        The source model, put in place of ``aircraft.aero`` (``coefficients(AeroState)``).
    reference : ReferenceCondition
        Speed and altitude of the straight, level, wings-level trim.

    Returns
    -------
    dict
        ``{"gna": {...}, "source": {...}, "difference": {...}}`` with
        :func:`trim_record` entries; differences are GNA minus source
        (thrust as a fraction of the source's; ``inf`` when the source's thrust is 0).

    Raises
    ------
    ConvergenceError, DomainError
        Either model cannot be trimmed there, e.g. outside its envelope (from :func:`gna.trim.trim_level`).
    """
    fitted = trim_level(aircraft, reference.V, reference.altitude)
    src = trim_level(dataclasses.replace(aircraft, aero=source), reference.V, reference.altitude)
    a, b = trim_record(fitted), trim_record(src)
    diff = {k: a[k] - b[k] for k in ("alpha_deg", "dm_deg", "dl_deg", "dn_deg", "mu_deg")}
    diff["thrust_rel"] = (a["thrust_N"] - b["thrust_N"]) / b["thrust_N"] if b["thrust_N"] != 0 else math.inf
    return {"gna": a, "source": b, "difference": diff}
