"""JSBSim's step grid, and its properties -> the 12 wind-frame states and the common trajectory DataFrame.

JSBSim has no wind-axis bank property: mu comes from the body Euler angles and
alpha, beta (:func:`gna.frames.bank_from_euler`).  Positions are read as
latitude, longitude and altitude and mapped to the NED plane of the initial
point (spherical arcs, so that level flight on the huge sphere is level in NED).
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np
import pandas as pd

from gna import units
from gna.aircraft import Aircraft
from gna.atmosphere import Environment
from gna.eom import CONTROL_NAMES, STATE_NAMES
from gna.frames import bank_from_euler
from gna.errors import InputError
from gna.trajectory import COLUMNS

from . import export as jx
from .fdm import WGS84_A_FT, WGS84_B_FT

# Raw outputs read at each output time (their order is the order of the raw arrays).
STATE_NODES_FLAT = ("position/lat-gc-rad", "position/long-gc-rad", "position/h-sl-ft")
STATE_NODES_WGS84 = ("position/lat-geod-rad", "position/long-gc-rad", "position/geod-alt-ft")
STATE_NODES = ("velocities/vt-fps", "flight-path/gamma-rad", "flight-path/psi-gt-rad", "aero/alpha-rad",
               "aero/beta-rad", "attitude/phi-rad", "attitude/theta-rad", "attitude/psi-rad",
               "velocities/p-rad_sec", "velocities/q-rad_sec", "velocities/r-rad_sec")
DERIVED_NODES = (jx.QBAR_PROPERTY, jx.RHO_PROPERTY) + tuple(jx.COEFFICIENT_PROPERTIES.values()) + (
    "forces/fbx-total-lbs", "forces/fby-total-lbs", "forces/fbz-total-lbs",
    "forces/fbx-weight-lbs", "forces/fby-weight-lbs", "forces/fbz-weight-lbs",
    "moments/l-total-lbsft", "moments/m-total-lbsft", "moments/n-total-lbsft")


def step_grid(t0: float, t1: float, dt_max: float, dt_out: float, t_eval) -> tuple[int, float, np.ndarray]:
    """JSBSim's step grid: the largest step <= ``dt_max`` that divides the output interval.

    Parameters
    ----------
    t0, t1 : float
        Span [s].
    dt_max : float
        Largest step [s].
    dt_out : float
        Output interval [s] (used when ``t_eval`` is None).
    t_eval : array_like, shape (m,), or None
        Output times [s]; they must lie on the grid.

    Returns
    -------
    n : int
        Number of steps.
    dt : float
        Step [s].
    out_steps : ndarray of int, shape (m,)
        Step indices of the output times.

    Raises
    ------
    InputError
        Bad ``dt_out`` or ``t_eval``, or output times off the grid.
    """
    if t_eval is not None:
        te = np.asarray(t_eval, dtype=float).ravel()
        if te.size == 0 or not np.all(np.isfinite(te)) or np.any(np.diff(te) <= 0):
            raise InputError("t_eval must be a non-empty increasing sequence of finite times")
        if te[0] < t0 - 1e-12 or te[-1] > t1 + 1e-12:
            raise InputError(f"t_eval must lie in t_span [{t0:g}, {t1:g}] s")
        gaps = np.diff(np.concatenate([[t0], te, [t1]]))
        gaps = gaps[gaps > 1e-12]
        h = float(np.min(gaps)) if gaps.size else t1 - t0
        n_out = max(int(round((t1 - t0) / h)), 1)
    else:
        if not (math.isfinite(dt_out) and dt_out > 0):
            raise InputError(f"dt_out must be positive, got {dt_out}")
        n_out = max(int(round((t1 - t0) / dt_out)), 1)
    m = max(int(math.ceil((t1 - t0) / n_out / dt_max - 1e-9)), 1)
    n = n_out * m
    dt = (t1 - t0) / n
    if t_eval is None:
        return n, dt, np.arange(0, n + 1, m)
    k = np.round((te - t0) / dt).astype(int)
    off = np.abs(t0 + k * dt - te)
    if np.any(off > 1e-9 * max(1.0, abs(t1))):
        i = int(np.argmax(off))
        raise InputError(f"t_eval time {te[i]:.12g} s is not on JSBSim's step grid (dt = {dt:.6g} s from "
                         f"t0 = {t0:g} s); use a uniform t_eval or dt_out")
    return n, dt, k


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
    """

    def __init__(self, x0: np.ndarray, radius_ft: float, wgs84: tuple[float, float] | None):
        self.x0 = np.asarray(x0, dtype=float)
        self.wgs84 = wgs84
        if wgs84 is None:
            self.rm = self.rn = radius_ft
            self.lat0 = self.lon0 = 0.0
        else:
            lat0, lon0 = wgs84
            a, b = WGS84_A_FT, WGS84_B_FT
            e2 = 1.0 - (b / a) ** 2
            w = 1.0 - e2 * math.sin(lat0) ** 2
            self.rn = a / math.sqrt(w)                  # normal (prime vertical) radius
            self.rm = a * (1.0 - e2) / w ** 1.5          # meridian radius
            self.lat0, self.lon0 = lat0, lon0
        self._chi, self._mu = float(self.x0[5]), float(self.x0[8])

    def _states(self, raw, sin, cos, atan2):
        lat, lon, h, vt, gamma, psi_gt, alpha, beta, phi, theta, psi, p, q, r = raw
        ft = units.FT
        x = self.x0[0] + ft * (self.rm + h) * (lat - self.lat0)
        y = self.x0[1] + ft * (self.rn + h) * cos(lat if self.wgs84 is None else self.lat0) * (lon - self.lon0)
        return [x, y, -ft * h, vt * ft, gamma, psi_gt, alpha, beta, bank_from_euler(alpha, beta, phi, theta, sin, cos, atan2),
                p, q, r]

    def vector(self, raw: np.ndarray) -> np.ndarray:
        """Raw outputs -> states; chi and mu unwrapped from x0's values.

        Parameters
        ----------
        raw : ndarray, shape (14, n)
            Values of the position nodes and :data:`STATE_NODES`.

        Returns
        -------
        ndarray, shape (12, n)
        """
        s = np.array(self._states(raw, np.sin, np.cos, np.arctan2), dtype=float).reshape(12, -1)
        s[5] = align(s[5], self.x0[5])
        s[8] = align(s[8], self.x0[8])
        return s

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


def trajectory_frame(aircraft: Aircraft, env: Environment, t: np.ndarray, S: np.ndarray, U: np.ndarray,
                     D: np.ndarray) -> pd.DataFrame:
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
    fb = D[8:11] * units.LBF          # aerodynamic + thrust, body axes
    wb = D[11:14] * units.LBF         # weight, body axes
    mom = D[14:17] * (units.LBF * units.FT)
    alpha, beta = S[6], S[7]
    ca, sa, cb, sb = np.cos(alpha), np.sin(alpha), np.cos(beta), np.sin(beta)
    tot = fb + wb

    def to_wind(v):
        return (ca * cb * v[0] + sb * v[1] + sa * cb * v[2],
                -ca * sb * v[0] + cb * v[1] - sa * sb * v[2],
                -sa * v[0] + ca * v[2])

    X, Y, Z = to_wind(tot)
    mg = aircraft.mass.mass * env.g
    data = {n: S[i] for i, n in enumerate(STATE_NAMES)}
    data.update({n: U[i] for i, n in enumerate(CONTROL_NAMES)})
    data.update(qbar=qbar, rho=rho, nx=fb[0] / mg, ny=fb[1] / mg, nz=-fb[2] / mg, X=X, Y=Y, Z=Z,
                L=mom[0], M=mom[1], N=mom[2])
    data.update({n: coeffs[i] for i, n in enumerate(("CD", "CY", "CL", "Cl", "Cm", "Cn"))})
    return pd.DataFrame({k: np.asarray(data[k], dtype=float) for k in COLUMNS}, index=pd.Index(t, name="t"))


