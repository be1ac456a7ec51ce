"""``gflat fit``: fit GNA parameters to a source aerodynamic model, or regenerate the bundled fits.

Sub-commands::

    gflat fit jsbsim MODEL [--mach M] [--altitude H] [--root DIR] [--property VAR=PROP[:FACTOR]]...
                     [design options] [--out FILE]
    gflat fit gtm [design options] --out FILE
    gflat fit linear CSV [design options] --engines N --engine-offset Y --out FILE
    gflat fit compare ID --speed V [--altitude H] [--json]
    gflat fit regenerate [IDS...] [--check] [--out DIR [--replace]] [--docs docs/fit_quality.md]

Design options (angles in degrees): ``--alpha LO HI``, ``--beta MAX``,
``--phat MAX``, ``--qhat MAX``, ``--rhat MAX``, ``--dl LO HI``, ``--dm LO HI``,
``--dn LO HI``, ``--samples N`` (fit points per block), ``--test N``
(held-out points per block), ``--seed S``, ``--dm-band DEG``, ``--box-only``.
See :mod:`gna.fit.design` for the sampling design.

``gflat fit jsbsim NAME`` needs no option: the reference condition is level flight at
C_L = 0.4 at 1000 m (:class:`gna.fit.sources.jsbsim_aero.JSBSimAeroSource`), the surfaces and their ranges
come from the aircraft's flight-control system, the alpha and beta box is the default one clipped to the
aerodynamic tables' data (an explicit ``--alpha``/``--beta`` beyond them is refused unless
``--allow-extrapolation``), and the engines' thrust rating against speed, thrust lag and propulsive moments
are measured from JSBSim's own engines (:func:`gna.fit.sources.jsbsim_engines.measure_engines`).
"""

from __future__ import annotations

import argparse
import datetime
import math
from pathlib import Path

from gna.errors import InputError

from ..progress import stage
from ._args import bounded_count, bounded_float, finite_float, nonnegative_int, positive_float, within
from ._help import add_command
from ._json import add_json, emit
from ._output import add_out, output_file, run_dir

#: Largest angle a sampling flag names [deg] (``--alpha``, ``--beta``, the surfaces): the wind-frame chart ends
#: at |alpha| = 90 deg (:data:`gna.trajectory.DOMAIN`), and no surface deflects further.
MAX_ANGLE_DEG = 90.0
#: Largest non-dimensional rate a sampling flag names (``--phat`` = |p b / 2V|, ``--qhat``, ``--rhat``): at 1
#: the wing tip (the tail) moves as fast as the aircraft; the bundled fits sample 0.1 or less.
MAX_RATE_HAT = 1.0

#: Most sample points per block of a fit (``--samples``, ``--test``): a JSBSim point is one run_ic (about 1 ms),
#: and the design matrix holds 45 regressors per point.
MAX_FIT_POINTS = 200_000
#: Largest |FACTOR| of ``--property VAR=PROP:FACTOR`` (and smallest 1 / it): a property in degrees is 57.3 x the
#: rad, a normalised one a few units; beyond, the surface's sampled range collapses to nothing (1e308: 1e-310 rad).
MAX_PROPERTY_FACTOR = 1e4


def _surface_property(text: str) -> tuple[str, tuple[str, float | None]]:
    """``VAR=PROP[:FACTOR]`` -> ``(var, (prop, factor or None))``."""
    var, sep, rest = text.partition("=")
    var, rest = var.strip(), rest.strip()
    if not sep or var not in ("dl", "dm", "dn") or not rest:
        raise argparse.ArgumentTypeError(f"expected dl|dm|dn=PROPERTY[:FACTOR], got {text!r}")
    prop, colon, factor = rest.partition(":")
    value = None
    if colon:
        try:
            value = float(factor)
        except ValueError:
            raise argparse.ArgumentTypeError(f"FACTOR must be a number in {text!r}") from None
        if not (math.isfinite(value) and value != 0.0):
            raise argparse.ArgumentTypeError(f"FACTOR must be finite and non-zero in {text!r}")
        if not 1.0 / MAX_PROPERTY_FACTOR <= abs(value) <= MAX_PROPERTY_FACTOR:
            raise argparse.ArgumentTypeError(
                f"FACTOR {value:g} in {text!r} is outside its bounds: |FACTOR| from {1.0 / MAX_PROPERTY_FACTOR:g} "
                f"to {MAX_PROPERTY_FACTOR:g} (a property is the surface's deflection in rad times FACTOR)"
            )
    return var, (prop.strip(), value)


def _surface_overrides(items) -> dict[str, tuple[str, float]]:
    """The ``--property`` options as :class:`JSBSimAeroSource` ``surfaces`` (default factors filled in)."""
    from gna.fit.sources.jsbsim_aero import SURFACE_CANDIDATES

    out = {}
    for var, (prop, factor) in items:
        if var in out:
            raise InputError(f"--property given twice for {var}")
        if factor is None:
            factor = SURFACE_CANDIDATES[var][0][1] * (180.0 / math.pi if prop.endswith("-deg") else 1.0)
        out[var] = (prop, factor)
    return out


def register(sub) -> None:
    """Add the ``fit`` command and its sub-commands (``jsbsim``, ``gtm``, ``linear``, ``compare``, ``regenerate``).

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The CLI's sub-command set.
    """
    p = add_command(
        sub,
        "fit",
        help="fit GNA aerodynamic parameters to a source model",
        description="Fit the 45-term GNA structure (or the terms of --structure) by least squares "
        "to samples of a source aerodynamic model and write an aircraft file with "
        "provenance, sampling design, held-out statistics and a level-trim check.",
        examples=[
            "gflat fit jsbsim F4N                   # any JSBSim aircraft: writes f4n.toml here",
            "gflat fit gtm --out gtm-fit.toml",
            "gflat fit compare gtm --speed 40 --json",
        ],
    )
    sp = p.add_subparsers(dest="source", metavar="SOURCE")
    sp.required = True

    j = add_command(
        sp,
        "jsbsim",
        help="any JSBSim aircraft, sampled through JSBSim",
        description="Fit the GNA structure to a JSBSim aircraft's aerodynamics, sampled through JSBSim at a "
        "reference condition (default: level flight at C_L = 0.4 at 1000 m), and write <id>.toml (--out "
        "FILE) with the engines measured from JSBSim's own, the surfaces and their ranges from its "
        "flight-control system, the alpha and beta box clipped to its tables' data, held-out statistics "
        "and a level-trim check against JSBSim. No option is needed.",
        examples=[
            "gflat fit jsbsim F4N                                  # f4n.toml in the current folder",
            "gflat fit jsbsim c172x --samples 2000 --out c172.toml --json",
            "gflat fit jsbsim MODEL --property dm=fcs/elevator-pos-norm:-2.9   # name a surface's property",
        ],
    )
    j.add_argument("model", help="bundled JSBSim aircraft name (e.g. F4N) or path to <name>/<name>.xml")
    j.add_argument("--root", help="JSBSim root directory (default: the jsbsim package's)")
    j.add_argument(
        "--mach",
        type=positive_float,
        help="reference Mach number (default: level flight at C_L = 0.4 at the reference altitude, at least "
        "the lowest Mach of the aerodynamic tables)",
    )
    j.add_argument("--altitude", type=finite_float, metavar="H_M", help="reference altitude [m] (default 1000)")
    j.add_argument(
        "--property",
        action="append",
        type=_surface_property,
        default=[],
        metavar="VAR=PROP[:FACTOR]",
        help="JSBSim property of a surface (dl, dm or dn), written as FACTOR x the variable [rad]; "
        "FACTOR defaults to the detected sign (-1 for dl: JSBSim's positive aileron rolls right, "
        "+1 otherwise), times 180/pi for a '-deg' property; e.g. --property "
        "dl=fcs/effective-aileron-pos, --property dm=fcs/elevator-pos-norm:-2.9 (repeatable)",
    )
    _design_args(
        j,
        alpha=None,
        beta=None,
        phat=0.15,
        qhat=0.03,
        rhat=0.06,
        surfaces=None,
        band=math.degrees(0.1),
        hint=("-5 20 within the aerodynamic tables' data", "15 within the aerodynamic tables' data"),
    )
    _common(j)

    g = add_command(
        sp,
        "gtm",
        help="NASA GTM T2 database (clean configuration)",
        description="Fit the GNA structure to the NASA GTM T2 aerodynamic database (clean configuration) and "
        "write the aircraft file, with held-out statistics and a level-trim check.",
        examples=["gflat fit gtm --out gtm-fit.toml", "gflat fit gtm --samples 1000 --test 200 --out g.toml --json"],
    )
    _design_args(
        g,
        alpha=(-5.0, 16.0),
        beta=25.0,
        phat=0.1,
        qhat=0.0075,
        rhat=0.1,
        surfaces={"dl": (-20.0, 20.0), "dm": (-30.0, 20.0), "dn": (-30.0, 30.0)},
        band=0.0,
    )
    g.add_argument(
        "--speed",
        type=positive_float,
        default=75.0 * 1852.0 / 3600.0,
        metavar="V_MS",
        help="reference speed for the trim check [m/s] (default 75 kt)",
    )
    g.add_argument("--altitude", type=finite_float, default=0.0, metavar="H_M", help="reference altitude [m]")
    _common(g)

    lin = add_command(
        sp,
        "linear",
        help="linear derivative model in the Twin Otter CSV format",
        description="Fit the GNA structure to a linear derivative model (stability and control derivatives, "
        "geometry and mass rows in the Twin Otter CSV format) and write the aircraft file.",
        examples=["gflat fit linear aircraft_dat_clean.csv --speed 72 --engines 2 --engine-offset 2.8 --out to.toml"],
    )
    lin.add_argument("csv", help="group,name,value,unit,note file with derivatives, geometry and mass rows")
    _design_args(
        lin,
        alpha=(-5.0, 12.0),
        beta=15.0,
        phat=0.1,
        qhat=0.03,
        rhat=0.06,
        surfaces={"dl": (-20.0, 20.0), "dm": (-20.0, 20.0), "dn": (-20.0, 20.0)},
        band=0.0,
    )
    lin.add_argument("--engines", type=int, choices=(1, 2), default=1, help="number of engines")
    lin.add_argument(
        "--engine-offset", type=finite_float, default=0.0, metavar="Y_M", help="lateral engine offset [m] (two engines)"
    )
    lin.add_argument(
        "--speed", type=positive_float, required=True, metavar="V_MS", help="reference speed for the trim check [m/s]"
    )
    lin.add_argument("--altitude", type=finite_float, default=0.0, metavar="H_M", help="reference altitude [m]")
    _common(lin)

    c = add_command(
        sp,
        "compare",
        help="level trim of a bundled fitted aircraft and of its source model",
        description="Trim a bundled fitted aircraft and its source model in level flight at the given speed "
        "and altitude and print both (angle of attack, elevator, thrust, ...). Writes nothing.",
        examples=["gflat fit compare gtm --speed 40", "gflat fit compare f4 --speed 200 --altitude 3000 --json"],
    )
    c.add_argument("ident", help="fitted aircraft: twin-otter, gtm, f4, f16-jsbsim")
    c.add_argument("--speed", type=positive_float, required=True, metavar="V_MS", help="airspeed [m/s]")
    c.add_argument("--altitude", type=finite_float, default=0.0, metavar="H_M", help="altitude [m] (default 0)")
    add_json(c, "fit-compare", help="print the comparison as one JSON object")

    r = add_command(
        sp,
        "regenerate",
        help="rebuild every bundled fitted aircraft file",
        description="Fit every bundled fitted aircraft again from its source and rewrite its file in the "
        "source checkout's gna/data/aircraft/ (each file replaced atomically; an installed package is "
        "refused: give --out), or write them as a run folder with --out DIR; --check compares only.",
        examples=["gflat fit regenerate --check", "gflat fit regenerate gtm --out fits --json"],
    )
    r.add_argument("ids", nargs="*", help="subset (default: all)")
    r.add_argument("--check", action="store_true", help="only check that the committed files are current")
    add_out(
        r,
        "output folder, created whole once every file is written (default: the package's aircraft folder, "
        "each file replaced atomically)",
    )
    r.add_argument("--docs", type=Path, help="also rewrite (or check) the generated block of docs/fit_quality.md")
    add_json(r, "fit-regenerate")
    p.set_defaults(func=run)


def _design_args(p, *, alpha, beta, phat, qhat, rhat, surfaces, band, hint: tuple | None = None) -> None:
    d = p.add_argument_group("sampling design (angles in degrees)")
    d.add_argument(
        "--alpha",
        nargs=2,
        type=within(-MAX_ANGLE_DEG, MAX_ANGLE_DEG),
        default=alpha,
        metavar=("LO", "HI"),
        help=f"angle-of-attack range (default {hint[0] if hint else f'{alpha[0]:g} {alpha[1]:g}'})",
    )
    d.add_argument(
        "--beta",
        type=bounded_float(MAX_ANGLE_DEG),
        default=beta,
        metavar="MAX",
        help=f"|sideslip| (default {hint[1] if hint else beta})",
    )
    d.add_argument(
        "--phat", type=bounded_float(MAX_RATE_HAT), default=phat, metavar="MAX", help=f"|p b/2V| (default {phat:g})"
    )
    d.add_argument(
        "--qhat", type=bounded_float(MAX_RATE_HAT), default=qhat, metavar="MAX", help=f"|q c/2V| (default {qhat:g})"
    )
    d.add_argument(
        "--rhat", type=bounded_float(MAX_RATE_HAT), default=rhat, metavar="MAX", help=f"|r b/2V| (default {rhat:g})"
    )
    for k, name in (("dl", "aileron"), ("dm", "elevator"), ("dn", "rudder")):
        default = None if surfaces is None else surfaces[k]
        hint = "the source's range" if default is None else f"{default[0]:g} {default[1]:g}"
        d.add_argument(
            f"--{k}",
            nargs=2,
            type=within(-MAX_ANGLE_DEG, MAX_ANGLE_DEG),
            default=default,
            metavar=("LO", "HI"),
            help=f"{name} range (default {hint})",
        )
    d.add_argument(
        "--samples", type=bounded_count(MAX_FIT_POINTS), default=4000, help="fit points per block (default 4000)"
    )
    d.add_argument(
        "--test", type=bounded_count(MAX_FIT_POINTS), default=1000, help="held-out points per block (default 1000)"
    )
    d.add_argument("--seed", type=nonnegative_int, default=0, help="random seed (default 0)")
    d.add_argument(
        "--dm-band",
        type=within(0.0, 2 * MAX_ANGLE_DEG),
        default=band,
        metavar="DEG",
        help=f"sample dm within this of the pitch-trim schedule on the longitudinal plane, 0 = "
        f"whole range (default {band:.3g})",
    )
    d.add_argument(
        "--box-only", action="store_true", help="fit CD, CL, Cm on the 8-D box too (default: on the longitudinal plane)"
    )
    d.add_argument(
        "--allow-extrapolation",
        action="store_true",
        help="sample beyond the source's data (JSBSim holds table end values there)",
    )


def _common(p) -> None:
    p.add_argument("--id", dest="ident", help="aircraft identifier (default: from the source)")
    p.add_argument("--name", help="aircraft name")
    p.add_argument("--structure", help="aircraft TOML file whose [aero] terms give the structure (default gna45)")
    add_out(p, "output TOML file, written whole (default: <id>.toml in the current folder)", metavar="FILE")
    p.add_argument("--no-trim-check", action="store_true", help="skip the level-trim comparison")
    add_json(p, "fit")


#: The alpha range [deg] and |beta| [deg] of a JSBSim fit without --alpha/--beta, before the tables clip them.
JSBSIM_ALPHA = (-5.0, 20.0)
JSBSIM_BETA = 15.0


def _ranges(args, source_envelope=None) -> dict:
    rad = math.radians
    alpha = args.alpha or JSBSIM_ALPHA
    out = {
        "alpha": (rad(alpha[0]), rad(alpha[1])),
        "beta": (-rad(args.beta or JSBSIM_BETA), rad(args.beta or JSBSIM_BETA)),
        "phat": (-args.phat, args.phat),
        "qhat": (-args.qhat, args.qhat),
        "rhat": (-args.rhat, args.rhat),
    }
    for k in ("dl", "dm", "dn"):
        v = getattr(args, k)
        if v is None:
            from gna.errors import InputError

            if not source_envelope or k not in source_envelope:
                raise InputError(f"the source gives no range for {k}: pass --{k} LO HI")
            out[k] = source_envelope[k]
        else:
            out[k] = (rad(v[0]), rad(v[1]))
    env = source_envelope or {}
    # Unset, the alpha and beta box of a JSBSim fit is the default one within the tables' data.
    if args.source == "jsbsim" and args.alpha is None and "alpha" in env:
        lo, hi = max(out["alpha"][0], env["alpha"][0]), min(out["alpha"][1], env["alpha"][1])
        if not lo < hi:
            raise InputError(
                f"the aerodynamic tables cover alpha {math.degrees(env['alpha'][0]):.4g} .. "
                f"{math.degrees(env['alpha'][1]):.4g} deg only: pass --alpha LO HI"
            )
        out["alpha"] = (lo, hi)
    if args.source == "jsbsim" and args.beta is None and "beta" in env:
        b = min(out["beta"][1], -env["beta"][0], env["beta"][1])
        if not b > 0:
            raise InputError("the aerodynamic tables cover no sideslip but 0: pass --beta MAX")
        out["beta"] = (-b, b)
    return out


def _design(args, ranges):
    from gna.fit.design import standard_design

    return standard_design(
        ranges,
        n_fit=args.samples,
        n_test=args.test,
        seed=args.seed,
        longitudinal_plane=not args.box_only,
        dm_band=math.radians(args.dm_band),
    )


def run(args) -> int:
    """Fit the source named by ``args.source`` and write the aircraft file (or compare, or regenerate).

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.

    Returns
    -------
    int
        0 on success.

    Raises
    ------
    InputError
        A source that cannot be read or represented (one line), an output file that cannot be written.
    """
    if args.source == "regenerate":
        return _regenerate(args)
    if args.source == "compare":
        return _compare(args)
    _check_reference(args)  # the reference condition and the output checked before the source is read
    ident = args.ident or _default_ident(args)
    out = output_file(args, Path(f"{ident}.toml"), "aircraft file")
    progress = getattr(args, "progress", None)
    with stage(progress, "loading the fitting modules"):
        from gna.fit.document import envelope_section, fitted_aircraft, fitted_document, render
        from gna.fit.pipeline import fit_source, gna45_structure, structure_from_file
        from gna.fit.quality import ReferenceCondition, trim_comparison

    if args.source == "jsbsim":
        from gna.fit.sources.jsbsim_aero import JSBSimAeroSource, vehicle_sections

        with stage(progress, f"reading JSBSim's {args.model}"):
            src = JSBSimAeroSource(
                args.model,
                mach=args.mach,
                altitude=args.altitude,
                root=args.root,
                surfaces=_surface_overrides(args.property),
            )
        args.mach, args.altitude = src.mach, src.altitude  # the defaults, written into the regenerating command
        with stage(progress, "measuring the engines"):
            sections = vehicle_sections(src, measure=True)
        ranges = _ranges(args, src.envelope)
        reference = ReferenceCondition(src.V_ref, args.altitude, f"Mach {args.mach:g} at {args.altitude:g} m")
        limits = {k: math.degrees(max(abs(ranges[k][0]), abs(ranges[k][1]))) for k in ("dl", "dm", "dn")}
        limits_source = "the sampled surface ranges (largest magnitude)"
    elif args.source == "gtm":
        from gna.fit.sources.gtm import GTMSource, vehicle_sections

        src = GTMSource(V_ref=args.speed)
        sections = vehicle_sections()
        ranges = _ranges(args)
        reference = ReferenceCondition(args.speed, args.altitude, f"{args.speed:g} m/s at {args.altitude:g} m")
        limits = {"dl": 20.0, "dm": 30.0, "dn": 30.0}
        limits_source = "GTM_DesignSim actuator limits"
    else:
        from gna.fit.sources.linear import LinearDerivativeModel

        ranges = _ranges(args)
        src = LinearDerivativeModel.from_csv(args.csv, {k: ranges[k] for k in ("alpha", "beta", "dl", "dm", "dn")})
        sections = _linear_sections(args)
        reference = ReferenceCondition(args.speed, args.altitude, f"{args.speed:g} m/s at {args.altitude:g} m")
        limits = {k: math.degrees(max(abs(ranges[k][0]), abs(ranges[k][1]))) for k in ("dl", "dm", "dn")}
        limits_source = "the sampled surface ranges (largest magnitude)"

    design = _design(args, ranges)
    structure = structure_from_file(args.structure) if args.structure else gna45_structure()
    with stage(progress, "sampling the source and fitting the coefficients"):
        result = fit_source(src, structure, design, check_envelope=not args.allow_extrapolation)
    envelope = envelope_section(design, limits, limits_source)
    if args.source == "jsbsim" and src.mach_range is not None:
        envelope["mach_min"], envelope["mach_max"] = (float(f"{m:.6g}") for m in src.mach_range)
        envelope["source"] += (
            f"; Mach: the aerodynamic tables' data (JSBSim holds their end values beyond), the coefficients "
            f"sampled at Mach {src.mach:g}"
        )
    name = args.name or f"{ident}, GNA fit to {src.name}"
    craft = fitted_aircraft(ident, name, sections, envelope, result.table, src.name)
    with stage(progress, "trimming the fit and the source"):
        trim = None if args.no_trim_check else trim_comparison(craft, src, reference)
    command = _command_line(args, ranges)
    doc = fitted_document(
        ident=ident,
        name=name,
        source_provenance=src.provenance(),
        sections=sections,
        envelope=envelope,
        design=design,
        result=result,
        reference=reference,
        trim=trim,
        notes="",
        date=datetime.date.today().isoformat(),
        command=command,
    )
    text = render(doc, name, command)
    out.write(text)  # atomic: a reader never sees half a file
    if getattr(args, "json", False):
        emit(
            args,
            {
                "out": str(out.path),
                "aircraft": ident,
                "name": name,
                "source": src.name,
                "statistics": {
                    c: {"r2": s["test"].r2, "rms": s["test"].rms, "max_abs": s["test"].max_abs}
                    for c, s in result.stats.items()
                },
                "trim": trim,
                "regenerate": command,
            },
        )
        return 0
    print(f"wrote {out.path}")
    print("held-out statistics (R2, RMS, max |error|):")
    for c, s in result.stats.items():
        t = s["test"]
        print(f"  {c:<3} R2 {t.r2:8.5f}  RMS {t.rms:10.3g}  max {t.max_abs:10.3g}")
    if trim:
        g, s = trim["gna"], trim["source"]
        print(
            f"level trim at {reference.label}: alpha {g['alpha_deg']:.3f} deg (source {s['alpha_deg']:.3f}), "
            f"dm {g['dm_deg']:.3f} deg (source {s['dm_deg']:.3f}), thrust {g['thrust_N']:.1f} N "
            f"(source {s['thrust_N']:.1f})"
        )
    return 0


def _check_reference(args) -> None:
    """``--speed`` within the physical domain (:data:`gna.trajectory.DOMAIN`) and ``--altitude`` within the ISA
    model's range, before anything is sampled (the fit would otherwise run at that speed and fail at the trim)."""
    from gna.atmosphere import ISA
    from gna.trajectory import DOMAIN

    speed = getattr(args, "speed", None)
    if speed is not None and not DOMAIN.V_min <= speed <= DOMAIN.V_max:
        raise InputError(
            f"--speed {speed:g} m/s is outside the physical domain [{DOMAIN.V_min:g}, {DOMAIN.V_max:g}] m/s "
            f"(gna.trajectory.DOMAIN)"
        )
    altitude = getattr(args, "altitude", None)
    if altitude is not None:
        ISA().check_altitude(altitude, "--altitude")


def _default_ident(args) -> str:
    """The fitted aircraft's identifier without ``--id``: the JSBSim model's name (as
    :func:`gna.fit.sources.jsbsim_aero.resolve` reads it), ``gtm-fit``, the CSV file's stem."""
    if args.source == "jsbsim":
        from gna.fit.sources.jsbsim_aero import check_model_name

        return (Path(args.model).stem if Path(args.model).suffix == ".xml" else check_model_name(args.model)).lower()
    return "gtm-fit" if args.source == "gtm" else Path(args.csv).stem


def _command_line(args, ranges) -> str:
    """The ``gflat fit`` invocation that reproduces this file (paths quoted for a POSIX shell: it runs as written)."""
    from shlex import quote

    parts = ["gflat fit", args.source]
    if args.source == "jsbsim":
        parts += [quote(str(args.model)), f"--mach {args.mach:g}", f"--altitude {args.altitude:g}"]
        if args.root:
            parts.append(f"--root {quote(str(args.root))}")
    elif args.source == "linear":
        parts += [
            quote(str(args.csv)),
            f"--engines {args.engines}",
            f"--engine-offset {args.engine_offset:g}",
            f"--speed {args.speed:g}",
            f"--altitude {args.altitude:g}",
        ]
    else:
        parts += [f"--speed {args.speed:g}", f"--altitude {args.altitude:g}"]
    deg = math.degrees
    parts.append(f"--alpha {deg(ranges['alpha'][0]):g} {deg(ranges['alpha'][1]):g}")
    parts.append(
        f"--beta {deg(ranges['beta'][1]):g} --phat {ranges['phat'][1]:g} --qhat {ranges['qhat'][1]:g} "
        f"--rhat {ranges['rhat'][1]:g}"
    )
    for k in ("dl", "dm", "dn"):
        parts.append(f"--{k} {deg(ranges[k][0]):.10g} {deg(ranges[k][1]):.10g}")
    parts.append(f"--samples {args.samples} --test {args.test} --seed {args.seed} --dm-band {args.dm_band:.10g}")
    for flag in ("box_only", "allow_extrapolation", "no_trim_check"):
        if getattr(args, flag):
            parts.append("--" + flag.replace("_", "-"))
    if args.structure:
        parts.append(f"--structure {quote(str(args.structure))}")
    return " ".join(parts)


def _linear_sections(args) -> dict:
    from gna.fit.sources.linear import vehicle_values

    v = vehicle_values(args.csv)
    need = ("Weight", "I_xx", "I_yy", "I_zz", "Sw", "bw", "cbar")
    missing = [k for k in need if k not in v]
    if missing:
        raise InputError(f"{args.csv}: missing vehicle row(s) {', '.join(missing)}")
    if args.engines == 1 and args.engine_offset != 0:
        raise InputError(f"one engine sits on the symmetry plane; got --engine-offset {args.engine_offset}")
    src = f"{args.csv} (units as written there: lb, slug ft^2, ft)"
    return {
        "mass": {
            "weight_lb": v["Weight"][0],
            "Ixx_slugft2": v["I_xx"][0],
            "Iyy_slugft2": v["I_yy"][0],
            "Izz_slugft2": v["I_zz"][0],
            "Ixz_slugft2": v.get("I_xz", (0.0, ""))[0],
            "source": src,
        },
        "geometry": {"S_ft2": v["Sw"][0], "b_ft": v["bw"][0], "cbar_ft": v["cbar"][0], "source": src},
        "engines": {"count": args.engines, "y_p_m": abs(args.engine_offset), "source": "command line"},
    }


def _compare(args) -> int:
    from gna.aircraft import load_aircraft
    from gna.fit.quality import ReferenceCondition, trim_comparison
    from gna.fit.regenerate import SPECS

    if args.ident not in SPECS:
        raise InputError(f"no source model known for {args.ident!r}; fitted aircraft: {', '.join(SPECS)}")
    src = SPECS[args.ident].make_source()
    ref = ReferenceCondition(args.speed, args.altitude, f"{args.speed:g} m/s at {args.altitude:g} m")
    res = trim_comparison(load_aircraft(args.ident), src, ref)
    if args.json:
        emit(
            args,
            {"aircraft": args.ident, "source_model": src.name, "V_ms": args.speed, "altitude_m": args.altitude, **res},
        )
        return 0
    print(f"{args.ident}: level trim at {ref.label}, GNA fit vs source ({src.name})")
    for k, unit in (
        ("alpha_deg", "deg"),
        ("dm_deg", "deg"),
        ("thrust_N", "N"),
        ("dl_deg", "deg"),
        ("dn_deg", "deg"),
        ("mu_deg", "deg"),
    ):
        print(f"  {k[:-4] if unit == 'deg' else k[:-2]:<7} {res['gna'][k]:12.6g} {res['source'][k]:12.6g} {unit}")
    return 0


def _source_checkout() -> bool:
    """gna is a source checkout's (its repository's ``pyproject.toml`` beside it), not an installed package."""
    import gna

    return (Path(gna.__file__).resolve().parents[1] / "pyproject.toml").is_file()


def _regenerate(args) -> int:
    from gna.fit.regenerate import run as regenerate_run

    from ..rundir import write_file

    done: dict = {}
    if args.out is None and not args.check and not _source_checkout():
        raise InputError(
            "gflat fit regenerate rewrites the bundled aircraft files of a source checkout; this gflat is an "
            "installed package: give --out DIR"
        )
    if args.out is None or args.check:  # the package's own files (and docs), each replaced atomically
        where = None if args.check else args.out
        status = regenerate_run(args.ids or None, args.check, where, args.docs, write_file, summary=done)
        out = args.out
    else:
        with run_dir(args, command="fit regenerate") as folder:  # a folder the user names: a run, written whole
            status = regenerate_run(args.ids or None, False, folder.root, args.docs, write_file, summary=done)
            folder.commit()
        out = folder.out
    if getattr(args, "json", False):
        import gna

        emit(
            args,
            {
                "out": str(out if out is not None else Path(gna.__file__).resolve().parent / "data" / "aircraft"),
                "check": bool(args.check),
                "current": status == 0 if args.check else None,
                **done,
            },
        )
    return status
