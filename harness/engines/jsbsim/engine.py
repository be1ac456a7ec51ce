"""The JSBSim engine: the exported aircraft flown step by step, with an optional sampled controller.

:class:`JSBSimEngine` sets the problem on JSBSim's step grid; :class:`_Run`
(the run context) holds the FDM, its cached property nodes and the records of
one run, and steps it open loop or with a controller.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from gna import units
from gna.aircraft import Aircraft
from gna.atmosphere import Environment
from gna.controller import Controller, as_controller, state_names
from gna.eom import CONTROL_NAMES
from gna.errors import InputError
from gna.simulate import envelope_warnings
from gna.trajectory import (RunSettings, SimulationResult, check_span, control_function, controller_frames,
                            controls_on_grid, environment_of, initial_state)

from ..base import EngineError
from . import export as jx
from .fdm import Integrators, import_jsbsim, load_fdm, prepare, property_node
from .states import (DERIVED_NODES, STATE_NODES, STATE_NODES_FLAT, STATE_NODES_WGS84, StateConverter,
                     step_grid, trajectory_frame)

#: How the JSBSim engine advances a controller's states (recorded in the result's settings).
CONTROLLER_SCHEME = ("AB2 (two-step Adams-Bashforth, Euler first step) on the sampled aircraft states, "
                     "second order in the controller step")


@dataclass(frozen=True)
class JSBSimEngine:
    """JSBSim 1.3 flying the exported aircraft file.

    Parameters
    ----------
    dt : float
        Largest step [s]; the step used divides the output interval exactly
        and is recorded in ``settings["dt"]``.
    integrators : Integrators
        JSBSim's integrators per state group.
    earth : {"flat", "wgs84"}
        ``"flat"``: the file's flat-earth planet (non-rotating sphere of radius
        ``planet_radius_ft``, no J2, ``GM`` giving ``env.g`` exactly at the
        initial altitude) and ``simulation/gravity-model`` 0.  ``"wgs84"``:
        no planet element, JSBSim's default rotating WGS84 Earth with J2
        gravity, starting at (``latitude``, ``longitude``): shows what the
        flat-earth assumption costs.
    planet_radius_ft : float
        Radius of the flat planet [ft].
    latitude, longitude : float
        Initial position on the WGS84 Earth [rad] (ignored on the flat earth).
    controller_dt : float, optional
        Controller update interval [s], rounded to a whole number of steps
        (the value used is recorded in ``settings.controller_dt``); default
        every step.  The feedback is held between updates.

    Notes
    -----
    Control timing (``docs/jsbsim.md``): JSBSim's ``run()`` first integrates
    with the derivatives of the previous frame, then evaluates the models at
    the new state.  So ``u(t_k)`` is written before the ``run()`` that reaches
    ``t_k`` and ``u(t0)`` before ``run_ic()``: JSBSim samples the controls at
    every step.  With a controller, each update step runs, reads the
    propagated state ``x_k``, advances the controller states to ``t_k``,
    computes ``controller.output(t_k, x_k, xc_k)``, writes the corrected
    controls and re-evaluates the derivatives at ``x_k`` with the integration
    suspended (which leaves the state and the integrators' history
    untouched): the feedback is sampled without delay.  Between updates the
    reference controls are sampled every step and the feedback is held.

    The controller states are advanced on the controller grid ``h_c`` by the
    two-step Adams-Bashforth scheme ``xc_{j+1} = xc_j + h_c (3/2 f_j - 1/2
    f_{j-1})`` with ``f_j = controller.derivative(t_j, x_j, xc_j)`` (an Euler
    first step): explicit, one derivative per update, second order in ``h_c``
    (:data:`CONTROLLER_SCHEME`).

    Positions are read as latitude, longitude and altitude and mapped to the
    NED plane of the initial point: ``x = x0 + (R + h) lat``,
    ``y = y0 + (R + h) cos(lat) lon`` (spherical arcs, so that level flight on
    the huge sphere is level in NED), ``z = -h``.  On the WGS84 Earth the
    meridian and normal radii of curvature at the initial latitude are used.
    ``chi`` and ``mu`` are unwrapped and start at ``x0``'s values.
    """

    dt: float = 1.0 / 480.0
    integrators: Integrators = field(default_factory=Integrators)
    earth: str = "flat"
    planet_radius_ft: float = jx.PLANET_RADIUS_FT
    latitude: float = 0.0
    longitude: float = 0.0
    controller_dt: float | None = None

    def __post_init__(self):
        if not (math.isfinite(self.dt) and self.dt > 0):
            raise InputError(f"JSBSim step dt must be positive, got {self.dt}")
        if self.earth not in ("flat", "wgs84"):
            raise InputError(f"earth must be 'flat' or 'wgs84', got {self.earth!r}")
        if not (abs(self.latitude) < math.pi / 2 and math.isfinite(self.longitude)):
            raise InputError(f"bad initial latitude/longitude ({self.latitude}, {self.longitude}) rad")
        if self.controller_dt is not None and not (math.isfinite(self.controller_dt) and self.controller_dt > 0):
            raise InputError(f"controller_dt must be positive, got {self.controller_dt}")

    @property
    def name(self) -> str:
        """Registry name: ``"jsbsim"`` on the flat earth, ``"jsbsim-wgs84"`` on JSBSim's rotating Earth."""
        return "jsbsim" if self.earth == "flat" else "jsbsim-wgs84"

    def xml(self, aircraft: Aircraft, env: Environment, x0: np.ndarray) -> str:
        """The aircraft file this engine flies from ``x0`` (the flat planet's g is exact at ``-z0``).

        Parameters
        ----------
        aircraft : Aircraft
            The aircraft to export.
        env : Environment
            Its g sets the flat planet's GM.
        x0 : ndarray, shape (12,)
            Initial state; ``-x0[2]`` is the planet's reference altitude [m].

        Returns
        -------
        str
            The JSBSim aircraft file.
        """
        planet = (jx.FlatPlanet(g=env.g, h_ref=-float(x0[2]), radius_ft=self.planet_radius_ft)
                  if self.earth == "flat" else None)
        return jx.aircraft_xml(aircraft, planet)

    def simulate(self, aircraft: Aircraft, controls, t_span, x0=None, *, env: Environment | None = None,
                 controller=None, dt_out: float = 0.02, t_eval: np.ndarray | None = None) -> SimulationResult:
        """Fly ``aircraft`` in JSBSim from ``x0`` with the control source ``controls``.

        Parameters
        ----------
        aircraft : Aircraft
            Exported on the fly (:func:`harness.engines.jsbsim.export.aircraft_xml`),
            so variants built in memory fly too.
        controls : callable, object with ``controls(t)``, or sequence of 5 floats
            Reference controls ``t [s] -> (F [N], eta [-], dl, dm, dn [rad])``,
            a plan, or 5 constants; sampled at every JSBSim step.
        t_span : pair of float
            ``(t0, t1)`` [s].
        x0 : array_like, shape (12,), optional
            Initial wind-frame state; default the source's ``initial_state``.
        env : Environment, optional
            ISA or constant density, and g; default the source's ``env``, else the ISA.
        controller : Controller or callable, optional
            Anything :func:`gna.controller.as_controller` takes; sampled at the
            controller updates (see the class notes).
        dt_out : float
            Output interval [s]; the step divides it exactly.
        t_eval : array_like, shape (n,), optional
            Output times [s], on the step grid (a uniform grid always is).

        Returns
        -------
        SimulationResult
            Same columns as the in-house engine; ``settings`` records the step,
            integrators, planet, environment, controller scheme and rate, and
            timing.  A divergence (non-finite or vanishing airspeed, JSBSim
            stopping, non-finite controls or controller states) ends the run
            with ``status == "domain"``, a message naming the time, variable
            and value, and the outputs up to then.

        Raises
        ------
        InputError
            Bad span, state, controls at t0, controller, step grid or atmosphere model.
        EngineError
            JSBSim refused the file or an initial condition.
        """
        env = environment_of(controls, env)
        y0 = initial_state(controls, x0)
        t0, t1 = check_span(t_span)
        ufun = control_function(controls)
        ctrl = as_controller(controller)
        n, dt, out_steps = step_grid(t0, t1, self.dt, dt_out, t_eval)
        times = t0 + np.arange(n + 1) * dt
        U = controls_on_grid(ufun, times)
        every = 1 if self.controller_dt is None else max(int(round(self.controller_dt / dt)), 1)

        t_setup = time.perf_counter()
        fdm, load_problems, capture = load_fdm(self.xml(aircraft, env, y0), aircraft.id)
        with capture:
            run = _Run(self, fdm, capture, aircraft, env, y0, times, out_steps, U, ctrl, every)
            run.start()
            t_loop = time.perf_counter()
            status, message, t_end = run.step_all()
            t_post = time.perf_counter()
            return run.result(status, message, t_end, load_problems,
                              {"setup": t_loop - t_setup, "stepping": t_post - t_loop})


class StepStop(Exception):
    """The run leaves the domain at step ``k``: ``text`` names the variable and value."""

    def __init__(self, k: int, text: str):
        self.k, self.text = k, text

    @staticmethod
    def control(k: int, u) -> StepStop:
        bad = [f"{n} = {v}" for n, v in zip(CONTROL_NAMES, u) if not math.isfinite(v)]
        return StepStop(k, f"non-finite control at t = {{t}} ({', '.join(bad)})")


class _Run:
    """One JSBSim run: the problem on the step grid, the FDM with its cached nodes, and the records."""

    def __init__(self, engine: JSBSimEngine, fdm, capture, aircraft: Aircraft, env: Environment, x0: np.ndarray,
                 times: np.ndarray, out_steps: np.ndarray, U: np.ndarray, controller: Controller | None,
                 every: int):
        self.engine, self.fdm, self.capture = engine, fdm, capture
        self.aircraft, self.env, self.x0 = aircraft, env, x0
        self.times, self.U, self.n = times, U, times.size - 1
        self.out = np.zeros(self.n + 1, dtype=bool)
        self.out[out_steps] = True
        self.controller, self.every = controller, every
        self.names = state_names(controller)
        self.wgs84 = engine.earth == "wgs84"
        self.pos_nodes = STATE_NODES_WGS84 if self.wgs84 else STATE_NODES_FLAT
        # Records at the output steps: raw states, raw derived outputs, feedback and controller states.
        self.raw_states, self.raw_derived, self.index, self.fb, self.xcs = [], [], [], [], []
        self.k = 0

    # ---- setup -----------------------------------------------------------------------------------
    def start(self) -> None:
        """Settings, initial condition, u(t0) written, ``run_ic``, first record."""
        e, fdm = self.engine, self.fdm
        prepare(fdm, e.integrators, float(self.times[1] - self.times[0]), self.env, self.x0, wgs84=self.wgs84,
                latitude=e.latitude, longitude=e.longitude, planet_radius_ft=e.planet_radius_ft)
        node = lambda name: property_node(fdm, name)  # noqa: E731
        self.writers = [node(p).set_double_value for p in (*jx.THRUST_PROPERTIES, *jx.CONTROL_PROPERTIES.values())]
        self.state_readers = [node(p).get_double_value for p in self.pos_nodes + STATE_NODES]
        self.derived_readers = [node(p).get_double_value for p in DERIVED_NODES]
        self.vt = node("velocities/vt-fps").get_double_value
        geo = (e.latitude, e.longitude) if self.wgs84 else None
        self.to_state = StateConverter(self.x0, fdm["inertial/sea-level-radius_ft"], geo)

        t0, u0 = float(self.times[0]), self.U[:, 0]
        self.d = [0.0] * 5
        self.xc = np.zeros(0)
        if self.controller is not None:
            nc = int(self.controller.n_states)
            self.xc = np.asarray(self.controller.initial_state(t0, self.x0.copy()), dtype=float).reshape(-1)
            if self.xc.shape != (nc,) or not np.all(np.isfinite(self.xc)):
                raise InputError(f"the controller's initial state must be {nc} finite values, got {self.xc}")
            self.d = self._output(t0, self.x0.copy())
            self.f_prev = self._derivative(t0, self.x0.copy())
            self.f_prev2 = None
        applied = [a + b for a, b in zip(u0.tolist(), self.d)]
        if not all(math.isfinite(v) for v in applied):
            names = [f"{c} = {v}" for c, v in zip(CONTROL_NAMES, applied) if not math.isfinite(v)]
            raise InputError(f"controls at t0 = {t0:g} s are not finite ({', '.join(names)})")
        self._write(applied)
        fdm.set_sim_time(t0)
        try:
            ok = fdm.run_ic()
        except Exception as exc:  # JSBSim raises its own exception types
            raise EngineError(f"JSBSim run_ic failed for {self.aircraft.id}: {exc}") from None
        if not ok:
            raise EngineError(f"JSBSim run_ic failed for {self.aircraft.id}: {' | '.join(self.capture.problems())}")
        if self.out[0]:
            self._record(0)

    def _output(self, t: float, x: np.ndarray) -> list:
        return np.asarray(self.controller.output(t, x, self.xc), dtype=float).reshape(5).tolist()

    def _derivative(self, t: float, x: np.ndarray):
        if not self.names:
            return None
        return np.asarray(self.controller.derivative(t, x, self.xc), dtype=float).reshape(len(self.names))

    def _write(self, u) -> None:
        """Thrusts of engines 1, 2 [lbf] from (F, eta), and the three surfaces [rad]."""
        w, lbf = self.writers, units.LBF
        F, eta = u[0], u[1]
        w[0](F * (1.0 + eta) * 0.5 / lbf)
        w[1](F * (1.0 - eta) * 0.5 / lbf)
        w[2](u[2])
        w[3](u[3])
        w[4](u[4])

    def _record(self, k: int) -> None:
        self.raw_states.append([r() for r in self.state_readers])
        self.raw_derived.append([r() for r in self.derived_readers])
        self.index.append(k)
        self.fb.append(self.d)
        self.xcs.append(self.xc)

    # ---- stepping --------------------------------------------------------------------------------
    def step_all(self) -> tuple[str, str, float]:
        """Step to the end or to the first divergence: ``(status, message, t_end)``."""
        times = self.times
        try:
            if self.controller is None:
                self._open_loop()
            else:
                self._closed_loop()
        except StepStop as stop:
            t_end = float(times[self.index[-1]]) if self.index else float(times[0])
            message = stop.text.format(t=f"{times[stop.k]:.6g} s") + f"; result kept up to t = {t_end:.6g} s"
            return "domain", message, t_end
        except import_jsbsim().BaseError as exc:  # JSBSim's own exceptions (e.g. geographic errors on divergence)
            t_end = float(times[self.index[-1]]) if self.index else float(times[0])
            return "domain", (f"JSBSim stopped at t = {times[self.k]:.6g} s with {type(exc).__name__}: {exc}; "
                              f"result kept up to t = {t_end:.6g} s"), t_end
        return "completed", "", float(times[-1])

    def _check_run(self, ok: bool, k: int) -> None:
        if not ok:
            raise StepStop(k, "JSBSim asked to stop (run() returned false) at t = {t}")
        v = self.vt()
        if not (0.0 < v < math.inf):
            raise StepStop(k, f"JSBSim diverged at t = {{t}}: airspeed V = {v * units.FT:.6g} m/s")

    def _open_loop(self) -> None:
        """Reference controls precomputed on the step grid (engine thrusts in lbf)."""
        U, lbf = self.U, units.LBF
        F1 = (U[0] * (1.0 + U[1]) * 0.5 / lbf).tolist()
        F2 = (U[0] * (1.0 - U[1]) * 0.5 / lbf).tolist()
        DL, DM, DN = U[2].tolist(), U[3].tolist(), U[4].tolist()
        bad = ~np.all(np.isfinite(U), axis=0)
        k_bad = int(np.argmax(bad)) if bad.any() else self.n + 1
        w0, w1, w2, w3, w4 = self.writers
        run, check, out = self.fdm.run, self._check_run, self.out.tolist()
        for k in range(1, self.n + 1):
            self.k = k
            if k >= k_bad:
                raise StepStop.control(k, U[:, k])
            w0(F1[k]); w1(F2[k]); w2(DL[k]); w3(DM[k]); w4(DN[k])  # noqa: E702
            check(run(), k)
            if out[k]:
                self._record(k)

    def _closed_loop(self) -> None:
        """Feedback sampled at every ``every``-th step without delay, held in between; AB2 on the states."""
        fdm, ctrl, every = self.fdm, self.controller, self.every
        hc = every * float(self.times[1] - self.times[0])
        a1, a2 = 1.5 * hc, 0.5 * hc
        ucols, tlist, out = self.U.T.tolist(), self.times.tolist(), self.out.tolist()
        run, check, write, isfinite = fdm.run, self._check_run, self._write, math.isfinite
        readers, scalar = self.state_readers, self.to_state.scalar
        stateful = bool(self.names)
        bad = ~np.all(np.isfinite(self.U), axis=0)
        k_bad = int(np.argmax(bad)) if bad.any() else self.n + 1
        for k in range(1, self.n + 1):
            self.k = k
            if k % every:
                if k >= k_bad:
                    raise StepStop.control(k, ucols[k])
                write([a + b for a, b in zip(ucols[k], self.d)])
                check(run(), k)
            else:
                check(run(), k)
                xk = scalar([r() for r in readers])
                if stateful:
                    f1, f2 = self.f_prev, self.f_prev2
                    self.xc = self.xc + (hc * f1 if f2 is None else a1 * f1 - a2 * f2)
                    if not np.all(np.isfinite(self.xc)):
                        bad = ", ".join(f"{n} = {v}" for n, v in zip(self.names, self.xc) if not isfinite(v))
                        raise StepStop(k, f"non-finite controller state at t = {{t}} ({bad})")
                self.d = np.asarray(ctrl.output(tlist[k], xk, self.xc), dtype=float).reshape(5).tolist()
                uk = [a + b for a, b in zip(ucols[k], self.d)]
                if not all(isfinite(c) for c in uk):
                    raise StepStop.control(k, uk)
                write(uk)
                fdm.suspend_integration()
                try:
                    run()
                finally:
                    fdm.resume_integration()
                if stateful:
                    self.f_prev2, self.f_prev = self.f_prev, self._derivative(tlist[k], xk)
            if out[k]:
                self._record(k)

    # ---- result ----------------------------------------------------------------------------------
    def result(self, status: str, message: str, t_end: float, load_problems: list,
               wall: dict) -> SimulationResult:
        """Convert the records to the common result (states, applied controls, settings)."""
        t_post = time.perf_counter()
        e, env, aircraft, x0 = self.engine, self.env, self.aircraft, self.x0
        idx = np.asarray(self.index, dtype=int)
        S = self.to_state.vector(np.array(self.raw_states, dtype=float).T.reshape(
            len(self.pos_nodes) + len(STATE_NODES), -1))
        D = np.array(self.raw_derived, dtype=float).T.reshape(len(DERIVED_NODES), -1)
        dU = np.array(self.fb, dtype=float).T.reshape(5, -1)
        applied = self.U[:, idx] + dU if self.controller is not None else self.U[:, idx]
        t = self.times[idx]
        df = trajectory_frame(aircraft, env, t, S, applied, D)
        warnings = envelope_warnings(aircraft, df) + [f"JSBSim: {p}" for p in load_problems]
        near = np.abs(df["gamma"].to_numpy()) > 0.5 * math.pi - 1e-3
        if near.any():
            warnings.append(f"the flight path came within 1e-3 rad of vertical at t = {df.index[near.argmax()]:.4g} s: "
                            f"the wind-frame chart is singular there (chi and mu are ill-defined; the in-house "
                            f"engine stops)")
        dt = float(self.times[1] - self.times[0])
        planet = ({"radius_ft": e.planet_radius_ft, "h_ref_m": -float(x0[2]), "rotation_rad_s": 0.0, "J2": 0.0,
                   "GM_ft3_s2": jx.FlatPlanet(env.g, -float(x0[2]), e.planet_radius_ft).GM, "gravity_model": 0}
                  if not self.wgs84 else {"model": "JSBSim default WGS84, rotating, J2 gravity",
                                          "latitude_rad": e.latitude, "longitude_rad": e.longitude})
        ctrl = self.controller
        if ctrl is None:
            how = None
        elif self.every == 1:
            how = "sampled every step at the propagated state"
        else:
            how = (f"sampled every {self.every} steps ({self.every * dt:.6g} s) at the propagated state, "
                   f"held in between")
        settings = RunSettings(
            engine=e.name, model="full", environment=env.atmosphere.describe() + " (written into the aircraft file)",
            g=env.g, dt=dt, integrators=e.integrators.as_dict(), controller=how,
            controller_states=len(self.names),
            controller_scheme=None if ctrl is None else (CONTROLLER_SCHEME if self.names else "no states"),
            controller_dt=None if ctrl is None else self.every * dt,
            extra={"jsbsim_version": import_jsbsim().__version__, "dt_max": e.dt, "steps": self.n,
                   "earth": e.earth, "planet": planet,
                   "control_timing": "u(t_k) written before the run() reaching t_k; u(t0) before run_ic()",
                   "wall_time_s": {**wall, "conversion": time.perf_counter() - t_post}})
        res = SimulationResult(df=df, status=status, message=message, warnings=warnings, settings=settings,
                               t_end=t_end)
        if ctrl is not None:
            Xc = np.array(self.xcs, dtype=float).reshape(idx.size, len(self.names)).T
            res.controller_states, res.feedback = controller_frames(t, self.names, Xc, dU)
        return res

