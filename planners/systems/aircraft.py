"""The aircraft as an almost chained system (paper eq. chained-sys, section "The shape of the equations").

The paper's four groups, r = 4, with Z_1 = {x, y, z}, Z_3 = {zeta} (beta, mu, F or
``f1 beta + f2 mu``) and one neglected group H = H_2(p, q, r, dl, dm, dn) (l_2 = 3: L = 2):

* stage 1: ``(x', y', z') = G_1(V, gamma, chi)`` -- :func:`gna.eom.kinematics`, solved in closed form
  by :func:`planners.flat.stage1`;
* stage 2: ``(V', gamma', chi') = G_2(..., alpha, beta, mu, F) + H_2(p, q, r, dl, dm, dn)`` and the
  fourth flat output -- :func:`planners.flat.force_residuals` (the force coefficients with the
  neglected terms at ``X^``), solved by Newton on series from the kinematic starting values of
  :mod:`planners.flat`;
* stage 3: ``(alpha', beta', mu') = G_3(..., p, q, r)`` -- :func:`gna.eom.wind_angle_rates` with the
  wind-axis forces the force equations give, solved in closed form by :func:`planners.flat.stage3`;
* stage 4: ``(p', q', r') = G_4(..., dl, dm, dn)`` -- :func:`gna.eom.loads` and
  :func:`gna.eom.rotational_dynamics` (full model), solved by Newton on series; with a fixed rudder
  ``dn(t)`` the fourth control is ``eta``.

The thrust asymmetry ``eta(t)`` (or the fixed rudder ``dn(t)``) and the weights ``f1, f2`` of a
mixed flat output are the system's prescribed inputs.  The equations are those of :mod:`gna.eom`
and :mod:`planners.flat` (nothing is retyped here), so
:func:`planners.chained.generalized_parametrization` on :func:`aircraft_system` reproduces
:func:`planners.generalized.plan_motion` (the tests compare every series at the nodes).
"""

from __future__ import annotations

import numpy as np

from gna.eom import (
    H_NAMES,
    Controls,
    HValues,
    State,
    force_equations,
    kinematics,
    loads,
    rotational_dynamics,
    wind_angle_rates,
)

from ..chained import ChainedSystem, Stage
from ..flat import FlatProblem, _check_inputs, _stage2_guess, _unwrap_constant, force_residuals, stage1, stage3

#: Unknowns of stages 1-3 (stage 4: ``dl, dm, dn``, or ``dl, dm, eta`` with a fixed rudder).
STAGE_UNKNOWNS = (("V", "gamma", "chi"), ("alpha", "beta", "mu", "F"), ("p", "q", "r"))


def aircraft_system(problem: FlatProblem) -> ChainedSystem:
    """The aircraft of a flat problem as a :class:`planners.chained.ChainedSystem`.

    Parameters
    ----------
    problem : FlatProblem
        Aircraft, environment, flat outputs ``x, y, z`` [m] and ``zeta``, the prescribed ``eta(t)``
        or fixed rudder ``dn(t)`` [rad], the neglected terms' values ``h`` of iterate 0 (rates
        [rad/s], surfaces [rad]) and the stage-2 starting values ``start``.

    Returns
    -------
    ChainedSystem
        Flat outputs ``x, y, z`` (stage 1) and ``zeta`` (stage 3); prescribed inputs ``eta`` or
        ``dn`` (and ``f1, f2`` for a mixed output); default flat-output functions and iterate-0
        neglected values from ``problem``; Newton tolerance 1e-12 as :func:`planners.flat.parametrize`.
    """
    ac, env = problem.aircraft, problem.env
    m, g = ac.mass.mass, env.g
    kind = problem.zeta.kind
    rudder_control = problem.eta is not None
    inputs = {"eta": problem.eta} if rudder_control else {"dn": problem.dn}
    if kind == "mix":
        inputs.update(f1=problem.zeta.f1, f2=problem.zeta.f2)
    controls4 = ("dl", "dm", "dn") if rudder_control else ("dl", "dm", "eta")

    def state(v, rates=True):
        pqr = (v["p"], v["q"], v["r"]) if rates else (0.0, 0.0, 0.0)
        return State(
            0.0,
            0.0,
            v["z"],
            v["V"],
            v["gamma"],
            v["chi"],
            v.get("alpha", 0.0),
            v.get("beta", 0.0),
            v.get("mu", 0.0),
            *pqr,
        )

    # ---- stage 1: kinematics
    def residual1(v):
        xd, yd, zd = kinematics(state(v, rates=False))
        return [v["x'"] - xd, v["y'"] - yd, v["z'"] - zd]

    def solve1(v, t_nodes):
        _check_inputs(
            t_nodes,
            {
                "x": v["x"],
                "y": v["y"],
                "z": v["z"],
                "zeta": v["zeta"],
                "f1": v.get("f1"),
                "f2": v.get("f2"),
                "eta": v.get("eta"),
                "dn": v.get("dn"),
            },
        )
        return list(stage1(v["x"], v["y"], v["z"]))

    # ---- stage 2: force equations and the fourth flat output, H_2 at the neglected values
    def residual2(v):
        h = HValues(*(v[n] for n in H_NAMES))
        eta = v["eta"] if rudder_control else 0.0
        r1, r2, r3 = force_residuals(
            ac,
            env,
            v["z"],
            v["V"],
            v["gamma"],
            v["chi"],
            v["V'"],
            v["gamma'"],
            v["chi'"],
            eta,
            h,
            v["alpha"],
            v["beta"],
            v["mu"],
            v["F"],
        )
        if kind == "beta":
            r4 = v["beta"] - v["zeta"]
        elif kind == "mu":
            r4 = v["mu"] - v["zeta"]
        elif kind == "F":
            r4 = (v["F"] - v["zeta"]) / (m * g)
        else:
            r4 = v["f1"] * v["beta"] + v["f2"] * v["mu"] - v["zeta"]
        return [r1, r2, r3, r4]

    def start2(v, t_nodes):
        d = {
            "z": v["z"],
            "V": v["V"],
            "gamma": v["gamma"],
            "Vd": v["V'"],
            "gd": v["gamma'"],
            "chid": v["chi'"],
            "zv": v["zeta"],
            "f1": v.get("f1"),
            "f2": v.get("f2"),
        }
        return [np.real(s.constant_term) for s in _stage2_guess(problem, t_nodes, d, [v[n] for n in H_NAMES])]

    def post2(u):
        alpha, beta, mu, F = u
        return [alpha, beta, _unwrap_constant(mu), F]  # neighbouring nodes on the same bank branch

    # ---- stage 3: wind-angle rates
    def residual3(v):
        s = state(v)
        # the wind-axis forces Y, Z for which the force equations give gamma', chi' (linear in Y, Z)
        _, gy, cy = force_equations(ac, s, 0.0, 1.0, 0.0)
        _, gz, cz = force_equations(ac, s, 0.0, 0.0, 1.0)
        det = gy * cz - gz * cy
        Y = (v["gamma'"] * cz - gz * v["chi'"]) / det
        Z = (gy * v["chi'"] - cy * v["gamma'"]) / det
        ad, bd, mud = wind_angle_rates(ac, s, Y, Z, v["chi'"])
        return [v["alpha'"] - ad, v["beta'"] - bd, v["mu'"] - mud]

    def solve3(v, t_nodes):
        return list(stage3(v["alpha"], v["beta"], v["mu"], v["gamma"], v["chi"]))

    # ---- stage 4: rotational dynamics, full model
    def residual4(v):
        s = state(v)
        ld = loads(ac, env, s, Controls(v["F"], v["eta"], v["dl"], v["dm"], v["dn"]))
        a_p, a_q, a_r = rotational_dynamics(ac, s.p, s.q, s.r, ld.L, ld.M, ld.N)
        return [a_p - v["p'"], a_q - v["q'"], a_r - v["r'"]]

    outputs = {"x": problem.x, "y": problem.y, "z": problem.z, "zeta": problem.zeta.value}
    return ChainedSystem(
        name="aircraft",
        flat_outputs={"x": 1, "y": 1, "z": 1, "zeta": 3},
        stages=(
            Stage(STAGE_UNKNOWNS[0], residual1, solve=solve1),
            Stage(STAGE_UNKNOWNS[1], residual2, neglected=H_NAMES, ell=3, start=start2, post=post2),
            Stage(STAGE_UNKNOWNS[2], residual3, solve=solve3),
            Stage(controls4, residual4),
        ),
        description=f"{ac.id}: wind-frame model, flat outputs x, y, z and {kind}"
        + ("" if rudder_control else ", rudder fixed (eta the fourth control)"),
        inputs=inputs,
        outputs=outputs,
        neglected_values=dict(zip(H_NAMES, problem.h)),
        newton_tol=1e-12,
    )
