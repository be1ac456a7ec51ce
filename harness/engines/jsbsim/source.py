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
  controller sampling.
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
from gna.controller import as_controller
from gna.errors import InputError
from gna.fit.sources.jsbsim_aero import FittedSource, fitted_source, resolve
from gna.simulate import SimulationResult, envelope_warnings
from gna.trajectory import check_span, control_function, controls_on_grid, environment_of, initial_state

from ..base import EngineError
from . import export as jx
from .engine import StepStop
from .fdm import Integrators, LogCapture, import_jsbsim, initial_condition_properties
from .states import StateConverter, step_grid, trajectory_frame

_POS = ("position/lat-gc-rad", "position/long-gc-rad", "position/h-sl-ft")
_STATES = ("velocities/vt-fps", "flight-path/gamma-rad", "flight-path/psi-gt-rad", "aero/alpha-rad",
           "aero/beta-rad", "attitude/phi-rad", "attitude/theta-rad", "attitude/psi-rad",
           "velocities/p-rad_sec", "velocities/q-rad_sec", "velocities/r-rad_sec")
_DERIVED = ("aero/qbar-psf", "atmosphere/rho-slugs_ft3",
            "forces/fbx-aero-lbs", "forces/fby-aero-lbs", "forces/fbz-aero-lbs",
            "moments/l-aero-lbsft", "moments/m-aero-lbsft", "moments/n-aero-lbsft",
            "forces/fbx-total-lbs", "forces/fby-total-lbs", "forces/fbz-total-lbs",
            "forces/fbx-weight-lbs", "forces/fby-weight-lbs", "forces/fbz-weight-lbs",
            "moments/l-total-lbsft", "moments/m-total-lbsft", "moments/n-total-lbsft")


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
        raise InputError(f"engine jsbsim-source flies the JSBSim aircraft a GNA set was fitted from: {exc}; "
                         f"fly {aircraft.id!r} on 'inhouse' or 'jsbsim'") from None


class _ThrottleLoop:
    """Throttle = steady-thrust table inverted at the command + integral correction on the measured thrust."""

    def __init__(self, table_th: np.ndarray, table_T: np.ndarray, tau: float, dt: float):
        keep = np.concatenate([[True], np.diff(np.maximum.accumulate(table_T)) > 0])  # increasing part
        self.th, self.T = table_th[keep], table_T[keep]
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
    planet_radius_ft : float
        Radius of the flat-earth sphere [ft].
    throttle_tau : float
        Time constant [s] of the integral correction of the throttle loop.
    throttle_points : int
        Points of the steady thrust-throttle table built at the initial condition.
    root : str, optional
        JSBSim root (``aircraft/``, ``engine/``); default the jsbsim package's.
    """

    dt: float = 1.0 / 480.0
    integrators: Integrators = field(default_factory=Integrators)
    planet_radius_ft: float = jx.PLANET_RADIUS_FT
    throttle_tau: float = 0.05
    throttle_points: int = 41
    root: str | None = None
    name: ClassVar[str] = "jsbsim-source"

    def __post_init__(self):
        if not (math.isfinite(self.dt) and self.dt > 0):
            raise InputError(f"JSBSim step dt must be positive, got {self.dt}")
        if not (math.isfinite(self.throttle_tau) and self.throttle_tau >= 2 * self.dt):
            raise InputError(f"throttle_tau must be at least two steps ({2 * self.dt:g} s), got {self.throttle_tau}")

    def simulate(self, aircraft: Aircraft, controls, t_span, x0=None, *, env: Environment | None = None,
                 controller=None, dt_out: float = 0.02, t_eval: np.ndarray | None = None) -> SimulationResult:
        """Fly the JSBSim aircraft ``aircraft`` was fitted from, from ``x0`` with ``controls``.

        Parameters
        ----------
        aircraft : Aircraft
            A GNA set fitted from a JSBSim aircraft (its provenance names it).
        controls : control source
            Callable ``t -> (F, eta, dl, dm, dn)``, a plan with ``controls(t)``,
            or 5 constants; sampled at every step.  ``F`` [N] is the thrust the
            throttle loop tracks, ``eta`` its asymmetry (ignored with one engine).
        t_span : (t0, t1)
        x0 : array of 12, optional
            Initial wind-frame state; default the source's ``initial_state``.
        env : Environment, optional
            Must be ISA (JSBSim's own); ``env.g`` sets the flat planet's gravity.
        controller : Controller or callable ``(t, x) -> 5 corrections``, optional
            Sampled at every step without delay; controller states advanced by
            explicit trapezoidal (Heun) steps.
        dt_out, t_eval
            Output grid (on the step grid).

        Returns
        -------
        gna.simulate.SimulationResult
            Columns :data:`gna.trajectory.COLUMNS`; ``settings`` records the
            JSBSim version, aircraft file, configuration, surface mapping,
            thrust method and its tracking error, step, integrators and planet.

        Raises
        ------
        InputError
            Aircraft not fitted from JSBSim, non-ISA atmosphere, bad span,
            state, controls or grid.
        EngineError
            JSBSim refused the aircraft, the planet or the initial condition.
        """
        src = source_model(aircraft)
        env = environment_of(controls, env)
        if not isinstance(env.atmosphere, ISA):
            raise InputError(f"jsbsim-source flies in JSBSim's own ISA atmosphere; got "
                             f"{type(env.atmosphere).__name__} (use density = 'isa')")
        y0 = initial_state(controls, x0)
        t0, t1 = check_span(t_span)
        n, dt, out_steps = step_grid(t0, t1, self.dt, dt_out, t_eval)
        times = t0 + np.arange(n + 1) * dt
        U = controls_on_grid(control_function(controls), times)
        ctl = as_controller(controller)
        t_setup = time.perf_counter()
        jsbsim = import_jsbsim()
        name, acdir, root = resolve(src.model, self.root)
        capture = LogCapture(jsbsim)
        with capture, tempfile.TemporaryDirectory(prefix="gflat-planet-") as tmp:
            fdm = jsbsim.FGFDMExec(str(root))
            fdm.set_debug_level(0)
            if not fdm.load_model_with_paths(name, str(acdir.parent), str(root / "engine"), str(root / "systems")):
                raise EngineError(f"JSBSim could not load {acdir / (name + '.xml')}: "
                                  f"{' | '.join(capture.problems()) or 'load_model returned False'}")
            planet = jx.FlatPlanet(g=env.g, h_ref=-float(y0[2]), radius_ft=self.planet_radius_ft)
            path = Path(tmp) / "planet.xml"
            r = repr(float(planet.radius_ft))
            path.write_text(f'<?xml version="1.0"?>\n<planet name="gflat flat earth">'
                            f'<semimajor_axis unit="FT">{r}</semimajor_axis><semiminor_axis unit="FT">{r}'
                            f'</semiminor_axis><rotation_rate unit="RAD/SEC">0</rotation_rate>'
                            f'<GM unit="FT3/SEC2">{planet.GM!r}</GM><J2>0</J2></planet>\n', encoding="utf-8")
            if not fdm.load_planet(str(path), False):
                raise EngineError(f"JSBSim refused the flat-earth planet: {' | '.join(capture.problems())}")
            return self._run(fdm, capture, src, acdir / f"{name}.xml", aircraft, env, planet, y0, t0, t1, n, dt,
                             out_steps, times, U, ctl, t_setup)

    def _run(self, fdm, capture, src, xml_path, aircraft, env, planet, y0, t0, t1, n, dt, out_steps, times, U,
             ctl, t_setup) -> SimulationResult:
        fdm["simulation/gravity-model"] = 0
        fdm["simulation/models/FGFCS/enabled"] = 0
        for prop, code in self.integrators.properties().items():
            fdm[prop] = code
        fdm.set_dt(dt)
        for prop, value in src.configuration.items():
            fdm[prop] = value
        ics = initial_condition_properties(y0)
        for prop, value in ics:
            fdm[prop] = value
        pm = fdm.get_property_manager()

        def node(nm):
            nd = pm.get_node(nm, False)
            if nd is None:
                raise EngineError(f"JSBSim property {nm!r} does not exist in {xml_path.name}")
            return nd

        n_eng = fdm.get_propulsion().get_num_engines()
        if n_eng not in (1, 2):
            raise EngineError(f"jsbsim-source handles 1 or 2 engines; {xml_path.name} has {n_eng}")
        # engine order: left to right (eta > 0 puts more thrust on the left engine, gna.aircraft.Propulsion)
        order = sorted(range(n_eng), key=lambda i: fdm[f"propulsion/engine[{i}]/y-position"])
        th_w = [node(f"fcs/throttle-pos-norm[{i}]").set_double_value for i in order]
        T_r = [node(f"propulsion/engine[{i}]/thrust-lbs").get_double_value for i in order]
        surf = [(node(src.surfaces[v][0]).set_double_value, src.surfaces[v][1]) for v in ("dl", "dm", "dn")]
        lbf = units.LBF

        def split(F, eta):  # per-engine thrust command [lbf]
            return [F / lbf] if n_eng == 1 else [F * (1 + eta) / 2 / lbf, F * (1 - eta) / 2 / lbf]

        def write_surfaces(u):
            for (w, s), v in zip(surf, u[2:5]):
                w(s * v)

        xc = ctl.initial_state(t0, y0.copy()) if ctl is not None else None
        applied = U.copy()
        if ctl is not None:
            applied[:, 0] = U[:, 0] + ctl.output(t0, y0.copy(), xc)
        if not np.all(np.isfinite(applied[:, 0])):
            raise InputError(f"controls at t0 = {t0:g} s are not finite ({applied[:, 0].tolist()})")
        write_surfaces(applied[:, 0])
        fdm["propulsion/set-running"] = -1
        fdm.set_sim_time(t0)
        self._run_ic(fdm, capture, aircraft)
        loops, t_spin = self._spin_up(fdm, th_w, T_r, split(applied[0, 0], applied[1, 0]), dt)
        self._run_ic(fdm, capture, aircraft)  # derivatives at t0 with the engines at the initial thrust
        for prop, value in ics:
            got, tol = fdm[prop], 1e-9 * max(1.0, abs(value)) + (8 * np.spacing(planet.radius_ft) if "h-sl" in prop
                                                                   else 0.0)
            if not abs(math.remainder(got - value, 2 * math.pi) if prop.endswith("-rad") else got - value) <= tol:
                raise EngineError(f"JSBSim did not accept the initial condition {prop} = {value!r} (reads {got!r})")

        st_r = [node(p).get_double_value for p in _POS + _STATES]
        de_r = [node(p).get_double_value for p in _DERIVED]
        vt = node("velocities/vt-fps").get_double_value
        to_state = StateConverter(y0, fdm["inertial/sea-level-radius_ft"], None)
        out = np.zeros(n + 1, dtype=bool)
        out[out_steps] = True
        raw_s, raw_d, idx = [[r() for r in st_r]], [[r() for r in de_r]], [0]
        thrust = np.full((n_eng, n + 1), np.nan)
        thrust[:, 0] = [r() for r in T_r]
        cmd = np.full((n_eng, n + 1), np.nan)
        cmd[:, 0] = split(applied[0, 0], applied[1, 0])
        ths = [lp.throttle(c) for lp, c in zip(loops, cmd[:, 0])]
        f_prev = ctl.derivative(t0, y0.copy(), xc) if ctl is not None and ctl.n_states else None
        xc_pred = xc + dt * f_prev if f_prev is not None else xc
        status, message, t_end, k = "completed", "", t1, 0
        t_loop = time.perf_counter()
        try:
            for k in range(1, n + 1):
                for w, th in zip(th_w, ths):
                    w(th)
                if ctl is None:
                    uk = U[:, k]
                    if not np.all(np.isfinite(uk)):
                        raise StepStop.control(k, uk)
                    write_surfaces(uk)
                    if not fdm.run():
                        raise StepStop(k, "JSBSim asked to stop (run() returned false) at t = {t}")
                else:
                    if not fdm.run():
                        raise StepStop(k, "JSBSim asked to stop (run() returned false) at t = {t}")
                    xk = to_state.scalar([r() for r in st_r])
                    if f_prev is not None:  # Heun corrector with the propagated state
                        xc = xc + 0.5 * dt * (f_prev + ctl.derivative(times[k], xk, xc_pred))
                    uk = U[:, k] + ctl.output(times[k], xk, xc)
                    if not np.all(np.isfinite(uk)):
                        raise StepStop.control(k, uk)
                    applied[:, k] = uk
                    write_surfaces(uk)
                    fdm.suspend_integration()
                    try:
                        fdm.run()
                    finally:
                        fdm.resume_integration()
                    if f_prev is not None:
                        f_prev = ctl.derivative(times[k], xk, xc)
                        xc_pred = xc + dt * f_prev
                v = vt()
                if not (0.0 < v < math.inf):
                    raise StepStop(k, f"JSBSim diverged at t = {{t}}: airspeed V = {v * units.FT:.6g} m/s")
                cmd[:, k] = split(applied[0, k], applied[1, k])
                thrust[:, k] = [r() for r in T_r]
                for i, lp in enumerate(loops):
                    lp.update(cmd[i, k], thrust[i, k], ths[i])
                ths = [lp.throttle(c) for lp, c in zip(loops, cmd[:, k])]
                if out[k]:
                    raw_s.append([r() for r in st_r])
                    raw_d.append([r() for r in de_r])
                    idx.append(k)
        except StepStop as stop:
            status, t_end = "domain", float(times[idx[-1]])
            message = stop.text.format(t=f"{times[stop.k]:.6g} s") + f"; result kept up to t = {t_end:.6g} s"
        except import_jsbsim().BaseError as exc:
            status, t_end = "domain", float(times[idx[-1]])
            message = (f"JSBSim stopped at t = {times[k]:.6g} s with {type(exc).__name__}: {exc}; "
                       f"result kept up to t = {t_end:.6g} s")
        t_post = time.perf_counter()
        ix = np.asarray(idx)
        S = to_state.vector(np.array(raw_s, dtype=float).T)
        D = self._derived(fdm, np.array(raw_d, dtype=float).T, S)
        delivered = applied[:, ix].copy()
        Tn = thrust[:, ix] * lbf
        delivered[0] = Tn.sum(axis=0)
        if n_eng == 2:
            delivered[1] = (Tn[0] - Tn[1]) / np.where(delivered[0] != 0, delivered[0], np.nan)
        df = trajectory_frame(aircraft, env, times[ix], S, delivered, D)
        err = (cmd - thrust)[:, : (idx[-1] + 1)] * lbf
        settle = times[: idx[-1] + 1] >= t0 + 10 * self.throttle_tau
        settings = {
            "engine": self.name, "jsbsim_version": import_jsbsim().__version__, "aircraft_file": str(xml_path),
            "jsbsim_model": src.model, "surfaces": {k: f"{'-' if s < 0 else ''}{p}" for k, (p, s) in
                                                    src.surfaces.items()},
            "configuration": {"simulation/models/FGFCS/enabled": 0, **src.configuration},
            "thrust": {"method": "the aircraft's own engines; throttle = steady thrust table at the initial "
                                 "condition inverted at the command + integral correction on the measured thrust",
                       "throttle_tau_s": self.throttle_tau, "table_points": self.throttle_points,
                       "spin_up": f"engine steady state at the initial thrust before t0 ({t_spin:.3g} s of setup)",
                       "max_abs_error_N": float(np.nanmax(np.abs(err))) if err.size else 0.0,
                       "max_abs_error_after_settle_N": float(np.nanmax(np.abs(err[:, settle])))
                       if settle.any() else None,
                       "columns": "F and eta are the delivered thrust and asymmetry"},
            "mass": "the JSBSim aircraft's own (default fuel and point masses, fuel burning)",
            "dt": dt, "dt_max": self.dt, "steps": n, "integrators": self.integrators.as_dict(),
            "planet": {"radius_ft": planet.radius_ft, "GM_ft3_s2": planet.GM, "h_ref_m": planet.h_ref,
                       "rotation_rad_s": 0.0, "J2": 0.0, "gravity_model": 0, "loaded_with": "FGFDMExec.load_planet"},
            "environment": "JSBSim standard atmosphere (ISA 1976)", "g": env.g,
            "control_timing": "u(t_k) written before the run() reaching t_k; u(t0) before run_ic()",
            "controller": None if ctl is None else {"sampling": "every step at the propagated state",
                                                   "n_states": int(ctl.n_states),
                                                   "states_integrator": "explicit trapezoidal (Heun)"},
            "wall_time_s": {"setup": t_loop - t_setup, "stepping": t_post - t_loop},
        }
        warnings = envelope_warnings(aircraft, df) + [f"JSBSim: {p}" for p in capture.problems()]
        return SimulationResult(df=df, status=status, message=message, warnings=warnings, settings=settings,
                                t_end=t_end)

    @staticmethod
    def _run_ic(fdm, capture, aircraft):
        try:
            ok = fdm.run_ic()
        except Exception as exc:  # JSBSim raises its own exception types
            raise EngineError(f"JSBSim run_ic failed for {aircraft.id}: {exc}") from None
        if not ok:
            raise EngineError(f"JSBSim run_ic failed for {aircraft.id}: {' | '.join(capture.problems())}")

    def _spin_up(self, fdm, th_w, T_r, F0_lbf, dt):
        """Thrust-throttle tables at the initial condition, and the engines at steady state at ``F0``."""
        t = time.perf_counter()
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

        grid = np.linspace(0.0, 2.0, self.throttle_points)
        table = np.array([steady([g] * len(th_w)) for g in grid]).T
        loops = [_ThrottleLoop(grid, table[i], self.throttle_tau, dt) for i in range(len(th_w))]
        for lp, F in zip(loops, F0_lbf):
            if not lp.T[0] <= F <= lp.T[-1]:
                raise InputError(f"initial thrust {F * units.LBF:.6g} N outside what the engine delivers at the "
                                 f"initial condition ({lp.T[0] * units.LBF:.6g} .. {lp.T[-1] * units.LBF:.6g} N)")
        ths = [lp.throttle(F) for lp, F in zip(loops, F0_lbf)]
        for _ in range(30):  # secant refinement on the exact steady thrust
            T = steady(ths)
            e = [F - Ti for F, Ti in zip(F0_lbf, T)]
            if max(abs(x) for x in e) < 1e-6 * max(1.0, max(abs(F) for F in F0_lbf)):
                break
            ths = [min(max(th + ei / float(np.interp(th, lp.th, lp.slope)), lp.th[0]), lp.th[-1])
                   for th, ei, lp in zip(ths, e, loops)]
        for lp, th, F in zip(loops, ths, F0_lbf):
            lp.integral = th - float(np.interp(F, lp.T, lp.th))
        steady(ths)
        return loops, time.perf_counter() - t

    @staticmethod
    def _derived(fdm, R: np.ndarray, S: np.ndarray) -> np.ndarray:
        """Rows for :func:`harness.engines.jsbsim.states.trajectory_frame`: qbar, rho, the six coefficients, total and weight forces,
        total moments; coefficients from JSBSim's aero loads (stability-axis CD, CL; body CY, Cl, Cm, Cn)."""
        S_ft2, b_ft, c_ft = fdm["metrics/Sw-sqft"], fdm["metrics/bw-ft"], fdm["metrics/cbarw-ft"]
        qs = R[0] * S_ft2
        with np.errstate(divide="ignore", invalid="ignore"):
            cx, cy, cz = R[2] / qs, R[3] / qs, R[4] / qs
            ca, sa = np.cos(S[6]), np.sin(S[6])
            coef = [-(cx * ca + cz * sa), cy, cx * sa - cz * ca, R[5] / (qs * b_ft), R[6] / (qs * c_ft),
                    R[7] / (qs * b_ft)]
        return np.vstack([R[0:2], np.array(coef), R[8:17]])
