"""Numerical integration of the 12-state model with control functions of time.

The integrator is scipy's DOP853 driven step by step, so that leaving the
physical domain (:data:`gna.trajectory.DOMAIN`: airspeed out of
[1, 3000] m/s, cos(beta) or cos(gamma) near 0, |alpha| beyond pi/2,
non-finite values, and with ground effect a CG at or below the ground; the
JSBSim engines apply the same tests) stops the run at
the located time with a message naming the variable and value, and the valid
part of the result is kept.  A controller with its own states
(:class:`gna.controller.Controller`) is integrated together with the aircraft:
the integrated vector is ``(x, xc)`` with ``12 + n_states`` components.

The right-hand side evaluates :func:`gna.eom.derivatives` through
:func:`gna.tape.compile_derivatives`: the same definition traced once per run
into a straight-line program on Python floats (about 20x cheaper per call than
the generic evaluation on numpy floats, and equal to it; ``docs/equations.md``,
"Evaluating the equations on one state").
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
from scipy.integrate import DOP853, RK45, Radau
from scipy.optimize import brentq

from .aircraft import Aircraft
from .atmosphere import Environment
from .controller import as_controller, checked_initial_state, evaluate, state_names
from .eom import CONTROL_NAMES, STATE_NAMES, Controls, HValues, State, loads
from .errors import InputError
from .limits import body_load_factors, limit_violations
from .piecewise import PiecewisePolynomial
from .tape import compile_derivatives
from .trajectory import (
    DOMAIN_TESTS,
    ControlFunction,
    RunSettings,
    SimulationResult,
    check_initial_domain,
    check_span,
    control_function,
    controller_frames,
    controls_on_grid,
    domain_bounds,
    domain_margins,
    domain_text,
    domain_violation,
    initial_state,
    output_grid,
)

__all__ = [
    "ControlFunction",
    "SimulationResult",
    "RunSettings",
    "simulate",
    "envelope_warnings",
    "engine_thrust_warnings",
]

_SOLVERS = {"DOP853": DOP853, "RK45": RK45, "Radau": Radau}


class _NonFinite(Exception):
    def __init__(self, t, names, control=False):
        self.t, self.names, self.control = t, names, control


def _domain_functions(bounds):
    """Event functions of :data:`gna.trajectory.DOMAIN_TESTS`: (test index, margin), positive inside."""
    return [(i, (lambda y, i=i: domain_margins(y, bounds)[i])) for i in range(len(DOMAIN_TESTS))]


#: Stall detection: a run whose last ``STALL_STEPS`` integrator steps advanced less than
#: ``STALL_FRACTION`` of the span is stopped ("integrator stalled"), instead of creeping for hours.
STALL_STEPS = 5000
STALL_FRACTION = 1e-4


def simulate(
    aircraft: Aircraft,
    controls,
    t_span: tuple[float, float],
    x0,
    *,
    env: Environment | None = None,
    model: str = "full",
    h: HValues | None = None,
    controller=None,
    dt_out: float = 0.02,
    t_eval: np.ndarray | None = None,
    rtol: float = 1e-10,
    atol: float = 1e-10,
    method: str = "DOP853",
    max_step: float = np.inf,
) -> SimulationResult:
    """Integrate the full or simple model, with an optional feedback carrying its own states.

    Parameters
    ----------
    aircraft : Aircraft
        The aircraft.
    controls : callable, object with ``controls(t)``, or sequence of 5 floats
        Reference controls ``t [s] -> (F [N], eta [-], dl, dm, dn [rad])``,
        a plan, or five constants (:func:`gna.trajectory.control_function`).
    t_span : pair of float
        ``(t0, t1)`` [s].
    x0 : State or array_like, shape (12,)
        Initial wind-frame state (SI, rad).
    env : Environment, optional
        Atmosphere and gravity; default the ISA.
    model : {"full", "simple"}
        Equations of motion.
    h : HValues, optional
        Neglected-term values for the simple model.
    controller : Controller or callable, optional
        Anything :func:`gna.controller.as_controller` takes: a controller with
        ``n_states`` states (integrated with the aircraft), or ``f(t, x) -> 5
        corrections``.  The applied controls are ``controls(t) +
        controller.output(t, x, xc)``.
    dt_out : float
        Output interval [s]; it must divide the span (ignored when ``t_eval``
        is given; :func:`gna.trajectory.output_grid`).
    t_eval : array_like, shape (n,), optional
        Output times [s], increasing, inside the span.
    rtol, atol : float
        Integrator tolerances (on the aircraft and controller states).
    method : {"DOP853", "RK45", "Radau"}
        scipy integrator.
    max_step : float
        Largest step [s].

    Returns
    -------
    SimulationResult
        ``df`` with the applied controls; with a controller also
        ``controller_states`` and ``feedback`` on the output grid.  Settings
        record the integrator, tolerances, model, environment and controller.

    Raises
    ------
    InputError
        Not an Aircraft; bad span, output grid, initial state (not 12 values),
        controls (not 5 values, or not finite at t0), controller, model or
        integrator name; a non-finite derivative at t0 (naming the variables).

    Notes
    -----
    A run leaving the physical domain (:func:`gna.trajectory.domain_violation`)
    ends with ``status == "domain"``, the message naming the time, variable and
    value, and the rows up to the located crossing.
    """
    if not isinstance(aircraft, Aircraft):
        raise InputError(
            f"aircraft must be a gna.aircraft.Aircraft, got {type(aircraft).__name__} {aircraft!r:.60}; "
            f"gna.aircraft.load_aircraft(name) makes one"
        )
    env = env if env is not None else Environment()
    t0, t1 = check_span(t_span)
    y0 = initial_state(None, x0)
    if method not in _SOLVERS:
        raise InputError(f"unknown integrator {method!r}; choose from {', '.join(_SOLVERS)}")
    if model not in ("full", "simple"):
        raise InputError(f"model must be 'full' or 'simple', got {model!r}")
    grid = output_grid(t0, t1, dt_out, t_eval)
    ufun = control_function(controls)
    u0 = controls_on_grid(ufun, np.array([t0]))[:, 0]  # 5 values, or one clear InputError before integrating
    if not np.all(np.isfinite(u0)):
        bad = [f"{n} = {v}" for n, v in zip(CONTROL_NAMES, u0) if not math.isfinite(v)]
        raise InputError(f"controls at t0 = {t0:g} s are not finite ({', '.join(bad)})")
    bounds = domain_bounds(env)  # with ground effect: a CG at or below the ground too (no ground contact)
    check_initial_domain(t0, y0, bounds)  # as every engine: altitude (atmosphere model), V, beta, gamma, alpha
    ctrl = as_controller(controller)
    nc = 0 if ctrl is None else int(ctrl.n_states)
    names = state_names(ctrl)
    if nc:
        y0 = np.concatenate([y0, checked_initial_state(ctrl, t0, y0)])

    def feedback(t, y):
        return ctrl.output(t, y[:12], y[12:])

    # The fast float path of gna.eom.derivatives for this aircraft, environment and model (gna.tape):
    # the same definition traced into a straight-line program, the generic evaluation as its fallback.
    values = compile_derivatives(aircraft, env, model, h, y0[:12], u0).values
    isfinite = math.isfinite

    def rhs(t, y):
        u = ufun(t)
        if type(u) is not np.ndarray or u.dtype != np.float64:
            u = np.asarray(u, dtype=float)
        if not isfinite(u.sum()):  # a non-finite control stops the run, as on JSBSim (even one the model ignores)
            raise _NonFinite(t, [f"{n} = {v}" for n, v in zip(CONTROL_NAMES, u.tolist()) if not isfinite(v)], True)
        if ctrl is not None:
            du, dc = evaluate(ctrl, t, y[:12], y[12:])  # output and integrands from one evaluation
            u = u + du
            d = values(y[:12].tolist(), u.tolist()) + tuple(np.asarray(dc, dtype=float).tolist())
        else:
            d = values(y.tolist(), u.tolist())
        if not isfinite(sum(d)) and not all(map(isfinite, d)):
            names_bad = [f"{n}' = {v}" for n, v in zip(STATE_NAMES + names, d) if not isfinite(v)]
            if not np.all(np.isfinite(u)):
                names_bad += [f"control {n} = {v}" for n, v in zip(CONTROL_NAMES, u) if not isfinite(v)]
            raise _NonFinite(t, names_bad)
        return d

    try:
        solver = _SOLVERS[method](rhs, t0, y0, t1, rtol=rtol, atol=atol, max_step=max_step)
    except _NonFinite as exc:  # the first evaluation, at t0
        raise InputError(
            f"non-finite derivative at t0 = {t0:g} s ({', '.join(exc.names)}): the initial state, "
            f"controls and feedback give no motion"
        ) from None
    events = _domain_functions(bounds)
    segments = []  # (t_lo, t_hi, dense)
    status, message, t_end = "completed", "", t1
    # A non-finite derivative met inside a step: restart from the last good point with smaller steps
    # until the failure is bracketed within this span, so the valid part of the run is kept.
    bracket = 1e-6 * max(1.0, t1 - t0)
    n_steps, t_mark = 0, t0
    while solver.status == "running":
        t_prev, y_prev = solver.t, solver.y.copy()
        try:
            # Overflow in a trial step is caught below (non-finite derivative, domain tests), not warned.
            with np.errstate(over="ignore", invalid="ignore"):
                err = solver.step()
        except _NonFinite as exc:
            if exc.t - t_prev > bracket:
                span = 0.5 * (exc.t - t_prev)
                try:
                    solver = _SOLVERS[method](
                        rhs,
                        t_prev,
                        y_prev,
                        t1,
                        rtol=rtol,
                        atol=atol,
                        max_step=min(max_step, span),
                        first_step=0.5 * span,
                    )
                    continue
                except _NonFinite as again:  # non-finite at the last good point itself
                    exc = again
            status = "domain"
            t_end = t_prev
            if exc.control:  # JSBSim's words (harness.engines.jsbsim.run.StepStop.control)
                message = (
                    f"non-finite control at t = {exc.t:.6g} s ({', '.join(exc.names)}); "
                    f"partial result kept up to t = {t_prev:.6g} s"
                )
            else:
                message = (
                    f"non-finite derivative ({', '.join(exc.names)}) at t = {exc.t:.6g} s; "
                    f"integration stopped, partial result kept up to t = {t_prev:.6g} s"
                )
            break
        if solver.status == "failed":
            status, t_end = "failed", t_prev
            message = f"integrator failed at t = {t_prev:.6g} s: {err or 'the solver gave no reason'}"
            out = domain_violation(t_prev, y_prev, bounds)
            if out is not None:
                status, message = "domain", f"{out}; partial result kept up to t = {t_prev:.6g} s"
            break
        dense = solver.dense_output()
        hit = None
        if not np.all(np.isfinite(solver.y)):
            hit = (t_prev, None)
        m0, m1 = domain_margins(y_prev, bounds), domain_margins(solver.y, bounds)
        for i, g in events:
            g0, g1 = m0[i], m1[i]
            if g0 > 0 and not g1 > 0:
                te = brentq(lambda tt: g(dense(tt)), t_prev, solver.t, xtol=1e-12) if np.isfinite(g1) else t_prev  # noqa: B023
                if hit is None or te < hit[0]:
                    hit = (te, i)
        if hit is not None:
            te, i = hit
            segments.append((t_prev, te, dense))
            ye = dense(te) if te > t_prev else y_prev
            status, t_end = "domain", te
            if i is None:
                text = domain_violation(solver.t, solver.y, bounds) or "left the physical domain"
            else:
                text = domain_text(te, i, float(ye[STATE_NAMES.index(DOMAIN_TESTS[i][0])]), bounds)
            message = f"{text}; integration stopped, partial result kept up to t = {te:.6g} s"
            break
        segments.append((t_prev, solver.t, dense))
        n_steps += 1
        if n_steps % STALL_STEPS == 0:
            if solver.t - t_mark < STALL_FRACTION * (t1 - t0):
                # A right-hand side that switches faster than any step (a feedback chattering at a control
                # limit, Filippov sliding) makes an adaptive integrator creep forever: stop and say so.
                status, t_end = "failed", solver.t
                message = (
                    f"integrator stalled at t = {solver.t:.6g} s: {STALL_STEPS} steps advanced only "
                    f"{solver.t - t_mark:.3g} s (a right-hand side switching faster than the step, e.g. a "
                    f"feedback chattering at a control limit); partial result kept up to t = {solver.t:.6g} s"
                )
                break
            t_mark = solver.t
    if status == "completed":
        t_end = t1

    grid = grid[grid <= t_end + 1e-12]
    if status != "completed" and (grid.size == 0 or grid[-1] < t_end):
        grid = np.append(grid, t_end)
    Y = _evaluate_segments(segments, grid, y0, t0)
    df, dU = _frame(aircraft, env, grid, Y, ufun, feedback if ctrl is not None else None, model, h)
    warnings = envelope_warnings(aircraft, df)
    settings = RunSettings(
        engine="gna.simulate",
        method=method,
        rtol=rtol,
        atol=atol,
        max_step=max_step,
        model=model,
        environment=env.describe(),
        g=env.g,
        controller=None if ctrl is None else "evaluated continuously on the integrated state",
        controller_states=nc,
        controller_scheme=None if ctrl is None else f"{method} (integrated with the aircraft states)",
        extra={} if h is None else {"h": dict(h._asdict())},
    )
    result = SimulationResult(df=df, status=status, message=message, warnings=warnings, settings=settings, t_end=t_end)
    if ctrl is not None:
        result.controller_states, result.feedback = controller_frames(grid, names, Y[12:], dU)
    return result


def _evaluate_segments(segments, grid, y0, t0) -> np.ndarray:
    Y = np.empty((y0.size, grid.size))
    if not segments:
        Y[:] = y0[:, None]
        return Y
    his = np.array([s[1] for s in segments])
    idx = np.searchsorted(his, grid, side="left")
    idx = np.clip(idx, 0, len(segments) - 1)
    for k in np.unique(idx):
        sel = idx == k
        Y[:, sel] = segments[k][2](grid[sel])
    Y[:, grid == t0] = y0[:, None]
    return Y


def _frame(aircraft, env, grid, Y, ufun, feedback, model, h) -> tuple[pd.DataFrame, np.ndarray]:
    """The result's DataFrame and the feedback part of the controls (5, n) on the grid."""
    if isinstance(ufun, PiecewisePolynomial) and ufun.n_functions == 5:
        U = ufun.evaluate(grid)  # vectorised, the same Horner sums
    else:
        U = np.array([np.asarray(ufun(t), dtype=float) for t in grid]).T.reshape(5, grid.size)
    if feedback is None:
        dU = np.zeros_like(U)
    else:
        dU = np.array([np.asarray(feedback(t, Y[:, i]), dtype=float) for i, t in enumerate(grid)]).T.reshape(
            5, grid.size
        )
        U = U + dU
    Y = Y[:12]
    s, u = State(*Y), Controls(*U)
    ld = loads(aircraft, env, s, u, model, h)
    data = {n: Y[i] for i, n in enumerate(STATE_NAMES)}
    data.update({n: U[i] for i, n in enumerate(CONTROL_NAMES)})
    nx, ny, nz = body_load_factors(aircraft, env, s, ld)  # the limits' definition (gna.limits)
    data.update(
        qbar=np.broadcast_to(ld.qbar, grid.shape),
        rho=np.broadcast_to(ld.rho, grid.shape),
        nx=nx,
        ny=ny,
        nz=nz,
        X=ld.X,
        Y=ld.Y,
        Z=ld.Z,
        L=ld.L,
        M=ld.M,
        N=ld.N,
    )
    for name, v in zip(("CD", "CY", "CL", "Cl", "Cm", "Cn"), ld.moment_coeffs):
        data[name] = np.broadcast_to(v, grid.shape)
    df = pd.DataFrame({k: np.asarray(v, dtype=float) for k, v in data.items()}, index=pd.Index(grid, name="t"))
    return df, dU


#: The columns :func:`envelope_warnings` reads of a plan (a caller may build only these); a load-factor limit
#: also reads every state and control (:func:`gna.limits.limit_columns`).
ENVELOPE_VARIABLES: tuple[str, ...] = ("z", "V", "alpha", "beta") + CONTROL_NAMES


def envelope_warnings(aircraft, df, env=None) -> list[str]:
    """Excursions of a trajectory outside the aircraft's limits (:func:`gna.limits.limit_violations`), as text.

    Parameters
    ----------
    aircraft : Aircraft
        Its envelope, control limits and propulsion.
    df : pandas.DataFrame
        A trajectory indexed by time [s] with the columns :data:`ENVELOPE_VARIABLES` (z, V, alpha, beta, F,
        eta, dl, dm, dn); ``nz`` or every state for a load-factor limit.
    env : Environment, optional
        To compute ``nz`` when the frame has no such column.

    Returns
    -------
    list of str
        One warning per excursion (:meth:`gna.limits.Violation.text`): the span of times, its share of the
        run, the worst value and the limit.
    """
    return [v.text() for v in limit_violations(aircraft, df, env)]


def engine_thrust_warnings(aircraft: Aircraft, F, eta, V, t=None) -> list[str]:
    """Warnings for each engine whose thrust exceeds its own rating at the airspeed.

    Engine 1 gives ``F (1 + eta) / 2``, engine 2 ``F (1 - eta) / 2`` (one
    engine: ``F``); the limit is
    :meth:`gna.aircraft.Propulsion.engine_thrust_limit` (static thrust, and
    shaft power times propeller efficiency over ``V``), named with its source.

    Parameters
    ----------
    aircraft : Aircraft
        Its propulsion and per-engine rating.
    F, eta, V : float or array_like, shape (n,)
        Total thrust [N], asymmetry [-], airspeed [m/s].
    t : array_like, shape (n,), optional
        Times [s] (named in the warnings).

    Returns
    -------
    list of str
        One warning per engine over its limit (the worst point), empty when
        the aircraft has no per-engine rating.
    """
    prop = aircraft.propulsion
    if prop.engine_power is None and prop.engine_static_thrust is None:
        return []
    F, eta, V = np.broadcast_arrays(*(np.atleast_1d(np.asarray(v, dtype=float)) for v in (F, eta, V)))
    limit = np.array([prop.engine_thrust_limit(float(v)) for v in V])
    if prop.count == 2:
        shares = {"engine 1": 0.5 * (1.0 + eta), "engine 2": 0.5 * (1.0 - eta)}
    else:
        shares = {"the engine": np.ones_like(eta)}
    out = []
    for name, share in shares.items():
        Fi = F * share
        over = Fi > limit
        if np.any(over):
            i = int(np.argmax(np.where(over, Fi - limit, -np.inf)))
            at = "" if t is None else f" at t = {float(np.atleast_1d(t)[i]):.4g} s"
            share_of = "" if t is None else f" ({100.0 * np.mean(over):.0f} % of the run)"
            out.append(
                f"{name} thrust {Fi[i]:.1f} N{at} above its rating {limit[i]:.1f} N at V = {V[i]:.2f} m/s"
                f"{share_of} (per-engine limit: {prop.engine_source or 'aircraft file'})"
            )
    return out
