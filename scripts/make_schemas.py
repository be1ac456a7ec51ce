"""Write the JSON Schemas of aircraft, scenario and campaign files, and ``docs/scenarios.md`` from them.

The schemas are built from the tables the loaders use (unit suffixes of
:mod:`gna.aircraft`, coefficient names of :mod:`gna.aero`, flat-output kinds,
plan variables, trim variables, tracking and perturbation keys), so a key the
code learns is a key the schema and the page list.  ``tests/test_hardening_inputs.py``
checks the files are current; the documentation site renders its file references from the schema
files at every build (``scripts/mkdocs_hooks.py``, with :mod:`schema_doc`).

Usage: ``python scripts/make_schemas.py``  (from the repository root)
"""

from __future__ import annotations

import json
import sys
from itertools import combinations
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "scripts"))  # schema_doc, also when loaded by path (tests)

from schema_doc import cli_page, scenarios_page  # noqa: E402

from gna.aero import COEFFICIENTS, MAX_EXPONENT, MAX_TERMS  # noqa: E402
from gna.aircraft import UNIT_FACTORS  # noqa: E402
from gna.limits import LIMIT_NAMES  # noqa: E402
from gna.perturbation import PERTURBATION_KEYS  # noqa: E402
from gna.trim import TRIM_VARIABLES  # noqa: E402
from harness.campaign.spec import _CASE_KEYS as CAMPAIGN_CASE_KEYS  # noqa: E402
from harness.campaign.spec import _DISP_KEYS as DISPERSION_KEYS  # noqa: E402
from harness.campaign.spec import _OUTPUT_KEYS as CAMPAIGN_OUTPUT_KEYS  # noqa: E402
from harness.campaign.spec import _TOP_KEYS as CAMPAIGN_KEYS  # noqa: E402
from harness.campaign.spec import AERO_MODES, CASE_BUDGET_S, MAX_CASE_SPECS, MAX_DISPERSIONS  # noqa: E402
from harness.engines.registry import engine_names  # noqa: E402
from harness.validation.tolerances import DEFAULT_SETTLE_TIME, DEFAULT_TRACKING_TOLERANCE  # noqa: E402
from planners.bounded import (  # noqa: E402
    BOUNDED_KEYS,
    COSTS,
    DEFAULT_MARGIN,
    DEFAULT_MAXITER,
    DEFAULT_SINGULAR_MARGIN,
    DEFAULT_TOL,
)
from planners.bounded import METHODS as BOUNDED_METHODS  # noqa: E402
from planners.expressions import CONSTANTS, FUNCTIONS  # noqa: E402
from planners.flat import FLAT_KINDS, MAX_J  # noqa: E402
from planners.generalized import AUTO_J, AUTO_J_MAX, AUTO_J_TOL, MAX_E, METHODS  # noqa: E402
from planners.lqr import DESIGNS  # noqa: E402
from planners.plan import DEFAULT_INTERPOLATION, INTERPOLATIONS, PLAN_VARIABLES  # noqa: E402
from planners.scenario import (  # noqa: E402
    BOUNDARY_KEYS,
    COMPARE_KEYS,
    DEFAULT_BOUNDARY_ORDER,
    KNOWN_VERDICTS,
    MAX_NODES,
    MAX_REPORT_TIMES,
    PARAMETER_KEYS,
    SPLINE_KEYS,
    TRACKING_KEYS,
)
from planners.splines import BASES  # noqa: E402

AIRCRAFT_SCHEMA = ROOT / "gna" / "data" / "schemas" / "aircraft.schema.json"
SCENARIO_SCHEMA = ROOT / "planners" / "schemas" / "scenario.schema.json"
CAMPAIGN_SCHEMA = ROOT / "harness" / "campaign" / "schemas" / "campaign.schema.json"
DOC = ROOT / "docs" / "scenarios.md"
CLI_DOC = ROOT / "docs" / "cli.md"
#: The JSON Schemas of the commands' --json outputs (hand-written; docs/cli.md's key tables are made from them).
OUTPUT_SCHEMAS = ROOT / "harness" / "commands" / "schemas"
#: Their order on the page: the commands' order in gflat --help, then the error object.
OUTPUT_ORDER = (
    "aircraft",
    "trim",
    "plan",
    "compare",
    "paper",
    "report",
    "export-jsbsim",
    "export-jsbsim-script",
    "fit",
    "fit-compare",
    "fit-regenerate",
    "campaign-run",
    "campaign-status",
    "campaign-report",
    "error",
)

SAFE_NAME = "^[A-Za-z0-9][A-Za-z0-9._-]{0,63}$"
UNIT_WORDS = {
    "kg": "kg",
    "slug": "slug",
    "lb": "lb (weight, mass = W/g0)",
    "N": "N",
    "kgm2": "kg m^2",
    "slugft2": "slug ft^2",
    "m": "m",
    "ft": "ft",
    "in": "in",
    "m2": "m^2",
    "ft2": "ft^2",
    "rad": "rad",
    "deg": "deg",
    "lbf": "lbf",
    "ms": "m/s",
    "kt": "kt",
    "fps": "ft/s",
    "W": "W",
    "kW": "kW",
    "shp": "shp (shaft horsepower)",
    "s": "s",
}


def _text(description: str, **extra) -> dict:
    return {"type": "string", "description": description, **extra}


def _quantity(
    props: dict,
    conflicts: list,
    name: str,
    kind: str,
    description: str,
    default: str | None = None,
    extra: tuple[tuple[str, str, str], ...] = (),
) -> None:
    """Keys ``name_<unit>`` of one quantity; any two of them exclude each other."""
    keys = []
    for unit in UNIT_FACTORS[kind]:
        key = f"{name}_{unit}"
        props[key] = {"type": "number", "description": description, "x-unit": UNIT_WORDS[unit]}
        if default is not None:
            props[key]["x-default"] = default
        keys.append(key)
    for key, unit, desc in extra:
        props[key] = {"type": "number", "description": desc, "x-unit": unit}
        if default is not None:
            props[key]["x-default"] = default
        keys.append(key)
    conflicts.extend(combinations(keys, 2))


def _table(description: str, props: dict, conflicts: list = (), required: tuple = ()) -> dict:
    out = {"type": "object", "description": description, "properties": props, "additionalProperties": False}
    if required:
        out["required"] = list(required)
    if conflicts:
        out["allOf"] = [{"not": {"required": list(pair)}} for pair in conflicts]
    return out


def aircraft_schema() -> dict:
    """The JSON Schema of aircraft files (``gna/data/aircraft/*.toml``)."""
    mass, cm = {}, []
    _quantity(
        mass,
        cm,
        "mass",
        "mass",
        "Mass (required: one of mass_* or weight_*)",
        extra=tuple((f"weight_{u}", UNIT_WORDS[u], "Weight (mass = W / g0)") for u in UNIT_FACTORS["weight"]),
    )
    for axis, req in (("Ixx", True), ("Iyy", True), ("Izz", True), ("Ixz", False)):
        _quantity(
            mass,
            cm,
            axis,
            "inertia",
            f"{axis}, body axes" + (" (required)" if req else ", flight-dynamics sign: integral of x z dm"),
            None if req else "0",
        )
    mass["source"] = _text("Where the numbers come from")
    geo, cg = {}, []
    _quantity(geo, cg, "S", "area", "Reference wing area (required)")
    _quantity(geo, cg, "b", "length", "Reference span (required)")
    _quantity(geo, cg, "cbar", "length", "Mean aerodynamic chord (required)")
    _quantity(
        geo,
        cg,
        "x_cg",
        "length",
        "Centre of gravity aft of the leading edge of the m.a.c.",
        "0",
        extra=(("x_cg_cbar", "cbar", "Centre of gravity aft of the m.a.c. leading edge, in chords"),),
    )
    _quantity(
        geo,
        cg,
        "x_ref",
        "length",
        "Moment reference point aft of the m.a.c. leading edge",
        "x_cg",
        extra=(("x_ref_cbar", "cbar", "Moment reference point aft of the m.a.c. leading edge, in chords"),),
    )
    # chord fractions and lengths are not mixed between x_cg and x_ref (one of them would be ignored)
    for a, b in (("x_cg", "x_ref"), ("x_ref", "x_cg")):
        cg.extend((f"{a}_cbar", f"{b}_{u}") for u in UNIT_FACTORS["length"])
    geo["source"] = _text("Where the numbers come from")
    eng, ce = (
        {
            "count": {
                "type": "integer",
                "enum": [1, 2],
                "x-default": "1",
                "description": "Number of engines: 1 on the symmetry plane, 2 at y = -y_p and +y_p",
            }
        },
        [],
    )
    _quantity(eng, ce, "y_p", "length", "Lateral offset of each engine of a twin (0 for one engine)", "0")
    _quantity(eng, ce, "epsilon", "angle", "Thrust line tilt, nose-up from the body x axis", "0")
    _quantity(eng, ce, "max_thrust", "force", "Total thrust limit (optional)")
    eng["source"] = _text("Where the numbers come from")
    _quantity(eng, ce, "engine_power", "power", "Shaft power rating of ONE engine (optional; propeller engines)")
    eng["propeller_efficiency"] = {
        "type": "number",
        "exclusiveMinimum": 0,
        "maximum": 1,
        "description": "Propeller efficiency for the in-flight thrust limit "
        "eff * P / V (optional; 1 when a power is given without it)",
    }
    _quantity(eng, ce, "engine_static_thrust", "force", "Static thrust rating of ONE engine (optional)")
    eng["engine_source"] = _text("Where the per-engine rating comes from")
    _quantity(eng, ce, "thrust_line_offset", "length", "Thrust line's distance below the CG (nose-up moment)", "0")
    _quantity(eng, ce, "torque_arm", "length", "Propeller torque: rolling moment over thrust (+ right wing down)", "0")
    _quantity(eng, ce, "thrust_lag", "time", "First-order time constant of the thrust response", "0")
    for key, unit, desc in (
        ("engine_thrust_curve_speed_ms", "m/s", "Airspeeds of the thrust rating (increasing)"),
        ("engine_thrust_curve_N", "N", "Full-throttle thrust of ONE engine at those speeds"),
    ):
        eng[key] = {
            "type": "array",
            "items": {"type": "number"},
            "minItems": 2,
            "maxItems": 100,
            "description": desc,
            "x-unit": unit,
        }
    env, cv = {}, []
    _quantity(env, cv, "alpha_min", "angle", "Lowest angle of attack of the model's validity domain", "-10 deg")
    _quantity(env, cv, "alpha_max", "angle", "Highest angle of attack (above alpha_min)", "30 deg")
    _quantity(env, cv, "beta_max", "angle", "Largest |sideslip| of the validity domain, in (0, 90] deg", "20 deg")
    for s, word in (("dl", "aileron"), ("dm", "elevator"), ("dn", "rudder")):
        _quantity(env, cv, f"{s}_max", "angle", f"Largest |{word} deflection| (optional)")
    env["mach_min"] = {
        "type": "number",
        "minimum": 0,
        "x-unit": "-",
        "description": "Lowest Mach number of the data the aerodynamics were fitted or published on (optional; "
        "absent: not checked)",
    }
    env["mach_max"] = {
        "type": "number",
        "exclusiveMinimum": 0,
        "x-unit": "-",
        "description": "Highest Mach number of that data (optional; absent: not checked)",
    }
    env["nz_min"] = {
        "type": "number",
        "x-unit": "-",
        "description": "Lowest structural load factor nz (negative; optional; absent: not checked)",
    }
    env["nz_max"] = {
        "type": "number",
        "x-unit": "-",
        "description": "Highest structural load factor nz (optional; absent: not checked)",
    }
    env["source"] = _text("Where the numbers come from")
    term = {
        "type": "object",
        "additionalProperties": False,
        "description": "One term value * monomial of a coefficient (paper eq. (GNA))",
        "properties": {
            "theta": {
                "type": "integer",
                "minimum": 0,
                "description": "Term index (theta_i of the paper)",
                "x-default": "position in the list",
            },
            "index": {"type": "integer", "minimum": 0, "description": "Same as theta"},
            "coef": {"enum": list(COEFFICIENTS), "description": "Coefficient the term belongs to"},
            "coefficient": {"enum": list(COEFFICIENTS), "description": "Same as coef"},
            "monomial": {
                "type": "string",
                "description": "Product of alpha, beta, phat, qhat, rhat, dl, dm, dn "
                f'with exponents ^1..^{MAX_EXPONENT}, or "1" (required)',
            },
            "value": {"type": "number", "description": "Parameter value (required)"},
            "std_error": {"type": "number", "minimum": 0, "description": "Standard error of a fitted value"},
            "source": _text("Where the value comes from"),
        },
        "required": ["monomial", "value"],
        "anyOf": [{"required": ["coef"]}, {"required": ["coefficient"]}],
        "allOf": [{"not": {"required": ["theta", "index"]}}, {"not": {"required": ["coef", "coefficient"]}}],
    }
    aero = _table(
        "The aerodynamic model as a table of polynomial terms",
        {
            "structure": _text("Name of the structure (gna45 for the paper's 45 terms)", **{"x-default": "custom"}),
            "conventions": _text("The axes and sign conventions of the terms"),
            "terms": {
                "type": "array",
                "minItems": 1,
                "maxItems": MAX_TERMS,
                "items": term,
                "description": f"The terms (required, 1 to {MAX_TERMS}; a coefficient/monomial pair at most once)",
            },
            "absent_coefficients": {
                "type": "array",
                "maxItems": len(COEFFICIENTS),
                "uniqueItems": True,
                "items": {"enum": list(COEFFICIENTS)},
                "description": "Coefficients a fit could not identify (written by gflat fit)",
            },
        },
        required=("terms",),
    )
    return {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "$id": "https://gflat.invalid/schemas/aircraft.schema.json",
        "title": "gflat aircraft file",
        "description": "An aircraft: mass, geometry, engines, envelope and aerodynamic term table (TOML). Each "
        "quantity is written in one unit, the unit being part of the key; numbers are converted "
        "to SI with the exact factors of gna.units.",
        "type": "object",
        "additionalProperties": False,
        "required": ["id", "mass", "geometry", "aero"],
        "x-notes": [
            "Each aerodynamic term `[[aero.terms]]` names one coefficient (CD, CY, CL, Cl, Cm, Cn) and one "
            "monomial; a coefficient/monomial pair appears at most once, and term indices are unique. "
            f"Exponents are at most {MAX_EXPONENT}."
        ],
        "properties": {
            "id": _text(
                "Identifier, also the name of exported files (required)",
                pattern=SAFE_NAME,
                errorMessage="use 1 to 64 letters, digits, '.', '_' or '-' starting with a letter or a "
                "digit (it names output files)",
            ),
            "name": _text("Full name", **{"x-default": "the id"}),
            "provenance": {
                "type": "object",
                "additionalProperties": {"type": "string"},
                "description": "Source, transformation and date of the data set (strings)",
            },
            "mass": _table("Mass and inertia, body axes", mass, cm),
            "geometry": _table("Reference geometry", geo, cg),
            "engines": _table("Propulsion layout", eng, ce),
            "envelope": _table("Validity domain of the aerodynamic model, and control limits", env, cv),
            "aero": aero,
            "fit": {
                "type": "object",
                "description": "Record of the fit that produced the terms (written by "
                "gflat fit; not read by the model)",
            },
        },
    }


def _expr(description: str, default: str | None = None) -> dict:
    out = {"type": ["string", "number"], "description": description, "x-unit": "expression of t [s]"}
    if default is not None:
        out["x-default"] = default
    return out


#: A number, or an expression of the constants and parameters (not of t).
_VALUE = {"type": ["string", "number"]}

#: A spline flat output (planners.splines).
SPLINE = {
    "type": "object",
    "additionalProperties": False,
    "description": "A spline: basis, interior coefficients and conditions at both ends (planners.splines)",
    "properties": {
        "basis": {
            "enum": list(BASES),
            "x-default": '"bezier"',
            "description": "Basis: Bezier curve on [t0, t1] (Bernstein polynomials)",
        },
        "coefficients": {
            "type": "array",
            "items": _VALUE,
            "x-default": "[]",
            "description": "Control points between those the end conditions fix (numbers or expressions of "
            "the parameters)",
        },
        "start": {
            "anyOf": [{"const": "boundary"}, {"type": "array", "items": _VALUE}],
            "x-type": 'list or "boundary"',
            "x-default": '"boundary" with a [boundary.start] table, else []',
            "description": "Value and derivatives 0..k at t0, or the [boundary.start] trim's (x, y, z only)",
        },
        "end": {
            "anyOf": [{"const": "boundary"}, {"type": "array", "items": _VALUE}],
            "x-type": 'list or "boundary"',
            "x-default": '"boundary" with a [boundary.end] table, else []',
            "description": "Value and derivatives 0..k at t1, or the [boundary.end] trim's (x, y, z only)",
        },
    },
}
assert tuple(SPLINE["properties"]) == SPLINE_KEYS


def _output(description: str, default: str | None = None, unit: str | None = None) -> dict:
    """A flat output or prescribed input: an expression of t, or a spline table."""
    e = _expr(description, default)
    if unit:
        e["x-unit"] = unit
    out = {"anyOf": [{"type": ["string", "number"]}, {"$ref": "#/$defs/spline"}], "x-type": "string or number or table"}
    return {**out, **{k: v for k, v in e.items() if k != "type"}}


def _boundary_side() -> dict:
    props = {
        k: {**_VALUE, "description": d, "x-unit": u}
        for k, d, u in (
            ("V", "Airspeed", "m/s"),
            ("gamma", "Flight-path angle (default 0 when fewer than four trim variables are given)", "rad"),
            ("chi_dot", "Turn rate (default 0, as gamma)", "rad/s"),
            ("F", "Thrust", "N"),
            ("alpha", "Angle of attack", "rad"),
            ("beta", "Sideslip (default 0, as gamma)", "rad"),
            ("mu", "Bank angle", "rad"),
            ("p", "Roll rate", "rad/s"),
            ("q", "Pitch rate", "rad/s"),
            ("r", "Yaw rate", "rad/s"),
            ("dl", "Aileron", "rad"),
            ("dm", "Elevator", "rad"),
            ("dn", "Rudder", "rad"),
            ("altitude", "Altitude of the point (required)", "m"),
            ("x", "North position of the point", "m"),
            ("y", "East position of the point", "m"),
            ("chi", "Heading at the point", "rad"),
        )
    }
    for k in ("x", "y", "chi"):
        props[k]["x-default"] = "0"
    assert tuple(props) == TRIM_VARIABLES + BOUNDARY_KEYS
    return _table(
        "One end of a point-to-point manoeuvre: a steady flight of the full model (gflat trim's solution) "
        "with at most four trim variables fixed (numbers or expressions of the parameters; fewer: gamma = 0, "
        "chi_dot = 0, beta = 0 fill the four), at a position and heading",
        props,
        required=("altitude",),
    )


#: The ``[tracking.perturbation]`` keys (values checked by gna.perturbation.perturbation_from_dict).
PERTURBATION = {
    "aero_spread": {
        "x-type": "number",
        "x-unit": "-",
        "x-default": "0",
        "description": "Every aerodynamic term times its own seeded "
        "random factor in [1 - s, 1 + s], 0 <= s < 1 (needs a seed)",
    },
    "aero_scale": {
        "x-type": "table",
        "x-default": "{}",
        "description": "Table of factors by term index or coefficient name",
    },
    "mass_scale": {"x-type": "number", "x-default": "1", "description": "Factor on the mass (positive)"},
    "inertia_scale": {"x-type": "number", "x-default": "1", "description": "Factor on the inertia matrix (positive)"},
    "position_m": {
        "x-type": "number",
        "x-unit": "m",
        "x-default": "0",
        "description": "Initial position offset along (1, 1, 1)/sqrt(3)",
    },
    "speed_mps": {"x-type": "number", "x-unit": "m/s", "x-default": "0", "description": "Initial speed offset"},
    "angle_rad": {
        "x-type": "number",
        "x-unit": "rad",
        "x-default": "0",
        "description": "Offset added to gamma, chi, alpha, beta, mu",
    },
    "state_offsets": {"x-type": "table", "x-default": "{}", "description": "Table of offsets by state name (SI, rad)"},
    "seed": {"x-type": "integer", "x-default": "none", "description": "Seed of the random factors (whole number)"},
}


COMPARE = {
    "tolerances": {
        "x-type": "number or table",
        "x-unit": "SI unit of each variable",
        "description": "Absolute tolerances: one number for every compared variable, or a table "
        "quantity (position, velocity, angle, rate) or variable -> tolerance",
    },
    "rtol": {
        "x-type": "number or table",
        "x-unit": "-",
        "description": "Relative tolerances (fraction of max |reference| over the window), same forms",
    },
    "windows": {
        "x-type": "table",
        "x-unit": "s",
        "description": 'Comparison windows: name -> duration from t0, or "all" for the whole span',
    },
    "dt_out": {
        "x-type": "number",
        "x-unit": "s",
        "x-default": "0.05",
        "description": "Output grid step of every engine and of the plan comparison",
    },
    "jsbsim_dt": {
        "x-type": "number",
        "x-unit": "s",
        "x-default": "1/480",
        "description": "JSBSim's own step, independent of dt_out",
    },
    "self_convergence": {
        "x-type": "boolean",
        "x-default": "false",
        "description": "Also fly JSBSim at half its step and report that difference",
    },
    "tracking_tolerance": {
        "x-type": "number",
        "x-unit": "m",
        "x-default": f"{DEFAULT_TRACKING_TOLERANCE:g}",
        "description": "Closed loop: the tracking verdict passes when every engine's largest distance to the "
        "flat outputs after settle_time is at most this",
    },
    "settle_time": {
        "x-type": "number",
        "x-unit": "s",
        "x-default": f"{DEFAULT_SETTLE_TIME:g}",
        "description": "Closed loop: time from t0 the feedback is given to reach the flat outputs before the "
        "tracking verdict measures",
    },
}

VERDICTS = _table(
    "Violations the scenario records (still computed and shown; they do not fail the exit status of gflat "
    "compare and gflat paper; docs/output.md)",
    {
        "known": {
            "type": "array",
            "x-default": "[]",
            "description": "Recorded violations: a limit of the flyability verdict ("
            + ", ".join(LIMIT_NAMES)
            + ") or a whole verdict ("
            + ", ".join(KNOWN_VERDICTS)
            + "), each with its reason",
            "items": {
                "type": "object",
                "additionalProperties": False,
                "required": ["name", "reason"],
                "properties": {
                    "name": {"enum": list(LIMIT_NAMES + KNOWN_VERDICTS), "description": "The limit or verdict"},
                    "reason": {"type": "string", "minLength": 1, "description": "Why the scenario keeps it"},
                },
            },
        }
    },
)


def scenario_schema() -> dict:
    """The JSON Schema of scenario files (``planners/scenarios/*.toml``)."""
    num = {"type": "number"}
    num_pos = {"type": "number", "exclusiveMinimum": 0}
    tracking = _table(
        "The closed loop (planners.tracking.tracking_controller, planners.lqr.lqr_controller)",
        {
            "design": {
                "enum": list(DESIGNS),
                "x-type": "string",
                "description": "Tracking design: 'paper' (the paper's pole placement by sequential decoupling, "
                "the lambdas) or 'lqr' (finite-horizon time-varying LQR along the plan, Bryson weights from "
                "the tolerances and the aircraft's limits; docs/tracking.md); gflat --tracking overrides it",
                "x-default": '"paper"',
            },
            "tolerances": {
                "type": "object",
                "additionalProperties": False,
                "description": "Largest acceptable tracking errors, the LQR's Bryson weights Q = 1/error^2 "
                "(planners.lqr.TrackingTolerances); the paper's design does not use them",
                "properties": {
                    "position": {**num_pos, "x-unit": "m", "x-default": "1", "description": "x, y, z"},
                    "velocity": {**num_pos, "x-unit": "m/s", "x-default": "1", "description": "V"},
                    "angle": {
                        **num_pos,
                        "x-unit": "rad",
                        "x-default": "0.0174533 (1 deg)",
                        "description": "gamma, chi, alpha, beta, mu",
                    },
                    "rate": {**num_pos, "x-unit": "rad/s", "x-default": "1", "description": "p, q, r"},
                },
            },
            "lambdas": {
                "x-type": "number or table",
                "description": "Pole magnitudes of the tracking feedback: one positive number for all, or a "
                "table of lists I1, I2, I3, I4 of 3, 5, 5, 3 positive numbers (I1..I3 of 5 with "
                "zeta = 'F'); checked by planners.scenario",
                "x-unit": "1/s",
                "x-default": "1.0",
            },
            "feedforward_iterate": {
                "type": "integer",
                "description": "Plan iterate of the feedforward (-1 = last, 0 = the flat plan)",
                "x-default": "-1",
            },
            "saturate": {
                "type": "boolean",
                "description": "Clip the applied controls at the aircraft's limits",
                "x-default": "true",
            },
            "controller_dt": {
                "anyOf": [{"type": "number", "exclusiveMinimum": 0}, {"const": "step"}],
                "x-type": 'number or "step"',
                "description": "Sampling interval of the feedback on sampled engines (JSBSim), the output "
                'held in between; "step" samples at every engine step',
                "x-unit": "s",
                "x-default": '"step"',
            },
            "perturbation": {
                "type": "object",
                "additionalProperties": False,
                "description": "Model and initial-state perturbation (gna.perturbation)",
                "properties": PERTURBATION,
            },
        },
    )
    assert tuple(PERTURBATION) == PERTURBATION_KEYS
    assert set(tracking["properties"]) == set(TRACKING_KEYS)
    assert tuple(COMPARE) == COMPARE_KEYS
    assert tuple(PARAMETER_KEYS) == ("value", "min", "max", "description")
    schema = {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "$id": "https://gflat.invalid/schemas/scenario.schema.json",
        "title": "gflat scenario file",
        "description": "A manoeuvre to plan (TOML): aircraft, time grid, flat outputs as expressions of t, "
        "generalized-flatness iterations, first-iterate H values, report, environment, tracking.",
        "type": "object",
        "additionalProperties": False,
        "$defs": {"spline": SPLINE, "boundary_side": _boundary_side()},
        "required": ["aircraft", "time", "flat_outputs"],
        "allOf": [{"not": {"required": ["h", "calibration"]}}],
        "properties": {
            "name": _text(
                "Name, also the name of output folders",
                pattern=SAFE_NAME,
                errorMessage="use 1 to 64 letters, digits, '.', '_' or '-' starting with a letter or a "
                "digit (it names output folders)",
                **{"x-default": "the file name"},
            ),
            "description": _text("Free text", **{"x-default": '""'}),
            "aircraft": _text(
                "Bundled aircraft id, or path of an aircraft file (relative to the scenario's folder) (required)"
            ),
            "time": _table(
                "Time span and grid",
                {
                    "t0": dict(
                        _VALUE,
                        description="Start (required; a number or an expression of the parameters)",
                        **{"x-unit": "s"},
                    ),
                    "t1": dict(
                        _VALUE,
                        description="End, after t0 (required; a number or an expression of the parameters)",
                        **{"x-unit": "s"},
                    ),
                    "step": dict(
                        num,
                        exclusiveMinimum=0,
                        description=f"Grid step dividing t1 - t0, at most {MAX_NODES} steps (this or nodes)",
                        **{"x-unit": "s"},
                    ),
                    "nodes": {
                        "type": "integer",
                        "minimum": 2,
                        "maximum": MAX_NODES + 1,
                        "description": "Number of nodes from t0 to t1 (this or step)",
                    },
                },
                conflicts=[("step", "nodes")],
                required=("t0", "t1"),
            ),
            "flat_outputs": _table(
                "Flat outputs",
                {
                    "x": _output("North position (required)", None, "m, expression of t [s] or spline"),
                    "y": _output("East position (required)", None, "m, expression of t [s] or spline"),
                    "z": _output("Down position (required)", None, "m, expression of t [s] or spline"),
                    "zeta": {"enum": list(FLAT_KINDS), "description": "The fourth flat output", "x-default": "beta"},
                    "zeta_value": _output("Value of the fourth flat output (rad, or N for F)", "0"),
                    "eta": _output("Thrust asymmetry, the rudder being a control (not with dn)", "0"),
                    "dn": _output("Fixed rudder [rad] (eta becomes a control; not with eta)"),
                    "f1": _output("With zeta = 'mix': f1 beta + f2 mu = zeta_value"),
                    "f2": _output("With zeta = 'mix': f1 beta + f2 mu = zeta_value"),
                },
                conflicts=[("eta", "dn")],
                required=("x", "y", "z"),
            ),
            "generalized": _table(
                "Generalized flatness",
                {
                    "J": {
                        "anyOf": [{"type": "integer"}, {"enum": [AUTO_J]}],
                        "minimum": 0,
                        "maximum": 30,
                        "x-type": 'integer or "auto"',
                        "x-default": "0",
                        "description": 'Number of iterations J, or "auto": chosen by the convergence test on the '
                        "full-model equation residual at the nodes (J_tol, J_max; docs/planning.md)",
                    },
                    "e": {
                        "type": "integer",
                        "minimum": 0,
                        "maximum": MAX_E,
                        "x-default": "1",
                        "description": "Output order e: the controls' series order in the last iterate (the flat "
                        "outputs start at order e + 4 + 2J)",
                    },
                    "interpolation": {
                        "type": "string",
                        "enum": list(INTERPOLATIONS),
                        "x-default": DEFAULT_INTERPOLATION,
                        "description": "Evaluation between nodes: two-point Hermite interpolation of the "
                        "node series, or the paper's two-sided formula (docs/planning.md)",
                    },
                    "J_tol": {
                        "type": "number",
                        "minimum": 0,
                        "x-default": f"{AUTO_J_TOL:g}",
                        "x-unit": "m/s^2, rad/s",
                        "description": 'J = "auto": stop at the first iterate whose full-model residual at the '
                        "nodes is at most this",
                    },
                    "J_max": {
                        "type": "integer",
                        "minimum": 0,
                        "maximum": 30,
                        "x-default": str(AUTO_J_MAX),
                        "description": 'J = "auto": largest J tried',
                    },
                    "method": {
                        "type": "string",
                        "enum": list(METHODS),
                        "x-default": "fixed-point",
                        "description": "The paper's J iterations, or Newton's method on their fixed point "
                        "(J is then the depth; docs/generalized.md)",
                    },
                },
            ),
            "constants": {
                "type": "object",
                "description": "Named numbers the expressions may use; a name may "
                "not be t, a built-in constant ("
                + ", ".join(CONSTANTS)
                + ") or a function ("
                + ", ".join(FUNCTIONS)
                + ")",
                "propertyNames": {
                    "pattern": "^[A-Za-z_][A-Za-z0-9_]*$",
                    "errorMessage": "a constant's name is a letter or '_' followed by letters, digits or '_'",
                },
                "additionalProperties": num,
            },
            "parameters": {
                "type": "object",
                "description": "Named numbers the expressions, spline coefficients, boundary values and t1 may "
                "use, each with its range: a scenario with a parameter whose min is below its max plans "
                "bounded (planners.bounded: the parameters minimizing [bounded] cost within the aircraft's "
                "limits; docs/bounded.md). Names as constants, distinct from them",
                "propertyNames": {
                    "pattern": "^[A-Za-z_][A-Za-z0-9_]*$",
                    "errorMessage": "a parameter's name is a letter or '_' followed by letters, digits or '_'",
                },
                "additionalProperties": {
                    "type": "object",
                    "additionalProperties": False,
                    "required": ["value", "min", "max"],
                    "properties": {
                        "value": dict(
                            num, description="Nominal value (the starting point, the deviation cost's reference)"
                        ),
                        "min": dict(num, description="Lower bound"),
                        "max": dict(num, description="Upper bound (equal to min: fixed)"),
                        "description": _text("Free text"),
                    },
                },
            },
            "boundary": _table(
                "Point-to-point ends: steady flights whose positions and derivatives (0..order) the spline flat "
                "outputs x, y, z meet at t0 and t1",
                {
                    "order": {
                        "type": "integer",
                        "minimum": 0,
                        "maximum": 8,
                        "x-default": str(DEFAULT_BOUNDARY_ORDER),
                        "description": "Highest derivative of x, y, z matched at each end (4: the controls start "
                        "and end at the trims'; 5: their rates too are zero there)",
                    },
                    "start": {"$ref": "#/$defs/boundary_side", "description": "The start (at t0)"},
                    "end": {"$ref": "#/$defs/boundary_side", "description": "The end (at t1)"},
                },
            ),
            "bounded": _table(
                "The bounded planner (scenarios with free parameters; planners.bounded, docs/bounded.md)",
                {
                    "cost": {
                        "enum": list(COSTS),
                        "x-default": '"deviation"',
                        "description": "deviation: sum of ((p - value)/(max - min))^2; control_rate: mean of "
                        "sum (du/dt / half range)^2 over the span; thrust: integral of F; duration: t1 - t0",
                    },
                    "method": {
                        "enum": list(BOUNDED_METHODS),
                        "x-default": '"SLSQP"',
                        "description": "scipy.optimize.minimize method",
                    },
                    "maxiter": {
                        "type": "integer",
                        "minimum": 1,
                        "x-default": str(DEFAULT_MAXITER),
                        "description": "Iterations of the optimizer at most",
                    },
                    "margin": dict(
                        num,
                        minimum=0,
                        exclusiveMaximum=0.5,
                        description="Share of each limit's scale (half range; thrust: m g) kept inside the bound",
                        **{"x-default": f"{DEFAULT_MARGIN:g}"},
                    ),
                    "singular_margin": dict(
                        num,
                        minimum=0,
                        exclusiveMaximum=1,
                        description="Share of the largest magnitude of the flat output's stage-2 condition along "
                        "the nominal plan (planners.singularity, last iterate) kept at every node; 0: none",
                        **{"x-default": f"{DEFAULT_SINGULAR_MARGIN:g}"},
                    ),
                    "tol": dict(
                        num,
                        exclusiveMinimum=0,
                        description="Tolerance of the optimizer",
                        **{"x-default": f"{DEFAULT_TOL:g}"},
                    ),
                },
            ),
            "calibration": {
                "type": "object",
                "description": "H values of the first iterate from a full-model "
                "trim: four of the trim variables (SI, rad) and optionally altitude [m] (default: "
                "mean of -z)",
                "propertyNames": {"enum": list(TRIM_VARIABLES) + ["altitude"]},
                "additionalProperties": num,
            },
            "h": _table(
                "H values of the first iterate (not with [calibration])",
                {
                    k: dict(num, description=d, **{"x-unit": u, "x-default": "0"})
                    for k, d, u in (
                        ("p", "Roll rate", "rad/s"),
                        ("q", "Pitch rate", "rad/s"),
                        ("r", "Yaw rate", "rad/s"),
                        ("dl", "Aileron", "rad"),
                        ("dm", "Elevator", "rad"),
                        ("dn", "Rudder", "rad"),
                    )
                },
            ),
            "report": _table(
                "What the plan report shows",
                {
                    "times": {
                        "type": "array",
                        "maxItems": MAX_REPORT_TIMES,
                        "items": num,
                        "description": f"Times within [t0, t1] tabulated (at most {MAX_REPORT_TIMES})",
                        "x-unit": "s",
                        "x-default": "[]",
                    },
                    "variables": {
                        "type": "array",
                        "maxItems": len(PLAN_VARIABLES),
                        "uniqueItems": True,
                        "items": {"enum": list(PLAN_VARIABLES)},
                        "description": "Plan variables tabulated",
                        "x-default": '["F", "dl", "dm", "dn"]',
                    },
                },
            ),
            "environment": _table(
                "Atmosphere and gravity",
                {
                    "density": {"type": "string", "description": "'isa' or 'constant'", "x-default": "isa"},
                    "rho": dict(
                        num,
                        exclusiveMinimum=0,
                        description="Density with density = 'constant' (required then)",
                        **{"x-unit": "kg/m^3"},
                    ),
                    "g": dict(
                        num, exclusiveMinimum=0, description="Gravity", **{"x-unit": "m/s^2", "x-default": "9.80665"}
                    ),
                    "ground_effect": _table(
                        "Ground effect on lift and induced drag over a flat ground "
                        "(gna.ground_effect, docs/ground_effect.md); the table present turns it on",
                        {
                            "elevation": dict(
                                num,
                                description="Ground elevation (altitude of the ground plane)",
                                **{"x-unit": "m", "x-default": "0"},
                            ),
                            "oswald": dict(
                                num,
                                exclusiveMinimum=0,
                                maximum=1,
                                description="Oswald factor e of the induced drag CL^2/(pi e A)",
                                **{"x-default": "0.8"},
                            ),
                            "section_lift_slope": dict(
                                num,
                                exclusiveMinimum=0,
                                description="Section lift slope a0 of the lifting-line lift factor",
                                **{"x-unit": "1/rad", "x-default": "2 pi"},
                            ),
                        },
                    ),
                },
            ),
            "tracking": tracking,
            "compare": _table(
                "Engine comparison settings (gflat compare, gflat paper); keys checked by every "
                "command, values by harness.validation.parse_compare",
                COMPARE,
            ),
            "verdicts": VERDICTS,
        },
    }
    assert tuple(schema["properties"]["bounded"]["properties"]) == BOUNDED_KEYS
    return schema


def campaign_schema() -> dict:
    """The JSON Schema of campaign files (``harness/campaign/campaigns/*.toml``), from the loader's key tables."""
    J = {
        "anyOf": [{"type": "integer", "minimum": 0, "maximum": MAX_J}, {"enum": [AUTO_J]}],
        "x-type": f'integer 0..{MAX_J} or "auto"',
    }
    loop = {"enum": ["open", "closed"]}
    names = {"type": "string", "pattern": SAFE_NAME}
    case = {
        "id": dict(
            names,
            description="Label of the case, part of every case id (safe identifier)",
            **{"x-default": "the scenario's stem"},
        ),
        "scenario": {
            "anyOf": [{"type": "string"}, {"type": "array", "minItems": 1, "items": {"type": "string"}}],
            "x-type": "string or list",
            "description": "Bundled scenario name or scenario file (relative to the campaign's folder); a list "
            "expands into one case per scenario (required)",
        },
        "J": {
            "anyOf": [J, {"type": "array", "minItems": 1, "items": J}],
            "x-type": f'integer 0..{MAX_J}, "auto" or list',
            "x-default": "the scenario's",
            "description": "Generalized-flatness iterations; a list expands into one case per value",
        },
        "loop": {
            "anyOf": [loop, {"type": "array", "minItems": 1, "items": loop}],
            "x-type": '"open" / "closed" or list',
            "x-default": '"open"',
            "description": "The plan's controls alone, or with the tracking feedback; a list expands into one "
            "case per value",
        },
        "engines": {
            "type": "array",
            "minItems": 2,
            "items": {"enum": list(engine_names())},
            "x-type": "list of " + " / ".join(json.dumps(e) for e in engine_names()),
            "x-default": '["inhouse", "jsbsim"]',
            "description": "At least two distinct engines, the first the reference of the comparison",
        },
        **{k: COMPARE[k] for k in CAMPAIGN_CASE_KEYS if k in COMPARE},
        "tracking": {
            "enum": list(DESIGNS),
            "x-type": "string",
            "x-default": "the scenario's [tracking] design",
            "description": "Tracking design of a closed-loop case (gflat campaign run --tracking sets it for "
            "every case)",
        },
    }
    disp = {
        "aero": {
            "enum": list(AERO_MODES),
            "x-default": '"std_error"',
            "description": "std_error: each term theta + aero_sigma se z with the term's standard error se from "
            "the aircraft file (aero_relative for a term without one); relative: theta (1 + aero_relative z); "
            "none",
        },
        "aero_sigma": {
            "type": "number",
            "minimum": 0,
            "x-default": "1",
            "description": "Multiple of the standard errors",
        },
        "aero_relative": {
            "type": "number",
            "minimum": 0,
            "x-unit": "-",
            "x-default": "0",
            "description": "Relative 1-sigma spread of a term",
        },
        "mass": {
            "type": "number",
            "minimum": 0,
            "x-unit": "-",
            "x-default": "0",
            "description": "Relative 1-sigma spread of the mass (times truncate below 1)",
        },
        "inertia": {
            "type": "number",
            "minimum": 0,
            "x-unit": "-",
            "x-default": "0",
            "description": "Relative 1-sigma spread of the whole inertia matrix (times truncate below 1)",
        },
        "cg_cbar": {
            "type": "number",
            "minimum": 0,
            "x-unit": "fraction of cbar",
            "x-default": "0",
            "description": "1-sigma shift of the centre of gravity along body x",
        },
        "position_m": {
            "type": "number",
            "minimum": 0,
            "x-unit": "m",
            "x-default": "0",
            "description": "1-sigma offset of each of x, y, z at the start",
        },
        "speed_mps": {
            "type": "number",
            "minimum": 0,
            "x-unit": "m/s",
            "x-default": "0",
            "description": "1-sigma offset of the airspeed V at the start",
        },
        "angle_rad": {
            "type": "number",
            "minimum": 0,
            "x-unit": "rad",
            "x-default": "0",
            "description": "1-sigma offset of each of gamma, chi, alpha, beta, mu at the start",
        },
        "truncate": {
            "type": "number",
            "exclusiveMinimum": 0,
            "x-unit": "sigma",
            "x-default": "3",
            "description": "Normal draws z are clipped to [-truncate, truncate]",
        },
    }
    assert tuple(case) == CAMPAIGN_CASE_KEYS
    assert tuple(disp) == DISPERSION_KEYS
    props = {
        "name": _text("Name of the campaign (shown in its report)", **{"x-default": "the file name"}),
        "description": _text("Free text", **{"x-default": '""'}),
        "seed": {
            "type": "integer",
            "minimum": 0,
            "description": "Campaign seed: every sample's seed derives from it and from the sample's case, "
            "dispersion and index, not from the count (required)",
        },
        "samples": {
            "type": "integer",
            "minimum": 1,
            "x-default": "1",
            "description": "Samples per case and dispersion set (gflat campaign run --samples overrides)",
        },
        "case_budget_s": {
            "type": "number",
            "exclusiveMinimum": 0,
            "x-unit": "s",
            "x-default": f"{CASE_BUDGET_S:g}",
            "description": "Wall-time budget of one case (inf: none); a case beyond it ends as a timeout "
            "(gflat campaign run --case-budget overrides)",
        },
        "cases": {
            "type": "array",
            "minItems": 1,
            "items": _table("A validation case", case, required=("scenario",)),
            "description": "The cases (required, one or more); lists in scenario, J and loop expand into their "
            f"product, at most {MAX_CASE_SPECS} expanded cases in all, each label unique",
        },
        "dispersions": {
            "type": "object",
            "minProperties": 1,
            "maxProperties": MAX_DISPERSIONS,
            "propertyNames": {"pattern": SAFE_NAME},
            "additionalProperties": _table("A dispersion set", disp),
            "x-default": '{nominal = {aero = "none"}}',
            "description": "Named sets of 1-sigma spreads of the aircraft data and the initial state (all zero: "
            f"the nominal aircraft), at most {MAX_DISPERSIONS}; each multiplies the cases; NAME is part of every "
            "case id",
        },
        "output": _table(
            "What the campaign stores",
            {
                "trajectories": {
                    "type": "boolean",
                    "x-default": "true",
                    "description": "Write each case's trajectories (Parquet)",
                }
            },
        ),
    }
    assert tuple(props) == CAMPAIGN_KEYS
    assert tuple(props["output"]["properties"]) == CAMPAIGN_OUTPUT_KEYS
    return {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "$id": "https://gflat.invalid/schemas/campaign.schema.json",
        "title": "gflat campaign file",
        "description": "A validation campaign (TOML): validation cases times dispersion sets times samples, "
        "with one seed. The schema is built from the key tables of harness/campaign/spec.py, which checks "
        "the values.",
        "type": "object",
        "additionalProperties": False,
        "required": ["seed", "cases"],
        "properties": props,
    }


def outputs() -> dict[Path, str]:
    """``{path: text}`` of the generated files."""
    a, s = aircraft_schema(), scenario_schema()
    return {
        AIRCRAFT_SCHEMA: json.dumps(a, indent=2) + "\n",
        SCENARIO_SCHEMA: json.dumps(s, indent=2) + "\n",
        CAMPAIGN_SCHEMA: json.dumps(campaign_schema(), indent=2) + "\n",
        DOC: scenarios_page(a, s),
        CLI_DOC: cli_page(CLI_DOC.read_text(encoding="utf-8"), output_schemas()),
    }


def output_schemas() -> dict[str, dict]:
    """The output schemas of the commands, in :data:`OUTPUT_ORDER` (then any other, by name)."""
    names = sorted(p.stem for p in OUTPUT_SCHEMAS.glob("*.json"))
    order = [n for n in OUTPUT_ORDER if n in names] + [n for n in names if n not in OUTPUT_ORDER]
    return {n: json.loads((OUTPUT_SCHEMAS / f"{n}.json").read_text(encoding="utf-8")) for n in order}


def main() -> int:
    for path, text in outputs().items():
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text, encoding="utf-8")
        print(f"wrote {path.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
