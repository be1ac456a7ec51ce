"""Flat outputs as splines: a basis, its coefficients and boundary conditions.

A point-to-point manoeuvre ("from this trim to that trim in T seconds") gives the flat outputs' values and
derivatives at both ends, and leaves the shape between them free.  Here a flat output is a Bezier curve
on ``[t0, t1]`` (``basis = "bezier"``, python-control's :class:`control.flatsys.BezierFamily`): with
``s = (t - t0) / T``, ``T = t1 - t0``, ::

    B(t) = sum_k P_k C(n, k) s^k (1 - s)^(n - k),     k = 0..n

The first ``K0 + 1`` control points follow from the derivatives ``B^(m)(t0)``, ``m = 0..K0`` (a
triangular system: ``B^(m)(t0) = n! / (n - m)! / T^m sum_i (-1)^(m - i) C(m, i) P_i``), the last
``K1 + 1`` from those at ``t1``, and the points between are the given coefficients (numbers or
expressions of the scenario's parameters), so the degree is ``n = K0 + K1 + 1 + len(coefficients)``.

The curve is evaluated by Horner's rule on its monomial coefficients in ``u = 2 s - 1`` (in [-1, 1], where
the monomials are well conditioned), so it runs on floats, arrays and truncated power series alike (the
planner's nodes): one polynomial, smooth everywhere, whose series at every node are exact.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.polynomial import polynomial as P

from gna.errors import InputError

from .expressions import Expression

#: Bases a spline flat output may use.
BASES: tuple[str, ...] = ("bezier",)

#: Highest degree of a Bezier flat output (the monomial coefficients in [-1, 1] stay well conditioned).
MAX_DEGREE = 40


def bezier_points(start: Sequence[float], end: Sequence[float], interior: Sequence[float], t0: float, t1: float):
    """Control points of the Bezier curve on ``[t0, t1]`` with the given end derivatives and interior points.

    Parameters
    ----------
    start : sequence of float
        ``B(t0), B'(t0), ..., B^(K0)(t0)`` (units of the output per s^m).
    end : sequence of float
        ``B(t1), B'(t1), ..., B^(K1)(t1)``.
    interior : sequence of float
        The control points between those the end conditions fix.
    t0, t1 : float
        The span [s], ``t1 > t0``.

    Returns
    -------
    ndarray, shape (n + 1,)
        ``P_0 .. P_n``, ``n = len(start) + len(interior) + len(end) - 1``.

    Raises
    ------
    InputError
        ``t1 <= t0``, fewer than two control points, or a degree above :data:`MAX_DEGREE`.
    """
    T = float(t1) - float(t0)
    if not T > 0:
        raise InputError(f"a Bezier flat output needs t1 > t0, got [{t0:g}, {t1:g}]")
    n = len(start) + len(interior) + len(end) - 1
    if n < 1:
        raise InputError("a Bezier flat output needs at least two control points (conditions and coefficients)")
    if n > MAX_DEGREE:
        raise InputError(f"a Bezier flat output of degree {n} is above the largest degree {MAX_DEGREE}")
    pts = np.full(n + 1, np.nan)
    for m, d in enumerate(start):
        scale = math.perm(n, m) / T**m
        known = sum((-1) ** (m - i) * math.comb(m, i) * pts[i] for i in range(m))
        pts[m] = float(d) / scale - known
    for m, d in enumerate(end):
        scale = math.perm(n, m) / T**m
        known = sum((-1) ** (m - i) * math.comb(m, i) * pts[n - m + i] for i in range(1, m + 1))
        pts[n - m] = (float(d) / scale - known) * (-1) ** m
    pts[len(start) : n + 1 - len(end)] = np.asarray(interior, dtype=float)
    return pts


def bernstein_to_monomial(points) -> np.ndarray:
    """Monomial coefficients in ``u = 2 s - 1`` of the Bezier curve with control points ``points``.

    Parameters
    ----------
    points : array_like, shape (n + 1,)

    Returns
    -------
    ndarray, shape (n + 1,)
        ``a_j`` with ``B = sum_j a_j u^j`` (ascending powers).
    """
    pts = np.asarray(points, dtype=float)
    n = pts.size - 1
    out = np.zeros(n + 1)
    for k, p in enumerate(pts):
        if p == 0.0:
            continue
        b = P.polymul(P.polypow([1.0, 1.0], k), P.polypow([1.0, -1.0], n - k)) * (math.comb(n, k) / 2.0**n)
        out[: b.size] += p * b
    return out


def bezier_expression(points, t0: float, t1: float, text: str | None = None) -> Expression:
    """The Bezier curve with control points ``points`` on ``[t0, t1]`` as an :class:`Expression` of ``t``.

    Parameters
    ----------
    points : array_like, shape (n + 1,)
        Control points (:func:`bezier_points`).
    t0, t1 : float
        The span [s].
    text : str, optional
        What the expression shows (default: the basis, degree and span).

    Returns
    -------
    Expression
        Evaluates on floats, arrays and :class:`planners.series.Series` (Horner's rule in ``u = 2 s - 1``).
    """
    a = bernstein_to_monomial(points)
    mid, half = 0.5 * (float(t0) + float(t1)), 0.5 * (float(t1) - float(t0))

    def fn(t):
        u = (t - mid) * (1.0 / half)
        acc = a[-1] + 0.0 * u
        for c in a[-2::-1]:
            acc = acc * u + c
        return acc

    shown = text or f"bezier(degree {len(a) - 1} on [{t0:g}, {t1:g}] s)"
    return Expression(shown, fn, depends_on_t=True)


def steady_derivatives(V: float, gamma: float, chi: float, chi_dot: float, position, order: int) -> dict:
    """Derivatives of ``x, y, z`` along a steady flight (a helix: constant V, gamma and turn rate chi').

    Parameters
    ----------
    V : float
        Airspeed [m/s] (no wind: the inertial speed).
    gamma, chi : float
        Flight-path angle and heading at the point [rad].
    chi_dot : float
        Turn rate [rad/s].
    position : (float, float, float)
        ``x, y, z`` at the point (NED) [m].
    order : int
        Highest derivative.

    Returns
    -------
    dict
        ``"x"``, ``"y"``, ``"z"`` -> list of ``order + 1`` derivatives (m/s^k).
    """
    vh = V * math.cos(gamma)
    out = {"x": [float(position[0])], "y": [float(position[1])], "z": [float(position[2])]}
    for k in range(1, order + 1):
        w = chi_dot ** (k - 1)
        out["x"].append(vh * w * math.cos(chi + (k - 1) * math.pi / 2))
        out["y"].append(vh * w * math.sin(chi + (k - 1) * math.pi / 2))
        out["z"].append(-V * math.sin(gamma) if k == 1 else 0.0)
    return out
