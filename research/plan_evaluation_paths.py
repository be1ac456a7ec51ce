"""Whole-plan time of the paper's scenarios under evaluation-path variants, and the plans' differences.

Question: does an optional evaluation path of the planner pay for itself on whole plans (the rule: keep a
path only at >= 1.3x on the path it serves)?  Variants are ``NAME=TREE:BACKEND:TAPE``: a source tree,
the series kernels (``numpy`` or ``compiled``, i.e. ``GFLAT_SERIES_BACKEND``) and, for a tree that still has
``planners/series_tape.py``, the traced stage residuals ``on`` or ``off`` (``-`` for a tree without it).
Each variant plans in its own process (one BLAS thread); the variants are interleaved: every round runs
each variant once, in turn, and each run times ``--inner`` plans of every scenario (bundled settings,
:func:`planners.generalized.plan_scenario`) after one warm-up plan.  Printed: the 1-minute load average
before and after, the median over rounds of each run's median wall and CPU time per plan, the ratios
against the first variant, and the largest difference of every plan's node series (all iterates, all
variables, all coefficients) against the first variant's::

    python research/plan_evaluation_paths.py [--rounds 7] [--inner 5] [--variant NAME=TREE:BACKEND:TAPE ...]

Default variants: this tree with numpy kernels, tape on and off, and compiled kernels, tape on and off
(only ``numpy`` and ``compiled`` when the tree has no tape).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parents[1]
PAPER = ("twin-otter-single-engine", "gtm-forward-slip", "gtm-aileron-roll")

_CHILD = r"""
import functools, importlib.util, json, sys, time
import numpy as np
names, inner, tape, dump = json.loads(sys.argv[1]), int(sys.argv[2]), sys.argv[3], sys.argv[4]
if tape == "off":
    import importlib
    newton = importlib.import_module("planners.newton")
    newton.TapedResidual = functools.partial(newton.TapedResidual, when="never")
elif tape == "on" and importlib.util.find_spec("planners.series_tape") is None:
    raise SystemExit("this tree has no planners/series_tape.py: use TAPE '-'")
from planners.generalized import plan_scenario
from planners.scenario import load_scenario
out = {}
arrays = {}
for name in names:
    sc = load_scenario(name)
    plan = plan_scenario(sc)  # warm-up
    wall, cpu = [], []
    for _ in range(inner):
        w0, c0 = time.perf_counter(), time.process_time()
        plan = plan_scenario(sc)
        cpu.append(time.process_time() - c0)
        wall.append(time.perf_counter() - w0)
    out[name] = {"wall": float(np.median(wall)), "cpu": float(np.median(cpu))}
    for j, it in enumerate(plan.iterates):
        for var, s in it.series.items():
            arrays[f"{name}|{j}|{var}"] = np.asarray(s.coeffs)
np.savez(dump, **arrays)
print(json.dumps(out))
"""


def _variant(text: str) -> tuple:
    try:
        name, spec = text.split("=", 1)
        tree, backend, tape = spec.split(":")
    except ValueError:
        raise SystemExit(f"--variant {text!r}: expected NAME=TREE:BACKEND:TAPE") from None
    if backend not in ("numpy", "compiled") or tape not in ("on", "off", "-"):
        raise SystemExit(f"--variant {text!r}: BACKEND is numpy or compiled, TAPE on, off or -")
    return name, Path(tree).resolve(), backend, tape


def run(variant: tuple, names: list, inner: int, dump: Path) -> dict:
    """Median wall and CPU time per plan of each scenario, from a fresh process of the variant's tree."""
    _, tree, backend, tape = variant
    env = dict(os.environ, PYTHONPATH=str(tree), GFLAT_SERIES_BACKEND=backend)
    for v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        env[v] = "1"
    out = subprocess.run(
        [sys.executable, "-c", _CHILD, json.dumps(names), str(inner), tape, str(dump)],
        cwd=tree,
        env=env,
        capture_output=True,
        text=True,
    )
    if out.returncode:
        raise SystemExit(f"variant {variant[0]} failed: {out.stderr.strip().splitlines()[-1]}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def differences(ref: Path, other: Path) -> dict:
    """Largest absolute and relative (floor 1) difference of the plans' coefficients, per scenario."""
    a, b = np.load(ref), np.load(other)
    worst: dict = {}
    for key in a.files:
        name = key.split("|")[0]
        x, y = a[key], b[key] if key in b.files else None
        if y is None or x.shape != y.shape:
            worst[name] = (np.inf, np.inf)
            continue
        d = float(np.max(np.abs(x - y))) if x.size else 0.0
        r = float(np.max(np.abs(x - y) / np.maximum(1.0, np.abs(x)))) if x.size else 0.0
        w = worst.get(name, (0.0, 0.0))
        worst[name] = (max(w[0], d), max(w[1], r))
    return worst


def main() -> None:
    """Run the interleaved rounds and print the table."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--inner", type=int, default=5)
    ap.add_argument("--scenarios", nargs="+", default=list(PAPER))
    ap.add_argument("--variant", action="append", type=_variant, help="NAME=TREE:BACKEND:TAPE (repeatable)")
    args = ap.parse_args()
    variants = args.variant
    if not variants:
        has_tape = (HERE / "planners" / "series_tape.py").exists()
        tapes = ("on", "off") if has_tape else ("-",)
        variants = [
            (f"{b}{'' if t == '-' else ' tape ' + t}", HERE, b, t) for b in ("numpy", "compiled") for t in tapes
        ]
    load0 = os.getloadavg()[0]
    times: dict = {v[0]: {n: {"wall": [], "cpu": []} for n in args.scenarios} for v in variants}
    with tempfile.TemporaryDirectory() as tmp:
        dumps = {v[0]: Path(tmp) / f"{i}.npz" for i, v in enumerate(variants)}
        for _ in range(args.rounds):
            for v in variants:
                res = run(v, args.scenarios, args.inner, dumps[v[0]])
                for n, t in res.items():
                    times[v[0]][n]["wall"].append(t["wall"])
                    times[v[0]][n]["cpu"].append(t["cpu"])
        diffs = {v[0]: differences(dumps[variants[0][0]], dumps[v[0]]) for v in variants[1:]}
    load1 = os.getloadavg()[0]
    print(f"load average (1 min): {load0:.2f} before, {load1:.2f} after; {os.cpu_count()} CPUs")
    print(f"{args.rounds} rounds x {args.inner} plans per variant and scenario; medians [ms]; ratio = first / this")
    ref = variants[0][0]
    for n in args.scenarios:
        print(f"\n{n}")
        rw = statistics.median(times[ref][n]["wall"])
        rc = statistics.median(times[ref][n]["cpu"])
        for v in variants:
            w = statistics.median(times[v[0]][n]["wall"])
            c = statistics.median(times[v[0]][n]["cpu"])
            line = f"  {v[0]:<22} wall {1e3 * w:8.1f}  cpu {1e3 * c:8.1f}  ratio wall {rw / w:5.2f}  cpu {rc / c:5.2f}"
            if v[0] in diffs:
                d, r = diffs[v[0]][n]
                line += f"  max |diff| {d:.2e} (rel {r:.2e})"
            print(line)


if __name__ == "__main__":
    main()
