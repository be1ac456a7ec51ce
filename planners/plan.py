"""The result of motion planning: every node's series, evaluated anywhere.

Between nodes ``t_i <= t <= t_{i+1}`` (``h = t_{i+1} - t_i``) a variable ``s`` is a polynomial built
once per interval from the series ``s_i`` and ``s_{i+1}`` of the two ends, by one of two formulas
(:data:`INTERPOLATIONS`, the plan's ``interpolation``):

* ``"hermite"`` (default): two-point Hermite interpolation, the polynomial of degree ``2 m + 1``
  whose derivatives up to order ``m`` at both ends are those of the series (``m`` the series'
  order, at most :data:`HERMITE_MAX_ORDER`; for the five controls the surfaces' order, ``e`` in the
  last iterate, although F's series is two orders longer).  It is ``C^m`` at the nodes and its error is
  ``O(h^(2 m + 2))``: for the controls of the last iterate (order ``e``), ``O(h^(2 e + 2))``.
* ``"paper"``: the paper's two-sided formula (section "Motion planning")::

      [(t_{i+1} - t) s_i(t - t_i) + (t - t_i) s_{i+1}(t - t_{i+1})] / h

  a polynomial of degree ``K + 1`` for series of order ``K``, only ``C^0`` at the nodes and
  ``O(h^(e + 1))`` accurate for the controls.

Values and derivatives (``Plan.evaluate(..., derivative=k)``) are those of these polynomials,
exactly; :meth:`Plan.control_function` returns them as a :class:`gna.piecewise.PiecewisePolynomial`
for the integrators.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from fractions import Fraction
from functools import cache

import numpy as np
import pandas as pd

from gna.aircraft import Aircraft
from gna.atmosphere import Environment
from gna.eom import CONTROL_NAMES, STATE_NAMES, Controls, HValues, State, derivatives
from gna.errors import InputError
from gna.piecewise import PiecewisePolynomial

from .flat import FlatProblem, NodeSolution
from .newton import NewtonFailure
from .singularity import SingularityReport

PLAN_VARIABLES = STATE_NAMES + CONTROL_NAMES


#: Evaluation between nodes: two-point Hermite interpolation of the node series, or the paper's
#: two-sided formula (section "Motion planning").
INTERPOLATIONS = ("hermite", "paper")
#: Default evaluation between nodes (measured in docs/planning.md, "Accuracy between nodes").
DEFAULT_INTERPOLATION = "hermite"
#: Highest derivative order the Hermite interpolation matches at each end (degree 2 m + 1 <= 17): the
#: monomial form of the two-point Taylor basis grows like 4^m, so higher orders would only add rounding.
HERMITE_MAX_ORDER = 8


@cache
def hermite_matrix(m: int) -> np.ndarray:
    """Monomial coefficients of the two-point Hermite interpolant on ``[0, 1]`` from Taylor data at both ends.

    The polynomial ``P(w) = sum_k c_k w^k`` of degree ``2 m + 1`` whose Taylor coefficients at
    ``w = 0`` are ``A_0..A_m`` and at ``w = 1`` are ``B_0..B_m`` is ``c = M @ concat(A, B)``
    (computed in exact rational arithmetic, then rounded).  Hermite interpolation with two nodes of
    multiplicity ``m + 1`` (Stoer & Bulirsch, *Introduction to Numerical Analysis*, sec. 2.1.5).

    Parameters
    ----------
    m : int
        Highest derivative order matched at each end (>= 0).

    Returns
    -------
    ndarray, shape (2 m + 2, 2 m + 2)
        ``M``: columns ``0..m`` multiply ``A``, columns ``m + 1..2 m + 1`` multiply ``B``.

    Raises
    ------
    InputError
        A negative ``m``.
    """
    if m < 0:
        raise InputError(f"the Hermite order must be >= 0, got {m}")
    n = 2 * m + 2
    # Rows: Taylor coefficient k at 0 is c_k; at 1 it is sum_j C(j, k) c_j.
    rows = [[Fraction(int(j == k)) for j in range(n)] for k in range(m + 1)]
    rows += [[Fraction(math.comb(j, k)) for j in range(n)] for k in range(m + 1)]
    inv = _rational_inverse(rows)
    out = np.array([[float(v) for v in r] for r in inv])
    out.setflags(write=False)  # cached: shared by every caller
    return out


def _rational_inverse(a: list) -> list:
    """Inverse of a square matrix of Fractions (Gauss-Jordan, exact)."""
    n = len(a)
    aug = [list(r) + [Fraction(int(i == j)) for j in range(n)] for i, r in enumerate(a)]
    for col in range(n):
        piv = next(r for r in range(col, n) if aug[r][col] != 0)
        aug[col], aug[piv] = aug[piv], aug[col]
        p = aug[col][col]
        aug[col] = [v / p for v in aug[col]]
        for r in range(n):
            if r != col and aug[r][col] != 0:
                f = aug[r][col]
                aug[r] = [v - f * w for v, w in zip(aug[r], aug[col])]
    return [r[n:] for r in aug]


@cache
def _shift_matrix(K: int) -> np.ndarray:
    """``T`` with ``sum_k B_k (w - 1)^k = sum_j (T @ B)_j w^j`` for ``k, j = 0..K``."""
    T = np.zeros((K + 1, K + 1))
    for k in range(K + 1):
        for j in range(k + 1):
            T[j, k] = math.comb(k, j) * (-1.0) ** (k - j)
    T.setflags(write=False)
    return T


def interval_coefficients(a: np.ndarray, b: np.ndarray, h: np.ndarray, interpolation: str) -> np.ndarray:
    """Polynomial on each interval ``[t_i, t_i + h_i]`` from the node series at both ends.

    ``"paper"``: the two-sided formula ``[(h - s) A(s) + s B(s - h)] / h`` (degree K + 1; paper
    section "Motion planning");
    ``"hermite"``: the polynomial of degree ``2 m + 1`` with the Taylor coefficients ``0..m`` of
    ``A`` at ``s = 0`` and of ``B`` at ``s = h``, ``m = min(K, HERMITE_MAX_ORDER)`` (C^m at the
    nodes, error O(h^(2 m + 2)) for smooth data).

    Parameters
    ----------
    a, b : ndarray, shape (n, v, K + 1)
        Taylor coefficients (ascending powers of ``t - t_i``, resp. ``t - t_(i+1)``) of ``v``
        functions at the left and right ends of ``n`` intervals.
    h : ndarray, shape (n,)
        Interval lengths [s].
    interpolation : {"hermite", "paper"}
        The formula.

    Returns
    -------
    ndarray, shape (n, v, d + 1)
        Coefficients in ascending powers of ``s = t - t_i``.

    Raises
    ------
    InputError
        An unknown ``interpolation``.
    """
    K = a.shape[-1] - 1
    scale = h[:, None] ** np.arange(K + 1)  # Taylor coefficients in w = s / h
    A = a * scale[:, None, :]
    B = b * scale[:, None, :]
    if interpolation == "hermite":
        m = min(K, HERMITE_MAX_ORDER)
        M = hermite_matrix(m)
        c = np.einsum("jk,nvk->nvj", M, np.concatenate([A[..., : m + 1], B[..., : m + 1]], axis=-1))
    elif interpolation == "paper":
        Bw = np.einsum("jk,nvk->nvj", _shift_matrix(K), B)
        c = np.zeros(A.shape[:-1] + (K + 2,))
        c[..., : K + 1] = A  # (1 - w) A(w) + w B(w - 1), w = s / h
        c[..., 1:] -= A
        c[..., 1:] += Bw
    else:
        raise InputError(
            f"interpolation must be one of {', '.join(repr(v) for v in INTERPOLATIONS)}, got {interpolation!r}"
        )
    d = c.shape[-1]
    return c / h[:, None, None] ** np.arange(d)


def check_interpolation(value, where: str = "plan") -> str:
    """The evaluation between nodes, checked: one of :data:`INTERPOLATIONS`.

    Parameters
    ----------
    value : str
        ``"hermite"`` or ``"paper"``.
    where : str
        What the message names (file, function).

    Returns
    -------
    str

    Raises
    ------
    InputError
        Any other value.
    """
    if not isinstance(value, str) or value not in INTERPOLATIONS:
        raise InputError(
            f"{where}: interpolation must be one of {', '.join(repr(v) for v in INTERPOLATIONS)}, got {value!r}"
        )
    return value


def _horner(c: np.ndarray, s: np.ndarray, k: int) -> np.ndarray:
    """k-th derivative of polynomials ``c`` (N, v, d + 1) at offsets ``s`` (N,): (v, N)."""
    d = c.shape[-1] - 1
    if k > d:
        return np.zeros((c.shape[1], s.size))
    m = np.arange(k, d + 1)
    fall = np.ones(m.size)
    for j in range(k):
        fall = fall * (m - j)
    c = c[..., k:] * fall
    out = c[..., -1]
    for p in range(c.shape[-1] - 2, -1, -1):
        out = out * s[:, None] + c[..., p]
    return out.T.copy()


def _horner_blocks(c: np.ndarray, i: np.ndarray, s: np.ndarray) -> np.ndarray:
    """:func:`_horner` ``(c[i], s, 0)`` for non-decreasing interval indices ``i``: one Horner per interval on
    its block of offsets (the same operations on every value: the same values, without the gather)."""
    v, N = c.shape[1], s.size
    out = np.empty((v, N))
    starts = np.concatenate(([0], np.flatnonzero(np.diff(i)) + 1, [N]))
    for a, b in zip(starts[:-1], starts[1:]):
        cp = c[i[a]]  # (v, d + 1)
        sb = s[a:b]
        o = out[:, a:b]
        o[:] = cp[:, -1:]
        for p in range(cp.shape[1] - 2, -1, -1):  # in place: the same operations as o = o * s + c
            o *= sb
            o += cp[:, p : p + 1]
    return out


@dataclass(frozen=True)
class PlanFunctions(PiecewisePolynomial):
    """Plan variables as a :class:`gna.piecewise.PiecewisePolynomial` that also takes arrays of times.

    A call with one time (the integrators' path) is the piecewise polynomial's scalar call; a call with an
    array of times (batched integrators) is :meth:`~gna.piecewise.PiecewisePolynomial.evaluate`.

    Parameters
    ----------
    breaks : ndarray, shape (n + 1,)
        The plan's nodes [s].
    coeffs : ndarray, shape (n, m, d + 1)
        Per-interval coefficients in ascending powers of ``t - breaks[i]`` (:meth:`Plan.piecewise`).

    Raises
    ------
    InputError
        As :class:`gna.piecewise.PiecewisePolynomial` (shapes, order of the breaks, non-finite values).
    """

    def __call__(self, t) -> np.ndarray:
        """Values of the functions at one time, or at each of an array of times.

        Parameters
        ----------
        t : float or array_like, shape (N,)
            Time(s) [s] within the breaks.

        Returns
        -------
        ndarray, shape (m,) or (m, N)

        Raises
        ------
        InputError
            A time outside the span.
        """
        if isinstance(t, (float, int, np.floating, np.integer)) or np.ndim(t) == 0:
            return PiecewisePolynomial.__call__(self, t)
        return self.evaluate(np.asarray(t, dtype=float).ravel()).reshape((self.n_functions,) + np.shape(t))


@dataclass
class Plan:
    """A planned manoeuvre: the iterates j = 0..J of the (generalized) flat parametrization.

    Attributes
    ----------
    problem : FlatProblem
    t_nodes : ndarray
    iterates : list of NodeSolution
        ``iterates[0]`` is the plain flat plan (H at given values), ``iterates[-1]`` the J-th
        generalized-flatness iterate.
    warnings : list of str
        Everything to report, for printing: Newton failures, singularities, envelope.
    name : str
        Scenario name.
    timings : dict
        Wall time [s] of each iterate j.
    singularities : SingularityReport or None
        The singularity monitor's conditions along iterate 0 (set by
        :func:`~planners.generalized.plan_motion`).
    domain_failures : list of str
        Iterates whose node values leave the physical domain
        (:func:`gna.trajectory.domain_violation`: time, variable, value), or
        with ground effect whose path reaches the ground between the nodes
        (:func:`~planners.generalized.ground_failures`); such a plan is not feasible.
    generalized : dict
        The generalized-flatness method (``"method"``: ``"fixed-point"`` or ``"newton"``) and, for
        Newton, its depth, starting order and fixed-point residual ``max |H - G(H)|`` per iterate;
        with ``J = "auto"`` the rule that chose J (``"J_rule"``) and the residual of every iterate
        computed (``"J_residuals"``).
    interpolation : {"hermite", "paper"}
        Evaluation between nodes: two-point Hermite interpolation of the node series (default) or the
        paper's two-sided formula (module docstring).
    e : int
        Order of the controls' series in the last iterate (the paper's output order e).
    bounded : planners.bounded.BoundedResult or None
        For a scenario with free parameters, the bounded planner's outcome (optimum, cost, active
        limits, plans evaluated) this plan is the optimum of; None otherwise.
    """

    problem: FlatProblem
    t_nodes: np.ndarray
    iterates: list
    warnings: list = field(default_factory=list)
    name: str = "plan"
    timings: dict = field(default_factory=dict)
    singularities: SingularityReport | None = None
    domain_failures: list = field(default_factory=list)
    generalized: dict = field(default_factory=dict)
    interpolation: str = DEFAULT_INTERPOLATION
    e: int = 1
    bounded: object | None = field(default=None, repr=False)

    def __post_init__(self):
        check_interpolation(self.interpolation, f"plan {self.name}")

    @property
    def aircraft(self) -> Aircraft:
        return self.problem.aircraft

    @property
    def env(self) -> Environment:
        return self.problem.env

    @property
    def J(self) -> int:
        return len(self.iterates) - 1

    @property
    def t0(self) -> float:
        return float(self.t_nodes[0])

    @property
    def t1(self) -> float:
        return float(self.t_nodes[-1])

    def _iterate(self, j: int) -> NodeSolution:
        try:
            return self.iterates[j]
        except IndexError:
            raise InputError(f"iterate j = {j} not in the plan (J = {self.J})") from None

    def evaluate(self, name: str, t, j: int = -1, derivative: int = 0) -> np.ndarray:
        """Value (or ``derivative``-th derivative) of a variable at times ``t``.

        Parameters
        ----------
        name : str
            A state or control name (``"alpha"``, ``"dm"``, ...).
        t : float or array
            Times within ``[t0, t1]``.
        j : int
            Iterate (default: the last).
        derivative : int
            Order of the time derivative (0: the value).

        Returns
        -------
        float or ndarray, shape (N,)
            Value at each time, in the variable's unit (per second^derivative); a float for a scalar ``t``.

        Raises
        ------
        InputError
            Unknown variable or iterate, or a time outside the plan.
        """
        out = self._evaluate_many((name,), t, j, derivative)[0]
        return out if np.ndim(t) else out[0]

    def _coefficients(self, names: tuple, j: int) -> np.ndarray:
        """Per-interval polynomial coefficients of several variables: (intervals, len(names), d + 1).

        Built once per (names, iterate) from the node series by :attr:`interpolation`; each variable
        uses its own series order (the controls: the surfaces' order), zero-padded to the group's degree.
        """
        sol = self._iterate(j)
        cache = self.__dict__.setdefault("_coeff_cache", {})
        key = (names, j % len(self.iterates), self.interpolation)
        if key not in cache:
            for n in names:
                if n not in sol.series:
                    raise InputError(f"unknown plan variable {n!r}; known: {', '.join(sol.series)}")
            tn = np.asarray(self.t_nodes, dtype=float)
            h = np.diff(tn)
            # Hermite: the controls with the derivatives of the surfaces' order (e in the last iterate);
            # F's series is two orders longer (stage 2), but its extra derivatives changed the open-loop
            # accuracy by at most 6e-8 m on the paper's scenarios while adding 4 Horner steps to every call of
            # control_function (measured: docs/planning.md).
            k_controls = min((sol.series[n].order for n in CONTROL_NAMES if n in sol.series), default=None)
            groups: dict = {}  # coefficient count -> [(column, coefficients (nodes, K + 1))]
            for i, n in enumerate(names):
                c = np.real(np.asarray(sol.series[n].coeffs))
                c = np.broadcast_to(c, (len(tn), c.shape[-1]))
                if self.interpolation == "hermite" and n in CONTROL_NAMES:
                    c = c[:, : k_controls + 1]
                groups.setdefault(c.shape[-1], []).append((i, c))
            polys = []
            m = len(tn) - 1
            for items in groups.values():
                # one formula evaluation per order: the variables one after the other along the interval axis
                # (each variable's polynomials those of a call of its own, bit for bit; tested)
                a = np.concatenate([c[:-1, None, :] for _, c in items])
                b = np.concatenate([c[1:, None, :] for _, c in items])
                p = interval_coefficients(a, b, np.tile(h, len(items)), self.interpolation)[:, 0]
                polys.extend((i, p[q * m : (q + 1) * m]) for q, (i, _) in enumerate(items))
            d = max(p.shape[-1] for _, p in polys)
            out = np.zeros((len(tn) - 1, len(names), d))
            for i, p in polys:
                out[:, i, : p.shape[-1]] = p
            cache[key] = out
        return cache[key]

    def _check_times(self, t) -> np.ndarray:
        t_arr = np.atleast_1d(np.asarray(t, dtype=float))
        lo, hi = self.t0, self.t1
        if np.any(t_arr < lo - 1e-9 * max(1.0, abs(lo))) or np.any(t_arr > hi + 1e-9 * max(1.0, abs(hi))):
            raise InputError(
                f"time outside the plan [{lo:g}, {hi:g}] s: {float(t_arr.min()):g} .. {float(t_arr.max()):g}"
            )
        return t_arr

    def _evaluate_many(self, names: tuple, t, j: int = -1, derivative: int = 0, c=None) -> np.ndarray:
        """(len(names), N) values at times ``t`` by the plan's formula between nodes (``c``: their coefficients,
        when the caller has them)."""
        c = self._coefficients(tuple(names), j) if c is None else c
        t_arr = self._check_times(t)
        tn = self.t_nodes
        i = np.clip(np.searchsorted(tn, t_arr, side="right") - 1, 0, len(tn) - 2)
        if derivative == 0 and t_arr.size > 8 * len(tn):  # a fine grid (the limit checks)
            from . import _native

            out = _native.horner(c, i, t_arr - tn[i])  # when the native evaluator is loaded: the same values
            if out is not None:
                return out
            if np.all(np.diff(i) >= 0):
                return _horner_blocks(c, i, t_arr - tn[i])
        return _horner(c[i], t_arr - tn[i], derivative)

    def piecewise(self, names=CONTROL_NAMES, j: int = -1) -> PiecewisePolynomial:
        """Variables of iterate ``j`` as piecewise polynomials of time (the plan's formula between nodes).

        Parameters
        ----------
        names : sequence of str
            Plan variables (default the 5 controls ``F, eta, dl, dm, dn``).
        j : int
            Iterate (default: the last).

        Returns
        -------
        PlanFunctions
            A :class:`gna.piecewise.PiecewisePolynomial` of ``len(names)`` functions on the node
            intervals; calling it at one time returns shape ``(len(names),)``, at an array of N times
            ``(len(names), N)``.

        Raises
        ------
        InputError
            Unknown variable or iterate, or non-finite series (an infeasible plan).
        """
        names = tuple(names)
        self._iterate(j)
        cache = self.__dict__.setdefault("_pp_cache", {})
        key = (names, j % len(self.iterates), self.interpolation)
        if key not in cache:
            c = self._coefficients(names, j)
            if not np.all(np.isfinite(c)):
                bad = int(np.argmax(~np.all(np.isfinite(c), axis=(1, 2))))
                raise InputError(
                    f"plan {self.name}, iterate j = {j}: non-finite series at t = "
                    f"{self.t_nodes[bad]:g} s (a node where Newton failed)"
                )
            cache[key] = PlanFunctions(np.asarray(self.t_nodes, dtype=float), c)
        return cache[key]

    def state(self, t, j: int = -1) -> np.ndarray:
        """The 12 states at ``t``.

        Parameters
        ----------
        t : float or array, shape (N,)
            Times within ``[t0, t1]`` [s].
        j : int
            Iterate (default: the last).

        Returns
        -------
        ndarray, shape (12,) or (12, N)
            States in the order of :data:`gna.eom.STATE_NAMES` (SI, rad).
        """
        out = self._evaluate_many(STATE_NAMES, t, j)
        return out if np.ndim(t) else out[:, 0]

    def controls(self, t, j: int = -1) -> np.ndarray:
        """The 5 controls at ``t``.

        Parameters
        ----------
        t : float or array, shape (N,)
            Times within ``[t0, t1]`` [s].
        j : int
            Iterate (default: the last).

        Returns
        -------
        ndarray, shape (5,) or (5, N)
            ``(F, eta, dl, dm, dn)`` [N, -, rad, rad, rad].
        """
        if np.ndim(t) == 0:  # the integrators' path: one time, the cached piecewise polynomial
            self._iterate(j)
            try:
                f = self.piecewise(CONTROL_NAMES, j)
            except InputError:  # non-finite series (an infeasible plan): the general path below
                pass
            else:
                t = float(t)
                lo, hi = self.t0, self.t1
                if not lo - 1e-9 * max(1.0, abs(lo)) <= t <= hi + 1e-9 * max(1.0, abs(hi)):
                    self._check_times(t)  # raises, naming the plan's span
                return f(t)
        out = self._evaluate_many(CONTROL_NAMES, t, j)
        return out if np.ndim(t) else out[:, 0]

    def control_function(self, j: int = -1):
        """The controls of iterate ``j`` as a function of time, for the simulators.

        Parameters
        ----------
        j : int
            Iterate (default: the last).

        Returns
        -------
        callable
            ``f(t) -> ndarray, shape (5,)``: the controls of :meth:`controls` at time ``t`` [s]; a
            :class:`gna.piecewise.PiecewisePolynomial` (about 2 us per call) built once from the node
            series, or for an infeasible plan with non-finite series a slower function giving them.

        Raises
        ------
        InputError
            Unknown iterate.
        """
        self._iterate(j)
        try:
            return self.piecewise(CONTROL_NAMES, j)
        except InputError:
            return lambda t: self.controls(t, j)

    def initial_state(self, j: int = -1) -> np.ndarray:
        """The 12 states at the start of the plan.

        Parameters
        ----------
        j : int
            Iterate (default: the last).

        Returns
        -------
        ndarray, shape (12,)
            States at ``t0`` (SI, rad).
        """
        return self.state(self.t0, j)

    def to_dataframe(self, t=None, j: int = -1, step: float | None = None, variables=None) -> pd.DataFrame:
        """States and controls of iterate ``j`` on a time grid.

        Parameters
        ----------
        t : array, shape (N,), optional
            Times [s] (default: the nodes, or a regular grid of ``step``).
        j : int
            Iterate (default: the last).
        step : float, optional
            Step [s] of a regular grid ``t0 + k step`` when ``t`` is not
            given; the grid stops at the last time not after ``t1`` (``t1``
            itself when ``step`` divides the span).
        variables : sequence of str, optional
            The columns (plan variables; default every state and control, :data:`PLAN_VARIABLES`).

        Returns
        -------
        DataFrame
            One column per state and control (SI, rad), or per one of ``variables``, indexed by ``t``.

        Raises
        ------
        InputError
            ``step`` not a positive finite number, or an unknown variable.
        """
        if t is None and step is not None:
            try:
                step = float(step)
            except (TypeError, ValueError):
                raise InputError(f"step must be a number [s], got {step!r}") from None
            if not (math.isfinite(step) and step > 0):
                raise InputError(f"step must be a positive finite interval [s], got {step}")
            t = np.arange(self.t0, self.t1 + 0.5 * step, step)
            t = t[t <= self.t1 + 1e-9 * step]
        if t is None:
            t = self.t_nodes
        t = np.asarray(t, dtype=float)
        names = PLAN_VARIABLES if variables is None else tuple(variables)
        vals = self._evaluate_many(names, t, j)  # (len(names), N): one float block
        return pd.DataFrame(vals.T, columns=list(names), index=pd.Index(t, name="t"))

    def limit_frame(self, j: int = -1, aircraft: Aircraft | None = None) -> pd.DataFrame:
        """The plan on the grid its limits are checked on: step ``gna.limits.fine_step(smallest node step)``.

        The states are the iterate's; the controls are those of :meth:`control_function` (what an engine
        flies), evaluated on the grid.

        Parameters
        ----------
        j : int
            Iterate (default: the last).
        aircraft : Aircraft, optional
            Whose limits decide the columns (:func:`gna.limits.limit_columns`); default the plan's.

        Returns
        -------
        DataFrame
            Indexed by ``t`` [s], ``t0`` to ``t1`` (``t1`` included).
        """
        t, cols, vals = self._limit_arrays(j, aircraft)
        return pd.DataFrame(vals.T, columns=cols, index=pd.Index(t, name="t"))

    def _limit_arrays(self, j: int, aircraft: Aircraft | None) -> tuple:
        """:meth:`limit_frame` as arrays: times (N,), column names, values (columns, N)."""
        from gna.limits import fine_step, limit_columns

        step = fine_step(float(np.min(np.diff(self.t_nodes))))
        n = int(math.ceil((self.t1 - self.t0) / step - 1e-9))
        t = np.linspace(self.t0, self.t1, n + 1)
        names = limit_columns(aircraft or self.aircraft)
        states = [v for v in names if v not in CONTROL_NAMES]
        used = [c for c in CONTROL_NAMES if c in names]
        cu = self._coefficients(CONTROL_NAMES, j)
        if np.all(np.isfinite(cu)):  # what control_function then returns
            # the piecewise polynomial's values are those of the plan's evaluation with the same coefficients;
            # states and controls in one pass (each variable's own polynomial, zero-padded: the same values)
            cu = cu[:, [CONTROL_NAMES.index(c) for c in used]]
            cs = self._coefficients(tuple(states), j) if states else cu[:, :0]
            from . import _native

            if _native.loaded() is not None:  # each group at its own degree, natively: the padded values
                d = max(cs.shape[2], cu.shape[2])
                vals = np.empty((cs.shape[1] + cu.shape[1], t.size))
                tn = np.asarray(self.t_nodes, dtype=float)
                for rows, cg in ((slice(0, cs.shape[1]), cs), (slice(cs.shape[1], None), cu)):
                    if cg.shape[1]:
                        _native.grid_horner(cg, tn, t, vals[rows], pad=cg.shape[2] < d)
                return t, states + used, vals
            c = np.zeros((cu.shape[0], cs.shape[1] + cu.shape[1], max(cs.shape[2], cu.shape[2])))
            c[:, : cs.shape[1], : cs.shape[2]] = cs
            c[:, cs.shape[1] :, : cu.shape[2]] = cu
            return t, states + used, self._evaluate_many(tuple(states + used), t, j, c=c)
        f = self.control_function(j)
        U = np.array([f(x) for x in t]).T
        U = U[[CONTROL_NAMES.index(c) for c in used]]
        vals = np.concatenate([self._evaluate_many(tuple(states), t, j), U]) if states else U
        return t, states + used, vals

    def limit_violations(self, j: int = -1, aircraft: Aircraft | None = None) -> list:
        """Where iterate ``j`` leaves the aircraft's limits (:func:`gna.limits.limit_violations`).

        Parameters
        ----------
        j : int
            Iterate (default: the last).
        aircraft : Aircraft, optional
            Whose limits (default the plan's).

        Returns
        -------
        list of gna.limits.Violation
            On the grid of :meth:`limit_frame`; empty within every limit.
        """
        from gna.limits import TrajectoryColumns, limit_violations

        from . import _native

        ac = aircraft or self.aircraft
        scan = _native.limit_scan if _native.loaded() is not None else None  # the same records
        return limit_violations(ac, TrajectoryColumns(*self._limit_arrays(j, ac)), self.env, scan)

    def node_values(self, j: int = -1) -> tuple[State, Controls]:
        """States and controls at the nodes (constant terms of the series).

        Parameters
        ----------
        j : int
            Iterate (default: the last).

        Returns
        -------
        tuple of (State, Controls)
            Arrays of shape (nodes,) (SI, rad).
        """
        s = self._iterate(j).series
        v = {n: np.real(s[n].constant_term) for n in PLAN_VARIABLES}
        return State(*(v[n] for n in STATE_NAMES)), Controls(*(v[n] for n in CONTROL_NAMES))

    def node_derivatives(self, j: int = -1) -> State:
        """Time derivatives of the states at the nodes, from the series (first coefficients).

        Parameters
        ----------
        j : int
            Iterate (default: the last).

        Returns
        -------
        State
            Arrays of shape (nodes,) (SI units per second).
        """
        s = self._iterate(j).series
        return State(*(np.real(s[n].coeffs[..., 1]) for n in STATE_NAMES))

    def iterate_residuals(self) -> list[float]:
        """The full-model equation residual at the nodes of every iterate j = 0..J: the convergence test of J.

        ``max`` over nodes and the 12 equations of :meth:`equation_residuals` ``("full", j)``; the
        test of ``J = "auto"`` (:func:`planners.generalized.choose_J`).

        Returns
        -------
        list of float
            One residual per iterate [m/s^2 for V, rad/s for the angles; the position and rate
            equations hold exactly]; NaN where an iterate has non-finite values.
        """
        cache = self.__dict__.setdefault("_residual_cache", {})
        if len(cache) != len(self.iterates):
            with np.errstate(all="ignore"):
                for j in range(len(self.iterates)):
                    if j not in cache:
                        r = np.abs(self.equation_residuals("full", j).to_numpy())
                        cache[j] = float(np.max(r)) if np.all(np.isfinite(r)) else float("nan")
        return [cache[j] for j in range(len(self.iterates))]

    def equation_residuals(self, model: str = "full", j: int = -1, h: HValues | None = None) -> pd.DataFrame:
        """Residual ``d/dt state - f(state, controls)`` of the model's 12 equations at the nodes.

        ``model="simple"`` uses the H values the iterate was computed with
        (``h``; default the problem's for j = 0 or the previous iterate's).

        Parameters
        ----------
        model : {"full", "simple"}
            Model of :func:`gna.eom.derivatives`.
        j : int
            Iterate (default: the last).
        h : HValues, optional
            Values of the neglected terms for ``model="simple"``.

        Returns
        -------
        DataFrame
            One column per state (SI units per second), indexed by the node times.
        """
        st, ct = self.node_values(j)
        if model == "simple" and h is None:
            jj = j % len(self.iterates)
            if jj == 0:
                h = self.problem.h
            else:
                prev = self.iterates[jj - 1].series
                h = HValues(*(np.real(prev[n].constant_term) for n in ("p", "q", "r", "dl", "dm", "dn")))
        f = derivatives(self.aircraft, self.env, st, ct, model, h)
        d = self.node_derivatives(j)
        return pd.DataFrame(
            {n: np.asarray(a) - np.asarray(b) for n, a, b in zip(STATE_NAMES, d, f)},
            index=pd.Index(self.t_nodes, name="t"),
        )

    def convergence_table(self, variables=("F", "dl", "dm", "dn"), times=None) -> pd.DataFrame:
        """Values of ``variables`` at ``times`` for every iterate j = 0..J (the paper's aileron-roll table).

        Parameters
        ----------
        variables : sequence of str
            Plan variables (default the controls ``F, dl, dm, dn``).
        times : sequence of float, optional
            Times [s] (default: ``t0``).

        Returns
        -------
        DataFrame
            Index ``(t, variable)``, one column ``J=j`` per iterate.
        """
        times = [self.t0] if times is None else list(times)
        rows = {}
        for tt in times:
            for v in variables:
                rows[(tt, v)] = [float(self.evaluate(v, tt, j)) for j in range(len(self.iterates))]
        df = pd.DataFrame.from_dict(rows, orient="index", columns=[f"J={j}" for j in range(len(self.iterates))])
        df.index = pd.MultiIndex.from_tuples(df.index, names=["t", "variable"])
        return df

    @property
    def newton_failure_records(self) -> list[NewtonFailure]:
        """Where the paper's Newton rule failed (residual above 1e-3 after 20 iterations), as records.

        One :class:`~planners.newton.NewtonFailure` per iterate and stage that failed, in the
        order j = 0..J, stage 2 before stage 4, with its ``iterate`` and ``stage`` filled in.
        """
        return [
            replace(f, stage=stage, iterate=j)
            for j, it in enumerate(self.iterates)
            for stage, rep in it.reports.items()
            for f in getattr(rep, "failures", ())
        ]

    @property
    def newton_failures(self) -> list[str]:
        """The messages of :attr:`newton_failure_records`, prefixed by their iterate, for printing."""
        return [f"iterate j = {f.iterate}: {f.message}" for f in self.newton_failure_records]

    @property
    def feasible(self) -> bool:
        """False when Newton failed somewhere (the plan is not a solution of the model there) or a node
        leaves the physical domain, or the path reaches the ground (:attr:`domain_failures`)."""
        return not self.newton_failure_records and not self.domain_failures

    def worst_newton_residual(self) -> float:
        """Largest Newton residual (constant terms and series) over iterates and stages.

        Returns
        -------
        float
            Max-norm residual (stage-2 residuals are over g, stage-4 in rad/s^2).
        """
        return max(r.worst_residual for it in self.iterates for r in it.reports.values())


def save_plan(plan: Plan, out_dir, step: float | None = None, *, csv: bool = False) -> dict:
    """Write a plan to ``out_dir``: node series (npz, with the formula between nodes and e), the plan of every
    iterate (``plan-j<k>.parquet``), the singularity table (``singularities.parquet``); with ``csv`` the
    tables also as CSV, the same stem (``gflat plan``'s files and names).

    Parameters
    ----------
    plan : Plan
        The plan to write.
    out_dir : str or Path
        Folder, created if needed.
    step : float, optional
        Step [s] of the iterates' time grid (default: a quarter of the smallest node spacing).
    csv : bool
        Also write each table as CSV.

    Returns
    -------
    dict
        What was written (``"series"``, ``"plan-j0"``, ``"plan-j0.csv"``, ...) -> its path.
    """
    from pathlib import Path

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written = {}
    arrays = {"t_nodes": plan.t_nodes, "interpolation": np.array(plan.interpolation), "e": np.array(plan.e)}
    for j, it in enumerate(plan.iterates):
        for name, s in it.series.items():
            arrays[f"j{j}/{name}"] = np.real(np.asarray(s.coeffs))
    p = out / "plan_series.npz"
    np.savez_compressed(p, **arrays)
    written["series"] = str(p)
    step = step if step is not None else float(np.min(np.diff(plan.t_nodes))) / 4
    tables = {f"plan-j{j}": plan.to_dataframe(step=step, j=j) for j in range(plan.J + 1)}
    if plan.singularities is not None:
        tables["singularities"] = plan.singularities.table
    for name, df in tables.items():
        p = out / f"{name}.parquet"
        df.to_parquet(p)
        written[name] = str(p)
        if csv:
            p = out / f"{name}.csv"
            df.to_csv(p, float_format="%.10g")
            written[f"{name}.csv"] = str(p)
    return written
