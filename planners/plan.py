"""The result of motion planning: every node's series, evaluated anywhere.

Between nodes ``t_i <= t <= t_{i+1}`` a variable is evaluated with the
paper's two-sided formula (section "Motion planning")::

    [(t_{i+1} - t) s_i(t - t_i) + (t - t_i) s_{i+1}(t - t_{i+1})] / (t_{i+1} - t_i)

and its k-th derivative is the exact k-th derivative of that expression
(Leibniz rule).  Everything is vectorised over the evaluation times.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
import pandas as pd

from gna.aircraft import Aircraft
from gna.atmosphere import Environment
from gna.eom import CONTROL_NAMES, STATE_NAMES, Controls, HValues, State, derivatives
from gna.errors import InputError

from .flat import FlatProblem, NodeSolution
from .newton import NewtonFailure
from .singularity import SingularityReport

PLAN_VARIABLES = STATE_NAMES + CONTROL_NAMES


def _taylor_derivative(coeffs: np.ndarray, dt: np.ndarray, k: int) -> np.ndarray:
    """k-th derivative at offsets ``dt`` (N,) of polynomials with coefficients ``coeffs`` (..., N, K)."""
    K = coeffs.shape[-1]
    if k >= K:
        return np.zeros(coeffs.shape[:-2] + dt.shape)
    m = np.arange(k, K)
    fall = np.ones(K - k)
    for j in range(k):
        fall = fall * (m - j)
    c = np.real(coeffs[..., k:]) * fall
    out = c[..., -1].copy()
    for i in range(c.shape[-1] - 2, -1, -1):
        out = out * dt + c[..., i]
    return out


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
        (:func:`gna.trajectory.domain_violation`: time, variable, value); such
        a plan is not feasible.
    generalized : dict
        The generalized-flatness method (``"method"``: ``"fixed-point"`` or ``"newton"``) and, for
        Newton, its depth, starting order and fixed-point residual ``max |H - G(H)|`` per iterate.
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

    def _stack(self, names: tuple, j: int) -> np.ndarray:
        """Coefficients of several variables, zero-padded to a common order: (len(names), nodes, K)."""
        sol = self._iterate(j)
        cache = self.__dict__.setdefault("_stack_cache", {})
        key = (names, j % len(self.iterates))
        if key not in cache:
            for n in names:
                if n not in sol.series:
                    raise InputError(f"unknown plan variable {n!r}; known: {', '.join(sol.series)}")
            arrs = [np.real(np.asarray(sol.series[n].coeffs)) for n in names]
            K = max(a.shape[-1] for a in arrs)
            st = np.zeros((len(names), len(self.t_nodes), K))
            for i, a in enumerate(arrs):
                st[i, :, :a.shape[-1]] = a
            cache[key] = st
        return cache[key]

    def _evaluate_many(self, names: tuple, t, j: int = -1, derivative: int = 0) -> np.ndarray:
        """(len(names), N) values at times ``t`` by the two-sided formula."""
        c = self._stack(tuple(names), j)
        t_arr = np.atleast_1d(np.asarray(t, dtype=float))
        lo, hi = self.t0, self.t1
        if np.any(t_arr < lo - 1e-9 * max(1.0, abs(lo))) or np.any(t_arr > hi + 1e-9 * max(1.0, abs(hi))):
            raise InputError(f"time outside the plan [{lo:g}, {hi:g}] s: "
                             f"{float(t_arr.min()):g} .. {float(t_arr.max()):g}")
        tn = self.t_nodes
        i = np.clip(np.searchsorted(tn, t_arr, side="right") - 1, 0, len(tn) - 2)
        ti, tj = tn[i], tn[i + 1]
        dt = tj - ti
        w = (t_arr - ti) / dt
        A = _taylor_derivative(c[:, i], t_arr - ti, derivative)
        B = _taylor_derivative(c[:, i + 1], t_arr - tj, derivative)
        out = (1 - w) * A + w * B
        if derivative > 0:
            A1 = _taylor_derivative(c[:, i], t_arr - ti, derivative - 1)
            B1 = _taylor_derivative(c[:, i + 1], t_arr - tj, derivative - 1)
            out = out + derivative * (B1 - A1) / dt
        return out

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
            ``f(t) -> ndarray, shape (5,)``: the controls of :meth:`controls` at time ``t`` [s].
        """
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

    def to_dataframe(self, t=None, j: int = -1, step: float | None = None) -> pd.DataFrame:
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

        Returns
        -------
        DataFrame
            One column per state and control (SI, rad), indexed by ``t``.

        Raises
        ------
        InputError
            ``step`` not a positive finite number.
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
        vals = self._evaluate_many(PLAN_VARIABLES, t, j)
        data = dict(zip(PLAN_VARIABLES, vals))
        return pd.DataFrame(data, index=pd.Index(t, name="t"))

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
        return pd.DataFrame({n: np.asarray(a) - np.asarray(b) for n, a, b in zip(STATE_NAMES, d, f)},
                            index=pd.Index(self.t_nodes, name="t"))

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
        return [replace(f, stage=stage, iterate=j)
                for j, it in enumerate(self.iterates)
                for stage, rep in it.reports.items()
                for f in getattr(rep, "failures", ())]

    @property
    def newton_failures(self) -> list[str]:
        """The messages of :attr:`newton_failure_records`, prefixed by their iterate, for printing."""
        return [f"iterate j = {f.iterate}: {f.message}" for f in self.newton_failure_records]

    @property
    def feasible(self) -> bool:
        """False when Newton failed somewhere (the plan is not a solution of the model there) or a node
        leaves the physical domain (:attr:`domain_failures`)."""
        return not self.newton_failure_records and not self.domain_failures

    def worst_newton_residual(self) -> float:
        """Largest Newton residual (constant terms and series) over iterates and stages.

        Returns
        -------
        float
            Max-norm residual (stage-2 residuals are over g, stage-4 in rad/s^2).
        """
        return max(r.worst_residual for it in self.iterates for r in it.reports.values())


def save_plan(plan: Plan, out_dir, step: float | None = None) -> dict:
    """Write a plan to ``out_dir``: node series (npz), CSV tables of iterates 0 and J, singularity table.

    Parameters
    ----------
    plan : Plan
        The plan to write.
    out_dir : str or Path
        Folder, created if needed.
    step : float, optional
        Step [s] of the CSV time grid (default: a quarter of the smallest node spacing).

    Returns
    -------
    dict
        What was written (``"series"``, ``"plan_j0"``, ...) -> its path.
    """
    from pathlib import Path

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written = {}
    arrays = {"t_nodes": plan.t_nodes}
    for j, it in enumerate(plan.iterates):
        for name, s in it.series.items():
            arrays[f"j{j}/{name}"] = np.real(np.asarray(s.coeffs))
    p = out / "plan_series.npz"
    np.savez_compressed(p, **arrays)
    written["series"] = str(p)
    step = step if step is not None else float(np.min(np.diff(plan.t_nodes))) / 4
    for j in sorted({0, plan.J}):
        p = out / f"plan_j{j}.csv"
        plan.to_dataframe(step=step, j=j).to_csv(p, float_format="%.10g")
        written[f"plan_j{j}"] = str(p)
    sing = plan.singularities
    if sing is not None:
        p = out / "singularities.csv"
        sing.table.to_csv(p, float_format="%.8g")
        written["singularities"] = str(p)
    return written
