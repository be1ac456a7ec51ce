"""JSBSim's step is its own setting: the output grid samples the same trajectory."""

from __future__ import annotations

import numpy as np
import pytest

from gna.aircraft import load_aircraft
from gna.trim import trim_level
from harness.engines import JSBSimEngine
from harness.engines.jsbsim.grid import output_grid


@pytest.fixture(scope="module")
def manoeuvre():
    a = load_aircraft("f16c")
    tr = trim_level(a, 150.0, 3000.0)
    x0, u0 = np.array(tr.state, dtype=float), np.array(tr.controls, dtype=float)

    def u(t):
        t = np.asarray(t, dtype=float)
        return [
            u0[0] * (1 + 0.1 * np.sin(0.5 * t)),
            u0[1] + 0 * t,
            u0[2] + 0.02 * np.sin(1.3 * t),
            u0[3] + 0.02 * np.sin(0.9 * t) * (1 - np.cos(0.7 * t)),
            u0[4] + 0 * t,
        ]

    return a, x0, u


def test_step_grid_ignores_the_output_interval():
    for dt_out in (0.02, 0.05, 0.1, 0.3, 1.0):
        n, dt, out, rec = output_grid(0.0, 6.0, 1 / 480, dt_out, None)
        assert n == 2880 and dt == pytest.approx(1 / 480)
        assert out[0] == 0.0 and out[-1] == 6.0 and rec[0] == 0 and rec[-1] <= n


def test_changing_only_dt_out_leaves_jsbsim_unchanged_at_common_times(manoeuvre):
    a, x0, u = manoeuvre
    eng = JSBSimEngine()
    coarse = eng.simulate(a, u, (0.0, 6.0), x0, dt_out=0.05).df  # on the step grid
    fine = eng.simulate(a, u, (0.0, 6.0), x0, dt_out=0.02).df  # mostly between steps: interpolated
    common = coarse.index.intersection(fine.index)
    assert len(common) == 61  # every 0.1 s
    cols = ["x", "y", "z", "V", "gamma", "chi", "alpha", "beta", "mu", "p", "q", "r"]
    d = (fine.loc[common, cols] - coarse.loc[common, cols]).abs().max()
    assert d[["x", "y", "z"]].max() < 1e-9 and d.drop(["x", "y", "z"]).max() < 1e-10, d
    # an output time between two steps is interpolated to the accuracy of a run on a grid through it
    assert eng.simulate(a, u, (0.0, 6.0), x0, dt_out=0.02).settings.dt == pytest.approx(1 / 480)
