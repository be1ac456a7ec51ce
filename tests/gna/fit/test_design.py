"""Sampling designs: determinism, ranges, the longitudinal plane, the dm band, bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gna.aero import AERO_VARIABLES
from gna.errors import InputError
from gna.fit.design import Block, SamplingDesign, elevator_schedule, standard_design
from gna.fit.sources.linear import LinearDerivativeModel, parse_derivative

D = math.radians
RANGES = {
    "alpha": (D(-5), D(15)),
    "beta": (D(-10), D(10)),
    "phat": (-0.1, 0.1),
    "qhat": (-0.02, 0.02),
    "rhat": (-0.05, 0.05),
    "dl": (D(-20), D(20)),
    "dm": (D(-25), D(15)),
    "dn": (D(-30), D(30)),
}


def test_same_seed_same_points_other_seed_other_points():
    a = standard_design(RANGES, n_fit=50, n_test=10, seed=4).draw()
    b = standard_design(RANGES, n_fit=50, n_test=10, seed=4).draw()
    c = standard_design(RANGES, n_fit=50, n_test=10, seed=5).draw()
    for name in a:
        for k in range(2):
            assert all(np.array_equal(x, y) for x, y in zip(a[name][k], b[name][k]))
    assert not np.array_equal(a["box"][0].alpha, c["box"][0].alpha)


def test_points_lie_in_their_box_and_the_plane_holds_lateral_variables_at_zero():
    d = standard_design(RANGES, n_fit=300, n_test=100).draw()
    fit, test = d["box"]
    assert len(fit.alpha) == 300 and len(test.alpha) == 100
    for v, col in zip(AERO_VARIABLES, fit):
        lo, hi = RANGES[v]
        assert np.all((col >= lo) & (col <= hi)) and np.ptp(col) > 0.8 * (hi - lo)
    plane = d["longitudinal"][0]
    for v in ("beta", "phat", "rhat", "dl", "dn"):
        assert np.all(getattr(plane, v) == 0.0)
    assert np.ptp(plane.qhat) > 0


def _linear_pitch_model():
    ders = [parse_derivative(n, v) for n, v in (("Cmo", 0.04), ("Cm_a", -1.31), ("Cm_de", -1.74), ("CZ_a", -5.0))]
    return LinearDerivativeModel(ders, {}, "pitch model")


def test_elevator_schedule_solves_cm_zero():
    alpha, dm0 = elevator_schedule(_linear_pitch_model(), (D(-5), D(15)), (D(-25), D(15)))
    assert np.allclose(dm0, (0.04 - 1.31 * alpha) / 1.74, atol=1e-12)


def test_dm_band_points_stay_near_the_schedule():
    design = standard_design(RANGES, n_fit=400, n_test=100, dm_band=0.05)
    plane = design.draw(_linear_pitch_model())["longitudinal"][0]
    centre = (0.04 - 1.31 * plane.alpha) / 1.74
    assert np.all(np.abs(plane.dm - centre) <= 0.05 + 1e-9)
    assert np.all((plane.dm >= RANGES["dm"][0]) & (plane.dm <= RANGES["dm"][1]))
    with pytest.raises(InputError, match="source is needed|needs the source"):
        design.draw()


@pytest.mark.parametrize(
    "change, message",
    [
        ({"alpha": (0.3, 0.1)}, "range of alpha is empty"),
        ({"beta": (0.0, float("nan"))}, "not finite"),
        ({"dl": "x"}, "must be two numbers"),
    ],
)
def test_bad_ranges_are_refused(change, message):
    with pytest.raises(InputError, match=message):
        Block("b", ("CD",), {**RANGES, **change}, 10, 5)


def test_missing_variable_and_duplicate_coefficient_are_refused():
    with pytest.raises(InputError, match="missing: dn"):
        Block("b", ("CD",), {k: v for k, v in RANGES.items() if k != "dn"}, 10, 5)
    b1 = Block("a", ("CD", "CL"), RANGES, 10, 5)
    b2 = Block("b", ("CL",), RANGES, 10, 5)
    with pytest.raises(InputError, match="CL is fitted in two design blocks"):
        SamplingDesign((b1, b2))


def test_plane_needs_zero_inside_the_lateral_ranges():
    with pytest.raises(InputError, match="holds beta = 0"):
        standard_design({**RANGES, "beta": (D(1), D(10))})


def test_design_record_is_in_degrees_for_angles():
    rec = standard_design(RANGES, dm_band=0.1).to_dict()
    box = rec["blocks"]["box"]["ranges"]
    assert box["alpha_deg"] == [-5.0, 15.0] and box["qhat"] == [-0.02, 0.02]
    assert rec["blocks"]["longitudinal"]["dm_band_deg"] == pytest.approx(math.degrees(0.1))
