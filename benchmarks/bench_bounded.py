"""One point-to-point problem within the aircraft's limits by three methods, side by side (issue 26).

The problem is the bundled ``f16c-climb-turn`` (docs/bounded.md): the F-16C from a level trim at 150 m/s and
3000 m heading north to a level trim at 150 m/s and 4000 m heading east in 60 s, coordinated (beta = 0), every
limit of :func:`gna.limits.aircraft_limits` met (surfaces, thrust >= 0, the alpha/beta box, the load factor
+9/-3 g), least control effort: the ``control_rate`` cost of :mod:`planners.bounded`, the mean over the span of
``sum_c (du_c/dt / s_c)^2`` with ``s_c`` of :func:`planners.bounded.control_scales` (F, dl, dm, dn; eta = 0).

* **gflat**: :func:`planners.bounded.plan_bounded` at the scenario's settings: x, y, z Bezier curves of degree
  13 meeting both trims to the 5th derivative, their two interior control points each free (6 parameters),
  the generalized-flat plan of the full model (J = 6) inside SLSQP, the limits on the flyability verdict's
  grid (0.01 s).
* **python-control** (``control.flatsys.point_to_point``) on the flat (J = 0) model: the same basis
  (:class:`control.flatsys.BezierFamily` of 14 coefficients per flat output), the same end conditions (the
  trims' flags to the 5th derivative, from :func:`planners.splines.steady_derivatives`), so the same family of
  paths; the flat system is the aircraft with the controls as states and their rates as inputs (a dynamic
  extension: the cost is then a function of the inputs, as ``point_to_point`` needs), its reverse map gflat's
  flat parametrization of the simple model at one point (:func:`planners.flat.parametrize`, the J = 0
  iterate: H = 0, the scenario's); the fourth flat output beta has its own two free coefficients, held within
  1e-6 rad of 0 at every timept; the limits are the same records evaluated on the reverse map's states and
  controls at the ``timepts`` (every ``--pc-step`` s), the cost python-control's rectangle rule over them;
  SLSQP, gradients by scipy's finite differences (python-control passes none).
* **collocation** (CasADi + IPOPT) on the full model: the NLP of :class:`bench_collocation.CollocationProblem`
  (Radau IIA of degree 3, the project's equations on CasADi symbols, imported from that benchmark) with the
  path free instead of given: the 12 states and the controls at both ends the trims', the controls' rates there
  zero (as the order-5 end conditions give gflat), beta = 0 at every point, every limit at every collocation
  point, the cost by Radau quadrature; intervals of ``--col-step`` s; initial guess ``trim``
  (:func:`bench_collocation.trim_guess` on the nominal path: positions and kinematics from it, the rest at the
  start trim).

Every method's result is then judged the same way: its controls (F, eta, dl, dm, dn) flown open loop on the
full model (:func:`bench_collocation.fly_by_pieces`: DOP853, rtol = atol = 1e-10, restarted at every break)
from its own initial state, the largest distance to its own planned path (x, y, z) on a 0.05 s grid; the
``control_rate`` cost of its controls on a 0.1 s grid (trapezoidal rule, :func:`planners.bounded.control_rate_cost`,
the same for all); the limits (:func:`gna.limits.limit_violations`) of its states and controls on that grid.
python-control's controls between the grid points (0.1 s): cubic Hermite pieces of the reverse map's values
and rates.
Times: CPU (``time.process_time``) and wall (``time.perf_counter``) of the solve, medians of ``--repeat``
interleaved repeats, BLAS threads pinned to 1; the machine's load average before and after.

Usage::

    python benchmarks/bench_bounded.py [--repeat N] [--methods gflat,python-control,collocation] [--quick]
                                       [--json PATH]

``--quick``: the smallest setting (a coarse grid for every method, a few iterations each: the table's shape,
not its figures), what the test runs.
"""

from __future__ import annotations

import os
import sys

if __package__ in (None, ""):  # run as a script: the repository's packages, not an installed copy
    sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))  # bench_collocation, imported below

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import dataclasses  # noqa: E402
import gc  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import statistics  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402

import bench_collocation as bc  # noqa: E402
import numpy as np  # noqa: E402

from gna import eom  # noqa: E402
from gna.errors import GflatError  # noqa: E402
from gna.limits import TrajectoryColumns, aircraft_limits, body_load_factors, limit_violations  # noqa: E402
from gna.piecewise import PiecewisePolynomial  # noqa: E402
from planners.bounded import control_rate_cost, control_scales, plan_bounded  # noqa: E402
from planners.expressions import Expression  # noqa: E402
from planners.flat import FlatOutput, parametrize  # noqa: E402
from planners.scenario import load_scenario  # noqa: E402

SCENARIO = "f16c-climb-turn"
METHODS = ("gflat", "python-control", "collocation")
#: Grids of the judging: the open-loop flight's output [s] and the cost's and limits' [s].
FLY_STEP, COST_STEP = 0.05, 0.1
#: The four inputs of the flat system (eta = 0 is prescribed).
INPUTS = ("F", "dl", "dm", "dn")
#: Flag length of every flat output: derivatives 0..5 (the scenario's [boundary] order 5).
FLAG = 6
#: python-control: the fourth flat output beta held within this of 0 at every timept [rad].
BETA_TOL = 1e-6
#: ``--quick``: the scenario's node step [s], and python-control's result tabulated every this [s] (the
#: open-loop flight restarts at every piece).
QUICK_STEP, QUICK_TABLE_STEP = 5.0, 1.0
#: python-control: the cost and the constraints' values at a point where the reverse map fails.
FAILED_COST, FAILED_VALUE = 1e6, 1e9


@dataclasses.dataclass
class Outcome:
    """One method's solution: its controls, planned path and initial state, and what its solver said."""

    method: str
    controls: PiecewisePolynomial  # t -> (F, eta, dl, dm, dn)
    path: object  # t -> (x, y, z) (3, N)
    states: object  # t -> 12 states (12, N)
    x0: np.ndarray
    success: bool
    message: str
    evaluations: str = ""


# --- timing ---------------------------------------------------------------------------------------------------


def _clock():
    gc.collect()
    return time.process_time(), time.perf_counter()


def _since(start):
    return time.process_time() - start[0], time.perf_counter() - start[1]


# --- gflat ----------------------------------------------------------------------------------------------------


def solve_gflat(sc, quick: bool) -> Outcome:
    """:func:`planners.bounded.plan_bounded` of the scenario (``quick``: 2 iterations)."""
    if quick:
        sc = dataclasses.replace(sc, bounded=dataclasses.replace(sc.bounded, maxiter=2))
    r = plan_bounded(sc)
    plan = r.plan
    if plan is None:
        raise GflatError(f"gflat: no plan ({r.message})")
    return Outcome(
        "gflat",
        plan.control_function(),
        lambda t: np.stack([plan.evaluate(n, t) for n in ("x", "y", "z")]),
        lambda t: plan.state(t),
        plan.initial_state(),
        bool(r.feasible and r.success),
        f"{'within every limit' if r.feasible else 'INFEASIBLE'}; SLSQP: {r.message}",
        f"{r.plans_evaluated} plans, {r.iterations} iterations",
    )


# --- python-control -------------------------------------------------------------------------------------------


class FlatAircraft:
    """The aircraft's flat (J = 0) model as a :class:`control.flatsys.FlatSystem`: states the 12 of the model
    and the four controls, inputs the controls' rates, flat outputs x, y, z, beta (flag length :data:`FLAG`).

    ``reverse(zflag)``: the Taylor polynomials of the flags at one point, flat-parametrized by gflat
    (:func:`planners.flat.parametrize` at one node, flat outputs at order 5, controls at order 1: values and
    rates; the scenario's H values, the J = 0 iterate); the last :data:`CACHE` results kept (python-control
    asks for the same points for the cost and again for the constraints).  ``forward(x, u)``: the flags of a
    steady straight flight (the problem's trims: :func:`planners.splines.steady_derivatives`, beta's zero).
    """

    CACHE = 4096

    def __init__(self, scenario):
        import control.flatsys as fs

        self.sc = scenario
        base = scenario.problem()
        self._c = np.zeros((4, FLAG))
        outs = [self._taylor(i) for i in range(4)]
        self.problem = dataclasses.replace(base, x=outs[0], y=outs[1], z=outs[2], zeta=FlatOutput("beta", outs[3]))
        self.cache: dict = {}
        self.calls = 0
        self.sys = fs.FlatSystem(
            self.forward, self.reverse, inputs=[f"{n}_dot" for n in INPUTS], states=list(eom.STATE_NAMES) + list(INPUTS)
        )

    def _taylor(self, i: int) -> Expression:
        def fn(t):
            c = self._c[i]
            acc = c[-1] + 0.0 * t
            for a in c[-2::-1]:
                acc = acc * t + a
            return acc

        return Expression(f"taylor[{i}]", fn, True)

    def forward(self, x, u, params=None):
        from planners.splines import steady_derivatives

        x = np.asarray(x, dtype=float)
        d = steady_derivatives(x[3], x[4], x[5], 0.0, x[:3], FLAG - 1)
        return [np.array(d["x"]), np.array(d["y"]), np.array(d["z"]), np.zeros(FLAG)]

    def reverse(self, zflag, params=None):
        z = np.asarray(zflag, dtype=float).reshape(4, -1)
        key = z.tobytes()
        hit = self.cache.get(key)
        if hit is not None:
            return hit
        self.calls += 1
        fact = np.array([math.factorial(k) for k in range(FLAG)])
        self._c[:] = z[:, :FLAG] / fact
        try:
            sol = parametrize(self.problem, np.zeros(1), FLAG - 1)
            st = [float(np.real(sol[n].coeffs[0, 0])) for n in eom.STATE_NAMES]
            ctl = [float(np.real(sol[n].coeffs[0, 0])) for n in INPUTS]
            rates = [float(np.real(sol[n].coeffs[0, 1])) for n in INPUTS]
            out = (np.array(st + ctl), np.array(rates))
        except (GflatError, FloatingPointError, ValueError, ZeroDivisionError):
            out = (np.full(16, np.nan), np.full(4, np.nan))
        if len(self.cache) >= self.CACHE:
            self.cache.clear()
        self.cache[key] = out
        return out

    def columns(self, t, xs, us) -> TrajectoryColumns:
        """States (16, N) of the flat system as the limits' trajectory columns (eta = 0)."""
        xs = np.atleast_2d(np.asarray(xs, dtype=float))
        controls = [xs[12], np.zeros(xs.shape[1]), xs[13], xs[14], xs[15]]
        return TrajectoryColumns(t, list(eom.STATE_NAMES) + list(eom.CONTROL_NAMES), np.vstack([xs[:12], controls]))


def limit_rows(aircraft, env, frame) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every limit's value, lower and upper bound on the frame's rows (the records of :mod:`gna.limits`)."""
    vals, lows, highs = [], [], []
    for lim in aircraft_limits(aircraft):
        v = np.asarray(lim.value_of(frame, env), dtype=float)
        lo, hi = lim.bounds(frame)
        vals.append(v), lows.append(lo), highs.append(hi)
    return np.concatenate(vals), np.concatenate(lows), np.concatenate(highs)


def solve_python_control(sc, quick: bool, pc_step: float) -> Outcome:
    """``control.flatsys.point_to_point`` on :class:`FlatAircraft` (module docstring)."""
    import control.flatsys as fs
    from scipy.optimize import NonlinearConstraint

    fa = FlatAircraft(sc)
    start, end = sc.boundary["start"], sc.boundary["end"]
    scales = control_scales(sc.aircraft, sc.env)[[0, 2, 3, 4]]
    T = sc.t1 - sc.t0
    timepts = np.linspace(sc.t0, sc.t1, int(round(T / pc_step)) + 1)
    ib = eom.STATE_NAMES.index("beta")

    # A point where the reverse map fails (NaN) gets finite values beyond every bound: scipy's SLSQP is not
    # given a NaN (it can crash on one).
    def cost(x, u):
        c = float(np.sum((np.asarray(u) / scales) ** 2)) / T
        return c if math.isfinite(c) else FAILED_COST

    def constraint(x, u):
        if not np.all(np.isfinite(x)):
            return np.full(n_constraints, FAILED_VALUE)
        v, _, _ = limit_rows(sc.aircraft, sc.env, fa.columns([0.0], np.asarray(x)[:, None], None))
        return np.nan_to_num(np.append(v, x[ib]), nan=FAILED_VALUE, posinf=FAILED_VALUE, neginf=-FAILED_VALUE)

    probe = fa.columns([0.0], np.concatenate([start.state(), start.controls()[[0, 2, 3, 4]]])[:, None], None)
    _, lo, hi = limit_rows(sc.aircraft, sc.env, probe)
    # beta = 0 as |beta| <= BETA_TOL: as an equality at every timept it would be more equality constraints than
    # free coefficients, which SLSQP refuses (scipy 1.16's crashes on it).
    lb, ub = np.append(lo, -BETA_TOL), np.append(hi, BETA_TOL)
    n_constraints = lb.size
    x0 = np.concatenate([start.state(), start.controls()[[0, 2, 3, 4]]])
    xf = np.concatenate([end.state(), end.controls()[[0, 2, 3, 4]]])
    basis = fs.BezierFamily(2 * FLAG + 2, T)  # 14 coefficients: two free per flat output, as gflat's
    options = {"maxiter": 2 if quick else 200}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        traj = fs.point_to_point(
            fa.sys,
            timepts - sc.t0,
            x0,
            np.zeros(4),
            xf,
            np.zeros(4),
            cost=cost,
            basis=basis,
            trajectory_constraints=[(NonlinearConstraint, constraint, lb, ub)],
            minimize_method="SLSQP",
            minimize_options=options,
        )
    note = "; ".join(str(w.message).replace("\n", " ") for w in caught if "unable" in str(w.message))
    # The result between the timepts: the flat outputs (Bezier curves of python-control's coefficients, its
    # control points) through the same reverse map, at every point of a fine grid at once (SystemTrajectory.eval
    # asks the basis point by point: minutes for the grid below).
    from planners.splines import bezier_expression

    curves = [bezier_expression(np.asarray(c, dtype=float), sc.t0, sc.t1) for c in traj.coeffs]
    t = np.arange(sc.t0, sc.t1 + 1e-9, QUICK_TABLE_STEP if quick else COST_STEP)
    judged = dataclasses.replace(fa.problem, x=curves[0], y=curves[1], z=curves[2], zeta=FlatOutput("beta", curves[3]))
    sol = parametrize(judged, t, FLAG - 1)
    value = {n: np.real(sol[n].coeffs[:, 0]) for n in list(eom.STATE_NAMES) + list(INPUTS)}
    rate = {n: np.real(sol[n].coeffs[:, 1]) for n in INPUTS}
    zero = np.zeros(t.size)
    vals = np.vstack([value["F"], zero, value["dl"], value["dm"], value["dn"]])
    rates = np.vstack([rate["F"], zero, rate["dl"], rate["dm"], rate["dn"]])
    controls = hermite_pieces(t, vals, rates)
    states = hermite_pieces(t, np.vstack([value[n] for n in eom.STATE_NAMES]), None)
    interior = {f"{o}{k}": float(traj.coeffs[i][k]) for i, o in enumerate(("cx", "cy", "cz")) for k in (6, 7)}
    return Outcome(
        "python-control",
        controls,
        lambda tt: np.stack([np.asarray(c(np.asarray(tt, dtype=float)), dtype=float) for c in curves[:3]]),
        states.evaluate,
        states.evaluate(np.array([sc.t0]))[:, 0].copy(),
        bool(traj.success) and not note,
        str(traj.message)
        + (f" ({note})" if note else "")
        + "; interior control points "
        + ", ".join(f"{k} = {v:.6g}" for k, v in interior.items())
        + f"; beta's largest |coefficient| {float(np.max(np.abs(traj.coeffs[3]))):.2g} rad",
        f"{fa.calls} reverse maps, {len(timepts)} timepts",
    )


def hermite_pieces(t: np.ndarray, values: np.ndarray, rates: np.ndarray | None) -> PiecewisePolynomial:
    """Cubic pieces between the points ``t``: Hermite on values and rates, or a C1 cubic spline without rates."""
    if rates is None:
        from scipy.interpolate import CubicSpline

        cs = CubicSpline(t, values, axis=1)
        coeffs = np.moveaxis(cs.c[::-1], 0, -1)  # (pieces, rows, 4) ascending powers
        return PiecewisePolynomial(t, np.ascontiguousarray(coeffs))
    h = np.diff(t)[:, None]
    y0, y1, d0, d1 = values[:, :-1].T, values[:, 1:].T, rates[:, :-1].T, rates[:, 1:].T
    c0, c1 = y0, d0
    c2 = (3 * (y1 - y0) / h - 2 * d0 - d1) / h
    c3 = (2 * (y0 - y1) / h + d0 + d1) / h**2
    return PiecewisePolynomial(t, np.stack([c0, c1, c2, c3], axis=-1))


# --- collocation ----------------------------------------------------------------------------------------------


def solve_collocation(sc, quick: bool, col_step: float) -> Outcome:
    """Bounded collocation on the full model (module docstring), the NLP built and solved."""
    bc._require_casadi()
    ca = bc.ca
    pb = sc.problem()
    ac, env = pb.aircraft, pb.env
    nominal = sc.at({q.name: q.value for q in sc.free_parameters})
    guess = bc.trim_guess(nominal)
    n = max(1, int(round((sc.t1 - sc.t0) / col_step)))
    breaks = np.linspace(sc.t0, sc.t1, n + 1)
    h = np.diff(breaks)
    d = bc.DEGREE
    tau, D = bc.radau_matrices(d)
    quad_w = bc.radau_weights(tau[1:])
    P = d * n + 1
    t = np.concatenate([[breaks[0]]] + [breaks[k] + tau[1:] * h[k] for k in range(n)])
    gs, gu = guess(t)
    start, end = sc.boundary["start"], sc.boundary["end"]
    sx = np.ones(12)
    sx[eom.STATE_NAMES.index("V")] = 150.0
    sx[:3] = 1000.0
    su = control_scales(ac, env)
    ib = eom.STATE_NAMES.index("beta")
    free_x = [i for i in range(12) if i != ib]
    free_u = [0, 2, 3, 4]
    w = ca.MX.sym("w", (len(free_x) + len(free_u)) * P)
    W = ca.reshape(w, len(free_x) + len(free_u), P)
    rows_x = [ca.DM.zeros(1, P) if i == ib else sx[i] * W[free_x.index(i), :] for i in range(12)]
    eta = np.broadcast_to(np.asarray(pb.eta(t), dtype=float), t.shape)
    rows_u = [ca.DM(eta).T if i == 1 else su[i] * W[len(free_x) + free_u.index(i), :] for i in range(5)]
    X, U = ca.vertcat(*rows_x), ca.vertcat(*rows_u)
    xs, us = ca.SX.sym("xs", 12), ca.SX.sym("us", 5)
    s_sym, u_sym = eom.State(*ca.vertsplit(xs)), eom.Controls(*ca.vertsplit(us))
    senv = bc.symbolic_environment(env)
    f = ca.Function("f", [xs, us], [ca.vertcat(*eom.derivatives(ac, senv, s_sym, u_sym))])
    nz = body_load_factors(ac, senv, s_sym, eom.loads(ac, senv, s_sym, u_sym))[2]
    fnz = ca.Function("nz", [xs, us], [nz])
    radau, Dg_sp = bc.radau_derivatives(D, h)
    dyn = ca.vec(ca.diag(ca.DM(1.0 / sx)) @ (ca.mtimes(X, Dg_sp) - f.map(len(radau))(X[:, radau], U[:, radau])))
    Ud = ca.mtimes(U, Dg_sp)  # control rates at the Radau points
    Ud0 = ca.mtimes(U[:, : d + 1], ca.DM(D[:, 0] / h[0]))  # and at t0
    x0s, xfs = start.state(), end.state()
    u0s, ufs = start.controls(), end.controls()
    ends = [
        (X[:, 0] - ca.DM(x0s)) / ca.DM(sx),
        (X[:, -1] - ca.DM(xfs)) / ca.DM(sx),
        (U[free_u, 0] - ca.DM(u0s[free_u])) / ca.DM(su[free_u]),
        (U[free_u, -1] - ca.DM(ufs[free_u])) / ca.DM(su[free_u]),
        Ud0[free_u] / ca.DM(su[free_u]),
        Ud[free_u, -1] / ca.DM(su[free_u]),
    ]
    g = [dyn] + [ca.vec(e) for e in ends]
    lbg = [np.zeros(dyn.numel())] + [np.zeros(e.numel()) for e in ends]
    ubg = list(lbg)
    # The limits at every point: the same records (gna.limits), their values on the symbols.
    for lim in aircraft_limits(ac):
        if lim.name.startswith("thrust["):
            v = U[0, :] if ac.propulsion.count == 1 else None
            if v is None or lim.upper_of is not None:
                raise SystemExit(f"bench_bounded: collocation does not express the limit {lim.name} of {ac.id}")
        elif lim.name in eom.CONTROL_NAMES:
            v = U[eom.CONTROL_NAMES.index(lim.name), :]
        elif lim.name in ("alpha", "beta"):
            v = X[eom.STATE_NAMES.index(lim.name), :]
        elif lim.name == "nz":
            v = fnz.map(P)(X, U)
        else:
            raise SystemExit(f"bench_bounded: collocation does not express the limit {lim.name} of {ac.id}")
        g.append(ca.vec(v))
        lbg.append(np.full(P, -np.inf if lim.lower is None else lim.lower))
        ubg.append(np.full(P, np.inf if lim.upper is None else lim.upper))
    quad = np.concatenate([quad_w * h[k] for k in range(n)]) / (sc.t1 - sc.t0)
    Uds = ca.diag(ca.DM(1.0 / su)) @ Ud
    obj = ca.sum2(ca.sum1(Uds * Uds) * ca.DM(quad).T)
    opts = {
        "ipopt.print_level": 0,
        "print_time": False,
        "ipopt.sb": "yes",
        "ipopt.tol": bc.IPOPT_TOL,
        "ipopt.constr_viol_tol": bc.CONSTR_VIOL_TOL,
        "ipopt.linear_solver": "mumps",
        "ipopt.max_iter": 5 if quick else 3000,
    }
    solver = ca.nlpsol("bounded", "ipopt", {"x": w, "f": obj, "g": ca.vertcat(*g)}, opts)
    w0 = np.concatenate([gs[free_x] / sx[free_x, None], gu[free_u] / su[free_u, None]]).ravel(order="F")
    sol = solver(x0=w0, lbg=np.concatenate(lbg), ubg=np.concatenate(ubg))
    stats = solver.stats()
    Wv = np.asarray(sol["x"], dtype=float).reshape(len(free_x) + len(free_u), P, order="F")
    Xv = np.zeros((12, P))
    Uv = np.zeros((5, P))
    for i in free_x:
        Xv[i] = sx[i] * Wv[free_x.index(i)]
    for i in free_u:
        Uv[i] = su[i] * Wv[len(free_x) + free_u.index(i)]
    Uv[1] = eta
    controls = bc.cubic_pieces(breaks, t, Uv)
    states = bc.cubic_pieces(breaks, t, Xv)
    return Outcome(
        "collocation",
        controls,
        lambda tt: states.evaluate(tt)[:3],
        states.evaluate,
        Xv[:, 0].copy(),
        bool(stats.get("success", False)),
        f"IPOPT: {stats.get('return_status', '')}",
        f"{stats.get('iter_count', -1)} IPOPT iterations, {w.numel()} variables, {n} intervals",
    )


# --- judging --------------------------------------------------------------------------------------------------


def judge(sc, out: Outcome) -> dict:
    """The open-loop error, cost and limits of one method's result (module docstring)."""
    pb = sc.problem()
    fly = np.arange(sc.t0, sc.t1 + 1e-9, FLY_STEP)
    flown = bc.fly_by_pieces(pb, out.controls, out.x0, fly)
    if flown is None:
        err = math.nan
    else:
        e = np.sqrt(((flown[:3] - np.asarray(out.path(fly))) ** 2).sum(axis=0))
        err = float(np.max(e)) if np.all(np.isfinite(e)) else math.nan
    t = np.arange(sc.t0, sc.t1 + 1e-9, COST_STEP)
    u = np.asarray(out.controls.evaluate(t), dtype=float)
    du = np.asarray(out.controls.evaluate(t, derivative=1), dtype=float)
    cost = control_rate_cost(t, du, control_scales(sc.aircraft, sc.env))
    frame = TrajectoryColumns(
        t, list(eom.STATE_NAMES) + list(eom.CONTROL_NAMES), np.vstack([np.asarray(out.states(t)), u])
    )
    viol = limit_violations(sc.aircraft, frame, sc.env)
    nzv = np.asarray([lim for lim in aircraft_limits(sc.aircraft) if lim.name == "nz"][0].value_of(frame, sc.env))
    return {
        "open_loop_error_m": err,
        "cost": cost,
        "limits": "met" if not viol else "; ".join(f"{v.name} {v.side}" for v in viol),
        "violations": [v.text() for v in viol],
        "nz_range": [float(nzv.min()), float(nzv.max())],
    }


def run(methods, repeat: int, quick: bool, pc_step: float, col_step: float) -> dict:
    """Solve with every method ``repeat`` times (interleaved), judge the last solution of each."""
    sc = load_scenario(SCENARIO)
    if quick:  # 13 nodes instead of 121
        from planners.scenario import scenario_from_dict

        data = dict(sc.raw)
        data["time"] = {**data["time"], "step": QUICK_STEP}
        sc = scenario_from_dict(data, where=str(sc.path), path=sc.path)
    times: dict = {m: [] for m in methods}
    last: dict = {}
    solvers = {
        "gflat": lambda: solve_gflat(sc, quick),
        "python-control": lambda: solve_python_control(sc, quick, pc_step),
        "collocation": lambda: solve_collocation(sc, quick, col_step),
    }
    load_start = os.getloadavg()
    for _ in range(repeat):
        for m in methods:
            c = _clock()
            last[m] = solvers[m]()
            times[m].append(_since(c))
    load_end = os.getloadavg()
    rows = []
    for m in methods:
        out = last[m]
        rows.append(
            {
                "method": m,
                "cpu_s": statistics.median(c for c, _ in times[m]),
                "wall_s": statistics.median(w for _, w in times[m]),
                "success": out.success,
                "message": out.message,
                "evaluations": out.evaluations,
                **judge(sc, out),
            }
        )
    return {
        "scenario": SCENARIO,
        "repeat": repeat,
        "quick": quick,
        "pc_step_s": pc_step,
        "col_step_s": col_step,
        "loadavg_start": list(load_start),
        "loadavg_end": list(load_end),
        "cpus": os.cpu_count(),
        "rows": rows,
    }


def format_table(res: dict) -> str:
    """The results as a markdown table (docs/performance.md) and a note per method."""
    lines = [
        f"{res['scenario']}: {res['repeat']} repeat(s){' (quick)' if res['quick'] else ''}, python-control timepts "
        f"every {res['pc_step_s']:g} s, collocation intervals {res['col_step_s']:g} s; {res['cpus']} CPUs, load "
        "average (1, 5, 15 min) at start {:.2f} {:.2f} {:.2f}, at end {:.2f} {:.2f} {:.2f}".format(
            *res["loadavg_start"], *res["loadavg_end"]
        ),
        "",
        "| method | CPU [s] | wall [s] | cost [1/s^2] | open-loop error [m] | limits (0.1 s grid) | nz range | solver |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in res["rows"]:
        lines.append(
            f"| {r['method']} | {r['cpu_s']:.2f} | {r['wall_s']:.2f} | {r['cost']:.4g} | {r['open_loop_error_m']:.3g} | "
            f"{r['limits']} | {r['nz_range'][0]:.2f} .. {r['nz_range'][1]:.2f} | "
            f"{'ok' if r['success'] else 'FAILED'}: {r['evaluations']} |"
        )
    lines.append("")
    for r in res["rows"]:
        lines.append(f"{r['method']}: {r['message']}")
        for v in r["violations"]:
            lines.append(f"  {v}")
    return "\n".join(lines)


def main(argv=None) -> None:
    """Command line: run the methods, print the table (and write ``--json``)."""
    ap = argparse.ArgumentParser(prog="bench_bounded", description=__doc__.split("\n")[0])
    ap.add_argument("--repeat", type=int, default=3, help="repeats of each method, interleaved (median; default 3)")
    ap.add_argument("--methods", default=",".join(METHODS), help=f"comma-separated, of {', '.join(METHODS)}")
    ap.add_argument("--pc-step", type=float, default=2.0, help="python-control's timepts step [s] (default 2)")
    ap.add_argument("--col-step", type=float, default=1.0, help="collocation interval [s] (default 1)")
    ap.add_argument("--quick", action="store_true", help="the smallest setting: coarse grids, 2-5 iterations")
    ap.add_argument("--json", help="also write the results to this JSON file")
    args = ap.parse_args(argv)
    methods = [m.strip() for m in args.methods.split(",") if m.strip()]
    bad = [m for m in methods if m not in METHODS]
    if bad or not methods:
        ap.error(f"--methods: unknown {', '.join(bad) or '(none)'}; choose from {', '.join(METHODS)}")
    if args.repeat < 1 or args.repeat > 100:
        ap.error(f"--repeat must be 1 .. 100, got {args.repeat}")
    for flag, v in (("--pc-step", args.pc_step), ("--col-step", args.col_step)):
        if not (math.isfinite(v) and 0.05 <= v <= 30.0):
            ap.error(f"{flag} must be within 0.05 .. 30 s, got {v}")
    pc_step, col_step = (20.0, 10.0) if args.quick else (args.pc_step, args.col_step)
    try:
        res = run(methods, args.repeat, args.quick, pc_step, col_step)
    except ImportError as exc:
        raise SystemExit(f"bench_bounded needs the bench extra (pip install 'gflat[bench]'): {exc}") from None
    except KeyboardInterrupt:
        raise SystemExit("bench_bounded: interrupted") from None
    print(format_table(res))
    if args.json:
        with open(args.json, "w", encoding="utf-8") as fh:
            json.dump(res, fh, indent=2)


if __name__ == "__main__":
    main()
