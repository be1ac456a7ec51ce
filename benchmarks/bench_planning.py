"""Planning time of the paper's scenarios: the numpy reference, the native programs (the default) and numba's.

Each variant -- this tree with ``GFLAT_SERIES_BACKEND=numpy``, ``=native`` (the default: the stages as
compiled programs in C), ``=compiled`` (numba), and optionally
another source tree (``--ref``, e.g. a checkout of main) -- plans in its own process (the backend is
read once, at import), one BLAS thread.  The variants are interleaved: every round runs each variant
once, in turn, and each run times ``--inner`` plans of every case after one warm-up plan.  Printed:
the median over rounds of each run's median plan time, and the ratios.  Cases: the scenario's own J
at e = 1 (the bundled setting), and J = 8, e = 3 (series of order e + 4 + 2J = 23, the order the
accuracy work asks for)::

    python benchmarks/bench_planning.py [--rounds 5] [--inner 3] [--ref /work/main [--ref-compiled]] [--scenarios ...]
                                        [--blas-threads 1|default]

The compiled code is loaded (or compiled, on a fresh clone) before the first timed plan; the one-time
cost of that is printed separately (``first use``: import, then the first series operations and the
native library's loading), from a process of its own.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parents[1]
PAPER = ("gtm-aileron-roll", "twin-otter-single-engine", "gtm-forward-slip")

_CHILD = r"""
import json, sys, time
import numpy as np
from planners.generalized import plan_motion
from planners.scenario import load_scenario
cases, inner = json.loads(sys.argv[1]), int(sys.argv[2])
out, settings = {}, {}
for name, J, e in cases:
    sc = load_scenario(name)
    prob = sc.problem()
    key = f"{name} J={J} e={e}" if J is not None else f"{name} (bundled)"
    J = sc.J if J is None else J
    e = getattr(sc, "e", 1) if e is None else e
    plan_motion(prob, sc.t_nodes, J, e=e, name=name, max_cost=float("inf"))  # warm-up
    ts, cs = [], []
    for _ in range(inner):
        t0, c0 = time.perf_counter(), time.process_time()
        plan_motion(prob, sc.t_nodes, J, e=e, name=name, max_cost=float("inf"))
        ts.append(time.perf_counter() - t0)
        cs.append(time.process_time() - c0)
    out[key] = float(np.median(ts))
    out[key + " [CPU]"] = float(np.median(cs))
    settings[key] = f"J = {J}, e = {e}, {len(sc.t_nodes)} nodes"
print(json.dumps({"times": out, "settings": settings}))
"""

_FIRST_USE = r"""
import time
t0 = time.perf_counter()
import planners.series as S
from planners.series import Series
import numpy as np
t1 = time.perf_counter()
a = Series(np.ones((3, 4)))
(a * a) / (a + 1)
if S.BACKEND == "native":
    import planners._native as N
    N.library()
t2 = time.perf_counter()
print(S.BACKEND, f"{t1 - t0:.3f}", f"{t2 - t1:.3f}")
"""


#: BLAS threads of the child processes: "1" (pinned) or "default" (the library's own choice, as `gflat` runs).
BLAS_THREADS = {"value": "1"}
#: case -> tree -> its J, e and node count (the bundled settings differ between trees).
SETTINGS: dict = {}


def _env(tree: Path, backend: str | None) -> dict:
    env = dict(os.environ, PYTHONPATH=str(tree))
    for v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        if BLAS_THREADS["value"] == "1":
            env[v] = "1"
        else:
            env.pop(v, None)
    env.pop("GFLAT_SERIES_BACKEND", None)
    env.setdefault("GFLAT_NATIVE_WAIT", "1")  # a fresh cache: compile before the first plan, not in the background
    if backend:
        env["GFLAT_SERIES_BACKEND"] = backend
    return env


def run_variant(tree: Path, backend: str | None, cases, inner: int) -> dict:
    """Median plan time of each case, from a fresh process of ``tree`` with ``backend``."""
    out = subprocess.run(
        [sys.executable, "-c", _CHILD, json.dumps(cases), str(inner)],
        cwd=tree,
        env=_env(tree, backend),
        capture_output=True,
        text=True,
        check=True,
    )
    res = json.loads(out.stdout.strip().splitlines()[-1])
    for key, text in res["settings"].items():
        SETTINGS.setdefault(key, {})[str(tree)] = text
    return res["times"]


def first_use(tree: Path, backend: str) -> str:
    """Import time of planners.series and time of the first series operations (kernel loading)."""
    out = subprocess.run(
        [sys.executable, "-c", _FIRST_USE],
        cwd=tree,
        env=_env(tree, backend),
        capture_output=True,
        text=True,
        check=True,
    )
    name, imp, first = out.stdout.split()
    return f"{name}: import {imp} s, first operations {first} s"


def main() -> None:
    """Run the interleaved rounds and print the table."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--inner", type=int, default=3)
    ap.add_argument("--ref", help="a reference source tree (e.g. a checkout of main), numpy kernels")
    ap.add_argument("--ref-compiled", action="store_true", help="the reference tree with compiled kernels too")
    ap.add_argument("--scenarios", nargs="+", default=list(PAPER))
    ap.add_argument("--no-high-order", action="store_true", help="skip the J = 8, e = 3 cases")
    ap.add_argument(
        "--blas-threads",
        choices=("1", "default"),
        default="1",
        help="pin BLAS to one thread in the children (default), or leave it to the library",
    )
    args = ap.parse_args()
    BLAS_THREADS["value"] = args.blas_threads
    cases = [(n, None, None) for n in args.scenarios]  # each tree's bundled J, e and grid
    if not args.no_high_order:
        cases += [(n, 8, 3) for n in args.scenarios]
    variants = {"numpy": (HERE, "numpy"), "native": (HERE, "native"), "compiled": (HERE, "compiled")}
    if args.ref:
        variants = {"ref": (Path(args.ref).resolve(), None), **variants}
        if args.ref_compiled:
            variants = {"ref_c": (Path(args.ref).resolve(), "compiled"), **variants}
    print("first use (own process):", "; ".join(first_use(HERE, b) for b in ("numpy", "native", "compiled")))
    results: dict[str, list[dict]] = {v: [] for v in variants}
    t_start = time.perf_counter()
    for r in range(args.rounds):
        for v, (tree, backend) in variants.items():
            results[v].append(run_variant(tree, backend, cases, args.inner))
        print(f"  round {r + 1}/{args.rounds} done ({time.perf_counter() - t_start:.0f} s)", file=sys.stderr)
    keys = list(results["numpy"][0])
    med = {v: {k: float(np.median([run.get(k, np.nan) for run in runs])) for k in keys} for v, runs in results.items()}
    head = f"{'case':<40}" + "".join(f"{v + ' [s]':>14}" for v in variants) + f"{'numpy/native':>14}"
    head += f"{'numpy/compiled':>16}"
    if args.ref:
        head += f"{'ref/numpy':>11}{'ref/compiled':>14}"
        if args.ref_compiled:
            head += f"{'ref_c/compiled':>16}"
    threads = "1 BLAS thread" if args.blas_threads == "1" else "BLAS threads left to the library"
    print(
        f"median over {args.rounds} interleaved rounds of the median of {args.inner} plans ({threads}); wall, then CPU"
    )
    print(head)
    keys = [k for k in keys if not k.endswith(" [CPU]")] + [k for k in keys if k.endswith(" [CPU]")]
    for k in keys:
        row = f"{k:<40}" + "".join(f"{med[v][k]:>14.4f}" for v in variants)
        row += f"{med['numpy'][k] / med['native'][k]:>14.2f}{med['numpy'][k] / med['compiled'][k]:>16.2f}"
        if args.ref:
            row += f"{med['ref'][k] / med['numpy'][k]:>11.2f}{med['ref'][k] / med['compiled'][k]:>14.2f}"
            if args.ref_compiled:
                row += f"{med['ref_c'][k] / med['compiled'][k]:>16.2f}"
        print(row)
    for k in keys:
        trees = SETTINGS.get(k, {})
        if len(set(trees.values())) > 1:
            print(f"  {k}: " + "; ".join(f"{Path(t).name}: {v}" for t, v in trees.items()))


if __name__ == "__main__":
    main()
