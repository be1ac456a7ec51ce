"""The engines of a JSBSim aircraft, measured by running them in JSBSim.

The aircraft is loaded as for the aerodynamics (:func:`.jsbsim_aero.load_model`: no ``<input>``/``<output>``,
console captured), flight-control system off with the fit's configuration, engines running, and held at a
fixed airspeed (``simulation/models/FGPropagate/enabled = 0``: the state does not move while the engines'
own dynamics -- spool, propeller speed, manifold pressure -- run with the time step), fuel frozen
(``propulsion/fuel_freeze``: the loaded mass and CG).  Measured:

* **thrust rating against speed**: each engine at full throttle (``fcs/throttle-pos-norm = 1``, mixture and
  propeller advance full) brought to its steady state (``FGPropulsion::GetSteadyState``) at
  :data:`RATING_SPEEDS` times the reference speed, at the reference altitude;
* **thrust lag**: a first-order time constant, the time the thrust takes to cover 63.2 % of the step from its
  steady value at half throttle to its full-throttle value (throttle stepped 0.5 -> 1 at the reference speed);
* **propulsive moments** at full throttle at the reference speed, per unit of thrust: the pitching moment
  ``moments/m-prop-lbsft`` over the thrust ``forces/fbx-prop-lbs`` is the thrust line's distance below the
  CG (its offset), the rolling moment ``moments/l-prop-lbsft`` over it the propeller torque's arm
  (:mod:`gna.eom`, the propulsive moments).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ... import units
from ...errors import InputError
from . import jsbsim_xml as jx
from .jsbsim_aero import _console_captured, _quiet, load_model

#: Speeds of the thrust rating, as fractions of the reference speed.
RATING_SPEEDS = (0.0, 0.25, 0.5, 0.75, 1.0, 1.25, 1.5)
#: Step of the engines' run [s] and longest wait for the lag step [s].
ENGINE_DT = 1.0 / 120.0
LAG_WAIT = 30.0


@dataclass(frozen=True)
class EngineMeasurement:
    """What :func:`measure_engines` measured (SI units, per engine unless said otherwise).

    Attributes
    ----------
    speeds : tuple of float
        Airspeeds of the rating [m/s].
    thrust : tuple of float
        Full-throttle thrust of ONE engine at each speed [N] (the engines' mean).
    altitude : float
        Altitude of the measurement [m].
    lag : float
        First-order time constant of the thrust response [s].
    thrust_line_offset : float
        Distance of the thrust line below the CG [m] (pitching moment over thrust).
    torque_arm : float
        Rolling moment over thrust [m] (the propeller torque; positive right wing down).
    kinds : str
        The engine and thruster types.
    """

    speeds: tuple
    thrust: tuple
    altitude: float
    lag: float
    thrust_line_offset: float
    torque_arm: float
    kinds: str

    def section(self) -> dict:
        """The ``[engines]`` keys of the measurement (SI), with its method as ``engine_source``.

        Returns
        -------
        dict
        """
        rated = {} if "turbine" in self.kinds else {"max_thrust_N": float(f"{max(self.thrust) * self._count:.6g}")}
        return {
            **rated,
            **(
                {}
                if "turbine" in self.kinds
                else {
                    "engine_thrust_curve_speed_ms": [float(f"{v:.6g}") for v in self.speeds],
                    "engine_thrust_curve_N": [float(f"{t:.6g}") for t in self.thrust],
                }
            ),
            "thrust_lag_s": float(f"{self.lag:.4g}"),
            "thrust_line_offset_m": float(f"{self.thrust_line_offset:.6g}"),
            "torque_arm_m": float(f"{self.torque_arm:.6g}"),
            "engine_source": (
                f"measured in JSBSim ({self.kinds}) at {self.altitude:g} m, held at each speed "
                f"(FGPropagate off): "
                + ("" if "turbine" in self.kinds else "full-throttle steady thrust of one engine against airspeed; ")
                + "thrust lag = "
                "time to 63.2 % of the step from half to full throttle at the reference speed; thrust line "
                "offset and torque arm = propulsive pitching and rolling moments over thrust at full throttle "
                "there (gna.fit.sources.jsbsim_engines)"
            ),
        }

    _count: int = 1


def measure_engines(source) -> EngineMeasurement:
    """Measure the thrust rating, lag and propulsive moments of a JSBSim aircraft's engines.

    Parameters
    ----------
    source : JSBSimAeroSource
        The aircraft (folders, reference altitude and speed, the configuration held, ``console``).

    Returns
    -------
    EngineMeasurement

    Raises
    ------
    InputError
        No engine, or an engine that gives no thrust at full throttle at the reference speed.
    """
    fdm, console = load_model(source.model, source.aircraft_dir, source.root)
    source.console.extend(console)
    n = fdm.get_propulsion().get_num_engines()
    if n == 0:
        raise InputError(f"JSBSim {source.model} has no engine")
    pm = fdm.get_property_manager()
    kinds = sorted({jx.engine_kind(t.engine_file, source.aircraft_dir, source.root) for t in jx.engines(source._xml)})
    with _quiet(), _console_captured(source.console):
        fdm.set_dt(ENGINE_DT)
        fdm["simulation/models/FGFCS/enabled"] = 0
        for k, v in source.configuration.items():
            fdm[k] = v

        def hold(V_fps):
            fdm["ic/h-sl-ft"] = source.altitude / units.FT
            fdm["ic/lat-geod-rad"] = fdm["ic/long-gc-rad"] = 0.0
            fdm["ic/theta-rad"] = fdm["ic/phi-rad"] = fdm["ic/psi-true-rad"] = 0.0
            fdm["ic/u-fps"], fdm["ic/v-fps"], fdm["ic/w-fps"] = V_fps, 0.0, 0.0
            fdm["ic/p-rad_sec"] = fdm["ic/q-rad_sec"] = fdm["ic/r-rad_sec"] = 0.0
            fdm["simulation/models/FGPropagate/enabled"] = 1
            fdm.run_ic()
            fdm["simulation/models/FGPropagate/enabled"] = 0
            fdm["propulsion/set-running"] = -1
            fdm["propulsion/fuel_freeze"] = 1  # the loaded mass and CG, whatever the engines burn

        def throttle(th):
            for i in range(n):
                fdm[f"fcs/throttle-pos-norm[{i}]"] = th
                for extra in ("mixture-pos-norm", "advance-pos-norm"):
                    if pm.hasNode(f"fcs/{extra}[{i}]"):
                        fdm[f"fcs/{extra}[{i}]"] = 1.0

        V_ref = source.V_fps
        curve = []
        for f in RATING_SPEEDS:
            hold(f * V_ref)
            throttle(1.0)
            curve.append(_settle(fdm, n) / n * units.LBF)
        hold(V_ref)
        throttle(1.0)
        T_full = _settle(fdm, n)
        Fx, L, M = fdm["forces/fbx-prop-lbs"], fdm["moments/l-prop-lbsft"], fdm["moments/m-prop-lbsft"]
        if not Fx > 0:
            raise InputError(
                f"JSBSim {source.model}: its engines give {Fx:g} lbf at full throttle at the reference speed"
            )
        # The lag: settled at half throttle by running (not by the steady-state solver, whose state the
        # turbine model then leaves at once), then the throttle stepped to full.
        throttle(0.5)
        T_half = _settle(fdm, n)
        throttle(1.0)
        times, thrust = [0.0], [T_half]
        for k in range(1, round(LAG_WAIT / ENGINE_DT) + 1):
            fdm.run()
            times.append(k * ENGINE_DT)
            thrust.append(_thrust(fdm, n))
            if k % 120 == 0 and abs(thrust[-1] - thrust[-121]) <= 1e-4 * abs(T_full - T_half):
                break
        T_end = thrust[-1]
    lag = _time_constant(np.array(times), np.array(thrust), T_half, T_end)
    out = EngineMeasurement(
        speeds=tuple(f * V_ref * units.FT for f in RATING_SPEEDS),
        thrust=tuple(curve),
        altitude=source.altitude,
        lag=lag,
        thrust_line_offset=M / Fx * units.FT,
        torque_arm=L / Fx * units.FT,
        kinds=", ".join(kinds),
    )
    object.__setattr__(out, "_count", n)
    return out


def _thrust(fdm, n: int) -> float:
    return sum(fdm[f"propulsion/engine[{i}]/thrust-lbs"] for i in range(n))


def _settle(fdm, n: int) -> float:
    """Run until the total thrust changes by less than 1e-5 of itself over a second (at most LAG_WAIT)."""
    last = _thrust(fdm, n)
    for _ in range(round(LAG_WAIT)):
        for _ in range(round(1.0 / ENGINE_DT)):
            fdm.run()
        now = _thrust(fdm, n)
        if abs(now - last) <= 1e-5 * max(abs(now), 1.0):
            break
        last = now
    return now


def _time_constant(t: np.ndarray, T: np.ndarray, T0: float, T1: float) -> float:
    """Time at which ``T`` first covers 63.2 % of the step ``T0 -> T1`` (linear between samples); 0 when the
    step is nil or immediate."""
    if not abs(T1 - T0) > 1e-9 * max(1.0, abs(T1)):
        return 0.0
    level = T0 + (1.0 - math.exp(-1.0)) * (T1 - T0)
    x = (T - level) * math.copysign(1.0, T1 - T0)
    k = int(np.argmax(x >= 0)) if np.any(x >= 0) else len(t) - 1
    if k == 0:
        return 0.0
    return float(t[k - 1] + (t[k] - t[k - 1]) * (-x[k - 1]) / (x[k] - x[k - 1]))
