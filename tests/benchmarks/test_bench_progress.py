"""The progress benchmark records a command's stderr lines with their times (a cheap command; no time asserted)."""

from __future__ import annotations

import json

from .conftest import benchmark_module


def test_the_transcript_of_a_command_with_its_first_line(capsys, tmp_path):
    with benchmark_module("bench_progress") as bench:
        res = bench.transcript(["report", str(tmp_path / "none")])
        texts = [text for _, text in res["lines"]]
        assert texts[0].endswith("gflat report: started") and bench.LOADED in texts[1]
        assert texts[-1].startswith("gflat report: error: ") and res["status"] == 2
        times = [s for s, _ in res["lines"]]
        assert times == sorted(times) and res["first_line_s"] == times[0] <= res["modules_loaded_s"]

        assert bench.main(["--json", "--", "report", str(tmp_path / "none")]) == 0
        shown = json.loads(capsys.readouterr().out)
        assert shown["command"] == ["gflat", "report", str(tmp_path / "none")] and len(shown["lines"]) == 3
