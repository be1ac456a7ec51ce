"""Singularity monitor: the paper's determinants vanish where it says they do."""

from __future__ import annotations

import numpy as np

from planners.generalized import plan_scenario

from .conftest import make_scenario


def test_regular_plan_has_no_warning(weave_plan):
    _, plan = weave_plan
    rep = plan.singularities
    assert rep.condition == "cond_beta" and rep.warnings == []
    assert np.all(np.abs(rep.table["cond_beta"]) > 0)
    assert np.all(rep.table["cos_beta"] > 0.99)


def test_thrust_output_singular_in_vertical_plane():
    """Flat output F in a vertical plane with beta = mu = 0: eq. (cond_F) vanishes (paper, 'The thrust choice').

    Straight level flight with F prescribed at exactly the drag of beta = 0 flight: the solution is
    beta = mu = 0, where d/dmu of the forces vanishes by symmetry.
    """
    from gna.trim import trim_level

    sc0 = make_scenario()
    tr = trim_level(sc0.aircraft, 150.0, 3000.0, env=sc0.env)
    # start Newton on the symmetric solution (calibration: the beta = 0 level trim)
    sc = make_scenario(
        flat_outputs={"x": "150*t", "y": "0", "z": "-3000", "zeta": "F", "zeta_value": repr(tr.values["F"])},
        time={"t1": 5.0},
        calibration={"V": 150.0, "gamma": 0.0, "chi_dot": 0.0, "beta": 0.0},
    )
    plan = plan_scenario(sc, J=0)
    rep = plan.singularities
    assert rep.condition == "cond_F"
    assert np.max(np.abs(rep.table["cond_F"])) < 1e-6
    assert any("cond_F" in w and "zero" in w for w in plan.warnings)


def test_sideslip_output_singular_at_zero_g():
    """Flat output beta in a zero-g parabola: eq. (cond_beta) vanishes (paper: it 'excludes 0-g flight'),
    whereas the bank-angle output mu is regular there (the paper's choice for the aileron roll)."""
    fo = {"x": "150*t", "y": "0", "z": "-3000 + 0.5*g0*t**2"}
    tm = {"t0": -3.0, "t1": 3.0, "step": 0.25}
    plan = plan_scenario(make_scenario(flat_outputs=dict(fo, zeta="beta", zeta_value="0"), time=tm), J=0)
    assert plan.singularities.condition == "cond_beta"
    assert np.max(np.abs(plan.singularities.table["cond_beta"])) < 1e-9
    assert any("cond_beta" in w and "near zero" in w for w in plan.warnings)
    plan = plan_scenario(make_scenario(flat_outputs=dict(fo, zeta="mu", zeta_value="1.5*t"), time=tm), J=0)
    assert plan.singularities.condition == "stalling_cond"
    assert np.min(np.abs(plan.singularities.table["stalling_cond"])) > 1.0
    assert plan.singularities.warnings == []


def test_mixed_output_condition_is_dimensionless():
    """The mixed output's determinant is divided by the thrust pivot like the others: regular flight is quiet."""
    plan = plan_scenario(
        make_scenario(flat_outputs={"zeta": "mix", "zeta_value": "0", "f1": "1", "f2": "1"}, time={"t1": 10.0}), J=0
    )
    assert plan.singularities.condition == "det4"
    assert np.min(np.abs(plan.singularities.table["det4"])) > 0.1
    assert plan.singularities.warnings == []


def test_numerically_singular_stage_2_is_a_failure_naming_time_and_condition():
    """Flat output beta at zero g (the aileron roll with zeta = 'beta'): eq. (cond_beta) is zero at every node,
    so the stage-2 solution is one of a continuum and the later iterates diverge; the plan is not feasible,
    and its first failure names stage 2, the condition and the times (not the diverged alpha)."""
    fo = {"x": "150*t", "y": "0", "z": "-3000 + 0.5*g0*t**2", "zeta": "beta", "zeta_value": "0"}
    plan = plan_scenario(make_scenario(flat_outputs=fo, time={"t0": -3.0, "t1": 3.0, "step": 0.25}), J=1)
    fail = plan.singularities.failures
    assert len(fail) == 1 and not plan.feasible
    assert "stage 2 of the flat parametrization is singular at t = -3 .. 3 s (25 nodes)" in fail[0]
    assert "cond_beta" in fail[0] and "zeta = 'beta'" in fail[0]
    assert plan.domain_failures[0] == fail[0]


def test_regular_plans_have_no_singularity_failure(weave_plan):
    _, plan = weave_plan
    assert plan.singularities.failures == [] and plan.feasible
