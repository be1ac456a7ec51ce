"""JSBSim flying the original aircraft a GNA set was fitted from (engine ``"jsbsim-source"``).

For an aircraft whose provenance says it was fitted from a JSBSim aircraft
(:mod:`gna.fit.sources.jsbsim_aero`, e.g. ``f16-jsbsim`` from the bundled
``f16``) this engine flies that JSBSim aircraft itself: its own aerodynamic
tables, mass properties (with fuel burn) and engines.  A plan made on the
fitted model and flown here meets the fit's bias, which the in-house engine and
the exported file cannot show.

* **Configuration** as in the fit: FCS off (``simulation/models/FGFCS/enabled
  = 0``, else its channels overwrite the surfaces and move LEF, flaperon mix,
  gear) and the configuration the fit held (from the provenance: gear up, LEF,
  speedbrake, flaperon mix 0 for the f16) written before ``run_ic``.
* **Surfaces** with the fit's mapping, from the provenance (f16: ``dm =
  fcs/elevator-pos-rad``, ``dl = -fcs/aileron-pos-rad``, ``dn = fcs/rudder-pos-rad``).
* **Thrust** through the aircraft's own engines (spool dynamics, Mach and
  altitude lapse, thrust line off the CG): throttle = the engine's steady
  thrust-throttle table at the initial condition inverted at the command, plus
  an integral correction on the measured ``propulsion/engine[i]/thrust-lbs`` at
  every step (time constant ``throttle_tau``).  Engines spun up to the initial
  thrust (JSBSim's steady state) before ``t0``.  Columns ``F``, ``eta`` are the
  *delivered* thrust and asymmetry; ``settings["thrust"]`` has the loop's error.
* **Earth, air, timing** as :class:`harness.engines.JSBSimEngine`: flat
  non-rotating planet (``FGFDMExec.load_planet``: sphere of radius
  ``planet_radius_ft``, no J2, ``GM`` exact at the initial altitude), gravity
  model 0, JSBSim's ISA, exact wind-frame initial state, same integrators and
  controller sampling (``controller_dt``, controller states by AB2): the run
  loop is :class:`harness.engines.jsbsim.run.JSBSimRun`'s, with the hooks of
  :class:`_SourceRun`.
"""

from __future__ import annotations

import math
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import ClassVar

import numpy as np

from gna import units
from gna.aircraft import Aircraft
from gna.atmosphere import ISA, Environment
from gna.errors import InputError
from gna.fit.sources.jsbsim_aero import FittedSource, check_properties, fitted_source, load_model, resolve
from gna.trajectory import SimulationResult, environment_of

from ..base import EngineError
from . import export as jx
from .fdm import (
    Integrators,
    LogCapture,
    check_initial_condition,
    import_jsbsim,
    initial_condition_properties,
    set_stepping,
)
from .run import JSBSimRun, check_steps

#: Raw outputs for :meth:`_SourceRun._derived`: JSBSim's aero loads instead of the exported file's coefficients.
_DERIVED = (
    "aero/qbar-psf",
    "atmosphere/rho-slugs_ft3",
    "forces/fbx-aero-lbs",
    "forces/fby-aero-lbs",
    "forces/fbz-aero-lbs",
    "moments/l-aero-lbsft",
    "moments/m-aero-lbsft",
    "moments/n-aero-lbsft",
    "forces/fbx-total-lbs",
    "forces/fby-total-lbs",
    "forces/fbz-total-lbs",
    "forces/fbx-weight-lbs",
    "forces/fby-weight-lbs",
    "forces/fbz-weight-lbs",
    "moments/l-total-lbsft",
    "moments/m-total-lbsft",
    "moments/n-total-lbsft",
)


def source_model(aircraft: Aircraft) -> FittedSource:
    """The JSBSim aircraft, surface mapping and configuration ``aircraft`` was fitted with (its provenance).

    Parameters
    ----------
    aircraft : Aircraft

    Returns
    -------
    gna.fit.sources.jsbsim_aero.FittedSource

    Raises
    ------
    InputError
        If ``aircraft`` was not fitted from a JSBSim aircraft (the engine cannot fly it).
    """
    try:
        return fitted_source(aircraft.provenance, repr(aircraft.id))
    except InputError as exc:
        raise InputError(
            f"engine jsbsim-source flies the JSBSim aircraft a GNA set was fitted from: {exc}; "
            f"fly {aircraft.id!r} on 'inhouse' or 'jsbsim'"
        ) from None


def _few_numbers(values, n: int = 4) -> str:
    """``values`` as a short text: the first few, then how many more."""
    shown = ", ".join(f"{v:.4g}" for v in values[:n])
    return shown + (f", ... ({len(values)} values)" if len(values) > n else "")


class _ThrottleLoop:
    """Throttle = steady-thrust table inverted at the command + integral correction on the measured thrust."""

    def __init__(self, table_th: np.ndarray, table_T: np.ndarray, tau: float, dt: float):
        finite = np.isfinite(table_T)
        keep = np.concatenate([[True], np.diff(np.maximum.accumulate(np.where(finite, table_T, -np.inf))) > 0])
        keep &= finite  # the increasing part of the steady-thrust table
        self.th, self.T = table_th[keep], table_T[keep]
        if self.th.size < 2:
            raise InputError(
                f"JSBSim's steady state of the engine gives no thrust that grows with the throttle (thrust "
                f"{_few_numbers(table_T * units.LBF)} N over throttle {table_th[0]:g} .. {table_th[-1]:g}): the "
                f"jsbsim-source engine cannot command its thrust"
            )
        self.slope = np.maximum(np.gradient(self.T, self.th), 1e-3 * (self.T[-1] - self.T[0]) + 1e-9)
        self.gain = dt / tau
        self.integral = 0.0

    def throttle(self, F_lbf: float) -> float:
        ff = float(np.interp(F_lbf, self.T, self.th))
        return min(max(ff + self.integral, self.th[0]), self.th[-1])

    def update(self, F_lbf: float, T_lbf: float, th: float) -> None:
        e = F_lbf - T_lbf
        if (th >= self.th[-1] and e > 0) or (th <= self.th[0] and e < 0):
            return  # saturated: no wind-up
        self.integral += self.gain * e / float(np.interp(th, self.th, self.slope))


@dataclass(frozen=True)
class JSBSimSourceEngine:
    """JSBSim 1.3 flying the original JSBSim aircraft of a fitted GNA set (see the module notes).

    Parameters
    ----------
    dt : float
        Largest step [s] (as :class:`harness.engines.JSBSimEngine`).
    integrators : Integrators
        JSBSim's integrators per state group.
    planet_radius_ft : float
        Radius of the flat-earth sphere [ft].
    throttle_tau : float
        Time constant [s] of the integral correction of the throttle loop.
    throttle_points : int
        Points of the steady thrust-throttle table built at the initial condition.
    root : str, optional
        JSBSim root (``aircraft/``, ``engine/``); default the jsbsim package's.
    controller_dt : float, optional
        Controller update interval [s] (as :class:`harness.engines.JSBSimEngine`); default every step.
    compensate_roundoff : bool
        Correct the position read by the round-off of JSBSim's inertial position (as
        :class:`harness.engines.JSBSimEngine`).
    """

    dt: float = 1.0 / 480.0
    integrators: Integrators = field(default_factory=Integrators)
    planet_radius_ft: float = jx.PLANET_RADIUS_FT
    throttle_tau: float = 0.05
    throttle_points: int = 41
    root: str | None = None
    controller_dt: float | None = None
    compensate_roundoff: bool = True
    name: ClassVar[str] = "jsbsim-source"

    def __post_init__(self):
        check_steps(self.dt, self.controller_dt)
        if not (math.isfinite(self.throttle_tau) and self.throttle_tau >= 2 * self.dt):
            raise InputError(f"throttle_tau must be at least two steps ({2 * self.dt:g} s), got {self.throttle_tau}")

    def simulate(
        self,
        aircraft: Aircraft,
        controls,
        t_span,
        x0=None,
        *,
        env: Environment | None = None,
        controller=None,
        dt_out: float = 0.02,
        t_eval: np.ndarray | None = None,
    ) -> SimulationResult:
        """Fly the JSBSim aircraft ``aircraft`` was fitted from, from ``x0`` with ``controls``.

        Parameters
        ----------
        aircraft : Aircraft
            A GNA set fitted from a JSBSim aircraft (its provenance names it).
        controls : callable, object with ``controls(t)``, or sequence of 5 floats
            Reference controls ``t [s] -> (F [N], eta [-], dl, dm, dn [rad])``;
            sampled at every step.  ``F`` is the thrust the throttle loop
            tracks, ``eta`` its asymmetry (ignored with one engine).
        t_span : pair of float
            ``(t0, t1)`` [s].
        x0 : array_like, shape (12,), optional
            Initial wind-frame state; default the source's ``initial_state``.
        env : Environment, optional
            Must be ISA (JSBSim's own); ``env.g`` sets the flat planet's gravity.
        controller : Controller or callable, optional
            Anything :func:`gna.controller.as_controller` takes; sampled every
            step (or every ``controller_dt``) at the propagated state, its
            states advanced by AB2 (as :class:`harness.engines.JSBSimEngine`).
        dt_out : float
            Output interval [s]; the step divides it exactly.
        t_eval : array_like, shape (n,), optional
            Output times [s], on the step grid.

        Returns
        -------
        SimulationResult
            Columns :data:`gna.trajectory.COLUMNS` (``F``, ``eta`` the delivered
            thrust and asymmetry); with a controller, ``controller_states`` and
            ``feedback``; ``settings`` a :class:`gna.trajectory.RunSettings`
            whose extra records the JSBSim version, aircraft file,
            configuration, surface mapping, thrust method and its tracking
            error, mass and planet.

        Raises
        ------
        InputError
            Aircraft not fitted from JSBSim, non-ISA atmosphere, bad span,
            state, controls, controller or grid.
        EngineError
            JSBSim refused the aircraft, the planet or the initial condition.
        """
        source_model(aircraft)
        atmosphere = environment_of(controls, env).atmosphere
        if not isinstance(atmosphere, ISA):
            raise InputError(
                f"jsbsim-source flies in JSBSim's own ISA atmosphere; got "
                f"{type(atmosphere).__name__} (use density = 'isa')"
            )
        if environment_of(controls, env).ground_effect is not None:
            raise InputError(
                "jsbsim-source flies JSBSim's own aerodynamics: gflat's ground effect cannot be "
                "applied to it (fly without ground effect, or use the 'jsbsim' engine)"
            )
        return _SourceRun.fly(
            self, aircraft, controls, t_span, x0, env=env, controller=controller, dt_out=dt_out, t_eval=t_eval
        )


class _SourceRun(JSBSimRun):
    """A run of the source aircraft: signed surfaces, thrust through its engines with the throttle loop."""

    derived_nodes = _DERIVED

    def _load(self, stack):
        self.src = source_model(self.aircraft)
        jsbsim = import_jsbsim()
        name, acdir, root = resolve(self.src.model, self.engine.root)
        capture = stack.enter_context(LogCapture(jsbsim))
        self.xml_path = acdir / f"{name}.xml"
        try:  # without its <output>/<input> directives (no file written, no socket bound), console captured
            fdm, self.console = load_model(name, acdir, root)
        except InputError as exc:
            raise EngineError(f"{exc}{' | ' + ' | '.join(capture.problems()) if capture.problems() else ''}") from None
        check_properties(  # a hand-edited provenance must not fly with a surface that moves nothing
            fdm,
            {
                **{p: f"surface {v} in the provenance" for v, (p, _) in self.src.surfaces.items()},
                **{p: "configuration in the provenance" for p in self.src.configuration},
            },
            f"JSBSim {name} ({self.aircraft.id})",
        )
        self.planet = planet = jx.FlatPlanet(
            g=self.env.g, h_ref=-float(self.x0[2]), radius_ft=self.engine.planet_radius_ft
        )
        with tempfile.TemporaryDirectory(prefix="gflat-planet-") as tmp:  # JSBSim reads the file at once
            path = Path(tmp) / "planet.xml"
            path.write_text(jx.planet_xml(planet), encoding="utf-8")
            loaded = fdm.load_planet(str(path), False)
        if not loaded:
            raise EngineError(f"JSBSim refused the flat-earth planet: {' | '.join(capture.problems())}")
        return fdm, capture, []

    def _configure(self) -> None:
        fdm, src = self.fdm, self.src
        set_stepping(fdm, self.engine.integrators, self.dt, flat=True)
        fdm["simulation/models/FGFCS/enabled"] = 0
        for prop, value in src.configuration.items():
            fdm[prop] = value
        self.ics = initial_condition_properties(self.x0)
        for prop, value in self.ics:
            fdm[prop] = value
        self.n_eng = n_eng = fdm.get_propulsion().get_num_engines()
        if n_eng not in (1, 2):
            raise EngineError(f"jsbsim-source handles 1 or 2 engines; {self.xml_path.name} has {n_eng}")
        # engine order: left to right (eta > 0 puts more thrust on the left engine, gna.aircraft.Propulsion)
        order = sorted(range(n_eng), key=lambda i: fdm[f"propulsion/engine[{i}]/y-position"])
        self.th_w = [self._node(f"fcs/throttle-pos-norm[{i}]").set_double_value for i in order]
        self.T_r = [self._node(f"propulsion/engine[{i}]/thrust-lbs").get_double_value for i in order]
        self.surf = [(self._node(src.surfaces[v][0]).set_double_value, src.surfaces[v][1]) for v in ("dl", "dm", "dn")]

    def _split(self, F: float, eta: float) -> list:
        """Per-engine thrust command [lbf]."""
        lbf = units.LBF
        return [F / lbf] if self.n_eng == 1 else [F * (1 + eta) / 2 / lbf, F * (1 - eta) / 2 / lbf]

    def _write(self, u) -> None:
        """The three surfaces with the fit's signs (the throttles are written by the thrust loop)."""
        for (w, s), v in zip(self.surf, u[2:5]):
            w(s * v)

    def _initialize(self) -> None:
        """Engines running and spun up to the initial thrust, derivatives at t0, initial condition verified."""
        self.fdm["propulsion/set-running"] = -1
        self._run_ic()
        F0 = self._split(self.applied0[0], self.applied0[1])
        self.loops, self.t_spin = self._spin_up(F0)
        self._run_ic()  # derivatives at t0 with the engines at the initial thrust
        check_initial_condition(self.fdm, self.ics, self.planet.radius_ft)
        self.thrust = np.full((self.n_eng, self.n + 1), np.nan)
        self.cmd = np.full((self.n_eng, self.n + 1), np.nan)
        self.thrust[:, 0] = [r() for r in self.T_r]
        self.cmd[:, 0] = F0
        self._throttle(0)

    def _throttle(self, k: int) -> None:
        """Throttles for the next step from the command at step ``k``."""
        self.th_now = [lp.throttle(c) for lp, c in zip(self.loops, self.cmd[:, k])]
        for w, th in zip(self.th_w, self.th_now):
            w(th)

    def _stepped(self, k: int, u) -> None:
        """The thrust loop: measured thrust, integral update, throttles for the next step."""
        self.cmd[:, k] = self._split(u[0], u[1])
        self.thrust[:, k] = [r() for r in self.T_r]
        for i, lp in enumerate(self.loops):
            lp.update(self.cmd[i, k], self.thrust[i, k], self.th_now[i])
        self._throttle(k)

    def _spin_up(self, F0_lbf):
        """Thrust-throttle tables at the initial condition, and the engines at steady state at ``F0``."""
        t = time.perf_counter()
        fdm, th_w, T_r, dt = self.fdm, self.th_w, self.T_r, self.dt
        prop = fdm.get_propulsion()

        def steady(ths):
            for w, th in zip(th_w, ths):
                w(th)
            fdm.suspend_integration()  # loads the throttle into the engine inputs without moving the state
            try:
                fdm.run()
                prop.get_steady_state()
                fdm.run()
            finally:
                fdm.resume_integration()
            return [r() for r in T_r]

        grid = np.linspace(0.0, 2.0, self.engine.throttle_points)
        table = np.array([steady([g] * len(th_w)) for g in grid]).T
        loops = [_ThrottleLoop(grid, table[i], self.engine.throttle_tau, dt) for i in range(len(th_w))]
        for lp, F in zip(loops, F0_lbf):
            if not lp.T[0] <= F <= lp.T[-1]:
                raise InputError(
                    f"initial thrust {F * units.LBF:.6g} N outside what the engine delivers at the "
                    f"initial condition ({lp.T[0] * units.LBF:.6g} .. {lp.T[-1] * units.LBF:.6g} N)"
                )
        ths = [lp.throttle(F) for lp, F in zip(loops, F0_lbf)]
        for _ in range(30):  # secant refinement on the exact steady thrust
            T = steady(ths)
            e = [F - Ti for F, Ti in zip(F0_lbf, T)]
            if max(abs(x) for x in e) < 1e-6 * max(1.0, max(abs(F) for F in F0_lbf)):
                break
            ths = [
                min(max(th + ei / float(np.interp(th, lp.th, lp.slope)), lp.th[0]), lp.th[-1])
                for th, ei, lp in zip(ths, e, loops)
            ]
        for lp, th, F in zip(loops, ths, F0_lbf):
            lp.integral = th - float(np.interp(F, lp.T, lp.th))
        steady(ths)
        return loops, time.perf_counter() - t

    def _derived(self, R: np.ndarray, S: np.ndarray) -> np.ndarray:
        """qbar, rho, the six coefficients, total and weight forces, total moments; coefficients from
        JSBSim's aero loads (stability-axis CD, CL; body CY, Cl, Cm, Cn)."""
        fdm = self.fdm
        S_ft2, b_ft, c_ft = fdm["metrics/Sw-sqft"], fdm["metrics/bw-ft"], fdm["metrics/cbarw-ft"]
        qs = R[0] * S_ft2
        with np.errstate(divide="ignore", invalid="ignore"):
            cx, cy, cz = R[2] / qs, R[3] / qs, R[4] / qs
            ca, sa = np.cos(S[6]), np.sin(S[6])
            coef = [
                -(cx * ca + cz * sa),
                cy,
                cx * sa - cz * ca,
                R[5] / (qs * b_ft),
                R[6] / (qs * c_ft),
                R[7] / (qs * b_ft),
            ]
        return np.vstack([R[0:2], np.array(coef), R[8:17]])

    def _columns(self, applied: np.ndarray, idx: np.ndarray) -> np.ndarray:
        """F and eta: the thrust the engines deliver and its asymmetry."""
        delivered = applied.copy()
        Tn = self.thrust[:, idx] * units.LBF
        delivered[0] = Tn.sum(axis=0)
        if self.n_eng == 2:
            delivered[1] = (Tn[0] - Tn[1]) / np.where(delivered[0] != 0, delivered[0], np.nan)
        return delivered

    def _describe(self):
        e, src, planet, last = self.engine, self.src, self.planet, self.index[-1]
        err = (self.cmd - self.thrust)[:, : last + 1] * units.LBF
        settle = self.times[: last + 1] >= self.times[0] + 10 * e.throttle_tau
        return "JSBSim standard atmosphere (ISA 1976)", {
            "aircraft_file": str(self.xml_path),
            "jsbsim_model": src.model,
            "surfaces": {k: f"{'-' if s < 0 else ''}{p}" for k, (p, s) in src.surfaces.items()},
            "configuration": {"simulation/models/FGFCS/enabled": 0, **src.configuration},
            "thrust": {
                "method": "the aircraft's own engines; throttle = steady thrust table at the initial "
                "condition inverted at the command + integral correction on the measured thrust",
                "throttle_tau_s": e.throttle_tau,
                "table_points": e.throttle_points,
                "spin_up": f"engine steady state at the initial thrust before t0 ({self.t_spin:.3g} s of setup)",
                "max_abs_error_N": float(np.nanmax(np.abs(err))) if err.size else 0.0,
                "max_abs_error_after_settle_N": float(np.nanmax(np.abs(err[:, settle]))) if settle.any() else None,
                "columns": "F and eta are the delivered thrust and asymmetry",
            },
            "mass": "the JSBSim aircraft's own (default fuel and point masses, fuel burning)",
            "planet": {
                "radius_ft": planet.radius_ft,
                "GM_ft3_s2": planet.GM,
                "h_ref_m": planet.h_ref,
                "rotation_rad_s": 0.0,
                "J2": 0.0,
                "gravity_model": 0,
                "loaded_with": "FGFDMExec.load_planet",
            },
        }

    def _problems(self) -> list[str]:
        return self.capture.problems()
