"""A robust tracking design beside the paper's: finite-horizon time-varying LQR along the plan.

The paper's feedback (:mod:`planners.tracking`) places the poles of each position-error integral by
sequential decoupling, frozen at every node.  This module gives the second design selectable by
``[tracking] design = "lqr"``: the same plan, the same integral states and the same feedforward,
gains from a Riccati equation integrated backwards along the plan's own linearization.

Augmented error system
----------------------
With ``dx = x - x~(t)`` (12 states, angles wrapped), the integrals ``I`` of the paper
(:func:`planners.tracking.aircraft_model`: ``I1 = int cos chi~ dx + sin chi~ dy``,
``I2 = int -sin chi~ dx + cos chi~ dy``, ``I3 = int dz``, ``I4 = int d zeta``; no ``I4`` with the
thrust output) and, when the engine has a thrust time constant ``tau``, the thrust deviation
``e_F = F_actual - F~`` of a first-order engine ``F_actual' = (F_cmd - F_actual) / tau``::

    z = (dx, I[, e_F]),    z' = A(t) z + B(t) v

``A``, ``B``: the Jacobians of the full model along the plan (:func:`planners.tracking.linearize`
``model="full"``, series of order 1 at the nodes, C^1 cubic Hermite between nodes); ``v`` the
deviations of the feedback inputs of the paper's design (``F, dl, dm, dn``, ``eta`` in place of
``dn`` with a fixed rudder; ``dl, dm, dn`` with the thrust output); with a lag ``v_F`` drives
``e_F`` (``e_F' = (v_F - e_F) / tau``) and ``e_F`` enters the states where ``F`` did.

Riccati equation (Anderson & Moore, *Optimal Control: Linear Quadratic Methods*, Prentice Hall
1990, ch. 3, eqs. 3.2-3.3)::

    -P' = A' P + P A - P B R^-1 B' P + Q,     P(t1) = P_f,     v = -R^-1 B' P z

integrated backwards from ``t1`` to ``t0`` as a matrix ODE (``scipy.integrate.solve_ivp``, explicit
Dormand-Prince 5(4), dense output, P symmetrised), and sampled on the controller's grid
(:data:`GAIN_STEP`).  ``P_f`` is the stabilising solution of the algebraic Riccati equation of the
linearization frozen at ``t1`` (``scipy.linalg.solve_continuous_are``; ``Q`` when it has none): the
gains then stay those of an infinite-horizon loop up to the end of the plan instead of fading to 0 as
with ``P_f = 0``, and the last 20 % of the span, where the tracking is judged, is flown with full gains.

Weights (Bryson's rule; Bryson & Ho, *Applied Optimal Control*, 1975, sec. 5.4)
---------------------------------------------------------------------------
``Q`` and ``R`` diagonal, ``Q_ii = 1 / (largest acceptable error of state i)^2``,
``R_jj = 1 / (range of input j)^2``, nothing tuned per scenario:

* errors (:class:`TrackingTolerances`, the scenario's ``[tracking] tolerances``, defaults
  :data:`DEFAULT_TOLERANCES`): position ``x, y, z`` (the tracking criterion, 1 m), speed ``V``,
  angles ``gamma, chi, alpha, beta, mu``, rates ``p, q, r``; the integrals ``I1..I3`` the position
  tolerance held for :data:`INTEGRAL_TIME` s, ``I4`` the angle tolerance for as long; the thrust
  deviation ``e_F`` the thrust range;
* ranges: each surface its deflection limit (``aircraft.envelope.control_limits``), the thrust
  ``propulsion.max_thrust`` (the weight ``m g`` for an unrated engine), ``eta`` 1; for a loop that clips
  its commands at the limits (``saturate``), the smaller of that and the room the feedback has in both
  directions along the plan, ``min_t min(u~ - lower, upper - u~)`` (:func:`feedforward_room`): the
  feedback input is the deviation from the feedforward, and beyond the room one direction saturates.
  The aileron roll flies 5.9-28 N of its GTM's 136 N: sized by the rating, the thrust gains answered a
  2 m lag with up to +126 N, and the aircraft, then 2.9 m/s too fast, had 6 N of thrust to brake with
  (docs/tracking.md).  Where the plan touches or leaves a limit (no room), the limit's size.

Initial integrals
-----------------
The integrals are the controller's own states, free at ``t0``.  Started at zero, the loop must bring
``int dx`` back to zero, so an initial offset is answered by an overshoot of the same area (measured on a
dispersed aileron roll, 2 m off: ``y`` +2.1 -> -1.0 m, ``z`` +1.9 -> -0.9 m).  They start where the
cost-to-go ``z' P(t0) z`` of the initial error is least::

    I(t0) = -P_II(t0)^-1 P_Ix(t0) dx(t0)

(``P`` partitioned into the model's states ``x`` and the integrals ``I``; ``e_F`` starts at 0, the engine
at the plan's thrust): zero when the aircraft starts on the plan, so a loop flying a model error alone is
unchanged.

Anti-windup: back-calculation (Astrom & Hagglund, *Advanced PID Control*, ISA 2006, sec. 3.5; in state
space, Astrom & Murray, *Feedback Systems*, 2008, sec. 11.4).  While a command ``u_cmd`` exceeds its
limit, the integrals get ``I' = C dx - Gamma (u_cmd - sat(u_cmd))`` with ``K_I Gamma = 1 / T_t``
(``K_I`` the gains of the integrals, least squares; ``T_t`` = :data:`TRACKING_TIME`): the integral
part of the command returns to the limit with time constant ``T_t``.  Back-calculation, not the
paper's conditional integration, because the LQR has no decoupling stages (every integral acts on
every input) and because its correction is continuous in the state: switching integrals on and off
made the in-house integrator stall, chattering at a limit (measured on the aileron roll with a
5 m / 1 m/s / 1 deg offset).

Thrust lag: ``Propulsion.thrust_lag`` [s] when the aircraft data give one (measured engine response;
0 or absent: immediate thrust).  The controller then carries ``e_F`` as a state (the engine model run
on the applied command, the thrust being unmeasured) and commands ``F~ + tau F~' + v_F``: the lead
``tau F~'`` makes a first-order engine deliver the plan's thrust.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from gna.eom import CONTROL_NAMES, STATE_NAMES
from gna.errors import DomainError, InputError
from gna.piecewise import PiecewisePolynomial

from .plan import Plan, interval_coefficients
from .series import Series
from .tracking import _ANGLE_IDX, _TWO_PI, TrackingController, _horner, linearize, plan_model

#: The two tracking designs, ``[tracking] design`` and ``--tracking``.
DESIGNS: tuple[str, ...] = ("paper", "lqr")

#: Largest acceptable tracking errors of Bryson's rule when a scenario sets none: position 1 m (the
#: tracking criterion, < 1 m after the settle time), speed 1 m/s, angles 1 deg, rates 1 rad/s (a rate is
#: no flat output: it is bounded by the manoeuvre, the roll turns at pi/2 rad/s; at 5 deg/s the rate
#: weights put the closed loop's fastest poles at 70-430 rad/s, beyond any surface actuator).
DEFAULT_TOLERANCES: dict[str, float] = {
    "position": 1.0,
    "velocity": 1.0,
    "angle": math.radians(1.0),
    "rate": 1.0,
}

#: Seconds the tolerated error is held to make the tolerated integral (Bryson's rule on I1..I4) [s].
INTEGRAL_TIME = 1.0

#: Tracking time constant of the anti-windup's back-calculation [s] (Astrom & Hagglund 2006, sec. 3.5): the
#: integrals are pulled back so that the commanded input returns to its limit at this rate.
TRACKING_TIME = 1.0

#: Largest step of the gain grid [s]: each plan interval is cut into equal pieces no longer than this,
#: the gains are cubic Hermite on each piece (values and derivatives from the Riccati equation).
GAIN_STEP = 0.25

_QUANTITY_OF = {
    "x": "position",
    "y": "position",
    "z": "position",
    "V": "velocity",
    "gamma": "angle",
    "chi": "angle",
    "alpha": "angle",
    "beta": "angle",
    "mu": "angle",
    "p": "rate",
    "q": "rate",
    "r": "rate",
}


@dataclass(frozen=True)
class TrackingTolerances:
    """Largest acceptable tracking errors (the ``[tracking] tolerances`` of a scenario), SI units.

    Attributes
    ----------
    position : float
        [m] (x, y, z).
    velocity : float
        [m/s] (V).
    angle : float
        [rad] (gamma, chi, alpha, beta, mu).
    rate : float
        [rad/s] (p, q, r).

    Raises
    ------
    InputError
        A value that is not a positive finite number.
    """

    position: float = DEFAULT_TOLERANCES["position"]
    velocity: float = DEFAULT_TOLERANCES["velocity"]
    angle: float = DEFAULT_TOLERANCES["angle"]
    rate: float = DEFAULT_TOLERANCES["rate"]

    def __post_init__(self):
        for k in DEFAULT_TOLERANCES:
            v = getattr(self, k)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not (math.isfinite(v) and v > 0):
                raise InputError(f"tracking tolerance {k} must be a positive finite number, got {v!r}")
            object.__setattr__(self, k, float(v))

    def to_dict(self) -> dict:
        """The four tolerances by quantity.

        Returns
        -------
        dict
            ``{"position": m, "velocity": m/s, "angle": rad, "rate": rad/s}``.
        """
        return {k: getattr(self, k) for k in DEFAULT_TOLERANCES}


def thrust_lag(aircraft) -> float | None:
    """The engine's thrust time constant [s] from the aircraft data, or None (immediate thrust).

    Reads ``aircraft.propulsion.thrust_lag`` (the measured first-order response of the engine) when the
    aircraft data carry one; 0 or absent gives None.

    Parameters
    ----------
    aircraft : gna.aircraft.Aircraft

    Returns
    -------
    float or None
    """
    tau = getattr(aircraft.propulsion, "thrust_lag", None)
    return float(tau) if tau is not None and math.isfinite(tau) and tau > 0 else None


@dataclass
class LQRWeights:
    """Diagonal weights of the LQR and where each comes from.

    Attributes
    ----------
    states : tuple of str
        Augmented states (the model's, the integrals, ``e_F`` with a thrust lag).
    inputs : tuple of str
    Q : ndarray, shape (n,)
        State weights (diagonal).
    R : ndarray, shape (m,)
        Input weights (diagonal).
    errors : ndarray, shape (n,)
        Largest acceptable value of each state (``Q = 1 / errors^2``).
    ranges : ndarray, shape (m,)
        Range of each input (``R = 1 / ranges^2``).
    """

    states: tuple
    inputs: tuple
    Q: np.ndarray
    R: np.ndarray
    errors: np.ndarray
    ranges: np.ndarray


def feedforward_room(plan, inputs, j: int = -1) -> np.ndarray:
    """Room the feedback has in both directions along the plan: ``min_t min(u~ - lower, upper - u~)``.

    ``u~`` the controls of iterate ``j`` (what the loop flies as feedforward) on the grid the plan's limits
    are checked on (:meth:`planners.plan.Plan.limit_frame`: step ``gna.limits.fine_step`` of the smallest
    node step), the limits those the loop clips at (:func:`planners.tracking.tracking_limits`: surface
    limits, thrust ``0 .. max_thrust``, ``|eta| <= 1``).

    Parameters
    ----------
    plan : Plan
        An aircraft plan.
    inputs : sequence of str
        Control names among :data:`gna.eom.CONTROL_NAMES`.
    j : int
        Feedforward iterate.

    Returns
    -------
    ndarray, shape (len(inputs),)
        In the inputs' units (N, rad, 1); ``inf`` for an input without limits, 0 or negative where the
        plan touches or leaves a limit.
    """
    from gna.limits import fine_step

    from .tracking import tracking_limits

    lower, upper = tracking_limits(plan)
    step = fine_step(float(np.min(np.diff(plan.t_nodes))))
    t = np.linspace(plan.t0, plan.t1, int(math.ceil((plan.t1 - plan.t0) / step - 1e-9)) + 1)
    f = plan.control_function(j)
    U = f.evaluate(t) if isinstance(f, PiecewisePolynomial) else np.array([f(x) for x in t]).T  # (5, M)
    out = []
    for u in inputs:
        k = CONTROL_NAMES.index(u)
        out.append(float(np.min(np.minimum(U[k] - lower[k], upper[k] - U[k]))))
    return np.array(out)


def input_ranges(plan, inputs, *, j: int | None = None) -> np.ndarray:
    """Range of each feedback input for Bryson's rule (module notes).

    The size of each limit: surface deflection limits, the thrust rating (the weight ``m g`` for an
    unrated engine), ``|eta| <= 1``.  With ``j`` (a loop that clips its commands at the limits, flying
    iterate ``j`` as feedforward), the smaller of that size and the room the feedback has in both
    directions along the plan (:func:`feedforward_room`): the feedback input is the deviation from the
    feedforward, and a deviation beyond the room saturates.  Where the plan touches or leaves a limit
    (no room), the size.

    Parameters
    ----------
    plan : Plan
        An aircraft plan.
    inputs : sequence of str
        Control names among :data:`gna.eom.CONTROL_NAMES`.
    j : int, optional
        Feedforward iterate of a saturating loop; None: the limits' sizes.

    Returns
    -------
    ndarray, shape (len(inputs),)
        In the inputs' units (N, rad, 1).

    Raises
    ------
    InputError
        A surface without a deflection limit in the aircraft data.
    """
    ac = plan.aircraft
    out = []
    for u in inputs:
        if u == "F":
            mt = ac.propulsion.max_thrust
            out.append(float(mt) if mt is not None else ac.mass.mass * plan.env.g)
        elif u == "eta":
            out.append(1.0)
        else:
            lim = ac.envelope.control_limits.get(u)
            if lim is None:
                raise InputError(
                    f"{ac.id}: no deflection limit for {u} in the aircraft data (the LQR weights need it: "
                    f"R = 1 / range^2, Bryson's rule)"
                )
            out.append(float(lim))
    out = np.array(out)
    if j is not None:
        room = feedforward_room(plan, inputs, j)
        out = np.where(room > 0.0, np.minimum(out, room), out)
    return out


def lqr_weights(
    plan,
    states,
    inputs,
    n_integrals: int,
    tolerances: TrackingTolerances | None = None,
    lag=None,
    *,
    j: int | None = None,
):
    """Bryson's-rule weights of the augmented error system (module notes).

    Parameters
    ----------
    plan : Plan
        An aircraft plan.
    states : sequence of str
        The model's states (:data:`gna.eom.STATE_NAMES`).
    inputs : sequence of str
        Feedback inputs.
    n_integrals : int
        Number of integrals (4, or 3 with the thrust output); the last is the angle ``zeta`` when 4.
    tolerances : TrackingTolerances, optional
        Default :data:`DEFAULT_TOLERANCES`.
    lag : float, optional
        Thrust time constant [s]: adds the state ``e_F`` with the thrust range as its error.
    j : int, optional
        Feedforward iterate of a loop that clips its commands at the limits: the input ranges are the room
        along the plan (:func:`input_ranges`); None: the limits' sizes.

    Returns
    -------
    LQRWeights
    """
    tol = tolerances or TrackingTolerances()
    errors = [getattr(tol, _QUANTITY_OF[s]) for s in states]
    names = list(states) + [f"I{p + 1}" for p in range(n_integrals)]
    errors += [tol.position * INTEGRAL_TIME] * min(3, n_integrals)
    if n_integrals == 4:
        errors.append(tol.angle * INTEGRAL_TIME)
    ranges = input_ranges(plan, inputs, j=j)
    if lag is not None:
        names.append("e_F")
        errors.append(float(ranges[list(inputs).index("F")]))
    errors = np.array(errors, dtype=float)
    return LQRWeights(tuple(names), tuple(inputs), 1.0 / errors**2, 1.0 / ranges**2, errors, ranges)


# --------------------------------------------------------------------------------------------
# The Riccati equation
# --------------------------------------------------------------------------------------------


def solve_riccati(
    A_of, B_of, Q, R, P_final, t_span, t_eval, *, rtol: float = 1e-8, atol: float = 1e-10, method: str = "RK45"
):
    """Integrate the Riccati differential equation backwards (Anderson & Moore 1990, ch. 3).

    ``-P' = A' P + P A - P B R^-1 B' P + Q`` from ``P(t1) = P_final`` down to ``t0``, as a matrix ODE
    (``scipy.integrate.solve_ivp``, default explicit RK45: with Bryson's weights the closed loop's
    fastest modes are 10-30 rad/s, not stiff over 0.1 s steps; LSODA gave the same gains within 5e-8
    of their size, 10-15 times slower), the solution symmetrised.

    Parameters
    ----------
    A_of, B_of : callable
        ``A_of(t)`` (n, n) and ``B_of(t)`` (n, m) [SI].
    Q : ndarray, shape (n, n)
        State weight (symmetric, positive semi-definite).
    R : ndarray, shape (m, m)
        Input weight (symmetric, positive definite).
    P_final : ndarray, shape (n, n)
        Terminal weight.
    t_span : (float, float)
        ``(t0, t1)`` [s], ``t0 < t1``.
    t_eval : ndarray, shape (M,)
        Times [s] within ``t_span`` where P is returned.
    rtol, atol : float
        Integrator tolerances.
    method : str
        ``solve_ivp`` method.

    Returns
    -------
    P : ndarray, shape (M, n, n)
    dP : ndarray, shape (M, n, n)
        ``P'`` at ``t_eval`` (from the equation).

    Raises
    ------
    DomainError
        The integration failed (e.g. a finite escape of P).
    """
    from scipy.integrate import solve_ivp

    n = Q.shape[0]
    Rinv = np.linalg.inv(R)

    def rhs(t, p):
        P = p.reshape(n, n)
        A, B = A_of(t), B_of(t)
        PB = P @ B
        return -(A.T @ P + P @ A - PB @ Rinv @ PB.T + Q).reshape(-1)

    t0, t1 = float(t_span[0]), float(t_span[1])
    sol = solve_ivp(
        rhs,
        (t1, t0),
        np.asarray(P_final, dtype=float).reshape(-1),
        method=method,
        dense_output=True,
        rtol=rtol,
        atol=atol,
    )
    if not sol.success:
        raise DomainError(f"Riccati equation: the backward integration failed at t = {sol.t[-1]:.6g} s: {sol.message}")
    t_eval = np.asarray(t_eval, dtype=float)
    P = sol.sol(np.clip(t_eval, t0, t1)).T.reshape(-1, n, n)
    P = 0.5 * (P + np.swapaxes(P, 1, 2))
    dP = np.array([rhs(t, Pk.reshape(-1)).reshape(n, n) for t, Pk in zip(t_eval, P)])
    return P, dP


# --------------------------------------------------------------------------------------------
# The design along a plan
# --------------------------------------------------------------------------------------------


@dataclass
class LQRDesign:
    """Gains of the time-varying LQR on a grid and what they were computed from.

    Attributes
    ----------
    t : ndarray, shape (M,)
        Gain grid [s] (the plan's nodes, each interval cut into pieces of at most :data:`GAIN_STEP`).
    K : ndarray, shape (M, m, n)
        ``v = K z``: gains at ``t`` (``K = -R^-1 B' P``).
    dK : ndarray, shape (M, m, n)
        Their time derivatives.
    P : ndarray, shape (M, n, n)
        Riccati solution at ``t``.
    weights : LQRWeights
    inputs : tuple of str
    integrals : tuple of str
    lag : float or None
        Thrust time constant designed with [s].
    iterate : int
    A_of, B_of : callable
        The augmented linearization ``A(t)``, ``B(t)``.
    """

    t: np.ndarray
    K: np.ndarray
    dK: np.ndarray
    P: np.ndarray
    weights: LQRWeights
    inputs: tuple
    integrals: tuple
    lag: float | None
    iterate: int
    A_of: object = field(repr=False)
    B_of: object = field(repr=False)

    def initial_integrals(self) -> np.ndarray:
        """Gains of the integrals' least-cost start: ``I(t) = M(t) dx`` with ``M = -P_II^-1 P_Ix`` (module notes).

        Returns
        -------
        ndarray, shape (M, n_I, n_x)
            ``M`` at the gain grid :attr:`t`; ``n_x`` the model's states (12), ``n_I`` the integrals.
        """
        n_i = len(self.integrals)
        n_x = self.P.shape[1] - n_i - (self.lag is not None)
        P_ii = self.P[:, n_x : n_x + n_i, n_x : n_x + n_i]
        P_ix = self.P[:, n_x : n_x + n_i, :n_x]
        return -np.linalg.solve(P_ii, P_ix)


class _Interpolant:
    """Per-interval polynomials of matrix series (C^1 cubic Hermite from order-1 node series); picklable."""

    def __init__(self, t_nodes, series):  # series (N, ..., K)
        N, K = series.shape[0], series.shape[-1]
        flat = series.reshape(N, -1, K)[..., :2]
        self.t = np.asarray(t_nodes, dtype=float)
        self.shape = series.shape[1:-1]
        self.poly = interval_coefficients(flat[:-1], flat[1:], np.diff(self.t), "hermite")  # (N-1, v, 4)
        self.dpoly = self.poly[..., 1:] * np.arange(1, self.poly.shape[-1])

    def _at(self, t, poly):
        i = int(np.clip(np.searchsorted(self.t, t, side="right") - 1, 0, len(self.t) - 2))
        return _horner(poly[i], t - self.t[i]).reshape(self.shape)

    def __call__(self, t):
        return self._at(t, self.poly)

    def derivative(self, t):
        return self._at(t, self.dpoly)


def _grid(t_nodes: np.ndarray, step: float) -> np.ndarray:
    """The plan's nodes with each interval cut into equal pieces of at most ``step``."""
    pieces = [t_nodes[:1]]
    for a, b in zip(t_nodes[:-1], t_nodes[1:]):
        k = max(1, math.ceil((b - a) / step - 1e-9))
        pieces.append(a + (b - a) * np.arange(1, k + 1) / k)
    out = np.concatenate(pieces)
    out[-1] = t_nodes[-1]
    return out


def lqr_design(
    plan, *, j: int = -1, tolerances: TrackingTolerances | None = None, lag="aircraft", saturate: bool = True
) -> LQRDesign:
    """Time-varying LQR gains along an aircraft plan (module notes).

    Parameters
    ----------
    plan : Plan
        An aircraft plan (flat output beta, mu or F).
    j : int
        Iterate linearized about (and tracked).
    tolerances : TrackingTolerances, optional
        Largest acceptable errors of Bryson's rule (default :data:`DEFAULT_TOLERANCES`).
    lag : "aircraft", float or None
        Thrust time constant [s] of the design: ``"aircraft"`` reads :func:`thrust_lag`; None or 0:
        immediate thrust.  Ignored without the thrust input.
    saturate : bool
        The loop clips its commands at the limits: Bryson's input ranges are the room the feedback has
        along the plan (:func:`input_ranges` with ``j``); False: the limits' sizes.

    Returns
    -------
    LQRDesign

    Raises
    ------
    InputError
        Not an aircraft plan, an unsupported flat output, an iterate not in the plan, a surface without limit.
    DomainError
        The Riccati integration failed.
    """
    if not isinstance(plan, Plan):
        raise InputError(f"the LQR tracking design flies aircraft plans, got {type(plan).__name__}")
    ssm = plan_model(plan)
    lin = linearize(plan, j, model="full", order=1)
    inputs = tuple(ssm.inputs)
    tau = thrust_lag(plan.aircraft) if lag == "aircraft" else (float(lag) if lag else None)
    if "F" not in inputs:
        tau = None
    n_x, n_i = len(ssm.states), len(ssm.degrees)
    n = n_x + n_i + (tau is not None)
    m = len(inputs)
    N, K = lin.A.shape[0], lin.A.shape[-1]
    sol = plan.iterates[lin.iterate]
    ref = {name: v.truncate(min(v.order, K - 1)) for name, v in sol.items()}
    A = np.zeros((N, n, n, K))
    A[:, :n_x, :n_x] = lin.A
    for p, row in enumerate(ssm.integrands(ref)):
        for b, c in enumerate(row):
            if isinstance(c, Series):
                cf = np.broadcast_to(np.real(np.asarray(c.coeffs)), (N, c.order + 1))[:, :K]
                A[:, n_x + p, b, : cf.shape[1]] = cf
            else:
                A[:, n_x + p, b, 0] = float(np.real(c))
    B = np.zeros((N, n, m, K))
    B[:, :n_x] = lin.B[:, :, [ssm.controls.index(u) for u in inputs]]
    if tau is not None:  # the engine between the command and the thrust: e_F' = (v_F - e_F) / tau
        kF = inputs.index("F")
        A[:, :n_x, n - 1] = B[:, :n_x, kF]
        B[:, :n_x, kF] = 0.0
        A[:, n - 1, n - 1, 0] = -1.0 / tau
        B[:, n - 1, kF, 0] = 1.0 / tau
    if K < 2:
        A, B = np.concatenate([A, np.zeros_like(A)], -1), np.concatenate([B, np.zeros_like(B)], -1)
    A_of, B_of = _Interpolant(plan.t_nodes, A), _Interpolant(plan.t_nodes, B)
    w = lqr_weights(plan, ssm.states, inputs, n_i, tolerances, tau, j=lin.iterate if saturate else None)
    Q, R = np.diag(w.Q), np.diag(w.R)
    t0, t1 = float(plan.t_nodes[0]), float(plan.t_nodes[-1])
    P_f = terminal_weight(A_of(t1), B_of(t1), Q, R)
    t = _grid(np.asarray(plan.t_nodes, dtype=float), GAIN_STEP)
    P, dP = solve_riccati(A_of, B_of, Q, R, P_f, (t0, t1), t)
    Rinv = np.diag(1.0 / w.R)
    Bt = np.array([B_of(s) for s in t])
    dBt = np.array([B_of.derivative(s) for s in t])
    Kg = -np.einsum("ab,Ncb,Ncd->Nad", Rinv, Bt, P)
    dKg = -np.einsum("ab,Ncb,Ncd->Nad", Rinv, dBt, P) - np.einsum("ab,Ncb,Ncd->Nad", Rinv, Bt, dP)
    return LQRDesign(t, Kg, dKg, P, w, inputs, tuple(f"I{p + 1}" for p in range(n_i)), tau, lin.iterate, A_of, B_of)


def terminal_weight(A: np.ndarray, B: np.ndarray, Q: np.ndarray, R: np.ndarray) -> np.ndarray:
    """Stabilising solution of the algebraic Riccati equation of ``(A, B)`` frozen at the end, else ``Q``.

    Parameters
    ----------
    A : ndarray, shape (n, n)
    B : ndarray, shape (n, m)
    Q : ndarray, shape (n, n)
    R : ndarray, shape (m, m)

    Returns
    -------
    ndarray, shape (n, n)
    """
    from scipy.linalg import solve_continuous_are

    try:
        P = solve_continuous_are(A, B, Q, R)
    except (np.linalg.LinAlgError, ValueError):
        return Q.copy()
    return 0.5 * (P + P.T) if np.all(np.isfinite(P)) else Q.copy()


# --------------------------------------------------------------------------------------------
# The controller
# --------------------------------------------------------------------------------------------


def _shift(coeffs: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Coefficients of ``p(tau + d_r)`` from those of ``p(tau)`` (last axis ascending), one shift per leading row.

    ``out[r, ..., k] = sum_{j >= k} coeffs[r, ..., j] C(j, k) d_r^(j - k)`` (Taylor shift).
    """
    K = coeffs.shape[-1]
    jj, kk = np.meshgrid(np.arange(K), np.arange(K))  # [k, j]
    binom = np.array([[math.comb(j, k) if j >= k else 0 for j in range(K)] for k in range(K)], dtype=float)
    M = binom[None] * np.asarray(d, dtype=float)[:, None, None] ** np.maximum(jj - kk, 0)[None]  # (rows, k, j)
    M = M.reshape((coeffs.shape[0],) + (1,) * (coeffs.ndim - 2) + (K, K))
    return np.einsum("...j,...kj->...k", coeffs, M)


@dataclass
class LQRController(TrackingController):
    """The LQR tracking feedback as a :class:`gna.controller.Controller` (picklable, no closures).

    Built by :func:`lqr_controller`.  The same reference, feedforward and evaluation as
    :class:`planners.tracking.TrackingController` on a finer grid (:data:`GAIN_STEP`); states: the
    integrals ``I1..I4`` (``I1..I3`` with the thrust output), then ``e_F`` with a thrust lag.  Output:
    ``sat(u~ + lead + K z) - u~``.  Anti-windup: back-calculation (module notes).  The integrals start
    where the cost-to-go of the initial error is least (:meth:`initial_state`).

    Attributes
    ----------
    lag : float or None
        Thrust time constant of the design [s].
    lead_poly : ndarray, shape (M - 1, Kl) or None
        Per-interval polynomial of ``tau F~'`` (the command lead of a lagged engine).
    n_integrals : int
        Integrals among the states (the first ``n_integrals``).
    initial_gain : ndarray, shape (M, n_integrals, 12) or None
        ``M(t)`` at the gain grid ``t_nodes`` of the integrals' least-cost start ``I(t0) = M(t0) dx(t0)``
        (:meth:`initial_state`, module notes); None: the integrals start at zero.
    """

    lag: float | None = None
    lead_poly: np.ndarray | None = None
    n_integrals: int = 4
    input_rows: tuple = ()
    tracking_time: float = 1.0
    design: str = "lqr"
    initial_gain: np.ndarray | None = None

    def initial_state(self, t0: float, x0: np.ndarray) -> np.ndarray:
        """Controller states at the start: the integrals where the cost-to-go is least, ``e_F`` zero.

        ``I(t0) = -P_II^-1 P_Ix dx(t0)`` minimises ``z' P(t0) z`` over the integrals for the aircraft's
        initial error ``dx(t0)`` (module notes): zero when the aircraft starts on the plan.  ``M(t0)`` is
        linear between the gain grid's samples.

        Parameters
        ----------
        t0 : float
            Start time [s].
        x0 : ndarray, shape (12,)
            Initial aircraft state [SI, rad].

        Returns
        -------
        ndarray, shape (n_states,)
        """
        out = np.zeros(self.n_states)
        if self.initial_gain is None:
            return out
        ref, _ = self._reference_and_gain(float(t0))
        e = self._errors(x0, ref)
        tg = self.t_nodes
        k = int(np.clip(np.searchsorted(tg, t0, side="right") - 1, 0, len(tg) - 2))
        w = float(np.clip((t0 - tg[k]) / (tg[k + 1] - tg[k]), 0.0, 1.0))
        M = (1.0 - w) * self.initial_gain[k] + w * self.initial_gain[k + 1]
        out[: self.n_integrals] = M @ e
        return out

    def _law(self, ref, gain, e, xc, lead):
        """Output and state derivatives from the reference, gains and errors; (n,) or (n, batch) arrays."""
        n_x = len(self.model_states)
        if e.ndim == 1:
            du = gain[:, :n_x] @ e + gain[:, n_x:] @ xc
        elif gain.ndim == 2:
            du = gain[:, :n_x] @ e + gain[:, n_x:] @ xc
        else:  # one gain matrix per aircraft
            du = np.einsum("Bub,bB->uB", gain[..., :n_x], e) + np.einsum("Bub,bB->uB", gain[..., n_x:], xc)
        if self.lag is not None:
            du[0] = du[0] + lead
        u = ref[n_x:]
        rates = TrackingController._rates(self, ref, e)
        applied = du
        if self.saturate:
            lo = self.lower if e.ndim == 1 else self.lower[:, None]
            hi = self.upper if e.ndim == 1 else self.upper[:, None]
            total = u + du
            sat = np.minimum(np.maximum(total, lo), hi)
            if self.anti_windup:
                excess = total - sat  # (n_u[, batch]): zero within the limits
                if np.any(excess):
                    rates = rates - self._back_calculation(gain[..., n_x : n_x + self.n_integrals], excess)
            applied = sat - u
        if self.lag is not None:
            eF = xc[self.n_integrals]
            rates = np.concatenate([rates, ((applied[0] - lead - eF) / self.lag)[None]], axis=0)
        return u, du, applied, rates

    def _back_calculation(self, g_int: np.ndarray, excess: np.ndarray) -> np.ndarray:
        """``Gamma excess``: the integrals' correction, ``K_I Gamma = I / T_t`` (least squares, module notes).

        ``g_int`` (n_u, n_I) or (batch, n_u, n_I), ``excess`` (n_u[, batch]); only the inputs' rows count.
        """
        rows = list(self.input_rows)
        if excess.ndim == 1:
            sol = np.linalg.lstsq(g_int[rows], excess[rows], rcond=1e-8)[0]
            return sol / self.tracking_time
        gi = g_int if g_int.ndim == 3 else np.broadcast_to(g_int, (excess.shape[1],) + g_int.shape)
        sol = np.linalg.pinv(gi[:, rows], rcond=1e-8) @ excess[rows].T[:, :, None]  # (batch, n_I, 1)
        return sol[:, :, 0].T / self.tracking_time

    def _lead(self, t):
        if self.lead_poly is None:
            return 0.0
        if np.ndim(t) == 0:
            i, tau = self._locate(float(t))
            return float(_horner(self.lead_poly[i], tau))
        i, tau = self._locate_many(np.asarray(t, dtype=float))
        return _horner(self.lead_poly[i], tau)

    def _errors(self, x, ref):
        n_x = len(self.model_states)
        e = np.asarray(x, dtype=float)[:n_x] - (ref[:n_x] if ref.ndim == 1 else ref[:n_x])
        e[self.angles] = (e[self.angles] + math.pi) % _TWO_PI - math.pi
        return e

    def _evaluate(self, t: float, x: np.ndarray, xc: np.ndarray):
        ref, gain = self._reference_and_gain(t)
        e = self._errors(x, ref)
        return self._law(ref, gain, e, np.asarray(xc, dtype=float), self._lead(t))

    def output_and_derivative_many(self, t, X: np.ndarray, XC: np.ndarray, *, with_feedforward: bool = False):
        """:meth:`output_and_derivative` for many aircraft at once (batched simulation).

        Parameters
        ----------
        t : float or ndarray, shape (n,)
            Time [s], common or one per aircraft.
        X : ndarray, shape (12, n)
            Aircraft states, one column per aircraft.
        XC : ndarray, shape (n_states, n)
            Controller states, one column per aircraft.
        with_feedforward : bool
            Also return the feedforward ``u~`` at ``t``.

        Returns
        -------
        (ndarray, ndarray[, ndarray]), shapes (5, n), (n_states, n)[, (5, n)]
        """
        X = np.asarray(X, dtype=float)
        XC = np.asarray(XC, dtype=float)
        if np.ndim(t) == 0:
            ref, gain = self._reference_and_gain(float(t))
            ref = np.broadcast_to(ref[:, None], (ref.shape[0], X.shape[1]))
        else:
            i, tau = self._locate_many(np.asarray(t, dtype=float))
            ref = _horner(self.reference_poly[i], tau[:, None]).T
            gain = _horner(self.gain_poly[i], tau[:, None, None])  # (batch, n_u, n)
        n_x = len(self.model_states)
        e = X[:n_x] - ref[:n_x]
        e[self.angles] = (e[self.angles] + math.pi) % _TWO_PI - math.pi
        lead = self._lead(t)
        _, _, du, rates = self._law(ref, gain, e, XC, lead)
        if with_feedforward:
            return du, rates, np.array(ref[n_x:])
        return du, rates


def lqr_controller(
    plan,
    *,
    feedforward_iterate: int = -1,
    saturate: bool = True,
    anti_windup: bool = True,
    tolerances: TrackingTolerances | None = None,
    lag="aircraft",
    least_cost_start: bool = True,
) -> LQRController:
    """The time-varying LQR tracking feedback for an aircraft plan (:func:`lqr_design`), ready to fly.

    Parameters
    ----------
    plan : Plan
        An aircraft plan (flat output beta, mu or F).
    feedforward_iterate : int
        Plan iterate whose controls are the feedforward and whose states the reference (default the last).
    saturate : bool
        Clip the applied controls at the surface limits, the thrust range ``0 .. max_thrust`` and
        ``|eta| <= 1`` for two engines (as :func:`planners.tracking.tracking_controller`).
    anti_windup : bool
        With ``saturate``: conditional integration (module notes).
    tolerances : TrackingTolerances, optional
        Bryson's-rule errors (default :data:`DEFAULT_TOLERANCES`).
    lag : "aircraft", float or None
        Thrust time constant of the design (:func:`lqr_design`).
    least_cost_start : bool
        Start the integrals where the cost-to-go of the initial error is least
        (:meth:`LQRController.initial_state`); False: at zero.

    Returns
    -------
    LQRController

    Raises
    ------
    InputError
        Not an aircraft plan, an unsupported flat output, an iterate not in the plan, a surface without limit.
    DomainError
        The Riccati integration failed.
    """
    from .tracking import tracking_limits

    des = lqr_design(plan, j=feedforward_iterate, tolerances=tolerances, lag=lag, saturate=saturate)
    j = des.iterate
    names = STATE_NAMES + CONTROL_NAMES
    tn = np.asarray(plan.t_nodes, dtype=float)
    base = plan._coefficients(names, j)  # (N - 1, 17, d) per plan interval
    t = des.t
    i = np.clip(np.searchsorted(tn, t[:-1], side="right") - 1, 0, len(tn) - 2)
    reference_poly = _shift(base[i], t[:-1] - tn[i])
    n_u = len(CONTROL_NAMES)
    h = np.diff(t)
    n = des.K.shape[2]
    Kfull = np.zeros((len(t), n_u, n))
    dKfull = np.zeros_like(Kfull)
    for k, u in enumerate(des.inputs):
        Kfull[:, CONTROL_NAMES.index(u)] = des.K[:, k]
        dKfull[:, CONTROL_NAMES.index(u)] = des.dK[:, k]
    a = np.stack([Kfull[:-1], dKfull[:-1]], -1)
    b = np.stack([Kfull[1:], dKfull[1:]], -1)
    gain_poly = interval_coefficients(a.reshape(len(h), -1, 2), b.reshape(len(h), -1, 2), h, "hermite").reshape(
        len(h), n_u, n, -1
    )
    lead_poly = None
    if des.lag is not None:
        F = reference_poly[:, STATE_NAMES.__len__() + CONTROL_NAMES.index("F")]
        lead_poly = des.lag * F[:, 1:] * np.arange(1, F.shape[-1])
    lower, upper = tracking_limits(plan)
    zeta = plan.problem.zeta.kind
    n_i = len(des.integrals)
    names_c = des.integrals + (("e_F",) if des.lag is not None else ())
    return LQRController(
        t,
        reference_poly,
        gain_poly,
        STATE_NAMES.index(zeta) if zeta in ("beta", "mu") else -1,
        lower,
        upper,
        bool(saturate),
        names_c,
        des.inputs,
        (),
        j,
        len(names_c),
        np.zeros((len(names_c), n_u), dtype=bool),
        bool(anti_windup),
        angles=_ANGLE_IDX,
        lag=des.lag,
        lead_poly=lead_poly,
        n_integrals=n_i,
        input_rows=tuple(CONTROL_NAMES.index(u) for u in des.inputs),
        tracking_time=TRACKING_TIME,
        initial_gain=des.initial_integrals() if least_cost_start else None,
    )


def check_design(value, where: str) -> str:
    """A tracking design name (``[tracking] design``, ``--tracking``), one line otherwise.

    Parameters
    ----------
    value : object
    where : str
        Source, for the message.

    Returns
    -------
    str

    Raises
    ------
    InputError
        Not one of :data:`DESIGNS`.
    """
    if not isinstance(value, str) or value not in DESIGNS:
        raise InputError(f"{where}: the tracking design must be {' or '.join(map(repr, DESIGNS))}, got {value!r}")
    return value


__all__ = [
    "DEFAULT_TOLERANCES",
    "DESIGNS",
    "GAIN_STEP",
    "INTEGRAL_TIME",
    "LQRController",
    "LQRDesign",
    "LQRWeights",
    "TrackingTolerances",
    "check_design",
    "feedforward_room",
    "input_ranges",
    "lqr_controller",
    "lqr_design",
    "lqr_weights",
    "solve_riccati",
    "terminal_weight",
    "thrust_lag",
]
