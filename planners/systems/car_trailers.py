"""A car towing two trailers hitched off-axle (the paper's conclusion; Rouchon, Fliess, Levine and
Martin, "Flatness and motion planning: the car with n trailers", ECC 1993).

Kinematics (no slip, planar): the car's rear-axle midpoint moves at speed ``v0`` with heading ``theta0``,
``theta0' = v0 tan(phi) / l0`` (steering angle ``phi``, wheelbase ``l0``).  Trailer i is hitched at a
distance ``d_i`` behind the axle of the vehicle ahead (``d_i = 0``: on-axle) and has its axle ``L_i``
behind its hitch.  The hitch moves at ``v_(i-1) e_(i-1) - d_i theta_(i-1)' e_(i-1)^perp``, so with
``c = cos(theta_(i-1) - theta_i)``, ``s = sin(theta_(i-1) - theta_i)``::

    v_i = v_(i-1) c + d_i theta_(i-1)' s,      L_i theta_i' = v_(i-1) s - d_i theta_(i-1)' c.

On-axle (``d_i = 0``) the system is flat with the last trailer's axle ``(x2, y2)`` as flat output;
off-axle it is not (Rouchon et al. 1993).  The off-axle terms ``d_i theta_(i-1)'`` are the neglected
terms H of an almost chained system (paper eq. chained-sys), with the heading rates as chained
variables (as the lag's ``y'``):

* stage 1: ``(x2', y2') = v2 (cos theta2, sin theta2)``                      -> ``v2, theta2``
* stage 2: trailer-2 relations, ``H_2 = d2 w1^``                              -> ``v1, theta1``
* stage 3: ``w1 = theta1'`` and the trailer-1 relations, ``H_3 = d1 w0^``     -> ``v0, theta0, w1``
* stage 4: ``w0 = theta0'``, ``theta0' = v0 tan(phi) / l0``                   -> ``phi, w0``

``l_2 = l_3 = 2``: L = 1.  Iterate 0 (``w^ = 0``) is the on-axle (flat) approximation; the
generalized iterates correct it.  :func:`simulate_car_two_trailers` integrates the exact model.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gna.errors import DomainError

from ..chained import ChainedSystem, Stage, StateSpaceModel

#: States and controls of the exact model.
STATES = ("x2", "y2", "theta2", "theta1", "theta0")
CONTROLS = ("v0", "phi")


@dataclass(frozen=True)
class CarTrailers:
    """Geometry of the car with two trailers [m].

    Attributes
    ----------
    l0 : float
        Car wheelbase.
    d1, L1 : float
        Trailer 1: hitch offset behind the car's rear axle, hitch-to-axle length.
    d2, L2 : float
        Trailer 2: hitch offset behind trailer 1's axle, hitch-to-axle length.
    """

    l0: float = 2.7
    d1: float = 0.8
    L1: float = 3.0
    d2: float = 0.6
    L2: float = 3.0


def car_two_trailers(geometry: CarTrailers = CarTrailers(), speed: float = 5.0) -> ChainedSystem:
    """The car with two off-axle trailers as an almost chained system, flat output ``(x2, y2)``.

    Parameters
    ----------
    geometry : CarTrailers
        Lengths [m].
    speed : float
        Typical forward speed [m/s]: the Newton starting value of the speeds (headings start at 0).

    Returns
    -------
    ChainedSystem
        Four stages (see the module docstring); unknowns ``v2, theta2, v1, theta1, v0, theta0, w1, phi,
        w0``.
    """
    g = geometry

    def stage1(v):
        return [v["x2'"] - v["v2"] * np.cos(v["theta2"]), v["y2'"] - v["v2"] * np.sin(v["theta2"])]

    def stage2(v):
        c, s = np.cos(v["theta1"] - v["theta2"]), np.sin(v["theta1"] - v["theta2"])
        return [v["v2"] - v["v1"] * c - g.d2 * v["w1"] * s, g.L2 * v["theta2'"] - v["v1"] * s + g.d2 * v["w1"] * c]

    def stage3(v):
        c, s = np.cos(v["theta0"] - v["theta1"]), np.sin(v["theta0"] - v["theta1"])
        return [
            v["w1"] - v["theta1'"],
            v["v1"] - v["v0"] * c - g.d1 * v["w0"] * s,
            g.L1 * v["theta1'"] - v["v0"] * s + g.d1 * v["w0"] * c,
        ]

    def stage4(v):
        return [v["w0"] - v["theta0'"], g.l0 * v["theta0'"] - v["v0"] * np.tan(v["phi"])]

    def integrands(ref):
        # along-track and cross-track errors of the last trailer (as the aircraft's I1, I2)
        c, s = np.cos(ref["theta2"]), np.sin(ref["theta2"])
        return [[c, s, 0.0, 0.0, 0.0], [-s, c, 0.0, 0.0, 0.0]]

    # I1 (along track): second derivative dv2 -> dv0 (degree 2); I2 (cross track): theta2 -> theta1 ->
    # theta0 -> phi (degree 5), decoupled after I1 (the aircraft's sequential construction)
    model = StateSpaceModel(
        STATES,
        CONTROLS,
        lambda x, u, hat=None: kinematics(g, x, u, hat),
        integrands,
        degrees=(2, 5),
        stages=(((0,), (0,)), ((1,), (1,))),
    )
    return ChainedSystem(
        name="car-two-trailers",
        flat_outputs={"x2": 1, "y2": 1},
        stages=(
            Stage(("v2", "theta2"), stage1),
            Stage(("v1", "theta1"), stage2, neglected=("w1",), ell=2),
            Stage(("v0", "theta0", "w1"), stage3, neglected=("w0",), ell=2),
            Stage(("phi", "w0"), stage4),
        ),
        guess={"v2": speed, "v1": speed, "v0": speed},
        description=f"car with two trailers hitched off-axle (d1 = {g.d1:g} m, d2 = {g.d2:g} m); flat output "
        "(x2, y2) of the on-axle approximation",
        model=model,
    )


def kinematics(geometry: CarTrailers, x, u, hat=None) -> list:
    """The exact off-axle kinematics (module docstring), or the design model with the off-axle terms frozen.

    Parameters
    ----------
    geometry : CarTrailers
        Lengths [m].
    x : sequence of 5
        ``(x2, y2, theta2, theta1, theta0)`` [m, m, rad, rad, rad]: floats, arrays or Series.
    u : sequence of 2
        ``(v0, phi)``: car speed [m/s] and steering angle [rad].
    hat : mapping, optional
        Values of the heading rates ``w0, w1`` [rad/s] in the off-axle terms ``d_i w_(i-1)`` (the
        neglected terms H); None for the exact model (the rates of the state).

    Returns
    -------
    list of 5
        Time derivatives of ``x``.
    """
    g = geometry
    x2, y2, th2, th1, th0 = x
    v0, phi = u
    w0 = v0 * np.tan(phi) / g.l0
    w0h = w0 if hat is None else hat["w0"]
    c, s = np.cos(th0 - th1), np.sin(th0 - th1)
    v1 = v0 * c + g.d1 * w0h * s
    w1 = (v0 * s - g.d1 * w0h * c) / g.L1
    w1h = w1 if hat is None else hat["w1"]
    c, s = np.cos(th1 - th2), np.sin(th1 - th2)
    v2 = v1 * c + g.d2 * w1h * s
    w2 = (v1 * s - g.d2 * w1h * c) / g.L2
    return [v2 * np.cos(th2), v2 * np.sin(th2), w2, w1, w0]


def car_trailers_rhs(geometry: CarTrailers, v0: float, phi: float, state) -> np.ndarray:
    """Right-hand side of the exact (off-axle) kinematics.

    Parameters
    ----------
    geometry : CarTrailers
        Lengths [m].
    v0 : float
        Car speed [m/s].
    phi : float
        Steering angle [rad].
    state : array, shape (5,)
        ``(x2, y2, theta2, theta1, theta0)`` [m, m, rad, rad, rad].

    Returns
    -------
    ndarray, shape (5,)
        Time derivative of ``state``.
    """
    return np.array(kinematics(geometry, state, (v0, phi)))


def simulate_car_two_trailers(geometry: CarTrailers, v0, phi, state0, t_eval) -> np.ndarray:
    """Integrate the exact model open loop with given control functions (RK45, rtol 1e-10).

    Parameters
    ----------
    geometry : CarTrailers
        Lengths [m].
    v0, phi : callable
        Car speed [m/s] and steering angle [rad] as functions of t [s].
    state0 : array, shape (5,)
        Initial ``(x2, y2, theta2, theta1, theta0)``.
    t_eval : array, shape (N,)
        Output times [s], increasing, starting at the initial time.

    Returns
    -------
    ndarray, shape (N, 5)
        The states at ``t_eval``.

    Raises
    ------
    DomainError
        The integration stopped before the last time (e.g. a jack-knife: the hitch angles' rates
        blow up); the message names the time and the integrator's reason.
    """
    from scipy.integrate import solve_ivp

    t_eval = np.asarray(t_eval, dtype=float)
    sol = solve_ivp(
        lambda t, x: car_trailers_rhs(geometry, float(v0(t)), float(phi(t)), x),
        (t_eval[0], t_eval[-1]),
        np.asarray(state0, dtype=float),
        t_eval=t_eval,
        rtol=1e-10,
        atol=1e-10,
        method="RK45",
    )
    if sol.status != 0 or sol.y.shape[1] != t_eval.size:
        t_stop = float(sol.t[-1]) if sol.t.size else float(t_eval[0])
        raise DomainError(
            f"the exact car-with-trailers model flown open loop stopped at t = {t_stop:.6g} s "
            f"(of {t_eval[-1]:g} s): {sol.message}"
        )
    return sol.y.T


def open_loop_error(plan, geometry: CarTrailers, x2, y2, samples: int = 241) -> float:
    """Max distance of the exact model's last trailer, flown open loop with a plan's controls, from the flat output.

    The exact off-axle model (:func:`simulate_car_two_trailers`) starts on the plan's state at its
    first node and is driven by the planned ``v0(t), phi(t)`` (the two-sided interpolation of the
    last iterate).

    Parameters
    ----------
    plan : planners.chained.ChainedPlan
        A plan of :func:`car_two_trailers`.
    geometry : CarTrailers
        The exact model's lengths [m].
    x2, y2 : callable
        The flat output (last trailer's axle midpoint) [m] as functions of t [s].
    samples : int
        Number of equally spaced comparison times over the plan's span.

    Returns
    -------
    float
        ``max_t |(x2, y2)_simulated - (x2, y2)_planned|`` [m].

    Raises
    ------
    DomainError
        The open-loop flight stopped early (:func:`simulate_car_two_trailers`).
    """
    te = np.linspace(plan.t_nodes[0], plan.t_nodes[-1], samples)
    x0 = [plan.evaluate(n, te[0]) for n in ("x2", "y2", "theta2", "theta1", "theta0")]
    X = simulate_car_two_trailers(geometry, lambda t: plan.evaluate("v0", t), lambda t: plan.evaluate("phi", t), x0, te)
    return float(
        np.max(np.hypot(X[:, 0] - np.broadcast_to(x2(te), te.shape), X[:, 1] - np.broadcast_to(y2(te), te.shape)))
    )
