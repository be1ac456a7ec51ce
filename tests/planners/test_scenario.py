"""Scenario files: bundled scenarios, malformed input, calibration."""

from __future__ import annotations

import pytest

from gna.errors import InputError
from planners.scenario import list_scenarios, load_scenario, scenario_from_dict

from .conftest import WEAVE, make_scenario


def test_bundled_paper_scenarios_listed():
    assert {"twin-otter-single-engine", "gtm-forward-slip", "gtm-aileron-roll"} <= set(list_scenarios())


def test_grid_and_J_override():
    sc = make_scenario()
    assert sc.t_nodes[0] == 0.0 and sc.t_nodes[-1] == 30.0 and len(sc.t_nodes) == 61
    assert scenario_from_dict(WEAVE, J=2).J == 2


@pytest.mark.parametrize(
    "change, message",
    [
        ({"time": {"t1": -1.0}}, "must be after"),
        ({"time": {"step": 0.0}}, "step must be"),
        ({"flat_outputs": {"x": "import os"}}, "cannot parse"),
        ({"flat_outputs": {"zeta": "alpha"}}, "zeta must be one of"),
        ({"aircraft": "concorde"}, "unknown aircraft"),
        ({"generalized": {"J": -1}}, "J must be"),
        ({"environment": {"density": "mars"}}, "density must be"),
        ({"calibration": {"alpha": 0.1}}, "calibration failed"),
        ({"time": 5}, "must be a table"),
        ({"generalized": {"J": "two"}}, "whole number"),
        ({"generalized": {"J": 2.7}}, "whole number"),
        ({"time": {"step": 0.7}}, "does not divide"),
        ({"time": {"t1": 1e9, "step": 1.0}}, "exceed the limit"),
        ({"report": {"times": ["abc"]}}, "times must be"),
        ({"report": {"times": [100.0]}}, "times must be"),
        ({"report": {"variables": ["theta"]}}, "variables must be"),
        ({"flat_outputs": {"zeta_value": "1/0"}}, "cannot be evaluated"),
        ({"flat_outputs": {"zeta_value": "10**400"}}, "cannot be evaluated"),
    ],
)
def test_malformed(change, message):
    with pytest.raises(Exception, match=message) as exc:
        make_scenario(**change)
    assert hasattr(exc.value, "args")


def test_unknown_scenario_lists_bundled():
    with pytest.raises(InputError, match="bundled scenarios: .*gtm-forward-slip"):
        load_scenario("loop-the-loop")


def test_calibration_gives_h_values():
    sc = make_scenario(calibration={"V": 150.0, "gamma": 0.0, "chi_dot": 0.05, "beta": 0.0})
    # a steady turn: nonzero rates and surfaces become the first iterate's H values
    assert sc.h.q > 0 and sc.h.r > 0 and sc.h.dm < 0


def test_auto_j_settings_beside_a_fixed_j_are_refused(tmp_path):
    """J_tol / J_max only mean something with J = "auto": beside a whole J they would be silently ignored."""
    import pytest as _pytest

    from gna.errors import InputError as _InputError
    from planners.scenario import load_scenario as _load

    src = _load("gtm-aileron-roll").path
    text = open(src, encoding="utf-8").read()
    p = tmp_path / "s.toml"
    p.write_text(text.replace("\nJ = 7\n", "\nJ = 7\nJ_max = 9\n"))
    with _pytest.raises(_InputError, match='J_max applies only to J = "auto" \\(here J = 7\\)'):
        _load(p)
    p.write_text(text.replace("\nJ = 7\n", '\nJ = "auto"\nJ_max = 9\n'))
    assert _load(p).J_max == 9


def test_compare_keys_are_checked_by_the_loader_whatever_the_command():
    """``[compare]`` is read by gflat compare / paper, but a misspelt key is refused when the file is loaded,
    with the closest known key (one list, planners.scenario.COMPARE_KEYS, also the harness's)."""
    import pytest

    from gna.errors import InputError
    from harness.validation.tolerances import COMPARE_KEYS as HARNESS_KEYS
    from planners.scenario import COMPARE_KEYS

    from .conftest import make_scenario

    assert HARNESS_KEYS is COMPARE_KEYS
    with pytest.raises(InputError, match=r"\[compare\]: unknown key 'tolerance' \(did you mean 'tolerances'\?\)"):
        make_scenario(compare={"tolerance": 1.0})
    assert make_scenario(compare={"tolerances": 1.0}).compare == {"tolerances": 1.0}


def test_J_given_instead_of_the_files_is_blamed_as_such():
    import pytest

    from gna.errors import InputError
    from planners.scenario import load_scenario

    with pytest.raises(InputError, match=r"^J \(given instead of the file's\): J must be between 0 and 30"):
        load_scenario("gtm-aileron-roll", J=1000)
