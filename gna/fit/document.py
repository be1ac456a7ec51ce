"""Assembling a fitted aircraft file: vehicle data, fit, statistics, trim check, provenance."""

from __future__ import annotations

import math
from collections.abc import Mapping

from ..aero import COEFFICIENTS
from .design import SamplingDesign
from .lstsq import FitResult
from .quality import ReferenceCondition
from .writer import Inline, aircraft_document

CONVENTIONS = (
    "CD, CL stability axes; CY, Cl, Cm, Cn body axes about x_ref; alpha, beta, surfaces in rad; "
    "phat = p b/2V, qhat = q cbar/2V, rhat = r b/2V; dl right aileron trailing edge down, dm trailing "
    "edge down, dn trailing edge left positive"
)

TRANSFORMATION = (
    "least-squares fit (gna.fit) of the aerodynamic term structure to samples of the source model "
    "in the project's conventions (stability-axis CD = -(CX cos a + CZ sin a), CL = CX sin a - "
    "CZ cos a from the source's body axes); mass, geometry and engines in the source's units, "
    "converted to SI on load with exact factors (gna.units)"
)


def _deg(x: float) -> float:
    return float(f"{math.degrees(x):.12g}")


def envelope_section(design: SamplingDesign, limits_deg: Mapping[str, float], limits_source: str) -> dict:
    """Validity of the fit (the design's alpha and beta ranges) and the surface limits."""
    a_lo = min(b.ranges["alpha"][0] for b in design.blocks)
    a_hi = max(b.ranges["alpha"][1] for b in design.blocks)
    b_max = max(max(abs(b.ranges["beta"][0]), abs(b.ranges["beta"][1])) for b in design.blocks)
    out = {"alpha_min_deg": _deg(a_lo), "alpha_max_deg": _deg(a_hi), "beta_max_deg": _deg(b_max)}
    for k in ("dl", "dm", "dn"):
        if k in limits_deg:
            out[f"{k}_max_deg"] = float(limits_deg[k])
    out["source"] = (
        "alpha and beta: the sampling design's box (the fit is validated only inside it); "
        f"surface limits: {limits_source}"
    )
    return out


def statistics_summary(result: FitResult, set_name: str = "test") -> str:
    return ", ".join(f"{c} {s[set_name].r2:.4f} ({s[set_name].rms:.5f})" for c, s in result.stats.items())


def trim_summary(trim: Mapping, reference: ReferenceCondition) -> str:
    g, s = trim["gna"], trim["source"]
    return (
        f"level flight at {reference.label}: GNA fit alpha {g['alpha_deg']:.3f} deg, dm {g['dm_deg']:.3f} deg, "
        f"thrust {g['thrust_N']:.1f} N; source model alpha {s['alpha_deg']:.3f} deg, dm {s['dm_deg']:.3f} deg, "
        f"thrust {s['thrust_N']:.1f} N (same equations of motion, mass and engines)"
    )


def fitted_document(
    *,
    ident: str,
    name: str,
    source_provenance: Mapping[str, str],
    sections: Mapping[str, dict],
    envelope: dict,
    design: SamplingDesign,
    result: FitResult,
    reference: ReferenceCondition,
    trim: Mapping | None,
    notes: str,
    date: str,
    command: str,
) -> dict:
    """The aircraft document (a dict ready for :func:`gna.fit.writer.aircraft_document`)."""
    prov = {"source": source_provenance["source"]}
    if "source_model" in source_provenance:
        prov["source_model"] = source_provenance["source_model"]
    prov.update(
        {
            "transformation": TRANSFORMATION,
            "date": date,
            "sampling": (
                f"{design.description}; {sum(b.n_fit for b in design.blocks)} fit and "
                f"{sum(b.n_test for b in design.blocks)} held-out points, seed {design.seed} "
                f"(details in [fit.design])"
            ),
            "reference_condition": f"{reference.label}: V = {reference.V:.6g} m/s, altitude {reference.altitude:.6g} m",
            "statistics": "held-out R2 (RMS) per coefficient: " + statistics_summary(result),
            "trim_check": trim_summary(trim, reference) if trim else "not computed",
            "regenerate": command,
            "notes": notes,
        }
    )
    stats = {c: Inline({k: Inline(v.to_dict()) for k, v in s.items()}) for c, s in result.stats.items()}
    conds = {c: f.condition for c, f in result.fits.items()}
    fit = {
        "tool": "gna.fit",
        "structure": result.table.structure,
        "reference": Inline(reference.to_dict()),
        "condition_numbers": Inline(conds),
        "design": _design_tables(design),
        "statistics": stats,
    }
    if trim:
        fit["trim"] = {k: Inline(v) for k, v in trim.items()}
    se = result.std_errors()
    terms = []
    for t in result.table.terms:
        terms.append(
            {
                "theta": t.index,
                "coef": t.coefficient,
                "monomial": t.monomial,
                "value": t.value,
                "std_error": se[t.index],
                "source": "least-squares fit, see [fit]",
            }
        )
    doc = {"id": ident, "name": name, "provenance": prov}
    doc.update({k: dict(v) for k, v in sections.items()})
    doc["envelope"] = envelope
    doc["fit"] = fit
    doc["aero"] = {"structure": result.table.structure, "conventions": CONVENTIONS, "terms": terms}
    missing = [c for c in COEFFICIENTS if c not in result.stats]
    if missing:
        doc["aero"]["absent_coefficients"] = missing
    return doc


def _design_tables(design: SamplingDesign) -> dict:
    d = design.to_dict()
    blocks = {}
    for name, b in d["blocks"].items():
        body = {k: v for k, v in b.items() if k != "ranges"}
        body["ranges"] = Inline(b["ranges"])
        blocks[name] = body
    return {"method": d["method"], "seed": d["seed"], "description": d["description"], "blocks": blocks}


def fitted_aircraft(ident: str, name: str, sections: Mapping[str, dict], envelope: dict, table, source_name: str):
    """The :class:`~gna.aircraft.Aircraft` of a fit (to trim it), with errors naming the source of the data."""
    from ..aircraft import aircraft_from_dict
    from ..errors import InputError, describe

    base = {
        "id": ident,
        "name": name,
        **{k: dict(v) for k, v in sections.items()},
        "envelope": envelope,
        "aero": {"structure": table.structure, "terms": table.to_records()},
    }
    try:
        return aircraft_from_dict(base, where=f"{ident} (fitted)")
    except InputError as exc:
        raise InputError(f"vehicle data of {source_name}: {describe(exc)}") from None


def render(doc: Mapping, title: str, command: str) -> str:
    header = f"{title}\nGenerated by {command} (gna.fit); do not edit by hand."
    return aircraft_document(doc, header)
