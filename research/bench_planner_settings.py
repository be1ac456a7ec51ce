"""The planner's time and open-loop accuracy over its settings (node step, output order e, J).

For each combination of ``--step``, ``--e`` and ``--J`` a scenario is planned once (warm-up, and the
accuracy, which is deterministic), then ``--repeat`` times more for the time (median wall and CPU);
the accuracy is :func:`planners.verify.open_loop_error` (the planned controls flown open loop on the
full model from the plan's own initial state, DOP853, rtol = atol = 1e-10).  A plan that fails (its
cost bound, a Newton failure, a singular flat output) is listed with its one-line reason.

Use it to choose a scenario file's ``[time] step`` and ``[generalized] e, J`` for an accuracy, and to
see where the planner's cost goes with accuracy (docs/collocation.md, "Planner settings").  The series
kernels are the process's (``GFLAT_SERIES_BACKEND=compiled`` for the compiled ones).

Usage::

    python research/bench_planner_settings.py gtm-forward-slip --e 2,3 --J 8,9,10
    python research/bench_planner_settings.py twin-otter-single-engine --step 1,2 --e 2 --J 8,9,10 --repeat 5
"""

from __future__ import annotations

import os
import sys

if __package__ in (None, ""):  # run as a script: the repository's packages, not an installed copy
    sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import dataclasses  # noqa: E402
import itertools  # noqa: E402
import math  # noqa: E402
import statistics  # noqa: E402
import time  # noqa: E402

#: Largest number of nodes a ``--step`` may give.
MAX_NODES = 10000


def _numbers(text: str, kind, what: str, ap, top=None) -> list:
    """A comma-separated list of positive numbers (float) or whole numbers in 0..top (int), each once."""
    try:
        values = [kind(v) for v in text.split(",")]
    except ValueError:
        ap.error(f"--{what}: comma-separated numbers, got {text!r}")
    if kind is float:
        if not all(math.isfinite(v) and v > 0 for v in values):
            ap.error(f"--{what}: positive numbers, got {text!r}")
    elif not all(0 <= v <= top for v in values):
        ap.error(f"--{what}: whole numbers from 0 to {top}, got {text!r}")
    return list(dict.fromkeys(values))


def _check_steps(steps: list, sc, ap) -> None:
    span = sc.t1 - sc.t0
    for step in steps:
        nodes = span / step
        if step > span:
            ap.error(f"--step: {step:g} s is longer than the {span:g} s span of {sc.name}")
        if abs(nodes - round(nodes)) > 1e-9 * nodes:
            ap.error(f"--step: {step:g} s does not divide the {span:g} s span of {sc.name} ({nodes:.6g} steps)")
        if nodes > MAX_NODES:
            ap.error(
                f"--step: {step:g} s makes {nodes:.3g} nodes over the {span:g} s span of {sc.name}, above {MAX_NODES}"
            )


def measure(scenario, step: float, e: int, J: int, repeat: int) -> dict:
    """Plan ``scenario`` with the given settings; time and open-loop accuracy.

    Parameters
    ----------
    scenario : planners.scenario.Scenario
        The scenario (its other settings kept).
    step : float
        Node step [s].
    e : int
        Output order e.
    J : int
        Generalized-flatness iterations.
    repeat : int
        Timed plans after the first (medians).

    Returns
    -------
    dict
        ``step, e, J, nodes, wall_s, cpu_s, accuracy_m`` (median times [s], accuracy [m]), or ``error``
        (the plan's one-line reason) when it cannot be planned.
    """
    from gna.errors import GflatError
    from planners.generalized import plan_scenario
    from planners.verify import open_loop_error

    sc = dataclasses.replace(scenario, step=step, e=e)
    row = {"step": step, "e": e, "J": J}
    try:
        plan = plan_scenario(sc, J=J)
        wall, cpu = [], []
        for _ in range(repeat):
            w, c = time.perf_counter(), time.process_time()
            plan_scenario(sc, J=J)
            wall.append(time.perf_counter() - w)
            cpu.append(time.process_time() - c)
        check = open_loop_error(plan)
    except GflatError as exc:  # planning, or the open-loop flight of its controls
        return {**row, "error": str(exc)}
    return {
        **row,
        "nodes": len(plan.t_nodes),
        "feasible": bool(plan.feasible),
        "wall_s": statistics.median(wall),
        "cpu_s": statistics.median(cpu),
        "accuracy_m": check.max_position_error_m,
    }


def main(argv=None) -> None:
    """Run from the command line: bad settings one usage line (exit 2), Ctrl-C one line (exit 130)."""
    try:
        _main(argv)
    except KeyboardInterrupt:
        print("bench_planner_settings: interrupted", file=sys.stderr)
        sys.exit(130)


def _main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenario", help="a bundled scenario name or a scenario file")
    ap.add_argument("--step", default=None, help="node steps [s], comma-separated (default: the scenario's)")
    ap.add_argument("--e", dest="e", default=None, help="output orders e, comma-separated (default: the scenario's)")
    ap.add_argument("--J", dest="J", default=None, help="iterations J, comma-separated (default: the scenario's)")
    ap.add_argument("--repeat", type=int, default=3, help="timed plans per setting (medians)")
    args = ap.parse_args(argv)
    if args.repeat < 1:
        ap.error(f"--repeat: at least 1, got {args.repeat}")
    from gna.errors import GflatError
    from planners.scenario import load_scenario
    from planners.series import BACKEND

    try:
        sc = load_scenario(args.scenario)
    except GflatError as exc:
        ap.exit(2, f"{ap.prog}: error: {exc}\n")
    if isinstance(sc.J, str) and args.J is None:
        ap.error("the scenario's J is 'auto': give --J")
    from planners.flat import MAX_J
    from planners.generalized import MAX_E

    steps = _numbers(args.step, float, "step", ap) if args.step is not None else [sc.step]
    _check_steps(steps, sc, ap)
    orders = _numbers(args.e, int, "e", ap, MAX_E) if args.e is not None else [sc.e]
    iterations = _numbers(args.J, int, "J", ap, MAX_J) if args.J is not None else [sc.J]
    print(f"{sc.name}: span {sc.t1 - sc.t0:g} s, series kernels {BACKEND}; median of {args.repeat} plans")
    print(f"{'step [s]':>8} {'e':>2} {'J':>3} {'nodes':>5} {'wall [s]':>9} {'CPU [s]':>9} {'accuracy [m]':>12}")
    for step, e, J in itertools.product(steps, orders, iterations):
        r = measure(sc, step, e, J, args.repeat)
        head = f"{step:>8g} {e:>2} {J:>3}"
        if "error" in r:
            print(f"{head}  cannot be planned: {r['error']}", flush=True)
        else:
            flag = "" if r["feasible"] else "  (not feasible)"
            print(
                f"{head} {r['nodes']:>5} {r['wall_s']:>9.3f} {r['cpu_s']:>9.3f} {r['accuracy_m']:>12.3g}{flag}",
                flush=True,
            )


if __name__ == "__main__":
    main()
