"""One JSBSim run on the step grid, open loop or with a sampled controller: the loop every JSBSim engine shares.

:class:`JSBSimRun` holds the FDM, its cached property nodes and the records of
one run; it steps open loop or with a controller (feedback sampled at the
propagated state every ``every`` steps and held in between, controller states
advanced by AB2), continues chi and mu and applies the in-house engine's
domain test (:func:`gna.trajectory.domain_violation`) at every step, stops
there keeping the rows before, and builds the common
:class:`gna.trajectory.SimulationResult`.  An engine subclasses it and fills
its hooks (the class notes): what is loaded and how it is configured, how the
controls are written, what the columns report and what the settings add.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from contextlib import ExitStack

import numpy as np

from gna import units
from gna.aircraft import Aircraft
from gna.atmosphere import Environment
from gna.controller import (
    Controller,
    as_controller,
    at_sample_times,
    checked_initial_state,
    evaluate,
    sample_evaluator,
    state_names,
)
from gna.eom import CONTROL_NAMES
from gna.errors import InputError, describe
from gna.simulate import envelope_warnings
from gna.trajectory import (
    RunSettings,
    SimulationResult,
    check_initial_domain,
    check_span,
    control_function,
    controller_frames,
    controls_on_grid,
    domain_bounds,
    environment_of,
    initial_state,
)

from ..base import EngineError
from .fdm import import_jsbsim
from .grid import output_grid, resample_result
from .roundoff import ECI_POSITION, ECI_VELOCITY, PositionRoundoff
from .states import (
    DERIVED_NODES,
    STATE_NODES,
    STATE_NODES_FLAT,
    STATE_NODES_WGS84,
    TRACK_NODES,
    StateConverter,
    trajectory_frame,
)

#: How the JSBSim engines advance a controller's states (recorded in the result's settings).
CONTROLLER_SCHEME = (
    "AB2 (two-step Adams-Bashforth, Euler first step) on the sampled aircraft states, "
    "second order in the controller step"
)


#: Largest JSBSim step [s] an engine takes (``--jsbsim-dt``, ``[compare] jsbsim_dt``): trimmed level flight of
#: the GTM (the smallest, fastest aircraft bundled; 100 m/s at 1000 m, 10 s) flown by JSBSim stays within 3e-8
#: rad of the in-house model up to a step of 0.04 s and leaves the domain at 0.05 s; the f16c and the Twin Otter
#: diverge at 0.5 s and 0.2 s.  Half the GTM's last stable step: JSBSim's own models run at 60-120 Hz.
MAX_JSBSIM_DT = 0.02


def check_steps(dt: float, controller_dt: float | None) -> None:
    """Validate a JSBSim engine's largest step and controller interval.

    Parameters
    ----------
    dt : float
        Largest step [s], at most :data:`MAX_JSBSIM_DT`.
    controller_dt : float or None
        Controller update interval [s] (None: every step).

    Raises
    ------
    InputError
        If either is not a positive finite number, or ``dt`` is above :data:`MAX_JSBSIM_DT`.
    """
    if not (math.isfinite(dt) and dt > 0):
        raise InputError(f"JSBSim step dt must be positive, got {dt}")
    if dt > MAX_JSBSIM_DT:
        raise InputError(
            f"JSBSim step dt = {dt:g} s is above the bound {MAX_JSBSIM_DT:g} s (JSBSim's integration of the GTM "
            f"diverges at 0.05 s)"
        )
    if controller_dt is not None and not (math.isfinite(controller_dt) and controller_dt > 0):
        raise InputError(f"controller_dt must be positive, got {controller_dt}")


class StepStop(Exception):
    """The run leaves the domain at step ``k``: ``text`` names the variable and value (``{t}``: the time)."""

    def __init__(self, k: int, text: str):
        self.k, self.text = k, text

    @staticmethod
    def control(k: int, u) -> StepStop:
        """The stop for non-finite controls ``u`` (5 values) at step ``k``.

        Parameters
        ----------
        k : int
            Step index.
        u : sequence of 5 float
            The controls.

        Returns
        -------
        StepStop
        """
        bad = [f"{n} = {v}" for n, v in zip(CONTROL_NAMES, u) if not math.isfinite(v)]
        return StepStop(k, f"non-finite control at t = {{t}} ({', '.join(bad)})")


class JSBSimRun:
    """One JSBSim run: the problem on the step grid, the FDM with its cached nodes, and the records.

    Parameters
    ----------
    engine : object
        The engine (``name``, ``dt``, ``integrators``, ``controller_dt``).
    aircraft, env : Aircraft, Environment
        The aircraft flown; atmosphere and g.
    x0 : ndarray, shape (12,)
        Initial wind-frame state.
    times, out_steps : ndarray, shape (n + 1,), and ndarray of int
        The step grid [s]; the step indices of the output times.
    U : ndarray, shape (5, n + 1)
        Reference controls on the step grid.
    controller, every : Controller or None, int
        The feedback and its update interval in steps.

    Notes
    -----
    An engine subclasses this class and fills the hooks (methods for the
    subclasses, not for callers):

    * ``_load(stack) -> (fdm, capture, problems)`` (required): a new FDM with
      the aircraft loaded, its log capture entered on ``stack``;
    * ``_configure()`` (required): step, integrators, planet, atmosphere,
      configuration and initial condition written, control writers bound;
    * ``_write(u)`` (required): the applied controls (5 floats) written for the
      next ``run()``; ``_open_loop_writer() -> write_step(k)`` may precompute
      the reference controls of an open-loop run;
    * ``_initialize()``: JSBSim's initial condition (default ``_run_ic()``);
    * ``_stepped(k, u)``: after each complete step, with the applied controls (inner loops);
    * ``_derived(R, S)`` and :attr:`derived_nodes`: the rows of
      :func:`.states.trajectory_frame` from the raw outputs;
    * ``_columns(applied, idx)``: the control columns reported;
    * ``_describe() -> (environment, extra)`` and ``_problems()``: settings
      and warnings;
    * :attr:`geo`: initial (latitude, longitude) on the WGS84 Earth, or None.

    Control timing: ``u(t_k)`` is written before the ``run()`` reaching
    ``t_k`` and ``u(t0)`` before ``run_ic()``; at a controller update the step
    runs, the state ``x_k`` is read, the controller states are advanced to
    ``t_k``, the corrected controls written and the derivatives re-evaluated
    at ``x_k`` with the integration suspended.
    """

    #: Initial (latitude, longitude) [rad] on JSBSim's WGS84 Earth, or None on a flat planet.
    geo: tuple[float, float] | None = None
    #: Raw outputs read at the output times for :meth:`derived`.
    derived_nodes: tuple[str, ...] = DERIVED_NODES
    #: Called as ``_stepped(k, u)`` once step ``k`` is complete with the applied controls ``u``; None: nothing.
    _stepped: Callable[[int, list], None] | None = None

    def __init__(
        self,
        engine,
        aircraft: Aircraft,
        env: Environment,
        x0: np.ndarray,
        times: np.ndarray,
        out_steps: np.ndarray,
        U: np.ndarray,
        controller: Controller | None,
        every: int,
    ):
        self.engine, self.aircraft, self.env, self.x0 = engine, aircraft, env, x0
        self.times, self.U, self.n = times, U, times.size - 1
        self.dt = float(times[1] - times[0])
        self.out = np.zeros(self.n + 1, dtype=bool)
        self.out[out_steps] = True
        self.controller, self.every = controller, every
        self.names = state_names(controller)
        self.pos_nodes = STATE_NODES_WGS84 if self.geo is not None else STATE_NODES_FLAT
        # Records at the output steps: raw states, raw derived outputs, feedback and controller states.
        self.raw_states, self.raw_derived, self.index, self.fb, self.xcs = [], [], [], [], []
        self.turns: list[tuple[float, float]] = []  # chi and mu continued step by step, at the output steps
        self.k = 0
        self.fdm = self.capture = None
        self.load_problems: list[str] = []
        self.roundoff: PositionRoundoff | None = None  # set by start() on a flat planet

    @classmethod
    def fly(
        cls,
        engine,
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
        """Set the problem on the step grid of ``engine`` and fly it: the body of the engines' ``simulate``.

        Parameters
        ----------
        engine : object
            The engine (``name``, ``dt``, ``integrators``, ``controller_dt``).
        aircraft, controls, t_span, x0, env, controller, dt_out, t_eval
            As :meth:`harness.engines.base.Engine.simulate`.

        Returns
        -------
        SimulationResult
        """
        env = environment_of(controls, env)
        y0 = initial_state(controls, x0)
        t0, t1 = check_span(t_span)
        check_initial_domain(t0, y0, domain_bounds(env))  # as the in-house engine: refused before JSBSim loads
        ufun = control_function(controls)
        ctrl = as_controller(controller)
        n, dt, out_times, record = output_grid(t0, t1, engine.dt, dt_out, t_eval)  # the step ignores dt_out
        times = t0 + np.arange(n + 1) * dt
        U = controls_on_grid(ufun, times)
        every = 1 if engine.controller_dt is None else max(int(round(engine.controller_dt / dt)), 1)
        ctrl = at_sample_times(ctrl, times[::every])
        t_setup = time.perf_counter()
        run = cls(engine, aircraft, env, y0, times, record, U, ctrl, every)
        with ExitStack() as stack:
            run.fdm, run.capture, run.load_problems = run._load(stack)
            run.start()
            t_loop = time.perf_counter()
            status, message, t_end = run.step_all()
            t_post = time.perf_counter()
            res = run.result(status, message, t_end, {"setup": t_loop - t_setup, "stepping": t_post - t_loop})
        return resample_result(res, out_times, t0, dt)

    # ---- hooks (see the class notes) -------------------------------------------------------------
    def _load(self, stack: ExitStack):
        """``(fdm, capture, problems)``: a new FDM with the aircraft, its log capture entered on ``stack``."""
        raise NotImplementedError

    def _configure(self) -> None:
        """Settings, configuration and initial condition written, control writers bound (before ``u(t0)``)."""
        raise NotImplementedError

    def _write(self, u: list) -> None:
        """Write the applied controls ``u`` = (F [N], eta, dl, dm, dn [rad]) for the next ``run()``."""
        raise NotImplementedError

    def _open_loop_writer(self) -> Callable[[int], None]:
        """``write_step(k)`` writing the reference controls of step ``k``."""
        ucols, write = self.U.T.tolist(), self._write
        return lambda k: write(ucols[k])

    def _initialize(self) -> None:
        """JSBSim's initial condition, ``u(t0)`` written."""
        self._run_ic()

    def _derived(self, R: np.ndarray, S: np.ndarray) -> np.ndarray:
        """Rows for :func:`.states.trajectory_frame` from the raw :attr:`derived_nodes` ``R`` and states ``S``."""
        return R

    def _columns(self, applied: np.ndarray, idx: np.ndarray) -> np.ndarray:
        """The control columns reported at the output steps ``idx`` from the applied controls there."""
        return applied

    def _describe(self) -> tuple[str, dict]:
        """``(environment description, the engine's own settings records)``."""
        return self.env.atmosphere.describe(), {}

    def _problems(self) -> list[str]:
        """JSBSim's messages reported as warnings."""
        return list(self.load_problems)

    # ---- setup -----------------------------------------------------------------------------------
    def _node(self, name: str):
        """The cached property node ``name`` (:class:`EngineError` if the model has no such property)."""
        nd = self.fdm.get_property_manager().get_node(name, False)
        if nd is None:
            raise EngineError(f"JSBSim property {name!r} does not exist in the loaded model of {self.aircraft.id}")
        return nd

    def _run_ic(self) -> None:
        """``fdm.run_ic()``; :class:`EngineError` if JSBSim refuses the initial condition."""
        try:
            ok = self.fdm.run_ic()
        except Exception as exc:  # JSBSim raises its own exception types
            raise EngineError(f"JSBSim run_ic failed for {self.aircraft.id}: {describe(exc)}") from None
        if not ok:
            raise EngineError(f"JSBSim run_ic failed for {self.aircraft.id}: {' | '.join(self.capture.problems())}")

    def start(self) -> None:
        """Configuration, initial condition, u(t0) written, :meth:`initialize`, first record.

        Raises
        ------
        InputError
            Bad controller initial state or non-finite controls at t0.
        """
        self._configure()
        self.state_readers = [self._node(p).get_double_value for p in self.pos_nodes + STATE_NODES]
        self.derived_readers = [self._node(p).get_double_value for p in self.derived_nodes]
        bounds = domain_bounds(self.env)  # the atmosphere's altitude range, and with ground effect the ground
        track = TRACK_NODES + self.pos_nodes[2:]  # the CG's altitude: every domain test at every step
        self.track_readers = [self._node(p).get_double_value for p in track]
        self.radius_ft = float(self.fdm["inertial/sea-level-radius_ft"])
        self.to_state = StateConverter(self.x0, self.radius_ft, self.geo, bounds)
        t0, u0 = float(self.times[0]), self.U[:, 0]
        self.d = [0.0] * 5
        self.xc = np.zeros(0)
        if self.controller is not None:
            self.xc = checked_initial_state(self.controller, t0, self.x0)
            d, f = evaluate(self.controller, t0, self.x0.copy(), self.xc)
            self.d, self.f_prev = d.tolist(), (f if self.names else None)
            self.f_prev2 = None
        self.applied0 = [a + b for a, b in zip(u0.tolist(), self.d)]
        if not all(math.isfinite(v) for v in self.applied0):
            names = [f"{c} = {v}" for c, v in zip(CONTROL_NAMES, self.applied0) if not math.isfinite(v)]
            raise InputError(f"controls at t0 = {t0:g} s are not finite ({', '.join(names)})")
        self._write(self.applied0)
        self.fdm.set_sim_time(t0)
        self._initialize()
        if self.geo is None and getattr(self.engine, "compensate_roundoff", True):
            self.roundoff = PositionRoundoff(
                [self._node(p).get_double_value for p in ECI_POSITION],
                [self._node(p).get_double_value for p in ECI_VELOCITY],
                self.engine.integrators.translational_position,
                self.dt,
            )
        if self.out[0]:
            self._record(0)

    def _record(self, k: int) -> None:
        self.turns.append((self.to_state.chi, self.to_state.mu))
        raw = [r() for r in self.state_readers]
        self.raw_states.append(raw if self.roundoff is None else self.roundoff.correct(raw, self.radius_ft))
        self.raw_derived.append([r() for r in self.derived_readers])
        self.index.append(k)
        self.fb.append(self.d)
        self.xcs.append(self.xc)

    # ---- stepping --------------------------------------------------------------------------------
    def step_all(self) -> tuple[str, str, float]:
        """Step to the end or to the first divergence.

        Returns
        -------
        status : {"completed", "domain"}
        message : str
            Names the time, variable and value of a divergence.
        t_end : float
            Last output time [s].
        """
        times = self.times
        try:
            if self.controller is None:
                self._open_loop()
            else:
                self._closed_loop()
        except StepStop as stop:
            t_end = float(times[self.index[-1]]) if self.index else float(times[0])
            message = stop.text.format(t=f"{times[stop.k]:.6g} s") + f"; partial result kept up to t = {t_end:.6g} s"
            return "domain", message, t_end
        except import_jsbsim().BaseError as exc:  # JSBSim's own exceptions (e.g. geographic errors on divergence)
            t_end = float(times[self.index[-1]]) if self.index else float(times[0])
            return (
                "domain",
                (
                    f"JSBSim stopped at t = {times[self.k]:.6g} s with {type(exc).__name__}: {describe(exc)}; "
                    f"partial result kept up to t = {t_end:.6g} s"
                ),
                t_end,
            )
        return "completed", "", float(times[-1])

    def _check_run(self, ok: bool, k: int) -> None:
        """After step ``k``: chi and mu continued; :class:`StepStop` outside the physical domain."""
        if not ok:
            raise StepStop(k, "JSBSim asked to stop (run() returned false) at t = {t}")
        bad = self.to_state.check(self.times[k], [r() for r in self.track_readers])
        if bad is not None:
            raise StepStop(k, bad.replace("{", "{{").replace("}", "}}"))

    def _first_bad(self) -> int:
        bad = ~np.all(np.isfinite(self.U), axis=0)
        return int(np.argmax(bad)) if bad.any() else self.n + 1

    def _open_loop(self) -> None:
        k_bad, write_step, stepped = self._first_bad(), self._open_loop_writer(), self._stepped
        ucols = self.U.T.tolist() if stepped is not None else None
        run, check, out = self.fdm.run, self.to_state.check, self.out.tolist()
        readers, tlist = self.track_readers, self.times.tolist()
        advance = None if self.roundoff is None else self.roundoff.advance
        for k in range(1, self.n + 1):
            self.k = k
            if k >= k_bad:
                raise StepStop.control(k, self.U[:, k])
            write_step(k)
            if not run():
                raise StepStop(k, "JSBSim asked to stop (run() returned false) at t = {t}")
            if advance is not None:
                advance()
            bad = check(tlist[k], [r() for r in readers])  # _check_run, inline
            if bad is not None:
                raise StepStop(k, bad.replace("{", "{{").replace("}", "}}"))
            if stepped is not None:
                stepped(k, ucols[k])
            if out[k]:
                self._record(k)

    def _closed_loop(self) -> None:
        """Feedback sampled at every ``every``-th step without delay, held in between; AB2 on the states.

        At an update the 14 state outputs are read once (:meth:`.states.StateConverter.step`: the domain
        test and the state); the controller states and derivatives are kept as floats, and a controller
        offering :func:`gna.controller.sample_evaluator` is evaluated at the sample's index (the tracking
        feedback's table) on them.  The same arithmetic as :func:`gna.controller.evaluate` on arrays.
        """
        fdm, ctrl, every, stepped = self.fdm, self.controller, self.every, self._stepped
        hc = every * self.dt
        a1, a2 = 1.5 * hc, 0.5 * hc
        ucols, tlist, out = self.U.T.tolist(), self.times.tolist(), self.out.tolist()
        run, check, write, isfinite = fdm.run, self._check_run, self._write, math.isfinite
        readers, convert = self.state_readers, self.to_state.step
        suspend, resume = fdm.suspend_integration, fdm.resume_integration
        rc, radius = self.roundoff, self.radius_ft
        stateful, k_bad = bool(self.names), self._first_bad()
        fast = sample_evaluator(ctrl)
        if fast is None:
            n_u, n_c = len(CONTROL_NAMES), int(ctrl.n_states)

            def feedback(m, x, xc):
                d, f = evaluate(ctrl, tlist[m * every], np.array(x), np.array(xc, dtype=float).reshape(n_c))
                return d.reshape(n_u).tolist(), f.tolist()
        else:
            feedback = fast
        xc = self.xc = np.asarray(self.xc, dtype=float).tolist()
        f1 = None if self.f_prev is None else np.asarray(self.f_prev, dtype=float).tolist()
        f2 = None
        d = self.d
        for k in range(1, self.n + 1):
            self.k = k
            if k % every:
                if k >= k_bad:
                    raise StepStop.control(k, ucols[k])
                uk = [a + b for a, b in zip(ucols[k], d)]
                write(uk)
                ok = run()
                if rc is not None and ok:
                    rc.advance()
                check(ok, k)
            else:
                if not run():
                    raise StepStop(k, "JSBSim asked to stop (run() returned false) at t = {t}")
                raw = [r() for r in readers]
                if rc is not None:
                    rc.advance()
                    rc.correct(raw, radius)  # the feedback sees the position without JSBSim's round-off
                bad, xk = convert(tlist[k], raw)
                if bad is not None:
                    raise StepStop(k, bad.replace("{", "{{").replace("}", "}}"))
                if stateful:
                    if f2 is None:
                        xc = [x + hc * f for x, f in zip(xc, f1)]
                    else:
                        xc = [x + (a1 * f - a2 * g) for x, f, g in zip(xc, f1, f2)]
                    self.xc = xc
                    if not all(map(isfinite, xc)):
                        bad = ", ".join(f"{n} = {v}" for n, v in zip(self.names, xc) if not isfinite(v))
                        raise StepStop(k, f"non-finite controller state at t = {{t}} ({bad})")
                d, f_new = feedback(k // every, xk, xc)
                self.d = d
                uk = [a + b for a, b in zip(ucols[k], d)]
                if not all(map(isfinite, uk)):
                    raise StepStop.control(k, uk)
                write(uk)
                suspend()
                try:
                    run()
                finally:
                    resume()
                if stateful:
                    f2, f1 = f1, f_new
            if stepped is not None:
                stepped(k, uk)
            if out[k]:
                self._record(k)

    # ---- result ----------------------------------------------------------------------------------
    def result(self, status: str, message: str, t_end: float, wall: dict) -> SimulationResult:
        """Convert the records to the common result (states, reported controls, settings).

        Parameters
        ----------
        status : str
            From :meth:`step_all`.
        message : str
            From :meth:`step_all`.
        t_end : float
            From :meth:`step_all` [s].
        wall : dict
            Wall times [s] so far (setup, stepping).

        Returns
        -------
        SimulationResult
        """
        t_post = time.perf_counter()
        e, env, aircraft = self.engine, self.env, self.aircraft
        idx = np.asarray(self.index, dtype=int)
        S = self.to_state.vector(
            np.array(self.raw_states, dtype=float).T.reshape(len(self.pos_nodes) + len(STATE_NODES), -1),
            np.array(self.turns, dtype=float).T.reshape(2, -1),
        )
        D = self._derived(np.array(self.raw_derived, dtype=float).T.reshape(len(self.derived_nodes), -1), S)
        dU = np.array(self.fb, dtype=float).T.reshape(5, -1)
        applied = self.U[:, idx] + dU if self.controller is not None else self.U[:, idx]
        t = self.times[idx]
        df = trajectory_frame(aircraft, env, t, S, self._columns(applied, idx), D)
        warnings = envelope_warnings(aircraft, df) + [f"JSBSim: {p}" for p in self._problems()]
        near = np.abs(df["gamma"].to_numpy()) > 0.5 * math.pi - 1e-3
        if near.any():
            warnings.append(
                f"the flight path came within 1e-3 rad of vertical at t = {df.index[near.argmax()]:.4g} s: "
                f"the wind-frame chart is singular there (chi and mu are ill-defined; the in-house "
                f"engine stops)"
            )
        ctrl, dt = self.controller, self.dt
        if ctrl is None:
            how = None
        elif self.every == 1:
            how = "sampled every step at the propagated state"
        else:
            how = f"sampled every {self.every} steps ({self.every * dt:.6g} s) at the propagated state, held in between"
        environment, extra = self._describe()
        settings = RunSettings(
            engine=e.name,
            model="full",
            environment=environment,
            g=env.g,
            dt=dt,
            integrators=e.integrators.as_dict(),
            controller=how,
            controller_states=len(self.names),
            controller_scheme=None if ctrl is None else (CONTROLLER_SCHEME if self.names else "no states"),
            controller_dt=None if ctrl is None else self.every * dt,
            extra={
                "jsbsim_version": import_jsbsim().__version__,
                "dt_max": e.dt,
                "steps": self.n,
                **extra,
                "control_timing": "u(t_k) written before the run() reaching t_k; u(t0) before run_ic()",
                # JSBSim's inertial-position round-off taken out of the positions (harness.engines.jsbsim.roundoff):
                # on a flat planet unless the engine's compensate_roundoff is false; the largest correction [m].
                "position_roundoff": {
                    "corrected": self.roundoff is not None,
                    "largest_m": None if self.roundoff is None else self.roundoff.largest * units.FT,
                },
                "wall_time_s": {**wall, "conversion": time.perf_counter() - t_post},
            },
        )
        res = SimulationResult(df=df, status=status, message=message, warnings=warnings, settings=settings, t_end=t_end)
        if ctrl is not None:
            Xc = np.array(self.xcs, dtype=float).reshape(idx.size, len(self.names)).T
            res.controller_states, res.feedback = controller_frames(t, self.names, Xc, dU)
        return res
