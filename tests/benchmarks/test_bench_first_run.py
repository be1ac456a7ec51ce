"""The first-run benchmark: its helpers, its rounds and concurrent starts on a stand-in console script, a failure
in one line (no timing asserted)."""

from __future__ import annotations

import shutil
import sys

import pytest

from .conftest import benchmark_module


def test_plans_agree_on_feasibility_and_every_residual():
    with benchmark_module("bench_first_run") as bench:
        a = {"residuals": [1e-2, 3e-6], "feasible": True}
        assert bench.agrees(a, {"residuals": [1e-2, 3e-6 * (1 + 1e-12)], "feasible": True})
        assert bench.agrees(a, {"residuals": [1e-2, 3e-6 + 2e-17], "feasible": True})  # numpy against native
        assert not bench.agrees(a, {"residuals": [1e-2, 3.1e-6], "feasible": True})
        assert not bench.agrees(a, {"residuals": [1e-2], "feasible": True})
        assert not bench.agrees(a, {"residuals": [1e-2, 3e-6], "feasible": False})


def test_the_summary_is_medians_and_first_minus_warm():
    with benchmark_module("bench_first_run") as bench:
        runs = {
            k: [{"wall_s": w, "cpu_s": w / 2, "planning_s": w / 10} for w in ws]
            for k, ws in {"first": [3.0, 1.0, 2.0], "warm": [1.0, 1.5, 0.5], "numpy": [1.2, 1.2, 1.2]}.items()
        }
        m = bench.summarise(runs)
        assert m["first"]["wall_s"] == 2.0 and m["warm"]["cpu_s"] == 0.5
        assert m["first_minus_warm_wall_s"] == 1.0 and m["first_minus_warm_cpu_s"] == 0.5


def test_the_measured_commands_run_without_the_developers_variables(monkeypatch, tmp_path):
    monkeypatch.setenv("PYTHONPATH", "/somewhere")
    monkeypatch.setenv("GFLAT_NATIVE_WAIT", "1")
    with benchmark_module("bench_first_run") as bench:
        env = bench.child_env(tmp_path, GFLAT_SERIES_BACKEND="numpy")
        assert "PYTHONPATH" not in env and "GFLAT_NATIVE_WAIT" not in env
        assert env["XDG_CACHE_HOME"] == str(tmp_path) and env["GFLAT_SERIES_BACKEND"] == "numpy"


STUB = """#!{python}
import json, os, subprocess, sys
from pathlib import Path
out = Path(sys.argv[sys.argv.index("--out") + 1])
out.mkdir()
lib = Path(os.environ["XDG_CACHE_HOME"]) / "gflat" / "native" / "gflat_program-0.so"
lib.parent.mkdir(parents=True, exist_ok=True)
if not lib.exists():
    if os.environ.get("CC"):
        subprocess.run([os.environ["CC"], "-shared", "-x", "c", os.devnull, "-o", str(lib)], check=True)
    else:
        lib.write_bytes(b"")
print(json.dumps({{"planning_time_s": 0.01, "equation_residual_per_iterate": [1e-3, 2e-6], "feasible": True}}))
"""


@pytest.mark.skipif(shutil.which("cc") is None, reason="no cc")
def test_one_round_and_two_concurrent_starts_of_a_stand_in(capsys, tmp_path):
    # a stand-in for the console script (the real one is measured by hand: a compilation per round)
    stub = tmp_path / "gflat"
    stub.write_text(STUB.format(python=sys.executable))
    stub.chmod(0o755)
    with benchmark_module("bench_first_run") as bench:
        args = ["--gflat", str(stub), "--scenarios", "gtm-aileron-roll", "--rounds", "2", "--concurrent", "2"]
        assert bench.main(args) == 0
        text = capsys.readouterr().out
        assert "first - warm:" in text and "plans agree: True" in text and "within the 2 s budget" in text
        for kind in bench.KINDS:
            assert any(line.lstrip().startswith(kind) and "median" in line for line in text.splitlines()), kind
        background, waiting = [line for line in text.splitlines() if line.startswith("concurrent, ")]
        assert "background build" in background and "GFLAT_NATIVE_WAIT=1" in waiting
        for line in (background, waiting):
            assert "exit [0, 0]" in line and "compilation(s)" in line and "gflat_program-0.so" in line
            assert " 0 compilation(s)" not in line


def test_a_failing_command_is_one_line(capsys, tmp_path):
    with benchmark_module("bench_first_run") as bench:
        assert bench.main(["--gflat", str(tmp_path / "missing"), "--rounds", "1"]) == 2
        err = capsys.readouterr().err
        assert err.startswith("bench_first_run: error:") and err.count("\n") == 1
