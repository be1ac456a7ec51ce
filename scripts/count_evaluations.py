"""Count the stage-residual evaluations of one plan per bundled paper scenario (planning cost, docs/planning.md).

Every call of a stage residual handed to :func:`planners.newton.newton_series` is counted, by kind:
``J`` on series with the complex-step Jacobian (a batch of one complex step per unknown), ``R`` on
series, real (chord steps, checks), ``P`` pointwise on plain arrays (order 0: the pointwise Newton and
the constant term of a carried Jacobian; far cheaper than the series ones).  Tracing
(:mod:`planners.series_tape`) is off while counting -- every evaluation runs the residual, eagerly: the
tape changes what an evaluation costs (a replay instead of the model code), not how many there are.
Usage: ``python scripts/count_evaluations.py`` (from a worktree: ``PYTHONPATH=. python scripts/count_evaluations.py``).
"""

from __future__ import annotations

import functools
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
    taped = newton.TapedResidual
    newton.TapedResidual = functools.partial(taped, when="never")
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
        newton.TapedResidual = taped
    # The same plans with the tape: how the series evaluations were done (traced, replayed, eager).
    tapes = []

    def recording(residual, *a, **kw):
        tapes.append(taped(residual, *a, **kw))
        return tapes[-1]

    newton.TapedResidual = recording
    try:
        for name in SCENARIOS:
            tapes.clear()
            plan_scenario(load_scenario(name))
            total = {k: sum(t.counts[k] for t in tapes) for k in ("trace", "replay", "eager")}
            print(
                f"{name:<26} with the tape: {total['trace']} traced, {total['replay']} replayed, "
                f"{total['eager']} eager (pointwise and untraced orders)"
            )
    finally:
        newton.TapedResidual = taped


if __name__ == "__main__":
    main()
