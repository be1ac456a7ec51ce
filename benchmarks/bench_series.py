"""Micro-benchmark of :mod:`planners.series`: numpy reference against compiled (numba) kernels.

Prints, for each series operation and truncation order, the median time of one operation
(microseconds) with the numpy kernels and with the compiled ones, and their ratio.  The two
kernel sets are timed interleaved in one process (the kernel set of :mod:`planners.series` is
swapped between timing runs; the library itself reads its backend once, from
``GFLAT_SERIES_BACKEND``).  Batches: ``(nodes,)`` real, and the complex-step batch
``(5, nodes)`` complex of the planner's Jacobians::

    python benchmarks/bench_series.py [--nodes 81] [--orders 5 13 23]

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


def main() -> None:
    """Run the benchmark and print a table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--nodes", type=int, default=81)
    parser.add_argument("--orders", type=int, nargs="+", default=[5, 13, 23])
    parser.add_argument("--repeats", type=int, default=7)
    args = parser.parse_args()
    S._CompiledKernels.mul(np.ones((2, 1)), np.ones((2, 1)))  # load the compiled kernels before timing
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
