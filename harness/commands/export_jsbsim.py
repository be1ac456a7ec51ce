"""``gflat export-jsbsim [AIRCRAFT ...|--all] [--out DIR [--replace]] [--check]``: write the JSBSim aircraft files.

With ``--out`` the files are a run, written whole (:class:`harness.rundir.RunDir`); without it the
repository's tracked ``aircraft_xml/`` is updated in place, each file replaced atomically
(:func:`harness.rundir.write_file`), no manifest.
"""

from __future__ import annotations

import sys

from gna.aircraft import list_aircraft, load_aircraft
from gna.errors import InputError
from harness.engines.jsbsim import files as jf
from harness.engines.jsbsim.export import aircraft_xml
from harness.rundir import write_file

from ._output import add_out, run_dir


def register(sub) -> None:
    """Add the ``gflat export-jsbsim`` parser to the sub-commands ``sub``.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The ``gflat`` parser's sub-commands (:func:`harness.cli.build_parser`).
    """
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
    add_out(
        p,
        "output folder, created whole once every file is written (default: the repository's aircraft_xml/, "
        "updated in place)",
    )
    p.add_argument(
        "--check", action="store_true", help="write nothing; exit 1 if a file is missing or differs from a fresh export"
    )
    p.set_defaults(func=run)


def run(args) -> int:
    """Run ``gflat export-jsbsim`` with the parsed command line ``args``.

    Parameters
    ----------
    args : argparse.Namespace
        The options of the command (its parser: :func:`register`).

    Returns
    -------
    int
        The exit status (:data:`harness.cli.EXIT_CODES`).

    Raises
    ------
    gna.errors.InputError
        A bad option value, file or output folder (one line; exit status 2).
    """
    if args.all and args.aircraft:
        raise InputError("give aircraft identifiers or --all, not both")
    if not args.all and not args.aircraft:
        raise InputError("name the aircraft to export, or use --all")
    if getattr(args, "replace", False) and args.out is None:
        raise InputError("--replace replaces an --out folder; the repository's aircraft_xml/ is updated file by file")
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
    if args.out is None:  # the repository's tracked folder: other aircraft's files stay, each file replaced whole
        for a in crafts:
            path = jf.xml_path(root, a.id)  # an id leaving the folder is refused
            path.parent.mkdir(parents=True, exist_ok=True)
            print(f"{a.id}: {write_file(path, aircraft_xml(a))}")
        return 0
    with run_dir(args, command="export-jsbsim") as out:  # checked before any export
        for a in crafts:
            out.write_text(a.id, f"{a.id}.xml", text=aircraft_xml(a))  # an id leaving the folder is refused
        out.commit()
    for a in crafts:
        print(f"{a.id}: {out.out / a.id / f'{a.id}.xml'}")
    return 0
