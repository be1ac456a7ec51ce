"""The planner against direct collocation (CasADi + IPOPT) on the full model, side by side.

Both solve the same inverse problem on a scenario: find the 12 states and 5 controls such that the
full model's equations (``gna.eom.derivatives``, the project's one definition, evaluated on CasADi
symbols) hold, the flat outputs ``x, y, z`` and the fourth flat output (beta, mu, F or the mix) take
the scenario's values, and eta (or the fixed rudder dn when eta is the fourth control) is the
prescribed one.

Collocation scheme: Legendre--Gauss--Radau (Radau IIA), degree 3, on intervals of the scenario's node
step times a factor (1, 2, 4, 8 by default).  On each interval the states and the controls are the
degree-3 polynomials through their values at the interval start and at the three Radau points
(the last one is the interval end), so both are continuous piecewise cubics; the full model's
equations hold at the three Radau points of every interval (order 5 for the states of an ODE, 2s - 1
with s = 3; stiffly accurate, the standard choice of pseudospectral and ``casadi`` collocation).
The flat outputs and the prescribed inputs are imposed at every point (they are known numbers there,
so they enter as constants, which is what IPOPT's ``fixed_variable_treatment = make_parameter`` would
do with equal bounds); a mixed fourth output ``f1(t) beta + f2(t) mu = value(t)`` is a constraint at
every point.

The equations do not fix every unknown: there are 12 equations per Radau point but none at t0, so the
initial values of the non-flat states and the controls at t0 are left free; and on the full model the rate and surface terms of the
force coefficients (the paper's H) feed the controls back into the force equations, so the inverse
problem is a boundary-value problem with fast modes rather than the pointwise chain of the simple
model (collocating also at t0 makes the system square, but its Jacobian is then singular on the
aileron roll's grids).  As usual in direct collocation, an objective picks the solution, a sum of two terms of weight 1:
the squared defect of the model's equations at t0 (scaled like the constraints: the equations at
t0 in the least-squares sense, which fixes the initial state where the equations allow it) and the
integral over the span of the squared control rates (each control over its scale: F over m g,
surfaces and eta as they are; exact on the piecewise cubics by the Radau quadrature), which picks
the smooth member of the fast modes.  The constraints hold to IPOPT's tolerance whatever the
weights; the objective only chooses among their solutions (the weights measured against others:
docs/collocation.md, "Collocation scheme").

Initial guess, a setting (``--guess``, both by default, reported side by side):

* ``plan-j0``: the planner's J = 0 plan (flat parametrization of the simple model) evaluated at the
  collocation points: a guess only a user of this planner has;
* ``trim``: what a collocation user without flatness starts from: positions from the flat outputs at
  the points, V, gamma, chi from their first derivatives (kinematics, exact), and alpha, beta, mu,
  p, q, r and the controls held at one trim of the full model at the start: steady straight flight
  with the flat outputs' speed and flight-path angle at t0, no sideslip, at the altitude and eta of
  t0 (:data:`TRIM_RULE`; the same rule for every scenario, whatever the manoeuvre does next).

Computing the guess (the J = 0 plan, or the trim and the kinematics) is part of solving a new problem,
so it is counted in every collocation time below, built from scratch and re-solved alike.  A solution
IPOPT accepts but whose points leave the model's physical domain, or whose open-loop flight does not
finish, has no accuracy (NaN) and never counts as matched; no option is tuned per guess or scenario.

Accuracy of both: the planned controls flown open loop on the full model from the plan's own initial
state (``gna.simulate.simulate``, DOP853, rtol = atol = 1e-10, the settings of :mod:`planners.verify`),
the integrator restarted at every break of the controls (collocation: every interval end; planner:
every node), largest distance of ``(x, y, z)`` to the exact flat outputs on an output grid of a tenth
of the scenario's node step (at most 0.01 s): :func:`open_loop_error_of` for both.  The restarts: the
collocation controls are piecewise cubics whose derivative jumps at the interval ends, and an adaptive
integrator's error estimate assumes a smooth right-hand side (measured in docs/collocation.md, "Accuracy and
timing"); the one-piece figure is kept alongside in the results (``accuracy_one_piece_m``).

Timing: interleaved repetitions, per repetition the planner (``plan_scenario`` at the bundled
settings), then per guess, grid and CasADi graph (MX: the model an SX function mapped over the points,
quick to build; SX: everything expanded, slow to build, quicker to evaluate) the collocation built from
scratch (guess, symbolic NLP and ``nlpsol``, solve) and re-solved (guess, then the solver built once
called from it); medians of CPU (``time.process_time``) and wall time, BLAS threads pinned to 1, the
collector run before (not inside) every timed section.  The ratio at matched accuracy takes the
cheapest successful grid whose accuracy is at least the planner's and the quicker graph for each of
re-solve and built-from-scratch.  Finer grids than ``--factors`` are tried only while the finest grid
so far converged and flew.  IPOPT: MUMPS, exact Hessian, ``tol = 1e-8``, ``constr_viol_tol = 1e-10``
(:data:`CONSTR_VIOL_TOL`), ``print_level = 0``, other options at their defaults, the same for every
scenario and guess.  (Why ``constr_viol_tol`` is tightened from IPOPT's 1e-4: docs/collocation.md.)

Usage::

    python benchmarks/bench_collocation.py [--scenarios NAME ...] [--repeat N] [--factors 1,2,4,8]
                                           [--graphs MX,SX] [--guess plan-j0,trim] [--quick]
                                           [--json PATH] [--markdown PATH]
"""

from __future__ import annotations

import os
import sys

if __package__ in (None, ""):  # run as a script: the repository's packages, not an installed copy
    sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import dataclasses  # noqa: E402
import gc  # noqa: E402
import json  # noqa: E402
import statistics  # noqa: E402
import time  # noqa: E402
from collections.abc import Callable  # noqa: E402
from dataclasses import dataclass  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from gna import eom  # noqa: E402
from gna.atmosphere import H_TROPO, ISA, LAPSE, R_AIR, RHO0, RHO_TROPO, T0, T_TROPO  # noqa: E402
from gna.piecewise import PiecewisePolynomial  # noqa: E402
from gna.simulate import simulate  # noqa: E402
from gna.trajectory import domain_violation  # noqa: E402
from gna.units import G0  # noqa: E402
from planners import verify  # noqa: E402

try:  # an optional dependency: the ``bench`` extra
    import casadi as ca
except ImportError:  # pragma: no cover - reported by main()
    ca = None

SCENARIOS = ("gtm-aileron-roll", "twin-otter-single-engine", "gtm-forward-slip")
DEFAULT_FACTORS = (1.0, 2.0, 4.0, 8.0)
FINER_FACTORS = (0.5, 0.25, 0.125, 0.0625, 0.03125)
DEGREE = 3
IPOPT_TOL = 1e-8
# IPOPT's default constr_viol_tol (1e-4) lets it declare success with the collocation equations met
# to 2e-8 only (the Twin Otter from the trim guess, 2 iterations), which the open loop amplifies to
# micrometres; one more Newton step meets them to 1e-13.
CONSTR_VIOL_TOL = 1e-10


def _require_casadi():
    if ca is None:
        raise SystemExit("bench_collocation needs CasADi: pip install 'gflat[bench]' (or pip install casadi)")
    try:  # casadi >= 3.7 warns once when numpy functions meet casadi values unless told the mode
        ca.GlobalOptions.setNumpyMode(1)
    except AttributeError:
        pass


class SymbolicISA(ISA):
    """The ISA density of :class:`gna.atmosphere.ISA` that also takes CasADi symbols.

    ``ISA.density`` picks the layer from the altitude's numeric value, which a symbol does not
    have; on a symbol both layers' formulas (the same constants) are combined by ``if_else``.
    Numbers go to ``ISA.density`` itself.
    """

    def density(self, h):
        """Density [kg/m^3] at altitude ``h`` [m] (float, array, series or CasADi symbol)."""
        if ca is not None and isinstance(h, (ca.SX, ca.MX)):
            tropo = RHO0 * (1.0 - LAPSE * h / T0) ** (G0 / (R_AIR * LAPSE) - 1.0)
            strato = RHO_TROPO * ca.exp(-G0 * (h - H_TROPO) / (R_AIR * T_TROPO))
            return ca.if_else(h <= H_TROPO, tropo, strato)
        return super().density(h)


def symbolic_environment(env):
    """The environment ``env`` with a density that evaluates on CasADi symbols.

    Parameters
    ----------
    env : gna.atmosphere.Environment
        Gravity and atmosphere of the scenario.

    Returns
    -------
    gna.atmosphere.Environment
        The same, with :class:`SymbolicISA` in place of an ISA atmosphere (constant density works
        on symbols as it is).
    """
    if isinstance(env.atmosphere, ISA):
        return dataclasses.replace(env, atmosphere=SymbolicISA())
    return env


def radau_matrices(degree: int = DEGREE):
    """Legendre--Gauss--Radau points and differentiation weights on [0, 1].

    Parameters
    ----------
    degree : int
        Number of Radau points (the polynomial degree of states and controls on an interval).

    Returns
    -------
    tau : ndarray, shape (degree + 1,)
        0 followed by the Radau points (the last is 1).
    D : ndarray, shape (degree + 1, degree + 1)
        ``D[j, i]``: derivative at ``tau[i]`` of the Lagrange basis polynomial of ``tau[j]``.
    """
    tau = np.concatenate([[0.0], np.asarray(ca.collocation_points(degree, "radau"), dtype=float)])
    D = np.zeros((degree + 1, degree + 1))
    for j in range(degree + 1):
        others = np.delete(tau, j)
        basis = np.poly1d(others, r=True) / np.prod(tau[j] - others)
        D[j] = basis.deriv()(tau)
    return tau, D


def radau_derivatives(D: np.ndarray, h: np.ndarray):
    """The derivative of every point's value at the Radau points of a grid, as one sparse matrix.

    Parameters
    ----------
    D : ndarray, shape (degree + 1, degree + 1)
        :func:`radau_matrices`'s differentiation weights on [0, 1].
    h : ndarray, shape (n,)
        The intervals' lengths [s].

    Returns
    -------
    radau : ndarray of int, shape (degree * n,)
        The columns of the Radau points among the grid's ``degree * n + 1`` points (the start first).
    Dg : casadi.DM, shape (degree * n + 1, degree * n)
        ``X @ Dg``: the time derivative at the Radau points of the values ``X`` at every point [1/s].
    """
    d, n = D.shape[0] - 1, len(h)
    radau = np.array([k * d + i for k in range(n) for i in range(1, d + 1)])
    Dg = np.zeros((d * n + 1, d * n))
    for k in range(n):
        idx = k * d + np.arange(d + 1)
        Dg[np.ix_(idx, k * d + np.arange(d))] = D[:, 1:] / h[k]
    return radau, ca.sparsify(ca.DM(Dg))


def _state_scales(aircraft, env, guess_states, guess_controls):
    """Typical magnitudes of the 12 states and 5 controls (objective weights, F's unit)."""
    sx = np.ones(12)
    sx[eom.STATE_NAMES.index("V")] = max(1.0, float(np.mean(np.abs(guess_states[3]))))
    su = np.ones(5)
    su[0] = aircraft.mass.mass * env.g
    return sx, su


def radau_weights(points: np.ndarray) -> np.ndarray:
    """Quadrature weights on [0, 1] of the interpolation polynomial through ``points``.

    Parameters
    ----------
    points : ndarray, shape (d,)
        Distinct points in [0, 1] (the Radau points: exact to degree 2 d - 2).

    Returns
    -------
    ndarray, shape (d,)
        ``sum_j w_j g(points[j])`` approximates ``int_0^1 g``.
    """
    w = np.zeros(len(points))
    for j in range(len(points)):
        others = np.delete(points, j)
        basis = np.poly1d(others, r=True) / np.prod(points[j] - others)
        integral = basis.integ()
        w[j] = integral(1.0) - integral(0.0)
    return w


@dataclass
class CollocationSolution:
    """States and controls of a solved collocation problem.

    Attributes
    ----------
    t : ndarray, shape (P,)
        Times of the points (interval starts and Radau points) [s].
    states : ndarray, shape (12, P)
        States at the points (SI, rad), in the order of :data:`gna.eom.STATE_NAMES`.
    controls : ndarray, shape (5, P)
        Controls at the points ``(F [N], eta, dl, dm, dn [rad])``.
    control_function : PiecewisePolynomial
        The controls between the points: on each interval the cubic through its four points.
    success : bool
        IPOPT's verdict.
    status : str
        IPOPT's return status.
    iterations : int
        IPOPT iterations.
    constraint_violation : float
        Largest violation of the collocation equations (units of the states).
    domain : str or None
        (Property.) The first point outside the model's physical domain
        (:func:`gna.trajectory.domain_violation`: airspeed, ``|beta| < pi/2``, ``cos(gamma)``, ``|alpha|``),
        None when every point is inside; a solution outside it solves the NLP but is no flight (the open
        loop is then not flown).
    """

    t: np.ndarray
    states: np.ndarray
    controls: np.ndarray
    control_function: PiecewisePolynomial
    success: bool
    status: str
    iterations: int
    constraint_violation: float

    @property
    def domain(self) -> str | None:
        """The first point outside the physical domain (message), None when every point is inside."""
        return next(
            (msg for k in range(len(self.t)) if (msg := domain_violation(float(self.t[k]), self.states[:, k]))), None
        )

    @property
    def initial_state(self) -> np.ndarray:
        """The 12 states at the first point (SI, rad)."""
        return self.states[:, 0].copy()


class CollocationProblem:
    """The collocation NLP of a scenario on intervals of ``factor`` times the scenario's node step.

    Building it creates the symbolic NLP and the IPOPT solver (the "build" time); :meth:`solve`
    runs IPOPT from the initial guess and returns a :class:`CollocationSolution`.

    Parameters
    ----------
    scenario : planners.scenario.Scenario
        The scenario (aircraft, environment, flat outputs, eta or fixed rudder).
    factor : float
        Interval length over the scenario's node step.
    guess : callable
        ``guess(t) -> (states (12, P), controls (5, P))`` at times ``t`` (shape (P,)) [SI, rad].
    tol : float
        IPOPT's tolerance (``tol``).
    ipopt : dict, optional
        Further IPOPT options (without the ``ipopt.`` prefix), e.g. ``{"print_level": 5}``.
    weight : float
        Weight of the integral over the span of the squared scaled control rates in the objective.
    start_weight : float
        Weight of the squared (scaled) defect of the model's equations at t0 in the objective.
    graph : {"MX", "SX"}
        CasADi graph of the NLP: ``"MX"`` (the model an ``SX`` function mapped over the points; quick
        to build) or ``"SX"`` (everything expanded to scalar operations: slow to build, quicker to
        evaluate).  The model's equations are the same.

    Attributes
    ----------
    n_intervals : int
        Number of intervals.
    P : int
        Number of points (``3 n_intervals + 1``).
    n_variables, n_constraints : int
        Size of the NLP.
    t : ndarray, shape (P,)
        Times of the points [s].
    """

    def __init__(
        self,
        scenario,
        factor: float,
        guess: Callable,
        tol: float = IPOPT_TOL,
        ipopt: dict | None = None,
        weight: float = 1.0,
        start_weight: float = 1.0,
        graph: str = "MX",
    ):
        _require_casadi()
        pb = scenario.problem()
        ac, env = pb.aircraft, pb.env
        span = scenario.t1 - scenario.t0
        n = max(1, int(round(span / (scenario.step * factor))))
        self.n_intervals = n
        self.breaks = np.linspace(scenario.t0, scenario.t1, n + 1)
        h = np.diff(self.breaks)
        tau, D = radau_matrices(DEGREE)
        quad_w = radau_weights(tau[1:])
        d = DEGREE
        P = d * n + 1
        self.t = np.concatenate([[self.breaks[0]]] + [self.breaks[k] + tau[1:] * h[k] for k in range(n)])
        t = self.t
        g_states, g_controls = guess(t)
        g_states = np.asarray(g_states, dtype=float)
        g_controls = np.asarray(g_controls, dtype=float)
        sx, su = _state_scales(ac, env, g_states, g_controls)

        # Known values: flat outputs, the fourth flat output, eta or the fixed rudder.
        fixed_x: dict[int, np.ndarray] = {}
        fixed_u: dict[int, np.ndarray] = {}
        for name, f in (("x", pb.x), ("y", pb.y), ("z", pb.z)):
            fixed_x[eom.STATE_NAMES.index(name)] = np.broadcast_to(np.asarray(f(t), dtype=float), t.shape)
        zeta = pb.zeta
        zv = np.broadcast_to(np.asarray(zeta.value(t), dtype=float), t.shape)
        if zeta.kind in ("beta", "mu"):
            fixed_x[eom.STATE_NAMES.index(zeta.kind)] = zv
        elif zeta.kind == "F":
            fixed_u[0] = zv
        if pb.eta is not None:
            fixed_u[1] = np.broadcast_to(np.asarray(pb.eta(t), dtype=float), t.shape)
        else:
            fixed_u[4] = np.broadcast_to(np.asarray(pb.dn(t), dtype=float), t.shape)
        self.fixed_x, self.fixed_u = fixed_x, fixed_u

        # Decision variables (scaled by sx, su), one symbol row per free state / control.
        free_x = [i for i in range(12) if i not in fixed_x]
        free_u = [i for i in range(5) if i not in fixed_u]
        self.free_x, self.free_u = free_x, free_u
        if graph not in ("MX", "SX"):
            raise ValueError(f"graph must be 'MX' or 'SX', got {graph!r}")
        sym = ca.MX if graph == "MX" else ca.SX
        w = sym.sym("w", (len(free_x) + len(free_u)) * P)
        W = ca.reshape(w, len(free_x) + len(free_u), P)
        rows_x, rows_u = [], []
        for i in range(12):
            rows_x.append(ca.DM(fixed_x[i]).T if i in fixed_x else sx[i] * W[free_x.index(i), :])
        for i in range(5):
            rows_u.append(ca.DM(fixed_u[i]).T if i in fixed_u else su[i] * W[len(free_x) + free_u.index(i), :])
        X = ca.vertcat(*rows_x)
        U = ca.vertcat(*rows_u)

        # The full model on symbols: the project's equations, once, mapped over the Radau points.
        xs, us = ca.SX.sym("xs", 12), ca.SX.sym("us", 5)
        rhs = eom.derivatives(
            ac, symbolic_environment(env), eom.State(*ca.vertsplit(xs)), eom.Controls(*ca.vertsplit(us))
        )
        f = ca.Function("f", [xs, us], [ca.vertcat(*rhs)])
        # The equations at every Radau point: X @ Dg = f(X, U) there.
        radau, Dg_sp = radau_derivatives(D, h)
        dyn = ca.mtimes(X, Dg_sp) - f.map(len(radau))(X[:, radau], U[:, radau])
        dyn = ca.vec(ca.diag(ca.DM(1.0 / sx)) @ dyn)
        self.n_dynamics = int(dyn.numel())
        if zeta.kind == "mix":
            # The mixed fourth output f1(t) beta + f2(t) mu = value(t) at every point.
            f1 = np.broadcast_to(np.asarray(zeta.f1(t), dtype=float), t.shape)
            f2 = np.broadcast_to(np.asarray(zeta.f2(t), dtype=float), t.shape)
            ib, im = eom.STATE_NAMES.index("beta"), eom.STATE_NAMES.index("mu")
            mix = X[ib, :] * ca.DM(f1).T + X[im, :] * ca.DM(f2).T - ca.DM(zv).T
            dyn = ca.vertcat(dyn, ca.vec(mix))
        # Objective: the integral of the squared control rates (scaled), exact for the piecewise cubics
        # (Radau quadrature, exact to degree 2 d - 2 = 4).
        quad = np.concatenate([quad_w * h[k] for k in range(n)]) / (scenario.t1 - scenario.t0)
        Ud = ca.diag(ca.DM(1.0 / su)) @ ca.mtimes(U, Dg_sp)
        obj = weight * ca.sum2(ca.sum1(Ud * Ud) * ca.DM(quad).T) if weight else 0
        if start_weight:
            # The model's equations at t0 too, in the least-squares sense (scaled like the constraints).
            d0 = ca.DM(D[:, 0] / h[0])
            defect0 = (ca.mtimes(X[:, : d + 1], d0) - f(X[:, 0], U[:, 0])) / ca.DM(sx)
            obj = obj + start_weight * ca.sumsqr(defect0)
        self.n_variables = int(w.numel())
        self.n_constraints = int(dyn.numel())
        opts = {
            "ipopt.print_level": 0,
            "print_time": False,
            "ipopt.sb": "yes",
            "ipopt.tol": tol,
            "ipopt.constr_viol_tol": CONSTR_VIOL_TOL,
            "ipopt.linear_solver": "mumps",
        }
        opts.update({f"ipopt.{k}": v for k, v in (ipopt or {}).items()})
        self.solver = ca.nlpsol("collocation", "ipopt", {"x": w, "f": obj, "g": dyn}, opts)
        self._sx, self._su = sx, su
        self.P = P
        self.w0 = self._scaled(g_states, g_controls)

    def _scaled(self, states: np.ndarray, controls: np.ndarray) -> np.ndarray:
        """The decision vector of states (12, P) and controls (5, P): the free rows over their scales."""
        fx, fu = self.free_x, self.free_u
        w0 = np.concatenate([(states[fx] / self._sx[fx, None]), (controls[fu] / self._su[fu, None])])
        return w0.ravel(order="F")

    def set_guess(self, guess: Callable) -> None:
        """Replace the initial guess of the next :meth:`solve` (the NLP and its scales stay).

        Parameters
        ----------
        guess : callable
            ``guess(t) -> (states (12, P), controls (5, P))`` at the points' times ``t`` [SI, rad].
        """
        g_states, g_controls = guess(self.t)
        self.w0 = self._scaled(np.asarray(g_states, dtype=float), np.asarray(g_controls, dtype=float))

    def solve(self) -> CollocationSolution:
        """Run IPOPT from the initial guess.

        Returns
        -------
        CollocationSolution
            States and controls at the points, the controls as a piecewise cubic, IPOPT's status.
        """
        sol = self.solver(x0=self.w0, lbg=0.0, ubg=0.0)
        stats = self.solver.stats()
        return self.unpack(np.asarray(sol["x"], dtype=float).ravel(), np.asarray(sol["g"], dtype=float).ravel(), stats)

    def unpack(self, w: np.ndarray, g: np.ndarray, stats: dict) -> CollocationSolution:
        """States, controls and piecewise-cubic controls from the NLP's solution vector.

        Parameters
        ----------
        w : ndarray, shape (n_variables,)
            Scaled decision variables.
        g : ndarray, shape (n_constraints,)
            Collocation equations at ``w`` (scaled).
        stats : dict
            IPOPT's statistics (``success``, ``return_status``, ``iter_count``).

        Returns
        -------
        CollocationSolution
        """
        nf = len(self.free_x) + len(self.free_u)
        W = w.reshape(nf, self.P, order="F")
        X = np.zeros((12, self.P))
        U = np.zeros((5, self.P))
        for i in range(12):
            X[i] = self.fixed_x[i] if i in self.fixed_x else self._sx[i] * W[self.free_x.index(i)]
        for i in range(5):
            U[i] = self.fixed_u[i] if i in self.fixed_u else self._su[i] * W[len(self.free_x) + self.free_u.index(i)]
        ctl = cubic_pieces(self.breaks, self.t, U)
        gd = g[: self.n_dynamics]
        viol = float(np.max(np.abs(gd.reshape(12, -1, order="F") * self._sx[:, None]))) if gd.size else 0.0
        if g.size > gd.size:
            viol = max(viol, float(np.max(np.abs(g[gd.size :]))))
        return CollocationSolution(
            self.t,
            X,
            U,
            ctl,
            bool(stats.get("success", False)),
            str(stats.get("return_status", "")),
            int(stats.get("iter_count", -1)),
            viol,
        )


def cubic_pieces(breaks: np.ndarray, t: np.ndarray, values: np.ndarray) -> PiecewisePolynomial:
    """The piecewise polynomial through the values at the collocation points of each interval.

    Parameters
    ----------
    breaks : ndarray, shape (n + 1,)
        Interval ends [s].
    t : ndarray, shape (d n + 1,)
        Times of the points: ``breaks[0]``, then the ``d`` Radau points of each interval [s].
    values : ndarray, shape (m, d n + 1)
        Values at the points.

    Returns
    -------
    PiecewisePolynomial
        Degree ``d`` on each interval, continuous at the interval ends.
    """
    n = len(breaks) - 1
    d = (len(t) - 1) // n
    coeffs = np.zeros((n, values.shape[0], d + 1))
    for k in range(n):
        idx = k * d + np.arange(d + 1)
        s = t[idx] - breaks[k]
        V = np.vander(s, d + 1, increasing=True)
        coeffs[k] = np.linalg.solve(V, values[:, idx].T).T
    return PiecewisePolynomial(breaks, coeffs)


def verification_grid(scenario) -> np.ndarray:
    """Output times of the open-loop flights (:func:`planners.verify.verification_grid` of the scenario's nodes)."""
    return verify.verification_grid(scenario.t_nodes)


def open_loop_error_of(scenario, controls, x0, t_eval=None) -> float:
    """Largest distance [m] to the flat outputs when ``controls`` are flown open loop from ``x0``.

    The flight of :func:`planners.verify.open_loop_check` (full model, ``gna.simulate.simulate``,
    DOP853, rtol = atol = 1e-10), restarted at every break of a piecewise-polynomial ``controls``
    (:func:`fly_by_pieces`), the standard treatment of an input that is smooth only between its breaks;
    NaN when the flight stops early or the initial state is outside the physical domain.

    Parameters
    ----------
    scenario : planners.scenario.Scenario
        The scenario (aircraft, environment, flat outputs).
    controls : gna.piecewise.PiecewisePolynomial or callable
        ``t [s] -> (F [N], eta [-], dl, dm, dn [rad])``; a callable without ``breaks`` is flown in one piece.
    x0 : array_like, shape (12,)
        Initial state at the first output time (SI, rad).
    t_eval : array_like, shape (N,), optional
        Output times [s]; default :func:`verification_grid`.

    Returns
    -------
    float
        ``max |(x, y, z) - flat outputs|`` over the output times [m], or NaN.
    """
    grid = verification_grid(scenario) if t_eval is None else np.asarray(t_eval, dtype=float)
    if domain_violation(float(grid[0]), np.asarray(x0, dtype=float)) is not None:
        return float("nan")
    pb = scenario.problem()
    states = fly_by_pieces(pb, controls, x0, grid)
    if states is None:
        return float("nan")
    flat = np.stack([np.broadcast_to(np.asarray(f(grid), dtype=float), grid.shape) for f in (pb.x, pb.y, pb.z)])
    err = np.sqrt(((states[:3] - flat) ** 2).sum(axis=0))
    return float(np.max(err)) if np.all(np.isfinite(err)) else float("nan")


def fly_by_pieces(problem, controls, x0, grid: np.ndarray) -> np.ndarray | None:
    """The full model flown open loop, the integrator restarted at every break of the controls.

    A piecewise cubic through the collocation points is only continuous at the interval ends (its
    derivative jumps): an adaptive integrator stepping over such a kink accepts there a step whose
    error is near its tolerance (rtol |x| = 3.5e-7 m on a position of 3.5 km at rtol = 1e-10), once per
    kink, so on fine grids the flight's own error, not the controls', sets the open-loop figure.
    Integrating piece by piece (each piece a polynomial: a smooth right-hand side) removes it; the
    planner's controls (degree 5, continuous derivatives at its nodes) fly the same either way.

    Parameters
    ----------
    problem : planners.flat.FlatProblem
        Aircraft and environment.
    controls : gna.piecewise.PiecewisePolynomial or callable
        The controls ``t [s] -> (F [N], eta [-], dl, dm, dn [rad])``; without ``breaks`` one piece.
    x0 : array_like, shape (12,)
        Initial state at ``grid[0]`` (SI, rad).
    grid : ndarray, shape (N,)
        Output times [s], increasing.

    Returns
    -------
    ndarray, shape (12, N) or None
        The states at the output times; None when a piece's flight does not complete (domain, failure).
    """
    grid = np.asarray(grid, dtype=float)
    t0, t1 = float(grid[0]), float(grid[-1])
    breaks = np.asarray(getattr(controls, "breaks", (t0, t1)), dtype=float)
    cuts = np.concatenate([[t0], breaks[(breaks > t0) & (breaks < t1)], [t1]])
    out = np.empty((12, grid.size))
    out[:, 0] = x = np.asarray(x0, dtype=float)
    for a, b in zip(cuts[:-1], cuts[1:]):
        inside = (grid > a) & (grid <= b)
        te = np.unique(np.concatenate([[a], grid[inside], [b]]))
        run = simulate(
            problem.aircraft,
            controls,
            (a, b),
            x,
            env=problem.env,
            t_eval=te,
            method=verify.VERIFY_METHOD,
            rtol=verify.VERIFY_RTOL,
            atol=verify.VERIFY_ATOL,
        )
        if run.status != "completed":
            return None
        Y = run.df[list(eom.STATE_NAMES)].to_numpy().T
        out[:, inside] = Y[:, np.isin(te, grid[inside])]
        x = Y[:, -1]
    return out


def planner_guess(scenario) -> Callable:
    """Initial guess ``plan-j0``: the planner's J = 0 plan (flat parametrization, simple model).

    Parameters
    ----------
    scenario : planners.scenario.Scenario
        The scenario.

    Returns
    -------
    callable
        ``guess(t) -> (states (12, P), controls (5, P))`` at times ``t`` [s] (SI, rad).
    """
    from planners.generalized import plan_scenario

    plan = plan_scenario(scenario, J=0)
    return lambda t: (plan.state(np.asarray(t, dtype=float), 0), plan.controls(np.asarray(t, dtype=float), 0))


def flat_output_kinematics(problem, t: np.ndarray) -> np.ndarray:
    """Positions and the velocity vector's V, gamma, chi from the flat outputs x, y, z and their first derivatives.

    No wind: the air-path velocity is the time derivative of the position (NED), so
    ``V = |(x', y', z')|``, ``gamma = atan2(-z', sqrt(x'^2 + y'^2))``, ``chi = atan2(y', x')`` (unwrapped).
    The derivatives are exact (order-1 Taylor series of the scenario's expressions).

    Parameters
    ----------
    problem : planners.flat.FlatProblem
        The scenario's problem (flat outputs x, y, z of t).
    t : ndarray, shape (P,)
        Times [s].

    Returns
    -------
    ndarray, shape (6, P)
        ``x, y, z`` [m], ``V`` [m/s], ``gamma, chi`` [rad].
    """
    from planners.series import Series

    t = np.asarray(t, dtype=float)
    ts = Series.variable(t, 1)
    rows = []
    for f in (problem.x, problem.y, problem.z):
        s = f(ts)
        if isinstance(s, Series):
            c = s.coeffs
            rows.append((np.broadcast_to(c[..., 0], t.shape), np.broadcast_to(c[..., 1], t.shape)))
        else:  # an expression without t is a number
            rows.append((np.full(t.shape, float(s)), np.zeros(t.shape)))
    (x, xd), (y, yd), (z, zd) = rows
    V = np.sqrt(xd**2 + yd**2 + zd**2)
    gamma = np.arctan2(-zd, np.hypot(xd, yd))
    chi = np.unwrap(np.arctan2(yd, xd))
    return np.stack([x, y, z, V, gamma, chi])


TRIM_RULE = (
    "steady straight flight along the initial velocity: gna.trim.trim(aircraft, {V, gamma: from the flat "
    "outputs' derivatives at t0, chi_dot: 0, beta: 0}, altitude -z(t0), eta(t0)), full model"
)


def trim_guess(scenario) -> Callable:
    """Initial guess ``trim``: what a collocation user without the flat parametrization would start from.

    Positions from the flat outputs at the points, ``V, gamma, chi`` from their first derivatives
    (:func:`flat_output_kinematics`, exact), and ``alpha, beta, mu, p, q, r`` and the five controls held
    at one trim of the full model at the start (:data:`TRIM_RULE`): steady straight flight with the
    speed and flight-path angle of the flat outputs at t0, no sideslip, at the altitude -z(t0) and the
    thrust asymmetry eta(t0) (0 when eta is the fourth control).  The same rule for every scenario,
    whatever its manoeuvre does next.

    Parameters
    ----------
    scenario : planners.scenario.Scenario
        The scenario.

    Returns
    -------
    callable
        ``guess(t) -> (states (12, P), controls (5, P))`` at times ``t`` [s] (SI, rad); its attribute
        ``trim`` is the :class:`gna.trim.TrimResult`.

    Raises
    ------
    gna.errors.ConvergenceError
        The trim does not converge.
    """
    from gna.trim import trim

    pb = scenario.problem()
    k0 = flat_output_kinematics(pb, np.array([scenario.t0]))[:, 0]
    eta0 = float(np.asarray(pb.eta(scenario.t0))) if pb.eta is not None else 0.0
    tr = trim(
        pb.aircraft,
        {"V": float(k0[3]), "gamma": float(k0[4]), "chi_dot": 0.0, "beta": 0.0},
        altitude=float(-k0[2]),
        env=pb.env,
        eta=eta0,
    )
    held = np.array([tr.values[k] for k in ("alpha", "beta", "mu", "p", "q", "r")])
    u = np.array([tr.values["F"], eta0, tr.values["dl"], tr.values["dm"], tr.values["dn"]])

    def guess(t):
        t = np.asarray(t, dtype=float)
        states = np.concatenate([flat_output_kinematics(pb, t), np.repeat(held[:, None], t.size, axis=1)])
        return states, np.repeat(u[:, None], t.size, axis=1)

    guess.trim = tr
    return guess


GUESSES = {"plan-j0": planner_guess, "trim": trim_guess}
GUESS_TEXT = {
    "plan-j0": "the planner's J = 0 plan (flat parametrization, simple model) at the points",
    "trim": "flat outputs and their kinematics at the points, the rest held at a trim: " + TRIM_RULE,
}


def _clock():
    gc.collect()  # every timed section starts from the same collector state
    return time.process_time(), time.perf_counter()


def _since(start):
    c, w = time.process_time(), time.perf_counter()  # the collection belongs to the next section's start
    return c - start[0], w - start[1]


def _median(pairs):
    return [statistics.median(p[i] for p in pairs) for i in (0, 1)]


GRAPHS = ("MX", "SX")


class _numpy_reference:
    """The planner on its numpy reference path in this process (series kernels and stage residuals on
    numpy: what ``GFLAT_SERIES_BACKEND=numpy`` selects), restored on exit."""

    def __enter__(self):
        import planners.chained as chained
        import planners.series as series

        self._saved = (series._K, chained.compiled_programs)
        series._K = series._NumpyKernels
        chained.compiled_programs = lambda: False
        return self

    def __exit__(self, *exc):
        import planners.chained as chained
        import planners.series as series

        series._K, chained.compiled_programs = self._saved
        return False


def floor_estimate(plan, repeat: int = 20) -> float | None:
    """Time [s] of one compiled Taylor evaluation of each Newton stage residual per iterate, all nodes at once
    (the plan's own programs, at each iterate's working order, on its solution): the planner's time over this
    is how many such evaluations a plan costs.  None on the numpy path (no programs)."""
    from planners.series import BACKEND

    total = 0.0
    found = False
    for it in plan.iterates:
        cached = getattr(it, "_inputs", None) or {}
        programs = cached.get("programs") or {}
        data = dict(cached.get("known", {}))
        data.update(cached.get("derivs", {}))
        for n in it:
            data[n] = it[n]
            if it[n].order >= 1:
                data[n + "'"] = it[n].derivative()
        for h, (prog, _why) in programs.items():
            if not isinstance(h, int) or prog is None or any(n not in data for n in prog.data_names):
                continue  # the Newton stages only (a closed-form stage's program is keyed ("solve", h))
            from planners.flat import aircraft_system

            unknowns = aircraft_system(plan.problem).stages[h - 1].unknowns
            k = it.order - h
            if any(u not in it for u in unknowns):
                continue
            nodes = len(plan.t_nodes)
            x = np.zeros((len(unknowns), k + 1, nodes))
            for j, u in enumerate(unknowns):
                c = it[u]._c
                m = min(c.shape[0], k + 1)
                x[j, :m] = c[:m]
            d = prog.data_array(data, k, nodes)
            if BACKEND == "native":  # the evaluator the plans ran on
                nat = prog.native()

                def evaluate(x=x, d=d, k=k, nat=nat):
                    return nat.evaluate(x, d, k + 1)

            else:

                def evaluate(x=x, d=d, prog=prog):
                    return prog.residual(x, d)

            evaluate()
            ts = []
            for _ in range(repeat):
                t0 = time.perf_counter()
                evaluate()
                ts.append(time.perf_counter() - t0)
            total += min(ts)
            found = True
    return total if found else None


def bench_scenario(
    name: str,
    factors=DEFAULT_FACTORS,
    repeat: int = 3,
    finer=FINER_FACTORS,
    graphs=GRAPHS,
    guesses=tuple(GUESSES),
    log=print,
    J=None,
    step=None,
    e=None,
) -> dict:
    """Time and accuracy of the planner and of collocation on grids of a scenario, per initial guess.

    Parameters
    ----------
    name : str
        Bundled scenario name (or path).
    factors : sequence of float
        Interval lengths of the collocation grids over the scenario's node step.
    repeat : int
        Interleaved repetitions (medians are reported).
    finer : sequence of float
        Factors tried in turn when no grid of ``factors`` reaches the planner's accuracy (per guess),
        as long as the finest grid so far converged and its open-loop flight finished.
    graphs : sequence of str
        CasADi graphs timed (``"MX"``, ``"SX"``); the comparison takes the quicker of them.
    guesses : sequence of str
        Initial guesses (keys of :data:`GUESSES`: ``"plan-j0"``, ``"trim"``).
    log : callable
        Progress messages.
    J : int, "auto" or None
        The planner's J (None: the scenario's bundled setting); ``"auto"`` plans with the convergence
        test (:func:`planners.generalized.choose_J`), the planner's most accurate setting.
    step : float, optional
        The planner's node step [s] instead of the scenario's; the collocation grids' intervals are
        ``factors`` times this step (so both methods are compared on the problem as planned).
    e : int, optional
        The planner's output order e (paper section "From calibration to time varying controls")
        instead of the scenario's.

    Returns
    -------
    dict
        ``planner``: time (CPU, wall medians) [s] and accuracy [m]; ``guesses``: per guess its
        description and time (median, counted in every collocation time below), ``grids`` (per factor
        the intervals, points, variables, IPOPT's status and iterations, per graph the guess / build /
        solve / re-solve medians [s], the accuracy [m]) and ``matched`` (the cheapest successful grid at
        least as accurate as the planner, and the time ratios over the planner, the quicker graph; None
        when no grid is) and ``most_accurate`` (the same for the most accurate grid that converged and flew,
        whatever its accuracy: what collocation's best costs where it does not reach the planner's).
    """
    from planners.generalized import plan_scenario
    from planners.scenario import load_scenario
    from planners.series import BACKEND
    from planners.verify import open_loop_error

    _require_casadi()
    sc = load_scenario(name)
    if step is not None or e is not None:
        changed = {k: v for k, v in (("step", step), ("e", e)) if v is not None}
        label = ", ".join(f"{k} {v:g}" for k, v in changed.items())
        sc = dataclasses.replace(sc, name=f"{sc.name} ({label})", **changed)
    plan = plan_scenario(sc, J=J)  # warm-up, and the accuracy (deterministic)
    # The same flight as collocation's (restarted at the control breaks, the planner's nodes); the
    # flight of planners.verify in one piece is kept alongside (it agrees for the planner's controls).
    planner_acc = open_loop_error_of(sc, plan.control_function(), plan.initial_state())
    check = open_loop_error(plan)
    out = {
        "scenario": sc.name,
        "step_s": sc.step,
        "span_s": sc.t1 - sc.t0,
        "planner": {
            "J": plan.J,
            "J_setting": "bundled" if J is None else J,
            "nodes": len(plan.t_nodes),
            "accuracy_m": planner_acc,
            "accuracy_one_piece_m": check.max_position_error_m,
            "series_backend": BACKEND,
            "feasible": bool(plan.feasible),
            "settings": {k: getattr(plan, k) for k in ("e",) if hasattr(plan, k)},
        },
        "guesses": {},
    }
    log(f"{sc.name}: planner J = {plan.J}, accuracy {planner_acc:.3g} m")
    prebuilt: dict[tuple[str, float, str], CollocationProblem] = {}

    def add_grid(gname, grids, f):
        row = {"factor": f}
        sols = {}
        for graph in graphs:
            prob = CollocationProblem(sc, f, GUESSES[gname](sc), graph=graph)
            sols[graph] = prob.solve()
            prebuilt[gname, f, graph] = prob
        sol = sols[graphs[0]]
        acc = open_loop_error_of(sc, sol.control_function, sol.initial_state) if sol.domain is None else float("nan")
        # The one-piece flight of planners.verify (for the record: on fine grids it measures its own error).
        one = (
            verify.open_loop_check(
                sc.problem(), sol.control_function, sol.initial_state, verification_grid(sc)
            ).max_position_error_m
            if sol.domain is None and np.isfinite(acc)
            else float("nan")
        )
        spread = max(float(np.max(np.abs(s.controls - sol.controls))) for s in sols.values())
        row.update(
            {
                "intervals": prob.n_intervals,
                "points": prob.P,
                "variables": prob.n_variables,
                "constraints": prob.n_constraints,
                "accuracy_m": acc,
                "accuracy_one_piece_m": one,
                "success": all(s.success for s in sols.values()),
                "status": sol.status,
                "iterations": sol.iterations,
                "iterations_by_graph": {g: s.iterations for g, s in sols.items()},
                "constraint_violation": sol.constraint_violation,
                "domain": sol.domain,
                "graphs_max_control_difference": spread,
                "times": {g: {k: [] for k in ("guess", "build", "solve", "scratch", "resolve")} for g in graphs},
            }
        )
        grids[f] = row
        # A NaN accuracy: the solution's points or its open-loop flight leave the domain (_grid_note's words).
        acc_text = (
            f"{acc:.3g} m"
            if np.isfinite(acc)
            else "n/a (solution outside the domain)"
            if sol.domain
            else "n/a (open loop leaves the domain)"
        )
        log(
            f"  {gname}: grid {f:g} x step: {prob.n_intervals} intervals, accuracy {acc_text}, {sol.status}, "
            f"{sol.iterations} iterations" + (f"; solution outside the domain: {sol.domain}" if sol.domain else "")
        )

    by_guess: dict[str, dict] = {}
    for gname in guesses:
        if gname not in GUESSES:
            raise ValueError(f"unknown initial guess {gname!r}; choose from {', '.join(GUESSES)}")
        grids: dict[float, dict] = {}
        for f in factors:
            add_grid(gname, grids, float(f))
        for f in finer:
            # Finer grids buy accuracy, not convergence: none after a grid that failed or does not fly.
            last = grids[min(grids)]
            if any(g["success"] and g["accuracy_m"] <= planner_acc for g in grids.values()) or not (
                last["success"] and np.isfinite(last["accuracy_m"])
            ):
                break
            add_grid(gname, grids, float(f))
        by_guess[gname] = {"grids": grids, "guess_times": []}

    # Each collocation time includes its initial guess (computed afresh: it is part of every new
    # problem's solve): built from scratch = guess + build (guess at the points) + solve, re-solved =
    # guess + the pre-built solver's solve from it.
    planner_t, numpy_t = [], []
    floor = floor_estimate(plan)
    for _ in range(repeat):
        start = _clock()
        plan_scenario(sc, J=J)
        planner_t.append(_since(start))
        if BACKEND != "numpy":
            with _numpy_reference():
                plan_scenario(sc, J=J)  # its own warm-up is the first repetition's (numpy has no compile)
                start = _clock()
                plan_scenario(sc, J=J)
                numpy_t.append(_since(start))
        for gname in guesses:
            make_guess = GUESSES[gname]
            for f, g in by_guess[gname]["grids"].items():
                for graph in graphs:
                    tt = g["times"][graph]
                    start = _clock()
                    guess = make_guess(sc)
                    gt = _since(start)
                    start = _clock()
                    prob = CollocationProblem(sc, f, guess, graph=graph)
                    build = _since(start)
                    start = _clock()
                    prob.solve()
                    solve = _since(start)
                    tt["build"].append(build)
                    tt["solve"].append(solve)
                    tt["scratch"].append((gt[0] + build[0] + solve[0], gt[1] + build[1] + solve[1]))
                    pre = prebuilt[gname, f, graph]
                    start = _clock()
                    pre.set_guess(make_guess(sc))
                    gt2 = _since(start)
                    start = _clock()
                    pre.solve()
                    resolve = _since(start)
                    tt["guess"].append(gt2)
                    tt["resolve"].append((gt2[0] + resolve[0], gt2[1] + resolve[1]))
    out["planner"]["time_cpu_s"], out["planner"]["time_wall_s"] = _median(planner_t)
    p = out["planner"]
    if numpy_t:
        p["numpy_time_cpu_s"], p["numpy_time_wall_s"] = _median(numpy_t)
    p["floor_s"] = floor
    for gname in guesses:
        grids = by_guess[gname]["grids"]
        rows = []
        for f in sorted(grids):
            g = grids[f]
            for graph in graphs:
                tt = g["times"][graph]
                for key in ("guess", "build", "solve", "scratch", "resolve"):
                    tt[f"{key}_cpu_s"], tt[f"{key}_wall_s"] = _median(tt.pop(key))
            for key in ("scratch", "resolve"):
                for clock in ("cpu", "wall"):
                    best = min(graphs, key=lambda gn: g["times"][gn][f"{key}_{clock}_s"])
                    g[f"{key}_{clock}_s"] = g["times"][best][f"{key}_{clock}_s"]
                    g[f"{key}_{clock}_graph"] = best
            rows.append(g)
        gtimes = [g["times"][graph][f"guess_{c}_s"] for g in rows for graph in graphs for c in ("cpu", "wall")]
        res = {
            "what": GUESS_TEXT[gname],
            "counted_in_times": True,
            "time_cpu_s": statistics.median(gtimes[0::2]) if gtimes else float("nan"),
            "time_wall_s": statistics.median(gtimes[1::2]) if gtimes else float("nan"),
            "grids": rows,
        }
        if gname == "trim":
            tr = GUESSES[gname](sc).trim
            res["trim"] = {
                "fixed": tr.fixed,
                "values": tr.values,
                "altitude_m": tr.altitude,
                "eta": tr.eta,
                "warnings": list(tr.warnings),
            }
        flown = [g for g in rows if g["success"] and np.isfinite(g["accuracy_m"])]
        ok = [g for g in flown if g["accuracy_m"] <= planner_acc]
        res["matched"] = _against_planner(min(ok, key=lambda g: g["resolve_wall_s"]), p) if ok else None
        # Where no grid matches: collocation's most accurate grid, for the time it takes to get there.
        res["most_accurate"] = _against_planner(min(flown, key=lambda g: g["accuracy_m"]), p) if flown else None
        same = [g for g in rows if g["factor"] == 1.0]
        if same:
            res["same_grid_accuracy_m"] = same[0]["accuracy_m"]
        out["guesses"][gname] = res
    return out


def _against_planner(g: dict, p: dict) -> dict:
    """A grid's accuracy and its times over the planner's (re-solved, built from scratch; wall and CPU)."""
    return {
        "factor": g["factor"],
        "accuracy_m": g["accuracy_m"],
        "iterations": g["iterations"],
        "resolve_over_planner_wall": g["resolve_wall_s"] / p["time_wall_s"],
        "resolve_over_planner_cpu": g["resolve_cpu_s"] / p["time_cpu_s"],
        "scratch_over_planner_wall": g["scratch_wall_s"] / p["time_wall_s"],
        "scratch_over_planner_cpu": g["scratch_cpu_s"] / p["time_cpu_s"],
    }


def _ratio_text(m: dict) -> str:
    return (
        f"grid {m['factor']:g}x ({m['accuracy_m']:.3g} m): re-solved / planner = "
        f"{m['resolve_over_planner_wall']:.2f} wall ({m['resolve_over_planner_cpu']:.2f} CPU), built from scratch / "
        f"planner = {m['scratch_over_planner_wall']:.2f} wall ({m['scratch_over_planner_cpu']:.2f} CPU)"
    )


def _grid_note(g: dict) -> str:
    """IPOPT's status when it is not success, and a solution outside the physical domain."""
    note = "" if g["success"] else f" {g['status']}"
    if g.get("domain"):
        note += " (solution outside the domain)"
    elif not np.isfinite(g["accuracy_m"]):
        note += " (open loop leaves the domain)"
    return note


def format_table(res: dict) -> str:
    """The table of one scenario's results (medians: wall time, CPU time in parentheses).

    Parameters
    ----------
    res : dict
        A result of :func:`bench_scenario`.

    Returns
    -------
    str
    """
    p = res["planner"]
    lines = [
        f"{res['scenario']} (node step {res['step_s']:g} s, span {res['span_s']:g} s); times: median wall "
        f"(CPU) [s]; every collocation time includes its initial guess",
        f"  planner J={p['J']} ({p.get('J_setting', 'bundled')}), {p['nodes']} nodes, series backend {p.get('series_backend', '?')}: "
        f"{p['time_wall_s']:.3f} ({p['time_cpu_s']:.3f}), "
        f"open-loop accuracy {p['accuracy_m']:.3g} m",
    ]
    if p.get("numpy_time_wall_s") is not None:
        lines.append(
            f"  planner on the numpy reference (same run): {p['numpy_time_wall_s']:.3f} ({p['numpy_time_cpu_s']:.3f}), "
            f"numpy / {p.get('series_backend', '?')} {p['numpy_time_wall_s'] / p['time_wall_s']:.2f} wall "
            f"({p['numpy_time_cpu_s'] / p['time_cpu_s']:.2f} CPU)"
        )
    if p.get("floor_s"):
        lines.append(
            f"  floor: one compiled Taylor evaluation of each Newton stage per iterate, all nodes, {p['floor_s'] * 1e3:.3f} ms; "
            f"plan / floor {p['time_wall_s'] / p['floor_s']:.0f} wall ({p['time_cpu_s'] / p['floor_s']:.0f} CPU)"
        )
    for gname, gres in res["guesses"].items():
        graphs = list(gres["grids"][0]["times"]) if gres["grids"] else []
        lines += [
            f"  initial guess {gname}: {gres['what']}; {gres['time_wall_s']:.3f} ({gres['time_cpu_s']:.3f})",
            f"  {'grid':>6} {'interv.':>7} {'vars':>6} "
            + " ".join(f"{k + ' ' + gn:>16}" for k in ("build", "solve", "re-solve") for gn in graphs)
            + f" {'accuracy [m]':>12} {'it':>4}",
        ]
        for g in gres["grids"]:
            cells = []
            for key in ("build", "solve", "resolve"):
                for gn in graphs:
                    tt = g["times"][gn]
                    cells.append(f"{tt[key + '_wall_s']:.3f} ({tt[key + '_cpu_s']:.3f})")
            lines.append(
                f"  {g['factor']:>5g}x {g['intervals']:>7} {g['variables']:>6} "
                + " ".join(f"{c:>16}" for c in cells)
                + f" {g['accuracy_m']:>12.3g} {g['iterations']:>4}"
                + _grid_note(g)
            )
        m, best = gres["matched"], gres.get("most_accurate")
        if m:
            lines.append(f"  matched accuracy ({gname}): {_ratio_text(m)}")
        else:
            lines.append(
                f"  matched accuracy ({gname}): no successful collocation grid reached the planner's accuracy"
                + (f"; the most accurate, {_ratio_text(best)}" if best else "")
            )
    return "\n".join(lines)


def markdown_table(results: list) -> str:
    """One Markdown table of every scenario's results (for the note and ``docs/collocation.md``).

    Parameters
    ----------
    results : list of dict
        Results of :func:`bench_scenario`.

    Returns
    -------
    str
        Per scenario a planner row and per initial guess one row per grid: intervals, NLP variables,
        IPOPT iterations (and status when not success), built-from-scratch and re-solve times (median wall
        (CPU) [s], the initial guess included, the quicker graph), open-loop accuracy; then the ratios at
        matched accuracy per guess.
    """

    def t(x, key):
        return f"{x[key + '_wall_s']:.3f} ({x[key + '_cpu_s']:.3f})"

    lines = [
        "| scenario | solver | intervals | NLP variables | IPOPT iterations | built from scratch [s] | "
        "re-solve [s] | open-loop accuracy [m] |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in results:
        p = r["planner"]
        lines.append(
            f"| {r['scenario']} | planner J = {p['J']} | {p['nodes'] - 1} | | | "
            f"{t(p, 'time')} | | {p['accuracy_m']:.2g} |"
        )
        for gname, gres in r["guesses"].items():
            for g in gres["grids"]:
                lines.append(
                    f"| | collocation {g['factor']:g}x, guess {gname} | {g['intervals']} | "
                    f"{g['variables']} | {g['iterations']}{_grid_note(g)} | "
                    f"{t(g, 'scratch')} {g['scratch_wall_graph']} | "
                    f"{t(g, 'resolve')} {g['resolve_wall_graph']} | {g['accuracy_m']:.2g} |"
                )
    lines += [
        "",
        "| scenario | planner | initial guess (its time, included) | matched grid | re-solved / planner | "
        "built from scratch / planner |",
        "|---|---|---|---|---|---|",
    ]
    for r in results:
        p = r["planner"]
        for gname, gres in r["guesses"].items():
            m = gres["matched"]
            head = (
                f"| {r['scenario']} | {p['time_wall_s']:.3f} s, {p['accuracy_m']:.2g} m | {gname} "
                f"({gres['time_wall_s']:.3f} s) |"
            )
            best = gres.get("most_accurate")
            shown, label = (m, "") if m else (best, "none; most accurate: ")
            if shown:
                lines.append(
                    f"{head} {label}{shown['factor']:g}x, {shown['accuracy_m']:.2g} m, {shown['iterations']} it. | "
                    f"{shown['resolve_over_planner_wall']:.2f} wall ({shown['resolve_over_planner_cpu']:.2f} CPU) | "
                    f"{shown['scratch_over_planner_wall']:.2f} wall ({shown['scratch_over_planner_cpu']:.2f} CPU) |"
                )
            else:
                lines.append(f"{head} none | | |")
    return "\n".join(lines)


#: Largest number of planner nodes or collocation intervals a grid may have (``--step``, ``--factors``).
MAX_NODES = 10000


def _positive_factors(text: str) -> list[float]:
    """``--factors``: a nonempty comma-separated list of positive finite numbers."""
    parts = [v.strip() for v in text.split(",")]
    try:
        values = [float(v) for v in parts]
    except ValueError:
        raise argparse.ArgumentTypeError(f"positive numbers separated by commas, got {text!r}") from None
    if not values or not all(np.isfinite(v) and v > 0 for v in values):
        raise argparse.ArgumentTypeError(f"positive finite numbers separated by commas, got {text!r}")
    return values


def _check_writable(ap, flag: str, path: str | None) -> None:
    """An output file that can be written: its folder exists, it is not a folder, a probe opens it."""
    if path is None:
        return
    p = Path(path)
    if not path.strip() or p.is_dir():
        ap.error(f"{flag}: {path!r} is a folder or empty; give a file")
    if not p.parent.is_dir():
        ap.error(f"{flag}: the folder {str(p.parent)!r} of {path!r} does not exist")
    existed = p.exists()
    try:
        with open(p, "a", encoding="utf-8"):
            pass
    except OSError as exc:
        where = "" if existed else f" (no new file can be made in {str(p.parent)!r})"
        ap.error(f"{flag}: cannot write {path!r}{where}: {exc.strerror or exc}")
    if not existed:
        p.unlink(missing_ok=True)


def _check_arguments(ap, args):
    """Every argument checked before any work (one usage line, exit 2); returns J and the graphs."""
    from planners.flat import MAX_J
    from planners.generalized import MAX_E
    from planners.scenario import load_scenario

    J = args.J
    if J is not None and J != "auto":
        if not J.isdigit() or int(J) > MAX_J:
            ap.error(f"--J: a whole number from 0 to {MAX_J} or auto, got {J!r}")
        J = int(J)
    if args.e is not None and not 0 <= args.e <= MAX_E:
        ap.error(f"--e: a whole number from 0 to {MAX_E} (the planner's largest output order), got {args.e!r}")
    if args.repeat < 1:
        ap.error(f"--repeat: at least 1, got {args.repeat}")
    graphs = tuple(v.strip() for v in args.graphs.split(","))
    if not graphs or any(g not in ("MX", "SX") for g in graphs):
        ap.error(f"--graphs: MX, SX or MX,SX, got {args.graphs!r}")
    if args.step is not None and not (np.isfinite(args.step) and args.step > 0):
        ap.error(f"--step: a positive number of seconds, got {args.step!r}")
    for name in args.scenarios:
        try:
            sc = load_scenario(name)
        except Exception as exc:  # noqa: BLE001 -- the scenario loader's one-line error, as a usage error
            ap.error(f"--scenarios: {name}: {exc}")
        span = sc.t1 - sc.t0
        step = sc.step if args.step is None else args.step
        if args.step is not None:
            nodes = span / step
            if step > span:
                ap.error(f"--step: {step:g} s is longer than the {span:g} s span of {sc.name}")
            if abs(nodes - round(nodes)) > 1e-9 * nodes:
                ap.error(
                    f"--step: {step:g} s does not divide the {span:g} s span of {sc.name} "
                    f"({nodes:.6g} steps); give a divisor"
                )
            if nodes > MAX_NODES:
                ap.error(
                    f"--step: {step:g} s makes {nodes:.3g} nodes over the {span:g} s span of {sc.name}, "
                    f"above {MAX_NODES}"
                )
        factors = [8.0] if args.quick else args.factors
        worst = max(span / (step * f) for f in factors)
        if worst > MAX_NODES:
            ap.error(
                f"--factors: {min(factors):g} x the {step:g} s step makes {worst:.3g} collocation intervals "
                f"over the {span:g} s span of {sc.name}, above {MAX_NODES}"
            )
    _check_writable(ap, "--json", args.json)
    _check_writable(ap, "--markdown", args.markdown)
    return J, graphs


def main(argv=None) -> None:
    """Run the benchmark from the command line; Ctrl-C stops it with one line, exit status 130; a plan that
    cannot be made (the planner's one-line error) exits 1."""
    from gna.errors import GflatError

    try:
        _main(argv)
    except KeyboardInterrupt:
        print("bench_collocation: interrupted", file=sys.stderr)
        sys.exit(130)
    except GflatError as exc:  # the planner cannot plan these settings (a diverging J, a singular output)
        print(f"bench_collocation: error: {exc}", file=sys.stderr)
        sys.exit(1)


def _main(argv=None) -> None:
    os.environ.setdefault("GFLAT_NATIVE_WAIT", "1")  # the planner's native library compiled before it is timed
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenarios", nargs="+", default=list(SCENARIOS))
    ap.add_argument("--repeat", type=int, default=5, help="interleaved repetitions (medians)")
    ap.add_argument(
        "--factors",
        type=_positive_factors,
        default=list(DEFAULT_FACTORS),
        help="collocation interval / scenario node step, comma-separated",
    )
    ap.add_argument("--quick", action="store_true", help="smoke run: one repetition, the 8x grid only, no finer")
    ap.add_argument("--graphs", default="MX,SX", help="CasADi graphs timed, comma-separated (MX, SX)")
    ap.add_argument(
        "--guess",
        default=",".join(GUESSES),
        help="initial guesses, comma-separated: plan-j0 (the planner's J = 0 plan), trim (flat outputs, "
        "their kinematics and a trim at the start); default: both",
    )
    ap.add_argument(
        "--J",
        dest="J",
        default=None,
        help="the planner's J: a whole number or auto (the convergence test); default: the scenario's",
    )
    ap.add_argument(
        "--step",
        type=float,
        default=None,
        help="the planner's node step [s] (default: the scenario's); the grids' factors are relative to it",
    )
    ap.add_argument(
        "--e", dest="e", type=int, default=None, help="the planner's output order e (default: the scenario's)"
    )
    ap.add_argument("--json", help="write the results to this JSON file")
    ap.add_argument("--markdown", help="write the results as a Markdown table to this file")
    args = ap.parse_args(argv)
    J, graphs = _check_arguments(ap, args)
    _require_casadi()
    factors = args.factors
    guesses = tuple(v.strip() for v in args.guess.split(",") if v.strip())
    unknown = [v for v in guesses if v not in GUESSES]
    if unknown or not guesses:
        ap.error(f"--guess: unknown {', '.join(unknown) or 'empty list'}; choose from {', '.join(GUESSES)}")
    finer = FINER_FACTORS
    repeat = args.repeat
    if args.quick:
        factors, finer, repeat = [8.0], (), 1
    results = []
    for name in args.scenarios:
        res = bench_scenario(name, factors, repeat, finer, graphs, guesses, J=J, step=args.step, e=args.e)
        print(format_table(res), flush=True)
        results.append(res)
    if args.markdown:
        with open(args.markdown, "w", encoding="utf-8") as fh:
            fh.write(markdown_table(results) + "\n")
    if args.json:
        meta = {
            "repeat": repeat,
            "scheme": f"Legendre-Gauss-Radau degree {DEGREE}",
            "ipopt_tol": IPOPT_TOL,
            "constr_viol_tol": CONSTR_VIOL_TOL,
            "linear_solver": "mumps",
            "ipopt_options": f"tol {IPOPT_TOL:g}, constr_viol_tol {CONSTR_VIOL_TOL:g}, MUMPS, the rest defaults",
            "guesses": {g: GUESS_TEXT[g] for g in guesses},
            "casadi": ca.CasadiMeta.version(),
            "cpu_count": os.cpu_count(),
            "loadavg": os.getloadavg(),
            "date_utc": time.strftime("%Y-%m-%d %H:%M", time.gmtime()),
        }
        with open(args.json, "w", encoding="utf-8") as fh:
            json.dump({"meta": meta, "results": results}, fh, indent=2)


if __name__ == "__main__":
    main()
