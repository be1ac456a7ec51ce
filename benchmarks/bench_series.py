"""Micro-benchmark of :mod:`planners.series` (no assertions).

Prints the best-of-repeats time, in microseconds, of one series operation on a
batch of expansion points, for a few truncation orders::

    python benchmarks/bench_series.py [--batch 200] [--orders 5 13 21]
"""

from __future__ import annotations

import argparse
import time
from typing import Callable

import numpy as np

from planners.series import Series


def best_time_us(fn: Callable[[], object], repeats: int = 15, min_time: float = 0.01) -> float:
    """Best time per call in microseconds over ``repeats`` timing runs.

    Parameters
    ----------
    fn : callable
        Zero-argument function to time.
    repeats : int, optional
        Number of timing runs; the minimum is reported.
    min_time : float, optional
        Approximate duration (s) of one timing run, used to pick the loop count.

    Returns
    -------
    float
    """
    fn()
    loops = 1
    while True:
        t = time.perf_counter()
        for _ in range(loops):
            fn()
        if time.perf_counter() - t >= min_time / 4 or loops >= 1 << 20:
            break
        loops *= 2
    best = float("inf")
    for _ in range(repeats):
        t = time.perf_counter()
        for _ in range(loops):
            fn()
        best = min(best, (time.perf_counter() - t) / loops)
    return best * 1e6


def main() -> None:
    """Run the benchmark and print a table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--batch", type=int, default=200)
    parser.add_argument("--orders", type=int, nargs="+", default=[5, 13, 21])
    args = parser.parse_args()

    rng = np.random.default_rng(0)
    ops: dict[str, Callable[[Series, Series], Callable[[], object]]] = {
        "a * b": lambda a, b: lambda: a * b,
        "a / b": lambda a, b: lambda: a / b,
        "sin+cos (fresh)": lambda a, b: lambda: Series(a.coeffs).sincos(),
        "exp": lambda a, b: lambda: np.exp(a),
        "sqrt": lambda a, b: lambda: np.sqrt(b),
        "a ** 2.5": lambda a, b: lambda: b ** 2.5,
        "tan": lambda a, b: lambda: np.tan(a),
        "arctan2(a, b)": lambda a, b: lambda: np.arctan2(a, b),
        "a + b": lambda a, b: lambda: a + b,
        "2.0 * a": lambda a, b: lambda: 2.0 * a,
    }
    print(f"planners.series benchmark, batch {args.batch}, best of 15, microseconds per operation")
    print(f"{'operation':<18}" + "".join(f"{'n=' + str(n):>10}" for n in args.orders))
    rows: dict[str, list[float]] = {name: [] for name in ops}
    for n in args.orders:
        shape = (args.batch, n + 1)
        decay = 0.5 ** np.arange(n + 1)
        a = Series(rng.uniform(-1, 1, shape) * decay)
        b = Series(rng.uniform(-1, 1, shape) * decay + np.eye(1, n + 1) * 2.0)  # c0 in [1, 3]
        for name, make in ops.items():
            rows[name].append(best_time_us(make(a, b)))
    for name, vals in rows.items():
        print(f"{name:<18}" + "".join(f"{v:>10.1f}" for v in vals))
    print("('sin+cos (fresh)' includes copying the input, since sin/cos are memoised per series)")


if __name__ == "__main__":
    main()
