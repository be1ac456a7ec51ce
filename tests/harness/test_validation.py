"""Validation cases: TOML loading, pickling, run_case and its result, cross-engine comparisons."""

from __future__ import annotations

import dataclasses
import json
import math
import pickle

import numpy as np
import pandas as pd
import pytest

from gna.aircraft import Propulsion, list_aircraft, load_aircraft
from gna.eom import STATE_NAMES
from gna.errors import InputError
from gna.trim import stall_speed, trim_level
from harness.engines import engine_names
from harness.testing import smooth_inputs
from harness.validation import CaseResult, ValidationCase, compare_engines, load_case, run_case
from reports.case_files import write_case
from reports.figures import write_figures

ANGLES = ("gamma", "chi", "alpha", "beta", "mu")

SHORT = (
    'name = "short"\naircraft = "a7"\n[time]\nt0 = 0.0\nt1 = 4.0\nstep = 0.5\n'
    '[flat_outputs]\nx = "130*t"\ny = "20*sin(t/3)"\nz = "-1500"\nzeta = "beta"\n'
    'zeta_value = "0"\n[generalized]\nJ = 2\n'
)
SUMMARY_KEYS = {
    "scenario",
    "J",
    "engines",
    "passed",
    "verdicts",
    "failures",
    "status",
    "tables",
    "figures",
    "settings",
    "self_convergence_tables",
}


@pytest.fixture
def short_scenario(tmp_path):
    p = tmp_path / "short.toml"
    p.write_text(SHORT)
    return p


def test_case_defaults_normalisation_and_pickling():
    case = ValidationCase("gtm-forward-slip", tolerances={"position": 1e-2, "mu": 1e-4}, windows={"all": None})
    assert case.engines == ("inhouse", "jsbsim") and case.loop == "open" and case.dt_out is None
    assert case.tolerance_spec == {"mu": 1e-4, "position": 1e-2} and case.window_spec == {"all": None}
    assert ValidationCase("x").window_spec == {"first 10 s": 10.0, "whole span": None}
    back = pickle.loads(pickle.dumps(case))
    assert back == case and hash(back) == hash(case)
    with pytest.raises(dataclasses.FrozenInstanceError):
        case.J = 3
    assert "jsbsim-wgs84" in engine_names() and engine_names()[0] == "inhouse"


@pytest.mark.parametrize(
    "kw, match",
    [
        ({"engines": ("inhouse", "xplane")}, "unknown: xplane"),
        ({"engines": ("inhouse", "inhouse")}, "distinct"),
        ({"engines": ("inhouse",)}, "engines: at least 2 distinct of .* needed; got 'inhouse'"),
        ({"engines": "inhouse"}, "at least 2 distinct"),
        ({"engines": ()}, "at least 2 distinct"),
        ({"engines": (1, 2)}, "names of"),
        ({"loop": "half"}, "loop must be one of open, closed"),
        ({"J": -1}, "J must be an integer"),
        ({"dt_out": 0.0}, "dt_out must be a positive number"),
        ({"tolerances": {"mu": -1.0}}, "tolerances: mu must be a non-negative finite number"),
        ({"tolerances": {"positon": 1.0}}, "unknown key 'positon' \\(did you mean 'position'\\?\\)"),
        ({"rtol": {"angle": "big"}}, "rtol: angle must be a non-negative finite number"),
        ({"jsbsim_dt": 0.0}, "jsbsim_dt must be a positive"),
        ({"self_convergence": "yes"}, "self_convergence must be true or false"),
        ({"windows": {"w": -2.0}}, "window 'w' must be a positive number"),
    ],
)
def test_case_refuses_bad_values(kw, match):
    with pytest.raises(InputError, match=match):
        ValidationCase("gtm-forward-slip", **kw)


def test_case_from_toml(tmp_path, short_scenario):
    f = tmp_path / "case.toml"
    f.write_text(
        'scenario = "short.toml"\nJ = 1\nengines = ["inhouse", "jsbsim-wgs84"]\ndt_out = 0.1\n'
        'tolerances = 0.5\n[windows]\n"first 2 s" = 2.0\nall = "all"\n'
    )
    case = load_case(f)
    assert case == ValidationCase(
        str(short_scenario),
        J=1,
        engines=("inhouse", "jsbsim-wgs84"),
        dt_out=0.1,
        tolerances=0.5,
        windows={"first 2 s": 2.0, "all": None},
    )
    f.write_text('scenario = "gtm-forward-slip"\ntolerance = 0.5\nengine = ["inhouse"]\n')
    with pytest.raises(InputError, match="case.toml: unknown key 'tolerance' \\(did you mean 'tolerances'\\?\\)"):
        ValidationCase.from_toml(f)
    f.write_text("J = 2\n")
    with pytest.raises(InputError, match="missing 'scenario'"):
        load_case(f)
    f.write_text('scenario = "gtm-forward-slip"\nloop = "sideways"\n')
    with pytest.raises(InputError, match="case.toml: loop must be one of"):
        load_case(f)
    with pytest.raises(InputError, match="cannot read the case file"):
        load_case(tmp_path / "missing.toml")


def test_run_case_result_and_summary(short_scenario, tmp_path):
    case = ValidationCase(str(short_scenario), dt_out=0.1)
    result = run_case(case)
    assert isinstance(result, CaseResult) and result.case is case and result.plan.J == 2
    assert list(result.runs) == ["inhouse", "jsbsim"] and result.reference_engine == "inhouse"
    assert list(result.tables) == ["jsbsim"] and list(result.tables["jsbsim"]) == ["first 10 s", "whole span"]
    assert set(result.vs_plan) == {"inhouse", "jsbsim"} and result.passed
    assert result.runs["jsbsim"].df.index[1] == pytest.approx(0.1)
    assert result.planning_time_s > 0
    assert set(result.provenance) == {"gflat", "jsbsim", "numpy", "python", "date_utc", "git_commit"}
    assert result.provenance["numpy"] == np.__version__
    errors = result.max_position_error_m()
    assert set(errors) == {"inhouse", "jsbsim"} and all(0 <= e < 1.0 for e in errors.values())
    summary = result.summary()
    assert set(summary) == SUMMARY_KEYS and summary["scenario"] == "short" and summary["J"] == 2
    assert summary["status"] == {"inhouse": "completed", "jsbsim": "completed"} and summary["figures"] == []
    assert {r["variable"] for r in summary["tables"]["jsbsim"]["whole span"]} >= {"position", "mu"}
    text = result.report_text()
    assert text.startswith("short: a7, J = 2, t = 0 .. 4 s, open loop")
    assert "[first 10 s]" in text and "[jsbsim against the plan, whole span]" in text
    # a given plan is reused, and must match the case's J
    again = run_case(case, plan=result.plan)
    assert again.plan is result.plan and again.planning_time_s is None
    with pytest.raises(InputError, match="J = 2, the case asks for J = 1"):
        run_case(ValidationCase(str(short_scenario), J=1), plan=result.plan)
    # writing is the reports package's job
    written = write_case(result, tmp_path / "out")
    data = json.loads(written["summary"].read_text())
    assert set(data) >= SUMMARY_KEYS | {"provenance", "verdict", "trajectories", "units"}
    assert len(data["figures"]) == 3 and data["verdict"]["settings"]["dt_out"] == 0.1
    assert written["differences"].read_text() == text + "\n"


def test_run_case_refuses_what_is_not_a_case():
    with pytest.raises(InputError, match="needs a ValidationCase"):
        run_case("short")


def test_paper_plans_each_scenario_once(short_scenario, tmp_path, monkeypatch, capsys):
    import planners.generalized as generalized
    from harness.cli import main
    from harness.commands import paper

    calls = []
    real = generalized.plan_motion

    def counting(*args, **kw):
        calls.append(kw.get("name"))
        return real(*args, **kw)

    monkeypatch.setattr(generalized, "plan_motion", counting)
    monkeypatch.setattr(paper, "PAPER_SCENARIOS", (str(short_scenario),))
    assert main(["paper", "--out", str(tmp_path / "paper")]) == 0
    assert calls == ["short"]
    out = capsys.readouterr().out
    assert "convergence table" in out and "in-house vs JSBSim (open loop, J = 2)" in out
    for f in (
        "plan/plan_series.npz",
        "plan/summary.json",
        "plan/plan-j0.parquet",
        "plan/plan-j2.parquet",
        "open/states.png",
        "open/differences.txt",
        "open/summary.json",
        "open/trajectory-inhouse.parquet",
        "open/trajectory-jsbsim.parquet",
        "closed/trajectory-inhouse-open-loop.parquet",
    ):
        assert (tmp_path / "paper" / "short" / f).is_file(), f
    assert [c.scenario for c in paper.paper_cases()] == [str(short_scenario)]
    assert (tmp_path / "paper" / "short" / "closed" / "tracking.png").is_file()  # both loops by default
    manifest = json.loads((tmp_path / "paper" / "manifest.json").read_text())
    assert [c["loop"] for c in manifest["cases"]] == ["open", "closed"] and manifest["command_line"]
    assert {"gflat", "jsbsim", "numpy", "scipy", "date_utc", "inputs"} <= set(manifest)
    assert any(k.endswith("scenario") and len(v["sha256"]) == 64 for k, v in manifest["inputs"].items())
    assert manifest["tool"] == "gflat" and manifest["command"] == "paper"
    assert "short/open/report.json" in [f["path"] for f in manifest["files"]]


def _two_engine_aircraft():
    for name in list_aircraft():
        a = load_aircraft(name)
        if a.propulsion.count == 2:
            return a
    base = load_aircraft("f16c")
    return dataclasses.replace(base, propulsion=Propulsion(count=2, y_p=1.8, epsilon=math.radians(3.0)))


@pytest.mark.parametrize("which", ["f16c", "a7", "twin"])
def test_engines_agree_on_smooth_manoeuvres_from_trim(which, tmp_path):
    """Matched physics, smooth controls: in-house vs JSBSim <= 1e-2 m and <= 1e-4 rad over the first 10 s (and 12 s)."""
    a = _two_engine_aircraft() if which == "twin" else load_aircraft(which)
    V = 1.6 * stall_speed(a, 1000.0).V_stall
    tr = trim_level(a, V, 1000.0)
    x0, u0 = np.array(tr.state, dtype=float), np.array(tr.controls, dtype=float)
    c = compare_engines(a, smooth_inputs(u0, a.propulsion.count == 2), (0.0, 12.0), x0)
    assert set(c.tables["jsbsim"]) == {"first 10 s", "whole span"}
    first, whole = c.table("first 10 s"), c.table("whole span")
    assert first.window == (0.0, 10.0) and whole.window == (0.0, 12.0)
    assert c.passed, c.report()
    # Measured <= 3.2e-4 m and <= 3.6e-7 rad over 12 s on all six bundled aircraft (docs/jsbsim.md).
    assert whole.row("position").max_abs <= 2e-3, c.report()
    assert max(whole.row(v).max_abs for v in ANGLES) <= 1e-5, c.report()
    text = c.report()
    assert "[first 10 s]" in text and "[whole span]" in text and "overall: PASS" in text
    if which == "twin":  # figures from the result objects alone
        times = c.results["inhouse"].df.index
        ref = pd.DataFrame(np.tile(x0, (times.size, 1)), index=times, columns=STATE_NAMES)
        figures = write_figures(c.results, tmp_path / "cmp", reference=ref, title="twin")
        assert sorted(p.name for p in figures) == ["controls.png", "differences.png", "states.png"]
        assert all(p.stat().st_size > 10_000 for p in figures)


def test_a_plan_flies_open_loop_on_both_engines():
    """A plan from the planner plugs in unchanged: controls, initial state, environment, reference."""
    from planners.generalized import plan_scenario
    from planners.scenario import scenario_from_dict

    sc = scenario_from_dict(
        {
            "name": "f16c-weave",
            "aircraft": "f16c",
            "time": {"t0": 0.0, "t1": 10.0, "step": 0.5},
            "flat_outputs": {
                "x": "150*t",
                "y": "30*(1-cos(t/4))",
                "z": "-3000 - 5*sin(t/3)",
                "zeta": "beta",
                "zeta_value": "0",
                "eta": "0",
            },
            "generalized": {"J": 1},
        }
    )
    plan = plan_scenario(sc)
    c = compare_engines(plan.aircraft, plan)
    assert c.results["jsbsim"].settings["environment"].startswith(plan.env.atmosphere.describe())
    assert c.table("whole span").window == (0.0, 10.0)
    assert c.passed, c.report()


def test_case_file_not_utf8_is_one_clear_error(tmp_path):
    from harness.validation import ValidationCase

    bad = tmp_path / "case.toml"
    bad.write_bytes(b'scenario = "gtm-aileron-roll"\n\xff')
    with pytest.raises(InputError, match="not UTF-8"):
        ValidationCase.from_toml(bad)
