"""Tracking feedback along a plan (paper section "Design of the feed-back").

The plan gives reference states ``x~(t)`` and controls ``u~(t)``; the
feedback adds ``delta_u = K(t) [x - x~(t); I]`` to the feedforward ``u~``,
with the integral states (paper, subsec. "Design of the feed-back")::

    I1 = int  cos(chi~) dx + sin(chi~) dy     (along track)
    I2 = int -sin(chi~) dx + cos(chi~) dy     (cross track)
    I3 = int  dz                              (vertical)
    I4 = int  d(zeta)                         (zeta = beta or mu; absent with the thrust output F)

where ``dxi = xi - xi~`` (angle differences wrapped into (-pi, pi]) and
``chi~`` is the planned track angle.

Sign convention
---------------
The user gives lists of **positive** numbers ``lambda_{p,k}``; the linearized
closed loop obeys ``prod_k (d/dt + lambda_{p,k}) I_p = 0``, i.e. its poles
are ``-lambda_{p,k}`` (stable).  The paper writes ``(d/dt - lambda)`` with
positive lambda and means the same stable design.

Linearization along the plan
----------------------------
:func:`linearize` gives, at every node, the Jacobians ``A = df/dx`` (12 x 12)
and ``B = df/du`` (12 x 5) of :func:`gna.eom.derivatives` as power series at
the node: one batched complex step on the plan's series (exact to rounding,
no finite differences in time), as :func:`planners.newton.newton_series`
obtains its Jacobian series.  The last iterate carries its controls at order
``e = 1``, so A and B are known to order 1 (value and first derivative).

Design model.  The paper designs the feedback in the differential module of
the linearized system "using dx, dy, dz as flat outputs", completed with
d(beta) or d(mu): that is the linearization of the model the plan solves, in
which the force coefficients depend on the rates and surfaces only through
the neglected terms H, fixed along the plan (``gna.eom`` with
``model="simple"`` and H = the plan's own ``p, q, r, dl, dm, dn``; its value
equals the full model's on the plan, only the Jacobian drops the force
derivatives with respect to rates and surfaces).  There, and only there, the
integrals have the relative degrees the paper uses: 3 (I1, through F),
5 (I2, I3: position -> V, gamma, chi -> alpha, beta, mu -> p, q, r ->
surfaces), 3 (I4: beta or mu -> p, r -> surfaces); 5, 5, 5 with the thrust
output (the inputs are then the three surfaces).  In the full model the
surfaces' and rates' force terms (elevator lift, rudder side force, C_L_q)
lower these degrees and no such decoupling exists; the gains designed on the
design model are applied to the full model, where these terms act as a small
perturbation (:func:`closed_loop_matrix` gives both closed loops).

Gains (frozen-time, per node)
-----------------------------
At every node, with the augmented system ``(dx, I)`` (16 or 15 states), the
gains are obtained by sequential input-output decoupling (the paper's
construction): first ``dF = k_1 [dx; I]`` so that
``prod_k (d/dt + lambda_{1,k}) I1 = 0`` (``I1''' = ... + g dF``); with that
law substituted, ``(I2, I3, I4)`` have relative degrees (5, 5, 3) with
respect to ``(dl, dm, dn)`` (or ``eta`` for ``dn`` when the rudder is fixed)
and an invertible 3 x 3 decoupling matrix, which gives the three other rows.
The augmented closed loop ``A^ + B^ K`` is then similar to the block-diagonal
of the companion matrices of the requested polynomials: frozen at the node,
``e_p (A^ + B^ K)^r_p + sum_k a_{p,k} e_p (A^ + B^ K)^k = 0`` exactly
(``e_p`` selects ``I_p``), which the tests check at every node.

A frozen-time design, not a time-varying one, because the plan's controls
are known to order 1 only: an exact time-varying design of relative degree 5
needs the fourth derivative of A.  The order-1 information is used to make
the gains series of order 1 at each node (their derivative by a complex step
through the frozen-time formula with ``A + i h A'``), evaluated between nodes
by the plan's two-sided formula.

Evaluation cost
---------------
:class:`TrackingController` precomputes, per interval, the reference (states
and controls of the feedforward iterate, by the plan's own formula between
nodes) and the two-sided interpolant of the gains as polynomials in ``t - t_i``: one feedback evaluation is a
bisection and three small matrix-vector products (no series, no model).
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np

from gna.eom import CONTROL_NAMES, H_NAMES, STATE_NAMES, Controls, HValues, State, derivatives
from gna.errors import DomainError, InputError

from .chained import StateSpaceModel
from .newton import series_jacobian
from .plan import Plan, interval_coefficients
from .series import Series

#: The four integrals, in order (I4 absent with the thrust flat output).
INTEGRAL_NAMES: tuple[str, ...] = ("I1", "I2", "I3", "I4")

#: The paper's Twin Otter list (section "Single engine", after Martin's thesis).  The paper prints
#: lambda_{4,5} = 4 where I4 has three factors and lambda_{3,5} is missing: read as lambda_{3,5} = 4.
TWIN_OTTER_LAMBDAS: tuple = ((1.0, 2.0, 3.0), (1.0, 1.0, 1.0, 2.0, 3.0), (1.5, 1.5, 1.5, 3.0, 4.0), (1.0, 2.0, 3.0))
#: The paper's forward slip (eq. GTM_FS): lambda_{i,j} = 0.5 for the three integrals of the thrust output.
FORWARD_SLIP_LAMBDAS: tuple = ((0.5,) * 5, (0.5,) * 5, (0.5,) * 5)
#: The aileron roll (the paper gives none).  The roll lasts 8 s and turns at pi/2 rad/s, so the
#: linearization changes on a time scale of ~0.6 s: the slowest poles are put at 1 rad/s (errors
#: decay within the manoeuvre, at about the rate the paper's Twin Otter uses), the fastest at 4 rad/s
#: (faster gains drive the GTM's surfaces into their limits for the 5 m / 1 deg offsets of the tests,
#: and leave the frozen-time design further from the time-varying loop).
ROLL_LAMBDAS: tuple = ((1.0, 2.0, 3.0), (1.0, 1.5, 2.0, 3.0, 4.0), (1.0, 1.5, 2.0, 3.0, 4.0), (1.0, 2.0, 3.0))

#: Indices of the angles among the 12 states (differences wrapped into (-pi, pi]).
_ANGLE_IDX = np.array([STATE_NAMES.index(n) for n in ("gamma", "chi", "alpha", "beta", "mu")])
_CHI = STATE_NAMES.index("chi")
_TWO_PI = 2.0 * math.pi


def paper_lambdas(name: str):
    """The lambda lists the paper gives for a bundled scenario, as plain lists.

    Parameters
    ----------
    name : str
        ``"twin-otter-single-engine"``, ``"gtm-forward-slip"`` or ``"gtm-aileron-roll"``
        (the last one is this module's choice, :data:`ROLL_LAMBDAS`).

    Returns
    -------
    list of list of float
        One list per integral (4, or 3 with the thrust output).

    Raises
    ------
    InputError
        For another name.
    """
    table = {
        "twin-otter-single-engine": TWIN_OTTER_LAMBDAS,
        "gtm-forward-slip": FORWARD_SLIP_LAMBDAS,
        "gtm-aileron-roll": ROLL_LAMBDAS,
    }
    if name not in table:
        raise InputError(f"no paper lambdas for {name!r}; known: {', '.join(table)}")
    return [list(v) for v in table[name]]


# --------------------------------------------------------------------------------------------
# Linearization on series
# --------------------------------------------------------------------------------------------


@dataclass
class Linearization:
    """Jacobians of the model along a plan, as power series at the nodes.

    Attributes
    ----------
    t_nodes : ndarray, shape (N,)
        Nodes [s].
    A : ndarray, shape (N, 12, 12, K)
        ``A[i, a, b, k]``: k-th normalised Taylor coefficient at node i of
        ``d f_a / d x_b`` (states in :data:`gna.eom.STATE_NAMES` order).
    B : ndarray, shape (N, 12, 5, K)
        Same for ``d f_a / d u_b`` (controls ``F, eta, dl, dm, dn``).
    model : str
        ``"full"`` or ``"design"`` (force coefficients with rates and surfaces frozen along the plan).
    iterate : int
        Plan iterate linearized about.
    """

    t_nodes: np.ndarray
    A: np.ndarray
    B: np.ndarray
    model: str
    iterate: int

    @property
    def order(self) -> int:
        """Order of the series (K - 1)."""
        return self.A.shape[-1] - 1


def _check_linearization(plan, model: str, order, j: int) -> None:
    """The arguments of a linearization along a plan (aircraft or chained system), one message each."""
    if model not in ("full", "design"):
        raise InputError(f"model must be 'full' or 'design', got {model!r}")
    if not (isinstance(order, (int, np.integer)) and order >= 0):
        raise InputError(f"order must be a non-negative integer, got {order!r}")
    if not -len(plan.iterates) <= j < len(plan.iterates):
        raise InputError(f"iterate j = {j} not in the plan (J = {plan.J})")


def aircraft_model(problem) -> StateSpaceModel:
    """The aircraft's explicit model for the tracking feedback (paper subsec. "Design of the feed-back").

    States :data:`gna.eom.STATE_NAMES`, controls :data:`gna.eom.CONTROL_NAMES`; ``rhs`` is
    :func:`gna.eom.derivatives` (``hat`` given: ``model="simple"`` with H at ``hat``, the design
    model); the integrals ``I1..I4`` of the module notes; the feedback inputs ``F, dl, dm`` and ``dn``
    (``eta`` with a fixed rudder), the three surfaces with the thrust output.

    Parameters
    ----------
    problem : FlatProblem
        The plan's problem.

    Returns
    -------
    StateSpaceModel

    Raises
    ------
    InputError
        A flat output other than beta, mu and F.
    """
    ac, env = problem.aircraft, problem.env
    kind = problem.zeta.kind
    fourth = "eta" if problem.eta is None else "dn"
    if kind in ("beta", "mu"):
        inputs, degrees, stages = ("F", "dl", "dm", fourth), (3, 5, 5, 3), (((0,), (0,)), ((1, 2, 3), (1, 2, 3)))
    elif kind == "F":
        inputs, degrees, stages = ("dl", "dm", fourth), (5, 5, 5), (((0, 1, 2), (0, 1, 2)),)
    else:
        raise InputError(
            f"the tracking feedback supports the flat outputs beta, mu and F (paper, subsec. "
            f"'Design of the feed-back'), not {kind!r}"
        )

    def rhs(x, u, hat):
        if hat is None:
            return derivatives(ac, env, State(*x), Controls(*u), "full")
        return derivatives(ac, env, State(*x), Controls(*u), "simple", HValues(*(hat[n] for n in H_NAMES)))

    def integrands(ref):
        # I1' = cos(chi~) dx + sin(chi~) dy, I2' = -sin dx + cos dy, I3' = dz, I4' = d(zeta)
        c, s_ = np.cos(ref["chi"]), np.sin(ref["chi"])
        rows = [[c, s_] + [0.0] * 10, [-s_, c] + [0.0] * 10, [0.0, 0.0, 1.0] + [0.0] * 9]
        if kind != "F":
            rows.append([1.0 if n == kind else 0.0 for n in STATE_NAMES])
        return rows

    return StateSpaceModel(STATE_NAMES, CONTROL_NAMES, rhs, integrands, degrees, stages, inputs)


def plan_model(plan) -> StateSpaceModel:
    """The explicit model of a plan's system: :func:`aircraft_model` for an aircraft plan, the system's
    :attr:`~planners.chained.ChainedSystem.model` for a chained-system plan.

    Parameters
    ----------
    plan : Plan or planners.chained.ChainedPlan
        A plan.

    Returns
    -------
    StateSpaceModel

    Raises
    ------
    InputError
        A system without an explicit model, or an aircraft flat output the feedback does not support.
    """
    if isinstance(plan, Plan):
        return aircraft_model(plan.problem)
    if plan.system.model is None:
        raise InputError(
            f"{plan.system.name}: the system gives no explicit model (ChainedSystem.model) to "
            f"design a tracking feedback on"
        )
    return plan.system.model


def _neglected(plan) -> tuple:
    return H_NAMES if isinstance(plan, Plan) else plan.system.neglected


def linearize(plan, j: int = -1, *, model: str = "full", order: int = 1) -> Linearization:
    """Jacobians of the plan's explicit model (:func:`plan_model`) along iterate ``j``, as series at the nodes.

    One complex step on the plan's series, batched over the states and controls and all nodes
    (paper, subsec. "Design of the feed-back": "the state functions replaced at each step i by
    their power series expansion at t_i").

    Parameters
    ----------
    plan : Plan or planners.chained.ChainedPlan
        An aircraft plan, or a plan of a chained system with an explicit model.
    j : int
        Iterate (default: the last).
    model : {"full", "design"}
        ``"full"``: the exact model.  ``"design"``: the neglected terms frozen at the plan's own
        values (for the aircraft the force coefficients take the rates and surfaces as H,
        ``gna.eom`` ``model="simple"``), the model the plan solves.
    order : int
        Requested order of the series (lowered to the lowest order the iterate carries, 1 for the
        controls of the last iterate).

    Returns
    -------
    Linearization
        ``A`` (N, n_x, n_x, K) and ``B`` (N, n_x, n_u, K), in the model's state and control order.

    Raises
    ------
    InputError
        No explicit model, unknown model kind, negative order or iterate not in the plan.
    """
    ssm = plan_model(plan)
    _check_linearization(plan, model, order, j)
    sol = plan.iterates[j]
    names = tuple(ssm.states) + tuple(ssm.controls)
    order = int(min(order, min(sol[n].order for n in names)))
    K, N, n_x = order + 1, len(plan.t_nodes), len(ssm.states)

    def coeffs(name):
        return np.broadcast_to(np.real(np.asarray(sol[name].coeffs))[..., :K], (N, K))

    base = np.stack([coeffs(n) for n in names])
    hat = {n: Series(coeffs(n)) for n in _neglected(plan)} if model == "design" else None
    jac = np.moveaxis(series_jacobian(lambda v, k: ssm.rhs(v[:n_x], v[n_x:], hat), base, K - 1), 2, 0)
    return Linearization(
        np.asarray(plan.t_nodes, dtype=float),
        np.ascontiguousarray(jac[:, :, :n_x]),
        np.ascontiguousarray(jac[:, :, n_x:]),
        model,
        j % len(plan.iterates),
    )


# --------------------------------------------------------------------------------------------
# Gains
# --------------------------------------------------------------------------------------------


@dataclass
class TrackingDesign:
    """Frozen-time gains at the nodes and what they were computed from.

    Attributes
    ----------
    t_nodes : ndarray, shape (N,)
    A : ndarray, shape (N, n, n, K)
        Augmented design-model matrix series (``n = 12 + n_I``; states then integrals).
    B : ndarray, shape (N, n, m, K)
        Input columns (the ``inputs``) of the augmented design model.
    K : ndarray, shape (N, m, n, K)
        Gain series at the nodes: ``delta_u[inputs] = K [dx; I]``.
    inputs : tuple of str
        Control names of the feedback inputs.
    integrals : tuple of str
    degrees : tuple of int
        Relative degree of each integral.
    lambdas : tuple of tuple of float
    polynomials : list of ndarray
        Monic polynomial of each integral, coefficients in increasing powers
        (``a_0, ..., a_{r-1}, 1``) of ``prod_k (s + lambda_k)``.
    stages : tuple
        ``((integral indices), (input indices))`` in the order they are decoupled.
    iterate : int
    """

    t_nodes: np.ndarray
    A: np.ndarray
    B: np.ndarray
    K: np.ndarray
    inputs: tuple
    integrals: tuple
    degrees: tuple
    lambdas: tuple
    polynomials: list
    stages: tuple
    iterate: int

    @property
    def n(self) -> int:
        """Dimension of the augmented state."""
        return self.A.shape[1]

    def closed_loop(self, k: int = 0) -> np.ndarray:
        """Frozen-time closed loop ``A^ + B^ K`` at the nodes (k = 0), or its k-th Taylor coefficient.

        Parameters
        ----------
        k : int
            0 for the value; 1 for the first-order coefficient (Leibniz rule).

        Returns
        -------
        ndarray, shape (N, n, n)
        """
        out = self.A[..., k].copy()
        for i in range(k + 1):
            out += np.einsum("Nam,Nmb->Nab", self.B[..., i], self.K[..., k - i])
        return out


def _check_lambdas(lambdas, degrees: tuple) -> tuple:
    """Plain lists (or one number for all) -> tuple of tuples matching ``degrees``."""
    n_int = len(degrees)
    if isinstance(lambdas, (int, float)) and not isinstance(lambdas, bool):
        lambdas = [[float(lambdas)] * r for r in degrees]
    try:
        lam = [tuple(float(v) for v in row) for row in lambdas]
    except (TypeError, ValueError):
        raise InputError(f"lambdas must be {n_int} lists of numbers (or one number), got {lambdas!r}") from None
    if [len(row) for row in lam] != list(degrees):
        raise InputError(
            f"lambdas: need {n_int} lists of lengths {', '.join(map(str, degrees))} "
            f"(one factor per order of the integral's relative degree), got lengths "
            f"{[len(row) for row in lam]}"
        )
    for p, row in enumerate(lam):
        for k, v in enumerate(row):
            if not (math.isfinite(v) and v > 0):
                raise InputError(
                    f"lambda_{{{p + 1},{k + 1}}} = {v!r}: the lambdas must be positive finite numbers "
                    f"(poles at -lambda)"
                )
    return tuple(lam)


def _place(A: np.ndarray, B: np.ndarray, n_x: int, degrees, polys, stages, t_nodes, check: bool) -> np.ndarray:
    """Sequential decoupling at every node (batched; real or complex arrays).

    ``A`` (N, n, n), ``B`` (N, n, m); integral p is augmented state ``n_x + p``.
    Returns K (N, m, n) such that ``e_p (A + B K)^r + sum_k a_k e_p (A + B K)^k = 0``.
    """
    N, n, _ = A.shape
    m = B.shape[2]
    Kout = np.zeros((N, m, n), dtype=np.result_type(A, B))
    Acur = A.copy()
    remaining = list(range(m))
    for outs, cols in stages:
        cols = list(cols)
        later = [c for c in remaining if c not in cols]
        Bs, Bl = B[:, :, cols], B[:, :, later]
        G = np.zeros((N, len(outs), len(cols)), dtype=Kout.dtype)
        M = np.zeros((N, len(outs), n), dtype=Kout.dtype)
        for row, p in enumerate(outs):
            r, a = degrees[p], polys[p]
            R = np.zeros((N, n), dtype=Kout.dtype)
            R[:, n_x + p] = 1.0
            acc = a[0] * R
            for k in range(1, r + 1):
                if check:
                    # Relative degree r: e_p A^k B = 0 for k <= r - 2, and the later stages' inputs are
                    # absent from I_p^(r) too (exact decoupling).
                    Bk = B[:, :, remaining] if k - 1 <= r - 2 else Bl
                    if Bk.shape[2]:
                        lhs = np.abs(np.einsum("Na,Nam->Nm", np.real(R), np.real(Bk)))
                        scale = (
                            np.linalg.norm(np.real(R), axis=1)[:, None] * np.linalg.norm(np.real(Bk), axis=1) + 1e-300
                        )
                        bad = np.max(lhs / scale, axis=1) > 1e-9
                        if np.any(bad):
                            i = int(np.flatnonzero(bad)[0])
                            raise DomainError(
                                f"integral I{p + 1}: an input acts on its derivative of "
                                f"order {k} at t = {t_nodes[i]:.6g} s (relative degree below {r}): "
                                f"the design model does not have the paper's structure there",
                                time=float(t_nodes[i]),
                                variable=f"I{p + 1}",
                            )
                if k == r:
                    G[:, row] = np.einsum("Na,Nam->Nm", R, Bs)
                R = np.einsum("Na,Nab->Nb", R, Acur)
                acc = acc + (a[k] if k < r else 1.0) * R
            M[:, row] = acc
        if check:
            cond = np.linalg.cond(np.real(G))
            bad = ~(cond < 1e12)
            if np.any(bad):
                i = int(np.flatnonzero(bad)[0])
                raise DomainError(
                    f"decoupling matrix of {', '.join(f'I{p + 1}' for p in outs)} singular at "
                    f"t = {t_nodes[i]:.6g} s (condition number {cond[i]:.3g}): these inputs cannot "
                    f"steer these integrals independently there",
                    time=float(t_nodes[i]),
                    variable="decoupling",
                    value=float(cond[i]),
                )
        Ks = -np.linalg.solve(G, M)  # (N, len(cols), n)
        Kout[:, cols] = Ks
        Acur = Acur + np.einsum("Nam,Nmb->Nab", Bs, Ks)
        remaining = later
    return Kout


def _gain_series(A: np.ndarray, B: np.ndarray, n_x: int, degrees, polys, stages, t) -> np.ndarray:
    """Frozen-time gains (N, m, n, K) at the nodes, value and (for K > 1) first derivative."""
    N, n, _, K = A.shape
    gains = np.zeros((N, B.shape[2], n, K))
    gains[..., 0] = _place(A[..., 0], B[..., 0], n_x, degrees, polys, stages, t, check=True)
    if K > 1:
        # d/dt of the frozen-time gains: complex step through the (analytic) design formula.
        h = 1e-30
        Kc = _place(
            A[..., 0] + 1j * h * A[..., 1], B[..., 0] + 1j * h * B[..., 1], n_x, degrees, polys, stages, t, check=False
        )
        gains[..., 1] = np.imag(Kc) / h
    return gains


def design(plan, lambdas, *, j: int = -1) -> TrackingDesign:
    """Frozen-time gains at every node of a plan, as series of order 1 (see module notes).

    The design model (:func:`linearize` ``model="design"``) is augmented with the integrals of the
    model's :attr:`~planners.chained.StateSpaceModel.integrands`, and the gains place the poles of
    each integral at ``-lambda`` by sequential input-output decoupling
    (:attr:`~planners.chained.StateSpaceModel.stages`), frozen at every node.

    Parameters
    ----------
    plan : Plan or planners.chained.ChainedPlan
        An aircraft plan (flat output beta, mu or F; the rudder may be fixed, eta is then the fourth
        input), or a plan of a chained system with an explicit model.
    lambdas : list of list of float, or float
        Positive pole magnitudes, one list per integral, of the lengths of the model's relative
        degrees: (3, 5, 5, 3), or (5, 5, 5) with the thrust output, for the aircraft; one number sets
        them all [1/s].
    j : int
        Plan iterate linearized about (and tracked).

    Returns
    -------
    TrackingDesign
        Augmented matrices ``A`` (N, n, n, K), ``B`` (N, n, m, K), gains ``K`` (N, m, n, K) with
        ``n = n_x + n_I`` and the model's feedback inputs.

    Raises
    ------
    InputError
        Bad lambdas, no explicit model or an unsupported flat output, iterate not in the plan.
    DomainError
        A node where an integral's relative degree is below the model's, or the decoupling matrix is
        singular (time and condition number named).
    """
    ssm = plan_model(plan)
    degrees = tuple(ssm.degrees)
    lam = _check_lambdas(lambdas, degrees)
    lin = linearize(plan, j, model="design", order=1)
    N, K, n_x, n_i = len(plan.t_nodes), lin.order + 1, len(ssm.states), len(degrees)
    n = n_x + n_i
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
    inputs = tuple(ssm.controls if ssm.inputs is None else ssm.inputs)
    B = np.zeros((N, n, len(inputs), K))
    B[:, :n_x] = lin.B[:, :, [ssm.controls.index(u) for u in inputs]]
    polys = [np.poly(-np.asarray(row))[::-1].real for row in lam]  # increasing powers, monic
    gains = _gain_series(A, B, n_x, degrees, polys, ssm.stages, plan.t_nodes)
    return TrackingDesign(
        np.asarray(plan.t_nodes, dtype=float),
        A,
        B,
        gains,
        inputs,
        tuple(f"I{p + 1}" for p in range(n_i)),
        degrees,
        lam,
        polys,
        tuple(ssm.stages),
        lin.iterate,
    )


def closed_loop_matrix(plan, des: TrackingDesign, model: str = "full") -> np.ndarray:
    """Frozen-time augmented closed loop at the nodes with the design's gains, on either linearization.

    Parameters
    ----------
    plan : Plan or planners.chained.ChainedPlan
    des : TrackingDesign
    model : {"full", "design"}
        ``"design"`` reproduces :meth:`TrackingDesign.closed_loop`; ``"full"``
        puts the exact model's Jacobians in place of the design model's.

    Returns
    -------
    ndarray, shape (N, n, n)
    """
    if model == "design":
        return des.closed_loop()
    ssm = plan_model(plan)
    n_x = len(ssm.states)
    lin = linearize(plan, des.iterate, model="full", order=0)
    A = des.A[..., 0].copy()
    A[:, :n_x, :n_x] = lin.A[..., 0]
    B = np.zeros_like(des.B[..., 0])
    B[:, :n_x] = lin.B[:, :, [ssm.controls.index(u) for u in des.inputs], 0]
    return A + np.einsum("Nam,Nmb->Nab", B, des.K[..., 0])


# --------------------------------------------------------------------------------------------
# Two-sided interpolants as polynomials per interval
# --------------------------------------------------------------------------------------------


def _two_sided(coeffs: np.ndarray, t_nodes: np.ndarray) -> np.ndarray:
    """Per-interval polynomial (in ``tau = t - t_i``) of the paper's two-sided formula
    (:func:`planners.plan.interval_coefficients` ``"paper"``).

    ``coeffs`` (N, ..., K): series at the nodes.  Returns (N - 1, ..., K + 1) with
    ``P_i(tau) = [(h - tau) s_i(tau) + tau s_{i+1}(tau - h)] / h``.
    """
    N, K = coeffs.shape[0], coeffs.shape[-1]
    flat = coeffs.reshape(N, -1, K)
    out = interval_coefficients(flat[:-1], flat[1:], np.diff(np.asarray(t_nodes, dtype=float)), "paper")
    return out.reshape((N - 1,) + coeffs.shape[1:-1] + (K + 1,))


# --------------------------------------------------------------------------------------------
# The controller
# --------------------------------------------------------------------------------------------


@dataclass
class TrackingController:
    """The paper's tracking feedback as a :class:`gna.controller.Controller` (an aircraft's: picklable, no closures).

    Built by :func:`tracking_controller`.  States: the integrals ``I1..I4``
    (``I1..I3`` with the thrust output).  Output: the correction
    ``sat(u~ + K [dx; I]) - u~`` to the feedforward ``u~`` = :meth:`controls`.

    Attributes
    ----------
    t_nodes : ndarray, shape (N,)
    reference_poly : ndarray, shape (N - 1, n_x + n_u, Kr)
        Per-interval polynomials (in ``t - t_i``) of the model's states and controls of the feedforward
        iterate (the aircraft's 12 states and 5 controls).
    gain_poly : ndarray, shape (N - 1, n_u, n, Kg)
        Per-interval polynomials of the gains mapped onto the controls (zero rows for non-inputs).
    zeta_index : int
        Aircraft: state index of zeta (7 for beta, 8 for mu), -1 with the thrust output.
    lower, upper : ndarray, shape (n_u,)
        Limits of the applied controls (``-inf``/``inf`` where none).
    saturate : bool
    state_names : tuple of str
    windup_mask : ndarray of bool, shape (n_states, n_u)
        ``windup_mask[p, k]``: integral p is frozen while control k is held at a limit
        (the inputs of the integral's decoupling stage).
    anti_windup : bool
    inputs : tuple of str
    lambdas : tuple
    feedforward_iterate : int
    n_states : int
    model_states, model_controls : tuple of str
        The model's variables (default the aircraft's :data:`gna.eom.STATE_NAMES`, :data:`gna.eom.CONTROL_NAMES`).
    angles : ndarray of int
        Indices of the states whose differences are wrapped into (-pi, pi] (the aircraft's angles).
    integrands : callable, optional
        A chained system's :attr:`~planners.chained.StateSpaceModel.integrands`, evaluated on the
        reference; None: the aircraft's ``I1..I4`` (module notes), computed inline (picklable).
    design : str
        ``"paper"`` (this design; ``"lqr"``: :class:`planners.lqr.LQRController`).
    """

    t_nodes: np.ndarray
    reference_poly: np.ndarray
    gain_poly: np.ndarray
    zeta_index: int
    lower: np.ndarray
    upper: np.ndarray
    saturate: bool
    state_names: tuple
    inputs: tuple
    lambdas: tuple
    feedforward_iterate: int
    n_states: int = field(default=4)
    windup_mask: np.ndarray = field(default_factory=lambda: np.zeros((4, 5), dtype=bool))
    anti_windup: bool = True
    #: ``(index of each time, reference (M, n_x + n_u), gains (M, n_u, n))`` precomputed at an engine's
    #: sample times by :meth:`at_times`; ``None`` evaluates the interpolants at every call.
    samples: tuple | None = field(default=None, repr=False, compare=False)
    model_states: tuple = STATE_NAMES
    model_controls: tuple = CONTROL_NAMES
    angles: np.ndarray = field(default_factory=lambda: _ANGLE_IDX)
    integrands: Callable | None = field(default=None, repr=False, compare=False)
    #: Which design made the gains (``[tracking] design``): ``"paper"`` here, ``"lqr"`` for
    #: :class:`planners.lqr.LQRController`.
    design: str = "paper"

    def _rates(self, ref: np.ndarray, e: np.ndarray) -> np.ndarray:
        """The integrands at the reference ``ref`` (n_x + n_u, ...) for the state errors ``e`` (n_x, ...)."""
        if self.integrands is not None:
            rows = self.integrands(dict(zip(self.model_states, ref[: len(self.model_states)])))
            C = np.array([[np.broadcast_to(np.asarray(c, dtype=float), e.shape[1:]) for c in row] for row in rows])
            return np.einsum("pb...,b...->p...", C, e)
        if np.ndim(ref) == 1:
            c, s = math.cos(ref[_CHI]), math.sin(ref[_CHI])
        else:
            c, s = np.cos(ref[_CHI]), np.sin(ref[_CHI])
        rows = [c * e[0] + s * e[1], -s * e[0] + c * e[1], e[2]]
        if self.zeta_index >= 0:
            rows.append(e[self.zeta_index])
        return np.array(rows)

    def _locate(self, t: float):
        t0, t1 = self.t_nodes[0], self.t_nodes[-1]
        t = t0 if t < t0 else (t1 if t > t1 else t)
        i = bisect.bisect_right(self._nodes_list, t) - 1
        i = 0 if i < 0 else (len(self.t_nodes) - 2 if i > len(self.t_nodes) - 2 else i)
        return i, t - self._nodes_list[i]

    @property
    def _nodes_list(self) -> list:
        cache = self.__dict__.get("_nl")
        if cache is None:
            cache = self.__dict__["_nl"] = [float(v) for v in self.t_nodes]
        return cache

    def reference(self, t: float) -> np.ndarray:
        """Reference states and feedforward controls of the plan iterate at ``t``.

        Parameters
        ----------
        t : float
            Time [s] (held at the plan's ends outside it).

        Returns
        -------
        ndarray, shape (17,)
            The 12 states then ``(F, eta, dl, dm, dn)``.
        """
        return self._reference(float(t))[0].copy()

    def _reference(self, t: float):
        """``(reference at t, interval, t - t_i)``, the last time's kept: the engine asks for the feedforward
        (:meth:`controls`) and then the feedback at the same time."""
        memo = self.__dict__.get("_memo")
        if memo is not None and memo[0] == t:
            return memo[1]
        i, tau = self._locate(t)
        pw = tau ** np.arange(self.reference_poly.shape[-1])
        out = (self.reference_poly[i] @ pw, i, tau)
        self.__dict__["_memo"] = (t, out, None)
        return out

    def controls(self, t) -> np.ndarray:
        """Feedforward controls ``(F, eta, dl, dm, dn)`` at ``t`` (the reference the engine flies).

        Vectorised over times, so that an engine can evaluate the feedforward once on its
        whole step grid (:func:`gna.trajectory.controls_on_grid`).

        Parameters
        ----------
        t : float or ndarray, shape (N,)
            Time [s] (held at the plan's ends outside it).

        Returns
        -------
        ndarray, shape (5,) or (5, N)
        """
        if np.ndim(t) == 0:
            return self.reference(t)[len(self.model_states) :]
        i, tau = self._locate_many(np.asarray(t, dtype=float))
        pw = tau[:, None] ** np.arange(self.reference_poly.shape[-1])
        return np.einsum("njk,nk->jn", self.reference_poly[i, len(self.model_states) :], pw)

    def initial_state(self, t0: float, x0: np.ndarray) -> np.ndarray:
        """Integrals at the start: zero.

        Parameters
        ----------
        t0 : float
            Start time [s].
        x0 : ndarray, shape (12,)
            Initial aircraft state.

        Returns
        -------
        ndarray, shape (n_states,)
        """
        return np.zeros(self.n_states)

    def at_times(self, times) -> TrackingController:
        """The same controller with its reference and gains precomputed at given times.

        A sampled engine knows its sample times in advance (JSBSim's step grid,
        or every ``controller_dt``): evaluating the per-interval polynomials
        there once, vectorised, leaves a few small products per sample.  At any
        other time the controller evaluates the interpolants as usual.

        Parameters
        ----------
        times : array_like, shape (M,)
            Sample times [s].

        Returns
        -------
        TrackingController
            A copy carrying the table (:attr:`samples`).
        """
        tt = np.asarray(times, dtype=float).reshape(-1)
        i, tau = self._locate_many(tt)
        ref = np.einsum("mjk,mk->mj", self.reference_poly[i], tau[:, None] ** np.arange(self.reference_poly.shape[-1]))
        gain = np.einsum("mjnk,mk->mjn", self.gain_poly[i], tau[:, None] ** np.arange(self.gain_poly.shape[-1]))
        return replace(self, samples=({v: m for m, v in enumerate(tt.tolist())}, ref, gain))

    def sample_evaluator(self) -> Callable | None:
        """The feedback at the m-th time of :meth:`at_times`, on Python floats: an engine's per-step call.

        The same arithmetic as :meth:`output_and_derivative` at ``times[m]`` (the
        same two matrix-vector products of the gains, every other operation one
        IEEE operation on floats in the same order): the same numbers, bitwise,
        without the array bookkeeping of a general call.

        Returns
        -------
        callable or None
            ``f(m, x, xc) -> (output, derivative)``: ``x`` the 12 states and ``xc``
            the ``n_states`` integrals (sequences of float); the 5 corrections and
            the ``n_states`` integrands as lists of float.  None without a table
            (:meth:`at_times` not called) or with a chained system's integrands.
        """
        if self.samples is None or self.integrands is not None:
            return None
        _, ref_table, gain_table = self.samples
        core = self._on_floats

        def evaluate(m: int, x, xc):
            _, _, out, rates = core(ref_table[m].tolist(), gain_table[m], x, xc)
            return out, rates

        return evaluate

    def _on_floats(self, ref: list, gain: np.ndarray, x, xc) -> tuple[list, list, list, list]:
        """:meth:`_evaluate`'s arithmetic on floats, given the reference and gains at the time (an aircraft's).

        ``ref`` (n_x + n_u floats), ``gain`` (n_u, n) array, ``x`` the n_x states and ``xc`` the integrals
        (sequences of float).  Returns ``(u, du, out, rates)`` as lists: every operation the IEEE operation
        numpy does element by element, in the same order, and the two matrix-vector products of the gains
        themselves, so the same numbers, bitwise.
        """
        n_x = len(self.model_states)
        fixed = self.__dict__.get("_fl")
        if fixed is None:
            n_u = len(self.model_controls)
            fixed = self.__dict__["_fl"] = (
                [int(a) for a in self.angles],
                self.lower.tolist(),
                self.upper.tolist(),
                [[k for k in range(n_u) if self.windup_mask[p, k]] for p in range(self.n_states)],
            )
        angles, lower, upper, windup = fixed
        pi, two_pi = math.pi, _TWO_PI
        e = [a - b for a, b in zip(x[:n_x], ref)]
        for i in angles:
            e[i] = (e[i] + pi) % two_pi - pi
        du = [
            a + b
            for a, b in zip(
                (gain[:, :n_x] @ np.array(e)).tolist(), (gain[:, n_x:] @ np.array(xc, dtype=float)).tolist()
            )
        ]
        u = ref[n_x:]
        c, s = math.cos(ref[_CHI]), math.sin(ref[_CHI])
        rates = [c * e[0] + s * e[1], -s * e[0] + c * e[1], e[2]]
        if self.zeta_index >= 0:
            rates.append(e[self.zeta_index])
        if not self.saturate:
            return u, du, du, rates
        total = [a + b for a, b in zip(u, du)]
        held = [v < lo or v > hi for v, lo, hi in zip(total, lower, upper)]
        if self.anti_windup and True in held:
            # Conditional integration: the integrals of a decoupling stage stop while one of its inputs
            # is held at a limit (otherwise they wind up and the loop leaves the linear domain).
            for p, inputs in enumerate(windup):
                if any(held[k] for k in inputs):
                    rates[p] = 0.0
        out = []
        for v, lo, hi, a in zip(total, lower, upper, u):
            v = lo if v < lo else v  # np.maximum then np.minimum: a NaN stays NaN
            v = hi if v > hi else v
            out.append(v - a)
        return u, du, out, rates

    def _locate_many(self, t: np.ndarray):
        tt = np.clip(t, self.t_nodes[0], self.t_nodes[-1])
        i = np.clip(np.searchsorted(self.t_nodes, tt, side="right") - 1, 0, len(self.t_nodes) - 2)
        return i, tt - self.t_nodes[i]

    def _reference_and_gain(self, t: float):
        if self.samples is not None:
            m = self.samples[0].get(t)
            if m is not None:
                return self.samples[1][m], self.samples[2][m]
        t = float(t)
        ref, i, tau = self._reference(t)
        memo = self.__dict__["_memo"]
        if memo[2] is None:
            memo = self.__dict__["_memo"] = (
                t,
                memo[1],
                self.gain_poly[i] @ (tau ** np.arange(self.gain_poly.shape[-1])),
            )
        return ref, memo[2]

    def _evaluate(self, t: float, x: np.ndarray, xc: np.ndarray):
        """Feedforward, unsaturated feedback, the correction applied and the integrands, from one
        evaluation of the reference and gains."""
        n_x = len(self.model_states)
        ref, gain = self._reference_and_gain(t)  # (n_x + n_u,), (n_u, n)
        if self.integrands is None:  # the aircraft's, on floats: the engines call this at every step
            x = np.asarray(x, dtype=float)[:n_x].tolist()
            u, du, out, rates = self._on_floats(ref.tolist(), gain, x, np.asarray(xc, dtype=float))
            return np.array(u), np.array(du), np.array(out), np.array(rates)
        e = np.asarray(x, dtype=float)[:n_x] - ref[:n_x]
        e[self.angles] = (e[self.angles] + math.pi) % _TWO_PI - math.pi
        du = gain[:, :n_x] @ e + gain[:, n_x:] @ np.asarray(xc, dtype=float)
        u = ref[n_x:].copy()  # the caller's: the reference is kept (_reference)
        rates = self._rates(ref, e)
        if not self.saturate:
            return u, du, du, rates
        total = u + du
        held = (total < self.lower) | (total > self.upper)
        if self.anti_windup and held.any():
            # Conditional integration: the integrals of a decoupling stage stop while one of its inputs
            # is held at a limit (otherwise they wind up and the loop leaves the linear domain).
            rates[(self.windup_mask & held).any(axis=1)] = 0.0
        return u, du, np.minimum(np.maximum(total, self.lower), self.upper) - u, rates

    def derivative(self, t: float, x: np.ndarray, xc: np.ndarray) -> np.ndarray:
        """The integrands ``(cos chi~ dx + sin chi~ dy, -sin chi~ dx + cos chi~ dy, dz[, d zeta])``.

        With saturation and anti-windup, the integrals of a decoupling stage are
        held (integrand 0) while one of that stage's inputs is at a limit.

        Parameters
        ----------
        t : float
            Time [s].
        x : ndarray, shape (12,)
            Aircraft state.
        xc : ndarray, shape (n_states,)
            Integrals.

        Returns
        -------
        ndarray, shape (n_states,)
        """
        return self._evaluate(t, x, xc)[3]

    def commanded(self, t: float, x: np.ndarray, xc: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Feedforward and unsaturated feedback at ``t``.

        Parameters
        ----------
        t : float
            Time [s].
        x : ndarray, shape (12,)
            Aircraft state.
        xc : ndarray, shape (n_states,)
            Integrals.

        Returns
        -------
        (ndarray, ndarray), shapes (5,) and (5,)
            ``u~(t)`` and ``K(t) [dx; I]`` (before saturation).
        """
        u, du, _, _ = self._evaluate(t, x, xc)
        return u, du

    def _commanded_rows(self, t: np.ndarray, X: np.ndarray, XC: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`commanded` at every row: times (M,), states (M, n_x), integrals (M, n_states) -> (M, n_u) twice.

        Row by row the same operations as :meth:`commanded` (the interval's powers of ``t - t_i``, the
        same matrix-vector products, stacked), so the same numbers, bitwise.
        """
        n_x = len(self.model_states)
        i, tau = self._locate_many(t)
        pw = tau[:, None] ** np.arange(self.reference_poly.shape[-1])
        ref = np.matmul(self.reference_poly[i], pw[:, :, None])[:, :, 0]
        pw = tau[:, None] ** np.arange(self.gain_poly.shape[-1])
        gain = np.matmul(self.gain_poly[i], pw[:, None, :, None])[..., 0]
        e = X[:, :n_x] - ref[:, :n_x]
        e[:, self.angles] = (e[:, self.angles] + math.pi) % _TWO_PI - math.pi
        du = np.matmul(gain[:, :, :n_x], e[:, :, None])[..., 0] + np.matmul(gain[:, :, n_x:], XC[:, :, None])[..., 0]
        return ref[:, n_x:], du

    def output(self, t: float, x: np.ndarray, xc: np.ndarray) -> np.ndarray:
        """Correction added to the feedforward: ``sat(u~ + K [dx; I]) - u~``.

        Parameters
        ----------
        t : float
            Time [s].
        x : ndarray, shape (12,)
            Aircraft state.
        xc : ndarray, shape (n_states,)
            Integrals.

        Returns
        -------
        ndarray, shape (5,)
            ``(dF [N], d_eta [-], d_dl, d_dm, d_dn [rad])``.
        """
        return self._evaluate(t, x, xc)[2]

    def output_and_derivative(self, t: float, x: np.ndarray, xc: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`output` and :meth:`derivative` at one point from one evaluation (see
        :func:`gna.controller.evaluate`).

        Parameters
        ----------
        t : float
            Time [s].
        x : ndarray, shape (12,)
            Aircraft state.
        xc : ndarray, shape (n_states,)
            Integrals.

        Returns
        -------
        (ndarray, ndarray), shapes (5,) and (n_states,)
        """
        _, _, out, rates = self._evaluate(t, x, xc)
        return out, rates

    def output_and_derivative_many(self, t, X: np.ndarray, XC: np.ndarray, *, with_feedforward: bool = False):
        """:meth:`output_and_derivative` for many aircraft at once (batched simulation).

        The same arithmetic as :meth:`output_and_derivative`, one column per aircraft.

        Parameters
        ----------
        t : float or ndarray, shape (n,)
            Time [s], common or one per aircraft.
        X : ndarray, shape (12, n)
            Aircraft states, one column per aircraft.
        XC : ndarray, shape (n_states, n)
            Integrals, one column per aircraft.
        with_feedforward : bool
            Also return the feedforward ``u~`` (:meth:`controls`) at ``t``.

        Returns
        -------
        (ndarray, ndarray[, ndarray]), shapes (5, n), (n_states, n)[, (5, n)]
            Corrections ``sat(u~ + K [dx; I]) - u~``, integrands[, feedforward].
        """
        X = np.asarray(X, dtype=float)
        XC = np.asarray(XC, dtype=float)
        n_x = len(self.model_states)
        if np.ndim(t) == 0:
            ref, gain = self._reference_and_gain(float(t))
            ref = ref[:, None]
            e = X[:n_x] - ref[:n_x]
            e[self.angles] = (e[self.angles] + math.pi) % _TWO_PI - math.pi
            du = gain[:, :n_x] @ e + gain[:, n_x:] @ XC
            rates = self._rates(ref[:, 0], e) if self.integrands is None else self._rates(ref, e)
        else:
            i, tau = self._locate_many(np.asarray(t, dtype=float))
            ref = _horner(self.reference_poly[i], tau[:, None]).T  # (n_x + n_u, n)
            gain = _horner(self.gain_poly[i], tau[:, None, None])  # (n, n_u, n_x + n_states)
            e = X[:n_x] - ref[:n_x]
            e[self.angles] = (e[self.angles] + math.pi) % _TWO_PI - math.pi
            du = (gain @ np.concatenate([e, XC]).T[:, :, None])[:, :, 0].T
            rates = self._rates(ref, e)
        u = ref[n_x:]
        if self.saturate:
            total = u + du
            held = (total < self.lower[:, None]) | (total > self.upper[:, None])
            if self.anti_windup and held.any():
                frozen = (self.windup_mask[:, :, None] & held[None, :, :]).any(axis=1)
                rates[frozen] = 0.0
            du = np.minimum(np.maximum(total, self.lower[:, None]), self.upper[:, None]) - u
        if with_feedforward:
            return du, rates, np.broadcast_to(u, du.shape)
        return du, rates

    def saturated_time(self, df, controller_states=None) -> dict:
        """Time during which the commanded controls exceed their limits, per control.

        Parameters
        ----------
        df : pandas.DataFrame
            A closed-loop trajectory indexed by time [s] with the 12 state columns.
        controller_states : array_like, shape (len(df), n_states), optional
            The integrals along the run; default the columns :attr:`state_names` of ``df``.

        Returns
        -------
        dict
            ``{"F": s, ..., "any": s}``: seconds with the commanded control
            (feedforward + feedback) outside its limits (rectangle rule on the rows).

        Raises
        ------
        InputError
            When neither ``controller_states`` nor the integral columns are given.
        """
        if controller_states is None:
            missing = [c for c in self.state_names if c not in df.columns]
            if missing:
                raise InputError(
                    f"saturated_time needs the controller states ({', '.join(self.state_names)}) as "
                    f"columns of the trajectory or as controller_states; missing {', '.join(missing)}"
                )
            controller_states = df[list(self.state_names)].to_numpy(dtype=float)
        xc = np.asarray(controller_states, dtype=float).reshape(len(df), self.n_states)
        t = df.index.to_numpy(dtype=float)
        X = df[list(self.model_states)].to_numpy(dtype=float)
        if self.samples is None:  # every row at once
            u, du = self._commanded_rows(t, X, xc)
            tot = u + du
            out_of = (tot < self.lower) | (tot > self.upper)
        else:  # a prepared copy reads its table at its sample times: the same values as an engine's
            out_of = np.zeros((len(t), len(self.model_controls)), dtype=bool)
            for k in range(len(t)):
                u, du = self.commanded(t[k], X[k], xc[k])
                tot = u + du
                out_of[k] = (tot < self.lower) | (tot > self.upper)
        dt = np.diff(t, append=t[-1]) if len(t) else t
        res = {name: float(np.sum(dt[out_of[:, i]])) for i, name in enumerate(self.model_controls)}
        res["any"] = float(np.sum(dt[np.any(out_of, axis=1)]))
        return res

    def __getstate__(self):
        state = dict(self.__dict__)
        state.pop("_nl", None)
        state.pop("_fl", None)
        state.pop("_memo", None)
        return state


def _horner(coeffs: np.ndarray, tau: np.ndarray) -> np.ndarray:
    """``sum_k coeffs[..., k] tau^k`` by Horner's rule (``tau`` broadcast against ``coeffs[..., 0]``)."""
    acc = coeffs[..., -1]
    for k in range(coeffs.shape[-1] - 2, -1, -1):
        acc = acc * tau + coeffs[..., k]
    return acc


def tracking_controller(
    plan, lambdas, *, feedforward_iterate: int = -1, saturate: bool = True, anti_windup: bool = True
) -> TrackingController:
    """The paper's tracking feedback for a plan (:func:`design`), ready to fly.

    Parameters
    ----------
    plan : Plan or planners.chained.ChainedPlan
        An aircraft plan (flat output beta, mu or F; eta as fourth control when the rudder is
        fixed), or a plan of a chained system with an explicit model.
    lambdas : list of list of float, or float
        Positive pole magnitudes [1/s], one list per integral: for the aircraft ``I1..I4``
        (lengths 3, 5, 5, 3; or 5, 5, 5 for ``I1..I3`` with the thrust output),
        e.g. :func:`paper_lambdas`.  The closed loop obeys ``prod (d/dt + lambda) I_p = 0``.
    feedforward_iterate : int
        Plan iterate j whose controls are the feedforward and whose states the
        reference (default the last; 0 = the flat plan, the paper's dark-blue curve).
        The gains are designed about the same iterate.
    saturate : bool
        Aircraft: clip the applied controls at the aircraft's surface limits
        (``aircraft.envelope.control_limits``), the thrust range
        ``0 .. propulsion.max_thrust`` and ``|eta| <= 1`` for two engines (a chained system's
        controls have no limits).
    anti_windup : bool
        With ``saturate``: the integrals of a decoupling stage (I1 with F; I2..I4
        with the surfaces) stop integrating while one of that stage's inputs is
        held at a limit (conditional integration).

    Returns
    -------
    TrackingController
        Reference and feedforward between nodes by the plan's own formula (an aircraft plan's
        :attr:`~planners.plan.Plan.interpolation`; a chained plan's two-sided formula), gains by the
        two-sided formula.

    Raises
    ------
    InputError
        Bad lambdas, no explicit model or an unsupported flat output, iterate not in the plan.
    DomainError
        A node where the decoupling matrix is singular.
    """
    ssm = plan_model(plan)
    des = design(plan, lambdas, j=feedforward_iterate)
    j = des.iterate
    states, controls = tuple(ssm.states), tuple(ssm.controls)
    names = states + controls
    N, n_u = len(plan.t_nodes), len(controls)
    aircraft = isinstance(plan, Plan)
    if aircraft:  # the feedforward is the plan's own states and controls between nodes (its interpolation formula)
        reference_poly = plan._coefficients(names, j)
    else:
        sol = plan.iterates[j]
        series = np.zeros((N, len(names), max(sol[n].order for n in names) + 1))
        for v, n in enumerate(names):
            c = np.broadcast_to(np.real(np.asarray(sol[n].coeffs)), (N, sol[n].order + 1))
            series[:, v, : c.shape[1]] = c
        reference_poly = _two_sided(series, plan.t_nodes)
    gains = np.zeros((N, n_u, des.n, des.K.shape[-1]))
    for k, u in enumerate(des.inputs):
        gains[:, controls.index(u)] = des.K[:, k]
    gain_poly = _two_sided(gains, plan.t_nodes)
    lower, upper = np.full(n_u, -np.inf), np.full(n_u, np.inf)
    zeta_index = -1
    if aircraft:
        lower, upper = tracking_limits(plan)
        zeta = plan.problem.zeta.kind
        zeta_index = STATE_NAMES.index(zeta) if zeta in ("beta", "mu") else -1
    mask = np.zeros((len(des.integrals), n_u), dtype=bool)
    for outs, cols in des.stages:
        for p in outs:
            mask[p, [controls.index(des.inputs[k]) for k in cols]] = True
    return TrackingController(
        np.asarray(plan.t_nodes, dtype=float),
        reference_poly,
        gain_poly,
        zeta_index,
        lower,
        upper,
        bool(saturate) and aircraft,
        des.integrals,
        des.inputs,
        des.lambdas,
        j,
        len(des.integrals),
        mask,
        bool(anti_windup),
        model_states=states,
        model_controls=controls,
        angles=_ANGLE_IDX if aircraft else np.zeros(0, dtype=int),
        integrands=None if aircraft else ssm.integrands,
    )


def tracking_limits(plan) -> tuple[np.ndarray, np.ndarray]:
    """Limits of the applied controls of an aircraft plan's tracking feedback.

    The surfaces at the aircraft's deflection limits (``aircraft.envelope.control_limits``), the thrust
    in ``0 .. propulsion.max_thrust`` (no upper bound for an unrated engine) and ``|eta| <= 1`` for two
    engines; ``-inf``/``inf`` where there is none.

    Parameters
    ----------
    plan : Plan
        An aircraft plan.

    Returns
    -------
    (ndarray, ndarray), shapes (5,) and (5,)
        Lower and upper limits of ``(F [N], eta, dl, dm, dn [rad])``.
    """
    n_u = len(CONTROL_NAMES)
    lower, upper = np.full(n_u, -np.inf), np.full(n_u, np.inf)
    ac = plan.aircraft
    for name, lim in ac.envelope.control_limits.items():
        if name in CONTROL_NAMES:
            lower[CONTROL_NAMES.index(name)], upper[CONTROL_NAMES.index(name)] = -lim, lim
    lower[0] = 0.0
    if ac.propulsion.max_thrust is not None:
        upper[0] = ac.propulsion.max_thrust
    if ac.propulsion.count == 2:
        lower[1], upper[1] = -1.0, 1.0
    return lower, upper


def simulate_closed_loop(plan, controller: TrackingController, x0, t_eval, rtol: float = 1e-9, atol: float = 1e-9):
    """Fly a chained system's exact model (``rhs(x, u, None)`` of :func:`plan_model`) in closed loop, DOP853.

    The aircraft flies in the engines (:mod:`harness.engines`, ``controller=``); this is the same loop
    for the other systems: ``x' = f(x, u~(t) + output)``, integrals from 0 with the controller's
    integrands.

    Parameters
    ----------
    plan : planners.chained.ChainedPlan or Plan
        The plan whose model is flown.
    controller : TrackingController
        :func:`tracking_controller` of that plan.
    x0 : array, shape (n_x,)
        Initial state (e.g. the plan's, perturbed).
    t_eval : array, shape (M,)
        Output times [s], increasing, within the plan, the first the initial time.
    rtol, atol : float
        Integrator tolerances.

    Returns
    -------
    X : ndarray, shape (M, n_x)
        States.
    U : ndarray, shape (M, n_u)
        Applied controls.

    Raises
    ------
    ConvergenceError
        The integrator failed.
    """
    from scipy.integrate import solve_ivp

    from gna.errors import ConvergenceError

    rhs = plan_model(plan).rhs
    t_eval = np.asarray(t_eval, dtype=float)
    n_x = len(controller.model_states)

    def applied(t, z):
        du, rates = controller.output_and_derivative(t, z[:n_x], z[n_x:])
        return controller.controls(t) + du, rates

    def f(t, z):
        u, rates = applied(t, z)
        return np.concatenate([np.asarray(rhs(list(z[:n_x]), list(u), None), dtype=float), rates])

    z0 = np.concatenate([np.asarray(x0, dtype=float), controller.initial_state(t_eval[0], x0)])
    sol = solve_ivp(f, (t_eval[0], t_eval[-1]), z0, t_eval=t_eval, method="DOP853", rtol=rtol, atol=atol)
    if not sol.success:
        raise ConvergenceError(f"closed-loop simulation failed at t = {sol.t[-1]:.6g} s: {sol.message}")
    Z = sol.y.T
    U = np.array([applied(t, z)[0] for t, z in zip(t_eval, Z)])
    return Z[:, :n_x], U
