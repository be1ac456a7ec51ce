"""Campaign files: schema errors, product of cases, seeds and draws (no flying)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from gna.aircraft import load_aircraft
from gna.errors import InputError
from harness.campaign import campaign_from_dict, draw_sample, load_campaign, sample_seed
from harness.campaign.sampling import dispersed_aircraft, term_std_errors
from harness.campaign.spec import Dispersion
from harness.cli import main

BASE = {"seed": 3, "cases": [{"scenario": "twin-otter-single-engine", "loop": "closed"}]}


@pytest.mark.parametrize(
    "data, message",
    [
        ({**BASE, "samles": 4}, "unknown key 'samles' (did you mean 'samples'?)"),
        ({**BASE, "cases": [{"scenario": "twin-otter-single-engine", "lop": "open"}]}, "(did you mean 'loop'?)"),
        ({**BASE, "dispersions": {"d": {"mas": 0.1}}}, "(did you mean 'mass'?)"),
        ({**BASE, "dispersions": {"d": {"aero": "wild"}}}, "aero must be one of"),
        ({**BASE, "dispersions": {"d": {"mass": -0.1}}}, "mass must be >= 0"),
        ({**BASE, "seed": -1}, "seed must be a non-negative whole number"),
        ({"seed": 1}, "needs at least one [[cases]]"),
        ({**BASE, "cases": BASE["cases"] * 2}, "duplicate case labels"),
        ({**BASE, "dispersions": {"a/b": {"mass": 0.1}}}, "c.toml [dispersions.a/b]: name = 'a/b' is not a safe"),
    ],
)
def test_bad_campaign_files_give_one_line(data, message):
    with pytest.raises(InputError) as exc:
        campaign_from_dict(data, where="c.toml")
    assert message in str(exc.value) and "\n" not in str(exc.value)


def _case(**kw) -> dict:
    return {"seed": 3, "cases": [{"id": "to", "scenario": "twin-otter-single-engine", **kw}]}


@pytest.mark.parametrize(
    "data, message",
    [
        (
            _case(scenario="twin-otter"),
            "c.toml [[cases]] #1 (case to): scenario = 'twin-otter' is not a bundled "
            "scenario (did you mean 'twin-otter-single-engine'?)",
        ),
        (_case(scenario="gtm-aileron-rol"), "(did you mean 'gtm-aileron-roll'?)"),
        (_case(scenario=["gtm-aileron-roll", "nope"]), "(case to-nope): scenario = 'nope' is not a bundled scenario"),
        (_case(scenario="missing/roll.toml"), "(case to): scenario = 'missing/roll.toml': scenario file"),
        (_case(J=[1, 99]), "c.toml [[cases]] #1 (case to-J99): J must be between 0 and 30, got 99"),
        (_case(J=31), "(case to): J must be between 0 and 30, got 31"),
        (_case(J=-1), "c.toml [[cases]] #1 (case to): J must be between 0 and 30, got -1"),
        (_case(J=True), "(case to): J must be a whole number, got True"),
        (_case(J="autoo"), "c.toml [[cases]] #1: J must be an integer >= 0, 'auto' or None, got 'autoo'"),
        (_case(dt_out=0.7), "(case to): dt_out = 0.7 s does not divide the span"),
        (_case(loop="clsed"), "c.toml [[cases]] #1: loop must be one of open, closed, got 'clsed'"),
        (_case(engines=["inhouse", "jsbsm"]), "c.toml [[cases]] #1: engines: at least 2 distinct"),
        (_case(tolerances={"postion": 1.0}), "c.toml [[cases]] #1: "),
        (_case(id="../up"), "c.toml [[cases]] #1: id = '../up' is not a safe identifier"),
    ],
)
def test_bad_case_values_refused_when_the_file_is_read(data, message):
    """Every expanded case is checked before anything runs: one line naming the file, the case, key and value."""
    with pytest.raises(InputError) as exc:
        campaign_from_dict(data, where="c.toml")
    assert message in str(exc.value) and "\n" not in str(exc.value)


def test_bad_case_refused_by_the_cli_before_anything_is_written(tmp_path, capsys):
    """The new user's campaign: an unknown scenario and J = [1, 99]: exit 2, one line, no folder."""
    for i, case in enumerate(('scenario = "twin-otter"', 'scenario = "twin-otter-single-engine"\nJ = [1, 99]')):
        src = tmp_path / f"c{i}.toml"
        src.write_text(f'name = "c"\nseed = 1\n[[cases]]\nid = "to"\n{case}\nloop = "closed"\n')
        out = tmp_path / f"out{i}"
        assert main(["campaign", "run", str(src), "--out", str(out), "--workers", "1"]) == 2
        captured = capsys.readouterr()
        err = captured.err.strip()
        assert len(err.splitlines()) == 1 and f"c{i}.toml [[cases]] #1 (case to" in err and not captured.out
        assert ("'twin-otter' is not a bundled scenario" if i == 0 else "J must be between 0 and 30, got 99") in err
        assert not out.exists()


def test_scenario_compare_table_checked_with_the_case(tmp_path):
    """The scenario's [compare] merged with the case's settings at load time: a bad value there, or a
    dt_out from it that does not divide the span, is refused before running."""
    text = (Path(__file__).parent / "tiny-level.toml").read_text()
    (tmp_path / "lv.toml").write_text(text + "\n[compare]\ndt_out = 0.3\n")
    data = {"seed": 1, "cases": [{"id": "lv", "scenario": "lv.toml"}]}
    with pytest.raises(InputError, match=r"\(case lv\): .*lv.toml \[compare\] dt_out = 0.3 s does not divide"):
        campaign_from_dict(data, where="c.toml", base=tmp_path)
    assert campaign_from_dict({**data, "cases": [{**data["cases"][0], "dt_out": 0.5}]}, base=tmp_path).cases


def test_product_of_cases_and_dispersions():
    camp = campaign_from_dict(
        {
            **BASE,
            "cases": [{"id": "to", "scenario": "twin-otter-single-engine", "loop": ["open", "closed"], "J": [0, 4]}],
            "dispersions": {"a": {"mass": 0.01}, "b": {"aero": "none"}},
        }
    )
    assert [c.label for c in camp.cases] == ["to-J0-open", "to-J0-closed", "to-J4-open", "to-J4-closed"]
    tasks = camp.tasks(2)
    assert len(tasks) == 4 * 2 * 2 and len({t.case_id for t in tasks}) == 16
    assert tasks[0].case_id == "to-J0-open.a.0000" and tasks[0].spec.case.J == 0


def test_seeds_are_stable_and_independent_of_the_count():
    camp = load_campaign("paper-dispersions")
    few, many = camp.tasks(2), camp.tasks(5)
    by_id = {t.case_id: t.seed for t in many}
    assert all(by_id[t.case_id] == t.seed for t in few)
    assert len(set(by_id.values())) == len(by_id)
    assert sample_seed(1, "a.b", 0) == sample_seed(1, "a.b", 0) != sample_seed(2, "a.b", 0)
    assert 0 <= sample_seed(1, "a.b", 0) < 2**63


def test_draws_are_reproducible_and_follow_the_standard_errors():
    ac = load_aircraft("twin-otter")
    se = term_std_errors(ac)
    assert se.shape == (len(ac.aero.terms),) and np.isfinite(se).all()
    disp = Dispersion(name="d", aero="std_error", mass=0.02, position_m=1.0)
    a, b = draw_sample(ac, disp, 11), draw_sample(ac, disp, 11)
    assert np.array_equal(a.aero_values, b.aero_values) and a.parameters() == b.parameters()
    values = np.array([t.value for t in ac.aero.terms])
    assert np.allclose(a.aero_values, values + se * a.aero_z)
    assert np.all(np.abs(a.aero_z) <= 3.0) and a.inertia_scale == 1.0
    flown = dispersed_aircraft(ac, a)
    assert flown.mass.mass == pytest.approx(ac.mass.mass * a.mass_scale)
    assert [t.value for t in flown.aero.terms] == list(a.aero_values)
    nominal = draw_sample(ac, Dispersion(aero="none"), 11)
    assert np.array_equal(nominal.aero_values, values) and not nominal.offsets.any()


def test_campaign_file_paths_are_checked_like_scenario_files(tmp_path):
    """A folder, a missing file and a non-UTF-8 file each give their own one-line error (the loaders' shared
    gna.schema.find_file and read_toml); a byte-order mark is accepted."""
    with pytest.raises(InputError, match="is a folder"):
        load_campaign(tmp_path)
    with pytest.raises(InputError, match="no such file"):
        load_campaign(tmp_path / "none.toml")
    bad = tmp_path / "bad.toml"
    bad.write_bytes(b"\xff\xfe")
    with pytest.raises(InputError, match="not UTF-8"):
        load_campaign(bad)
    with pytest.raises(InputError, match="unknown campaign"):
        load_campaign("no-such-campaign")


def test_a_shortened_name_is_suggested_by_the_shared_did_you_mean():
    from gna.schema import did_you_mean

    assert (
        did_you_mean("twin-otter", ["twin-otter-single-engine", "gtm-aileron-roll"])
        == " (did you mean 'twin-otter-single-engine'?)"
    )
    assert did_you_mean("gtm", ["gtm-aileron-roll", "gtm-forward-slip"]) == ""  # two names start so: no guess
