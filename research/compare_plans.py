"""Plans of the paper's scenarios from two source trees, compared node series by node series.

Runs the planner of each tree in its own process (``PYTHONPATH`` = the tree, the series backend
from ``GFLAT_SERIES_BACKEND`` or ``--backend``) and prints, per scenario, the largest difference
of every iterate's node series, coefficient k weighted by step^k (its contribution over one node
interval) and relative to the largest weighted coefficient of that variable (absolute for a variable
that is zero to rounding, below 1e-12)::

    python research/compare_plans.py --ref /work/main [--backend numpy|compiled]

Exit status 1 when a difference exceeds ``--tol`` (default 1e-10).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

PAPER = ("gtm-aileron-roll", "twin-otter-single-engine", "gtm-forward-slip")

_DUMP = """
import sys, numpy as np
from planners.generalized import plan_scenario
from planners.scenario import load_scenario
out = {}
for name in sys.argv[2:]:
    plan = plan_scenario(load_scenario(name))
    out[f"{name}/step"] = np.min(np.diff(plan.t_nodes))
    for j, it in enumerate(plan.iterates):
        for var, s in it.series.items():
            out[f"{name}/{j}/{var}"] = np.asarray(s.coeffs)
np.savez(sys.argv[1], **out)
"""


def dump(tree: Path, target: Path, backend: str | None, names) -> None:
    """Plan ``names`` with the code of ``tree`` and save every iterate's node series to ``target``."""
    env = dict(os.environ, PYTHONPATH=str(tree), OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")
    if backend:
        env["GFLAT_SERIES_BACKEND"] = backend
    subprocess.run([sys.executable, "-c", _DUMP, str(target), *names], cwd=tree, env=env, check=True)


def main() -> int:
    """Compare and print; 0 when every difference is within ``--tol``."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--ref", required=True, help="reference source tree (e.g. a checkout of main)")
    ap.add_argument("--tree", default=str(Path(__file__).resolve().parents[1]), help="tree under test")
    ap.add_argument("--backend", choices=("numpy", "compiled"), help="series backend of the tree under test")
    ap.add_argument("--ref-backend", choices=("numpy", "compiled"), help="series backend of the reference")
    ap.add_argument("--tol", type=float, default=1e-10)
    ap.add_argument("scenarios", nargs="*", default=list(PAPER))
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        a, b = Path(tmp) / "ref.npz", Path(tmp) / "new.npz"
        dump(Path(args.ref), a, args.ref_backend, args.scenarios)
        dump(Path(args.tree), b, args.backend, args.scenarios)
        ra, rb = np.load(a), np.load(b)
        worst_all = 0.0
        for name in args.scenarios:
            keys = [k for k in ra.files if k.startswith(name + "/") and k != f"{name}/step"]
            step = float(ra[f"{name}/step"])
            missing = sorted(set(keys) ^ {k for k in rb.files if k.startswith(name + "/") and k != f"{name}/step"})
            worst, where = 0.0, ""
            for k in keys:
                if k not in rb.files:
                    continue
                x, y = ra[k], rb[k]
                if x.shape != y.shape:
                    worst, where = np.inf, f"{k} shape {x.shape} vs {y.shape}"
                    break
                # coefficient k weighted by step^k (its contribution over one node interval), relative to
                # the largest weighted coefficient of the variable (its scale over the grid)
                w = step ** np.arange(x.shape[-1])
                scale = np.max(np.abs(x) * w)
                # a variable that is zero to rounding (beta = 0 prescribed: ~1e-15) is compared absolutely
                d = float(np.max(np.abs(x - y) * w)) / (scale if scale >= 1e-12 else 1.0)
                if d > worst:
                    worst, where = d, k
            worst_all = max(worst_all, worst)
            print(
                f"{name:<28} {len(keys):>4} series  max scaled difference {worst:.2e}  ({where})"
                + (f"  missing: {missing[:4]}" if missing else "")
            )
    return 0 if worst_all <= args.tol else 1


if __name__ == "__main__":
    sys.exit(main())
