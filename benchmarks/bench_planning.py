"""Planning time of the paper's scenarios (issue 4, point 9).

Prints, for each bundled scenario, the best-of-N wall time of the whole plan
(all nodes together, array code) for J = 0 and J = 4 (and the scenario's own
J when different), on one core (BLAS threads pinned to 1).  Goal: <= 0.3 s
per scenario at J = 4.  The paper reports 647-1279 s in Maple.

Usage: ``python benchmarks/bench_planning.py [--repeat N]``
"""

from __future__ import annotations

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import time  # noqa: E402

from planners.generalized import plan_scenario  # noqa: E402
from planners.scenario import list_scenarios, load_scenario  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    print(f"{'scenario':<28} {'nodes':>5} {'J':>3} {'best [s]':>9} {'median [s]':>10}  per-iterate [s]")
    for name in list_scenarios():
        sc = load_scenario(name)
        for J in sorted({0, 4, sc.J}):
            plan_scenario(sc, J=J)  # warm-up (imports, caches)
            times, last = [], None
            for _ in range(args.repeat):
                t0 = time.perf_counter()
                last = plan_scenario(sc, J=J)
                times.append(time.perf_counter() - t0)
            times.sort()
            per = " ".join(f"{v:.3f}" for v in last.timings.values())
            print(f"{name:<28} {len(sc.t_nodes):>5} {J:>3} {times[0]:>9.3f} {times[len(times) // 2]:>10.3f}  {per}")


if __name__ == "__main__":
    main()
