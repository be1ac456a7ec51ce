"""Verdicts the user controls ([compare] table, command-line flags) and the artefacts written with them."""

from __future__ import annotations

import dataclasses
import json

import pytest

from gna.errors import InputError
from harness.artefacts import read_trajectory, write_artefacts
from harness.cli import main
from harness.rundir import MANIFEST
from harness.validation import ValidationCase, plan_case, resolve_compare, run_case

SHORT = (
    'name = "short"\naircraft = "a7"\n[time]\nt0 = 0.0\nt1 = 4.0\nstep = 0.5\n'
    '[flat_outputs]\nx = "130*t"\ny = "20*sin(t/3)"\nz = "-1500"\nzeta = "beta"\nzeta_value = "0"\n'
    "[generalized]\nJ = 2\n"
)


@pytest.fixture(scope="module")
def planned(tmp_path_factory):
    p = tmp_path_factory.mktemp("scen") / "short.toml"
    p.write_text(SHORT)
    return p, plan_case(ValidationCase(str(p)))


def test_settings_precedence_and_unknown_keys():
    s = resolve_compare(
        {"tolerances": {"position": 0.5, "z": 0.1}, "dt_out": 0.1, "self_convergence": True},
        {"tolerances": {"angle": 1e-3}, "jsbsim_dt": 1e-3},
    )
    assert s.tolerances["position"] == 0.5 and s.tolerances["x"] == 0.5 and s.tolerances["z"] == 0.1
    assert s.tolerances["mu"] == 1e-3 and s.tolerances["V"] == 1e-3  # default kept for V
    assert (s.dt_out, s.jsbsim_dt, s.self_convergence) == (0.1, 1e-3, True)
    assert s.sources == {
        "tolerances": "command line",
        "rtol": "default",
        "windows": "default",
        "dt_out": "scenario",
        "jsbsim_dt": "command line",
        "self_convergence": "scenario",
        "tracking_tolerance": "default",
        "settle_time": "default",
    }
    with pytest.raises(InputError, match=r"unknown key 'tolerance' \(did you mean 'tolerances'\?\)"):
        resolve_compare({"tolerance": 1.0}, where="s.toml [compare]")
    with pytest.raises(InputError, match=r"unknown key 'angles' \(did you mean 'angle'\?\)"):
        resolve_compare({"tolerances": {"angles": 1.0}})
    with pytest.raises(InputError, match="jsbsim_dt must be a positive"):
        resolve_compare({"jsbsim_dt": -1})


def test_a_tolerance_in_the_scenario_or_the_case_flips_the_verdict(planned):
    path, pc = planned
    sc, plan = pc.scenario, pc.plan
    base = run_case(ValidationCase(str(path)), plan=plan, scenario=sc)
    assert base.passed and base.verdict()["pass"]
    pos = base.tables["jsbsim"]["whole span"].row("position").max_abs
    assert 0 < pos < 1e-2
    strict = dataclasses.replace(sc, compare={"tolerances": {"position": pos / 10}})
    failed = run_case(ValidationCase(str(path)), plan=plan, scenario=strict)
    v = failed.verdict()
    assert not v["pass"] and v["settings"]["tolerances"]["position"] == pos / 10
    assert v["settings"]["sources"]["tolerances"] == "scenario"
    # the case (the command line) overrides the scenario
    loose = run_case(ValidationCase(str(path), tolerances={"position": 1.0}), plan=plan, scenario=strict)
    assert loose.passed and loose.settings.sources["tolerances"] == "command line"
    # a relative tolerance alone: max|d| <= rtol * max|ref| (position: distance from the origin, about 520 m)
    rel = run_case(
        ValidationCase(str(path), tolerances={"position": 0.0}, rtol={"position": 1e-3}), plan=plan, scenario=sc
    )
    row = rel.tables["jsbsim"]["whole span"].row("position")
    assert rel.passed and row.tolerance == pytest.approx(1e-3 * row.ref_max) and row.delta_pct < 0.1
    assert "delta_pct" in base.verdict()["differences"]["jsbsim"]


def test_self_convergence_is_reported_next_to_the_cross_engine_difference(planned, tmp_path):
    path, pc = planned
    r = run_case(
        ValidationCase(str(path), self_convergence=True, jsbsim_dt=1 / 240), plan=pc.plan, scenario=pc.scenario
    )
    assert set(r.half_step) == {"jsbsim"} and r.half_step["jsbsim"].settings["dt"] == pytest.approx(1 / 480)
    assert r.runs["jsbsim"].settings["dt"] == pytest.approx(1 / 240)
    sc = r.verdict()["self_convergence"]["jsbsim"]
    assert 0 < sc["max_position_m"] < 1e-3
    assert "[self-convergence of jsbsim: step against half the step, whole span]" in r.report_text()
    files = write_artefacts(r, tmp_path / "case", csv=True)
    names = sorted(p.name for p in files["trajectories"])
    assert names == sorted(
        f"trajectory-{e}.{x}" for e in ("inhouse", "jsbsim", "jsbsim-half-step") for x in ("parquet", "csv")
    )
    df, units = read_trajectory(tmp_path / "case" / "trajectory-jsbsim.parquet")
    assert units["t"] == "s" and units["x"] == "m" and units["phi"] == "rad" and units["Mach"] == "-"
    assert {"h", "phi", "theta", "psi", "u", "v", "w", "Mach"} <= set(df.columns)
    assert df["h"].iloc[0] == pytest.approx(1500.0) and 0.3 < df["Mach"].iloc[0] < 0.5
    assert (df["u"] ** 2 + df["v"] ** 2 + df["w"] ** 2).pow(0.5).sub(df["V"]).abs().max() < 1e-9
    summary = json.loads((tmp_path / "case" / "summary.json").read_text())
    assert summary["verdict"]["settings"]["jsbsim_dt"] == pytest.approx(1 / 240)
    assert summary["self_convergence_tables"]["jsbsim"]["whole span"][0]["variable"] == "position"
    manifest = json.loads((tmp_path / "case" / "manifest.json").read_text())
    assert manifest["cases"][0]["compare"]["self_convergence"] is True
    assert manifest["cases"][0]["engines"]["jsbsim"]["dt"] == pytest.approx(1 / 240)
    assert (tmp_path / "case" / "plan" / "plan-j2.parquet").is_file()


def test_compare_flags_and_scenario_table_on_the_command_line(tmp_path, capsys):
    scen = tmp_path / "short.toml"
    scen.write_text(SHORT + "[compare]\ntolerances = { position = 1e-9 }\ndt_out = 0.1\n")
    out = tmp_path / "out"
    assert main(["compare", str(scen), "--json", "--out", str(out), "--csv"]) == 1  # the scenario's 1e-9 m
    v = json.loads(capsys.readouterr().out)
    assert v["pass"] is False and v["settings"]["dt_out"] == 0.1 and v["settings"]["tolerances"]["position"] == 1e-9
    assert {"scenario", "loop", "runs", "differences", "pass"} <= set(v)
    assert (out / "trajectory-jsbsim.csv").is_file()
    assert main(["compare", str(scen), "--json", "--out", str(out), "--tol-position", "1"]) == 2  # out exists
    assert "exists: give --replace" in capsys.readouterr().err
    assert main(["compare", str(scen), "--json", "--out", str(out), "--tol-position", "1", "--replace"]) == 0
    v = json.loads(capsys.readouterr().out)
    assert v["pass"] is True and v["settings"]["sources"]["tolerances"] == "command line"
    assert not (out / "trajectory-jsbsim.csv").exists()  # the new run replaced the earlier one whole
    assert json.loads((out / MANIFEST).read_text())["command"] == "compare"


def test_bad_destination_and_bad_compare_table_stop_before_planning(tmp_path, capsys, monkeypatch):
    import planners.generalized as generalized

    def no_planning(*a, **k):
        raise AssertionError("planned before the inputs were checked")

    monkeypatch.setattr(generalized, "plan_motion", no_planning)
    scen = tmp_path / "short.toml"
    scen.write_text(SHORT)
    (tmp_path / "file").write_text("x")
    assert main(["compare", str(scen), "--out", str(tmp_path / "file")]) == 2
    err = capsys.readouterr().err
    assert "not a folder" in err and str(tmp_path / "file") in err and len(err.strip().splitlines()) == 1
    assert main(["plan", str(scen), "--out", str(tmp_path / "no" / "parent")]) == 2
    assert "does not exist" in capsys.readouterr().err
    scen.write_text(SHORT + "[compare]\ntolerances = { positon = 1.0 }\n")
    assert main(["compare", str(scen), "--out", str(tmp_path / "o")]) == 2
    assert "did you mean 'position'" in capsys.readouterr().err


def test_identifiers_cannot_write_outside_the_output_folder(tmp_path, monkeypatch):
    import argparse

    import harness.commands.export_jsbsim as ej
    from gna.aircraft import load_aircraft
    from harness.engines import JSBSimEngine

    with pytest.raises(InputError, match="not a safe identifier"):  # refused where an aircraft is made
        dataclasses.replace(load_aircraft("a7"), id="../../esc")
    a = dataclasses.replace(load_aircraft("a7"))
    object.__setattr__(a, "id", "../../esc")  # and, should one get through, at every writer (defence in depth)
    out = tmp_path / "a" / "b" / "c"
    out.mkdir(parents=True)
    monkeypatch.setattr(ej, "load_aircraft", lambda name: a)
    args = argparse.Namespace(aircraft=["x"], all=False, out=out / "xo", check=False)
    with pytest.raises(InputError, match="leaves the output folder"):
        ej.run(args)
    assert not (tmp_path / "a" / "esc.xml").exists()
    with pytest.raises(InputError, match="not a safe identifier"):
        JSBSimEngine().simulate(a, [0.0] * 5, (0.0, 0.1), [0.0, 0, -1000, 100, 0, 0, 0.05, 0, 0, 0, 0, 0])


def test_comparison_flags_parse_into_case_settings():
    from harness.cli import build_parser
    from harness.commands._compare_args import compare_overrides

    args = build_parser().parse_args(
        [
            "paper",
            "--tol-angle",
            "2e-4",
            "--rtol-velocity",
            "1e-6",
            "--window",
            "a=5",
            "--window",
            "all=all",
            "--dt-out",
            "0.1",
            "--jsbsim-dt",
            "0.001",
            "--self-convergence",
            "--csv",
        ]
    )
    kw = compare_overrides(args)
    assert (
        kw
        == {
            "tolerances": {"angle": 2e-4},
            "rtol": {"velocity": 1e-6},
            "windows": {"a": 5.0, "all": None},
            "dt_out": 0.1,
            "jsbsim_dt": 0.001,
            "self_convergence": True,
        }
        and args.csv
    )
    s = resolve_compare({"tolerances": {"angle": 1.0}}, ValidationCase("x", **kw).overrides)
    assert s.tolerances["mu"] == 2e-4 and s.rtol == {"V": 1e-6} and s.windows == {"a": 5.0, "all": None}
    assert compare_overrides(build_parser().parse_args(["paper"])) == {}
    with pytest.raises(SystemExit):
        build_parser().parse_args(["paper", "--window", "nonsense"])


def test_the_tracking_line_says_whether_commands_beyond_the_limits_were_flown_or_clipped():
    from harness.validation.verdicts import verdict_lines

    fly = {"pass": True, "violations": [], "infeasible": False}
    agree = {"pass": True, "incomplete": [], "differences": {}}

    def line(saturated_s, clipped):
        trk = {
            "pass": True,
            "settle_s": 5.0,
            "tolerance_m": 1.0,
            "max_error_after_settle_m": 1e-5,
            "saturated_s": saturated_s,
            "clipped": clipped,
        }
        lines = verdict_lines({"flyable": fly, "tracking": trk, "engines_agree": agree})
        return next(x for x in lines if x.startswith("tracking:"))

    assert line(0.0, True).endswith("; commands within their limits)")
    assert line(2.5, True).endswith("; commands clipped at their limits 2.50 s)")
    # the paper's forward slip flies its -28 deg ailerons unclipped: the PASS does not hide it
    assert line(120.0, False).endswith(
        "; commands beyond their limits 120.00 s, flown unclipped ([tracking] saturate = false))"
    )
