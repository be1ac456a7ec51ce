"""Robustness of the tracking feedback: plans made on the nominal model, flown closed loop on the in-house
engine with a perturbed model (every aerodynamic term x a seeded factor in [0.9, 1.1], mass + 5 %) and an
initial offset (5 m along (1, 1, 1)/sqrt(3), + 1 m/s, + 1 deg on gamma, chi, alpha, beta, mu); and the
``[tracking]`` table of scenario files with its perturbation (gna.perturbation)."""

from __future__ import annotations

import math
import pickle

import numpy as np
import pytest

from gna.aircraft import load_aircraft
from gna.errors import InputError
from gna.perturbation import Perturbation, offset_state, perturbation_from_dict, perturbed_aircraft
from harness.engines import get_engine
from planners import tracking as tr
from planners.generalized import plan_scenario
from planners.scenario import Tracking, load_scenario, scenario_from_dict

#: The perturbation the issue asks for.
PAPER_TEST = Perturbation(
    aero_spread=0.1, mass_scale=1.05, position_m=5.0, speed_mps=1.0, angle_rad=math.radians(1.0), seed=1
)


def _fly(name, perturbation, *, saturate=None, t1=None):
    """Closed loop on the in-house engine; returns (result, times, |(x, y, z) - flat outputs|)."""
    sc = load_scenario(name)
    plan = plan_scenario(sc)
    c = tr.tracking_controller(
        plan,
        sc.tracking.lambdas,
        feedforward_iterate=sc.tracking.feedforward_iterate,
        saturate=sc.tracking.saturate if saturate is None else saturate,
    )
    ac = perturbed_aircraft(plan.aircraft, perturbation)
    x0 = offset_state(plan.initial_state(), perturbation)
    t1 = plan.t_nodes[-1] if t1 is None else t1
    tt = np.arange(plan.t0, t1 + 1e-9, 0.1)
    res = get_engine("inhouse").simulate(ac, c, (plan.t0, t1), x0, controller=c, env=plan.env, t_eval=tt)
    t = res.df.index.to_numpy()
    err = np.linalg.norm(res.df[["x", "y", "z"]].to_numpy().T - np.array([plan.evaluate(n, t) for n in "xyz"]), axis=0)
    return res, plan, t, err


# ------------------------------------------------------------------------------------------------
# Perturbation (model level)
# ------------------------------------------------------------------------------------------------


def test_perturbed_aircraft_is_deterministic_and_within_spread():
    ac = load_aircraft("twin-otter")
    a1 = perturbed_aircraft(ac, PAPER_TEST)
    a2 = perturbed_aircraft(ac, pickle.loads(pickle.dumps(PAPER_TEST)))
    v0 = np.array([t.value for t in ac.aero.terms])
    v1 = np.array([t.value for t in a1.aero.terms])
    assert np.array_equal(v1, [t.value for t in a2.aero.terms])
    nz = v0 != 0
    ratio = v1[nz] / v0[nz]
    assert np.all((ratio >= 0.9) & (ratio <= 1.1)) and np.std(ratio) > 0.02
    assert a1.mass.mass == pytest.approx(1.05 * ac.mass.mass) and a1.mass.Ixx == ac.mass.Ixx
    assert "seed 1" in a1.provenance["perturbation"] and a1.id == ac.id
    other = np.array([t.value for t in perturbed_aircraft(ac, PAPER_TEST.with_seed(2)).aero.terms])
    assert not np.array_equal(v1, other)
    assert perturbed_aircraft(ac, Perturbation(position_m=3.0)) is ac


def test_explicit_factors_and_offsets():
    ac = load_aircraft("twin-otter")
    first = ac.aero.terms[0]
    p = Perturbation(
        aero_scale={"CL": 2.0, str(first.index): 3.0},
        inertia_scale=1.1,
        state_offsets={"q": 0.1, "x": 1.0},
        position_m=math.sqrt(3.0),
        speed_mps=2.0,
        angle_rad=0.01,
    )
    a = perturbed_aircraft(ac, p)
    for t0, t1 in zip(ac.aero.terms, a.aero.terms):
        f = (2.0 if t0.coefficient == "CL" else 1.0) * (3.0 if t0 is first else 1.0)
        assert t1.value == pytest.approx(f * t0.value)
    assert a.mass.Ixz == pytest.approx(1.1 * ac.mass.Ixz)
    x = offset_state(np.zeros(12), p)
    np.testing.assert_allclose(x, [2.0, 1.0, 1.0, 2.0, 0.01, 0.01, 0.01, 0.01, 0.01, 0.0, 0.1, 0.0])
    with pytest.raises(InputError, match="seed"):
        Perturbation(aero_spread=0.1)
    with pytest.raises(InputError, match="did you mean 'CL'"):
        Perturbation(aero_scale={"CLL": 1.1})
    with pytest.raises(InputError, match="not in the aerodynamic table"):
        perturbed_aircraft(ac, Perturbation(aero_scale={99999: 1.1}))
    with pytest.raises(InputError, match="did you mean 'mass_scale'"):
        perturbation_from_dict({"mass_scal": 1.05})
    with pytest.raises(InputError, match="must be positive"):
        Perturbation(mass_scale=-1.0)


# ------------------------------------------------------------------------------------------------
# The [tracking] table
# ------------------------------------------------------------------------------------------------


def test_bundled_tracking_tables():
    to = load_scenario("twin-otter-single-engine").tracking
    assert to.lambdas == tr.TWIN_OTTER_LAMBDAS and to.feedforward_iterate == -1 and to.saturate
    fs = load_scenario("gtm-forward-slip").tracking
    assert fs.lambdas == 0.5 and not fs.saturate
    assert load_scenario("gtm-aileron-roll").tracking.lambdas == tr.ROLL_LAMBDAS
    f16 = load_scenario("f16-s-turn").tracking
    assert len(f16.lambdas) == 4 and f16.perturbation is None


def _with_tracking(table, zeta="beta"):
    fo = {"x": "150*t", "y": "0", "z": "-3000", "zeta": zeta, "zeta_value": "0"}
    return scenario_from_dict(
        {
            "aircraft": "f16c",
            "time": {"t0": 0.0, "t1": 10.0, "step": 1.0},
            "flat_outputs": fo,
            "generalized": {"J": 2},
            "tracking": table,
        },
        where="t.toml",
    )


def test_tracking_table_parsing():
    assert _with_tracking({}).tracking == Tracking()
    t = _with_tracking(
        {
            "lambdas": {"I1": [1, 2, 3], "I2": [1] * 5, "I3": [2] * 5, "I4": [1, 1, 1]},
            "feedforward_iterate": 0,
            "saturate": False,
            "perturbation": {"aero_spread": 0.1, "seed": 7, "mass_scale": 1.05, "state_offsets": {"V": 1.0}},
        }
    ).tracking
    assert t.lambdas[0] == (1.0, 2.0, 3.0) and t.feedforward_iterate == 0 and not t.saturate
    assert t.perturbation == Perturbation(aero_spread=0.1, seed=7, mass_scale=1.05, state_offsets={"V": 1.0})
    assert _with_tracking({"lambdas": 0.5}, zeta="F").tracking.lambdas == 0.5


@pytest.mark.parametrize(
    "table, match",
    [
        ({"lambda": 1.0}, "unknown key 'lambda' \\(did you mean 'lambdas'\\?\\)"),
        ({"saturate": 1}, "saturate must be true or false"),
        ({"feedforward_iterate": 1.5}, "feedforward_iterate must be a whole number"),
        ({"feedforward_iterate": 3}, "not an iterate"),
        ({"lambdas": -1.0}, "positive"),
        ({"lambdas": "fast"}, "positive"),
        ({"lambdas": {"I1": [1, 2, 3], "I2": [1] * 5, "I3": [1] * 5}}, "missing I4"),
        ({"lambdas": {"I1": [1, 2], "I2": [1] * 5, "I3": [1] * 5, "I4": [1] * 3}}, "I1 must be a list of 3"),
        (
            {"lambdas": {"I1": [1, 2, 3], "I2": [1] * 5, "I3": [1] * 5, "I5": [1] * 3}},
            "unknown key 'I5'.*I1, I2, I3, I4",
        ),
        ({"perturbation": {"seeds": 3}}, "tracking.perturbation\\]: unknown key 'seeds' \\(did you mean 'seed'"),
        ({"perturbation": {"aero_spread": 0.1}}, "needs a seed"),
        ({"perturbation": {"mass_scale": "big"}}, "mass_scale must be a finite number"),
        ({"perturbation": {"state_offsets": {"vv": 1.0}}}, "unknown key 'vv'"),
        (
            {"perturbation": {"state_offsets": {"vv": 1.0}}},
            "^t.toml \\[tracking.perturbation\\] state_offsets: unknown key",
        ),
        ({"perturbation": 3}, "must be a table"),
    ],
)
def test_tracking_table_refusals(table, match):
    with pytest.raises(InputError, match=match):
        _with_tracking(table)


def test_no_fourth_integral_with_the_thrust_output():
    with pytest.raises(InputError, match="no I4 with the thrust"):
        _with_tracking({"lambdas": {"I1": [1] * 5, "I2": [1] * 5, "I3": [1] * 5, "I4": [1] * 3}}, zeta="F")


# ------------------------------------------------------------------------------------------------
# Closed loop on a perturbed model
# ------------------------------------------------------------------------------------------------


def test_twin_otter_absorbs_the_perturbation_within_10s():
    """Measured (seed 1, saturation on): 5.12 m max, below 1 m from t = 5.2 s on, 0.116 m max after 10 s,
    1.5e-4 m at 60 s; thrust saturated 2.6 s."""
    res, plan, t, err = _fly("twin-otter-single-engine", PAPER_TEST)
    assert res.status == "completed"
    assert err[0] == pytest.approx(5.0)
    assert np.max(err[t >= plan.t0 + 10.0]) < 1.0


@pytest.mark.xfail(
    strict=True,
    reason=(
        "the paper's lambda = 0.5 loop departs (seed 1: t = 2.2 s without saturation; with it, the plan's dl = -28 deg "
        "is clipped at the GTM's 20 deg and it departs at 0.9 s). Measured causes (python research/tracking_robustness.py "
        "--analysis; docs/tracking.md, Robustness): the same flat outputs cannot be planned on 12 of 20 perturbed models, "
        "seed 1 among them (a glider's only drag control is the slip, already at beta = 0.40); the frozen-time loop is "
        "strongly non-normal (max ||exp(Mt)|| = 284, distance to instability 3.3e-4) and the seed-1 aerodynamics move its "
        "slowest pole from -0.198 to -0.023; faster lambdas demand radians of rudder and depart sooner"
    ),
)
def test_forward_slip_absorbs_the_full_perturbation_within_40s():
    res, plan, t, err = _fly("gtm-forward-slip", PAPER_TEST, t1=60.0)
    assert res.status == "completed"
    assert np.max(err[t >= plan.t0 + 40.0]) < 1.0


def test_forward_slip_absorbs_a_small_offset_within_40s():
    """What holds: the nominal model and a fifth of the offset (1 m, 0.2 m/s, 0.2 deg), saturation off
    (the file's setting).  Measured: 1.15 m max, 0.82 m max after 10 s, 5e-3 m max after 40 s.  Half the
    offset (2.5 m, 0.5 m/s, 0.5 deg) departs at t = 9.6 s."""
    small = Perturbation(position_m=1.0, speed_mps=0.2, angle_rad=math.radians(0.2))
    res, plan, t, err = _fly("gtm-forward-slip", small)
    assert res.status == "completed"
    assert np.max(err[t >= plan.t0 + 40.0]) < 1.0


def test_aileron_roll_completes_unsaturated():
    """Measured (seed 1): saturation off, the run completes, below 1 m from t = 3.3 s on, 0.117 m at the end
    (t = 5.5 s); with saturation on it departs at t = 0.3 s (half the offset: completes, 0.43 m at the end)."""
    res, plan, t, err = _fly("gtm-aileron-roll", PAPER_TEST, saturate=False)
    assert res.status == "completed"
    assert err[-1] < 0.5
