"""The three verdicts of a case: flyable (the aircraft's limits), tracking, engines agree; recorded violations."""

from __future__ import annotations

import dataclasses
import json
import math
import re

import numpy as np
import pandas as pd
import pytest

from gna.aircraft import load_aircraft
from gna.errors import InputError
from gna.limits import LIMIT_NAMES, aircraft_limits, control_ranges, limit_violations
from harness.cli import main
from harness.validation import ValidationCase, plan_case, run_case
from harness.validation.verdicts import CAUSES, cause, flyable_verdict, judge
from planners.scenario import KnownViolation, load_scenario

SHORT = (
    'name = "short"\naircraft = "a7"\n[time]\nt0 = 0.0\nt1 = 4.0\nstep = 0.5\n'
    '[flat_outputs]\nx = "130*t"\ny = "20*sin(t/3)"\nz = "-1500"\nzeta = "beta"\nzeta_value = "0"\n'
    "[generalized]\nJ = 2\n"
)


def _frame(t, **cols):
    return pd.DataFrame(cols, index=pd.Index(np.asarray(t, dtype=float), name="t"))


def test_limits_found_at_their_time_value_and_share_of_the_span():
    a = load_aircraft("twin-otter")  # dl, dm, dn 20 deg; alpha -5..12 deg; beta 15 deg; PT6A-27 rating
    t = np.linspace(0.0, 10.0, 1001)
    n = t.size
    dl = math.radians(30.0) * np.sin(2 * np.pi * t / 10.0)  # beyond +-20 deg twice
    F = np.full(n, 5000.0)
    eta = np.where(t >= 5.0, 1.0, 0.0)  # engine 2 out from t = 5 s: engine 1 gives 5000 N
    df = _frame(
        t,
        z=np.zeros(n),
        V=np.full(n, 100.0),  # the rating 0.8 x 680 shp / 100 m/s = 4057 N
        alpha=np.zeros(n),
        beta=np.zeros(n),
        F=F,
        eta=eta,
        dl=dl,
        dm=np.zeros(n),
        dn=np.zeros(n),
    )
    found = {(v.name, v.side): v for v in limit_violations(a, df)}
    assert set(found) == {("dl", "upper"), ("dl", "lower"), ("thrust[1]", "upper")}
    up, lo = found[("dl", "upper")], found[("dl", "lower")]
    assert up.worst == pytest.approx(math.radians(30.0)) and up.time == pytest.approx(2.5)
    assert up.limit == pytest.approx(math.radians(20.0)) and lo.limit == pytest.approx(-math.radians(20.0))
    assert lo.worst == pytest.approx(-math.radians(30.0)) and lo.time == pytest.approx(7.5)
    # sin beyond 2/3 for (pi - 2 asin(2/3)) / (2 pi) of the period: 26.8 % of the span on each side
    share = (np.pi - 2 * math.asin(2 / 3)) / (2 * np.pi)
    assert up.fraction == pytest.approx(share, abs=2e-3) and lo.fraction == pytest.approx(share, abs=2e-3)
    thr = found[("thrust[1]", "upper")]
    rating = 0.8 * 680 * 745.69987158227 / 100.0
    assert thr.worst == pytest.approx(5000.0) and thr.limit == pytest.approx(rating, rel=1e-9)
    assert thr.first == pytest.approx(5.0) and thr.fraction == pytest.approx(0.5, abs=2e-3)
    assert "PT6A-27" in thr.source and thr.text().startswith("engine 1 thrust 5000.0 N at t = 5 s above its rating")
    # the same record for the JSON contract, SI and radians
    assert set(up.to_dict()) >= {"name", "limit", "worst", "time", "fraction"}
    # states: alpha beyond the fit's box, a Mach and a structural limit when the file gives them
    env = dataclasses.replace(a.envelope, mach_max=0.25, nz_min=-1.0, nz_max=2.5)
    b = dataclasses.replace(a, envelope=env)
    assert (
        {lim.name for lim in aircraft_limits(b)}
        == {"thrust[1]", "thrust[2]", "eta", "dl", "dm", "dn"}
        | {
            "alpha",
            "beta",
            "mach",
            "nz",
        }
        <= set(LIMIT_NAMES)
    )
    df2 = df.assign(dl=0.0, F=1000.0, eta=0.0, alpha=np.where(t > 9.0, 0.3, 0.0), nz=np.where(t < 1.0, 3.0, 1.0))
    got = {(v.name, v.side): v for v in limit_violations(b, df2)}
    assert set(got) == {("alpha", "upper"), ("mach", "upper"), ("nz", "upper")}
    assert got[("mach", "upper")].worst == pytest.approx(100.0 / 340.294, rel=1e-4) and got[
        ("mach", "upper")
    ].fraction == pytest.approx(1.0)
    assert got[("nz", "upper")].worst == 3.0 and got[("nz", "upper")].last == pytest.approx(0.99)
    assert got[("alpha", "upper")].limit == pytest.approx(math.radians(12.0))
    # the constant control ranges the figures draw and the feedback saturates at: the same definition
    assert control_ranges(a) == {
        "F": (0.0, pytest.approx(4000 * 4.4482216152605)),
        "eta": (-1.0, 1.0),
        "dl": (pytest.approx(-math.radians(20)), pytest.approx(math.radians(20))),
        "dm": (pytest.approx(-math.radians(20)), pytest.approx(math.radians(20))),
        "dn": (pytest.approx(-math.radians(20)), pytest.approx(math.radians(20))),
    }


def test_a_plans_violation_is_found_on_the_fine_grid_of_its_control_function(tmp_path):
    path = tmp_path / "short.toml"
    path.write_text(SHORT)
    plan = plan_case(ValidationCase(str(path))).plan
    a = plan.aircraft
    lim = math.radians(7.3)  # the plan's elevator spans -7.35 .. -7.20 deg
    tight = dataclasses.replace(a, envelope=dataclasses.replace(a.envelope, control_limits={"dm": lim}))
    v = flyable_verdict(plan, aircraft=tight)
    assert v["pass"] is False and v["grid_step_s"] == pytest.approx(0.01)  # min(0.01, 0.5 / 8)
    (rec,) = v["violations"]
    t = np.linspace(plan.t0, plan.t1, 401)  # the same grid, evaluated independently
    dm = np.array([plan.control_function()(x)[3] for x in t])
    over = np.abs(dm) > lim
    assert rec["name"] == "dm" and rec["limit"] == pytest.approx(-lim)
    assert rec["worst"] == pytest.approx(dm.min(), abs=1e-12) and rec["time"] == pytest.approx(t[np.argmin(dm)])
    assert rec["first"] == pytest.approx(t[over][0]) and rec["fraction"] == pytest.approx(over.sum() / 400, abs=0.01)
    assert rec["known"] is False and rec["reason"] is None
    assert flyable_verdict(plan)["pass"] is True  # the A-7 file gives no surface limit


def _aircraft_file(tmp_path, dm_deg: float):
    with open(load_aircraft("a7").path, encoding="utf-8") as fh:
        text = fh.read().replace("beta_max_deg = 20.0\n", f"beta_max_deg = 20.0\ndm_max_deg = {dm_deg}\n")
    p = tmp_path / "a7-tight.toml"
    p.write_text(text.replace('id = "a7"', 'id = "a7-tight"'))
    return p


def test_a_recorded_violation_is_shown_and_does_not_fail_the_exit_status(tmp_path, capsys):
    _aircraft_file(tmp_path, 7.3)
    base = SHORT.replace('aircraft = "a7"', 'aircraft = "a7-tight.toml"')
    scen = tmp_path / "short.toml"
    scen.write_text(base)
    assert main(["compare", str(scen), "--json", "--out", str(tmp_path / "o1")]) == 1
    v = json.loads(capsys.readouterr().out)
    assert v["failures"] == ["flyable: dm"] and v["pass"] is False
    assert v["verdicts"]["engines_agree"]["pass"] is True and v["verdicts"]["tracking"]["pass"] is None
    reason = "a test: the path asks for more elevator than the file allows"
    scen.write_text(base + f'[verdicts]\nknown = [{{ name = "dm", reason = "{reason}" }}]\n')
    assert main(["compare", str(scen), "--json", "--out", str(tmp_path / "o2")]) == 0
    v = json.loads(capsys.readouterr().out)
    fly = v["verdicts"]["flyable"]
    assert fly["pass"] is False and fly["violations"][0]["known"] is True and fly["violations"][0]["reason"] == reason
    assert v["pass"] is True and v["failures"] == [] and v["recorded"] == [{"failure": "flyable: dm", "reason": reason}]
    summary = json.loads((tmp_path / "o2" / "summary.json").read_text())
    assert summary["verdicts"]["flyable"]["violations"][0]["name"] == "dm" and summary["passed"] is True
    report = json.loads((tmp_path / "o2" / "report.json").read_text())
    assert report["verdict"]["verdicts"]["flyable"]["violations"][0]["known"] is True
    assert main(["compare", str(scen), "--out", str(tmp_path / "o3")]) == 0  # the printed form
    out = capsys.readouterr().out
    assert "flyable: FAIL (1 violation(s), 1 recorded by the scenario)" in out and f"recorded: {reason}" in out


@pytest.mark.parametrize(
    "table, message",
    [
        ('known = [{ name = "dll", reason = "x" }]', "name must be one of 'thrust[1]', 'thrust[2]', 'eta', 'dl'"),
        ('known = [{ name = "dl" }]', "reason"),
        ('known = [{ name = "dl", reason = "x", why = "y" }]', "unknown key 'why'"),
        ("knwon = []", "unknown key 'knwon' (did you mean 'known'?)"),
        ('known = [{ name = "dl", reason = "  " }]', "known #1 (dl): the reason is blank"),
        ('known = [{ name = "dl", reason = "a" }, { name = "dl", reason = "b" }]', "known #2: 'dl' recorded twice"),
    ],
)
def test_bad_verdicts_tables_are_one_line(tmp_path, table, message):
    p = tmp_path / "s.toml"
    p.write_text(SHORT + "[verdicts]\n" + table + "\n")
    with pytest.raises(InputError, match=re.escape(message)):
        load_scenario(str(p))


def test_the_paper_scenarios_record_their_known_violations():
    slip = load_scenario("gtm-forward-slip").known
    assert [k.name for k in slip] == ["dl"] and "GTM_FS" in slip[0].reason
    otter = load_scenario("twin-otter-single-engine").known
    assert [k.name for k in otter] == ["thrust[1]"] and "PT6A-27" in otter[0].reason
    assert load_scenario("gtm-aileron-roll").known == ()


def test_tracking_verdict_against_the_scenarios_tolerance(tmp_path):
    p = tmp_path / "short.toml"
    p.write_text(SHORT)
    pc = plan_case(ValidationCase(str(p)))
    opened = run_case(ValidationCase(str(p)), plan=pc.plan, scenario=pc.scenario)
    assert opened.verdicts()["tracking"]["pass"] is None  # open loop: nothing to judge
    case = ValidationCase(str(p), loop="closed", engines=("inhouse", "jsbsim"))
    r = run_case(case, plan=pc.plan, scenario=pc.scenario)
    t = r.verdicts()["tracking"]
    # the span (4 s) is shorter than the default settle time (5 s): judged at its end
    assert t["pass"] is True and t["settle_s"] == 5.0 and t["from_s"] == 4.0 and t["tolerance_m"] == 1.0
    err = t["max_error_after_settle_m"]
    strict = dataclasses.replace(pc.scenario, compare={"tracking_tolerance": err / 2, "settle_time": 1.0}, path=str(p))
    r2 = run_case(case, plan=pc.plan, scenario=strict)
    t2 = r2.verdicts()["tracking"]
    assert t2["from_s"] == 1.0 and t2["pass"] is (t2["max_error_after_settle_m"] <= err / 2)
    assert r2.settings.sources["tracking_tolerance"] == "scenario"
    if not t2["pass"]:
        assert r2.verdict()["failures"] == ["tracking"] and r2.verdict()["pass"] is False


def _verdicts(fly=True, trk=True, agree=True, infeasible=False, names=("dl",)):
    flyable = (
        {"pass": False, "infeasible": True, "reason": "Newton", "violations": []}
        if infeasible
        else {"pass": fly, "violations": [] if fly else [{"name": n} for n in names]}
    )
    return {"flyable": flyable, "tracking": {"pass": trk}, "engines_agree": {"pass": agree}}


def test_a_samples_cause_tells_the_plan_from_the_controller():
    known = (KnownViolation("dl", "the paper's"),)
    assert cause(_verdicts()) == "pass"
    assert cause(_verdicts(fly=False), known) == "pass"  # the recorded dl alone
    assert cause(_verdicts(fly=False)) == "unflyable"
    assert cause(_verdicts(fly=False, names=("dl", "dn")), known) == "unflyable"
    assert cause(_verdicts(infeasible=True, trk=False, agree=False), known) == "infeasible"
    assert cause(_verdicts(fly=False, trk=False, agree=False), known) == "controller failure"
    assert cause(_verdicts(agree=False)) == "engines disagree"
    assert cause(_verdicts(trk=None, agree=False)) == "engines disagree"  # open loop
    assert judge(_verdicts(trk=False), (KnownViolation("tracking", "r"),))["pass"] is True
    assert set(CAUSES) >= {"pass", "infeasible", "unflyable", "controller failure", "engines disagree", "error"}
