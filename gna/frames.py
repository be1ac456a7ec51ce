"""Frames and attitude conversions (NED earth frame, wind, stability and body axes).

Rotation matrices ``C_ab`` map components in frame b to components in frame a.
``R1, R2, R3`` are the elementary frame rotations about x, y, z.
"""

from __future__ import annotations

import numpy as np


def R1(a: float) -> np.ndarray:
    """Elementary frame rotation by ``a`` about the x axis: components in the old frame -> in the turned one.

    Parameters
    ----------
    a : float
        Rotation angle [rad], positive right-handed about x.

    Returns
    -------
    ndarray, shape (3, 3)
        The orthogonal matrix ``C_new,old``.
    """
    c, s = np.cos(a), np.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, s], [0.0, -s, c]])


def R2(a: float) -> np.ndarray:
    """Elementary frame rotation by ``a`` about the y axis: components in the old frame -> in the turned one.

    Parameters
    ----------
    a : float
        Rotation angle [rad], positive right-handed about y.

    Returns
    -------
    ndarray, shape (3, 3)
        The orthogonal matrix ``C_new,old``.
    """
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0.0, -s], [0.0, 1.0, 0.0], [s, 0.0, c]])


def R3(a: float) -> np.ndarray:
    """Elementary frame rotation by ``a`` about the z axis: components in the old frame -> in the turned one.

    Parameters
    ----------
    a : float
        Rotation angle [rad], positive right-handed about z.

    Returns
    -------
    ndarray, shape (3, 3)
        The orthogonal matrix ``C_new,old``.
    """
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])


def C_wind_ned(gamma: float, chi: float, mu: float) -> np.ndarray:
    """Rotation from NED to wind axes: ``C_wn = R1(mu) R2(gamma) R3(chi)`` (docs/conventions.md, Frames).

    Parameters
    ----------
    gamma : float
        Flight-path angle [rad], positive climbing.
    chi : float
        Track angle [rad] from north, positive towards east.
    mu : float
        Wind-axis bank angle [rad].

    Returns
    -------
    ndarray, shape (3, 3)
        ``C_wn``: NED components -> wind-axis components.
    """
    return R1(mu) @ R2(gamma) @ R3(chi)


def C_body_wind(alpha: float, beta: float) -> np.ndarray:
    """Rotation from wind to body axes: ``C_bw = R2(alpha) R3(-beta)``.

    The air velocity ``(V, 0, 0)`` in wind axes has body components ``V (cos a cos b, sin b, sin a cos b)``.

    Parameters
    ----------
    alpha : float
        Angle of attack [rad].
    beta : float
        Sideslip angle [rad].

    Returns
    -------
    ndarray, shape (3, 3)
        ``C_bw``: wind-axis components -> body-axis components.
    """
    return R2(alpha) @ R3(-beta)


def C_body_ned(gamma, chi, mu, alpha, beta) -> np.ndarray:
    """Rotation from NED to body axes through the wind frame: ``C_bn = C_bw C_wn``.

    Parameters
    ----------
    gamma, chi, mu : float
        Flight-path, track and wind-axis bank angles [rad] (:func:`C_wind_ned`).
    alpha, beta : float
        Angle of attack and sideslip [rad] (:func:`C_body_wind`).

    Returns
    -------
    ndarray, shape (3, 3)
        ``C_bn``: NED components -> body-axis components.
    """
    return C_body_wind(alpha, beta) @ C_wind_ned(gamma, chi, mu)


def euler_from_dcm(C_bn: np.ndarray) -> tuple[float, float, float]:
    """Body Euler angles (roll, pitch, yaw; 3-2-1 sequence) of ``C_bn = R1(phi) R2(theta) R3(psi)``.

    Parameters
    ----------
    C_bn : ndarray, shape (3, 3)
        Rotation from NED to body axes.

    Returns
    -------
    phi, theta, psi : float
        Roll in (-pi, pi], pitch in [-pi/2, pi/2] and heading in (-pi, pi] [rad].
    """
    phi = np.arctan2(C_bn[1, 2], C_bn[2, 2])
    theta = -np.arcsin(np.clip(C_bn[0, 2], -1.0, 1.0))
    psi = np.arctan2(C_bn[0, 1], C_bn[0, 0])
    return float(phi), float(theta), float(psi)


def euler_from_wind(gamma, chi, mu, alpha, beta) -> tuple[float, float, float]:
    """Body Euler angles (phi, theta, psi) from the wind-frame angles, through :func:`C_body_ned`.

    Parameters
    ----------
    gamma, chi, mu : float
        Flight-path, track and wind-axis bank angles [rad].
    alpha, beta : float
        Angle of attack and sideslip [rad].

    Returns
    -------
    phi, theta, psi : float
        Roll, pitch and heading [rad] (:func:`euler_from_dcm`).
    """
    return euler_from_dcm(C_body_ned(gamma, chi, mu, alpha, beta))


def quaternion_from_dcm(C: np.ndarray) -> np.ndarray:
    """Unit quaternion, scalar first, of a rotation matrix ``C_bn`` (Shepperd's method).

    The largest of ``trace C`` and the diagonal entries selects which component is computed from a
    square root, so the division is well conditioned for every rotation. Inverse of
    :func:`dcm_from_quaternion`.

    Parameters
    ----------
    C : ndarray, shape (3, 3)
        Rotation matrix from NED to body axes (orthogonal, determinant +1).

    Returns
    -------
    ndarray, shape (4,)
        ``(q0, q1, q2, q3)``, unit norm, sign chosen so that ``q0 >= 0``.
    """
    tr = np.trace(C)
    cand = np.array([tr, C[0, 0], C[1, 1], C[2, 2]])
    i = int(np.argmax(cand))
    if i == 0:
        q0 = 0.5 * np.sqrt(1 + tr)
        q = [q0, (C[1, 2] - C[2, 1]) / (4 * q0), (C[2, 0] - C[0, 2]) / (4 * q0), (C[0, 1] - C[1, 0]) / (4 * q0)]
    elif i == 1:
        q1 = 0.5 * np.sqrt(1 + 2 * C[0, 0] - tr)
        q = [(C[1, 2] - C[2, 1]) / (4 * q1), q1, (C[0, 1] + C[1, 0]) / (4 * q1), (C[2, 0] + C[0, 2]) / (4 * q1)]
    elif i == 2:
        q2 = 0.5 * np.sqrt(1 + 2 * C[1, 1] - tr)
        q = [(C[2, 0] - C[0, 2]) / (4 * q2), (C[0, 1] + C[1, 0]) / (4 * q2), q2, (C[1, 2] + C[2, 1]) / (4 * q2)]
    else:
        q3 = 0.5 * np.sqrt(1 + 2 * C[2, 2] - tr)
        q = [(C[0, 1] - C[1, 0]) / (4 * q3), (C[2, 0] + C[0, 2]) / (4 * q3), (C[1, 2] + C[2, 1]) / (4 * q3), q3]
    q = np.array(q)
    return q / np.linalg.norm(q) * (1 if q[0] >= 0 else -1)


def dcm_from_quaternion(q) -> np.ndarray:
    """Rotation matrix ``C_bn`` of a quaternion, scalar first (normalized here first).

    Parameters
    ----------
    q : array_like, shape (4,) or (4, ...)
        Quaternion ``(q0, q1, q2, q3)``, any non-zero norm; trailing axes are many quaternions at once.

    Returns
    -------
    ndarray, shape (3, 3) or (3, 3, ...)
        ``C_bn``: NED components -> body-axis components.
    """
    q0, q1, q2, q3 = q / np.sqrt(np.sum(np.asarray(q) ** 2, axis=0))
    return np.array(
        [
            [q0 * q0 + q1 * q1 - q2 * q2 - q3 * q3, 2 * (q1 * q2 + q0 * q3), 2 * (q1 * q3 - q0 * q2)],
            [2 * (q1 * q2 - q0 * q3), q0 * q0 - q1 * q1 + q2 * q2 - q3 * q3, 2 * (q2 * q3 + q0 * q1)],
            [2 * (q1 * q3 + q0 * q2), 2 * (q2 * q3 - q0 * q1), q0 * q0 - q1 * q1 - q2 * q2 + q3 * q3],
        ]
    )


def wind_angles_from_body(uvw, C_bn):
    """Wind-frame variables from the body velocity and the attitude (no wind: air velocity = ground velocity).

    Parameters
    ----------
    uvw : array_like, shape (3,) or (3, ...)
        Body-axis velocity components ``u, v, w`` [m/s]; must not be zero.
    C_bn : array_like, shape (3, 3) or (3, 3, ...)
        Rotation from NED to body axes (trailing axes broadcast with those of ``uvw``).

    Returns
    -------
    V, gamma, chi, alpha, beta, mu : float or ndarray
        Airspeed [m/s]; flight-path, track angle, angle of attack, sideslip and wind-axis bank [rad].
    """
    u, v, w = uvw
    V = np.sqrt(u * u + v * v + w * w)
    alpha = np.arctan2(w, u)
    beta = np.arcsin(v / V)
    # NED velocity = C_bn^T uvw
    vn = C_bn[0, 0] * u + C_bn[1, 0] * v + C_bn[2, 0] * w
    ve = C_bn[0, 1] * u + C_bn[1, 1] * v + C_bn[2, 1] * w
    vd = C_bn[0, 2] * u + C_bn[1, 2] * v + C_bn[2, 2] * w
    gamma = np.arctan2(-vd, np.hypot(vn, ve))
    chi = np.arctan2(ve, vn)
    mu = bank_angle(alpha, beta, (C_bn[0, 2], C_bn[1, 2], C_bn[2, 2]))
    return V, gamma, chi, alpha, beta, mu


def bank_angle(alpha, beta, down, sin=np.sin, cos=np.cos, atan2=np.arctan2):
    """Wind-axis bank angle mu from alpha, beta and the body components of the local vertical.

    ``C_wn = C_wb C_bn`` and ``mu = atan2(C_wn[1, 2], C_wn[2, 2])`` (``C_wind_ned
    = R1(mu) R2(gamma) R3(chi)``), with rows 1, 2 of ``C_wb = C_body_wind^T``
    equal to ``(-ca sb, cb, -sa sb)`` and ``(-sa, 0, ca)``.

    Parameters
    ----------
    alpha, beta : float or ndarray
        Angle of attack and sideslip [rad].
    down : sequence of 3 float or ndarray
        Body components of the NED down axis: the third column of ``C_bn``.
    sin, cos, atan2 : callable
        Elementary functions (``math``'s for fast scalar use).

    Returns
    -------
    float or ndarray
        The bank angle mu [rad] in (-pi, pi].
    """
    ca, sa, cb, sb = cos(alpha), sin(alpha), cos(beta), sin(beta)
    d1, d2, d3 = down
    return atan2(-ca * sb * d1 + cb * d2 - sa * sb * d3, -sa * d1 + ca * d3)


def bank_from_euler(alpha, beta, phi, theta, sin=np.sin, cos=np.cos, atan2=np.arctan2):
    """Wind-axis bank angle mu from alpha, beta and the body Euler angles phi, theta.

    The third column of ``C_bn = R1(phi) R2(theta) R3(psi)`` is
    ``(-sin theta, sin phi cos theta, cos phi cos theta)`` (:func:`bank_angle`).

    Parameters
    ----------
    alpha, beta, phi, theta : float or ndarray
        Angles [rad].
    sin, cos, atan2 : callable
        Elementary functions (``math``'s for fast scalar use).

    Returns
    -------
    float or ndarray
        The bank angle mu [rad].
    """
    cth = cos(theta)
    return bank_angle(alpha, beta, (-sin(theta), sin(phi) * cth, cos(phi) * cth), sin, cos, atan2)
