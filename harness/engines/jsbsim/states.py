"""JSBSim's step grid, and its properties -> the 12 wind-frame states and the common trajectory DataFrame.

JSBSim has no wind-axis bank property: mu comes from the body Euler angles and
alpha, beta (:func:`gna.frames.bank_from_euler`).  Positions are read as
latitude, longitude and altitude and mapped to the NED plane of the initial
point (spherical arcs, so that level flight on the huge sphere is level in NED).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import pandas as pd

from gna import units
from gna.aircraft import Aircraft
from gna.atmosphere import Environment
from gna.eom import CONTROL_NAMES, STATE_NAMES
from gna.frames import bank_from_euler
from gna.trajectory import COLUMNS, DOMAIN, DomainBounds, domain_violation

from . import export as jx
from .fdm import WGS84_A_FT, WGS84_B_FT

# Raw outputs read at each output time (their order is the order of the raw arrays).
STATE_NODES_FLAT = ("position/lat-gc-rad", "position/long-gc-rad", "position/h-sl-ft")
STATE_NODES_WGS84 = ("position/lat-geod-rad", "position/long-gc-rad", "position/geod-alt-ft")
STATE_NODES = (
    "velocities/vt-fps",
    "flight-path/gamma-rad",
    "flight-path/psi-gt-rad",
    "aero/alpha-rad",
    "aero/beta-rad",
    "attitude/phi-rad",
    "attitude/theta-rad",
    "attitude/psi-rad",
    "velocities/p-rad_sec",
    "velocities/q-rad_sec",
    "velocities/r-rad_sec",
)
#: Raw outputs read at every step to continue chi and mu and test the domain (order of :meth:`StateConverter.track`).
TRACK_NODES = (
    "velocities/vt-fps",
    "flight-path/gamma-rad",
    "flight-path/psi-gt-rad",
    "aero/alpha-rad",
    "aero/beta-rad",
    "attitude/phi-rad",
    "attitude/theta-rad",
)
DERIVED_NODES = (
    (jx.QBAR_PROPERTY, jx.RHO_PROPERTY)
    + tuple(jx.COEFFICIENT_PROPERTIES.values())
    + (
        "forces/fbx-total-lbs",
        "forces/fby-total-lbs",
        "forces/fbz-total-lbs",
        "forces/fbx-weight-lbs",
        "forces/fby-weight-lbs",
        "forces/fbz-weight-lbs",
        "moments/l-total-lbsft",
        "moments/m-total-lbsft",
        "moments/n-total-lbsft",
    )
)


def align(angle: np.ndarray, reference: float) -> np.ndarray:
    """Unwrap an angle history and shift it by whole turns so that it starts nearest ``reference``.

    Parameters
    ----------
    angle : ndarray, shape (n,)
        Angles [rad].
    reference : float
        Angle [rad] the history should start nearest to.

    Returns
    -------
    ndarray, shape (n,)
    """
    a = np.unwrap(np.asarray(angle, dtype=float))
    if a.size:
        a = a + 2.0 * math.pi * np.round((reference - a[0]) / (2.0 * math.pi))
    return a


def inside_test(bounds: DomainBounds = DOMAIN):
    """:func:`gna.trajectory.domain_margins`' test on floats, for a step: every margin positive.

    Parameters
    ----------
    bounds : DomainBounds
        The domain.

    Returns
    -------
    callable
        ``inside(z, V, gamma, alpha, beta) -> bool`` [m, m/s, rad]: True exactly when every margin of
        ``domain_margins`` is positive (False for a non-finite gamma or beta, or any margin NaN).
    """
    V_min, V_max, cos_min, alpha_max = bounds.V_min, bounds.V_max, bounds.cos_min, bounds.alpha_max
    ground, h_min, h_max = bounds.ground, bounds.h_min, bounds.h_max
    low, high = h_min != -math.inf, h_max != math.inf
    isfinite, cos = math.isfinite, math.cos

    def inside(z: float, V: float, gamma: float, alpha: float, beta: float) -> bool:
        if not (isfinite(gamma) and isfinite(beta)):
            return False
        return (
            V - V_min > 0
            and V_max - V > 0
            and cos(beta) - cos_min > 0
            and cos(gamma) - cos_min > 0
            and alpha_max - abs(alpha) > 0
            and (ground is None or -z - ground > 0)
            and (not low or -z - h_min > 0)
            and (not high or h_max + z > 0)
        )

    return inside


class StateConverter:
    """JSBSim raw outputs -> the 12 wind-frame states (scalar per step, or vectorised).

    Parameters
    ----------
    x0 : ndarray, shape (12,)
        Initial state (origin of the NED plane; chi and mu start at its values).
    radius_ft : float
        Sea-level radius of the flat planet [ft].
    wgs84 : pair of float or None
        Initial (latitude, longitude) [rad] on JSBSim's WGS84 Earth; None on the flat planet.
    bounds : DomainBounds
        The domain :meth:`check` tests (:func:`gna.trajectory.domain_bounds` of the run's environment).
    """

    def __init__(
        self, x0: np.ndarray, radius_ft: float, wgs84: tuple[float, float] | None, bounds: DomainBounds = DOMAIN
    ):
        self.x0 = np.asarray(x0, dtype=float)
        self.bounds = bounds
        self.wgs84 = wgs84
        if wgs84 is None:
            self.rm = self.rn = radius_ft
            self.lat0 = self.lon0 = 0.0
        else:
            lat0, lon0 = wgs84
            a, b = WGS84_A_FT, WGS84_B_FT
            e2 = 1.0 - (b / a) ** 2
            w = 1.0 - e2 * math.sin(lat0) ** 2
            self.rn = a / math.sqrt(w)  # normal (prime vertical) radius
            self.rm = a * (1.0 - e2) / w**1.5  # meridian radius
            self.lat0, self.lon0 = lat0, lon0
        self._chi, self._mu = float(self.x0[5]), float(self.x0[8])
        self._x0, self._y0 = float(self.x0[0]), float(self.x0[1])  # floats: the same sums as on numpy's
        self._inside = inside_test(bounds)

    def _states(self, raw, sin, cos, atan2):
        lat, lon, h, vt, gamma, psi_gt, alpha, beta, phi, theta, psi, p, q, r = raw
        ft = units.FT
        x = self.x0[0] + ft * (self.rm + h) * (lat - self.lat0)
        y = self.x0[1] + ft * (self.rn + h) * cos(lat if self.wgs84 is None else self.lat0) * (lon - self.lon0)
        return [
            x,
            y,
            -ft * h,
            vt * ft,
            gamma,
            psi_gt,
            alpha,
            beta,
            bank_from_euler(alpha, beta, phi, theta, sin, cos, atan2),
            p,
            q,
            r,
        ]

    @property
    def chi(self) -> float:
        """chi [rad] continued through every :meth:`scalar` call so far (x0's value before the first)."""
        return self._chi

    @property
    def mu(self) -> float:
        """mu [rad] continued through every :meth:`scalar` call so far (x0's value before the first)."""
        return self._mu

    def vector(self, raw: np.ndarray, turns: np.ndarray | None = None) -> np.ndarray:
        """Raw outputs -> states; chi and mu continuous.

        Parameters
        ----------
        raw : ndarray, shape (14, n)
            Values of the position nodes and :data:`STATE_NODES`.
        turns : ndarray, shape (2, n), optional
            chi and mu [rad] continued at every integration step
            (:attr:`chi`, :attr:`mu` at the output steps): each output angle is
            shifted by the whole turns that bring it nearest.  Without it the
            output samples themselves are unwrapped from x0's values (wrong
            when an angle turns by more than pi between two samples).

        Returns
        -------
        ndarray, shape (12, n)
        """
        s = np.array(self._states(raw, np.sin, np.cos, np.arctan2), dtype=float).reshape(12, -1)
        if turns is None:
            s[5] = align(s[5], self.x0[5])
            s[8] = align(s[8], self.x0[8])
            return s
        two_pi = 2.0 * math.pi
        for row, ref in ((5, turns[0]), (8, turns[1])):
            s[row] = s[row] + two_pi * np.round((ref - s[row]) / two_pi)
        return s

    def track(
        self, vt: float, gamma: float, psi_gt: float, alpha: float, beta: float, phi: float, theta: float
    ) -> tuple[float, ...]:
        """One integration step: chi and mu continued, and the states the domain tests need.

        Called at every step, so that chi and mu stay continuous whatever the
        output interval (a fast roll turns mu by more than pi between coarse
        output samples).

        Parameters
        ----------
        vt : float
            Airspeed [ft/s].
        gamma, psi_gt, alpha, beta, phi, theta : float
            Flight-path angle, ground track, angle of attack, sideslip, Euler roll and pitch [rad].

        Returns
        -------
        tuple of float
            The 12 wind-frame states with the position and rates left at 0
            (for :func:`gna.trajectory.domain_margins`).
        """
        gamma = self._track(gamma, psi_gt, alpha, beta, phi, theta)[0]
        return (0.0, 0.0, 0.0, vt * units.FT, gamma, self._chi, alpha, beta, self._mu, 0.0, 0.0, 0.0)

    def _track(self, gamma, psi_gt, alpha, beta, phi, theta) -> tuple[float, float]:
        """:meth:`track`'s work: chi and mu continued; ``(gamma, mu)``, gamma folded at the vertical, mu as read."""
        sin, cos = math.sin, math.cos
        ca, sa, cb, sb = cos(alpha), sin(alpha), cos(beta), sin(beta)
        d1, d2, d3 = -sin(theta), sin(phi) * cos(theta), cos(phi) * cos(theta)
        mu = math.atan2(-ca * sb * d1 + cb * d2 - sa * sb * d3, -sa * d1 + ca * d3)
        dchi = math.remainder(psi_gt - self._chi, 2.0 * math.pi)
        if abs(dchi) > 0.5 * math.pi and abs(gamma) > 0.25 * math.pi:
            # The track turned by more than pi/2 in one step near the vertical: the flight path went through
            # it (JSBSim's gamma folds back inside [-pi/2, pi/2], the wind-frame chart passes cos(gamma) = 0).
            gamma = math.copysign(0.5 * math.pi, gamma)
        self._chi = self._chi + dchi
        self._mu = self._mu + math.remainder(mu - self._mu, 2.0 * math.pi)
        return gamma, mu

    def check(self, t: float, raw: Sequence[float]) -> str | None:
        """One integration step: :meth:`track` on the :data:`TRACK_NODES` values, then the domain test.

        Parameters
        ----------
        t : float
            Time of the step [s].
        raw : sequence of 7 or 8 float
            Values of :data:`TRACK_NODES`, then the altitude of the CG [ft] (the ground's and the
            atmosphere's tests of ``bounds``).

        Returns
        -------
        str or None
            None inside the physical domain, else :func:`gna.trajectory.domain_violation`'s message (with
            ``bounds``: the CG at or below the ground, or outside the atmosphere model's altitudes, too).
        """
        vt, gamma, psi_gt, alpha, beta, phi, theta = raw[:7]
        z = -units.FT * raw[7] if len(raw) > 7 else 0.0  # the ground and the atmosphere's range tested too
        try:
            folded = self._track(gamma, psi_gt, alpha, beta, phi, theta)[0]
        except (ValueError, OverflowError):  # math functions of non-finite outputs
            x = [math.nan] * 12
            x[2], x[3] = z if len(raw) > 7 else math.nan, vt * units.FT
        else:
            if self._inside(z, vt * units.FT, folded, alpha, beta):
                return None
            x = [0.0, 0.0, z, vt * units.FT, folded, self._chi, alpha, beta, self._mu, 0.0, 0.0, 0.0]
        return domain_violation(t, x, self.bounds) or f"left the physical domain at t = {t:.6g} s"

    def step(self, t: float, raw: Sequence[float]) -> tuple[str | None, list | None]:
        """:meth:`check` then :meth:`scalar` on one reading of the 14 raw outputs (a feedback's sample).

        The same numbers as the two calls in turn, each output read once: the
        :data:`TRACK_NODES` and the altitude are among the 14 (mu, the same
        formula on the same angles, is computed once).

        Parameters
        ----------
        t : float
            Time of the step [s].
        raw : sequence of 14 float
            Values of the position nodes and :data:`STATE_NODES`.

        Returns
        -------
        (str, None) or (None, list of float)
            :meth:`check`'s message outside the physical domain; else the 12 states.
        """
        lat, lon, h, vt, gamma, psi_gt, alpha, beta, phi, theta, psi, p, q, r = raw
        try:
            folded, mu = self._track(gamma, psi_gt, alpha, beta, phi, theta)
        except (ValueError, OverflowError):  # math functions of non-finite outputs: check()'s own path
            return self.check(t, (vt, gamma, psi_gt, alpha, beta, phi, theta, h)) or "", None
        ft = units.FT
        z, V = -ft * h, vt * ft
        if not self._inside(z, V, folded, alpha, beta):
            x = [0.0, 0.0, z, V, folded, self._chi, alpha, beta, self._mu, 0.0, 0.0, 0.0]
            return domain_violation(t, x, self.bounds) or f"left the physical domain at t = {t:.6g} s", None
        chi = self._chi + math.remainder(psi_gt - self._chi, 2.0 * math.pi)
        mu = self._mu + math.remainder(mu - self._mu, 2.0 * math.pi)
        self._chi, self._mu = chi, mu
        x = self._x0 + ft * (self.rm + h) * (lat - self.lat0)
        y = self._y0 + ft * (self.rn + h) * math.cos(lat if self.wgs84 is None else self.lat0) * (lon - self.lon0)
        return None, [x, y, z, V, gamma, chi, alpha, beta, mu, p, q, r]

    def scalar(self, raw: Sequence[float]) -> np.ndarray:
        """One step (pure-Python arithmetic), chi and mu continued from the previous call.

        Parameters
        ----------
        raw : sequence of 14 float
            Values of the position nodes and :data:`STATE_NODES`.

        Returns
        -------
        ndarray, shape (12,)
        """
        s = self._states(raw, math.sin, math.cos, math.atan2)
        s[5] = self._chi + math.remainder(s[5] - self._chi, 2.0 * math.pi)
        s[8] = self._mu + math.remainder(s[8] - self._mu, 2.0 * math.pi)
        self._chi, self._mu = s[5], s[8]
        return np.array(s)


def trajectory_frame(
    aircraft: Aircraft, env: Environment, t: np.ndarray, S: np.ndarray, U: np.ndarray, D: np.ndarray
) -> pd.DataFrame:
    """The common DataFrame (:data:`gna.trajectory.COLUMNS`) from JSBSim's states and its own derived outputs.

    Parameters
    ----------
    aircraft : Aircraft
        Its mass gives the load factors.
    env : Environment
        Its g gives the load factors.
    t : ndarray, shape (n,)
        Output times [s].
    S : ndarray, shape (12, n)
        Wind-frame states (:meth:`StateConverter.vector`).
    U : ndarray, shape (5, n)
        Applied controls.
    D : ndarray, shape (len(DERIVED_NODES), n)
        Raw derived outputs read from :data:`DERIVED_NODES` (English units).

    Returns
    -------
    pandas.DataFrame
    """
    qbar, rho = D[0] * (units.LBF / units.FT2), D[1] * units.SLUG_FT3
    coeffs = D[2:8]
    fb = D[8:11] * units.LBF  # aerodynamic + thrust, body axes
    wb = D[11:14] * units.LBF  # weight, body axes
    mom = D[14:17] * (units.LBF * units.FT)
    alpha, beta = S[6], S[7]
    ca, sa, cb, sb = np.cos(alpha), np.sin(alpha), np.cos(beta), np.sin(beta)
    tot = fb + wb

    def to_wind(v):
        return (
            ca * cb * v[0] + sb * v[1] + sa * cb * v[2],
            -ca * sb * v[0] + cb * v[1] - sa * sb * v[2],
            -sa * v[0] + ca * v[2],
        )

    X, Y, Z = to_wind(tot)
    mg = aircraft.mass.mass * env.g
    data = {n: S[i] for i, n in enumerate(STATE_NAMES)}
    data.update({n: U[i] for i, n in enumerate(CONTROL_NAMES)})
    data.update(
        qbar=qbar, rho=rho, nx=fb[0] / mg, ny=fb[1] / mg, nz=-fb[2] / mg, X=X, Y=Y, Z=Z, L=mom[0], M=mom[1], N=mom[2]
    )
    data.update({n: coeffs[i] for i, n in enumerate(("CD", "CY", "CL", "Cl", "Cm", "Cn"))})
    return pd.DataFrame({k: np.asarray(data[k], dtype=float) for k in COLUMNS}, index=pd.Index(t, name="t"))
