"""Campaign files: schema errors, product of cases, seeds and draws (no flying)."""

from __future__ import annotations

import numpy as np
import pytest

from gna.aircraft import load_aircraft
from gna.errors import InputError
from harness.campaign import campaign_from_dict, draw_sample, load_campaign, sample_seed
from harness.campaign.sampling import dispersed_aircraft, term_std_errors
from harness.campaign.spec import Dispersion

BASE = {"seed": 3, "cases": [{"scenario": "twin-otter-single-engine", "loop": "closed"}]}


@pytest.mark.parametrize("data, message", [
    ({**BASE, "samles": 4}, "unknown key 'samles' (did you mean 'samples'?)"),
    ({**BASE, "cases": [{"scenario": "twin-otter-single-engine", "lop": "open"}]}, "(did you mean 'loop'?)"),
    ({**BASE, "dispersions": {"d": {"mas": 0.1}}}, "(did you mean 'mass'?)"),
    ({**BASE, "dispersions": {"d": {"aero": "wild"}}}, "aero must be one of"),
    ({**BASE, "dispersions": {"d": {"mass": -0.1}}}, "mass must be >= 0"),
    ({**BASE, "seed": -1}, "seed must be a non-negative whole number"),
    ({"seed": 1}, "needs at least one [[cases]]"),
    ({**BASE, "cases": BASE["cases"] * 2}, "duplicate case labels"),
])
def test_bad_campaign_files_give_one_line(data, message):
    with pytest.raises(InputError) as exc:
        campaign_from_dict(data, where="c.toml")
    assert message in str(exc.value) and "\n" not in str(exc.value)


def test_product_of_cases_and_dispersions():
    camp = campaign_from_dict({**BASE, "cases": [{"id": "to", "scenario": "twin-otter-single-engine",
                                                  "loop": ["open", "closed"], "J": [0, 4]}],
                               "dispersions": {"a": {"mass": 0.01}, "b": {"aero": "none"}}})
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
    assert 0 <= sample_seed(1, "a.b", 0) < 2 ** 63


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
