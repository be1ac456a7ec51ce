"""Batched in-house simulation: many dispersed aircraft integrated at once, with the same model code.

The equations of :mod:`gna.eom` are array-generic: with every state an array of
shape ``(n,)`` (one entry per sample) and an aircraft whose mass, inertia, CG
and aerodynamic term values are arrays of the same shape, one call of
:func:`gna.eom.derivatives` gives the derivatives of all samples.  The stacked
system (``12 + n_states`` rows by ``n`` columns) is integrated by scipy's
DOP853 with the single-run engine's tolerances divided by ``sqrt(n)``: scipy's
error norm is the RMS over all components, so this keeps every sample's local
error within the single run's (Hairer, Norsett & Wanner, *Solving ODEs I*,
sec. II.4).  The tracking feedback is evaluated for all samples at once
(:meth:`planners.tracking.TrackingController.output_and_derivative_many`).  A
sample that leaves the flight domain (the engines' test, :func:`gna.trajectory.inside_domain`
with :func:`gna.trajectory.domain_bounds` of the environment: airspeed, sideslip, flight path,
angle of attack and, with ground effect, the height above the ground; or a non-finite
derivative) is frozen from the end of that step on and marked ``domain``; the others go on.
"""

from __future__ import annotations

from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np

from gna.aero import COEFFICIENTS, Coefficients
from gna.atmosphere import Environment
from gna.eom import Controls, State, derivatives
from gna.errors import InputError
from gna.trajectory import control_function, domain_bounds, inside_domain

from .integrators import TABLEAUS, fixed, per_sample, stacked

__all__ = ["BatchTerms", "batched_aircraft", "simulate_batch", "BatchResult", "BATCH_METHODS"]

#: Integrators of :func:`simulate_batch` (:mod:`harness.campaign.integrators`): DOP853 per sample (default),
#: DOP853 on the stacked system, fixed steps of RK4 or of the 8th-order DOP853 tableau.
BATCH_METHODS: tuple[str, ...] = ("DOP853", "DOP853-stacked", "rk4", "rk8")


class BatchTerms:
    """An aerodynamic term table with one set of term values per sample.

    Parameters
    ----------
    table : gna.aero.TermTable
        The structure (monomials, coefficient of each term).
    values : ndarray, shape (n_terms, n)
        Term values, one column per sample.
    """

    def __init__(self, table, values: np.ndarray):
        self.table = table
        self.values = np.asarray(values, dtype=float)
        self.terms = table.terms
        ind = np.zeros((len(COEFFICIENTS), len(table.terms)))
        for i, t in enumerate(table.terms):
            ind[COEFFICIENTS.index(t.coefficient), i] = 1.0
        self.indicator = ind
        self.exponents = np.array([t.exponents for t in table.terms], dtype=int)  # (n_terms, 8)
        self._columns = np.arange(self.exponents.shape[1])

    def coefficients(self, state) -> Coefficients:
        """The six coefficients of every sample (paper eq. (GNA)).

        The monomials of :meth:`gna.aero.TermTable.monomials` from one table of
        powers of the eight aerodynamic variables, gathered per term.

        Parameters
        ----------
        state : gna.aero.AeroState
            Arrays of shape (n,).

        Returns
        -------
        gna.aero.Coefficients
            Arrays of shape (n,).
        """
        v = np.array(np.broadcast_arrays(*state, self.values[0]))[:-1]  # (8, n)
        powers = np.empty((self.exponents.max() + 1,) + v.shape)
        powers[0] = 1.0
        for k in range(1, powers.shape[0]):
            powers[k] = powers[k - 1] * v
        mons = powers[self.exponents, self._columns].prod(axis=1)  # (n_terms, n)
        return Coefficients(*(self.indicator @ (self.values * mons)))


def batched_aircraft(aircraft, draws):
    """An aircraft whose mass, inertia, CG and term values are arrays over samples.

    Parameters
    ----------
    aircraft : gna.aircraft.Aircraft
        The nominal aircraft (term table aerodynamics).
    draws : sequence of harness.campaign.sampling.SampleDraw
        One per sample (:func:`harness.campaign.sampling.draw_sample`).

    Returns
    -------
    types.SimpleNamespace
        ``geometry``, ``mass``, ``propulsion``, ``aero`` (:class:`BatchTerms`) as
        :func:`gna.eom.derivatives` reads them, entries of shape (n,).
    """
    m, g = aircraft.mass, aircraft.geometry
    ms = np.array([d.mass_scale for d in draws])
    si = np.array([d.inertia_scale for d in draws])
    mass = SimpleNamespace(mass=m.mass * ms, Ixx=m.Ixx * si, Iyy=m.Iyy * si, Izz=m.Izz * si, Ixz=m.Ixz * si)
    geometry = SimpleNamespace(
        S=g.S, b=g.b, cbar=g.cbar, x_ref=g.x_ref, x_cg=g.x_cg + np.array([d.cg_shift_m for d in draws])
    )
    values = np.stack([d.aero_values for d in draws], axis=1)
    return SimpleNamespace(
        id=aircraft.id,
        mass=mass,
        geometry=geometry,
        propulsion=aircraft.propulsion,
        envelope=aircraft.envelope,
        aero=BatchTerms(aircraft.aero, values),
    )


@dataclass
class BatchResult:
    """Output of :func:`simulate_batch`.

    Attributes
    ----------
    t : ndarray, shape (m,)
        Output times [s].
    X : ndarray, shape (m, 12, n)
        States on the grid (:data:`gna.eom.STATE_NAMES`); a frozen sample keeps its last state.
    XC : ndarray, shape (m, n_states, n)
        Controller states.
    status : ndarray of str, shape (n,)
        ``completed``, ``domain`` (left the flight domain) or ``stalled`` (``max_steps`` reached).
    t_end : ndarray, shape (n,)
        End of the valid part of each run [s].
    nfev : int
        Evaluations of the batched derivative.
    steps : ndarray of int, shape (n,) or None
        Steps tried per sample (accepted and rejected; per-sample DOP853 only).
    """

    t: np.ndarray
    X: np.ndarray
    XC: np.ndarray
    status: np.ndarray
    t_end: np.ndarray
    nfev: int
    steps: np.ndarray | None = None

    def positions(self) -> np.ndarray:
        """Positions ``(x, y, z)`` on the grid.

        Returns
        -------
        ndarray, shape (m, 3, n)
        """
        return self.X[:, :3, :]


def simulate_batch(
    aircraft,
    x0: np.ndarray,
    controls,
    t_span,
    *,
    env: Environment | None = None,
    controller=None,
    dt_out: float = 0.05,
    t_eval=None,
    method: str = "DOP853",
    rtol: float = 1e-10,
    atol: float = 1e-10,
    max_step: float = 0.01,
    max_steps: int | None = None,
) -> BatchResult:
    """Integrate n samples of the 12-state model (and a controller's states) at once.

    Parameters
    ----------
    aircraft : Aircraft or batched aircraft
        :func:`batched_aircraft` (or one aircraft for all samples).
    x0 : array_like, shape (n, 12)
        Initial states (SI, rad), one row per sample.
    controls : callable or object with ``controls(t)``
        Reference controls, the same for every sample (:func:`gna.trajectory.control_function`).
    t_span : (float, float)
        ``(t0, t1)`` [s].
    env : Environment, optional
        Default the ISA.
    controller : TrackingController, optional
        With ``output_and_derivative_many``; its states start at ``initial_state``.
    dt_out : float
        Output interval [s] (the single-run engine's grid).
    t_eval : array_like, optional
        Output times [s] instead.
    method : {"DOP853", "rk4", "rk8"}
        Adaptive DOP853 on the stacked system, or fixed steps (classic RK4, or
        the 8th-order DOP853 tableau) of at most ``max_step`` landing on the output times.
    rtol, atol : float
        DOP853: per-sample tolerances (those of the single-run engine); the
        stacked system uses them divided by ``sqrt(n)``.
    max_step : float
        Fixed-step methods: largest step [s].
    max_steps : int, optional
        Per-sample DOP853: steps after which a sample is stopped (status ``stalled``).

    Returns
    -------
    BatchResult

    Raises
    ------
    InputError
        Bad shapes, span, or a controller without a batched evaluation.
    """
    env = env if env is not None else Environment()
    X0 = np.atleast_2d(np.asarray(x0, dtype=float))
    if X0.ndim != 2 or X0.shape[1] != 12 or not np.isfinite(X0).all():
        raise InputError(f"x0 must be finite with shape (n, 12), got shape {X0.shape}")
    t0, t1 = (float(v) for v in t_span)
    if not t1 > t0:
        raise InputError(f"t_span must have t1 > t0, got {t_span}")
    if method not in BATCH_METHODS:
        raise InputError(f"unknown batched integrator {method!r}; choose from {', '.join(BATCH_METHODS)}")
    if controller is not None and not hasattr(controller, "output_and_derivative_many"):
        raise InputError(f"{type(controller).__name__} has no batched evaluation (output_and_derivative_many)")
    system = _System(aircraft, env, control_function(controls), controller, X0, t0)
    if t_eval is None:
        k = max(int(round((t1 - t0) / dt_out)), 1)
        grid = np.linspace(t0, t1, k + 1)
    else:
        grid = np.asarray(t_eval, dtype=float)
    if method == "DOP853":
        out = per_sample(system, grid, t0, t1, rtol, atol, max_steps)
    elif method == "DOP853-stacked":
        out = stacked(system, grid, t0, t1, rtol, atol)
    else:
        out = fixed(system, grid, t0, t1, max_step, TABLEAUS[method]())
    system.t_end[np.isinf(system.t_end)] = t1
    status = np.where(system.stalled, "stalled", np.where(system.t_end < t1, "domain", "completed"))
    return BatchResult(
        t=grid,
        X=out[:, :12],
        XC=out[:, 12:],
        status=status,
        t_end=system.t_end,
        nfev=system.nfev,
        steps=getattr(system, "steps", None),
    )


class _System:
    """The stacked right-hand side, with the samples still inside the flight domain."""

    def __init__(self, aircraft, env, ufun, controller, X0, t0):
        self.aircraft, self.env, self.ufun, self.controller = aircraft, env, ufun, controller
        self.n = X0.shape[0]
        self.nc = 0 if controller is None else int(controller.n_states)
        self.rows = 12 + self.nc
        Y0 = np.zeros((self.rows, self.n))
        Y0[:12] = X0.T
        if self.nc:
            Y0[12:] = np.stack([controller.initial_state(t0, x) for x in X0], axis=1)
        self.Y0 = Y0
        self.bounds = domain_bounds(env)
        self.alive = inside_domain(Y0[:12], self.bounds)
        self.bad = np.zeros(self.n, dtype=bool)
        self.t_end = np.full(self.n, np.inf)
        self.t_end[~self.alive] = t0
        self.nfev = 0
        self.stalled = np.zeros(self.n, dtype=bool)
        self._subsets = {}
        self.own_feedforward = self.nc > 0 and getattr(ufun, "__self__", None) is controller

    def rhs(self, t, Y, cols=None):
        """Derivatives of the columns ``cols`` (all by default) at time(s) ``t``."""
        self.nfev += 1
        ac = self.aircraft if cols is None else self.subset(cols)
        alive = self.alive if cols is None else self.alive[cols]
        m = Y.shape[1]
        D = np.empty((self.rows, m))
        if self.own_feedforward:  # the controller's own feedforward: evaluated once with the feedback
            du, D[12:], U = self.controller.output_and_derivative_many(t, Y[:12], Y[12:], with_feedforward=True)
            U = U + du
        else:
            U = np.asarray(self.ufun(t), dtype=float).reshape(5, -1) + np.zeros((1, m))
            if self.nc:
                du, D[12:] = self.controller.output_and_derivative_many(t, Y[:12], Y[12:])
                U = U + du
        D[:12] = np.broadcast_arrays(*derivatives(ac, self.env, State(*Y[:12]), Controls(*U)), Y[0])[:12]
        with np.errstate(invalid="ignore"):
            nonfinite = ~np.isfinite(D).all(axis=0)
        if cols is None:
            self.bad |= nonfinite & alive
        else:
            self.bad[cols[nonfinite & alive]] = True
        D[:, nonfinite | ~alive] = 0.0
        return D

    def subset(self, cols):
        """The batched aircraft restricted to some samples (cached for the current set)."""
        key = cols.tobytes()
        if key not in self._subsets:
            if len(self._subsets) > 4:
                self._subsets.clear()
            self._subsets[key] = _take(self.aircraft, cols)
        return self._subsets[key]

    def check_columns(self, t, Y, cols) -> None:
        """Freeze the samples among ``cols`` that left the domain (per-sample times ``t``)."""
        died = cols[self.alive[cols] & (self.bad[cols] | ~inside_domain(Y[:12, cols], self.bounds))]
        self.alive[died] = False
        self.t_end[died] = t[died]

    def check(self, t, Y) -> bool:
        """Freeze the samples that left the domain; True when some did."""
        died = self.alive & (self.bad | ~inside_domain(Y[:12], self.bounds))
        if died.any():
            self.alive &= ~died
            self.t_end[died] = t
        return bool(died.any())


def _take(aircraft, cols):
    """A batched aircraft restricted to the samples ``cols`` (one aircraft for all is returned as is)."""
    if not isinstance(aircraft.aero, BatchTerms):
        return aircraft
    m, g = aircraft.mass, aircraft.geometry
    mass = SimpleNamespace(**{k: np.asarray(getattr(m, k))[cols] for k in ("mass", "Ixx", "Iyy", "Izz", "Ixz")})
    geometry = SimpleNamespace(S=g.S, b=g.b, cbar=g.cbar, x_ref=g.x_ref, x_cg=np.asarray(g.x_cg)[cols])
    return SimpleNamespace(
        id=aircraft.id,
        mass=mass,
        geometry=geometry,
        propulsion=aircraft.propulsion,
        envelope=aircraft.envelope,
        aero=BatchTerms(aircraft.aero.table, aircraft.aero.values[:, cols]),
    )
