"""``gflat trim AIRCRAFT --speed V --altitude H [--gamma] [--beta] [--turn-rate] [--json]``.

A trim whose Newton iterations do not converge is a computed negative verdict, not an input error: one
line with the cause on stderr (and ``{"converged": false, "message": ...}`` with ``--json``), exit status 1.
"""

from __future__ import annotations

import math
import sys

from gna.aircraft import load_aircraft
from gna.errors import ConvergenceError
from gna.limits import ValidityWarnings
from gna.trim import trim

from ._args import finite_float, positive_float
from ._help import add_command
from ._json import add_json, emit


def register(sub) -> None:
    """Add the ``gflat trim`` parser to the sub-commands ``sub``.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The ``gflat`` parser's sub-commands (:func:`harness.cli.build_parser`).
    """
    p = add_command(
        sub,
        "trim",
        help="steady flight (trim) of an aircraft",
        description="Solve the nine steady-flight equations with V, gamma, turn rate and beta fixed. "
        "Density: ISA at the given altitude. Writes nothing.",
        examples=[
            "gflat trim f16c --speed 152.4 --altitude 3048 --json",
            "gflat trim a7 --speed 120 --altitude 1000 --turn-rate 0.1   # steady coordinated turn",
        ],
    )
    p.add_argument("aircraft", help="aircraft identifier (see 'gflat aircraft') or TOML file")
    p.add_argument("--speed", type=positive_float, required=True, metavar="V_MS", help="airspeed [m/s]")
    p.add_argument("--altitude", type=finite_float, default=0.0, metavar="H_M", help="altitude [m] (default 0)")
    p.add_argument("--gamma", type=finite_float, default=0.0, metavar="RAD", help="flight-path angle [rad]")
    p.add_argument("--beta", type=finite_float, default=0.0, metavar="RAD", help="sideslip angle [rad]")
    p.add_argument("--turn-rate", type=finite_float, default=0.0, metavar="RAD_S", help="track rate chi' [rad/s]")
    p.add_argument(
        "--eta", type=finite_float, default=0.0, help="thrust asymmetry (F1-F2)/F in [-1, 1] (0 for one engine)"
    )
    p.add_argument("--model", choices=("full", "simple"), default="full")
    add_json(p, "trim", help="print the trim as one JSON object (a trim not found: converged false, message)")
    p.set_defaults(func=run)


def run(args) -> int:
    """Run ``gflat trim`` with the parsed command line ``args``.

    Parameters
    ----------
    args : argparse.Namespace
        The options of the command (its parser: :func:`register`).

    Returns
    -------
    int
        The exit status (:data:`harness.cli.EXIT_CODES`).
    """
    a = load_aircraft(args.aircraft)
    try:
        t = trim(
            a,
            {"V": args.speed, "gamma": args.gamma, "chi_dot": args.turn_rate, "beta": args.beta},
            altitude=args.altitude,
            eta=args.eta,
            model=args.model,
        )
    except ConvergenceError as exc:  # the equations were solved for, without a steady state found
        if args.json:
            emit(args, {"aircraft": a.id, "converged": False, "message": str(exc)})
        print(f"gflat trim: no steady flight found: {exc}", file=sys.stderr)
        return 1
    v = t.values  # the validity box of the aerodynamic data said aloud (stderr), once per quantity
    what = f"trim at {v['V']:g} m/s, {t.altitude:g} m"
    ValidityWarnings().check_point(a, V=v["V"], altitude=t.altitude, alpha=v["alpha"], beta=v["beta"], what=what)
    if args.json:
        emit(args, t.to_dict())
        return 0
    print(
        f"{a.id} trim ({t.model} model), altitude {t.altitude:g} m, density {t.density:.5g} kg/m^3: "
        f"converged in {t.iterations} Newton iterations"
    )
    rows = [
        ("V", v["V"], "m/s"),
        ("gamma", v["gamma"], "rad"),
        ("chi'", v["chi_dot"], "rad/s"),
        ("F", v["F"], "N"),
        ("alpha", v["alpha"], "rad"),
        ("beta", v["beta"], "rad"),
        ("mu", v["mu"], "rad"),
        ("p", v["p"], "rad/s"),
        ("q", v["q"], "rad/s"),
        ("r", v["r"], "rad/s"),
        ("dl", v["dl"], "rad"),
        ("dm", v["dm"], "rad"),
        ("dn", v["dn"], "rad"),
    ]
    for name, val, unit in rows:
        extra = f"  ({math.degrees(val):9.4f} deg)" if unit == "rad" else ""
        print(f"  {name:<6} {val:14.8g} {unit:<6}{extra}")
    print(f"  max |residual| of the 9 steady equations: {t.max_residual:.2e}")
    for w in t.warnings:
        print(f"  warning: {w}")
    return 0
