"""Up-front bounds on a command's work: refused before anything is planned, flown or written (one line, exit 2)."""

from __future__ import annotations

import pytest

from harness.campaign.checks import MAX_CASES, check_samples
from harness.campaign.spec import load_campaign
from harness.cli import main
from harness.commands._compare_args import MAX_STEPS, SAMPLE_COST, flight_steps
from harness.validation import ValidationCase, case_settings
from planners.scenario import list_scenarios, load_scenario


@pytest.mark.parametrize(
    "argv, value",
    [
        (["compare", "gtm-aileron-roll", "--jsbsim-dt", "1e-7"], "--jsbsim-dt 1e-07 s"),
        (["compare", "gtm-aileron-roll", "--dt-out", "1e-5"], "--dt-out 1e-05 s"),
        (["paper", "--jsbsim-dt", "1e-6"], "--jsbsim-dt 1e-06 s"),
        (["compare", "gtm-aileron-roll", "--jsbsim-dt", "1e-4", "--max-steps", "1e4"], "--jsbsim-dt 0.0001 s"),
        # beyond what any machine holds, whatever the bound (was a ValueError traceback from numpy)
        (["compare", "gtm-aileron-roll", "--jsbsim-dt", "1e-300", "--max-steps", "inf"], "--jsbsim-dt 1e-300 s"),
    ],
)
def test_a_run_beyond_the_step_bound_is_refused_before_any_work(argv, value, tmp_path, capsys):
    out = tmp_path / "out"
    assert main([*argv, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and value in err and "above the bound" in err and "--max-steps" in err
    assert not out.exists()  # nothing planned, flown or written


@pytest.mark.parametrize("text", ["0", "-1", "x"])
def test_a_bad_step_bound_is_a_usage_error(text, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["compare", "gtm-aileron-roll", "--max-steps", text])
    assert exc.value.code == 2


@pytest.mark.parametrize("name", list_scenarios())
def test_every_bundled_scenario_fits_the_default_bound(name):
    sc = load_scenario(name)
    total = 0
    for loop in ("open", "closed"):
        case = ValidationCase(name, engines=("inhouse", "jsbsim"), loop=loop, self_convergence=True)
        steps, samples = flight_steps(case, sc, case_settings(case, sc))
        assert steps > 0 and samples > 0
        total += steps + SAMPLE_COST * samples
    assert total < MAX_STEPS / 10


def test_flight_steps_counts_every_flight():
    sc = load_scenario("gtm-aileron-roll")  # 8 s
    case = ValidationCase("gtm-aileron-roll", engines=("inhouse", "jsbsim"), loop="closed", dt_out=0.5, jsbsim_dt=0.01)
    steps, samples = flight_steps(case, sc, case_settings(case, sc))
    assert steps == 800 and samples == 4 * 17  # closed loop: open-loop and flat-loop flights too


def test_campaign_samples_bound(tmp_path, capsys):
    out = tmp_path / "c"
    assert main(["campaign", "run", "paper-dispersions", "--samples", "100000000", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "--samples 100000000" in err and "3e+08 cases" in err and "1e+05" in err
    assert not out.exists()
    assert main(["campaign", "run", "paper-dispersions", "--samples", "3", "--max-cases", "5", "--out", str(out)]) == 2
    assert "9 cases, above the bound 5" in capsys.readouterr().err
    camp = load_campaign("paper-dispersions")
    assert check_samples(camp, None) == camp.samples * len(camp.cases) * len(camp.dispersions) <= MAX_CASES


def test_flight_work_puts_the_closed_loop_jsbsim_flights_first():
    """The paper's flights by flight_work: JSBSim's closed loop (two runs of the models per update) first, the
    longest span first; the in-house flights counted by their output samples."""
    from harness.commands.paper import paper_cases
    from harness.validation import plan_case
    from harness.validation.flights import FLAT_LOOP, case_flights
    from harness.validation.work import flight_work

    work = {}
    for loop in ("open", "closed"):
        for case in paper_cases(loop=loop):
            planned = plan_case(case)
            cf = case_flights(case, plan=planned.plan, scenario=planned.scenario)
            span = planned.plan.t1 - planned.plan.t0
            samples = int(span / cf.settings.dt_out + 1e-9) + 1
            steps = round(span / cf.settings.jsbsim_dt)
            for name in cf.flights:
                work[(case.scenario, loop, name)] = flight_work(cf, name)
            assert work[(case.scenario, loop, "inhouse")] == SAMPLE_COST * samples
            assert (
                work[(case.scenario, loop, "jsbsim")] == steps * (2 if loop == "closed" else 1) + SAMPLE_COST * samples
            )
            if loop == "closed":
                assert work[(case.scenario, loop, FLAT_LOOP)] == SAMPLE_COST * samples  # the in-house reference's
    first = max(work, key=work.get)
    assert first == ("gtm-forward-slip", "closed", "jsbsim")
