"""Numerical integration of the 12-state model with control functions of time.

The integrator is scipy's DOP853 driven step by step, so that leaving the
physical domain (V <= 0, |beta| >= pi/2, cos(gamma) = 0, non-finite values)
stops the run at the located time with a message naming the variable, and the
partial result is kept.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, Sequence

import numpy as np
import pandas as pd
from scipy.integrate import DOP853, RK45, Radau
from scipy.optimize import brentq

from .aircraft import Aircraft
from .atmosphere import Environment
from .eom import CONTROL_NAMES, STATE_NAMES, Controls, HValues, State, derivatives, loads
from .errors import InputError

ControlFunction = Callable[[float], Sequence[float]]

_SOLVERS = {"DOP853": DOP853, "RK45": RK45, "Radau": Radau}


@dataclass
class SimulationResult:
    """Outcome of :func:`simulate`.

    Attributes
    ----------
    df : pandas.DataFrame
        Indexed by time ``t`` [s]: the 12 states, the 5 applied controls and
        derived quantities (``qbar``, ``rho``, load factors ``nx, ny, nz``,
        wind-axis forces ``X, Y, Z``, body moments ``L, M, N``, coefficients).
    status : {"completed", "domain", "failed"}
    message : str
        Empty when completed; otherwise names the time, variable and value.
    warnings : list of str
        Envelope excursions (time, variable, value).
    settings : dict
        Integrator, tolerances, model, environment.
    """

    df: pd.DataFrame
    status: str
    message: str = ""
    warnings: list = field(default_factory=list)
    settings: dict = field(default_factory=dict)
    t_end: float = float("nan")

    @property
    def completed(self) -> bool:
        return self.status == "completed"


class _NonFinite(Exception):
    def __init__(self, t, names):
        self.t, self.names = t, names


def _as_control_function(controls) -> ControlFunction:
    if callable(controls):
        return controls
    arr = np.asarray(controls, dtype=float)
    if arr.shape != (5,):
        raise InputError(f"controls must be a function of t or 5 constants (F, eta, dl, dm, dn), got shape {arr.shape}")
    return lambda t: arr


def _domain_functions():
    """Event functions: positive inside the physical domain."""
    return [
        ("V", "airspeed V reached zero", lambda y: y[3]),
        ("beta", "|beta| reached pi/2", lambda y: math.cos(y[7])),
        ("gamma", "cos(gamma) reached zero (vertical flight path: the wind-frame chart is singular)",
         lambda y: math.cos(y[4])),
    ]


def simulate(aircraft: Aircraft, controls, t_span: tuple[float, float], x0, *,
             env: Environment | None = None, model: str = "full", h: HValues | None = None,
             controller=None, dt_out: float = 0.02, t_eval: np.ndarray | None = None,
             rtol: float = 1e-10, atol: float = 1e-10, method: str = "DOP853",
             max_step: float = np.inf) -> SimulationResult:
    """Integrate the full or simple model.

    Parameters
    ----------
    aircraft : Aircraft
    controls : callable or sequence
        ``controls(t) -> (F, eta, dl, dm, dn)``, or five constants.
    t_span : (t0, t1)
    x0 : State or array of 12
    env : Environment, optional
    model : {"full", "simple"}
    h : HValues, optional
        Neglected-term values for the simple model.
    controller : callable, optional
        ``controller(t, x) -> correction`` (5 values) added to the reference
        controls (``x`` the 12-state array).
    dt_out, t_eval
        Output grid (``t_eval`` overrides ``dt_out``).
    rtol, atol, method, max_step
        Integrator settings (recorded in the result).

    Returns
    -------
    SimulationResult
    """
    env = env if env is not None else Environment()
    t0, t1 = (float(v) for v in t_span)
    if not (math.isfinite(t0) and math.isfinite(t1) and t1 > t0):
        raise InputError(f"t_span must be finite and increasing, got {t_span}")
    y0 = np.asarray(x0, dtype=float).reshape(12)
    if not np.all(np.isfinite(y0)):
        bad = [n for n, v in zip(STATE_NAMES, y0) if not math.isfinite(v)]
        raise InputError(f"initial state has non-finite values: {', '.join(bad)}")
    if y0[3] <= 0:
        raise InputError(f"initial speed must be positive, got V = {y0[3]} m/s")
    if method not in _SOLVERS:
        raise InputError(f"unknown integrator {method!r}; choose from {', '.join(_SOLVERS)}")
    ufun = _as_control_function(controls)

    def applied(t, y):
        u = np.asarray(ufun(t), dtype=float)
        if controller is not None:
            u = u + np.asarray(controller(t, y), dtype=float)
        return u

    def rhs(t, y):
        u = applied(t, y)
        d = np.array(derivatives(aircraft, env, State(*y), Controls(*u), model, h), dtype=float)
        if not np.all(np.isfinite(d)):
            names = [n for n, v in zip(STATE_NAMES, d) if not math.isfinite(v)]
            if not np.all(np.isfinite(u)):
                names += [f"control {n}" for n, v in zip(CONTROL_NAMES, u) if not math.isfinite(v)]
            raise _NonFinite(t, names)
        return d

    solver = _SOLVERS[method](rhs, t0, y0, t1, rtol=rtol, atol=atol, max_step=max_step)
    events = _domain_functions()
    segments = []  # (t_lo, t_hi, dense)
    status, message, t_end = "completed", "", t1
    # A non-finite derivative met inside a step: restart from the last good point with smaller steps
    # until the failure is bracketed within this span, so the valid part of the run is kept.
    bracket = 1e-6 * max(1.0, t1 - t0)
    while solver.status == "running":
        t_prev, y_prev = solver.t, solver.y.copy()
        try:
            err = solver.step()
        except _NonFinite as exc:
            if exc.t - t_prev > bracket:
                span = 0.5 * (exc.t - t_prev)
                solver = _SOLVERS[method](rhs, t_prev, y_prev, t1, rtol=rtol, atol=atol,
                                          max_step=min(max_step, span), first_step=0.5 * span)
                continue
            status = "domain"
            t_end = t_prev
            message = (f"non-finite derivative ({', '.join(exc.names)}) at t = {exc.t:.6g} s; "
                       f"integration stopped, result kept up to t = {t_prev:.6g} s")
            break
        if solver.status == "failed":
            status, t_end = "failed", t_prev
            message = f"integrator failed at t = {t_prev:.6g} s: {err}"
            break
        dense = solver.dense_output()
        hit = None
        for name, text, g in events:
            g0, g1 = g(y_prev), g(solver.y)
            if g0 > 0 and not g1 > 0:
                te = brentq(lambda tt: g(dense(tt)), t_prev, solver.t, xtol=1e-12) if np.isfinite(g1) else solver.t
                if hit is None or te < hit[0]:
                    hit = (te, name, text)
        if hit is not None:
            te, name, text = hit
            segments.append((t_prev, te, dense))
            ye = dense(te)
            status, t_end = "domain", te
            message = (f"{text} at t = {te:.6g} s ({name} = {ye[STATE_NAMES.index(name)]:.6g}); "
                       f"integration stopped, partial result kept")
            break
        segments.append((t_prev, solver.t, dense))
    if status == "completed":
        t_end = t1

    if t_eval is None:
        n = max(int(round((t1 - t0) / dt_out)), 1)
        grid = np.linspace(t0, t1, n + 1)
    else:
        grid = np.asarray(t_eval, dtype=float)
    grid = grid[grid <= t_end + 1e-12]
    if status != "completed" and (grid.size == 0 or grid[-1] < t_end):
        grid = np.append(grid, t_end)
    Y = _evaluate_segments(segments, grid, y0, t0)
    df = _frame(aircraft, env, grid, Y, applied, model, h)
    warnings = envelope_warnings(aircraft, df)
    settings = dict(method=method, rtol=rtol, atol=atol, max_step=max_step, model=model,
                    environment=env.atmosphere.describe(), g=env.g,
                    h=None if h is None else dict(h._asdict()))
    return SimulationResult(df=df, status=status, message=message, warnings=warnings, settings=settings,
                            t_end=t_end)


def _evaluate_segments(segments, grid, y0, t0) -> np.ndarray:
    Y = np.empty((12, grid.size))
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


def _frame(aircraft, env, grid, Y, applied, model, h) -> pd.DataFrame:
    U = np.array([applied(t, Y[:, i]) for i, t in enumerate(grid)]).T.reshape(5, grid.size)
    s, u = State(*Y), Controls(*U)
    ld = loads(aircraft, env, s, u, model, h)
    data = {n: Y[i] for i, n in enumerate(STATE_NAMES)}
    data.update({n: U[i] for i, n in enumerate(CONTROL_NAMES)})
    m, g = aircraft.mass.mass, env.g
    # Load factors: non-gravitational specific force in body axes over g (nz positive "up").
    ca, sa, cb, sb = np.cos(s.alpha), np.sin(s.alpha), np.cos(s.beta), np.sin(s.beta)
    fx_w, fy_w, fz_w = ld.Xa, ld.Ya, ld.Za
    fbx = ca * cb * fx_w - ca * sb * fy_w - sa * fz_w
    fby = sb * fx_w + cb * fy_w
    fbz = sa * cb * fx_w - sa * sb * fy_w + ca * fz_w
    data.update(qbar=np.broadcast_to(ld.qbar, grid.shape), rho=np.broadcast_to(ld.rho, grid.shape),
                nx=fbx / (m * g), ny=fby / (m * g), nz=-fbz / (m * g),
                X=ld.X, Y=ld.Y, Z=ld.Z, L=ld.L, M=ld.M, N=ld.N)
    for name, v in zip(("CD", "CY", "CL", "Cl", "Cm", "Cn"), ld.moment_coeffs):
        data[name] = np.broadcast_to(v, grid.shape)
    df = pd.DataFrame({k: np.asarray(v, dtype=float) for k, v in data.items()}, index=pd.Index(grid, name="t"))
    return df


def _excursion(df, mask, name: str, values, worst_index: int, text: str) -> str:
    t = df.index.to_numpy(dtype=float)
    m = mask.to_numpy() if hasattr(mask, "to_numpy") else np.asarray(mask)
    first, last = float(t[m][0]), float(t[m][-1])
    dt = np.diff(t, append=t[-1])
    duration = float(np.sum(dt[m]))
    frac = 100.0 * duration / max(float(t[-1] - t[0]), 1e-300)
    span = f"at t = {first:.4g} s" if first == last else f"from t = {first:.4g} to {last:.4g} s ({frac:.0f} % of the run)"
    return f"{text} {span}; worst {values[worst_index]} at t = {t[worst_index]:.4g} s"


def envelope_warnings(aircraft, df) -> list[str]:
    """Excursions of a trajectory outside the aircraft's envelope, control limits and thrust range.

    Each warning names the span of times, its share of the run, the worst value and the limit.
    """
    out = []
    env = aircraft.envelope
    deg = lambda v: f"{math.degrees(v):.2f} deg"  # noqa: E731
    a, b = df["alpha"].to_numpy(), df["beta"].to_numpy()
    for mask, worst, text in (
            (a < env.alpha_min, int(np.argmin(a)),
             f"alpha below the aerodynamic model's envelope ({math.degrees(env.alpha_min):.1f} deg)"),
            (a > env.alpha_max, int(np.argmax(a)),
             f"alpha above the aerodynamic model's envelope ({math.degrees(env.alpha_max):.1f} deg)"),
            (np.abs(b) > env.beta_max, int(np.argmax(np.abs(b))),
             f"|beta| above the aerodynamic model's envelope ({math.degrees(env.beta_max):.1f} deg)")):
        if np.any(mask):
            vals = a if "alpha" in text else b
            out.append(_excursion(df, mask, "", [deg(v) for v in vals], worst, text))
    for name, lim in env.control_limits.items():
        v = df[name].to_numpy()
        mask = np.abs(v) > lim
        if np.any(mask):
            out.append(_excursion(df, mask, name, [deg(x) for x in v], int(np.argmax(np.abs(v))),
                                  f"control {name} beyond its limit {math.degrees(lim):.1f} deg"))
    F = df["F"].to_numpy()
    if np.any(F < 0):
        out.append(_excursion(df, F < 0, "F", [f"{x:.4g} N" for x in F], int(np.argmin(F)),
                              "negative thrust F (drag beyond the airframe's needed)"))
    fmax = aircraft.propulsion.max_thrust
    if fmax is not None and np.any(F > fmax):
        out.append(_excursion(df, F > fmax, "F", [f"{x:.4g} N" for x in F], int(np.argmax(F)),
                              f"thrust F above the maximum {fmax:.4g} N"))
    if aircraft.propulsion.count == 2:
        eta = df["eta"].to_numpy()
        if np.any(np.abs(eta) > 1):
            out.append(_excursion(df, np.abs(eta) > 1, "eta", [f"{x:.4g}" for x in eta],
                                  int(np.argmax(np.abs(eta))),
                                  "|eta| above 1 (one engine would need negative thrust)"))
    return out
