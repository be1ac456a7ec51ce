"""Seeds and draws of a campaign's samples: a pure function of (campaign seed, case, sample index).

Each sample's seed comes from ``numpy.random.SeedSequence(campaign_seed,
spawn_key=(crc32(case key), sample))``: independent streams, stable when cases
are added, removed or reordered, and when the number of samples changes.  A
draw takes its normal variates from ``default_rng(seed)`` in a fixed order (all
aerodynamic terms, mass, inertia, CG, x, y, z, V, gamma, chi, alpha, beta,
mu), whatever spreads are zero, so one sample is rerun alone with the same
result (:func:`draw_sample`).
"""

from __future__ import annotations

import functools
import math
import zlib
from dataclasses import dataclass, replace

import numpy as np

from gna.eom import STATE_NAMES
from gna.errors import InputError
from gna.schema import read_toml

from .spec import Dispersion

__all__ = ["sample_seed", "SampleDraw", "draw_sample", "dispersed_aircraft", "term_std_errors", "OFFSET_STATES"]

#: States offset at the start, in draw order.
OFFSET_STATES: tuple[str, ...] = ("x", "y", "z", "V", "gamma", "chi", "alpha", "beta", "mu")


def sample_seed(campaign_seed: int, key: str, sample: int) -> int:
    """The seed of one sample.

    Parameters
    ----------
    campaign_seed : int
        The campaign's seed (>= 0).
    key : str
        ``<case label>.<dispersion name>``.
    sample : int
        Sample index (>= 0).

    Returns
    -------
    int
        A 63-bit seed (fits an SQLite integer).
    """
    ss = np.random.SeedSequence(int(campaign_seed), spawn_key=(zlib.crc32(key.encode("utf-8")), int(sample)))
    return int(ss.generate_state(1, dtype=np.uint64)[0]) >> 1


@functools.lru_cache(maxsize=16)
def _std_errors_of_file(path: str) -> dict:
    data = read_toml(path)  # the bounded reader of every input file
    return {
        int(t.get("theta", i + 1)): float(t["std_error"])
        for i, t in enumerate(data.get("aero", {}).get("terms", []))
        if "std_error" in t
    }


def term_std_errors(aircraft) -> np.ndarray:
    """Standard error of each aerodynamic term, in table order (NaN where the file gives none).

    Parameters
    ----------
    aircraft : gna.aircraft.Aircraft
        An aircraft loaded from a file (``aircraft.path``); fitted sets carry
        ``std_error`` per term (:mod:`gna.fit.writer`).

    Returns
    -------
    ndarray, shape (n_terms,)
        Same units as the terms.
    """
    se = _std_errors_of_file(aircraft.path) if getattr(aircraft, "path", None) else {}
    return np.array([se.get(t.index, math.nan) for t in aircraft.aero.terms], dtype=float)


@dataclass(frozen=True)
class SampleDraw:
    """One sample's dispersed aircraft data and initial-state offsets.

    Attributes
    ----------
    seed : int
    aero_values : ndarray, shape (n_terms,)
        Term values flown.
    aero_z : ndarray, shape (n_terms,)
        Their normal variates (0 when not dispersed).
    mass_scale, inertia_scale : float
        Factors on the mass and on the inertia matrix.
    cg_shift_m : float
        Shift of ``x_cg`` [m].
    offsets : ndarray, shape (12,)
        Added to the initial state (:data:`gna.eom.STATE_NAMES`, SI, rad).
    aero_labels : tuple of str
        ``theta<i>:<coefficient>:<monomial>`` of each term.
    """

    seed: int
    aero_values: np.ndarray
    aero_z: np.ndarray
    mass_scale: float
    inertia_scale: float
    cg_shift_m: float
    offsets: np.ndarray
    aero_labels: tuple = ()

    def parameters(self) -> dict:
        """The dispersed parameters by name (for the store and the correlations).

        Returns
        -------
        dict
            ``mass_scale``, ``inertia_scale``, ``cg_shift_m``, ``d<state>`` offsets
            [SI, rad] and ``z_theta<i>:<coefficient>:<monomial>`` (normal variate of term i).
        """
        out = {"mass_scale": self.mass_scale, "inertia_scale": self.inertia_scale, "cg_shift_m": self.cg_shift_m}
        for name in OFFSET_STATES:
            out[f"d{name}"] = float(self.offsets[STATE_NAMES.index(name)])
        labels = self.aero_labels or tuple(f"theta{i + 1}" for i in range(len(self.aero_z)))
        out.update({f"z_{lab}": float(z) for lab, z in zip(labels, self.aero_z)})
        return out


def draw_sample(aircraft, dispersion: Dispersion, seed: int) -> SampleDraw:
    """Draw one sample of a dispersion set for an aircraft.

    Parameters
    ----------
    aircraft : gna.aircraft.Aircraft
        The nominal aircraft (aerodynamics a term table).
    dispersion : Dispersion
        The 1-sigma spreads.
    seed : int
        The sample's seed (:func:`sample_seed`).

    Returns
    -------
    SampleDraw

    Raises
    ------
    InputError
        Aerodynamics that are not a term table while the set disperses them.
    """
    terms = getattr(aircraft.aero, "terms", None)
    if terms is None and dispersion.aero != "none":
        raise InputError(f"{aircraft.id}: dispersing the aerodynamics needs a term table")
    n = len(terms) if terms is not None else 0
    rng = np.random.default_rng(seed)
    c = dispersion.truncate
    z = np.clip(rng.standard_normal(n + 3 + len(OFFSET_STATES)), -c, c)
    za, zm, zi, zcg, zs = z[:n], z[n], z[n + 1], z[n + 2], z[n + 3 :]
    values = np.array([t.value for t in terms], dtype=float) if terms is not None else np.zeros(0)
    if dispersion.aero == "none":
        za = np.zeros(n)
    else:
        sigma = np.abs(values) * dispersion.aero_relative
        if dispersion.aero == "std_error":
            se = term_std_errors(aircraft) * dispersion.aero_sigma
            sigma = np.where(np.isfinite(se), se, sigma)
        values = values + sigma * za
        za = np.where(sigma > 0, za, 0.0)
    spreads = {
        "x": dispersion.position_m,
        "y": dispersion.position_m,
        "z": dispersion.position_m,
        "V": dispersion.speed_mps,
    }
    offsets = np.zeros(12)
    for name, zk in zip(OFFSET_STATES, zs):
        offsets[STATE_NAMES.index(name)] = spreads.get(name, dispersion.angle_rad) * zk
    return SampleDraw(
        seed=int(seed),
        aero_values=values,
        aero_z=za,
        mass_scale=1.0 + dispersion.mass * zm,
        inertia_scale=1.0 + dispersion.inertia * zi,
        cg_shift_m=dispersion.cg_cbar * aircraft.geometry.cbar * zcg,
        offsets=offsets,
        aero_labels=tuple(f"theta{t.index}:{t.coefficient}:{t.monomial}" for t in terms or ()),
    )


def dispersed_aircraft(aircraft, draw: SampleDraw):
    """A copy of the aircraft with a sample's term values, mass, inertia and CG.

    Parameters
    ----------
    aircraft : gna.aircraft.Aircraft
        The nominal aircraft.
    draw : SampleDraw
        From :func:`draw_sample` for this aircraft.

    Returns
    -------
    gna.aircraft.Aircraft
        ``provenance["dispersion"]`` names the seed.
    """
    aero = aircraft.aero
    if len(draw.aero_values):
        aero = aero.with_values(draw.aero_values, source=f"campaign sample, seed {draw.seed}")
    m, s = aircraft.mass, draw.inertia_scale
    mass = replace(m, mass=m.mass * draw.mass_scale, Ixx=m.Ixx * s, Iyy=m.Iyy * s, Izz=m.Izz * s, Ixz=m.Ixz * s)
    geometry = replace(aircraft.geometry, x_cg=aircraft.geometry.x_cg + draw.cg_shift_m)
    provenance = dict(aircraft.provenance)
    provenance["dispersion"] = f"campaign sample, seed {draw.seed}"
    return replace(aircraft, aero=aero, mass=mass, geometry=geometry, provenance=provenance)
