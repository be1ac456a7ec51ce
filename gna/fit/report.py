"""The quality tables of ``docs/fit_quality.md``, generated from the committed aircraft files.

Everything here reads the fitted aircraft files (their ``[fit]`` records:
held-out statistics and the level-trim check computed when they were
regenerated) and, for the F-16 comparison, trims the ``f16c`` parameter set
at the ``f16-jsbsim`` reference condition.  The block between
:data:`BEGIN` and :data:`END` in the documentation is this module's output;
``gflat fit regenerate --docs docs/fit_quality.md`` rewrites it and a test
checks it is current.
"""

from __future__ import annotations

from pathlib import Path

from ..aircraft import load_aircraft
from ..errors import InputError
from ..schema import read_toml
from ..trim import trim_level
from .quality import trim_record

BEGIN = "<!-- BEGIN GENERATED: gflat fit regenerate --docs (do not edit by hand) -->"
END = "<!-- END GENERATED -->"

FITTED = ("twin-otter", "gtm", "f4", "f16-jsbsim")
TARGET_ALPHA_DEG = 0.5
TARGET_DM_DEG = 1.0


def num(x: float, digits: int, sign: bool = False) -> str:
    """``x`` with ``digits`` decimals, never "-0.000" (round-off must not change the text)."""
    text = f"{x:+.{digits}f}" if sign else f"{x:.{digits}f}"
    if float(text) == 0.0:
        text = f"{0.0:+.{digits}f}" if sign else f"{0.0:.{digits}f}"
    return text


def record(ident: str) -> dict:
    """The parsed aircraft file of ``ident`` (with its ``[fit]`` record)."""
    path = load_aircraft(ident).path
    doc = read_toml(path)  # the bounded reader of every input file
    if "fit" not in doc:
        raise InputError(f"{ident}: {path} has no [fit] record (not a fitted aircraft)")
    return doc


def statistics_table(ids=FITTED) -> str:
    rows = [
        "| aircraft | coef | R² held-out | RMS held-out | max abs held-out | range of source | R² on 8-D box |",
        "|---|---|---|---|---|---|---|",
    ]
    for ident in ids:
        stats = record(ident)["fit"]["statistics"]
        for c, s in stats.items():
            t = s["test"]
            box = num(s["test_box"]["r2"], 4) if "test_box" in s else "(fitted on it)"
            rows.append(
                f"| {ident} | {c} | {num(t['r2'], 4)} | {num(t['rms'], 5)} | {num(t['max_abs'], 5)} "
                f"| {num(t['range'], 4)} | {box} |"
            )
    return "\n".join(rows)


def trim_table(ids=FITTED) -> str:
    rows = [
        "| aircraft | reference condition | α GNA / source [deg] | Δα [deg] | δm GNA / source [deg] "
        "| Δδm [deg] | thrust GNA / source [N] | Δthrust | target (0.5°, 1°) |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for ident in ids:
        f = record(ident)["fit"]
        g, s, d = f["trim"]["gna"], f["trim"]["source"], f["trim"]["difference"]
        ref = f["reference"]
        ok = abs(d["alpha_deg"]) <= TARGET_ALPHA_DEG and abs(d["dm_deg"]) <= TARGET_DM_DEG
        rows.append(
            f"| {ident} | {ref['label']}, V = {num(ref['V_ms'], 3)} m/s "
            f"| {num(g['alpha_deg'], 3)} / {num(s['alpha_deg'], 3)} | {num(d['alpha_deg'], 3, True)} "
            f"| {num(g['dm_deg'], 3)} / {num(s['dm_deg'], 3)} | {num(d['dm_deg'], 3, True)} "
            f"| {num(g['thrust_N'], 1)} / {num(s['thrust_N'], 1)} | {num(100 * d['thrust_rel'], 1, True)} % "
            f"| {'met' if ok else 'NOT met'} |"
        )
    return "\n".join(rows)


def lateral_trim_table(ids=FITTED) -> str:
    rows = ["| aircraft | δl GNA / source [deg] | δn GNA / source [deg] | μ GNA / source [deg] |", "|---|---|---|---|"]
    for ident in ids:
        t = record(ident)["fit"]["trim"]
        g, s = t["gna"], t["source"]
        rows.append(
            f"| {ident} | {num(g['dl_deg'], 4)} / {num(s['dl_deg'], 4)} "
            f"| {num(g['dn_deg'], 4)} / {num(s['dn_deg'], 4)} "
            f"| {num(g['mu_deg'], 4)} / {num(s['mu_deg'], 4)} |"
        )
    return "\n".join(rows)


def f16_comparison() -> str:
    """All 45 parameters of f16c and f16-jsbsim side by side, and their level trims."""
    a, b = load_aircraft("f16c"), load_aircraft("f16-jsbsim")
    rec = record("f16-jsbsim")
    se = {t["theta"]: t.get("std_error") for t in rec["aero"]["terms"]}
    rows = [
        "| θ | coef | monomial | f16c (Grauer–Morelli) | f16-jsbsim (fit) | std error of fit |",
        "|---|---|---|---|---|---|",
    ]
    for ta, tb in zip(a.aero.terms, b.aero.terms):
        if (ta.coefficient, ta.exponents) != (tb.coefficient, tb.exponents):
            raise InputError(f"f16c and f16-jsbsim structures differ at theta {ta.index}")
        rows.append(
            f"| {ta.index} | {ta.coefficient} | {ta.monomial} | {ta.value:.4g} | {tb.value:.4g} "
            f"| {se.get(tb.index, float('nan')):.2g} |"
        )
    ref = rec["fit"]["reference"]
    tc = trim_record(trim_level(a, ref["V_ms"], ref["altitude_m"]))
    tj, ts = rec["fit"]["trim"]["gna"], rec["fit"]["trim"]["source"]
    trims = ["| model (own mass, geometry) | α [deg] | δm [deg] | thrust [N] |", "|---|---|---|---|"]
    for name, t in (("f16c (Grauer–Morelli GNA)", tc), ("f16-jsbsim (GNA fit)", tj), ("JSBSim f16 aerodynamics", ts)):
        trims.append(f"| {name} | {num(t['alpha_deg'], 3)} | {num(t['dm_deg'], 3)} | {num(t['thrust_N'], 1)} |")
    mass = (
        f"f16c: m = {a.mass.mass:.1f} kg, x_cg − x_ref = {a.geometry.x_cg - a.geometry.x_ref:+.4f} m; "
        f"f16-jsbsim: m = {b.mass.mass:.1f} kg, moments about its CG"
    )
    return (
        "\n".join(rows) + f"\n\nLevel trim at {ref['label']} (V = {ref['V_ms']:.3f} m/s, "
        f"{ref['altitude_m']:.1f} m), same equations of motion ({mass}):\n\n" + "\n".join(trims)
    )


def generated_block() -> str:
    """The generated part of ``docs/fit_quality.md`` (between the markers)."""
    parts = [
        BEGIN,
        "",
        "### Held-out statistics",
        "",
        "Each coefficient on the held-out points of the block it was fitted on; CD, CL, Cm (fitted on the "
        "longitudinal plane) also on the held-out points of the 8-D box.",
        "",
        statistics_table(),
        "",
        "### Level-flight trim, GNA fit against its source model",
        "",
        "Straight, level, wings-level flight (γ = χ' = β = 0), ISA density, same equations of motion, mass "
        "and engines; only the aerodynamic model differs.",
        "",
        trim_table(),
        "",
        "Lateral trim variables at the same conditions:",
        "",
        lateral_trim_table(),
        "",
        "### f16-jsbsim against f16c",
        "",
        f16_comparison(),
        "",
        END,
    ]
    return "\n".join(parts)


def update_docs(path: str | Path, check: bool = False) -> bool:
    """Rewrite (or, with ``check``, compare) the generated block of ``path``; True when it was current."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"documentation file not found: {path}")
    text = path.read_text()
    if BEGIN not in text or END not in text:
        raise InputError(f"{path}: missing the generated-block markers {BEGIN!r} ... {END!r}")
    head, rest = text.split(BEGIN, 1)
    _, tail = rest.split(END, 1)
    new = head + generated_block() + tail
    current = new == text
    if not check and not current:
        path.write_text(new)
    return current
