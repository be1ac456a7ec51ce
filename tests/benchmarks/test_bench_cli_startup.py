"""The start-up benchmark runs and prints its table and its JSON (one round; no timing asserted)."""

from __future__ import annotations

import json
import shutil

import pytest

from .conftest import benchmark_module

pytestmark = pytest.mark.skipif(shutil.which("gflat") is None, reason="no gflat console script installed")


def test_the_benchmark_prints_every_command_against_the_peer(capsys):
    with benchmark_module("bench_cli_startup") as bench:
        assert bench.main(["--runs", "1"]) == 0
        text = capsys.readouterr().out
        for label in bench.commands("gflat"):
            assert any(line.startswith(label) for line in text.splitlines()), label
        assert "load average (1, 5, 15 min) at start" in text and "at end" in text
        assert "gflat --version: " in text and "budget" in text

        assert bench.main(["--runs", "1", "--json"]) == 0
        result = json.loads(capsys.readouterr().out)
        assert list(result["entries"]) == list(bench.commands("gflat"))
        peer = result["entries"][bench.PEER]
        assert peer["wall_minus_peer_s"] == 0.0 and peer["wall_ratio_to_peer"] == 1.0
        assert all(len(e["wall_s"]) == 1 and e["cpu_median_s"] >= 0 for e in result["entries"].values())


def test_a_failing_command_is_one_line(capsys, tmp_path):
    with benchmark_module("bench_cli_startup") as bench:
        assert bench.main(["--runs", "1", "--gflat", str(tmp_path / "missing")]) == 2
        err = capsys.readouterr().err
        assert err.startswith("bench_cli_startup: error:") and err.count("\n") == 1
