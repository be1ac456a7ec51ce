"""Speed of the fitting pipeline (no assertions).

Source evaluation per point (GTM database vectorised, JSBSim through ``run_ic``,
linear model), the least-squares fit of the 45 terms, and the regeneration of
each bundled fitted aircraft (sampling + fit + trim check)::

    python research/bench_fit.py [--points 5000] [--repeats 3]
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's packages, not an installed copy

import argparse
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from gna.aero import AeroState
from gna.fit import fit_source, gna45_structure
from gna.fit.regenerate import SPECS, regenerate


def _median_time(fn, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times)


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--points", type=int, default=5000)
    p.add_argument("--repeats", type=int, default=3)
    args = p.parse_args(argv)
    rng = np.random.default_rng(0)
    n = args.points
    st = AeroState(
        rng.uniform(-0.05, 0.25, n),
        rng.uniform(-0.2, 0.2, n),
        rng.uniform(-0.1, 0.1, n),
        rng.uniform(-0.005, 0.005, n),
        rng.uniform(-0.05, 0.05, n),
        rng.uniform(-0.3, 0.3, n),
        rng.uniform(-0.3, 0.3, n),
        rng.uniform(-0.2, 0.2, n),
    )
    print(f"source evaluation, {n} points (median of {args.repeats}):")
    for ident in SPECS:
        src = SPECS[ident].make_source()
        t = _median_time(lambda: src.coefficients(st), args.repeats)  # noqa: B023
        print(f"  {ident:<11} {src.name:<70} {1e6 * t / n:8.2f} us/point")
    print("fit of the 45 terms (sampling included), regeneration of each file (fit + trim check):")
    for ident, spec in SPECS.items():
        src = spec.make_source()
        design = spec.design(src)
        t_fit = _median_time(lambda: fit_source(src, gna45_structure(), design), args.repeats)  # noqa: B023
        with tempfile.TemporaryDirectory() as tmp:
            t_reg = _median_time(lambda: regenerate(Path(tmp), [ident]), args.repeats)  # noqa: B023
        print(f"  {ident:<11} fit {t_fit:6.2f} s   regenerate {t_reg:6.2f} s")


if __name__ == "__main__":
    main()
