"""Count the stage-residual evaluations of one plan per bundled paper scenario (planning cost, docs/planning.md).

Every call of a stage residual handed to :func:`planners.newton.newton_series` is counted, by kind:
``J`` on series with the complex-step Jacobian (a batch of one complex step per unknown), ``R`` on
series, real (chord steps, checks), ``P`` pointwise on plain arrays (order 0: the pointwise Newton and
the constant term of a carried Jacobian; far cheaper than the series ones).
Usage: ``python research/count_evaluations.py``.
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's packages, not an installed copy

import importlib

import numpy as np

from planners.generalized import plan_scenario
from planners.scenario import load_scenario

flat = importlib.import_module("planners.flat")
newton = importlib.import_module("planners.newton")

#: The bundled paper scenarios, one plan each.
SCENARIOS = ("gtm-aileron-roll", "twin-otter-single-engine", "gtm-forward-slip")


def _kind(u, k) -> str:
    """``P`` (order 0, plain arrays), ``J`` (complex series: the Jacobian's complex steps) or ``R``."""
    if k == 0:
        return "P"
    return "J" if any(np.iscomplexobj(getattr(x, "coeffs", x)) for x in u) else "R"


def main() -> None:
    calls = {"J": 0, "R": 0, "P": 0}
    original = newton.newton_series

    def counting(residual, *args, **kw):
        def counted(u, k, *a, **k2):
            calls[_kind(u, k)] += 1
            return residual(u, k, *a, **k2)

        return original(counted, *args, **kw)

    flat.newton_series = counting
    try:
        for name in SCENARIOS:
            sc = load_scenario(name)
            for key in calls:
                calls[key] = 0
            plan = plan_scenario(sc)
            print(
                f"{name:<26} J = {plan.J}, {len(sc.t_nodes)} nodes: {sum(calls.values())} stage-residual "
                f"evaluations: {calls['J']} J (series, complex-step Jacobian), {calls['R']} R (series, real), "
                f"{calls['P']} P (pointwise)"
            )
    finally:
        flat.newton_series = original


if __name__ == "__main__":
    main()
