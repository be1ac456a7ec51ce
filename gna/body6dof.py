"""Body-axis 6-DoF with quaternion attitude: an independent formulation of the
same physics, used to check the wind-frame equations of :mod:`gna.eom`.

States: NED position (3), body velocity u, v, w (3), attitude quaternion
q0..q3 (scalar first, ``C_bn``), body rates p, q, r (3): 13 in all.  Forces
are assembled in body axes from the same aerodynamic coefficients (stability
axes -> body through alpha), the engine thrust vectors and the moments
``r x F`` of each engine written out as vectors, and gravity rotated by the
quaternion.  Nothing is shared with :mod:`gna.eom` except the coefficient
table and the aircraft data.
"""

from __future__ import annotations

import numpy as np

from .aero import AeroState
from .aircraft import Aircraft
from .atmosphere import Environment
from .frames import C_body_ned, dcm_from_quaternion, quaternion_from_dcm, wind_angles_from_body


def from_wind_state(s) -> np.ndarray:
    """The body-axis state equal to a wind-frame state.

    Parameters
    ----------
    s : sequence of 12 float
        Wind-frame state ``x, y, z, V, gamma, chi, alpha, beta, mu, p, q, r`` (:class:`gna.eom.State` order):
        NED position [m], airspeed [m/s], angles [rad], body rates [rad/s].

    Returns
    -------
    ndarray, shape (13,)
        NED position [m], body velocity ``u, v, w`` [m/s], unit attitude quaternion of ``C_bn`` (scalar
        first, :func:`gna.frames.quaternion_from_dcm`), body rates ``p, q, r`` [rad/s].
    """
    x, y, z, V, gamma, chi, alpha, beta, mu, p, q, r = (float(v) for v in s)
    C = C_body_ned(gamma, chi, mu, alpha, beta)
    uvw = V * np.array([np.cos(alpha) * np.cos(beta), np.sin(beta), np.sin(alpha) * np.cos(beta)])
    return np.concatenate([[x, y, z], uvw, quaternion_from_dcm(C), [p, q, r]])


def to_wind_state(X: np.ndarray) -> np.ndarray:
    """Wind-frame states from body-axis states (inverse of :func:`from_wind_state`; no wind).

    Parameters
    ----------
    X : ndarray, shape (13,) or (13, ...)
        Body-axis states (:func:`from_wind_state` layout); trailing axes are many states at once. The
        quaternion need not be of unit norm.

    Returns
    -------
    ndarray, shape (12,) or (12, ...)
        Wind-frame states ``x, y, z, V, gamma, chi, alpha, beta, mu, p, q, r`` (SI, rad).
    """
    C = dcm_from_quaternion(X[6:10])
    V, gamma, chi, alpha, beta, mu = wind_angles_from_body(X[3:6], C)
    return np.array([X[0], X[1], X[2], V, gamma, chi, alpha, beta, mu, X[10], X[11], X[12]])


def derivative(aircraft: Aircraft, env: Environment, X: np.ndarray, controls) -> np.ndarray:
    """Time derivative of the 13-state body-axis formulation (flat, non-rotating Earth, no wind).

    Body-axis force and moment equations ``u' = F/m - w x u``, ``I w' = M - w x I w``, position
    ``C_bn^T u`` and quaternion kinematics ``q' = Omega(w) q / 2`` (Stevens, Lewis & Johnson, *Aircraft
    Control and Simulation*, 3rd ed., ch. 1). The stability-axis aerodynamic force is rotated through
    alpha into body axes, the moments are transferred from ``x_ref`` to the CG, and each engine's thrust
    moment is ``r x F`` (engine 1 at ``y = -y_p`` takes ``F (1 + eta)/2``).

    Parameters
    ----------
    aircraft : Aircraft
        Geometry, mass, inertia, propulsion and aerodynamic coefficient table.
    env : Environment
        Atmosphere (density at altitude ``-z``) and gravity.
    X : ndarray, shape (13,)
        Body-axis state (:func:`from_wind_state` layout).
    controls : sequence of 5 float
        ``F`` total thrust [N], ``eta = (F1 - F2)/(F1 + F2)``, ``dl, dm, dn`` aileron, elevator, rudder [rad]
        (:class:`gna.eom.Controls` order).

    Returns
    -------
    ndarray, shape (13,)
        ``dX/dt``: NED velocity [m/s], body acceleration [m/s^2], quaternion rate [1/s], angular
        acceleration [rad/s^2].
    """
    F, eta, dl, dm, dn = controls
    pos, uvw, quat, w = X[0:3], X[3:6], X[6:10], X[10:13]
    u, v, ww = uvw
    p, q, r = w
    C_bn = dcm_from_quaternion(quat)
    V = np.sqrt(u * u + v * v + ww * ww)
    alpha = np.arctan2(ww, u)
    beta = np.arcsin(v / V)
    geo, m = aircraft.geometry, aircraft.mass.mass
    rho = env.density(pos[2])
    qS = 0.5 * rho * V * V * geo.S
    c = aircraft.aero.coefficients(
        AeroState(alpha, beta, p * geo.b / (2 * V), q * geo.cbar / (2 * V), r * geo.b / (2 * V), dl, dm, dn)
    )
    # Aerodynamic force: stability axes (-CD, CY, -CL) -> body.
    Fs = qS * np.array([-c.CD, c.CY, -c.CL])
    ca, sa = np.cos(alpha), np.sin(alpha)
    C_bs = np.array([[ca, 0.0, -sa], [0.0, 1.0, 0.0], [sa, 0.0, ca]])
    Fa = C_bs @ Fs
    # Aerodynamic moment about the reference, then about the CG: M_cg = M_ref + r_ref x F.
    Ma = qS * np.array([geo.b * c.Cl, geo.cbar * c.Cm, geo.b * c.Cn])
    r_ref = np.array([-(geo.x_ref - geo.x_cg), 0.0, 0.0])  # body x forward, x_ref measured aft
    Ma = Ma + np.cross(r_ref, Fa)
    # Engines: one on the symmetry plane, or two at y = -y_p (1, left) and +y_p (2, right).
    eps = aircraft.propulsion.epsilon
    d = np.array([np.cos(eps), 0.0, -np.sin(eps)])
    # The thrust line passes thrust_line_offset below the CG: the engines at (o sin eps, y, o cos eps).
    o = aircraft.propulsion.thrust_line_offset
    xo, zo = o * np.sin(eps), o * np.cos(eps)
    if aircraft.propulsion.count == 1:
        engines = [(np.array([xo, 0.0, zo]), F)]
    else:
        yp = aircraft.propulsion.y_p
        engines = [(np.array([xo, -yp, zo]), F * (1 + eta) / 2), (np.array([xo, yp, zo]), F * (1 - eta) / 2)]
    Ft = sum(Fi * d for _, Fi in engines)
    Mt = sum(np.cross(ri, Fi * d) for ri, Fi in engines)
    Mt = Mt + np.array([aircraft.propulsion.torque_arm * F, 0.0, 0.0])  # propeller torque, proportional to F
    Fg = C_bn @ np.array([0.0, 0.0, m * env.g])
    Fb = Fa + Ft + Fg
    Mb = Ma + Mt
    I = aircraft.mass.inertia_matrix
    wdot = np.linalg.solve(I, Mb - np.cross(w, I @ w))
    uvwdot = Fb / m - np.cross(w, uvw)
    posdot = C_bn.T @ uvw
    q0, q1, q2, q3 = quat
    Omega = 0.5 * np.array([[0, -p, -q, -r], [p, 0, r, -q], [q, -r, 0, p], [r, q, -p, 0]])
    qdot = Omega @ quat
    return np.concatenate([posdot, uvwdot, qdot, wdot])
