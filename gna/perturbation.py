"""Parameter and initial-state perturbations of an aircraft, for robustness runs.

A plan is made on the nominal model; flying it on a perturbed one (every
aerodynamic term scaled by its own random factor, mass and inertia scaled,
the initial state offset) measures how much model error the tracking
feedback absorbs.  A :class:`Perturbation` is a plain frozen, picklable
value: every random draw comes from ``numpy.random.default_rng(seed)``, so a
perturbation is reproduced exactly from its fields (no global random state);
a campaign gives each sample its own seed.

Conventions
-----------
- ``aero_spread = s``: the value of every term of the aerodynamic table is
  multiplied by its own factor drawn uniformly in ``[1 - s, 1 + s]`` (one draw
  per term, in table order), then by the explicit factors ``aero_scale``
  (keyed by term index ``theta`` or by coefficient name ``CD, CY, CL, Cl, Cm,
  Cn``, the latter applying to every term of that coefficient).
- ``mass_scale`` multiplies the mass; ``inertia_scale`` multiplies the whole
  inertia matrix (``Ixx, Iyy, Izz, Ixz``: it stays positive definite and
  physical).
- Initial-state offsets: ``position_m`` is the norm of the position offset,
  along ``(1, 1, 1) / sqrt(3)`` in the NED axes; ``speed_mps`` is added to
  ``V``; ``angle_rad`` is added to each of the five angles ``gamma, chi, alpha,
  beta, mu``; ``state_offsets`` adds per-state amounts (state names of
  :data:`gna.eom.STATE_NAMES`, SI units, rad) on top.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from .aero import COEFFICIENTS, TermTable
from .aircraft import Aircraft
from .eom import STATE_NAMES
from .errors import InputError
from .schema import did_you_mean, unknown_key_message

__all__ = ["Perturbation", "perturbed_aircraft", "offset_state", "perturbation_from_dict", "PERTURBATION_KEYS"]

#: Keys of a perturbation table (scenario files, campaigns).
PERTURBATION_KEYS: tuple[str, ...] = (
    "aero_spread",
    "aero_scale",
    "mass_scale",
    "inertia_scale",
    "position_m",
    "speed_mps",
    "angle_rad",
    "state_offsets",
    "seed",
)

_ANGLES = ("gamma", "chi", "alpha", "beta", "mu")


def _finite(value: Any, key: str, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(float(value)):
        raise InputError(f"{where}: {key} must be a finite number, got {value!r}")
    return float(value)


@dataclass(frozen=True)
class Perturbation:
    """A model and initial-state perturbation (see the module docstring for the conventions).

    Parameters
    ----------
    aero_spread : float
        Relative spread ``s`` in ``[0, 1)`` of the random factor of every aerodynamic term.
    aero_scale : tuple of (int or str, float)
        Explicit factors by term index or coefficient name (a mapping is accepted).
    mass_scale : float
        Factor on the mass (> 0).
    inertia_scale : float
        Factor on the inertia matrix (> 0).
    position_m : float
        Norm of the initial position offset [m], along ``(1, 1, 1) / sqrt(3)``.
    speed_mps : float
        Initial airspeed offset [m/s].
    angle_rad : float
        Offset [rad] on each of ``gamma, chi, alpha, beta, mu``.
    state_offsets : tuple of (str, float)
        Per-state offsets (a mapping is accepted), SI units and rad.
    seed : int, optional
        Seed of the random factors; required when ``aero_spread > 0``.

    Raises
    ------
    InputError
        Non-finite values, spread outside ``[0, 1)``, non-positive factors,
        unknown state or coefficient names, a spread without a seed.
    """

    aero_spread: float = 0.0
    aero_scale: tuple = ()
    mass_scale: float = 1.0
    inertia_scale: float = 1.0
    position_m: float = 0.0
    speed_mps: float = 0.0
    angle_rad: float = 0.0
    state_offsets: tuple = ()
    seed: int | None = None

    def __post_init__(self):
        where = "perturbation"
        for key in ("aero_spread", "mass_scale", "inertia_scale", "position_m", "speed_mps", "angle_rad"):
            object.__setattr__(self, key, _finite(getattr(self, key), key, where))
        if not 0.0 <= self.aero_spread < 1.0:
            raise InputError(f"{where}: aero_spread is a relative spread in [0, 1), got {self.aero_spread}")
        for key in ("mass_scale", "inertia_scale"):
            if not getattr(self, key) > 0.0:
                raise InputError(f"{where}: {key} must be positive, got {getattr(self, key)}")
        scale = self.aero_scale.items() if isinstance(self.aero_scale, Mapping) else self.aero_scale
        norm = []
        for k, v in scale:
            if isinstance(k, str) and k.strip().lstrip("+-").isdigit():
                k = int(k)
            if isinstance(k, str) and k not in COEFFICIENTS:
                raise InputError(
                    f"{where}: aero_scale key {k!r} is neither a term index nor a coefficient"
                    f"{did_you_mean(k, COEFFICIENTS)}; coefficients: {', '.join(COEFFICIENTS)}"
                )
            if isinstance(k, bool) or not isinstance(k, (int, str)):
                raise InputError(f"{where}: aero_scale keys are term indices or coefficient names, got {k!r}")
            f = _finite(v, f"aero_scale[{k!r}]", where)
            if not f > 0.0:
                raise InputError(f"{where}: aero_scale[{k!r}] must be positive, got {f}")
            norm.append((k, f))
        object.__setattr__(self, "aero_scale", tuple(norm))
        offs = self.state_offsets.items() if isinstance(self.state_offsets, Mapping) else self.state_offsets
        norm = []
        for k, v in offs:
            if k not in STATE_NAMES:
                raise InputError(unknown_key_message(k, STATE_NAMES, f"{where} state_offsets"))
            norm.append((str(k), _finite(v, f"state_offsets[{k!r}]", where)))
        object.__setattr__(self, "state_offsets", tuple(norm))
        if self.seed is not None and (
            isinstance(self.seed, bool) or not isinstance(self.seed, (int, np.integer)) or self.seed < 0
        ):
            raise InputError(f"{where}: seed must be a non-negative whole number, got {self.seed!r}")
        if self.seed is not None:
            object.__setattr__(self, "seed", int(self.seed))
        if self.aero_spread > 0.0 and self.seed is None:
            raise InputError(
                f"{where}: aero_spread = {self.aero_spread} needs a seed (the random factors are "
                f"drawn from it, so a run can be reproduced)"
            )

    def with_seed(self, seed: int) -> Perturbation:
        """The same perturbation with another seed (a campaign sample).

        Parameters
        ----------
        seed : int
            Non-negative seed.

        Returns
        -------
        Perturbation
        """
        return replace(self, seed=seed)

    @property
    def changes_model(self) -> bool:
        """True when :func:`perturbed_aircraft` changes the aircraft."""
        return self.aero_spread > 0.0 or bool(self.aero_scale) or self.mass_scale != 1.0 or self.inertia_scale != 1.0

    def describe(self) -> str:
        """One line naming every non-neutral field (for provenance and reports).

        Returns
        -------
        str
        """
        parts = []
        if self.aero_spread:
            parts.append(f"aero terms x U[{1 - self.aero_spread:g}, {1 + self.aero_spread:g}]")
        if self.aero_scale:
            parts.append("aero_scale " + ", ".join(f"{k}: {v:g}" for k, v in self.aero_scale))
        if self.mass_scale != 1.0:
            parts.append(f"mass x {self.mass_scale:g}")
        if self.inertia_scale != 1.0:
            parts.append(f"inertia x {self.inertia_scale:g}")
        if self.position_m:
            parts.append(f"position offset {self.position_m:g} m")
        if self.speed_mps:
            parts.append(f"speed offset {self.speed_mps:g} m/s")
        if self.angle_rad:
            parts.append(f"angle offset {self.angle_rad:g} rad")
        if self.state_offsets:
            parts.append("offsets " + ", ".join(f"{k} {v:+g}" for k, v in self.state_offsets))
        parts.append(f"seed {self.seed}")
        return "; ".join(parts)

    def aero_factors(self, table: TermTable) -> np.ndarray:
        """The factor applied to each term of ``table``, in table order.

        Parameters
        ----------
        table : TermTable
            The aerodynamic table.

        Returns
        -------
        ndarray, shape (len(table.terms),)

        Raises
        ------
        InputError
            A term index of ``aero_scale`` that is not in the table.
        """
        n = len(table.terms)
        factors = np.ones(n)
        if self.aero_spread > 0.0:
            rng = np.random.default_rng(self.seed)
            factors = rng.uniform(1.0 - self.aero_spread, 1.0 + self.aero_spread, size=n)
        indices = [t.index for t in table.terms]
        for key, f in self.aero_scale:
            if isinstance(key, str):
                hit = [i for i, t in enumerate(table.terms) if t.coefficient == key]
            else:
                hit = [i for i, idx in enumerate(indices) if idx == key]
                if not hit:
                    raise InputError(
                        f"perturbation: aero_scale term {key} is not in the aerodynamic table "
                        f"(indices {min(indices)}..{max(indices)})"
                    )
            factors[hit] *= f
        return factors


def perturbed_aircraft(aircraft: Aircraft, perturbation: Perturbation) -> Aircraft:
    """A copy of ``aircraft`` with scaled aerodynamic terms, mass and inertia.

    Parameters
    ----------
    aircraft : Aircraft
        The nominal aircraft (its aerodynamics a :class:`gna.aero.TermTable`).
    perturbation : Perturbation
        The perturbation; deterministic from its fields (seed included).

    Returns
    -------
    Aircraft
        Same id, geometry, propulsion and envelope; ``provenance["perturbation"]``
        describes the change (seed included).  ``aircraft`` itself when the
        perturbation changes nothing in the model.

    Raises
    ------
    InputError
        Aerodynamics that are not a term table, or an ``aero_scale`` index not in it.
    """
    if not perturbation.changes_model:
        return aircraft
    aero = aircraft.aero
    if perturbation.aero_spread > 0.0 or perturbation.aero_scale:
        if not isinstance(aero, TermTable):
            raise InputError(f"{aircraft.id}: aerodynamic perturbation needs a term table, got {type(aero).__name__}")
        factors = perturbation.aero_factors(aero)
        aero = aero.with_values([t.value * f for t, f in zip(aero.terms, factors)])
    m = aircraft.mass
    s = perturbation.inertia_scale
    mass = replace(m, mass=m.mass * perturbation.mass_scale, Ixx=m.Ixx * s, Iyy=m.Iyy * s, Izz=m.Izz * s, Ixz=m.Ixz * s)
    provenance = dict(aircraft.provenance)
    provenance["perturbation"] = perturbation.describe()
    return replace(aircraft, aero=aero, mass=mass, provenance=provenance)


def offset_state(x0, perturbation: Perturbation) -> np.ndarray:
    """The initial state with the perturbation's offsets added.

    Parameters
    ----------
    x0 : array_like, shape (12,)
        Wind-frame state (:data:`gna.eom.STATE_NAMES`, SI, rad).
    perturbation : Perturbation
        Its ``position_m``, ``speed_mps``, ``angle_rad`` and ``state_offsets``.

    Returns
    -------
    ndarray, shape (12,)
        A new array.

    Raises
    ------
    InputError
        ``x0`` not 12 finite numbers.
    """
    x = np.array(x0, dtype=float).reshape(-1)
    if x.shape != (12,) or not np.all(np.isfinite(x)):
        raise InputError(f"offset_state: x0 must be 12 finite numbers, got {np.asarray(x0)!r}")
    x[:3] += perturbation.position_m / math.sqrt(3.0)
    x[STATE_NAMES.index("V")] += perturbation.speed_mps
    for name in _ANGLES:
        x[STATE_NAMES.index(name)] += perturbation.angle_rad
    for name, v in perturbation.state_offsets:
        x[STATE_NAMES.index(name)] += v
    return x


def perturbation_from_dict(table: Mapping[str, Any], where: str = "perturbation") -> Perturbation:
    """Build a :class:`Perturbation` from a parsed table (scenario ``[tracking.perturbation]``).

    Parameters
    ----------
    table : mapping
        Keys among :data:`PERTURBATION_KEYS`; ``aero_scale`` and ``state_offsets`` are tables.
    where : str
        File and table, for error messages.

    Returns
    -------
    Perturbation

    Raises
    ------
    InputError
        Unknown keys (with the closest known key), wrong types or values.
    """
    if not isinstance(table, Mapping):
        raise InputError(f"{where}: must be a table, got {table!r}")
    for key in table:
        if key not in PERTURBATION_KEYS:
            raise InputError(unknown_key_message(key, PERTURBATION_KEYS, where))
    # Scalars are checked by Perturbation itself; tables and the seed's type here.
    kw: dict[str, Any] = {
        key: table[key]
        for key in ("aero_spread", "mass_scale", "inertia_scale", "position_m", "speed_mps", "angle_rad")
        if key in table
    }
    for key in ("aero_scale", "state_offsets"):
        if key in table:
            if not isinstance(table[key], Mapping):
                raise InputError(f"{where}: {key} must be a table (name = number), got {table[key]!r}")
            kw[key] = tuple(table[key].items())
    if "seed" in table:
        seed = table["seed"]
        if isinstance(seed, bool) or not isinstance(seed, int):
            raise InputError(f"{where}: seed must be a whole number, got {seed!r}")
        kw["seed"] = seed
    try:
        return Perturbation(**kw)
    except InputError as exc:
        # Perturbation names itself "perturbation" (also in "perturbation state_offsets: ..."): name the table instead.
        msg, own = str(exc), "perturbation"
        raise InputError(where + msg[len(own) :] if msg.startswith(own) else msg) from None
