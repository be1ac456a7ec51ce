"""``assert_trajectories_close``: tolerances per group and column, relative tolerances, common times, messages;
``SimulationResult.to_timeresponse``."""

import math

import numpy as np
import pandas as pd
import pytest

from gna.eom import CONTROL_NAMES, STATE_NAMES
from gna.errors import InputError
from gna.trajectory import SimulationResult
from harness.testing import assert_trajectories_close, trajectory_differences


def _traj(t, **cols):
    df = pd.DataFrame({n: np.zeros_like(t) for n in STATE_NAMES + CONTROL_NAMES}, index=pd.Index(t, name="t"))
    df["V"] = 50.0
    for k, v in cols.items():
        df[k] = v
    return df


def test_groups_column_overrides_and_relative_tolerances():
    t = np.linspace(0.0, 4.0, 41)
    e = _traj(t, x=50.0 * t, mu=0.1 * t)
    a = _traj(t, x=50.0 * t + 0.02 * t, mu=0.1 * t + 2e-4)
    with pytest.raises(AssertionError, match=r"2 of 12 columns exceed .*\(x, mu\)"):
        assert_trajectories_close(expected=e, actual=a)  # defaults 1e-2 m, 1e-4 rad
    assert_trajectories_close(expected=e, actual=a, atol={"position": 0.1, "mu": 3e-4})
    with pytest.raises(AssertionError, match=r"\(mu\)"):
        assert_trajectories_close(expected=e, actual=a, atol={"position": 0.1, "angle": 1e-3, "mu": 1e-4})
    # x differs by 0.02 t = 4e-4 x: relative 5e-4 passes, 3e-4 fails; atol 0 for the group.
    assert_trajectories_close(expected=e, actual=a, atol={"position": 0.0, "mu": 1e-3}, rtol={"x": 5e-4})
    with pytest.raises(AssertionError, match=r"\(x\)"):
        assert_trajectories_close(expected=e, actual=a, atol={"position": 0.0, "mu": 1e-3}, rtol={"x": 3e-4})
    table = assert_trajectories_close(expected=e, actual=a, atol=1.0)
    assert table.loc["x", "max_abs"] == pytest.approx(0.08) and table.loc["x", "t_worst"] == 4.0


def test_common_times_interpolation_and_coverage():
    t = np.linspace(0.0, 2.0, 21)
    fine = np.linspace(0.0, 2.0, 2001)
    e = _traj(t, x=3.0 * t, chi=np.full_like(t, math.pi - 1e-3))
    a = _traj(fine, x=3.0 * fine, chi=np.full_like(fine, -math.pi + 1e-3))  # chi across the wrap: 2e-3 rad
    assert_trajectories_close(expected=e, actual=a, atol={"angle": 3e-3})
    assert_trajectories_close(expected=e, actual=a, atol={"angle": 3e-3}, times=[0.005, 1.2345, 1.999])
    short = a.loc[:1.5]
    with pytest.raises(AssertionError, match="actual ends at t = 1.5 s, before the last compared time t = 2 s"):
        assert_trajectories_close(expected=e, actual=short, atol={"angle": 3e-3})
    assert_trajectories_close(expected=e, actual=short, atol={"angle": 3e-3}, times=np.linspace(0, 1.5, 7))


def test_message_has_the_table_and_names_which_is_which():
    t = np.linspace(0.0, 1.0, 11)
    e = _traj(t)
    a = _traj(t, z=0.05 * (t >= 0.5), F=np.full_like(t, 3.0))
    with pytest.raises(AssertionError) as exc:
        assert_trajectories_close(expected=e, actual=a, columns=["z", "F"], atol={"F": 1.0}, labels=("plan", "jsbsim"))
    msg = str(exc.value)
    assert msg.startswith("trajectories differ: jsbsim (actual) vs plan (expected): 2 of 2 columns exceed")
    assert "column   unit    max|diff|" in msg
    z_line = next(line for line in msg.splitlines() if line.startswith("z "))
    assert "5.000e-02" in z_line and "0.5" in z_line and z_line.endswith("FAIL")


def test_nan_fails_and_bad_input_is_named():
    t = np.linspace(0.0, 1.0, 11)
    e = _traj(t)
    with pytest.raises(AssertionError, match=r"\(V\)"):
        assert_trajectories_close(expected=e, actual=_traj(t, V=np.where(t > 0.5, np.nan, 50.0)))
    with pytest.raises(InputError, match="no tolerance for F"):
        assert_trajectories_close(expected=e, actual=e, columns=["F"])
    with pytest.raises(InputError, match="neither a group"):
        assert_trajectories_close(expected=e, actual=e, atol={"positon": 1.0})
    with pytest.raises(InputError, match="non-negative"):
        assert_trajectories_close(expected=e, actual=e, rtol={"angle": -1.0})
    with pytest.raises(InputError, match="not a column of both"):
        assert_trajectories_close(expected=e, actual=e.drop(columns="q"))
    with pytest.raises(InputError, match="SimulationResult"):
        assert_trajectories_close(expected=[1, 2], actual=e)
    table, problems = trajectory_differences(e, e)
    assert table["passed"].all() and not problems


def test_to_timeresponse():
    control = pytest.importorskip("control")
    from gna.trajectory import COLUMNS, DERIVED_NAMES, RunSettings

    t = np.linspace(0.0, 1.0, 11)
    df = pd.DataFrame({c: np.full_like(t, float(i)) for i, c in enumerate(COLUMNS)}, index=pd.Index(t, name="t"))
    r = SimulationResult(df=df, status="completed", settings=RunSettings(engine="jsbsim"))
    resp = r.to_timeresponse()
    assert isinstance(resp, control.TimeResponseData)
    assert resp.outputs.shape == (12 + len(DERIVED_NAMES), 11) and resp.states.shape == (12, 11)
    assert resp.inputs.shape == (5, 11)
    assert list(resp.output_labels[:12]) == list(STATE_NAMES) and list(resp.input_labels) == list(CONTROL_NAMES)
    assert list(resp.state_labels) == list(STATE_NAMES) and resp.output_labels[12] == "qbar"
    np.testing.assert_array_equal(resp.time, t)
    np.testing.assert_array_equal(resp.inputs[2], df["dl"].to_numpy())
    assert resp.sysname == "jsbsim" and resp.success
    pd_frame = resp.to_pandas()
    assert "mu" in pd_frame.columns


def test_to_timeresponse_without_control(monkeypatch):
    import builtins

    real = builtins.__import__

    def fake(name, *args, **kwargs):
        if name == "control":
            raise ImportError("No module named 'control'")
        return real(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", fake)
    r = SimulationResult(df=pd.DataFrame(), status="completed")
    with pytest.raises(ImportError, match=r"gflat\[control\]"):
        r.to_timeresponse()
