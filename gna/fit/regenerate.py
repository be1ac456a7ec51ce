"""The fitted aircraft of the project, and the one command that regenerates them.

``gflat fit regenerate`` (or ``python -m gna.fit.regenerate``) rebuilds
``gna/data/aircraft/{twin-otter,gtm,f4,f16-jsbsim}.toml`` from their sources:

=============  ==========================================  ==========================================
id             source                                      reference condition (trim check)
=============  ==========================================  ==========================================
twin-otter     UIUC/NASA Twin Otter clean linear model      140 kt at 1000 ft
gtm            NASA GTM T2 database (GTM_DesignSim)         75 kt EAS at sea level (38.583 m/s)
f4             JSBSim F4N                                   Mach 0.6 at 10 000 ft
f16-jsbsim     JSBSim f16                                   Mach 0.6 at 10 000 ft
=============  ==========================================  ==========================================

Everything is deterministic (fixed seeds); a file's ``date`` is kept when
its content is unchanged.  ``--check`` compares instead of writing and exits
with status 1 when a committed file is not current.
"""

from __future__ import annotations

import argparse
import datetime
import math
import sys
import tomllib
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

from .. import units
from ..errors import GflatError
from .design import SamplingDesign, standard_design
from .document import envelope_section, fitted_aircraft, fitted_document, render
from .pipeline import fit_source, gna45_structure
from .quality import ReferenceCondition, trim_comparison
from .writer import differences

COMMAND = "gflat fit regenerate"

#: Fields not compared when checking that a file is current: the date, and text summaries of numbers
#: that are compared numerically in [fit] (their last printed digit may differ across platforms).
SUMMARY_FIELDS = ("provenance.date", "provenance.statistics", "provenance.trim_check")
D = math.radians
FT = units.FT


def _data_dir(*parts: str) -> Path:
    root = resources.files("gna") / "data"
    for p in parts:
        root = root / p
    return Path(str(root))


@dataclass(frozen=True)
class FitSpec:
    """Everything needed to (re)build one fitted aircraft file.

    ``make_source`` builds the source model; ``design``, ``sections`` and
    ``limits`` are functions of the source (JSBSim aircraft take their
    surface ranges and mass from it); ``limits`` returns
    ``({"dl": deg, ...}, source text)``.
    """

    ident: str
    name: str
    make_source: Callable[[], object]
    design: Callable[[object], SamplingDesign]
    sections: Callable[[object], Mapping[str, dict]]
    limits: Callable[[object], tuple[dict, str]]
    reference: Callable[[object], ReferenceCondition]
    notes: str
    title: str = field(default="")


# -- Twin Otter ---------------------------------------------------------------------------------
TWIN_OTTER_RANGES = {
    "alpha": (D(-5.0), D(12.0)),
    "beta": (D(-15.0), D(15.0)),
    "phat": (-0.1, 0.1),
    "qhat": (-0.03, 0.03),
    "rhat": (-0.06, 0.06),
    "dl": (D(-20.0), D(20.0)),
    "dm": (D(-20.0), D(20.0)),
    "dn": (D(-20.0), D(20.0)),
}


def _twin_otter_source():
    from .sources.linear import LinearDerivativeModel

    env = {k: TWIN_OTTER_RANGES[k] for k in ("alpha", "beta", "dl", "dm", "dn")}
    src = LinearDerivativeModel.from_csv(
        _data_dir("sources", "twin_otter", "aircraft_dat_clean.csv"),
        env,
        "UIUC/NASA Twin Otter icing research aircraft, clean linear model",
        "UIUC Smart Icing Systems model of the NASA Glenn DHC-6 Twin Otter icing research aircraft, clean "
        "configuration (FlightGear FGDATA Aircraft-uiuc/TwinOtter/aircraft.dat, 2000-05-23; J. Scott, "
        "D. Pokhariyal; data from Pokhariyal & Merret 2000, Ratvasky & Ranaudo AIAA-93-0398), vendored in "
        "gna/data/sources/twin_otter",
    )
    src.envelope_origin = {
        "alpha": "declared: the source states no range; its linear lift reaches CL = 1.55 at 12 deg",
        "beta": "declared: the source states no range",
        "dl": "the source's control limit (20 deg, 'guess for now')",
        "dm": "the source's control limit (20 deg, 'guess for now')",
        "dn": "the source's control limit (20 deg, 'guess for now')",
    }
    return src


def _twin_otter_sections(_src) -> dict:
    from .sources.linear import vehicle_values

    v = vehicle_values(_data_dir("sources", "twin_otter", "aircraft_dat_clean.csv"))
    src = "UIUC Twin Otter aircraft.dat (clean), gna/data/sources/twin_otter/aircraft_dat_clean.csv"
    return {
        "mass": {
            "weight_lb": v["Weight"][0],
            "Ixx_slugft2": v["I_xx"][0],
            "Iyy_slugft2": v["I_yy"][0],
            "Izz_slugft2": v["I_zz"][0],
            "Ixz_slugft2": v["I_xz"][0],
            "source": src,
        },
        "geometry": {
            "S_ft2": v["Sw"][0],
            "b_ft": v["bw"][0],
            "cbar_ft": v["cbar"][0],
            "x_cg_m": 0.0,
            "x_ref_m": 0.0,
            "source": src + "; the model's moments are about the CG, whose position on the MAC the source "
            "does not give: x_cg = x_ref = 0 (only their difference matters)",
        },
        "engines": {
            "count": 2,
            "y_p_ft": 9.2,
            "epsilon_rad": 0.0,
            "max_thrust_lbf": 2.0 * v["simpleSingle"][0],
            "source": "engines at +-9.2 ft as in Ollivier (2022), subsection 'Single engine' (the JSBSim "
            "DHC6 has +-9.108 ft); thrust line along body x (no data); max thrust 2 x "
            f"{v['simpleSingle'][0]:g} lbf, the source's '~2000 lb static thrust each'",
            "engine_power_shp": 680.0,
            "propeller_efficiency": 0.8,
            "engine_static_thrust_lbf": v["simpleSingle"][0],
            "engine_source": TWIN_OTTER_ENGINE_SOURCE,
        },
    }


#: Provenance of the Twin Otter's per-engine rating (aircraft file key ``engine_source``).
TWIN_OTTER_ENGINE_SOURCE = (
    "one Pratt & Whitney Canada PT6A-27: takeoff rating 680 shp (FAA Type Certificate Data Sheet E4EA, PT6A-27 "
    "ratings); static thrust 2000 lbf, the UIUC source's '~2000 lb static thrust each'; in flight "
    "power-limited, thrust <= 0.8 x 680 shp / V with 0.8 a typical cruise propeller efficiency (Raymer, "
    "Aircraft Design: A Conceptual Approach, sec. 13.6): 5633 N at 140 kt"
)


def _twin_otter_design(_src) -> SamplingDesign:
    return standard_design(TWIN_OTTER_RANGES, seed=1)


# -- GTM ------------------------------------------------------------------------------------------
GTM_RANGES = {
    "alpha": (D(-5.0), D(16.0)),
    "beta": (D(-25.0), D(25.0)),
    "phat": (-0.1, 0.1),
    "qhat": (-0.0075, 0.0075),
    "rhat": (-0.1, 0.1),
    "dl": (D(-20.0), D(20.0)),
    "dm": (D(-30.0), D(20.0)),
    "dn": (D(-30.0), D(30.0)),
}
GTM_SPEED = 75.0 * units.KT


def _gtm_source():
    from .sources.gtm import GTMSource

    return GTMSource(V_ref=GTM_SPEED)


def _gtm_sections(_src) -> dict:
    from .sources.gtm import vehicle_sections

    return vehicle_sections()


def _gtm_design(_src) -> SamplingDesign:
    return standard_design(GTM_RANGES, seed=2)


# -- JSBSim aircraft ------------------------------------------------------------------------------
JSBSIM_MACH = 0.6
JSBSIM_ALTITUDE = 10000.0 * FT


def _jsbsim(model: str):
    def make():
        from .sources.jsbsim_aero import JSBSimAeroSource

        return JSBSimAeroSource(model, mach=JSBSIM_MACH, altitude=JSBSIM_ALTITUDE)

    return make


def _jsbsim_design(alpha_max_deg: float, seed: int):
    def design(src) -> SamplingDesign:
        ranges = {
            "alpha": (D(-5.0), D(alpha_max_deg)),
            "beta": (D(-15.0), D(15.0)),
            "phat": (-0.15, 0.15),
            "qhat": (-0.03, 0.03),
            "rhat": (-0.06, 0.06),
        }
        for k in ("dl", "dm", "dn"):
            ranges[k] = src.envelope[k]
        return standard_design(ranges, seed=seed, dm_band=0.1)

    return design


def _jsbsim_sections(src) -> dict:
    from .sources.jsbsim_aero import vehicle_sections

    return vehicle_sections(src)


def _jsbsim_limits(src) -> tuple[dict, str]:
    lim = {k: math.degrees(max(abs(src.envelope[k][0]), abs(src.envelope[k][1]))) for k in ("dl", "dm", "dn")}
    dm = src.envelope["dm"]
    return lim, (
        f"JSBSim flight-control output ranges (largest magnitude; dm spans "
        f"[{math.degrees(dm[0]):.4g}, {math.degrees(dm[1]):.4g}] deg)"
    )


def _jsbsim_reference(src) -> ReferenceCondition:
    return ReferenceCondition(src.V_ref, JSBSIM_ALTITUDE, f"Mach {JSBSIM_MACH:g} at 10 000 ft")


_LIMITS_NOTE = (
    "The GNA structure has no alpha*beta terms (Cl_beta(alpha), Cn_beta(alpha) are constants), no "
    "beta, |dm| or dm^2 terms in CD and no power, Mach, flap or gear effects; a quartic in alpha "
    "cannot follow a stall break. See docs/fit_quality.md for the numbers."
)

SPECS: dict[str, FitSpec] = {
    "twin-otter": FitSpec(
        ident="twin-otter",
        name="DHC-6 Twin Otter (NASA icing research aircraft, clean), GNA fit",
        make_source=_twin_otter_source,
        design=_twin_otter_design,
        sections=_twin_otter_sections,
        limits=lambda s: ({"dl": 20.0, "dm": 20.0, "dn": 20.0}, "the source's 20 deg ('guess for now')"),
        reference=lambda s: ReferenceCondition(140.0 * units.KT, 1000.0 * FT, "140 kt at 1000 ft"),
        notes="The source is linear in alpha for body CX (quadratic), CZ and Cm: the GNA fit reproduces it "
        "except where the rotation to stability axes creates terms GNA lacks (alpha^2*dm and alpha^2*qhat "
        "in CL). Power effects and alpha-dot terms are not in the source. " + _LIMITS_NOTE,
    ),
    "gtm": FitSpec(
        ident="gtm",
        name="NASA Generic Transport Model T2 (5.5 % scale), GNA fit",
        make_source=_gtm_source,
        design=_gtm_design,
        sections=_gtm_sections,
        limits=lambda s: (
            {"dl": 20.0, "dm": 30.0, "dn": 30.0},
            "GTM_DesignSim actuator limits (ailerons +-20, elevators -30..+20, rudder +-30 deg)",
        ),
        reference=lambda s: ReferenceCondition(GTM_SPEED, 0.0, "75 kt EAS at sea level (GTM nominal)"),
        notes="Stabilizer 0, flaps 0, spoilers 0, gear up. The database is tabulated to alpha 85 deg with a "
        "stall break near 13 deg that the quartic smooths; the design stops at 16 deg. The database's "
        "nonzero CY, Cl, Cn at zero sideslip and rates (forced-oscillation tables) have no GNA term. " + _LIMITS_NOTE,
    ),
    "f4": FitSpec(
        ident="f4",
        name="F-4 Phantom II (JSBSim F4N), GNA fit",
        make_source=_jsbsim("F4N"),
        design=_jsbsim_design(25.0, 3),
        sections=_jsbsim_sections,
        limits=_jsbsim_limits,
        reference=_jsbsim_reference,
        notes="Clean configuration, gear up, BLC off, Mach 0.6 coefficients; the alpha-dot term Cmadot is "
        "removed (GNA has only qhat; JSBSim's Cm_alphadot = -9 /rad could be folded into Cm_q). "
        "CD contains 0.048 |de| (CDde), not representable: dm is sampled within 0.1 rad of the pitch-trim "
        "schedule on the longitudinal plane. " + _LIMITS_NOTE,
    ),
    "f16-jsbsim": FitSpec(
        ident="f16-jsbsim",
        name="F-16 (JSBSim f16), GNA fit",
        make_source=_jsbsim("f16"),
        design=_jsbsim_design(30.0, 4),
        sections=_jsbsim_sections,
        limits=_jsbsim_limits,
        reference=_jsbsim_reference,
        notes="Clean configuration: gear up, LEF 0, speedbrake 0, flaperon mix 0 (the JSBSim flaperon-mix "
        "property is a defect, see shared notes), Mach 0.6 coefficients. JSBSim's f16 has CL_de = -0.19 "
        "/rad (sign suspect) and is neutrally stable about its CG. Compare with f16c (Grauer-Morelli) in "
        "docs/fit_quality.md. " + _LIMITS_NOTE,
    ),
}


def build(spec: FitSpec, date: str) -> tuple[dict, str]:
    """Fit one aircraft from its source: design, least squares, envelope, trim check, document.

    Parameters
    ----------
    spec : FitSpec
        The aircraft to build (:data:`SPECS`).
    date : str
        ISO date written into the provenance.

    Returns
    -------
    document : dict
        The aircraft document (:func:`gna.fit.document.fitted_document`).
    text : str
        Its TOML text (:func:`gna.fit.document.render`).
    """
    src = spec.make_source()
    design = spec.design(src)
    result = fit_source(src, gna45_structure(), design)
    sections = spec.sections(src)
    limits, limits_source = spec.limits(src)
    envelope = envelope_section(design, limits, limits_source)
    reference = spec.reference(src)
    craft = fitted_aircraft(spec.ident, spec.name, sections, envelope, result.table, src.name)
    trim = trim_comparison(craft, src, reference)
    doc = fitted_document(
        ident=spec.ident,
        name=spec.name,
        source_provenance=src.provenance(),
        sections=sections,
        envelope=envelope,
        design=design,
        result=result,
        reference=reference,
        trim=trim,
        notes=spec.notes,
        date=date,
        command=COMMAND,
    )
    return doc, render(doc, spec.title or spec.name, COMMAND)


def _aircraft_dir() -> Path:
    return _data_dir("aircraft")


def regenerate(
    out_dir: Path | None = None,
    ids: list[str] | None = None,
    check: bool = False,
    today: str | None = None,
    committed_dir: Path | None = None,
    write=None,
) -> dict[str, list[str]]:
    """Rebuild the fitted aircraft files.

    Parameters
    ----------
    out_dir : Path, optional
        Where to write (default: the package's ``gna/data/aircraft``).  The
        committed files there provide the dates kept for unchanged content.
    ids : list of str, optional
        Subset of :data:`SPECS` (default: all).
    check : bool
        Compare with the committed files instead of writing.
    today : str, optional
        Date written into changed files (default: today).
    committed_dir : Path, optional
        Where the committed files are (default: the package's ``gna/data/aircraft``).
    write : callable, optional
        ``write(path, text)`` writing one file (default :meth:`pathlib.Path.write_text`; ``gflat fit
        regenerate`` gives an atomic one).

    Returns
    -------
    dict
        id -> list of differences from the committed file (empty when current).

    Raises
    ------
    GflatError
        An id not in :data:`SPECS`.
    """
    unknown = [i for i in (ids or []) if i not in SPECS]
    if unknown:
        raise GflatError(f"unknown fitted aircraft {', '.join(unknown)}; known: {', '.join(SPECS)}")
    today = today or datetime.date.today().isoformat()
    committed_dir = Path(committed_dir) if committed_dir is not None else _aircraft_dir()
    target_dir = Path(out_dir) if out_dir is not None else committed_dir
    report = {}
    for ident in ids or list(SPECS):
        spec = SPECS[ident]
        committed = committed_dir / f"{ident}.toml"
        old = tomllib.loads(committed.read_text()) if committed.is_file() else None
        date = old["provenance"].get("date", today) if old else today
        doc, text = build(spec, date)
        new = tomllib.loads(text)
        diffs = differences(new, old, ignore=SUMMARY_FIELDS) if old is not None else [f"{committed} does not exist"]
        if diffs and not check:
            doc["provenance"]["date"] = today
            text = render(doc, spec.title or spec.name, COMMAND)
        report[ident] = diffs
        if not check:
            target_dir.mkdir(parents=True, exist_ok=True)
            (write or Path.write_text)(target_dir / f"{ident}.toml", text)
    return report


def main(argv: list[str] | None = None) -> int:
    """``python -m gna.fit.regenerate [IDS...] [--check] [--out DIR] [--docs FILE]``.

    Parameters
    ----------
    argv : list of str, optional
        Command-line arguments (default: ``sys.argv[1:]``).

    Returns
    -------
    int
        Exit status: 0 done, 1 with ``--check`` when a file is not current, 2 on an error (one line on
        stderr).
    """
    p = argparse.ArgumentParser(prog="python -m gna.fit.regenerate", description=__doc__.split("\n\n")[0])
    p.add_argument("ids", nargs="*", help=f"subset of {', '.join(SPECS)}")
    p.add_argument("--check", action="store_true", help="compare with the committed files, write nothing")
    p.add_argument("--out", type=Path, help="output directory (default: gna/data/aircraft)")
    p.add_argument("--docs", type=Path, help="also rewrite (or check) the generated block of docs/fit_quality.md")
    args = p.parse_args(argv)
    try:
        return run(args.ids or None, args.check, args.out, args.docs)
    except GflatError as exc:
        print(f"regenerate: error: {exc}", file=sys.stderr)
        return 2


def run(
    ids: list[str] | None, check: bool, out: Path | None, docs: Path | None, write=None, summary: dict | None = None
) -> int:
    """Regenerate (or check) and print one line per file, and its first differences.

    Parameters
    ----------
    ids : list of str or None
        Subset of :data:`SPECS` (None: all).
    check : bool
        Compare with the committed files instead of writing.
    out : Path or None
        Output directory (None: the package's ``gna/data/aircraft``).
    docs : Path or None
        Also rewrite (or check) the generated block of this ``docs/fit_quality.md``.
    write : callable, optional
        ``write(path, text)`` writing one file (default :meth:`pathlib.Path.write_text`).
    summary : dict, optional
        Filled with what was done: ``files`` (id -> ``state``, ``differences``) and ``docs`` (the page's
        ``path`` and ``state``, or None): ``gflat fit regenerate --json``.

    Returns
    -------
    int
        The command's exit status: 1 with ``check`` when something is not current, else 0.

    Raises
    ------
    GflatError
        An unknown id (from :func:`regenerate`).
    """
    from .report import update_docs

    report = regenerate(out, ids, check, write=write)
    stale = False
    done = {} if summary is None else summary
    done["files"], done["docs"] = {}, None
    for ident, diffs in report.items():
        state = "current" if not diffs else ("NOT current" if check else "updated")
        stale = stale or bool(diffs)
        print(f"{ident}: {state}")
        for d in diffs[:10]:
            print(f"    {d}")
        done["files"][ident] = {"state": state, "differences": list(diffs)}
    if docs is not None:
        current = update_docs(docs, check=check, write=write)
        stale = stale or not current
        state = "current" if current else ("NOT current" if check else "updated")
        print(f"{docs}: {state}")
        done["docs"] = {"path": str(docs), "state": state}
    return 1 if (check and stale) else 0


if __name__ == "__main__":
    sys.exit(main())
