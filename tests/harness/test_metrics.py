"""Metrics: difference tables, tolerances, deviation from the plan, and the pytest helper."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from gna.eom import STATE_NAMES
from gna.errors import InputError
from harness.metrics import (
    DEFAULT_TOLERANCES,
    PERCENT_FLOORS,
    difference_table,
    differences,
    engine_tables,
    max_position_error,
    percent_floor,
    position_error,
    window_span,
)
from harness.testing import assert_trajectories_close


def _traj(t, **over):
    data = {n: np.zeros_like(t) for n in STATE_NAMES}
    data.update(over)
    return pd.DataFrame(data, index=pd.Index(t, name="t"))


def test_table_values_time_of_maximum_and_pass_fail():
    t = np.linspace(0.0, 10.0, 101)
    a = _traj(t, x=t, mu=0.1 * t)
    b = _traj(t, x=t + 1e-3 * np.sin(t), y=np.where(t == 3.0, 4e-3, 0.0), mu=0.1 * t + 2e-4 * (t == 7.0))
    tab = difference_table(a, b, labels=("ref", "other"))
    pos = tab.row("position")
    assert pos.max_abs == pytest.approx(4e-3, rel=1e-3) and pos.t_max == pytest.approx(3.0)
    assert tab.row("x").rms == pytest.approx(np.sqrt(np.mean((1e-3 * np.sin(t)) ** 2)), rel=1e-12)
    mu = tab.row("mu")
    assert mu.max_abs == pytest.approx(2e-4) and mu.t_max == pytest.approx(7.0) and mu.passed is False
    assert pos.passed is True and pos.tolerance == DEFAULT_TOLERANCES["position"] and pos.unit == "m"
    assert not tab.passed and [r.variable for r in tab.failures()] == ["mu"]
    text = tab.format()
    assert "difference other - ref, t in [0, 10] s, 101 samples" in text
    assert "mu" in text and "FAIL" in text and "overall: FAIL (mu)" in text
    assert set(tab.to_frame().columns) == {
        "unit",
        "max_abs",
        "t_max",
        "rms",
        "delta_pct",
        "scale",
        "ref_max",
        "atol",
        "rtol",
        "tolerance",
        "passed",
    }
    # Window: the first 5 s only.
    early = difference_table(a, b, window=(0.0, 5.0))
    assert early.passed and early.window == (0.0, 5.0) and early.samples == 51


def test_angles_wrap_and_tolerance_forms():
    t = np.linspace(0.0, 1.0, 11)
    a = _traj(t, chi=np.full_like(t, math.pi - 1e-6))
    b = _traj(t, chi=np.full_like(t, -math.pi + 1e-6))
    assert difference_table(a, b).row("chi").max_abs == pytest.approx(2e-6, abs=1e-12)
    tab = difference_table(a, b, 1e-7)  # one tolerance for every variable
    assert tab.row("chi").passed is False and tab.row("V").passed is True
    tab = difference_table(a, b, {"chi": 1e-5}, variables=("chi", "V"))
    assert tab.passed and tab.row("V").passed is None
    with pytest.raises(InputError, match="not a column of both"):
        difference_table(a, b, variables=("nz",))
    with pytest.raises(InputError, match="tolerances given for variables not compared: mu"):
        difference_table(a, b, {"mu": 1e-3}, variables=("chi",))


def test_grids_and_coverage():
    t = np.linspace(0.0, 4.0, 41)
    a = _traj(t, x=2.0 * t)
    b = _traj(t[:21], x=2.0 * t[:21])  # stopped early at t = 2
    tab = difference_table(a, b)
    assert not tab.passed and "ends at t = 2" in tab.notes[0] and "overall: FAIL (coverage)" in tab.format()
    fine = np.linspace(0.0, 4.0, 401)
    c = _traj(fine + 0.005, x=2.0 * (fine + 0.005))  # shifted grid: no common times
    with pytest.raises(InputError, match="no common output times.*interpolate=True"):
        difference_table(a, c)
    tab = difference_table(a, c, interpolate=True, window=(0.01, 4.0))
    assert tab.row("x").max_abs <= 1e-12


def test_assert_trajectories_close_message():
    t = np.linspace(0.0, 2.0, 21)
    a = _traj(t, z=-1000.0 + 0 * t)
    assert_trajectories_close(expected=a, actual=a.copy())
    b = _traj(t, z=-1000.0 + 0.05 * (t >= 1.5))
    with pytest.raises(AssertionError) as exc:
        assert_trajectories_close(expected=a, actual=b, atol={"position": 1e-2})
    msg = str(exc.value)
    assert "1 of 12 columns exceed" in msg and "(z)" in msg and "5.000e-02" in msg and "FAIL" in msg
    assert_trajectories_close(expected=a, actual=b, atol=0.1)


def test_differences_series_wraps_angles_and_measures_distance():
    t = np.linspace(0.0, 1.0, 11)
    a = _traj(t, chi=np.full_like(t, math.pi - 1e-6), x=t)
    b = _traj(t[2:], chi=np.full_like(t[2:], -math.pi + 1e-6), x=t[2:] + 3.0, y=4.0 + 0 * t[2:])
    d = differences(a, b, "chi")
    assert list(d.index) == list(t[2:]) and np.allclose(d.to_numpy(), 2e-6, atol=1e-12)
    assert np.allclose(differences(a, b, "position").to_numpy(), 5.0)
    with pytest.raises(InputError, match="not a column of both"):
        differences(a, b, "nz")


def test_engine_tables_windows_clipped_to_the_span():
    t = np.linspace(0.0, 12.0, 121)
    runs = {"ref": _traj(t, x=t), "other": _traj(t, x=t + 1e-3 * (t > 10.5)), "third": _traj(t, x=t)}
    assert window_span((0.0, 12.0), 10.0) == (0.0, 10.0) and window_span((0.0, 6.0), 10.0) == (0.0, 6.0)
    assert window_span((1.0, 6.0), None) == (1.0, None)
    tabs = engine_tables(runs, (0.0, 12.0))
    assert list(tabs) == ["other", "third"] and list(tabs["other"]) == ["first 10 s", "whole span"]
    assert tabs["other"]["first 10 s"].row("x").max_abs == 0.0
    assert tabs["other"]["whole span"].row("x").max_abs == pytest.approx(1e-3)
    assert tabs["other"]["first 10 s"].labels == ("ref", "other")
    short = engine_tables(runs, (0.0, 6.0), windows={"first 10 s": 10.0})
    assert short["third"]["first 10 s"].window == (0.0, 6.0)


def test_position_error_against_flat_outputs():
    t = np.linspace(0.0, 10.0, 101)
    flown = _traj(t, x=100.0 * t + 3.0 * (t >= 4.0), y=4.0 * (t >= 4.0), z=-1000.0 + 0 * t)

    def outputs(tt):
        tt = np.asarray(tt, dtype=float)
        return np.vstack([100.0 * tt, 0 * tt, -1000.0 + 0 * tt, 0 * tt])  # extra rows are ignored

    err = position_error(flown, outputs)
    assert err.iloc[0] == 0.0 and err.iloc[-1] == pytest.approx(5.0)
    assert max_position_error(flown, outputs) == pytest.approx(5.0)
    assert max_position_error(flown, outputs, window=(0.0, 3.9)) == 0.0
    assert max_position_error(flown, outputs, window=(5.0, None)) == pytest.approx(5.0)
    frame = pd.DataFrame({"x": 100.0 * t, "y": 0 * t, "z": -1000.0 + 0 * t}, index=pd.Index(t, name="t"))
    assert max_position_error(flown, frame) == pytest.approx(5.0)
    nan_run = flown.copy()
    nan_run.loc[nan_run.index[-1], "x"] = np.nan
    assert math.isnan(max_position_error(nan_run, outputs))
    with pytest.raises(InputError, match="shape"):
        max_position_error(flown, lambda tt: np.zeros((2, np.size(tt))))
    with pytest.raises(InputError, match="reference covers"):
        max_position_error(flown, frame.iloc[:50])


def test_nesc_metric_and_relative_tolerance():
    t = np.linspace(0.0, 10.0, 101)
    a = _traj(t, V=100.0 + t, mu=0.1 * t)
    b = _traj(t, V=100.0 + t + 0.0105 * (t == 5.0), mu=0.1 * t)
    tab = difference_table(a, b, tolerances={"V": 0.0}, rtol={"V": 1e-4})
    v = tab.row("V")
    assert v.ref_max == pytest.approx(110.0) and v.delta_pct == pytest.approx(100 * 0.0105 / 110.0, rel=1e-9)
    assert v.tolerance == pytest.approx(0.011) and v.rtol == 1e-4 and v.atol == 0.0
    assert v.passed is True and "delta [%]" in tab.format()
    assert difference_table(a, b, tolerances={"V": 0.0}, rtol={"V": 0.9e-4}).row("V").passed is False


def test_informative_table_has_one_overall_line_and_undefined_delta_is_a_dash():
    t = np.linspace(0.0, 10.0, 101)
    a = _traj(t, x=t, V=100.0 + 0 * t)
    b = _traj(t, x=t + 1e-3, V=100.0 + 0 * t)
    text = difference_table(a, b, labels=("plan", "run"), tolerances={}).format()
    assert text.count("overall:") == 1 and "overall: - (no tolerances given: informative)" in text
    assert "overall: PASS" not in text
    y_line = next(line for line in text.splitlines() if line.split()[:1] == ["y"])  # max|y_ref| = 0
    assert (
        "nan" not in y_line
        and "undefined (-) where the scale is at most the floor of its kind "
        "(0.01 m, 0.001 m/s, 0.0001 rad, 0.001 rad/s)"
        in text
        and "max - min for x, y, z, chi" in text
    )


def test_delta_is_undefined_where_the_reference_is_zero_to_rounding():
    # beta of a symmetric flight is 1e-26 rad, not 0: a rounding-size difference is no 1e+16 % error
    t = np.linspace(0.0, 10.0, 101)
    a = _traj(t, beta=1e-26 * np.sin(t), V=100.0 + 0 * t)
    b = _traj(t, beta=1e-14 * np.cos(t), V=100.0 + 0 * t)
    row = difference_table(a, b, tolerances={}).row("beta")
    assert row.ref_max == pytest.approx(1e-26, rel=1e-2) and row.max_abs == pytest.approx(1e-14, rel=1e-2)
    assert math.isnan(row.delta_pct)
    c = _traj(t, beta=1e-3 * np.sin(t), V=100.0 + 0 * t)  # a small but resolved sideslip keeps its metric
    d = _traj(t, beta=1e-3 * np.sin(t) + 1e-9 * np.cos(t), V=100.0 + 0 * t)
    assert difference_table(c, d, tolerances={}).row("beta").delta_pct == pytest.approx(1e-4, rel=1e-3)


def test_delta_is_undefined_where_the_reference_is_within_the_agreement_of_its_kind_of_zero():
    # z of a flight at sea level and y of a straight flight along x are above rounding but below the absolute
    # agreement of a position (1e-2 m): as scales of a percentage they made 1e+5 % and 1.5 % of differences of
    # 1e-5 m; V of the same flight keeps its metric, and so does z at altitude.
    t = np.linspace(0.0, 10.0, 101)
    a = _traj(t, x=100.0 * t, y=3.4e-4 * t / 10, z=1e-8 * np.sin(t), V=100.0 + t)
    b = _traj(t, x=100.0 * t, y=3.4e-4 * t / 10 + 5.1e-6, z=1e-8 * np.sin(t) + 1e-5, V=100.0 + t + 0.0105 * (t == 5))
    tab = difference_table(a, b, tolerances={})
    for name in ("y", "z"):
        row = tab.row(name)
        assert 0.0 < row.ref_max <= percent_floor(name) == PERCENT_FLOORS["m"] == DEFAULT_TOLERANCES["z"]
        assert math.isnan(row.delta_pct) and row.max_abs == pytest.approx({"y": 5.1e-6, "z": 1e-5}[name])
    assert tab.row("V").delta_pct == pytest.approx(100 * 0.0105 / 110.0, rel=1e-9)
    assert tab.row("x").delta_pct == 0.0
    # z is relative to its excursion (max - min): a level flight at altitude has none, a 1.01 cm descent has one
    high = difference_table(_traj(t, z=-1000.0 + 0 * t), _traj(t, z=-1000.0 + 1e-5 + 0 * t), tolerances={})
    assert math.isnan(high.row("z").delta_pct) and high.row("z").ref_max == 1000.0 and high.row("z").scale == 0.0
    edge = [
        difference_table(_traj(t, z=-1000.0 + dz * t / 10), _traj(t, z=-1000.0 + dz * t / 10 + 1e-5), tolerances={})
        .row("z")
        .delta_pct
        for dz in (1e-2, 1.01e-2)
    ]
    assert math.isnan(edge[0]) and edge[1] == pytest.approx(100 * 1e-5 / 1.01e-2)
    assert [percent_floor(n) for n in ("V", "alpha", "p", "X", "L", "qbar")] == [1e-3, 1e-4, 1e-3, 1e-3, 1e-4, 1e-9]


def _turn(t, *, shift=(0.0, 0.0, 0.0), heading=0.0, error=0.0):
    """A climbing 90-degree turn from ``shift``, rotated by ``heading`` about the vertical; ``error`` scales a
    perturbation of the position and heading (the candidate's difference rotates with the manoeuvre)."""
    R, V = 200.0, 50.0
    th = V * t / R
    bump = error * np.sin(t)
    xl, yl = R * np.sin(th) + 0.3 * bump, R * (1.0 - np.cos(th)) - 0.2 * bump
    c, s = math.cos(heading), math.sin(heading)
    return _traj(
        t,
        x=shift[0] + c * xl - s * yl,
        y=shift[1] + s * xl + c * yl,
        z=shift[2] - 2.0 * t + 0.1 * bump,
        chi=np.remainder(heading + th + 1e-3 * bump + math.pi, 2 * math.pi) - math.pi,
        V=V + 0 * t,
        mu=0.3 + 1e-3 * bump,
    )


def test_delta_of_datum_dependent_variables_is_the_same_wherever_and_whichever_way_the_manoeuvre_is_flown():
    # positions and heading have no physical zero: the same turn flown from 1000 m or 10 km, north, east or
    # across chi = +-pi gives the same percentage (relative to the reference's excursion over the window)
    t = np.linspace(0.0, 10.0, 201)
    names = ("position", "x", "y", "z", "chi", "mu")

    def deltas(**where):
        tab = difference_table(_turn(t, **where), _turn(t, error=1e-2, **where), tolerances={}, variables=names)
        return {n: tab.row(n).delta_pct for n in names}

    base = deltas()
    assert all(math.isfinite(v) and v > 0 for v in base.values())
    for where in ({"shift": (0.0, 0.0, -1000.0)}, {"shift": (5e3, -7e4, -1e4)}, {"heading": math.pi}):
        assert deltas(**where) == pytest.approx(base, rel=1e-6)
    east = deltas(heading=math.pi / 2, shift=(0.0, 0.0, -1e4))  # rotated by 90 deg: x and y swap roles
    assert east["x"] == pytest.approx(base["y"], rel=1e-6) and east["y"] == pytest.approx(base["x"], rel=1e-6)
    free = ("position", "z", "chi", "mu")  # any heading: x and y mix, these do not
    for where in ({"heading": math.pi / 2, "shift": (0.0, 0.0, -1e4)}, {"heading": 2.9, "shift": (1e5, 1e5, -1e4)}):
        assert {n: deltas(**where)[n] for n in free} == pytest.approx({n: base[n] for n in free}, rel=1e-6)
    tab = difference_table(_turn(t), _turn(t, error=1e-2), tolerances={}, variables=names)
    z, mu, pos = tab.row("z"), tab.row("mu"), tab.row("position")
    assert z.scale == pytest.approx(20.0) and z.delta_pct == pytest.approx(100 * z.max_abs / 20.0)
    assert mu.scale == mu.ref_max == pytest.approx(0.3)  # a physical zero keeps max|ref|
    assert pos.scale == pytest.approx(math.hypot(200.0 * math.sqrt(2 - 2 * math.cos(2.5)), 20.0), rel=1e-9)
