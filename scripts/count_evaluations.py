"""Count the stage-residual evaluations of one plan per bundled paper scenario (planning cost, docs/planning.md).

Every call of a stage residual handed to :func:`planners.newton.newton_series` is counted (pointwise,
series, with or without the complex-step batch).  Usage: ``python scripts/count_evaluations.py``.
"""

from __future__ import annotations

import importlib

from planners.generalized import plan_scenario
from planners.scenario import load_scenario

flat = importlib.import_module("planners.flat")
newton = importlib.import_module("planners.newton")


def main() -> None:
    calls = [0]
    original = newton.newton_series

    def counting(residual, *args, **kw):
        def counted(*a, **k):
            calls[0] += 1
            return residual(*a, **k)
        return original(counted, *args, **kw)

    flat.newton_series = counting
    try:
        for name in ("gtm-aileron-roll", "twin-otter-single-engine", "gtm-forward-slip"):
            sc = load_scenario(name)
            calls[0] = 0
            plan = plan_scenario(sc)
            print(f"{name:<26} J = {plan.J}, {len(sc.t_nodes)} nodes: {calls[0]} stage-residual evaluations")
    finally:
        flat.newton_series = original


if __name__ == "__main__":
    main()
