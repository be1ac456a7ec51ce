"""How the JSBSim engine's sampling of the tracking feedback moves it from the in-house engine (docs/tracking.md).

A dispersed Twin Otter and aileron roll (aero terms x U[0.95, 1.05] seed 3, mass +2 %, offsets 1 m, 0.5 m/s, 0.3 deg)
flown closed loop with saturation on the in-house engine and on JSBSim with the feedback sampled at every step,
240, 120 and 60 Hz; prints the largest position difference between the engines::

    python research/controller_sampling.py
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's packages, not an installed copy

import math

import numpy as np

from gna.perturbation import Perturbation, offset_state, perturbed_aircraft
from harness.engines import InHouseEngine, JSBSimEngine
from planners.generalized import plan_scenario
from planners.scenario import load_scenario
from planners.tracking import tracking_controller


def main() -> None:
    for name in ("twin-otter-single-engine", "gtm-aileron-roll"):
        sc = load_scenario(name)
        plan = plan_scenario(sc)
        p = Perturbation(
            seed=3, aero_spread=0.05, mass_scale=1.02, position_m=1.0, speed_mps=0.5, angle_rad=math.radians(0.3)
        )
        ac = perturbed_aircraft(plan.aircraft, p)
        x0 = offset_state(plan.initial_state(), p)
        c = tracking_controller(plan, sc.tracking.lambdas, saturate=sc.tracking.saturate)
        tt = np.arange(plan.t0, plan.t1 + 1e-9, 0.05)
        ref = InHouseEngine().simulate(ac, c.controls, (plan.t0, plan.t1), x0, env=plan.env, controller=c, t_eval=tt)
        sat = c.saturated_time(ref.df, ref.controller_states.to_numpy())
        print(name, "in-house", ref.status, "saturated", round(sat["any"], 2))
        for cdt in (None, 1 / 240, 1 / 120, 1 / 60):
            e = JSBSimEngine() if cdt is None else JSBSimEngine(controller_dt=cdt)
            d = e.simulate(ac, c.controls, (plan.t0, plan.t1), x0, env=plan.env, controller=c, t_eval=tt).df
            n = min(len(d), len(ref.df))
            dp = np.linalg.norm(
                d[["x", "y", "z"]].to_numpy()[:n] - ref.df[["x", "y", "z"]].to_numpy()[:n], axis=1
            ).max()
            print("   controller_dt", cdt, "engines differ %.3g m" % dp)  # noqa: UP031


if __name__ == "__main__":
    main()
