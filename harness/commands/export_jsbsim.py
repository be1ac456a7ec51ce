"""``gflat export-jsbsim [AIRCRAFT ...|--all] [--out DIR] [--check]``: write the JSBSim aircraft files."""

from __future__ import annotations

import sys

from gna.aircraft import list_aircraft, load_aircraft
from gna.errors import InputError
from harness.engines.jsbsim import files as jf
from harness.engines.jsbsim.export import aircraft_xml
from harness.outdir import INCOMPLETE, OutputDir

from ._args import out_path


def register(sub) -> None:
    p = sub.add_parser(
        "export-jsbsim",
        help="write the JSBSim aircraft files (aircraft_xml/<id>/<id>.xml)",
        description="Generate JSBSim aircraft files from the gflat aircraft: GNA aerodynamics as "
        "function trees, two thrust forces, declared control properties, flat-earth "
        "planet, English units with exact factors. The output is deterministic.",
    )
    p.add_argument(
        "aircraft", nargs="*", help="aircraft identifiers or TOML files (default with --all: every bundled aircraft)"
    )
    p.add_argument("--all", action="store_true", help="export every bundled aircraft")
    p.add_argument(
        "--out",
        type=out_path,
        default=None,
        metavar="DIR",
        help="output folder (default: the repository's aircraft_xml/)",
    )
    p.add_argument(
        "--check", action="store_true", help="write nothing; exit 1 if a file is missing or differs from a fresh export"
    )
    p.set_defaults(func=run)


def run(args) -> int:
    if args.all and args.aircraft:
        raise InputError("give aircraft identifiers or --all, not both")
    if not args.all and not args.aircraft:
        raise InputError("name the aircraft to export, or use --all")
    crafts = [load_aircraft(n) for n in (list_aircraft() if args.all else args.aircraft)]
    root = args.out if args.out is not None else jf.default_root()
    if args.check:
        stale = jf.stale_files(root, crafts)
        for s in stale:
            print(s, file=sys.stderr)
        if stale:
            print("run 'gflat export-jsbsim --all' to regenerate", file=sys.stderr)
            return 1
        print(f"{len(crafts)} JSBSim file(s) current in {root}")
        return 0
    # checked before any export; never cleaned: other aircraft's files in the folder stay. The repository's
    # aircraft_xml/ is tracked in git: no marker there (nor the in-progress record earlier versions left)
    out = OutputDir(root, clean=False, parents=args.out is None, command="export-jsbsim", marker=args.out is not None)
    if args.out is None:
        (out.root / INCOMPLETE).unlink(missing_ok=True)
    for a in crafts:
        path = out.write_text(a.id, f"{a.id}.xml", text=aircraft_xml(a))  # an id leaving the folder is refused
        print(f"{a.id}: {path}")
    out.finish()
    return 0
