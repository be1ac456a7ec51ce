"""Robustness of the tracking feedback: the figures quoted in docs/tracking.md and the closing notes.

Each paper scenario is planned on the nominal model and flown closed loop on the in-house engine with a
perturbation (every aerodynamic term x a seeded factor in [1 - s, 1 + s], mass scale, initial offset of
position / speed / angles), saturation on and off; one factor at a time for the forward slip.

    python scripts/tracking_robustness.py [--seed 1]

Prints, per run: status, end time, the time after which |(x, y, z) - flat outputs| stays below 1 m, and the
largest error after 10 s and after 40 s.
"""

from __future__ import annotations

import argparse
import math

import numpy as np

from gna.perturbation import Perturbation, offset_state, perturbed_aircraft
from harness.engines import get_engine
from planners.generalized import plan_scenario
from planners.scenario import load_scenario
from planners.tracking import tracking_controller


def fly(plan, sc, perturbation, saturate):
    c = tracking_controller(plan, sc.tracking.lambdas, feedforward_iterate=sc.tracking.feedforward_iterate,
                            saturate=saturate)
    tt = np.arange(plan.t0, plan.t1 + 1e-9, 0.1)
    res = get_engine("inhouse").simulate(perturbed_aircraft(plan.aircraft, perturbation), c, (plan.t0, plan.t1),
                                         offset_state(plan.initial_state(), perturbation), controller=c,
                                         env=plan.env, t_eval=tt)
    t = res.df.index.to_numpy()
    err = np.linalg.norm(res.df[["x", "y", "z"]].to_numpy().T - plan.state(t)[:3], axis=0)
    above = np.flatnonzero(err >= 1.0)
    settled = (t[above[-1] + 1] if above[-1] + 1 < t.size else math.nan) if above.size else t[0]
    after = {w: float(np.max(err[t >= plan.t0 + w])) if np.any(t >= plan.t0 + w) else math.nan for w in (10, 40)}
    return res, settled, after


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    full = dict(aero_spread=0.1, mass_scale=1.05, position_m=5.0, speed_mps=1.0, angle_rad=math.radians(1.0))
    cases = [(name, "all", full) for name in ("twin-otter-single-engine", "gtm-forward-slip", "gtm-aileron-roll")]
    cases += [("gtm-forward-slip", "offset only", dict(position_m=5.0, speed_mps=1.0, angle_rad=math.radians(1.0))),
              ("gtm-forward-slip", "mass +5 % only", dict(mass_scale=1.05)),
              ("gtm-forward-slip", "aero spread only", dict(aero_spread=0.1)),
              ("gtm-forward-slip", "offset x 0.2", dict(position_m=1.0, speed_mps=0.2, angle_rad=math.radians(0.2)))]
    plans = {}
    print(f"{'scenario':<26} {'perturbation':<17} {'saturate':<8} {'status':<10} {'t_end [s]':>9} "
          f"{'< 1 m from [s]':>14} {'max after 10 s':>14} {'max after 40 s':>14}")
    for name, label, kw in cases:
        if name not in plans:
            sc = load_scenario(name)
            plans[name] = (sc, plan_scenario(sc))
        sc, plan = plans[name]
        p = Perturbation(seed=args.seed if "aero_spread" in kw else None, **kw)
        for saturate in (True, False):
            res, settled, after = fly(plan, sc, p, saturate)
            print(f"{name:<26} {label:<17} {str(saturate):<8} {res.status:<10} {res.t_end:>9.2f} {settled:>14.2f} "
                  f"{after[10]:>14.3g} {after[40]:>14.3g}")


if __name__ == "__main__":
    main()
