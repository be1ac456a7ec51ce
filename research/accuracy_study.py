"""Open-loop accuracy and plan time of the paper's scenarios by grid step, J, output order e and formula.

For each setting ``scenario,J,e,step``: the plan's CPU and wall time (median of interleaved
repetitions of all the settings given, one core), then the issue's accuracy
(:func:`planners.verify.open_loop_error`) with the paper's two-sided formula and with Hermite
interpolation between nodes, and the full-model residual of the last iterate.  Prints the rows of the
table in docs/planning.md ("Accuracy between nodes, output order e, and J").

Usage::

    python research/accuracy_study.py [--repeat N] roll,7,2,0.5 to,6,1,2 fs,6,2,6 ...

(``roll``, ``to``, ``fs``: the three paper scenarios; with no setting, the bundled ones.)
"""

from __future__ import annotations

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np  # noqa: E402

from planners.generalized import plan_motion  # noqa: E402
from planners.scenario import load_scenario  # noqa: E402
from planners.verify import open_loop_error  # noqa: E402

SHORT = {"roll": "gtm-aileron-roll", "to": "twin-otter-single-engine", "fs": "gtm-forward-slip"}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("settings", nargs="*", help="scenario,J,e,step (scenario: roll, to, fs or a bundled name)")
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    specs = args.settings
    if not specs:
        specs = []
        for short, name in SHORT.items():
            sc = load_scenario(name)
            specs.append(f"{short},{sc.J},{sc.e},{sc.step:g}")
    cands = []
    for spec in specs:
        n, J, e, step = spec.split(",")
        sc = load_scenario(SHORT.get(n, n))
        sc.step = float(step)
        cands.append((spec, sc, int(J), int(e)))
    cpu = {c[0]: [] for c in cands}
    wall = {c[0]: [] for c in cands}
    plans = {}
    for spec, sc, J, e in cands:  # warm-up  # noqa: B007
        plan_motion(sc.problem(), sc.t_nodes, J, e=e, name=sc.name)
    for _ in range(args.repeat):
        for spec, sc, J, e in cands:
            t, w = time.process_time(), time.perf_counter()
            plans[spec] = plan_motion(sc.problem(), sc.t_nodes, J, e=e, name=sc.name)
            cpu[spec].append(time.process_time() - t)
            wall[spec].append(time.perf_counter() - w)
    print(
        "| scenario | step [s] | nodes | J | e | paper formula [m] | Hermite [m] | plan CPU [s] | plan wall [s] "
        "| residual |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    for spec, sc, J, e in cands:
        p = plans[spec]
        acc = {}
        for formula in ("paper", "hermite"):
            p.interpolation = formula
            acc[formula] = open_loop_error(p).max_position_error_m
        print(
            f"| {sc.name} | {sc.step:g} | {len(sc.t_nodes)} | {J} | {e} | {acc['paper']:.2g} | "
            f"{acc['hermite']:.2g} | {np.median(cpu[spec]):.3f} | {np.median(wall[spec]):.3f} | "
            f"{p.iterate_residuals()[-1]:.1e} |",
            flush=True,
        )


if __name__ == "__main__":
    main()
