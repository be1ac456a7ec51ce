"""Twelve-state wind-frame equations of motion (paper section "The shape of the equations").

States ``x, y, z`` (north-east-down, m), ``V`` (airspeed, m/s), ``gamma``
(flight-path angle), ``chi`` (track angle), ``alpha``, ``beta`` (angle of
attack, sideslip), ``mu`` (wind-axis bank angle), ``p, q, r`` (body rates,
rad/s).  Controls ``F`` (total thrust, N), ``eta = (F1 - F2)/(F1 + F2)``,
``dl, dm, dn`` (aileron, elevator, rudder, rad).  Flat, non-rotating Earth,
uniform gravity, no wind.

This is the **one definition** of the model: every function here uses only
arithmetic and numpy ufuncs on its inputs, so it evaluates on floats, on numpy
arrays (many states at once, broadcast together) and on truncated power series
(:mod:`planners.series`) alike.  Nothing here branches on values.

Equations and where they come from
----------------------------------
:func:`derivatives` is the concatenation of four public equation groups,
which the planner calls too (on series):

* :func:`kinematics` -- paper eqs. (aircraft1:x)-(aircraft1:z);
* :func:`force_equations` -- V', gamma', chi', paper eqs. (aircraft1:V)-(aircraft1:chi);
* :func:`wind_angle_rates` -- alpha', beta', mu', the G3 equations;
* :func:`rotational_dynamics` -- p', q', r', paper eq. (aircraft2);

given the forces (:func:`wind_forces`) and moments (:func:`body_moments`) of
:func:`loads`, with the coefficients of :func:`aero_coefficients`.

* Kinematics, paper eqs. (aircraft1:x)-(aircraft1:z).
* Force equations, paper eqs. (aircraft1:V)-(aircraft1:chi): with the total
  force ``(X, Y, Z)`` in wind axes,
  ``V' = X/m``, ``gamma' = -(Y sin mu + Z cos mu)/(m V)``,
  ``chi' = (Y cos mu - Z sin mu)/(m V cos gamma)``.
* Forces, paper eqs. (X)-(Z), re-derived (see :func:`wind_forces`): the paper's
  eq. (LDtoXY) rotates C_D and C_L through alpha as if they were body-axis
  coefficients; here stability-axis C_D, C_L and body-axis C_Y are rotated
  through beta into wind axes.  The paper's eq. (Z) writes the gravity term
  ``-g m cos(gamma) cos(mu)``; with z down (as its thrust and lift terms and
  eq. (aircraft1:gamma) require) it is ``+g m cos(gamma) cos(mu)``.
* Moments, paper eqs. (L)-(N): the thrust moments follow from the engine
  positions ``(0, -+y_p, 0)`` and direction ``(cos eps, 0, -sin eps)``; this
  gives ``L = +y_p sin(eps) (F1 - F2)`` where the paper prints a minus sign
  (the two differ only when eps != 0).  Aerodynamic moments are transferred
  from the moment reference to the centre of gravity.
* Propulsive moments, an extension of the paper's eqs. (L), (M) (whose engines
  sit on the CG's y axis, without torque): a thrust line ``d`` below the
  CG (:attr:`gna.aircraft.Propulsion.thrust_line_offset`) adds ``M = +d F``
  (the moment ``r x F`` of the thrust ``F (cos eps, 0, -sin eps)`` applied
  at ``r = (x_t, +-y_p, z_t)``, ``d = z_t cos eps + x_t sin eps``), and the
  propellers' reaction torque adds ``L = k F``
  (:attr:`~gna.aircraft.Propulsion.torque_arm`: torque proportional to
  thrust, the ratio JSBSim's ``FGPropeller`` gives at the reference
  condition, :mod:`gna.fit.sources.jsbsim_engines`).  Both are 0 for every
  aircraft that does not give them, and then no operation is added.
* Rotational dynamics, paper eq. (aircraft2).
* G3 (the alpha', beta', mu' equations), derived in :func:`derivatives`'
  notes below and in ``docs/equations.md``.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .aero import AeroState, Coefficients
from .aircraft import Aircraft
from .atmosphere import Environment
from .errors import InputError
from .ground_effect import ground_effect_coefficients

STATE_NAMES: tuple[str, ...] = ("x", "y", "z", "V", "gamma", "chi", "alpha", "beta", "mu", "p", "q", "r")
CONTROL_NAMES: tuple[str, ...] = ("F", "eta", "dl", "dm", "dn")
H_NAMES: tuple[str, ...] = ("p", "q", "r", "dl", "dm", "dn")


class State(NamedTuple):
    """The 12 wind-frame states (any numeric type, broadcast together)."""

    x: object
    y: object
    z: object
    V: object
    gamma: object
    chi: object
    alpha: object
    beta: object
    mu: object
    p: object
    q: object
    r: object


class Controls(NamedTuple):
    """The 5 controls."""

    F: object
    eta: object
    dl: object
    dm: object
    dn: object


class HValues(NamedTuple):
    """Values of the rates and surfaces used in the *force* coefficients of the
    simple (flat) model: the paper's neglected terms H, evaluated at given
    values (zero, calibration constants, or a previous plan iterate)."""

    p: object = 0.0
    q: object = 0.0
    r: object = 0.0
    dl: object = 0.0
    dm: object = 0.0
    dn: object = 0.0


class Loads(NamedTuple):
    """Everything the equations need, and the derived quantities users plot."""

    qbar: object  #: dynamic pressure [Pa]
    rho: object  #: air density [kg/m^3]
    force_coeffs: Coefficients  #: coefficients used for the forces
    moment_coeffs: Coefficients  #: coefficients used for the moments (always full)
    X: object  #: total force along x_w (aero + thrust + gravity) [N]
    Y: object  #: total force along y_w [N]
    Z: object  #: total force along z_w [N]
    L: object  #: total rolling moment about the CG, body axes [N m]
    M: object  #: total pitching moment [N m]
    N: object  #: total yawing moment [N m]
    Xa: object  #: aerodynamic + thrust force in wind axes (no gravity) [N]
    Ya: object
    Za: object


def aero_state(aircraft: Aircraft, V, alpha, beta, p, q, r, dl, dm, dn) -> AeroState:
    """Nondimensional aerodynamic variables: ``phat = p b/(2V)``, ``qhat = q cbar/(2V)``, ``rhat = r b/(2V)``.

    Parameters
    ----------
    aircraft : Aircraft
        Its span ``b`` and mean chord ``cbar`` [m] are used.
    V : float, array or Series
        Airspeed [m/s].
    alpha, beta : float, array or Series
        Angle of attack and sideslip [rad].
    p, q, r : float, array or Series
        Body rates [rad/s].
    dl, dm, dn : float, array or Series
        Aileron, elevator, rudder deflections [rad].

    Returns
    -------
    AeroState
        ``(alpha, beta, phat, qhat, rhat, dl, dm, dn)``, the inputs of the aerodynamic model,
        broadcast together.
    """
    g = aircraft.geometry
    half_over_V = 0.5 / V
    return AeroState(
        alpha, beta, p * (g.b * half_over_V), q * (g.cbar * half_over_V), r * (g.b * half_over_V), dl, dm, dn
    )


def aero_coefficients(aircraft: Aircraft, s: State, u: Controls, h: HValues | None = None) -> Coefficients:
    """Aerodynamic coefficients with the actual rates and surfaces, or with the H values ``h``.

    The force coefficients of the paper's simple model are these with ``h`` given: the rate and
    surface variables (the neglected terms H) replaced by the values in ``h``.

    Parameters
    ----------
    aircraft : Aircraft
        Geometry (b, cbar for the nondimensional rates) and aerodynamic model.
    s : State
        States (only ``V`` [m/s], ``alpha``, ``beta`` [rad] and, when ``h`` is None, ``p, q, r``
        [rad/s] are used); floats, arrays or series, broadcast together.
    u : Controls
        Controls (only ``dl, dm, dn`` [rad], when ``h`` is None).
    h : HValues, optional
        Values of ``p, q, r, dl, dm, dn`` used instead of the actual ones.

    Returns
    -------
    Coefficients
        ``CD, CY, CL`` (stability/body axes, see :func:`wind_forces`) and ``Cl, Cm, Cn`` (body axes),
        dimensionless, of the broadcast shape of the inputs.
    """
    if h is None:
        return aircraft.aero.coefficients(aero_state(aircraft, s.V, s.alpha, s.beta, s.p, s.q, s.r, u.dl, u.dm, u.dn))
    return aircraft.aero.coefficients(aero_state(aircraft, s.V, s.alpha, s.beta, h.p, h.q, h.r, h.dl, h.dm, h.dn))


def wind_forces(aircraft: Aircraft, env: Environment, s: State, u: Controls, fc: Coefficients, qbar):
    """Total force in wind axes (paper eqs. X, Y, Z, re-derived; see module notes).

    Parameters
    ----------
    aircraft : Aircraft
        Wing area, mass and propulsion (thrust inclination ``epsilon``).
    env : Environment
        Gravity ``g`` [m/s^2].
    s : State
        States (``gamma``, ``alpha``, ``beta``, ``mu`` [rad] are used).
    u : Controls
        Controls (total thrust ``F`` [N] is used).
    fc : Coefficients
        Force coefficients ``CD, CL`` (stability axes) and ``CY`` (body axes), e.g. from
        :func:`aero_coefficients`.
    qbar : float, array or Series
        Dynamic pressure [Pa].

    Returns
    -------
    tuple
        ``(X, Y, Z, Xa, Ya, Za)`` [N] along ``x_w, y_w, z_w``: total force, then aerodynamic plus
        thrust force without gravity.
    """
    qS = qbar * aircraft.geometry.S
    cb, sb = np.cos(s.beta), np.sin(s.beta)
    # Aerodynamic force: stability axes (-CD, CY, -CL) rotated by beta into wind axes.
    Xaero = qS * (sb * fc.CY - cb * fc.CD)
    Yaero = qS * (sb * fc.CD + cb * fc.CY)
    Zaero = -qS * fc.CL
    # Thrust F (cos eps, 0, -sin eps) in body axes, in wind axes.
    eps = aircraft.propulsion.epsilon
    cae, sae = np.cos(s.alpha + eps), np.sin(s.alpha + eps)
    Xa = Xaero + u.F * cb * cae
    Ya = Yaero - u.F * sb * cae
    Za = Zaero - u.F * sae
    # Gravity (0, 0, m g) NED, in wind axes.
    mg = aircraft.mass.mass * env.g
    cg = np.cos(s.gamma)
    X = Xa - mg * np.sin(s.gamma)
    Y = Ya + mg * cg * np.sin(s.mu)
    Z = Za + mg * cg * np.cos(s.mu)
    return X, Y, Z, Xa, Ya, Za


def body_moments(aircraft: Aircraft, s: State, u: Controls, full: Coefficients, qbar):
    """Total moment about the CG in body axes (paper eqs. L, M, N, re-derived).

    Aerodynamic moments about ``x_ref`` are transferred to ``x_cg`` with the
    full aerodynamic force; the thrust moments follow from the engine geometry,
    the thrust line's offset below the CG and the propeller torque (module notes).

    Parameters
    ----------
    aircraft : Aircraft
        Geometry (``S, b, cbar, x_cg, x_ref``) and propulsion (``y_p``, ``epsilon``,
        ``thrust_line_offset``, ``torque_arm``).
    s : State
        States (``alpha`` [rad] is used for the moment transfer).
    u : Controls
        Controls (``F`` [N] and ``eta`` for the thrust moments).
    full : Coefficients
        Coefficients of the full model (moments and the force for the transfer).
    qbar : float, array or Series
        Dynamic pressure [Pa].

    Returns
    -------
    tuple
        ``(L, M, N)`` [N m], rolling, pitching and yawing moments about the CG, body axes.
    """
    geo = aircraft.geometry
    qS = qbar * geo.S
    L = qS * geo.b * full.Cl
    M = qS * geo.cbar * full.Cm
    N = qS * geo.b * full.Cn
    d = geo.x_cg - geo.x_ref  # a parameter, not a state: no branching on values
    if np.any(d != 0.0):
        Fby = qS * full.CY
        Fbz = -qS * (np.sin(s.alpha) * full.CD + np.cos(s.alpha) * full.CL)
        # The reference sits at body x = d (x forward) from the CG: M_cg = M_ref + (d, 0, 0) x F.
        M = M - d * Fbz
        N = N + d * Fby
    yp = aircraft.propulsion.y_p
    if yp != 0.0:
        eps = aircraft.propulsion.epsilon
        dF = u.F * u.eta  # F1 - F2
        L = L + yp * np.sin(eps) * dF
        N = N + yp * np.cos(eps) * dF
    d = aircraft.propulsion.thrust_line_offset  # parameters: the terms exist only when given
    if d != 0.0:
        M = M + d * u.F
    k = aircraft.propulsion.torque_arm
    if k != 0.0:
        L = L + k * u.F
    return L, M, N


def loads(
    aircraft: Aircraft, env: Environment, s: State, u: Controls, model: str = "full", h: HValues | None = None
) -> Loads:
    """Forces (wind axes) and moments (body axes, about the CG).

    Parameters
    ----------
    aircraft : Aircraft
        The aircraft model.
    env : Environment
        Atmosphere (density at altitude ``-z``), gravity, and the ground effect on ``CL, CD``
        (:mod:`gna.ground_effect`, when ``env.ground_effect`` is set; the moments transferred to the CG
        use the corrected forces).
    s : State
        The 12 states (SI, rad); floats, arrays or series, broadcast together.
    u : Controls
        The 5 controls (``F`` [N], ``eta``, surfaces [rad]).
    model : {"full", "simple"}
        ``"simple"``: the force coefficients keep only their alpha, beta
        dependence, the rate and surface variables being replaced by ``h``
        (zero when ``h`` is None).  Moments always use the full model.
    h : HValues, optional
        Values of the neglected terms for ``model="simple"``.

    Returns
    -------
    Loads
        Dynamic pressure, density, coefficients, forces (wind axes) and moments (body axes).

    Raises
    ------
    InputError
        ``model`` is neither ``"full"`` nor ``"simple"`` (a ValueError).
    """
    if model not in ("full", "simple"):
        raise InputError(f"model must be 'full' or 'simple', got {model!r}")
    rho = env.density(s.z)
    qbar = 0.5 * rho * s.V * s.V
    # Free-air coefficients, corrected for the ground when env.ground_effect is set (gna.ground_effect).
    full = ground_effect_coefficients(aircraft, env, s.z, aero_coefficients(aircraft, s, u, None))
    fc = (
        full
        if model == "full"
        else ground_effect_coefficients(
            aircraft, env, s.z, aero_coefficients(aircraft, s, u, h if h is not None else HValues())
        )
    )
    X, Y, Z, Xa, Ya, Za = wind_forces(aircraft, env, s, u, fc, qbar)
    L, M, N = body_moments(aircraft, s, u, full, qbar)
    return Loads(qbar, rho, fc, full, X, Y, Z, L, M, N, Xa, Ya, Za)


def kinematics(s: State):
    """Velocity of the centre of gravity in NED axes, paper eqs. (aircraft1:x)-(aircraft1:z).

    Parameters
    ----------
    s : State
        States (``V`` [m/s], ``gamma``, ``chi`` [rad] are used); floats, arrays or series.

    Returns
    -------
    tuple
        ``(x', y', z')`` [m/s]: ``V cos(chi) cos(gamma)``, ``V sin(chi) cos(gamma)``, ``-V sin(gamma)``.
    """
    cg, sg = np.cos(s.gamma), np.sin(s.gamma)
    cc, sc = np.cos(s.chi), np.sin(s.chi)
    return s.V * cc * cg, s.V * sc * cg, -s.V * sg


def force_equations(aircraft: Aircraft, s: State, X, Y, Z):
    """Speed and flight-path angle rates, paper eqs. (aircraft1:V), (aircraft1:gamma), (aircraft1:chi).

    ``V' = X/m``, ``gamma' = -(Y sin mu + Z cos mu)/(m V)``,
    ``chi' = (Y cos mu - Z sin mu)/(m V cos gamma)``.

    Parameters
    ----------
    aircraft : Aircraft
        Its mass ``m`` [kg] is used.
    s : State
        States (``V`` [m/s], ``gamma``, ``mu`` [rad] are used); floats, arrays or series.
    X, Y, Z : float, array or Series
        Total force (aerodynamic, thrust and gravity) in wind axes [N], e.g. from :func:`wind_forces`.

    Returns
    -------
    tuple
        ``(V', gamma', chi')`` in [m/s^2], [rad/s], [rad/s].
    """
    m = aircraft.mass.mass
    cg = np.cos(s.gamma)
    cm, sm = np.cos(s.mu), np.sin(s.mu)
    mV = m * s.V
    Vd = X / m
    gd = -(Y * sm + Z * cm) / mV
    chid = (Y * cm - Z * sm) / (mV * cg)
    return Vd, gd, chid


def wind_angle_rates(aircraft: Aircraft, s: State, Y, Z, chi_dot):
    """Rates of the wind angles, the G3 equations (derived in :func:`derivatives`' notes).

    ``alpha' = q - tan(beta) (p cos alpha + r sin alpha) + Z/(m V cos beta)``,
    ``beta' = p sin alpha - r cos alpha + Y/(m V)``,
    ``mu' = (p cos alpha + r sin alpha)/cos beta - tan(beta) Z/(m V) + chi' sin gamma``.

    Parameters
    ----------
    aircraft : Aircraft
        Its mass ``m`` [kg] is used.
    s : State
        States (``V`` [m/s], ``gamma``, ``alpha``, ``beta`` [rad], ``p, q, r`` [rad/s] are used);
        floats, arrays or series.
    Y, Z : float, array or Series
        Total force along ``y_w`` and ``z_w`` (wind axes) [N].
    chi_dot : float, array or Series
        Track-angle rate ``chi'`` [rad/s], from :func:`force_equations`.

    Returns
    -------
    tuple
        ``(alpha', beta', mu')`` [rad/s].
    """
    m = aircraft.mass.mass
    ca, sa = np.cos(s.alpha), np.sin(s.alpha)
    cb, sb = np.cos(s.beta), np.sin(s.beta)
    sg = np.sin(s.gamma)
    mV = m * s.V
    pcr = s.p * ca + s.r * sa
    ad = s.q - sb / cb * pcr + Z / (mV * cb)
    bd = s.p * sa - s.r * ca + Y / mV
    mud = pcr / cb - sb / cb * Z / mV + chi_dot * sg
    return ad, bd, mud


def rotational_dynamics(aircraft: Aircraft, p, q, r, L, M, N):
    """Body angular accelerations, paper eq. (aircraft2), inverse inertia written out.

    Parameters
    ----------
    aircraft : Aircraft
        Its inertia ``Ixx, Iyy, Izz, Ixz`` [kg m^2] is used.
    p, q, r : float, array or Series
        Body rates [rad/s].
    L, M, N : float, array or Series
        Total moment about the centre of gravity, body axes [N m], e.g. from :func:`body_moments`.

    Returns
    -------
    tuple
        ``(p', q', r')`` [rad/s^2].
    """
    I = aircraft.mass
    Lp = (I.Iyy - I.Izz) * q * r + I.Ixz * p * q + L
    Mp = (I.Izz - I.Ixx) * p * r + I.Ixz * (r * r - p * p) + M
    Np = (I.Ixx - I.Iyy) * p * q - I.Ixz * q * r + N
    gam = I.Ixx * I.Izz - I.Ixz**2
    return (I.Izz * Lp + I.Ixz * Np) / gam, Mp / I.Iyy, (I.Ixz * Lp + I.Ixx * Np) / gam


#: Former name of :func:`rotational_dynamics`.
angular_acceleration = rotational_dynamics


def derivatives(
    aircraft: Aircraft,
    env: Environment,
    s: State,
    u: Controls,
    model: str = "full",
    h: HValues | None = None,
    ld: Loads | None = None,
) -> State:
    """Time derivatives of the 12 states: the four equation groups, concatenated.

    :func:`kinematics` (x', y', z'), :func:`force_equations` (V', gamma', chi'),
    :func:`wind_angle_rates` (alpha', beta', mu', the G3 equations) and
    :func:`rotational_dynamics` (p', q', r'), with the forces and moments of :func:`loads`.

    Parameters
    ----------
    aircraft : Aircraft
        Mass, inertia, geometry, aerodynamics and propulsion.
    env : Environment
        Atmosphere (density at ``-z``) and gravity ``g`` [m/s^2].
    s : State
        The 12 states (SI, rad); floats, arrays or series, broadcast together.
    u : Controls
        The 5 controls (``F`` [N], ``eta``, surfaces [rad]).
    model : {"full", "simple"}
        Force coefficients of the full model, or of the simple model with the neglected terms at ``h``.
    h : HValues, optional
        Values of the neglected terms for ``model="simple"`` (zero when None).
    ld : Loads, optional
        Forces and moments already computed by :func:`loads` (then ``model`` and ``h`` are not used).

    Returns
    -------
    State
        ``(x', y', z', V', gamma', chi', alpha', beta', mu', p', q', r')`` (SI, rad/s, rad/s^2).

    Notes
    -----
    G3 derivation.  Let ``w_w`` be the angular velocity of the wind frame
    relative to the (inertial, flat-Earth) NED frame, in wind axes.  From
    ``C_wn = R1(mu) R2(gamma) R3(chi)``::

        w_wx = mu' - chi' sin(gamma)
        w_wy = gamma' cos(mu) + chi' cos(gamma) sin(mu)
        w_wz = -gamma' sin(mu) + chi' cos(gamma) cos(mu)

    and the acceleration of the velocity vector ``V x_w`` is
    ``(V', V w_wz, -V w_wy) = (X, Y, Z)/m``, whence ``w_wy = -Z/(m V)``,
    ``w_wz = Y/(m V)`` (this also gives eqs. (aircraft1:gamma, chi)).
    The body frame is the wind frame turned by ``-beta`` about ``z_w`` then by
    ``alpha`` about ``y``, so ``C_wb (p, q, r) = w_w + alpha' (sin beta, cos beta, 0) - beta' z_w``.
    Its three components give::

        alpha' = q - tan(beta) (p cos alpha + r sin alpha) + Z / (m V cos beta)
        beta'  = p sin alpha - r cos alpha + Y / (m V)
        mu'    = (p cos alpha + r sin alpha)/cos beta - tan(beta) Z/(m V) + chi' sin gamma

    (Stevens, Lewis & Johnson, *Aircraft Control and Simulation*, 3rd ed.,
    sec. 2.5 give the same result in another notation.)  The test
    ``tests/gna/test_eom.py`` checks all twelve equations against an
    independent body-axis quaternion 6-DoF to 1e-7 relative.
    """
    if ld is None:
        ld = loads(aircraft, env, s, u, model, h)
    xd, yd, zd = kinematics(s)
    Vd, gd, chid = force_equations(aircraft, s, ld.X, ld.Y, ld.Z)
    ad, bd, mud = wind_angle_rates(aircraft, s, ld.Y, ld.Z, chid)
    pd, qd, rd = rotational_dynamics(aircraft, s.p, s.q, s.r, ld.L, ld.M, ld.N)
    return State(xd, yd, zd, Vd, gd, chid, ad, bd, mud, pd, qd, rd)


def state_vector_derivative(
    aircraft: Aircraft, env: Environment, x: np.ndarray, u: Controls, model: str = "full", h: HValues | None = None
) -> np.ndarray:
    """Array form of :func:`derivatives`: ``x`` of shape ``(12, ...)`` -> derivative of the same shape.

    Parameters
    ----------
    aircraft : Aircraft
        The aircraft model.
    env : Environment
        Atmosphere and gravity.
    x : ndarray, shape (12, ...)
        The states in the order of :data:`STATE_NAMES` (SI, rad).
    u : Controls
        The 5 controls, broadcast against ``x[0]``.
    model : {"full", "simple"}
        Force coefficients of the full or the simple model.
    h : HValues, optional
        Values of the neglected terms for ``model="simple"``.

    Returns
    -------
    ndarray, shape (12, ...)
        Time derivatives of the states (SI, rad/s, rad/s^2).
    """
    return np.stack(np.broadcast_arrays(*derivatives(aircraft, env, State(*x), u, model, h)))
