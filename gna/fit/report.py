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
    """``x`` with ``digits`` decimals, never "-0.000" (round-off must not change the text).

    Parameters
    ----------
    x : float
        The number.
    digits : int
        Decimals.
    sign : bool
        Always print the sign (``+0.000`` for zero).

    Returns
    -------
    str
        The fixed-point text.
    """
    text = f"{x:+.{digits}f}" if sign else f"{x:.{digits}f}"
    if float(text) == 0.0:
        text = f"{0.0:+.{digits}f}" if sign else f"{0.0:.{digits}f}"
    return text


def record(ident: str) -> dict:
    """The parsed aircraft file of ``ident`` (with its ``[fit]`` record).

    Parameters
    ----------
    ident : str
        A bundled aircraft id or an aircraft file path (:func:`gna.aircraft.load_aircraft`).

    Returns
    -------
    dict
        The file's TOML as read (source units, ``[fit]`` included).

    Raises
    ------
    InputError
        The file has no ``[fit]`` record (not a fitted aircraft), or cannot be loaded as an aircraft.
    """
    path = load_aircraft(ident).path
    doc = read_toml(path)  # the bounded reader of every input file
    if "fit" not in doc:
        raise InputError(f"{ident}: {path} has no [fit] record (not a fitted aircraft)")
    return doc


def statistics_table(ids=FITTED) -> str:
    """The held-out statistics of each fitted coefficient, as a Markdown table.

    Parameters
    ----------
    ids : sequence of str
        Fitted aircraft ids (default :data:`FITTED`), read from their ``[fit]`` records (:func:`record`).

    Returns
    -------
    str
        One row per aircraft and coefficient: R², RMS and max abs error on the block's held-out points,
        the range of the source values and R² on the 8-D box's held-out points.

    Raises
    ------
    InputError
        An aircraft without a ``[fit]`` record.
    """
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
    """The level-trim check of each fitted aircraft against its source model, as a Markdown table.

    Parameters
    ----------
    ids : sequence of str
        Fitted aircraft ids (default :data:`FITTED`), read from their ``[fit]`` records (:func:`record`).

    Returns
    -------
    str
        One row per aircraft: alpha, dm and thrust of both models and their differences, and whether the
        targets (:data:`TARGET_ALPHA_DEG`, :data:`TARGET_DM_DEG`) are met.

    Raises
    ------
    InputError
        An aircraft without a ``[fit]`` record.
    """
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
    """The lateral trim variables (dl, dn, mu) of both models of each fitted aircraft, as a Markdown table.

    Parameters
    ----------
    ids : sequence of str
        Fitted aircraft ids (default :data:`FITTED`), read from their ``[fit]`` records (:func:`record`).

    Returns
    -------
    str
        One row per aircraft, degrees.

    Raises
    ------
    InputError
        An aircraft without a ``[fit]`` record.
    """
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
    """All 45 parameters of f16c and f16-jsbsim side by side, and their level trims.

    f16c (Grauer--Morelli's parameter set) is trimmed here at f16-jsbsim's reference condition; the two
    f16-jsbsim trims are read from its ``[fit]`` record.

    Returns
    -------
    str
        Markdown: the parameter table (with the fit's standard errors), then the trim table and the two
        aircraft's masses.

    Raises
    ------
    InputError
        The two files' term structures differ.
    ConvergenceError, DomainError
        f16c cannot be trimmed at the reference condition (from :func:`gna.trim.trim_level`).
    """
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
    """The generated part of ``docs/fit_quality.md``.

    Returns
    -------
    str
        Markdown from :data:`BEGIN` to :data:`END` inclusive: the statistics, trim, lateral trim and F-16
        tables with their headings.
    """
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


def update_docs(path: str | Path, check: bool = False, write=None) -> bool:
    """Rewrite (or, with ``check``, compare) the generated block of a documentation file.

    Parameters
    ----------
    path : str or Path
        The Markdown file, holding the :data:`BEGIN` and :data:`END` markers.
    check : bool
        Compare only; write nothing.
    write : callable, optional
        ``write(path, text)`` writing the file (default :meth:`pathlib.Path.write_text`; ``gflat fit regenerate``
        gives an atomic one).

    Returns
    -------
    bool
        True when the block was current (nothing written).

    Raises
    ------
    InputError
        The file does not exist or lacks the markers.
    """
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
        (write or Path.write_text)(path, new)
    return current
