"""Micro-benchmark of :mod:`planners.series`: numpy reference against compiled (numba) kernels.

Prints, for each series operation and truncation order, the median time of one operation
(microseconds) with the numpy kernels and with the compiled ones, and their ratio.  The two
kernel sets are timed interleaved in one process (the kernel set of :mod:`planners.series` is
swapped between timing runs; the library itself reads its backend once, from
``GFLAT_SERIES_BACKEND``).  Batches: ``(nodes,)`` real, and the complex-step batch
``(5, nodes)`` complex of the planner's Jacobians::

    python benchmarks/bench_series.py [--nodes 81] [--orders 5 13 23]

With ``--tape``: one stage-residual evaluation of the roll plan (gtm-aileron-roll, 17 nodes, its
first generalized-flatness iterate), eager against the replay of its traced program
(:mod:`planners.series_tape`) and against the trace itself, at working orders 2, 10, 18 (stage 4 at
most 16, its order in that plan), real unknowns ``(nodes,)`` and the complex-step batch
``(n, nodes)``, with both kernel sets::

    python benchmarks/bench_series.py --tape [--orders 2 10 18]
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this tree's planners, not an installed one
for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import time  # noqa: E402
from collections.abc import Callable  # noqa: E402

import numpy as np  # noqa: E402

import planners.series as S  # noqa: E402
from planners.series import Series  # noqa: E402

KERNELS = {"numpy": S._NumpyKernels, "compiled": S._CompiledKernels}


def time_us(fn: Callable[[], object], loops: int) -> float:
    """Time per call in microseconds of ``loops`` calls.

    Parameters
    ----------
    fn : callable
        Zero-argument function.
    loops : int
        Number of calls.

    Returns
    -------
    float
    """
    t = time.perf_counter()
    for _ in range(loops):
        fn()
    return (time.perf_counter() - t) / loops * 1e6


def interleaved(make: Callable[[], Callable[[], object]], repeats: int) -> dict:
    """Median time per call of ``make()`` under each kernel set, timing runs interleaved.

    Parameters
    ----------
    make : callable
        Returns the zero-argument function to time (called once per kernel set and run, so that
        memoised results are not reused).
    repeats : int
        Timing runs per kernel set.

    Returns
    -------
    dict
        Kernel-set name -> median microseconds per call.
    """
    loops = {}
    for name, k in KERNELS.items():
        S._K = k
        fn = make()
        fn()
        n = 1
        while time_us(fn, n) * n < 2e3 and n < 4096:
            n *= 2
        loops[name] = n
    times: dict[str, list[float]] = {name: [] for name in KERNELS}
    for _ in range(repeats):
        for name, k in KERNELS.items():
            S._K = k
            fn = make()
            times[name].append(time_us(fn, loops[name]))
    return {name: float(np.median(v)) for name, v in times.items()}


def _roll_residuals() -> dict:
    """The stage-2 and stage-4 residuals of the roll plan's first iterate, with their solutions."""
    import importlib

    from planners.generalized import plan_scenario
    from planners.scenario import load_scenario

    flat = importlib.import_module("planners.flat")
    original = flat.newton_series
    captured = []

    def capture(residual, u0, order, **kw):
        u, rep = original(residual, u0, order, **kw)
        captured.append((residual, u, order))
        return u, rep

    flat.newton_series = capture
    try:
        plan_scenario(load_scenario("gtm-aileron-roll"))
    finally:
        flat.newton_series = original
    return {"stage 2": captured[0], "stage 4": captured[1]}


def _unknowns(u: list, k: int, kind: str) -> list:
    """The unknowns at order ``k``: real ``(nodes,)``, or the complex-step batch of planners.newton."""
    stacked = np.stack([np.real(x.truncate(min(k, x.order)).coeffs) for x in u])
    if kind == "real":
        return [Series(stacked[j]) for j in range(len(u))]
    n = len(u)
    pert = np.broadcast_to(stacked, (n,) + stacked.shape).astype(complex)
    for j in range(n):
        pert[j, j, ..., 0] += 1e-30j
    return [Series(pert[:, j]) for j in range(n)]


def tape_table(orders: list, repeats: int) -> None:
    """Print eager / trace / replay times of the roll's stage residuals (microseconds per evaluation).

    Parameters
    ----------
    orders : list of int
        Working orders (stage 4 capped at its order in the plan).
    repeats : int
        Interleaved timing runs per kernel set and mode.
    """
    from planners.series_tape import TapedResidual, trace

    saved = S._K
    residuals = _roll_residuals()
    print(
        f"stage residuals of gtm-aileron-roll (17 nodes, first iterate): microseconds per evaluation, median "
        f"of {repeats} interleaved runs; trace = the traced evaluation (the first one of a Newton call)"
    )
    print(
        f"{'residual':<10}{'k':>4}{'unknowns':>12}{'kernels':>10}{'eager':>9}{'trace':>9}{'replay':>9}"
        f"{'eager/replay':>14}{'trace/eager':>13}"
    )
    for label, (residual, u, top) in residuals.items():
        for k in orders:
            k = min(k, top)
            for kind in ("real", "complex"):
                x = _unknowns(u, k, kind)
                for kname, kern in KERNELS.items():
                    S._K = kern
                    tr = TapedResidual(residual, "first")
                    tr(x, k)
                    tape = tr.tapes[k]
                    ins = [v._c for v in x]
                    # fresh series objects per evaluation, as Newton makes them (a series memoises its sin/cos)
                    modes = {
                        "eager": lambda: residual([Series._wrap(c) for c in ins], k),  # noqa: B023
                        "trace": lambda: trace(residual, [Series._wrap(c) for c in ins], k),  # noqa: B023
                        "replay": lambda: tape.run(ins),  # noqa: B023
                    }
                    loops = {m: max(1, int(3e3 / max(1.0, time_us(f, 3)))) for m, f in modes.items()}
                    t = {m: [] for m in modes}
                    for _ in range(repeats):
                        for m, f in modes.items():
                            t[m].append(time_us(f, loops[m]))
                    med = {m: float(np.median(v)) for m, v in t.items()}
                    shape = "(n, nodes)" if kind == "complex" else "(nodes,)"
                    print(
                        f"{label:<10}{k:>4}{shape:>12}{kname:>10}{med['eager']:>9.0f}{med['trace']:>9.0f}"
                        f"{med['replay']:>9.0f}{med['eager'] / med['replay']:>14.2f}"
                        f"{med['trace'] / med['eager']:>13.2f}"
                    )
    S._K = saved


def main() -> None:
    """Run the benchmark and print a table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--nodes", type=int, default=81)
    parser.add_argument("--orders", type=int, nargs="+", default=None)
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--tape", action="store_true", help="stage residuals: eager, traced, replayed")
    args = parser.parse_args()
    S._CompiledKernels.mul(np.ones((2, 1)), np.ones((2, 1)))  # load the compiled kernels before timing
    if args.tape:
        tape_table(args.orders or [2, 10, 18], args.repeats)
        return
    args.orders = args.orders or [5, 13, 23]
    saved = S._K
    rng = np.random.default_rng(0)
    ops: dict[str, Callable[[Series, Series], Callable[[], object]]] = {
        "a * b": lambda a, b: lambda: a * b,
        "a / b": lambda a, b: lambda: a / b,
        "sin+cos": lambda a, b: lambda: Series(a.coeffs).sincos(),
        "sinh+cosh": lambda a, b: lambda: Series(a.coeffs).sinhcosh(),
        "exp": lambda a, b: lambda: np.exp(a),
        "log": lambda a, b: lambda: np.log(b),
        "sqrt": lambda a, b: lambda: np.sqrt(b),
        "a ** 2.5": lambda a, b: lambda: b**2.5,
        "a ** 3": lambda a, b: lambda: a**3,
        "tan": lambda a, b: lambda: np.tan(a),
        "tanh": lambda a, b: lambda: np.tanh(a),
        "arctan": lambda a, b: lambda: np.arctan(a),
        "arcsin": lambda a, b: lambda: np.arcsin(0.5 * a),
        "arctan2(a, b)": lambda a, b: lambda: np.arctan2(a, b),
        "compose": lambda a, b: lambda: b.compose(a - a.constant_term),
        "a + b": lambda a, b: lambda: a + b,
        "2.0 * a": lambda a, b: lambda: 2.0 * a,
    }
    print(
        f"planners.series: numpy / compiled kernels, median of {args.repeats} interleaved runs, "
        f"microseconds per operation"
    )
    for batch, dtype in (((args.nodes,), float), ((5, args.nodes), complex)):
        print(
            f"\nbatch {batch} {dtype.__name__}"
            + ("  (data (nodes,) real times complex-step batch)" if dtype is complex else "")
        )
        print(
            f"{'operation':<16}" + "".join(f"{'n=' + str(n) + ' np':>12}{'comp':>9}{'ratio':>7}" for n in args.orders)
        )
        rows: dict[str, list] = {name: [] for name in ops}
        for n in args.orders:
            shape = batch + (n + 1,)
            decay = 0.5 ** np.arange(n + 1)
            ca = rng.uniform(-1, 1, shape) * decay
            cb = rng.uniform(-1, 1, shape) * decay + np.eye(1, n + 1)[0] * 2.0  # c0 in [1, 3]
            if dtype is complex:
                ca = ca + 1e-3j * rng.uniform(-1, 1, shape)
                a, b = Series(ca), Series(cb[0])  # b: a (nodes,) real series, broadcast
            else:
                a, b = Series(ca), Series(cb)
            for name, make in ops.items():
                r = interleaved(lambda: make(a, b), args.repeats)  # noqa: B023
                rows[name].append(r)
        for name, vals in rows.items():
            print(
                f"{name:<16}"
                + "".join(f"{r['numpy']:>12.1f}{r['compiled']:>9.1f}{r['numpy'] / r['compiled']:>7.2f}" for r in vals)
            )
    S._K = saved


if __name__ == "__main__":
    main()
