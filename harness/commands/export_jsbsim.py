"""``gflat export-jsbsim [AIRCRAFT ...|--all] [--out DIR [--replace]] [--check] [--json]``: write the JSBSim
aircraft files.

With ``--out`` the files are a run, written whole (:class:`harness.rundir.RunDir`); without it
``aircraft_xml/`` under the current folder (:data:`DEFAULT_FOLDER`; in a source checkout, run from its root,
the repository's tracked folder) is updated in place, each file replaced atomically
(:func:`harness.rundir.write_file`), no manifest.  Never a folder of the installed package.
"""

from __future__ import annotations

import shlex
import sys
from pathlib import Path

from gna.aircraft import list_aircraft, load_aircraft
from gna.errors import InputError
from harness.engines.jsbsim import files as jf
from harness.engines.jsbsim.export import aircraft_xml
from harness.rundir import write_file

from ._help import add_command
from ._json import add_json, emit
from ._output import add_out, run_dir

#: Where ``gflat export-jsbsim`` writes without ``--out``: under the current folder.
DEFAULT_FOLDER = Path("aircraft_xml")


def register(sub) -> None:
    """Add the ``gflat export-jsbsim`` parser to the sub-commands ``sub``.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The ``gflat`` parser's sub-commands (:func:`harness.cli.build_parser`).
    """
    p = add_command(
        sub,
        "export-jsbsim",
        help="write the JSBSim aircraft files (aircraft_xml/<id>/<id>.xml)",
        description="Generate JSBSim aircraft files from the gflat aircraft: GNA aerodynamics as "
        "function trees, two thrust forces, declared control properties, flat-earth "
        "planet, English units with exact factors. The output is deterministic. Without --out the files "
        "go to aircraft_xml/ under the current folder (in a source checkout, from its root: the "
        "repository's tracked folder), updated file by file.",
        examples=[
            "gflat export-jsbsim --all                 # aircraft_xml/<id>/<id>.xml of every bundled aircraft",
            "gflat export-jsbsim f16c --out xml        # a run folder of its own",
            "gflat export-jsbsim --all --check --json  # exit 1 if a file is missing or stale",
        ],
    )
    p.add_argument(
        "aircraft", nargs="*", help="aircraft identifiers or TOML files (default with --all: every bundled aircraft)"
    )
    p.add_argument("--all", action="store_true", help="export every bundled aircraft")
    add_out(
        p,
        "output folder, created whole once every file is written (default: aircraft_xml/ under the current "
        "folder, updated file by file)",
    )
    p.add_argument(
        "--check", action="store_true", help="write nothing; exit 1 if a file is missing or differs from a fresh export"
    )
    add_json(p, "export-jsbsim")
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
        raise InputError("--replace replaces an --out folder; the default aircraft_xml/ is updated file by file")
    crafts = [load_aircraft(n) for n in (list_aircraft() if args.all else args.aircraft)]
    root = args.out if args.out is not None else DEFAULT_FOLDER.absolute()
    json_mode = getattr(args, "json", False)
    if args.check:
        stale = jf.stale_files(root, crafts)
        for s in stale:
            print(s, file=sys.stderr)
        if stale:
            again = ["gflat", "export-jsbsim", *(["--all"] if args.all else args.aircraft)]
            again += [] if args.out is None else ["--out", str(args.out), "--replace"]
            print(f"run {shlex.join(again)} to regenerate", file=sys.stderr)
        else:
            print(f"{len(crafts)} JSBSim file(s) current in {root}")
        if json_mode:
            _emit(args, root, crafts, check=True, stale=stale, files=[])
        return 1 if stale else 0
    if args.out is None:  # the folder under the current one: other aircraft's files stay, each file replaced whole
        files = []
        for a in crafts:
            path = jf.xml_path(root, a.id)  # an id leaving the folder is refused
            path.parent.mkdir(parents=True, exist_ok=True)
            files.append(write_file(path, aircraft_xml(a)))
            print(f"{a.id}: {files[-1]}")
    else:
        with run_dir(args, command="export-jsbsim") as out:  # checked before any export
            for a in crafts:
                out.write_text(a.id, f"{a.id}.xml", text=aircraft_xml(a))  # an id leaving the folder is refused
            out.commit()
        files = [out.out / a.id / f"{a.id}.xml" for a in crafts]
        for a, f in zip(crafts, files):
            print(f"{a.id}: {f}")
    if json_mode:
        _emit(args, root, crafts, check=False, stale=[], files=files)
    return 0


def _emit(args, root, crafts, *, check: bool, stale: list, files: list) -> None:
    """The command's ``--json`` object (schema ``export-jsbsim``): the folder, the aircraft, their files."""
    emit(
        args,
        {
            "out": str(Path(root).absolute()),
            "check": check,
            "aircraft": [a.id for a in crafts],
            "current": not stale,
            "stale": stale,
            "files": [str(f) for f in files],
        },
    )
