"""Flat parametrization of the aircraft at the nodes of a time grid.

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

Every stage works on truncated power series batched over all nodes at once.
Stage 2 uses the force coefficients with the neglected rate and surface
terms H evaluated at given values (zero, calibration constants, or the
previous iterate of generalized flatness), i.e. ``gna.eom`` with
``model="simple"``; stages 3--4 use the full moments.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from gna.aircraft import Aircraft
from gna.atmosphere import Environment
from gna.eom import (
    Controls,
    HValues,
    State,
    aero_coefficients,
    aero_state,
    body_moments,
    force_equations,
    rotational_dynamics,
    wind_forces,
)
from gna.errors import DomainError, InputError
from gna.ground_effect import ground_effect_coefficients

from . import series as _series
from .expressions import Expression
from .newton import newton_series
from .series import Series

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


def check_grid(t_nodes) -> np.ndarray:
    """The planning grid as a float array: at least two increasing nodes.

    Parameters
    ----------
    t_nodes : array_like, shape (N,)
        Node times [s].

    Returns
    -------
    ndarray, shape (N,)

    Raises
    ------
    InputError
        Not a 1-D sequence of at least two increasing times.
    """
    t = np.asarray(t_nodes, dtype=float)
    if t.ndim != 1 or len(t) < 2 or np.any(np.diff(t) <= 0):
        raise InputError("the planning grid needs at least two increasing nodes")
    return t


STAGE2_UNKNOWNS = ("alpha", "beta", "mu", "F")

#: Order lost at each stage relative to the flat outputs x, y, z.
STAGE_OF = {
    "x": 0,
    "y": 0,
    "z": 0,
    "V": 1,
    "gamma": 1,
    "chi": 1,
    "alpha": 2,
    "beta": 2,
    "mu": 2,
    "F": 2,
    "p": 3,
    "q": 3,
    "r": 3,
    "dl": 4,
    "dm": 4,
    "dn": 4,
    "eta": 4,
}


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


@dataclass
class NodeSolution:
    """Series of every state and control at every node, for one iterate.

    Attributes
    ----------
    series : dict of str -> Series
        Batch shape (nodes,); the order of each depends on its stage.
    order : int
        Order kappa of the flat outputs for this iterate.
    reports : dict of str -> SeriesNewtonReport
        Newton diagnostics of stages 2 and 4.
    """

    series: dict
    order: int
    reports: dict = field(default_factory=dict)
    # The series that depend only on the problem, the grid and the order (flat outputs, prescribed inputs,
    # stage 1), at the highest order computed so far: a later iterate (lower order) truncates them.
    _inputs: dict | None = field(default=None, repr=False, compare=False)

    def __getstate__(self) -> dict:
        state = dict(self.__dict__)
        state["_inputs"] = None
        return state

    def __getitem__(self, name: str) -> Series:
        return self.series[name]

    def h_values(self) -> HValues:
        """The rates and surfaces of this iterate, as H values for the next one.

        Returns
        -------
        HValues
            Series of ``p, q, r`` [rad/s] and ``dl, dm, dn`` [rad].
        """
        s = self.series
        return HValues(s["p"], s["q"], s["r"], s["dl"], s["dm"], s["dn"])


class _OrderCache:
    """Given series truncated to each working order; order 0 gives plain constant arrays.

    Newton on series evaluates its residual at increasing orders; the
    constant-term iterations run on plain numpy arrays, much faster than
    order-0 series.
    """

    def __init__(self, data: dict):
        self._data = data
        self._cache: dict[int, dict] = {}

    def __getitem__(self, k: int) -> dict:
        if k not in self._cache:
            out = {}
            for name, v in self._data.items():
                if isinstance(v, Series):
                    out[name] = np.asarray(v.constant_term) if k == 0 else v.truncate(min(k, v.order))
                else:
                    out[name] = v
            self._cache[k] = out
        return self._cache[k]


def _unwrap_constant(angle: Series) -> Series:
    """Make the constant terms of an angle continuous along the node axis."""
    c0 = np.real(angle.constant_term)
    if np.all(np.abs(np.diff(c0)) < np.pi):  # np.unwrap's rule: no jump of pi or more, nothing to shift
        return angle
    shift = np.unwrap(c0) - c0
    if np.any(shift != 0):
        return angle + shift
    return angle


def _check_inputs(t_nodes, series: Mapping[str, Series | None]) -> None:
    """Refuse non-finite flat outputs and prescribed inputs, and flat outputs that make stage 1
    singular (V cos(gamma) = 0), naming the time and the value."""
    t_nodes = np.asarray(t_nodes, dtype=float)
    for name, s in series.items():
        if s is None:
            continue
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
    xd, yd, zd = x.derivative(), y.derivative(), z.derivative()
    vh2 = xd * xd + yd * yd
    vh = np.sqrt(vh2)
    V = np.sqrt(vh2 + zd * zd)
    gamma = np.arctan2(-zd, vh)
    chi = _unwrap_constant(np.arctan2(yd, xd))
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


def parametrize(
    problem: FlatProblem,
    t_nodes: np.ndarray,
    order: int,
    h: HValues | None = None,
    guess: Mapping[str, Series] | NodeSolution | None = None,
    newton_tol: float = 1e-12,
) -> NodeSolution:
    """Flat parametrization at all nodes, flat outputs at ``order`` (kappa).

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
        previous generalized-flatness iterate) also lends its flat outputs and stage 1, truncated.
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
    ac, env = problem.aircraft, problem.env
    m, g = ac.mass.mass, env.g
    hv = h if h is not None else problem.h
    k2 = order - 2
    zeta = problem.zeta
    inputs = _flat_inputs(problem, t_nodes, order, guess)
    x, y, z, zv, f1, f2, eta_pres, dn_fixed, V, gamma, chi, Vd, gd, chid = (
        None if inputs[k] is None else inputs[k].truncate(min(inputs[k].order, order - _INPUT_NAMES[k]))
        for k in _INPUT_NAMES
    )
    z2, V2, gamma2, chi2 = z.truncate(k2), V.truncate(k2), gamma.truncate(k2), chi.truncate(k2)
    eta2 = eta_pres.truncate(k2) if eta_pres is not None else 0.0

    d2 = _OrderCache(
        dict(
            z=z2,
            V=V2,
            gamma=gamma2,
            chi=chi2,
            Vd=Vd,
            gd=gd,
            chid=chid,
            eta=eta2,
            zv=zv,
            f1=f1,
            f2=f2,
            hp=hv.p,
            hq=hv.q,
            hr=hv.r,
            hdl=hv.dl,
            hdm=hv.dm,
            hdn=hv.dn,
        )
    )

    def stage2_residual(u, k):
        alpha, beta, mu, F = u
        d = d2[k]
        h_k = HValues(d["hp"], d["hq"], d["hr"], d["hdl"], d["hdm"], d["hdn"])
        r1, r2, r3 = force_residuals(
            ac,
            env,
            d["z"],
            d["V"],
            d["gamma"],
            d["chi"],
            d["Vd"],
            d["gd"],
            d["chid"],
            d["eta"],
            h_k,
            alpha,
            beta,
            mu,
            F,
        )
        if zeta.kind == "beta":
            r4 = beta - d["zv"]
        elif zeta.kind == "mu":
            r4 = mu - d["zv"]
        elif zeta.kind == "F":
            r4 = (F - d["zv"]) / (m * g)
        else:
            r4 = d["f1"] * beta + d["f2"] * mu - d["zv"]
        return [r1, r2, r3, r4]

    if guess is not None:
        u0 = [guess[k] for k in STAGE2_UNKNOWNS]
    else:
        u0 = _stage2_guess(problem, t_nodes, d2[0], hv)
    u2, rep2 = newton_series(
        stage2_residual,
        u0,
        k2,
        tol=newton_tol,
        names=STAGE2_UNKNOWNS,
        t_nodes=t_nodes,
        warm=guess is not None,
        jacobian=_previous_jacobian(guess, "stage2"),
    )
    alpha, beta, mu, F = u2
    mu = _unwrap_constant(mu)  # bank angles of neighbouring nodes on the same branch (no 2 pi jumps)

    # Stage 3: rates.
    p, q, r = _stage3(alpha, beta, mu, inputs["path"])
    k4 = order - 4
    pd, qd, rd = p.derivative(), q.derivative(), r.derivative()
    s4 = State(
        0.0,
        0.0,
        z.truncate(k4),
        V.truncate(k4),
        gamma.truncate(k4),
        chi.truncate(k4),
        alpha.truncate(k4),
        beta.truncate(k4),
        mu.truncate(k4),
        p.truncate(k4),
        q.truncate(k4),
        r.truncate(k4),
    )
    F4 = F.truncate(k4)
    qbar4 = inputs["qbar4"].truncate(k4)

    d4 = _OrderCache(
        dict(
            z=s4.z,
            V=s4.V,
            gamma=s4.gamma,
            chi=s4.chi,
            alpha=s4.alpha,
            beta=s4.beta,
            mu=s4.mu,
            p=s4.p,
            q=s4.q,
            r=s4.r,
            pd=pd,
            qd=qd,
            rd=rd,
            F=F4,
            qbar=qbar4,
            eta=eta_pres.truncate(k4) if problem.eta is not None else None,
            dn=dn_fixed.truncate(k4) if problem.dn is not None else None,
        )
    )
    names4 = ("dl", "dm", "dn") if problem.eta is not None else ("dl", "dm", "eta")

    def controls_of(u, d):
        if problem.eta is not None:
            return Controls(d["F"], d["eta"], u[0], u[1], u[2])
        return Controls(d["F"], u[2], u[0], u[1], d["dn"])

    def stage4_residual(u, k):
        d = d4[k]
        st = State(
            0.0, 0.0, d["z"], d["V"], d["gamma"], d["chi"], d["alpha"], d["beta"], d["mu"], d["p"], d["q"], d["r"]
        )
        ctl = controls_of(u, d)
        full = ground_effect_coefficients(ac, env, st.z, aero_coefficients(ac, st, ctl))
        L, M, N = body_moments(ac, st, ctl, full, d["qbar"])
        a_p, a_q, a_r = rotational_dynamics(ac, st.p, st.q, st.r, L, M, N)
        return [a_p - d["pd"], a_q - d["qd"], a_r - d["rd"]]

    if guess is not None:
        v0 = [guess[n] for n in names4]
    else:
        v0 = [Series.constant(np.zeros(len(t_nodes)), 0) for _ in names4]
    # Newton at the working order from the start, even from zero deflections: the moments are affine in
    # the controls in the bundled models (one step solves them; the full scheme takes over otherwise).
    u4, rep4 = newton_series(
        stage4_residual,
        v0,
        k4,
        tol=newton_tol,
        names=names4,
        t_nodes=t_nodes,
        warm=True,
        jacobian=_previous_jacobian(guess, "stage4"),
    )
    ctl = controls_of(u4, d4[k4])
    out = {
        "x": x,
        "y": y,
        "z": z,
        "V": V,
        "gamma": gamma,
        "chi": chi,
        "alpha": alpha,
        "beta": beta,
        "mu": mu,
        "F": F,
        "p": p,
        "q": q,
        "r": r,
        "dl": ctl.dl,
        "dm": ctl.dm,
        "dn": ctl.dn,
        "eta": ctl.eta,
    }
    for k, v in out.items():
        if not isinstance(v, Series):
            out[k] = Series.constant(np.broadcast_to(np.asarray(v, dtype=float), (len(t_nodes),)), k4)
    return NodeSolution(out, order, {"stage2": rep2, "stage4": rep4}, inputs)


def _previous_jacobian(guess, stage: str):
    """The Jacobian series of a stage's last Newton step in ``guess`` (a NodeSolution: the previous
    generalized-flatness iterate), for the chord steps of the same stage; None for other guesses."""
    rep = guess.reports.get(stage) if isinstance(guess, NodeSolution) else None
    return getattr(rep, "jacobian", None)


#: The series :func:`_flat_inputs` gives, with the orders they lose relative to the flat outputs.
_INPUT_NAMES = {
    "x": 0,
    "y": 0,
    "z": 0,
    "zv": 2,
    "f1": 2,
    "f2": 2,
    "eta": 0,
    "dn": 0,
    "V": 1,
    "gamma": 1,
    "chi": 1,
    "Vd": 2,
    "gd": 2,
    "chid": 2,
}


def _flat_inputs(problem: FlatProblem, t_nodes: np.ndarray, order: int, guess) -> dict:
    """Flat outputs (order ``order``), zeta and its weights (``order - 2``), prescribed eta or dn (``order``)
    and stage 1 with its derivatives, checked; truncated from ``guess`` (a NodeSolution of the same
    problem and grid at an order at least ``order``) when it has them: truncating a series of a
    higher order gives the same coefficients as computing at the lower one."""
    cached = getattr(guess, "_inputs", None) if isinstance(guess, NodeSolution) else None
    if (
        cached is not None
        and cached["problem"] is problem
        and cached["order"] >= order
        and np.array_equal(cached["t_nodes"], t_nodes)
    ):
        return cached
    t = Series.variable(np.asarray(t_nodes, dtype=float), order)
    x, y, z = problem.x(t), problem.y(t), problem.z(t)
    k2 = order - 2
    zeta = problem.zeta
    zv = zeta.value(Series.variable(t_nodes, k2))
    f1 = zeta.f1(Series.variable(t_nodes, k2)) if zeta.kind == "mix" else None
    f2 = zeta.f2(Series.variable(t_nodes, k2)) if zeta.kind == "mix" else None
    eta_pres = problem.eta(Series.variable(t_nodes, order)) if problem.eta is not None else None
    dn_fixed = problem.dn(Series.variable(t_nodes, order)) if problem.dn is not None else None
    _check_inputs(t_nodes, {"x": x, "y": y, "z": z, "zeta": zv, "f1": f1, "f2": f2, "eta": eta_pres, "dn": dn_fixed})
    V, gamma, chi = stage1(x, y, z)
    Vd, gd, chid = V.derivative(), gamma.derivative(), chi.derivative()
    values = (x, y, z, zv, f1, f2, eta_pres, dn_fixed, V, gamma, chi, Vd, gd, chid)
    return {
        **dict(zip(_INPUT_NAMES, values)),
        "problem": problem,
        "t_nodes": np.array(t_nodes, dtype=float),
        "order": order,
        "path": _path_terms(gamma.truncate(order - 2), chi.truncate(order - 2)),
        "qbar4": _dynamic_pressure(problem.env, z.truncate(order - 4), V.truncate(order - 4)),
    }


def _dynamic_pressure(env: Environment, z, V):
    """``qbar = rho(z) V^2 / 2`` [Pa] of stage 4 (depends on the flight path only: computed once per plan)."""
    rho = env.density(z)
    return 0.5 * rho * V * V


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
    V, gam, Vd, gd, chid = (np.real(np.asarray(d[k], dtype=complex)) for k in ("V", "gamma", "Vd", "gd", "chid"))
    rho = np.real(env.density(np.real(np.asarray(d["z"], dtype=complex))))
    qS = 0.5 * rho * V * V * S
    fx = Vd + g * np.sin(gam)
    fy = V * np.cos(gam) * chid
    fz = -V * gd - g * np.cos(gam)
    kind = problem.zeta.kind
    zv = np.real(np.asarray(d["zv"], dtype=complex)) + 0 * V
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
        f1 = np.real(np.asarray(d["f1"], dtype=complex)) + 0 * V
        f2 = np.real(np.asarray(d["f2"], dtype=complex)) + 0 * V
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
