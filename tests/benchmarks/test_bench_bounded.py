"""The bounded-planning benchmark at its smallest setting: the three methods run and are judged alike, and the
python-control flat system's maps agree with the trims (the figures of docs/performance.md come from the full
run)."""

from __future__ import annotations

import numpy as np
import pytest

from .conftest import benchmark_module

pytest.importorskip("casadi")
pytest.importorskip("control")

from planners.scenario import load_scenario  # noqa: E402


@pytest.fixture(scope="module")
def bb():
    with benchmark_module("bench_bounded", "bench_bounded") as mod:
        yield mod


def test_the_flat_systems_maps_meet_the_start_trim(bb):
    """forward at the start trim gives the steady flight's flags; reverse of them gives back the trim's states
    (the J = 0 model: alpha, the controls of the simple model, close to the full model's trim), rates zero."""
    sc = load_scenario(bb.SCENARIO)
    fa = bb.FlatAircraft(sc)
    start = sc.boundary["start"]
    x0 = np.concatenate([start.state(), start.controls()[[0, 2, 3, 4]]])
    flag = fa.forward(x0, np.zeros(4))
    assert len(flag) == 4 and all(f.size == bb.FLAG for f in flag)
    assert flag[0][1] == pytest.approx(150.0) and flag[2][0] == pytest.approx(-3000.0)
    xs, us = fa.reverse(flag)
    np.testing.assert_allclose(xs[:6], x0[:6], atol=1e-9)  # position, V, gamma, chi
    assert abs(xs[6] - x0[6]) < 0.02  # alpha within about 1 deg of the full model's
    assert np.all(np.abs(us) < 1e-6) and fa.calls == 1
    fa.reverse(flag)
    assert fa.calls == 1  # the same point: from the cache


def test_quick_run_prints_the_table_of_the_three_methods(bb, capsys, tmp_path):
    out = tmp_path / "bounded.json"
    bb.main(["--quick", "--repeat", "1", "--json", str(out)])
    text = capsys.readouterr().out
    assert "load average" in text
    for m in bb.METHODS:
        assert f"| {m} |" in text
    import json

    res = json.loads(out.read_text())
    assert [r["method"] for r in res["rows"]] == list(bb.METHODS)
    g = res["rows"][0]
    assert g["cpu_s"] > 0 and g["wall_s"] > 0 and g["cost"] > 0
    assert np.isfinite(g["open_loop_error_m"]) and g["limits"] == "met"  # 13 nodes, 2 iterations: not accurate


def test_bad_arguments_are_one_line(bb, capsys):
    with pytest.raises(SystemExit) as exc:
        bb.main(["--methods", "gflat,simplex"])
    assert exc.value.code == 2 and "unknown simplex" in capsys.readouterr().err
