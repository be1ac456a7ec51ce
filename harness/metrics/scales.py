"""Tolerances and scales of the difference tables: default tolerances, the scale and floors of ``delta_pct``.

``delta_pct = 100 max|u - u_ref| / scale`` over the compared window, where the
scale is a size of the reference that does not depend on where its zero was put:

* variables with a physical zero (speed, the angles alpha, beta, gamma, mu
  measured from the air flow or the horizon, rates, controls, forces, moments,
  pressure, load factors, coefficients): ``max|u_ref|``;
* datum-dependent variables (:data:`DATUM_DEPENDENT`: the positions x, y, z
  and ``"position"``, whose zero is the NED origin a scenario chose, and the
  heading chi, whose zero is north): the reference's excursion over the window,
  ``max u_ref - min u_ref`` (chi unwrapped; for ``"position"`` the largest
  distance between two points of the reference's path).  The same manoeuvre
  flown at 1000 m or 10 km, north or east, then gets the same percentage.

Where the scale is at most the floor of the variable's kind of quantity
(:func:`percent_floor`), the reference is no scale for a percentage and
``delta_pct`` is undefined (NaN).
"""

from __future__ import annotations

import numpy as np

from gna.trajectory import POSITION, UNITS

#: Cross-engine tolerances for matched physics and smooth controls over 10 s:
#: 1e-2 m in position, 1e-4 rad in angles; speed and rates get the same relative
#: scale, 1e-3 m/s and 1e-3 rad/s.
DEFAULT_TOLERANCES: dict[str, float] = {
    POSITION: 1e-2,
    "x": 1e-2,
    "y": 1e-2,
    "z": 1e-2,
    "V": 1e-3,
    "gamma": 1e-4,
    "chi": 1e-4,
    "alpha": 1e-4,
    "beta": 1e-4,
    "mu": 1e-4,
    "p": 1e-3,
    "q": 1e-3,
    "r": 1e-3,
}

#: Scale of ``delta_pct`` (SI units) taken as zero to rounding for the kinds of quantity without a floor in
#: :data:`PERCENT_FLOORS` (pressure, density, load factors, coefficients).
REFERENCE_ZERO = 1e-9

#: Floors of ``delta_pct`` per kind of quantity (unit -> SI value): where the scale of a variable over the
#: window (:func:`percent_scale`) is at most its floor, it is no scale for a percentage and ``delta_pct`` is
#: undefined.  Engines are judged on absolute differences per variable (NESC 6-DoF check-cases,
#: NASA/TM-2015-218675: difference plots; JSBSim's ``tests/JSBSim_utils.py::FindDifferences``: ``|delta| >
#: tol``): a scale within the absolute agreement of its kind (y of a straight flight along x, 3e-4 m) is zero at
#: the comparison's resolution.  Positions, speeds, angles, rates: their tolerances (:data:`DEFAULT_TOLERANCES`).
#: Forces and moments (no tolerance): what changes the speed of the lightest aircraft of the catalogue (GTM T2,
#: 26.2 kg) by the speed tolerance over the 10 s window, 2.6e-3 N, or its roll rate (Ixx = 1.66 kg m^2) by the
#: rate tolerance, 1.7e-4 N m, each rounded down to its decade.
PERCENT_FLOORS: dict[str, float] = {
    "m": DEFAULT_TOLERANCES["x"],
    "m/s": DEFAULT_TOLERANCES["V"],
    "rad": DEFAULT_TOLERANCES["alpha"],
    "rad/s": DEFAULT_TOLERANCES["p"],
    "N": 1e-3,
    "N m": 1e-4,
}

#: Variables whose zero is a datum, not physics: the positions (NED origin) and the heading chi (north).
#: Their ``delta_pct`` is relative to the reference's excursion over the window, not to ``max|u_ref|``.
DATUM_DEPENDENT: frozenset[str] = frozenset({POSITION, "x", "y", "z", "chi"})


def percent_floor(variable: str) -> float:
    """The floor of the scale above which ``delta_pct`` of a variable is defined.

    Parameters
    ----------
    variable : str
        Column name (:data:`gna.trajectory.UNITS`) or ``"position"``.

    Returns
    -------
    float
        The floor of the variable's kind of quantity (:data:`PERCENT_FLOORS`,
        in its SI unit), or the rounding floor :data:`REFERENCE_ZERO` for a
        kind without one (pressure, density, dimensionless).
    """
    return PERCENT_FLOORS.get(UNITS.get(variable, ""), REFERENCE_ZERO)


def percent_scale(variable: str, reference) -> float:
    """The scale of ``delta_pct`` of one variable: ``max|u_ref|``, or the excursion of a datum-dependent one.

    Parameters
    ----------
    variable : str
        Column name or ``"position"``.
    reference : mapping str -> array of shape (n,)
        The reference's values over the window, in SI units and radians: the
        variable's column, or ``x``, ``y``, ``z`` [m] for ``"position"``.

    Returns
    -------
    float
        ``max|u_ref|`` for a variable with a physical zero; for one of
        :data:`DATUM_DEPENDENT`, ``max u_ref - min u_ref`` (chi unwrapped), or
        for ``"position"`` the diameter of the path ``max |r(t) - r(s)|`` [m].
        NaN when a value is NaN or there is none.
    """
    if variable == POSITION:
        return _diameter(np.column_stack([np.asarray(reference[c], dtype=float) for c in ("x", "y", "z")]))
    u = np.asarray(reference[variable], dtype=float)
    if u.size == 0 or np.any(np.isnan(u)):
        return float("nan")
    if variable not in DATUM_DEPENDENT:
        return float(np.max(np.abs(u)))
    if variable == "chi":
        u = np.unwrap(u)
    return float(np.max(u) - np.min(u))


def _diameter(points: np.ndarray) -> float:
    """Largest distance between two of the points (rows): over the far ones, then the vertices of their convex
    hull."""
    if points.size == 0 or np.any(np.isnan(points)):
        return float("nan")
    from scipy.spatial import ConvexHull, QhullError
    from scipy.spatial.distance import cdist

    points = points - points[0]
    # only points far enough from the centroid can end a pair longer than a distance already found (``found``):
    # |p - q| <= r_p + r_q with r the distance to the centroid, so a longer pair has r_p > found - max r (a
    # straight path keeps its two ends, a circle all of its points); the largest distance is the same float
    r = np.sqrt(np.sum((points - points.mean(axis=0)) ** 2, axis=1))
    found = float(np.max(cdist(points[np.argmax(r)][None, :], points)))
    keep = r >= found - float(np.max(r)) - 1e-9 * (found + float(np.max(r)))
    if np.count_nonzero(keep) >= 2:
        points = points[keep]
    if len(points) > 64:
        try:  # QJ: joggled input, so a level (planar) or straight (linear) path still has a hull
            points = points[ConvexHull(points, qhull_options="QJ").vertices]
        except (QhullError, ValueError):
            pass
    step = max(1, 2_000_000 // len(points))  # blocks of at most 2e6 pairs
    return max(found, *(float(np.max(cdist(points[i : i + step], points))) for i in range(0, len(points), step)))
