"""The model's equation groups (gna.eom) evaluated on truncated power series.

``gna.eom`` is the one definition of the equations for floats, arrays and series; the planner's
stage-2 and stage-4 residuals call its groups, and stage 3 inverts its G3 group in closed form.
"""

from __future__ import annotations

import numpy as np
import pytest

from gna.aircraft import load_aircraft
from gna.atmosphere import Environment
from gna.eom import (
    STATE_NAMES,
    Controls,
    HValues,
    State,
    aero_coefficients,
    derivatives,
    force_equations,
    wind_angle_rates,
    wind_forces,
)
from planners.series import Series

N_NODES, ORDER = 7, 5


def _random_trajectory(ac, seed):
    """States and controls as series of order ORDER at N_NODES nodes around a plausible flight condition."""
    rng = np.random.default_rng(seed)
    centre = dict(
        x=0.0,
        y=0.0,
        z=-1500.0,
        V=120.0,
        gamma=0.02,
        chi=0.3,
        alpha=0.06,
        beta=0.01,
        mu=0.2,
        p=0.05,
        q=0.02,
        r=-0.03,
        F=0.3 * ac.mass.mass * 9.8,
        eta=0.0,
        dl=0.01,
        dm=-0.02,
        dn=0.005,
    )
    spread = dict(x=100.0, y=100.0, z=200.0, V=20.0, F=0.1 * centre["F"])
    out = {}
    for name, c in centre.items():
        a = spread.get(name, 0.05)
        co = np.empty((N_NODES, ORDER + 1))
        co[:, 0] = c + a * rng.uniform(-1, 1, N_NODES)
        co[:, 1:] = a * rng.uniform(-1, 1, (N_NODES, ORDER)) / np.arange(1, ORDER + 1) ** 2
        out[name] = co
    return out


@pytest.mark.parametrize(
    "name,model", [("f16c", "full"), ("gtm", "full"), ("f16c", "simple"), ("twin-otter", "simple")]
)
def test_derivatives_on_series_match_floats_node_by_node(name, model):
    """Constant terms equal the float evaluation at each node; the first coefficient is the chain rule
    ``(df/dx) x'(0)``, checked by a complex step along the series' slope."""
    ac, env = load_aircraft(name), Environment()
    co = _random_trajectory(ac, seed=len(name))
    h_co = {k: co[k][:, 0] * 0.5 for k in ("p", "q", "r", "dl", "dm", "dn")}
    s = State(*(Series(co[k]) for k in STATE_NAMES))
    u = Controls(*(Series(co[k]) for k in Controls._fields))
    h = HValues(*h_co.values()) if model == "simple" else None
    d = derivatives(ac, env, s, u, model, h)
    step = 1e-30
    for i in range(N_NODES):
        s0 = State(*(float(co[k][i, 0]) for k in STATE_NAMES))
        u0 = Controls(*(float(co[k][i, 0]) for k in Controls._fields))
        h0 = HValues(*(float(v[i]) for v in h_co.values())) if model == "simple" else None
        d0 = derivatives(ac, env, s0, u0, model, h0)
        sc = State(*(co[k][i, 0] + 1j * step * co[k][i, 1] for k in STATE_NAMES))
        uc = Controls(*(co[k][i, 0] + 1j * step * co[k][i, 1] for k in Controls._fields))
        dc = derivatives(ac, env, sc, uc, model, h0)
        for n, ds, df, dcs in zip(STATE_NAMES, d, d0, dc):
            c = np.real(ds.coeffs[i])
            assert c[0] == pytest.approx(df, rel=1e-12, abs=1e-12), (n, i)
            assert c[1] == pytest.approx(np.imag(dcs) / step, rel=1e-10, abs=1e-10), (n, i)


def _g3_check(plan, j, model_forces: bool):
    """alpha', beta', mu' of the plan's series against the forward G3 group (all coefficients)."""
    ac, env = plan.aircraft, plan.env
    sol = plan.iterates[j]
    k = sol["p"].order  # the rates come out one order below alpha, beta, mu
    v = {n: sol[n].truncate(min(k, sol[n].order)) for n in STATE_NAMES}
    s = State(*(v[n] for n in STATE_NAMES))
    gd, chid = sol["gamma"].derivative().truncate(k), sol["chi"].derivative().truncate(k)
    m = ac.mass.mass
    if model_forces:
        # forces of the stage-2 model (H at the previous iterate, or the problem's for j = 0)
        h = plan.problem.h if j == 0 else plan.iterates[j - 1].h_values()
        h = HValues(*(x.truncate(k) if isinstance(x, Series) else x for x in h))
        u = Controls(sol["F"].truncate(k), sol["eta"].truncate(min(k, sol["eta"].order)), 0.0, 0.0, 0.0)
        qbar = 0.5 * env.density(s.z) * s.V * s.V
        X, Y, Z, *_ = wind_forces(ac, env, s, u, aero_coefficients(ac, s, u, h), qbar)
        _, _, chid = force_equations(ac, s, X, Y, Z)
    else:
        # forces implied by the kinematics: (Y, Z) = m V (w_wz, -w_wy)
        cm, sm, cg = np.cos(s.mu), np.sin(s.mu), np.cos(s.gamma)
        Y = m * s.V * (-gd * sm + chid * cg * cm)
        Z = -m * s.V * (gd * cm + chid * cg * sm)
    fwd = wind_angle_rates(ac, s, Y, Z, chid)
    for name, f in zip(("alpha", "beta", "mu"), fwd):
        stage3 = np.real(sol[name].derivative().coeffs)
        g3 = np.real(np.broadcast_to(f.coeffs, stage3.shape))
        scale = np.maximum(np.max(np.abs(stage3), axis=0), 1e-3)  # per coefficient order, over the nodes
        yield name, np.max(np.abs(g3 - stage3) / scale)


@pytest.fixture(scope="module")
def bank_plan():
    """A plan with the bank angle as fourth flat output: the sideslip is free (non-zero)."""
    from planners.generalized import plan_scenario

    from .conftest import make_scenario

    sc = make_scenario(
        name="f16-weave-mu", generalized={"J": 1}, flat_outputs={"zeta": "mu", "zeta_value": "0.02 + 0.1*sin(t/5)"}
    )
    plan = plan_scenario(sc)
    assert plan.feasible
    return plan


@pytest.mark.parametrize("which,j", [("beta", 0), ("beta", 4), ("mu", 0), ("mu", 1)])
def test_stage3_closed_form_is_the_inverse_of_forward_g3(weave_plan, bank_plan, which, j):
    """With the wind-frame rates of the kinematics, forward G3 on the plan's p, q, r gives back
    alpha', beta', mu' to rounding, node by node and order by order."""
    plan = weave_plan[1] if which == "beta" else bank_plan
    for name, err in _g3_check(plan, j, model_forces=False):
        assert err < 1e-12, (name, err)


@pytest.mark.parametrize("which,j", [("beta", 0), ("beta", 4), ("mu", 0), ("mu", 1)])
def test_forward_g3_with_model_forces_reproduces_the_plan(weave_plan, bank_plan, which, j):
    """With the forces of the stage-2 model, forward G3 reproduces stage 3 to the Newton tolerance."""
    plan = weave_plan[1] if which == "beta" else bank_plan
    for name, err in _g3_check(plan, j, model_forces=True):
        assert err < 1e-10, (name, err)
