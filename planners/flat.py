"""The aircraft as an almost chained system: its equations, stages and flat parametrization.

Paper section "The shape of the equations": with flat outputs ``x, y, z``
and a fourth output ``zeta`` (beta, mu, F, or ``f1(t) beta + f2(t) mu``),

* stage 1 gives ``V, gamma, chi`` from ``x', y', z'`` (closed form),
* stage 2 gives ``alpha, beta, mu, F`` (three of them besides the one fixed
  by ``zeta``) from the force equations ``V', gamma', chi'`` -- solved by
  Newton's method on power series (:func:`planners.newton.newton_series`),
* stage 3 gives ``p, q, r`` from ``alpha', beta', mu'`` (the G3 equations are
  linear in the rates: closed form),
* stage 4 gives ``dl, dm, dn`` (or ``dl, dm, eta`` when the rudder is fixed:
  rudder failure, differential thrust as fourth control) from ``p', q', r'``
  -- Newton on series of the moment equations.

Every stage works on truncated power series batched over all nodes at once: the stages are those
of :func:`aircraft_system`, solved by the generic machinery of :mod:`planners.chained`.
Stage 2 uses the force coefficients with the neglected rate and surface
terms H evaluated at given values (zero, calibration constants, or the
previous iterate of generalized flatness), i.e. ``gna.eom`` with
``model="simple"``; stages 3--4 use the full moments.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from gna.aircraft import Aircraft
from gna.atmosphere import Environment
from gna.eom import (
    H_NAMES,
    Controls,
    HValues,
    State,
    aero_coefficients,
    aero_state,
    body_moments,
    force_equations,
    kinematics,
    rotational_dynamics,
    wind_angle_rates,
    wind_forces,
)
from gna.errors import DomainError, InputError
from gna.ground_effect import ground_effect_coefficients

from . import series as _series
from .chained import ChainedSystem, NodeSolution, Stage, check_grid, flat_parametrization
from .expressions import Expression
from .series import Series

__all__ = ["NodeSolution", "check_grid"]  # re-exported: the aircraft's callers import them from here

FLAT_KINDS = ("beta", "mu", "F", "mix")

#: Largest number of generalized-flatness iterations J a plan accepts.
MAX_J = 30


def check_iterations(J, where: str = "plan") -> int:
    """The number of generalized-flatness iterations ``J``, checked: a whole number in 0..:data:`MAX_J`.

    The one check of the scenario files' ``[generalized] J``, of ``--J`` and
    of the Python API (:func:`planners.generalized.plan_scenario`).

    Parameters
    ----------
    J : int
        Iterations after the flat plan (a float with a whole value, as TOML may give, is accepted).
    where : str
        What the message names (file, function).

    Returns
    -------
    int

    Raises
    ------
    InputError
        Not a number (a string, a bool, None), not whole, or outside 0..MAX_J.
    """
    return check_whole(J, "J", MAX_J, where)


def check_whole(value, what: str, upper: int, where: str) -> int:
    """A whole-number setting in ``0..upper`` (J, the output order e), one message per fault.

    Parameters
    ----------
    value : int
        The setting (a float with a whole value, as TOML may give, is accepted).
    what : str
        Its name in the message (``"J"``, ``"the output order e"``).
    upper : int
        Largest accepted value.
    where : str
        What the message names (file, function).

    Returns
    -------
    int

    Raises
    ------
    InputError
        Not a number (a string, a bool, None), not whole, or outside 0..upper.
    """
    if (
        isinstance(value, (bool, np.bool_))
        or not isinstance(value, (int, float, np.integer, np.floating))
        or not np.isfinite(value)
        or float(value) != int(value)
    ):
        raise InputError(f"{where}: {what} must be a whole number, got {value!r} (0 to {upper})")
    if not 0 <= int(value) <= upper:
        raise InputError(f"{where}: {what} must be between 0 and {upper}, got {int(value)}")
    return int(value)


STAGE2_UNKNOWNS = ("alpha", "beta", "mu", "F")


@dataclass(frozen=True)
class FlatOutput:
    """The fourth flat output ``zeta``.

    ``kind`` is ``"beta"``, ``"mu"``, ``"F"`` or ``"mix"`` (``f1(t) beta +
    f2(t) mu = value(t)``).
    """

    kind: str
    value: Expression
    f1: Expression | None = None
    f2: Expression | None = None

    def __post_init__(self):
        if self.kind not in FLAT_KINDS:
            raise InputError(f"flat output must be one of {', '.join(FLAT_KINDS)}, got {self.kind!r}")
        if self.kind == "mix" and (self.f1 is None or self.f2 is None):
            raise InputError("a mixed flat output needs f1(t) and f2(t): f1*beta + f2*mu = value")


@dataclass(frozen=True)
class FlatProblem:
    """What a flat parametrization needs besides the grid.

    Parameters
    ----------
    aircraft, env
    x, y, z : Expression
        Flat outputs (NED, m) as functions of t.
    zeta : FlatOutput
    eta : Expression or None
        Prescribed thrust asymmetry; ``None`` makes eta the fourth control
        (rudder failure), with the rudder fixed at ``dn``.
    dn : Expression or None
        Fixed rudder (only with ``eta = None``).
    h : HValues
        Constant values of the neglected terms for the first iterate (zero, or
        calibration values).
    start : mapping, optional
        Starting values of stage 2 (alpha, beta, mu) where the kinematics do not
        fix them -- e.g. the sideslip branch of a thrust flat output, from a calibration.
    """

    aircraft: Aircraft
    env: Environment
    x: Expression
    y: Expression
    z: Expression
    zeta: FlatOutput
    eta: Expression | None
    dn: Expression | None = None
    h: HValues = HValues()
    start: Mapping[str, float] | None = None

    def __post_init__(self):
        if (self.eta is None) == (self.dn is None):
            raise InputError(
                "give either eta(t) (rudder is a control) or a fixed rudder dn(t) (eta becomes "
                "the fourth control), not both or neither"
            )

    def __getstate__(self) -> dict:
        state = dict(self.__dict__)
        state.pop("_system", None)  # aircraft_system's closures: rebuilt on demand
        return state


def _unwrap_constant(angle: Series) -> Series:
    """Make the constant terms of an angle continuous along the node axis."""
    c0 = np.real(angle.constant_term)
    if c0.ndim == 1 and bool((np.abs(c0[1:] - c0[:-1]) < np.pi).all()):  # np.diff's values, without its checks
        return angle  # np.unwrap's rule: no jump of pi or more, nothing to shift
    if np.all(np.abs(np.diff(c0)) < np.pi):
        return angle
    shift = np.unwrap(c0) - c0
    if np.any(shift != 0):
        return angle + shift
    return angle


def _check_inputs(t_nodes, series: Mapping[str, Series | None]) -> None:
    """Refuse non-finite flat outputs and prescribed inputs, and flat outputs that make stage 1
    singular (V cos(gamma) = 0), naming the time and the value."""
    t_nodes = np.asarray(t_nodes, dtype=float)
    given = {name: s for name, s in series.items() if s is not None}
    heads = [getattr(s, "_c", None) for s in given.values()]  # coefficient first: the first two, below
    if all(c is not None and np.isfinite(c[:2]).all() for c in heads):
        given = {}  # the usual case: every one finite, nothing to name
    for name, s in given.items():
        c = np.real(np.asarray(s.coeffs[..., :2]))
        c = np.broadcast_to(c, (len(t_nodes),) + c.shape[-1:])
        bad = ~np.all(np.isfinite(c), axis=-1)
        if np.any(bad):
            i = int(np.flatnonzero(bad)[0])
            raise DomainError(
                f"{name}(t) or its derivative is not finite at t = {t_nodes[i]:.6g} s ({name} = {c[i, 0]:.6g})",
                time=float(t_nodes[i]),
                variable=name,
                value=float(c[i, 0]),
            )
    xd, yd, zd = (np.real(series[k].coeffs[..., 1]) for k in ("x", "y", "z"))
    vh = np.hypot(xd, yd)
    tiny = 1e-6 * max(1.0, float(np.max(np.hypot(vh, zd))))
    bad = vh <= tiny
    if np.any(bad):
        idx = np.flatnonzero(bad)
        raise DomainError(
            f"the flat outputs give a vertical or zero velocity (V cos(gamma) = {vh[idx[0]]:.3g} m/s) "
            f"at t = {', '.join(f'{v:.6g}' for v in t_nodes[idx[:5]])}{' ...' if len(idx) > 5 else ''} s: "
            f"stage 1 of the flat parametrization is singular there (chi undefined); "
            f"loops and vertical flight need another chart",
            time=float(t_nodes[idx[0]]),
            variable="V cos(gamma)",
            value=float(vh[idx[0]]),
        )


def stage1(x: Series, y: Series, z: Series):
    """V, gamma, chi from the flat outputs (paper eqs. aircraft1:x-z inverted).

    Parameters
    ----------
    x, y, z : Series
        Flat outputs, NED position [m], batch shape (nodes,).

    Returns
    -------
    tuple of Series
        ``(V, gamma, chi)`` [m/s, rad, rad], one order below the flat outputs; chi is made
        continuous along the nodes.
    """
    V, gamma, chi = _stage1_series(x, y, z)
    return V, gamma, _unwrap_constant(chi)


def _stage1_series(x, y, z):
    """:func:`stage1` without making chi continuous: plain arithmetic on series (traced as a program)."""
    xd, yd, zd = x.derivative(), y.derivative(), z.derivative()
    vh2 = xd * xd + yd * yd
    vh = np.sqrt(vh2)
    V = np.sqrt(vh2 + zd * zd)
    gamma = np.arctan2(-zd, vh)
    chi = np.arctan2(yd, xd)
    return V, gamma, chi


def stage3(alpha, beta, mu, gamma, chi):
    """p, q, r from alpha', beta', mu' (G3 solved for the rates; see docs/equations.md).

    With ``w_wy = gamma' cos mu + chi' cos gamma sin mu`` and
    ``w_wz = -gamma' sin mu + chi' cos gamma cos mu`` (wind-frame rates, which
    the stage-2 force equations make equal to ``-Z/(mV)`` and ``Y/(mV)``):
    ``P = p cos a + r sin a = cos b (mu' - tan b w_wy - chi' sin gamma)``,
    ``R = -p sin a + r cos a = w_wz - beta'``,
    ``q = alpha' + tan b P + w_wy / cos b``.

    Parameters
    ----------
    alpha, beta, mu : Series
        Wind angles from stage 2 [rad].
    gamma, chi : Series
        Flight-path and track angles from stage 1 [rad], at the order of ``alpha``.

    Returns
    -------
    tuple of Series
        ``(p, q, r)`` [rad/s], one order below the inputs.
    """
    return _stage3(alpha, beta, mu, _path_terms(gamma, chi))


#: The terms of stage 3 that depend on the flight path only (stage 1): gamma', chi' cos gamma and
#: chi' sin gamma, one order below gamma.
_PATH_TERMS = ("gd", "chid_cg", "chid_sg")


def _path_terms(gamma, chi) -> dict:
    """The flight-path terms of stage 3 (:data:`_PATH_TERMS`) from gamma and chi (stage 1).

    Computed once at the highest order of a plan and truncated for each iterate: a coefficient of
    a truncated power series depends only on the coefficients below it.
    """
    gd, chid = gamma.derivative(), chi.derivative()
    cg, sg = np.cos(gamma), np.sin(gamma)
    return {"gd": gd, "chid_cg": chid * cg, "chid_sg": chid * sg}


def _stage3(alpha, beta, mu, path: dict):
    """:func:`stage3` with the flight-path terms ``path`` (:func:`_path_terms`, at the order of
    ``alpha`` or above: truncated here).

    Real series of one batch shape go through the series kernels directly, the products and
    quotients that do not depend on each other in one call each (the same kernels on more
    columns: the same coefficients as the operators of :class:`~planners.series.Series`).
    """
    k = alpha.order
    gd, chid_cg, chid_sg = (path[n].truncate(min(path[n].order, k - 1)) for n in _PATH_TERMS)
    shape = alpha.batch_shape
    ops = (alpha, beta, mu, gd, chid_cg, chid_sg)
    if (
        k < 1
        or any(u.dtype != np.float64 or u.batch_shape != shape for u in ops)
        or any(u.order != k for u in (beta, mu))
        or any(u.order != k - 1 for u in ops[3:])
    ):
        return _stage3_series(alpha, beta, mu, gd, chid_cg, chid_sg)
    K = _series._K
    n = math.prod(shape)
    m = k + 1

    def flat(u, rows=m):
        return u._c[:rows].reshape(rows, n)

    abm = np.concatenate([flat(alpha), flat(beta), flat(mu)], axis=1)
    s, c = K.sincos(abm, False)
    sa, sb, sm = s[:, :n], s[:, n : 2 * n], s[:, 2 * n :]
    ca, cb, cm = c[:, :n], c[:, n : 2 * n], c[:, 2 * n :]
    d = _series._diff_kernel(abm)  # the derivatives
    ad, bd, mud = d[:, :n], d[:, n : 2 * n], d[:, 2 * n :]
    gd_, chid_cg_, chid_sg_ = flat(gd, m - 1), flat(chid_cg, m - 1), flat(chid_sg, m - 1)
    # wy = gd cm + chid cg sm, wz = -gd sm + chid cg cm
    w = K.mul(
        np.concatenate([gd_, chid_cg_, -gd_, chid_cg_], axis=1),
        np.concatenate([cm[:-1], sm[:-1], sm[:-1], cm[:-1]], axis=1),
    )
    wy = w[:, :n] + w[:, n : 2 * n]
    wz = w[:, 2 * n : 3 * n] + w[:, 3 * n :]
    # tan b = sb / cb and wy / cb
    qt = K.div(np.concatenate([sb[:-1], wy], axis=1), np.concatenate([cb[:-1], cb[:-1]], axis=1))
    tb, wy_cb = qt[:, :n], qt[:, n:]
    P = K.mul(cb[:-1], mud - K.mul(tb, wy) - chid_sg_)
    R = wz - bd
    q = ad + K.mul(tb, P) + wy_cb
    # p = P ca - R sa, r = P sa + R ca
    pr = K.mul(np.concatenate([P, R, P, R], axis=1), np.concatenate([ca[:-1], sa[:-1], sa[:-1], ca[:-1]], axis=1))
    p = pr[:, :n] - pr[:, n : 2 * n]
    r = pr[:, 2 * n : 3 * n] + pr[:, 3 * n :]
    return tuple(Series._wrap(np.ascontiguousarray(v).reshape((m - 1,) + shape)) for v in (p, q, r))


def _stage3_series(alpha, beta, mu, gd, chid_cg, chid_sg):
    """:func:`_stage3` with the operators of :class:`~planners.series.Series` (any dtype and batch)."""
    ad, bd, mud = alpha.derivative(), beta.derivative(), mu.derivative()
    cm, sm = np.cos(mu), np.sin(mu)
    cb, sb = np.cos(beta), np.sin(beta)
    ca, sa = np.cos(alpha), np.sin(alpha)
    wy = gd * cm + chid_cg * sm
    wz = -gd * sm + chid_cg * cm
    tb = sb / cb
    P = cb * (mud - tb * wy - chid_sg)
    R = wz - bd
    q = ad + tb * P + wy / cb
    p = P * ca - R * sa
    r = P * sa + R * ca
    return p, q, r


def force_residuals(
    ac: Aircraft, env: Environment, z, V, gamma, chi, Vd, gd, chid, eta, h: HValues, alpha, beta, mu, F
):
    """The three stage-2 force equations (paper eqs. aircraft1:V, gamma, chi), as specific forces over g.

    Residuals ``(V' - X/m)/g``, ``V (gamma' - gamma'_m)/g`` and ``V cos(gamma) (chi' - chi'_m)/g``,
    with ``gamma'_m, chi'_m`` of :func:`gna.eom.force_equations`, the forces of
    :func:`gna.eom.wind_forces` and the force coefficients evaluated with the H values ``h``
    for the rates and surfaces.  Floats, arrays and series alike.

    Parameters
    ----------
    ac : Aircraft
        The aircraft model.
    env : Environment
        Atmosphere and gravity ``g`` [m/s^2].
    z : float, array or Series
        Down position [m] (altitude ``-z`` for the density).
    V, gamma, chi : float, array or Series
        Airspeed [m/s], flight-path and track angles [rad] (stage 1).
    Vd, gd, chid : float, array or Series
        Their time derivatives [m/s^2, rad/s, rad/s].
    eta : float, array or Series
        Thrust asymmetry ``(F1 - F2)/(F1 + F2)``.
    h : HValues
        Values of the rates [rad/s] and surfaces [rad] in the force coefficients.
    alpha, beta, mu : float, array or Series
        Wind angles [rad] (the unknowns of stage 2).
    F : float, array or Series
        Total thrust [N].

    Returns
    -------
    tuple
        The three residuals, dimensionless.
    """
    g = env.g
    s = State(0.0, 0.0, z, V, gamma, chi, alpha, beta, mu, 0.0, 0.0, 0.0)
    ctl = Controls(F, eta, 0.0, 0.0, 0.0)
    rho = env.density(z)
    qbar = 0.5 * rho * V * V
    fc = ground_effect_coefficients(ac, env, z, aero_coefficients(ac, s, ctl, h))  # free air: fc itself
    X, Y, Z, *_ = wind_forces(ac, env, s, ctl, fc, qbar)
    Vd_m, gd_m, chid_m = force_equations(ac, s, X, Y, Z)
    # Scaled to specific forces over g (dimensionless): the Newton tolerance is on these.
    r1 = (Vd - Vd_m) / g
    r2 = V * (gd - gd_m) / g
    r3 = V * np.cos(gamma) * (chid - chid_m) / g
    return r1, r2, r3


#: Unknowns of stages 1-3 (stage 4: ``dl, dm, dn``, or ``dl, dm, eta`` with a fixed rudder).
STAGE_UNKNOWNS = (("V", "gamma", "chi"), STAGE2_UNKNOWNS, ("p", "q", "r"))


def aircraft_system(problem: FlatProblem) -> ChainedSystem:
    """The aircraft of a flat problem as an almost chained system (paper eq. chained-sys).

    The paper's four groups, r = 4, with Z_1 = {x, y, z}, Z_3 = {zeta} and one neglected group
    H = H_2(p, q, r, dl, dm, dn) (l_2 = 3: L = 2):

    * stage 1: ``(x', y', z') = G_1(V, gamma, chi)`` (:func:`gna.eom.kinematics`), closed form
      :func:`stage1`;
    * stage 2: the force equations ``(V', gamma', chi') = G_2 + H_2`` (:func:`force_residuals`, the
      force coefficients with the neglected terms at ``X^``) and the fourth flat output, Newton on
      series from the kinematic starting values of :func:`_stage2_guess`;
    * stage 3: ``(alpha', beta', mu') = G_3(..., p, q, r)`` (:func:`gna.eom.wind_angle_rates` with the
      wind-axis forces of the force equations), closed form :func:`stage3`;
    * stage 4: ``(p', q', r') = G_4(..., dl, dm, dn)`` (full moments, :func:`gna.eom.body_moments`,
      :func:`gna.eom.rotational_dynamics`), Newton on series at the working order from the start
      (the moments are affine in the surfaces in the bundled models: one step solves them); with a
      fixed rudder ``dn(t)`` the fourth control is ``eta``.

    The thrust asymmetry ``eta(t)`` (or the fixed rudder ``dn(t)``) and the weights ``f1, f2`` of a
    mixed flat output are the system's prescribed inputs.

    Parameters
    ----------
    problem : FlatProblem
        Aircraft, environment, flat outputs ``x, y, z`` [m] and ``zeta``, the prescribed ``eta(t)``
        or fixed rudder ``dn(t)`` [rad], the neglected terms' values ``h`` of iterate 0 (rates
        [rad/s], surfaces [rad]) and the stage-2 starting values ``start``.

    Returns
    -------
    ChainedSystem
        Flat outputs ``x, y, z`` (stage 1) and ``zeta`` (stage 3); prescribed inputs ``eta`` or
        ``dn`` (and ``f1, f2`` for a mixed output); default flat-output functions and iterate-0
        neglected values from ``problem``; Newton tolerance 1e-12; the explicit model for tracking
        (:func:`planners.tracking.aircraft_model`).
    """
    cache = problem.__dict__.get("_system")
    if cache is not None:
        return cache
    ac, env = problem.aircraft, problem.env
    m, g = ac.mass.mass, env.g
    kind = problem.zeta.kind
    rudder_control = problem.eta is not None
    inputs = {"eta": problem.eta} if rudder_control else {"dn": problem.dn}
    if kind == "mix":
        inputs.update(f1=problem.zeta.f1, f2=problem.zeta.f2)
    controls4 = ("dl", "dm", "dn") if rudder_control else ("dl", "dm", "eta")

    def state(v, rates=True):
        pqr = (v["p"], v["q"], v["r"]) if rates else (0.0, 0.0, 0.0)
        return State(
            0.0,
            0.0,
            v["z"],
            v["V"],
            v["gamma"],
            v["chi"],
            v.get("alpha", 0.0),
            v.get("beta", 0.0),
            v.get("mu", 0.0),
            *pqr,
        )

    def residual1(v):
        xd, yd, zd = kinematics(state(v, rates=False))
        return [v["x'"] - xd, v["y'"] - yd, v["z'"] - zd]

    def check1(v, t_nodes):
        names = ("x", "y", "z", "zeta", "f1", "f2", "eta", "dn")
        _check_inputs(t_nodes, {n: v.get(n) for n in names})

    def solve1(v, t_nodes):
        check1(v, t_nodes)
        return list(stage1(v["x"], v["y"], v["z"]))

    def solve1_series(v):
        return list(_stage1_series(v["x"], v["y"], v["z"]))

    def post1(u):
        V, gamma, chi = u
        return [V, gamma, _unwrap_constant(chi)]  # chi continuous along the nodes (as stage1 gives it)

    def residual2(v):
        h = HValues(*(v[n] for n in H_NAMES))
        eta = v["eta"] if rudder_control else 0.0
        r1, r2, r3 = force_residuals(
            ac, env, v["z"], v["V"], v["gamma"], v["chi"], v["V'"], v["gamma'"], v["chi'"], eta, h,
            v["alpha"], v["beta"], v["mu"], v["F"],
        )  # fmt: skip
        if kind == "beta":
            r4 = v["beta"] - v["zeta"]
        elif kind == "mu":
            r4 = v["mu"] - v["zeta"]
        elif kind == "F":
            r4 = (v["F"] - v["zeta"]) / (m * g)
        else:
            r4 = v["f1"] * v["beta"] + v["f2"] * v["mu"] - v["zeta"]
        return [r1, r2, r3, r4]

    def start2(v, t_nodes):
        d = {"z": v["z"], "V": v["V"], "gamma": v["gamma"], "Vd": v["V'"], "gd": v["gamma'"], "chid": v["chi'"]}
        d.update(zv=v["zeta"], f1=v.get("f1"), f2=v.get("f2"))
        return [np.real(s.constant_term) for s in _stage2_guess(problem, t_nodes, d, [v[n] for n in H_NAMES])]

    def post2(u):
        alpha, beta, mu, F = u
        return [alpha, beta, _unwrap_constant(mu), F]  # neighbouring nodes on the same bank branch

    def residual3(v):
        s = state(v)
        # the wind-axis forces Y, Z for which the force equations give gamma', chi' (linear in Y, Z)
        _, gy, cy = force_equations(ac, s, 0.0, 1.0, 0.0)
        _, gz, cz = force_equations(ac, s, 0.0, 0.0, 1.0)
        det = gy * cz - gz * cy
        Y = (v["gamma'"] * cz - gz * v["chi'"]) / det
        Z = (gy * v["chi'"] - cy * v["gamma'"]) / det
        ad, bd, mud = wind_angle_rates(ac, s, Y, Z, v["chi'"])
        return [v["alpha'"] - ad, v["beta'"] - bd, v["mu'"] - mud]

    def solve3(v, t_nodes):
        return list(_stage3(v["alpha"], v["beta"], v["mu"], {n: v[n] for n in _PATH_TERMS}))

    def solve3_series(v):
        return list(_stage3_series(v["alpha"], v["beta"], v["mu"], *(v[n] for n in _PATH_TERMS)))

    def residual4(v):
        st = state(v)
        ctl = Controls(v["F"], v["eta"], v["dl"], v["dm"], v["dn"])
        full = ground_effect_coefficients(ac, env, st.z, aero_coefficients(ac, st, ctl))
        L, M, N = body_moments(ac, st, ctl, full, v["qbar"])
        a_p, a_q, a_r = rotational_dynamics(ac, st.p, st.q, st.r, L, M, N)
        return [a_p - v["p'"], a_q - v["q'"], a_r - v["r'"]]

    def derived(v, order):
        # the flight-path terms of stage 3 and the dynamic pressure of stage 4: flight path only
        z4, V4 = v["z"].truncate(order - 4), v["V"].truncate(order - 4)
        return {
            **_path_terms(v["gamma"].truncate(order - 2), v["chi"].truncate(order - 2)),
            "qbar": _dynamic_pressure(env, z4, V4),
        }

    def derived_series(order):
        def fun(v):
            path = _path_terms(v["gamma"], v["chi"])
            return [path[n] for n in _PATH_TERMS] + [_dynamic_pressure(env, v["z"], v["V"])]

        return fun, {**dict.fromkeys(_PATH_TERMS, order - 3), "qbar": order - 4}

    system = ChainedSystem(
        name="aircraft",
        flat_outputs={"x": 1, "y": 1, "z": 1, "zeta": 3},
        stages=(
            Stage(STAGE_UNKNOWNS[0], residual1, solve=solve1, solve_series=solve1_series, check=check1, post=post1),
            Stage(STAGE_UNKNOWNS[1], residual2, neglected=H_NAMES, ell=3, start=start2, post=post2),
            Stage(STAGE_UNKNOWNS[2], residual3, solve=solve3, solve_series=solve3_series),
            Stage(controls4, residual4, warm=True),
        ),
        description=f"{ac.id}: wind-frame model, flat outputs x, y, z and {kind}"
        + ("" if rudder_control else ", rudder fixed (eta the fourth control)"),
        inputs=inputs,
        outputs={"x": problem.x, "y": problem.y, "z": problem.z, "zeta": problem.zeta.value},
        neglected_values=dict(zip(H_NAMES, problem.h)),
        newton_tol=1e-12,
        derived=derived,
        derived_series=derived_series,
    )
    problem.__dict__["_system"] = system  # one system per problem: iterates reuse each other's series
    return system


def plan_iterate(sol: NodeSolution) -> NodeSolution:
    """An iterate of :func:`aircraft_system` as a plan's: the 12 states and 5 controls only, the
    prescribed input (``eta`` or ``dn``) at the order of the surfaces.

    Parameters
    ----------
    sol : NodeSolution
        :func:`planners.chained.flat_parametrization` of the aircraft system.

    Returns
    -------
    NodeSolution
        Same order, reports and reusable series; series of :data:`planners.plan.PLAN_VARIABLES`.
    """
    k = sol["dl"].order
    out = {n: sol[n] for n in _PLAN_NAMES}
    for n in ("eta", "dn"):
        if out[n].order > k:
            out[n] = out[n].truncate(k)
    return NodeSolution(out, sol.order, sol.reports, sol._inputs)


_PLAN_NAMES = ("x", "y", "z", "V", "gamma", "chi", "alpha", "beta", "mu", "F", "p", "q", "r", "dl", "dm", "dn", "eta")


def parametrize(
    problem: FlatProblem,
    t_nodes: np.ndarray,
    order: int,
    h: HValues | None = None,
    guess: Mapping[str, Series] | NodeSolution | None = None,
    newton_tol: float = 1e-12,
) -> NodeSolution:
    """Flat parametrization of the aircraft at all nodes, flat outputs at ``order`` (kappa).

    :func:`planners.chained.flat_parametrization` of :func:`aircraft_system`.

    Parameters
    ----------
    problem : FlatProblem
    t_nodes : array (nodes,)
    order : int
        Order of x, y, z; the controls come out at ``order - 4``.
    h : HValues, optional
        Values (constants or series) of the neglected terms; default ``problem.h``.
    guess : mapping or NodeSolution, optional
        Previous solution (series) used as the starting point of the Newton iterations; a
        :class:`NodeSolution` of the same problem and grid at an order at least ``order`` (the
        previous generalized-flatness iterate) also lends its flat outputs and stage 1, truncated,
        and its Jacobians.
    newton_tol : float
        Tolerance of the pointwise Newton on the constant terms (stage 2: over g; stage 4: rad/s^2).

    Returns
    -------
    NodeSolution
        Series of every state and control at every node, with the Newton reports of stages 2 and 4.

    Raises
    ------
    InputError
        ``order`` below 4.
    DomainError
        Non-finite flat outputs or inputs, or a vertical or zero velocity (stage 1 singular).
    """
    if order < 4:
        raise InputError(f"the flat parametrization needs order >= 4 to reach the controls, got {order}")
    hat = None if h is None else dict(zip(H_NAMES, h))
    sol = flat_parametrization(aircraft_system(problem), t_nodes, order, hat=hat, guess=guess, newton_tol=newton_tol)
    return plan_iterate(sol)


def _dynamic_pressure(env: Environment, z, V):
    """``qbar = rho(z) V^2 / 2`` [Pa] of stage 4 (depends on the flight path only: computed once per plan)."""
    return 0.5 * env.density(z) * V * V


def _real(v) -> np.ndarray:
    """The real part of a number or array as floats (a real float array as it is)."""
    a = np.asarray(v)
    if a.dtype == np.float64:
        return a
    return np.real(np.asarray(a, dtype=complex))


def _stage2_guess(problem: FlatProblem, t_nodes, d: dict, hv) -> list:
    """Node-wise starting values for stage 2, from the kinematics of the flat outputs.

    The specific force the airframe must produce follows from the flat outputs:
    in the path frame (x along the velocity, y horizontal, wind frame with
    mu = 0) it is ``f = (V' + g sin gamma, V cos gamma chi', -V gamma' - g cos gamma)``.
    Lift supplies its normal part: the bank angle is ``atan2(f_y, -f_z)`` and the
    lift coefficient ``m |f_n| / (qbar S)``, from which alpha is read on the
    rising branch of the model's C_L(alpha) within the envelope; the thrust
    balances drag and ``f_x``.  Starting each node there picks the physical
    root (a polynomial C_L has other, spurious ones).  For the thrust output the
    sideslip sign is taken from ``problem.start`` (a calibration) when given.
    """
    ac, env = problem.aircraft, problem.env
    m, g, S = ac.mass.mass, env.g, ac.geometry.S
    V, gam, Vd, gd, chid = (_real(d[k]) for k in ("V", "gamma", "Vd", "gd", "chid"))
    rho = np.real(env.density(_real(d["z"])))
    qS = 0.5 * rho * V * V * S
    fx = Vd + g * np.sin(gam)
    fy = V * np.cos(gam) * chid
    fz = -V * gd - g * np.cos(gam)
    kind = problem.zeta.kind
    zv = _real(d["zv"]) + 0 * V
    start = dict(problem.start or {})
    if kind == "mu":
        mu = zv
    elif kind == "F" and "mu" in start:
        mu = np.full_like(V, start["mu"])
    else:
        mu = np.unwrap(np.arctan2(fy, -fz))
    lift = m * (fy * np.sin(mu) - fz * np.cos(mu))
    CL_req = lift / qS
    # C_L(alpha) of the stage-2 model (H at its mean values) on the envelope.
    hconst = [float(np.mean(np.real(getattr(v, "constant_term", v)))) for v in hv]
    env_ = ac.envelope
    a_grid = np.linspace(env_.alpha_min, env_.alpha_max, 401)
    b0 = float(np.mean(zv)) if kind == "beta" else float(start.get("beta", 0.0))
    c = ac.aero.coefficients(aero_state(ac, float(np.mean(V)), a_grid, b0, *hconst))
    CL = np.broadcast_to(np.asarray(c.CL, dtype=float), a_grid.shape)
    CD = np.broadcast_to(np.asarray(c.CD, dtype=float), a_grid.shape)
    top = int(np.argmax(CL))
    rising_a, rising_CL = a_grid[: top + 1], CL[: top + 1]
    order = np.argsort(rising_CL)
    alpha = np.interp(CL_req, rising_CL[order], rising_a[order])
    F = m * fx + qS * np.interp(alpha, a_grid, CD)
    if kind == "beta":
        beta = zv
    elif kind == "mix":
        f1 = _real(d["f1"]) + 0 * V
        f2 = _real(d["f2"]) + 0 * V
        beta = (zv - f2 * mu) / np.where(f1 != 0, f1, 1.0) * (f1 != 0)
    else:
        # thrust output: beta = 0 is singular (eq. cond_F); without a calibration start on the beta > 0 branch
        beta = np.full_like(V, start.get("beta", 0.1))
    if kind == "F":
        F = zv
        if "alpha" in start:
            alpha = np.full_like(V, start["alpha"])
    out = {"alpha": alpha, "beta": beta, "mu": mu, "F": F}
    return [Series.constant(out[k], 0) for k in STAGE2_UNKNOWNS]
