"""Static check: JSBSim's loads and state derivatives equal the in-house model's to <= 1e-9 relative.

For every aircraft (the committed ``aircraft_xml`` file) and a two-engine variant
with tilted thrust, at 200 random states and controls (both density models),
JSBSim is put at the state with ``run_ic`` and its own outputs are compared
with :mod:`gna.eom`:

* body-axis aerodynamic force and moment about the CG, thrust force and moment
  (``forces/fb*-aero-lbs``, ``moments/*-aero-lbsft``, ``...-external-...``);
* body accelerations ``u', v', w'`` (from the in-house ``V', alpha', beta'``),
  ``p', q', r'``, and ``alpha', beta'``;
* coefficients, dynamic pressure and density.

A vector's error is its largest component error over its Euclidean norm.  The
in-house model is evaluated at the state JSBSim holds: the altitude read back
(the ECEF position of the huge flat-earth sphere is quantised to ~5e-6 m,
checked below) and JSBSim's local ``GM/r^2`` as ``g`` (which differs from the
planet's reference value by ``2 dh / R``, checked below).  ``pytest -s`` prints
the largest differences found.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from gna import units
from gna.aircraft import Propulsion, list_aircraft, load_aircraft
from gna.atmosphere import ISA, ConstantDensity, Environment
from gna.eom import Controls, State, derivatives, loads
from gna.frames import C_body_wind
from harness.engines import initial_condition_properties, load_fdm
from harness.engines.jsbsim import export as jx
from harness.engines.jsbsim import files as jf

N_SAMPLES = 200
REL_TOL = 1e-9
TWIN = "twin-variant"
CASES = list_aircraft() + [TWIN]


def _aircraft(name):
    if name != TWIN:
        return load_aircraft(name), jf.xml_path(jf.default_root(), name).read_text(encoding="utf-8")
    base = load_aircraft("f16c" if "f16c" in list_aircraft() else list_aircraft()[0])
    a = dataclasses.replace(base, id="twin", propulsion=Propulsion(count=2, y_p=1.8, epsilon=math.radians(3.0)))
    return a, jx.aircraft_xml(a)


def _rel(x, y) -> float:
    x, y = np.atleast_1d(np.asarray(x, dtype=float)), np.atleast_1d(np.asarray(y, dtype=float))
    scale = max(np.linalg.norm(x), np.linalg.norm(y))
    return 0.0 if scale == 0.0 else float(np.max(np.abs(x - y)) / scale)


@pytest.mark.parametrize("name", CASES)
def test_jsbsim_loads_and_derivatives_equal_inhouse(name):
    a, text = _aircraft(name)
    fdm, problems, capture = load_fdm(text, a.id)
    assert problems == []
    rng = np.random.default_rng(20261122)
    env_alpha = (max(a.envelope.alpha_min, -0.3), min(a.envelope.alpha_max, 0.6))
    worst: dict[str, float] = {}
    planet_g = jx.FlatPlanet()
    with capture:
        fdm["simulation/gravity-model"] = 0
        for i in range(N_SAMPLES):
            s = State(
                rng.uniform(-2e3, 2e3),
                rng.uniform(-2e3, 2e3),
                -rng.uniform(0.0, 15e3),
                rng.uniform(15.0, 250.0),
                rng.uniform(-0.5, 0.5),
                rng.uniform(-math.pi, math.pi),
                rng.uniform(*env_alpha),
                rng.uniform(-0.3, 0.3),
                rng.uniform(-1.2, 1.2),
                *rng.uniform(-1.0, 1.0, 3),
            )
            u = Controls(
                rng.uniform(0.0, 1.0) * a.mass.mass * units.G0, rng.uniform(-1.0, 1.0), *rng.uniform(-0.3, 0.3, 3)
            )
            constant = i % 2 == 1
            rho_c = rng.uniform(0.3, 1.3)
            fdm[jx.DENSITY_MODEL_PROPERTY] = 1.0 if constant else 0.0
            fdm[jx.DENSITY_CONSTANT_PROPERTY] = rho_c / units.SLUG_FT3
            for prop, value in initial_condition_properties(np.array(s, dtype=float)):
                fdm[prop] = value
            fdm[jx.THRUST_PROPERTIES[0]] = u.F * (1 + u.eta) / 2 / units.LBF
            fdm[jx.THRUST_PROPERTIES[1]] = u.F * (1 - u.eta) / 2 / units.LBF
            for key, prop in jx.CONTROL_PROPERTIES.items():
                fdm[prop] = getattr(u, key)
            assert fdm.run_ic()

            h = fdm["position/h-sl-ft"] * units.FT
            g = fdm["accelerations/gravity-ft_sec2"] * units.FT
            assert abs(h + s.z) <= 1e-5  # ECEF quantisation only
            assert abs(g - planet_g.g) <= planet_g.g * (2.0 * abs(h) / (planet_g.radius_ft * units.FT) + 1e-12)
            env = Environment(ConstantDensity(rho_c) if constant else ISA(), g)
            sj = s._replace(z=-h)
            ld = loads(a, env, sj, u)
            d = derivatives(a, env, sj, u, ld=ld)

            eps, yp = a.propulsion.epsilon, a.propulsion.y_p
            F_thrust = u.F * np.array([math.cos(eps), 0.0, -math.sin(eps)])
            dF = u.F * u.eta if a.propulsion.count == 2 else 0.0
            M_thrust = np.array([yp * math.sin(eps) * dF, 0.0, yp * math.cos(eps) * dF])
            F_aero = C_body_wind(sj.alpha, sj.beta) @ np.array([ld.Xa, ld.Ya, ld.Za]) - F_thrust
            M_aero = np.array([ld.L, ld.M, ld.N]) - M_thrust
            ca, sa, cb, sb = math.cos(s.alpha), math.sin(s.alpha), math.cos(s.beta), math.sin(s.beta)
            uvw_dot = np.array(
                [
                    d.V * ca * cb - s.V * sa * cb * d.alpha - s.V * ca * sb * d.beta,
                    d.V * sb + s.V * cb * d.beta,
                    d.V * sa * cb + s.V * ca * cb * d.alpha - s.V * sa * sb * d.beta,
                ]
            )

            def j3(fmt, factor):
                return np.array([fdm[fmt.format(c)] for c in "xyz"]) * factor

            def m3(fmt, factor):
                return np.array([fdm[fmt.format(c)] for c in "lmn"]) * factor

            lbft = units.LBF * units.FT
            checks = {
                "aero force": (F_aero, j3("forces/fb{}-aero-lbs", units.LBF)),
                "aero moment": (M_aero, m3("moments/{}-aero-lbsft", lbft)),
                "thrust force": (F_thrust, j3("forces/fb{}-external-lbs", units.LBF)),
                "thrust moment": (M_thrust, m3("moments/{}-external-lbsft", lbft)),
                "u', v', w'": (uvw_dot, np.array([fdm[f"accelerations/{c}dot-ft_sec2"] for c in "uvw"]) * units.FT),
                "p', q', r'": (
                    np.array([d.p, d.q, d.r]),
                    np.array([fdm[f"accelerations/{c}dot-rad_sec2"] for c in "pqr"]),
                ),
                "alpha'": (d.alpha, fdm["aero/alphadot-rad_sec"]),
                "beta'": (d.beta, fdm["aero/betadot-rad_sec"]),
                "coefficients": (
                    np.array(ld.moment_coeffs),
                    np.array([fdm[jx.COEFFICIENT_PROPERTIES[c]] for c in ("CD", "CY", "CL", "Cl", "Cm", "Cn")]),
                ),
                "qbar": (ld.qbar, fdm[jx.QBAR_PROPERTY] * units.LBF / units.FT2),
                "rho": (ld.rho, fdm[jx.RHO_PROPERTY] * units.SLUG_FT3),
            }
            for key, (x, y) in checks.items():
                worst[key] = max(worst.get(key, 0.0), _rel(x, y))
    assert capture.problems() == []
    print(
        f"{name}: largest relative differences over {N_SAMPLES} states: "
        + ", ".join(f"{k} {v:.1e}" for k, v in worst.items())
    )
    bad = {k: v for k, v in worst.items() if not v <= REL_TOL}
    assert not bad, (
        f"{name}: relative differences above {REL_TOL:g}: "
        + ", ".join(f"{k} {v:.2e}" for k, v in bad.items())
        + f" (all: {worst})"
    )
