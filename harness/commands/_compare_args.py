"""Comparison flags shared by ``gflat compare`` and ``gflat paper``.

The flags override the scenario's ``[compare]`` table, which overrides the
defaults (:mod:`harness.validation.tolerances`).
"""

from __future__ import annotations

import argparse

from gna.errors import InputError

from ..validation.tolerances import QUANTITIES
from ..validation.work import MAX_STEPS, SAMPLE_COST, check_steps, flight_steps  # noqa: F401 (re-exported)
from ._args import add_tracking, cost_bound, finite_float, positive_float

#: Unit of each tolerance quantity, for the help texts.
_UNITS = {"position": "m", "velocity": "m/s", "angle": "rad", "rate": "rad/s"}


def nonnegative_float(text: str) -> float:
    v = finite_float(text)
    if v < 0:
        raise argparse.ArgumentTypeError(f"must be >= 0, got {text}")
    return v


def window(text: str) -> tuple[str, float | None]:
    name, sep, dur = text.rpartition("=")
    if not sep or not name.strip():
        raise argparse.ArgumentTypeError(f"a window is NAME=SECONDS or NAME=all, got {text!r}")
    if dur.strip() == "all":
        return name.strip(), None
    return name.strip(), positive_float(dur)


def add_compare_arguments(p: argparse.ArgumentParser) -> None:
    add_tracking(p)
    g = p.add_argument_group(
        "comparison settings",
        "override the scenario's [compare] table, which overrides the "
        "defaults; a variable passes when max|diff| <= tol + rtol * "
        "max|reference| over the window",
    )
    for q in QUANTITIES:
        g.add_argument(
            f"--tol-{q}",
            type=nonnegative_float,
            default=None,
            metavar=_UNITS[q].upper().replace("/", "_"),
            help=f"absolute tolerance of the {q} [{_UNITS[q]}] ({', '.join(QUANTITIES[q])})",
        )
        g.add_argument(
            f"--rtol-{q}",
            type=nonnegative_float,
            default=None,
            metavar="FRACTION",
            help=f"relative tolerance of the {q} (fraction of max |reference|)",
        )
    g.add_argument(
        "--window",
        type=window,
        action="append",
        default=None,
        metavar="NAME=SECONDS",
        help="comparison window from t0 (repeat; NAME=all for the whole span); replaces the windows",
    )
    g.add_argument(
        "--dt-out",
        type=positive_float,
        default=None,
        metavar="S",
        help="output grid of every engine and of the plan comparison [s] (default 0.05)",
    )
    g.add_argument(
        "--jsbsim-dt",
        type=positive_float,
        default=None,
        metavar="S",
        help="JSBSim's own step [s], independent of --dt-out (default 1/480)",
    )
    g.add_argument(
        "--self-convergence",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="also fly JSBSim at half its step and report that difference next to the cross-engine one",
    )
    g.add_argument(
        "--max-steps",
        type=cost_bound,
        default=MAX_STEPS,
        metavar="N",
        help=f"bound on the engine steps plus {SAMPLE_COST} x the output samples of all the flights over the "
        f"manoeuvres' spans, checked before any work (default {MAX_STEPS:.0e}, about 3.5 GB; "
        f"'inf' for none)",
    )
    p.add_argument(
        "--csv", action="store_true", help="write every trajectory and plan iterate as CSV too (Parquet always)"
    )


def compare_overrides(args) -> dict:
    """The ValidationCase keywords the flags set (unset flags are left out)."""
    tol = {q: getattr(args, f"tol_{q}") for q in QUANTITIES if getattr(args, f"tol_{q}") is not None}
    rtol = {q: getattr(args, f"rtol_{q}") for q in QUANTITIES if getattr(args, f"rtol_{q}") is not None}
    names = [name for name, _ in args.window or ()]
    repeated = sorted({n for n in names if names.count(n) > 1})
    if repeated:
        raise InputError(
            f"--window: each name once, {', '.join(map(repr, repeated))} given "
            f"{max(names.count(n) for n in repeated)} times"
        )
    kw = {
        "tolerances": tol or None,
        "rtol": rtol or None,
        "dt_out": args.dt_out,
        "jsbsim_dt": args.jsbsim_dt,
        "self_convergence": args.self_convergence,
        "windows": dict(args.window) if args.window else None,
        "tracking": getattr(args, "tracking", None),
    }
    return {k: v for k, v in kw.items() if v is not None}
