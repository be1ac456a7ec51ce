"""``gflat aircraft [NAME] [--json]``: list the aircraft, or show one, with provenance."""

from __future__ import annotations

import math

from gna.aircraft import list_aircraft, load_aircraft

from ._help import add_command
from ._json import add_json, emit


def register(sub) -> None:
    """Add the ``gflat aircraft`` parser to the sub-commands ``sub``.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The ``gflat`` parser's sub-commands (:func:`harness.cli.build_parser`).
    """
    p = add_command(
        sub,
        "aircraft",
        help="list the aircraft and their provenance",
        description="List the bundled aircraft with their provenance, or show one in detail. Writes nothing.",
        examples=["gflat aircraft", "gflat aircraft f16c --json"],
    )
    p.add_argument("name", nargs="?", help="aircraft identifier or path to an aircraft TOML file")
    add_json(p, "aircraft", help='print one JSON object: the aircraft (with NAME), or {"aircraft": [...]}')
    p.set_defaults(func=run)


def _describe(a) -> dict:
    return {
        "id": a.id,
        "name": a.name,
        "mass_kg": a.mass.mass,
        "Ixx_kgm2": a.mass.Ixx,
        "Iyy_kgm2": a.mass.Iyy,
        "Izz_kgm2": a.mass.Izz,
        "Ixz_kgm2": a.mass.Ixz,
        "S_m2": a.geometry.S,
        "b_m": a.geometry.b,
        "cbar_m": a.geometry.cbar,
        "x_cg_m": a.geometry.x_cg,
        "x_ref_m": a.geometry.x_ref,
        "engines": {
            "count": a.propulsion.count,
            "y_p_m": a.propulsion.y_p,
            "epsilon_rad": a.propulsion.epsilon,
            "max_thrust_N": a.propulsion.max_thrust,
        },
        "envelope_deg": {
            "alpha_min": math.degrees(a.envelope.alpha_min),
            "alpha_max": math.degrees(a.envelope.alpha_max),
            "beta_max": math.degrees(a.envelope.beta_max),
        },
        "aero": {"structure": a.aero.structure, "terms": len(a.aero)},
        "provenance": dict(a.provenance),
        "sources": {
            "mass": a.mass.source,
            "geometry": a.geometry.source,
            "engines": a.propulsion.source,
            "envelope": a.envelope.source,
        },
    }


def run(args) -> int:
    """Run ``gflat aircraft`` with the parsed command line ``args``.

    Parameters
    ----------
    args : argparse.Namespace
        The options of the command (its parser: :func:`register`).

    Returns
    -------
    int
        The exit status (:data:`harness.cli.EXIT_CODES`).
    """
    if args.name:
        a = load_aircraft(args.name)
        d = _describe(a)
        if args.json:
            emit(args, d)
            return 0
        print(a.summary())
        for k, v in d["provenance"].items():
            print(f"  {k}: {v}")
        for k, v in d["sources"].items():
            if v:
                print(f"  {k} source: {v}")
        return 0
    crafts = [load_aircraft(n) for n in list_aircraft()]
    if args.json:
        emit(args, {"aircraft": [_describe(a) for a in crafts]})
        return 0
    for a in crafts:
        print(f"{a.id:<12} {a.name}")
        print(f"{'':<12} source: {a.provenance.get('source', 'not stated')}")
        print(
            f"{'':<12} transformation: {a.provenance.get('transformation', 'not stated')}; "
            f"date: {a.provenance.get('date', 'not stated')}"
        )
    return 0
