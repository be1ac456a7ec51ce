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
    """The ``[envelope]`` table of a fitted aircraft: the fit's validity and the surface limits.

    Parameters
    ----------
    design : SamplingDesign
        The fit's design; its blocks' alpha range and largest ``|beta|`` bound where the fit holds.
    limits_deg : mapping of str to float
        Surface deflection limits ``{"dl": ..., "dm": ..., "dn": ...}`` [deg] (any subset).
    limits_source : str
        Where the surface limits come from (provenance text).

    Returns
    -------
    dict
        ``alpha_min_deg``, ``alpha_max_deg``, ``beta_max_deg``, ``<surface>_max_deg`` and ``source``
        (degrees, as the aircraft files are written).
    """
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


def _statistics_summary(result: FitResult, set_name: str = "test") -> str:
    return ", ".join(f"{c} {s[set_name].r2:.4f} ({s[set_name].rms:.5f})" for c, s in result.stats.items())


def _trim_summary(trim: Mapping, reference: ReferenceCondition) -> str:
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
    """The aircraft document of a fit (a dict ready for :func:`gna.fit.writer.aircraft_document`).

    All parameters are keywords.

    Parameters
    ----------
    ident : str
        Aircraft id (the file's stem).
    name : str
        Human-readable aircraft name.
    source_provenance : mapping of str to str
        The source model's ``provenance()``: ``"source"``, and ``"source_model"`` when it has one.
    sections : mapping of str to dict
        The vehicle tables ``mass``, ``geometry``, ``engines`` in the aircraft-file layout (source units).
    envelope : dict
        The ``[envelope]`` table (:func:`envelope_section`).
    design : SamplingDesign
        The sampling design of the fit.
    result : FitResult
        The fitted table, per-coefficient statistics and condition numbers (:func:`gna.fit.lstsq.fit_table`).
    reference : ReferenceCondition
        The trim-check condition.
    trim : mapping or None
        :func:`gna.fit.quality.trim_comparison` at ``reference``, or None when not computed.
    notes : str
        Known limits of the fit (provenance text).
    date : str
        ISO date written into the provenance.
    command : str
        The command that regenerates the file.

    Returns
    -------
    dict
        ``id``, ``name``, ``[provenance]``, the vehicle sections, ``[envelope]``, the machine-readable
        ``[fit]`` record and ``[aero]`` (one term a row, with its standard error).
    """
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
            "statistics": "held-out R2 (RMS) per coefficient: " + _statistics_summary(result),
            "trim_check": _trim_summary(trim, reference) if trim else "not computed",
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
    """The :class:`~gna.aircraft.Aircraft` of a fit (to trim it), with errors naming the source of the data.

    Parameters
    ----------
    ident : str
        Aircraft id.
    name : str
        Human-readable aircraft name.
    sections : mapping of str to dict
        The vehicle tables ``mass``, ``geometry``, ``engines`` in the aircraft-file layout.
    envelope : dict
        The ``[envelope]`` table (:func:`envelope_section`).
    table : TermTable
        The fitted aerodynamic term table.
    source_name : str
        The source model's name (for the message).

    Returns
    -------
    Aircraft
        Loaded by :func:`gna.aircraft.aircraft_from_dict` (SI units).

    Raises
    ------
    InputError
        The vehicle data do not load as an aircraft; the message names ``source_name``.
    """
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
    """The TOML text of a fitted aircraft document, under a header naming the generating command.

    Parameters
    ----------
    doc : mapping
        The document (:func:`fitted_document`).
    title : str
        First header line.
    command : str
        The command that regenerates the file.

    Returns
    -------
    str
        The file's text (:func:`gna.fit.writer.aircraft_document`: checked to parse and to load).
    """
    header = f"{title}\nGenerated by {command} (gna.fit); do not edit by hand."
    return aircraft_document(doc, header)
