"""Loading a benchmark script (``benchmarks/*.py``, not a package) as a module for its tests."""

from __future__ import annotations

import functools

from tests.script_loader import script_module

benchmark_module = functools.partial(script_module, "benchmarks")
