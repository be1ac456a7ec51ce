"""Steady flight: trim and calibration (paper section "Calibration functions").

For a trajectory of constant curvature and torsion, the nine equations
``V' = gamma' = alpha' = beta' = mu' = p' = q' = r' = 0`` and
``chi' = const`` relate the thirteen unknowns
``{V, gamma, chi', F, alpha, beta, mu, p, q, r, dl, dm, dn}`` (eta is a given
parameter).  The user fixes any four; Newton's method gives the other nine,
for the full or the simple model.  Density is taken at the given altitude and
held constant (a climbing helix is only steady in constant density).
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import brentq, minimize_scalar

from .aircraft import Aircraft
from .atmosphere import ConstantDensity, Environment
from .eom import Controls, HValues, State, derivatives
from .errors import ConvergenceError, DomainError, InputError
from .simulate import engine_thrust_warnings
from .solve import newton
from .trajectory import DOMAIN, UNITS, domain_bounds, domain_violation
from .units import G0

TRIM_VARIABLES: tuple[str, ...] = ("V", "gamma", "chi_dot", "F", "alpha", "beta", "mu", "p", "q", "r", "dl", "dm", "dn")
RESIDUAL_NAMES: tuple[str, ...] = ("V'", "gamma'", "chi'-chi_dot", "alpha'", "beta'", "mu'", "p'", "q'", "r'")


@dataclass
class TrimResult:
    """A steady-flight solution.

    Attributes
    ----------
    values : dict
        The 13 trim variables (SI, rad).
    fixed : dict
        The four values the user fixed.
    residuals : dict
        The nine steady-flight equations at the solution (``chi'`` minus ``chi_dot``).
    iterations : int
    model : str
    altitude : float
    state, controls : State, Controls
        The steady state (x = y = 0, chi = 0, z = -altitude) and controls.
    """

    values: dict
    fixed: dict
    residuals: dict
    iterations: int
    model: str
    altitude: float
    eta: float
    aircraft: str
    state: State = field(repr=False)
    controls: Controls = field(repr=False)
    density: float = float("nan")
    warnings: list = field(default_factory=list)

    @property
    def max_residual(self) -> float:
        return max(abs(v) for v in self.residuals.values())

    def to_dict(self) -> dict:
        """The solution as plain data (values with units, degrees, residuals, warnings).

        Returns
        -------
        dict
            JSON-serialisable record of the trim.
        """
        return {
            "aircraft": self.aircraft,
            "model": self.model,
            "altitude_m": self.altitude,
            "density_kg_m3": self.density,
            "eta": self.eta,
            "fixed": self.fixed,
            "iterations": self.iterations,
            "converged": True,
            "values": {k: {"value": v, "unit": UNITS[k]} for k, v in self.values.items()},
            "values_deg": {k: math.degrees(self.values[k]) for k in ("gamma", "alpha", "beta", "mu", "dl", "dm", "dn")},
            "residuals": self.residuals,
            "max_residual": self.max_residual,
            "warnings": list(self.warnings),
        }

    def to_json(self) -> str:
        """The solution as JSON text.

        Returns
        -------
        str
            :meth:`to_dict`, indented.
        """
        return json.dumps(self.to_dict(), indent=2)


def _check_number(name: str, value) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InputError(f"{name} must be a number, got {value!r}") from None
    if not math.isfinite(v):
        raise InputError(f"{name} must be finite, got {v}")
    return v


def check_eta(aircraft: Aircraft, eta: float) -> float:
    """Check a thrust asymmetry ``eta = (F1 - F2)/(F1 + F2)`` against the aircraft's engines.

    Parameters
    ----------
    aircraft : Aircraft
        Its engine count.
    eta : float
        Thrust asymmetry [-].

    Returns
    -------
    float
        ``eta``.

    Raises
    ------
    InputError
        ``|eta| > 1`` (one engine would give negative thrust) with two
        engines, ``eta != 0`` with one engine on the symmetry plane.
    """
    if aircraft.propulsion.count == 1 and eta != 0.0:
        raise InputError(
            f"eta = {eta:g}: {aircraft.id} has one engine on the symmetry plane, so the thrust asymmetry eta must be 0"
        )
    if not -1.0 <= eta <= 1.0:
        raise InputError(
            f"eta = {eta:g} is outside [-1, 1]: eta = (F1 - F2)/(F1 + F2), so one engine would give "
            f"negative thrust (eta = 1: engine 2 off, eta = -1: engine 1 off)"
        )
    return eta


def _default_guess(aircraft: Aircraft, rho: float, fixed: Mapping[str, float]) -> dict:
    """Initial values: level flight estimates from the lift and drag polars."""
    m, g, S = aircraft.mass.mass, G0, aircraft.geometry.S
    V = fixed.get("V")
    alpha = fixed.get("alpha")
    # Lift slope and zero-lift from the model itself (alpha sweep at zero controls).
    from .aero import AeroState

    a = np.array([0.0, 0.05])
    c = aircraft.aero.coefficients(AeroState(a, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0))
    CL = np.broadcast_to(c.CL, a.shape)
    CLa = max((CL[1] - CL[0]) / 0.05, 0.5)
    if V is None:
        al = alpha if alpha is not None else 0.08
        CLv = max(float(CL[0] + CLa * al), 0.1)
        V = math.sqrt(2 * m * g / (rho * S * CLv))
    if alpha is None:
        alpha = (2 * m * g / (rho * V * V * S) - CL[0]) / CLa
        alpha = float(np.clip(alpha, aircraft.envelope.alpha_min, aircraft.envelope.alpha_max))
    cD = aircraft.aero.coefficients(AeroState(alpha, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)).CD
    F = 0.5 * rho * V * V * S * float(cD) + m * g * math.sin(fixed.get("gamma", 0.0))
    guess = dict(
        V=V,
        gamma=0.0,
        chi_dot=0.0,
        F=max(F, 0.0),
        alpha=alpha,
        beta=0.0,
        mu=0.0,
        p=0.0,
        q=0.0,
        r=0.0,
        dl=0.0,
        dm=0.0,
        dn=0.0,
    )
    # A coordinated turn needs the bank angle that tilts the lift.
    if "chi_dot" in fixed and fixed["chi_dot"] != 0.0:
        guess["mu"] = math.atan(V * fixed["chi_dot"] / g)
    return guess


def trim(
    aircraft: Aircraft,
    fixed: Mapping[str, float],
    *,
    altitude: float = 0.0,
    env: Environment | None = None,
    eta: float = 0.0,
    model: str = "full",
    h: HValues | None = None,
    guess: Mapping[str, float] | None = None,
    tol: float = 1e-11,
    maxiter: int = 60,
    check_envelope: bool = True,
) -> TrimResult:
    """Solve the nine steady-flight equations for the nine free trim variables.

    Parameters
    ----------
    aircraft : Aircraft
    fixed : mapping
        Exactly four of :data:`TRIM_VARIABLES` with their values (SI, rad).
    altitude : float
        Altitude [m]; the density is the environment's at that altitude.
    env : Environment, optional
        Default: ISA.
    eta : float
        Thrust asymmetry ``(F1 - F2)/F``.
    model : {"full", "simple"}
    h : HValues, optional
        Values of the neglected terms for the simple model.
    guess : mapping, optional
        Initial values of free variables.
    tol : float
        Newton tolerance on the max-norm of the nine residuals.
    maxiter : int
        Maximum number of Newton iterations.
    check_envelope : bool
        Refuse a solution with alpha or beta outside the aerodynamic model's
        envelope or a surface beyond 90 deg (the polynomial model has
        mathematical, non-physical trims there).  Surface limits, negative or
        excessive thrust are reported in ``warnings``.

    Returns
    -------
    TrimResult
        The 13 trim variables, the residuals, the steady state and controls, and warnings.

    Raises
    ------
    InputError
        Wrong set of fixed variables, bad values, ``|eta| > 1`` (or ``eta != 0``
        with one engine), unknown model.
    ConvergenceError
        Newton did not converge (message names the residual, iterations and fixed values).
    DomainError
        The altitude is outside the atmosphere model's range (the ISA's -2 to
        20 km); a fixed speed or the solved steady state lies outside the
        physical domain (:data:`gna.trajectory.DOMAIN`, e.g. V above 3000 m/s);
        with ``check_envelope``, the solution lies outside the aerodynamic
        model's envelope.
    """
    env = env if env is not None else Environment()
    unknown = [k for k in fixed if k not in TRIM_VARIABLES]
    if unknown:
        raise InputError(f"unknown trim variable(s) {', '.join(unknown)}; choose from {', '.join(TRIM_VARIABLES)}")
    if len(fixed) != 4:
        raise InputError(f"fix exactly 4 of the 13 trim variables (got {len(fixed)}: {', '.join(fixed) or 'none'})")
    fixed = {k: _check_number(k, v) for k, v in fixed.items()}
    altitude = _check_number("altitude", altitude)
    eta = check_eta(aircraft, _check_number("eta", eta))
    if model not in ("full", "simple"):
        raise InputError(f"model must be 'full' or 'simple', got {model!r}")
    env.check_altitude(altitude, "trim")
    if "V" in fixed and fixed["V"] <= 0:
        raise InputError(f"speed must be positive, got V = {fixed['V']} m/s")
    if "V" in fixed and not DOMAIN.V_min <= fixed["V"] <= DOMAIN.V_max:
        raise DomainError(
            f"trim of {aircraft.id}: V = {fixed['V']:g} m/s is outside the physical domain "
            f"[{DOMAIN.V_min:g}, {DOMAIN.V_max:g}] m/s (gna.trajectory.DOMAIN)",
            variable="V",
            value=fixed["V"],
        )
    if "beta" in fixed and abs(fixed["beta"]) >= math.pi / 2:
        raise InputError(f"|beta| must be below pi/2, got {fixed['beta']} rad")
    if "gamma" in fixed and abs(fixed["gamma"]) >= math.pi / 2:
        raise InputError(f"|gamma| must be below pi/2, got {fixed['gamma']} rad")
    rho = float(env.density(-altitude))
    cenv = Environment(ConstantDensity(rho), env.g, env.ground_effect)  # density frozen at the altitude
    free = [k for k in TRIM_VARIABLES if k not in fixed]
    g0 = _default_guess(aircraft, rho, fixed)
    if guess:
        g0.update({k: float(v) for k, v in guess.items() if k in g0})
    x0 = np.array([g0[k] for k in free])

    def unpack(x):
        vals = dict(fixed)
        vals.update(zip(free, x))
        return vals

    def residual(x):
        v = unpack(x)
        s = State(0.0, 0.0, -altitude, v["V"], v["gamma"], 0.0, v["alpha"], v["beta"], v["mu"], v["p"], v["q"], v["r"])
        u = Controls(v["F"], eta, v["dl"], v["dm"], v["dn"])
        d = derivatives(aircraft, cenv, s, u, model, h)
        return np.array([d.V, d.gamma, d.chi - v["chi_dot"], d.alpha, d.beta, d.mu, d.p, d.q, d.r])

    # Complex step needs an analytic aerodynamic model; tabulated sources set analytic = False.
    jac = "complex" if getattr(aircraft.aero, "analytic", True) else "central"
    res = newton(residual, x0, tol=tol, maxiter=maxiter, jac=jac)
    if not res.all_converged:
        fx = ", ".join(f"{k} = {v:.6g}" for k, v in fixed.items())
        raise ConvergenceError(
            f"trim of {aircraft.id} ({model} model) did not converge: residual {float(res.residual):.3g} after "
            f"{res.iterations} Newton iterations with {fx} at altitude {altitude:g} m "
            f"(the condition may be outside the aircraft's steady-flight domain)",
            residual=float(res.residual),
            iterations=res.iterations,
        )
    vals = unpack(res.x)
    r = residual(res.x)
    s = State(
        0.0,
        0.0,
        -altitude,
        vals["V"],
        vals["gamma"],
        0.0,
        vals["alpha"],
        vals["beta"],
        vals["mu"],
        vals["p"],
        vals["q"],
        vals["r"],
    )
    u = Controls(vals["F"], eta, vals["dl"], vals["dm"], vals["dn"])
    if vals["V"] <= 0:
        raise ConvergenceError(
            f"trim of {aircraft.id} converged to a non-physical speed V = {vals['V']:.4g} m/s",
            residual=float(res.residual),
            iterations=res.iterations,
        )
    outside = domain_violation(0.0, s, domain_bounds(env))  # the engines' domain, the atmosphere's range included
    if outside is not None:  # a free speed or angle solved outside the domain
        fx = ", ".join(f"{k} = {v:.6g}" for k, v in fixed.items())
        raise DomainError(
            f"trim of {aircraft.id} with {fx}: the steady state is outside the physical domain: "
            + outside.split(": ", 1)[1]
        )
    warnings = _envelope_check(aircraft, vals, fixed, check_envelope, eta)
    return TrimResult(
        values={k: float(vals[k]) for k in TRIM_VARIABLES},
        fixed=dict(fixed),
        residuals={n: float(v) for n, v in zip(RESIDUAL_NAMES, r)},
        iterations=res.iterations,
        model=model,
        altitude=altitude,
        eta=eta,
        aircraft=aircraft.id,
        state=s,
        controls=u,
        density=rho,
        warnings=warnings,
    )


def _envelope_check(
    aircraft: Aircraft, vals: Mapping[str, float], fixed: Mapping[str, float], strict: bool, eta: float = 0.0
) -> list[str]:
    env = aircraft.envelope
    errors, warnings = [], []
    a, b = vals["alpha"], vals["beta"]
    if not env.alpha_min <= a <= env.alpha_max:
        errors.append(
            f"alpha = {math.degrees(a):.2f} deg outside the aerodynamic model's envelope "
            f"[{math.degrees(env.alpha_min):.1f}, {math.degrees(env.alpha_max):.1f}] deg"
        )
    if abs(b) > env.beta_max:
        errors.append(
            f"|beta| = {math.degrees(abs(b)):.2f} deg above the envelope's {math.degrees(env.beta_max):.1f} deg"
        )
    for name in ("dl", "dm", "dn"):
        d = vals[name]
        if abs(d) >= math.pi / 2:
            errors.append(f"{name} = {math.degrees(d):.1f} deg (a surface cannot deflect 90 deg)")
        elif name in env.control_limits and abs(d) > env.control_limits[name]:
            warnings.append(
                f"{name} = {math.degrees(d):.2f} deg beyond its limit {math.degrees(env.control_limits[name]):.1f} deg"
            )
    if vals["F"] < 0:
        warnings.append(f"negative thrust F = {vals['F']:.1f} N (the condition needs drag beyond the airframe's)")
    elif aircraft.propulsion.max_thrust is not None and vals["F"] > aircraft.propulsion.max_thrust:
        warnings.append(f"thrust F = {vals['F']:.1f} N above the maximum {aircraft.propulsion.max_thrust:.1f} N")
    warnings += engine_thrust_warnings(aircraft, vals["F"], eta, vals["V"])
    if errors and strict:
        fx = ", ".join(f"{k} = {v:.6g}" for k, v in fixed.items())
        raise DomainError(
            f"trim of {aircraft.id} with {fx} is outside the model's validity: " + "; ".join(errors),
            variable="alpha" if "alpha" in errors[0] else None,
        )
    return warnings + errors


def trim_level(aircraft: Aircraft, V: float, altitude: float = 0.0, **kw) -> TrimResult:
    """Wings-level, straight and level flight at speed ``V`` (gamma = chi' = beta = 0).

    Parameters
    ----------
    aircraft : Aircraft
        The aircraft model.
    V : float
        Airspeed [m/s].
    altitude : float
        Altitude [m].
    **kw
        Further keywords of :func:`trim` (``env``, ``model``, ``tol``, ...).

    Returns
    -------
    TrimResult
        The steady-flight solution.
    """
    return trim(aircraft, {"V": V, "gamma": 0.0, "chi_dot": 0.0, "beta": 0.0}, altitude=altitude, **kw)


def level_alpha(aircraft: Aircraft, V: float, altitude: float = 0.0, **kw) -> float:
    """Angle of attack of straight and level flight at speed ``V``.

    Parameters
    ----------
    aircraft : Aircraft
        The aircraft model.
    V : float
        Airspeed [m/s].
    altitude : float
        Altitude [m].
    **kw
        Further keywords of :func:`trim` (``env``, ``model``, ``tol``, ...).

    Returns
    -------
    float
        Angle of attack [rad].
    """
    return trim_level(aircraft, V, altitude, **kw).values["alpha"]


def coordinated_turn(
    aircraft: Aircraft, V: float, turn_rate: float, altitude: float = 0.0, gamma: float = 0.0, **kw
) -> TrimResult:
    """Steady coordinated (beta = 0) turn at ``turn_rate`` = chi'.

    Parameters
    ----------
    aircraft : Aircraft
        The aircraft model.
    V : float
        Airspeed [m/s].
    turn_rate : float
        Track-angle rate chi' [rad/s].
    altitude : float
        Altitude [m].
    gamma : float
        Flight-path angle [rad] (a climbing or descending helix).
    **kw
        Further keywords of :func:`trim` (``env``, ``model``, ``tol``, ...).

    Returns
    -------
    TrimResult
        The steady-flight solution.
    """
    return trim(aircraft, {"V": V, "gamma": gamma, "chi_dot": turn_rate, "beta": 0.0}, altitude=altitude, **kw)


def sideslip_glide(aircraft: Aircraft, beta: float, alpha: float, altitude: float = 0.0, **kw) -> TrimResult:
    """Steady straight glide with engines off (F = 0) at given sideslip and angle of attack.

    This is the paper's calibration of the forward slip (its table of
    straight-line trajectories at alpha = 0.15 and beta = 0, 0.2, 0.35).

    Parameters
    ----------
    aircraft : Aircraft
        The aircraft model.
    beta : float
        Sideslip [rad].
    alpha : float
        Angle of attack [rad].
    altitude : float
        Altitude [m].
    **kw
        Further keywords of :func:`trim` (``env``, ``model``, ``tol``, ...).

    Returns
    -------
    TrimResult
        The steady-flight solution.
    """
    return trim(aircraft, {"F": 0.0, "beta": beta, "alpha": alpha, "chi_dot": 0.0}, altitude=altitude, **kw)


@dataclass
class StallResult:
    """Stall speed: the minimum speed of straight, level, coordinated flight."""

    V_stall: float
    alpha_stall: float
    trim: TrimResult


def stall_speed(aircraft: Aircraft, altitude: float = 0.0, **kw) -> StallResult:
    """Stall speed defined as the lift maximum (paper: "a rough mathematical definition of stalling").

    Level flight at fixed alpha gives V(alpha); the stall is its minimum over
    the envelope's alpha range.

    Parameters
    ----------
    aircraft : Aircraft
        The aircraft model.
    altitude : float
        Altitude [m].
    **kw
        Further keywords of :func:`trim` (``env``, ``model``, ``tol``, ...).

    Returns
    -------
    StallResult
        Stall speed [m/s], its angle of attack [rad] and the trim there.
    """
    env = aircraft.envelope
    cache: dict[float, TrimResult] = {}

    def V_of(alpha):
        try:
            t = trim(
                aircraft,
                {"alpha": float(alpha), "gamma": 0.0, "chi_dot": 0.0, "beta": 0.0},
                altitude=altitude,
                check_envelope=False,
                **kw,
            )
        except ConvergenceError:
            return 1e6
        cache[float(alpha)] = t
        return t.values["V"]

    lo, hi = max(env.alpha_min, 0.0), env.alpha_max
    grid = np.linspace(lo, hi, 25)
    vs = [V_of(a) for a in grid]
    i = int(np.argmin(vs))
    a_lo, a_hi = grid[max(i - 1, 0)], grid[min(i + 1, len(grid) - 1)]
    if i in (0, len(grid) - 1):
        best_alpha = float(grid[i])
    else:
        best_alpha = float(minimize_scalar(V_of, bounds=(a_lo, a_hi), method="bounded", options={"xatol": 1e-7}).x)
        # V is flat at its minimum, so alpha is known there only to ~sqrt(tolerance): refine it as the
        # root of dV/dalpha (central difference), where it is sharp (a rank test at the stall needs it).
        h = 1e-5

        def dV(alpha):
            return (V_of(alpha + h) - V_of(alpha - h)) / (2 * h)

        if dV(a_lo + h) < 0 < dV(a_hi - h):
            best_alpha = float(brentq(dV, a_lo + h, a_hi - h, xtol=1e-12))
    V_of(best_alpha)
    t = cache[best_alpha]
    return StallResult(V_stall=t.values["V"], alpha_stall=best_alpha, trim=t)
