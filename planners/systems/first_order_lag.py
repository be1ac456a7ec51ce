"""The paper's linear example of generalized flatness: ``x' = y + eps y'`` (section "Generalized
flatness from the theoretical standpoint").

With ``eps = 0``, x is a flat output; for ``eps > 0`` the paper keeps x as a *generalized* flat
output: ``y = (1 + eps d/dt)^-1 x' = sum_i (-eps)^i x^(i+1)``, which converges when x is analytic
with a convergence radius greater than ``eps`` (for ``x = sin(w t)``: when ``eps w < 1``).

As an almost chained system (eq. chained-sys), with the derivative of the control as a chained
variable (the paper adds ``F^(p-3)`` to its stages the same way): Z_1 = {x}, X_2 = {y}, X_3 = {y1},

* stage 1: ``x' = y + H_1(y1)``, ``H_1 = eps y1`` (l_1 = 2: L = 1);
* stage 2: ``y' = y1``.

The J-th iterate of the generalized parametrization is the partial sum
``sum_(i <= J) (-eps d/dt)^i x'``.
"""

from __future__ import annotations

import numpy as np

from ..chained import ChainedSystem, Stage, StateSpaceModel


def first_order_lag(eps: float = 0.1) -> ChainedSystem:
    """The system ``x' = y + eps y'`` with x as generalized flat output.

    Parameters
    ----------
    eps : float
        Time constant of the lag [s].

    Returns
    -------
    ChainedSystem
        Stages ``x' = y + eps y1`` (y1 neglected, from the previous iterate) and ``y' = y1``.
    """
    eps = float(eps)
    return ChainedSystem(
        name="first-order-lag",
        flat_outputs={"x": 1},
        # at stage 1, "y1" is the neglected variable's value from the previous iterate
        stages=(
            Stage(("y",), lambda v: [v["x'"] - v["y"] - eps * v["y1"]], neglected=("y1",), ell=2),
            Stage(("y1",), lambda v: [v["y'"] - v["y1"]]),
        ),
        description=f"x' = y + eps y' with eps = {eps:g} s; x is a generalized flat output",
        # states x, y, control y1 = y'; the design model freezes H_1 = eps y1 at the plan's values:
        # I = int dx has relative degree 3 (dx, then dy, then dy1)
        model=StateSpaceModel(
            ("x", "y"),
            ("y1",),
            lambda x, u, hat=None: [x[1] + eps * (u[0] if hat is None else hat["y1"]), u[0]],
            lambda ref: [[1.0, 0.0]],
            degrees=(3,),
            stages=(((0,), (0,)),),
        ),
    )


def lag_reference(x_derivative, eps: float, omega: float):
    """The exact ``y = (1 + eps d/dt)^-1 x'`` for ``x' = a cos(w t) + b sin(w t)`` (the operator relation).

    Parameters
    ----------
    x_derivative : tuple of float
        ``(a, b)``.
    eps : float
        Lag time constant [s].
    omega : float
        Angular frequency w [rad/s].

    Returns
    -------
    callable
        ``y(t)``: the periodic solution of ``y + eps y' = x'``.
    """
    a, b = x_derivative
    d = 1.0 + (eps * omega) ** 2
    # y = A cos + B sin with A + eps w B = a, B - eps w A = b
    A = (a - eps * omega * b) / d
    B = (b + eps * omega * a) / d
    return lambda t: A * np.cos(omega * np.asarray(t)) + B * np.sin(omega * np.asarray(t))


def lag_exact(x, eps: float, t, points: int = 80) -> np.ndarray:
    """The exact ``y = (1 + eps d/dt)^-1 x'`` for any analytic ``x``, by the Laplace integral of the operator.

    ``(1 + eps D)^-1 = int_0^inf e^-u e^(-eps u D) du``, so ``y(t) = int_0^inf e^-u x'(t - eps u) du``:
    termwise it is the paper's series ``sum_i (-eps)^i x^(i+1)`` (``int e^-u u^i du = i!``), and its
    (Borel) sum where that series diverges; for exponential-polynomial ``x`` it is the exact operator
    relation (``x = e^(l t)``: ``y = l e^(l t) / (1 + eps l)``).  Gauss-Laguerre quadrature with
    ``points`` nodes, exact for polynomial ``x`` of degree up to ``2 points``.

    Parameters
    ----------
    x : callable
        The flat output as a function of t (evaluated on Series for its derivative).
    eps : float
        Lag time constant [s], positive.
    t : array, shape (N,)
        Times [s].
    points : int
        Quadrature nodes.

    Returns
    -------
    ndarray, shape (N,)
        ``y`` at ``t``.
    """
    from ..series import Series

    u, w = np.polynomial.laguerre.laggauss(points)
    tt = np.asarray(t, dtype=float)[:, None] - float(eps) * u[None, :]
    xs = x(Series.variable(tt.ravel(), 1))
    xd = np.real(np.broadcast_to(xs.coeffs[..., 1], tt.size) if isinstance(xs, Series) else np.zeros(tt.size))
    return xd.reshape(tt.shape) @ w
