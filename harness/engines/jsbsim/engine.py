"""The JSBSim engine: the exported aircraft flown step by step, with an optional sampled controller.

:class:`JSBSimEngine` flies the aircraft file exported from a gflat aircraft;
its run (:class:`_ExportRun`) fills the hooks of the shared run loop
(:class:`harness.engines.jsbsim.run.JSBSimRun`): the file loaded, the two
engine thrusts and three surfaces written directly.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from gna import units
from gna.aircraft import Aircraft
from gna.atmosphere import Environment
from gna.errors import InputError
from gna.trajectory import SimulationResult

from . import export as jx
from .fdm import Integrators, load_fdm, prepare
from .run import CONTROLLER_SCHEME, JSBSimRun, StepStop, check_steps

__all__ = ["JSBSimEngine", "CONTROLLER_SCHEME", "StepStop"]


@dataclass(frozen=True)
class JSBSimEngine:
    """JSBSim 1.3 flying the exported aircraft file.

    Parameters
    ----------
    dt : float
        Largest step [s], JSBSim's own setting: the step used is the largest
        that divides the span, independent of the output grid, and is recorded
        in ``settings["dt"]``.  Output times between two steps are interpolated
        (cubic Lagrange through four steps, :mod:`harness.engines.jsbsim.grid`).
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
    compensate_roundoff : bool
        On the flat planet, correct the position read by the round-off of
        JSBSim's inertial position (:mod:`harness.engines.jsbsim.roundoff`:
        a steady vertical speed is otherwise flown at a multiple of 2.2 mm/s
        at 1/480 s); the largest correction is recorded in
        ``settings.extra["position_roundoff"]``.  Ignored on the WGS84 Earth.

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
    ``chi`` and ``mu`` are unwrapped and start at ``x0``'s values.  On the flat
    planet the position is that of JSBSim's integration without the round-off
    of its inertial position (``compensate_roundoff``).
    """

    dt: float = 1.0 / 480.0
    integrators: Integrators = field(default_factory=Integrators)
    earth: str = "flat"
    planet_radius_ft: float = jx.PLANET_RADIUS_FT
    latitude: float = 0.0
    longitude: float = 0.0
    controller_dt: float | None = None
    compensate_roundoff: bool = True

    def __post_init__(self):
        check_steps(self.dt, self.controller_dt)
        if self.earth not in ("flat", "wgs84"):
            raise InputError(f"earth must be 'flat' or 'wgs84', got {self.earth!r}")
        if not (abs(self.latitude) < math.pi / 2 and math.isfinite(self.longitude)):
            raise InputError(f"bad initial latitude/longitude ({self.latitude}, {self.longitude}) rad")

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
            Its g sets the flat planet's GM; its ground effect, if any, is written into the file.
        x0 : ndarray, shape (12,)
            Initial state; ``-x0[2]`` is the planet's reference altitude [m].

        Returns
        -------
        str
            The JSBSim aircraft file.
        """
        planet = (
            jx.FlatPlanet(g=env.g, h_ref=-float(x0[2]), radius_ft=self.planet_radius_ft)
            if self.earth == "flat"
            else None
        )
        return jx.aircraft_xml(aircraft, planet, ground_effect=env.ground_effect)

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
            Output interval [s]; it does not change the step.
        t_eval : array_like, shape (n,), optional
            Output times [s] in the span, on the step grid or not.

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
        return _ExportRun.fly(
            self, aircraft, controls, t_span, x0, env=env, controller=controller, dt_out=dt_out, t_eval=t_eval
        )


class _ExportRun(JSBSimRun):
    """A run of the exported aircraft file: two thrusts (engines 1, 2) and the three surfaces written directly."""

    @property
    def geo(self):
        e = self.engine
        return (e.latitude, e.longitude) if e.earth == "wgs84" else None

    def _load(self, stack):
        fdm, problems, capture = load_fdm(self.engine.xml(self.aircraft, self.env, self.x0), self.aircraft.id)
        stack.enter_context(capture)
        return fdm, capture, problems

    def _configure(self) -> None:
        e = self.engine
        prepare(
            self.fdm,
            e.integrators,
            self.dt,
            self.env,
            self.x0,
            wgs84=self.geo is not None,
            latitude=e.latitude,
            longitude=e.longitude,
            planet_radius_ft=e.planet_radius_ft,
        )
        props = (*jx.THRUST_PROPERTIES, *jx.CONTROL_PROPERTIES.values())
        self.writers = [self._node(p).set_double_value for p in props]

    def _write(self, u) -> None:
        """Thrusts of engines 1, 2 [lbf] from (F, eta), and the three surfaces [rad]."""
        w, lbf = self.writers, units.LBF
        F, eta = u[0], u[1]
        w[0](F * (1.0 + eta) * 0.5 / lbf)
        w[1](F * (1.0 - eta) * 0.5 / lbf)
        w[2](u[2])
        w[3](u[3])
        w[4](u[4])

    def _open_loop_writer(self):
        """Reference controls precomputed on the step grid (engine thrusts in lbf)."""
        U, lbf = self.U, units.LBF
        F1 = (U[0] * (1.0 + U[1]) * 0.5 / lbf).tolist()
        F2 = (U[0] * (1.0 - U[1]) * 0.5 / lbf).tolist()
        DL, DM, DN = U[2].tolist(), U[3].tolist(), U[4].tolist()
        w0, w1, w2, w3, w4 = self.writers

        def write_step(k):
            w0(F1[k])
            w1(F2[k])
            w2(DL[k])
            w3(DM[k])
            w4(DN[k])  # noqa: E702

        return write_step

    def _describe(self):
        e, env, h_ref = self.engine, self.env, -float(self.x0[2])
        planet = (
            {
                "radius_ft": e.planet_radius_ft,
                "h_ref_m": h_ref,
                "rotation_rad_s": 0.0,
                "J2": 0.0,
                "GM_ft3_s2": jx.FlatPlanet(env.g, h_ref, e.planet_radius_ft).GM,
                "gravity_model": 0,
            }
            if self.geo is None
            else {
                "model": "JSBSim default WGS84, rotating, J2 gravity",
                "latitude_rad": e.latitude,
                "longitude_rad": e.longitude,
            }
        )
        return (env.describe() + " (written into the aircraft file)", {"earth": e.earth, "planet": planet})
