"""Numbers of issue 4's verification (tests 8(b) and 8(c)) for the paper's scenarios.

For each bundled paper scenario: the full-model equation residual at the nodes
for every iterate j (and its ratio between iterates), and the maximum
deviation of the full model flown open loop from the planned initial state
with the controls of iterate j = 0 and j = J.

Usage: ``python research/planning_report.py``
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's packages, not an installed copy

import numpy as np

from gna.simulate import simulate
from planners.generalized import plan_scenario
from planners.scenario import load_scenario

SCENARIOS = ("twin-otter-single-engine", "gtm-forward-slip", "gtm-aileron-roll")
ANGLES = ("gamma", "chi", "alpha", "beta", "mu")


def main() -> None:
    for name in SCENARIOS:
        sc = load_scenario(name)
        plan = plan_scenario(sc)
        res = [float(plan.equation_residuals("full", j).abs().max().max()) for j in range(plan.J + 1)]
        print(f"{name} (J = {plan.J}, {len(plan.t_nodes)} nodes)")
        print("  8(b) full-model residual at the nodes, max over the 12 equations:")
        print("       " + "  ".join(f"j={j}: {r:.2e}" for j, r in enumerate(res)))
        print("       ratio per iteration: " + "  ".join(f"{a / b:.1f}" for a, b in zip(res, res[1:])))
        for j in (0, plan.J):
            r = simulate(
                sc.aircraft, plan.control_function(j), (plan.t0, plan.t1), plan.initial_state(j), env=sc.env, dt_out=0.1
            )
            ref = plan.to_dataframe(r.df.index.values, j=j)
            pos = np.sqrt((r.df["x"] - ref["x"]) ** 2 + (r.df["y"] - ref["y"]) ** 2 + (r.df["z"] - ref["z"]) ** 2)
            ang = max(float((r.df[k] - ref[k]).abs().max()) for k in ANGLES)
            status = "" if r.completed else f" ({r.status} at t = {r.t_end:.3g} s)"
            print(
                f"  8(c) open loop with the j = {j} controls over {plan.t0:g}..{r.t_end:g} s: max position "
                f"deviation {pos.max():.3g} m, max angle deviation {ang:.3g} rad{status}"
            )


if __name__ == "__main__":
    main()
