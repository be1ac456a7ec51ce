"""The ``--out`` of every command, in one place: a run's folder or one file, refused when it exists unless
``--replace``.

A command that writes a run (``plan``, ``compare``, ``paper``, ``export-jsbsim --out``,
``export-jsbsim-script``, ``fit regenerate --out``) declares its options with :func:`add_out` and opens
:func:`run_dir` before any work (:class:`harness.rundir.RunDir`: staged, renamed into place whole); a
command that writes one file (``fit jsbsim|gtm|linear``) declares them with :func:`add_out` too
(``metavar="FILE"``) and opens :func:`output_file` (:class:`harness.rundir.OutputFile`: written beside it,
renamed into place).  Without ``--out`` the tool's own default folders under ``reports/out/`` are replaced
implicitly (:func:`default_out`; under the current folder); a default file the user's folder would hold (``fit``'s ``<id>.toml``) is
not.
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

from gna.errors import InputError, expand_home

from ..rundir import OutputFile, RunDir

#: Where the command line writes a run when no ``--out`` is given: relative, so under the current folder (never
#: in the installed package; ``tests/harness/test_json_output.py`` runs the commands from a folder of their own).
DEFAULT_ROOT = Path("reports") / "out"


def _expanded(text: str) -> Path:
    """``text`` with ``~`` expanded; a home folder that cannot be found is an option error."""
    try:
        return expand_home(text)
    except InputError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def out_path(text: str) -> Path:
    """An ``--out`` folder (``~`` expanded): refused when empty (an empty name would silently mean the current
    folder or the default) or ``-`` (no standard output)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("an empty path; give a folder's name (an empty one is no folder)")
    if text == "-":
        raise argparse.ArgumentTypeError("'-': gflat writes a run to a folder, not to the standard output")
    return _expanded(text)


def out_file(text: str) -> Path:
    """An ``--out`` file (``~`` expanded): refused when empty (an empty name would silently mean the default),
    ``-`` (no standard output) or ending in ``/`` (a folder's name: the file would take it)."""
    if not text.strip():
        raise argparse.ArgumentTypeError(
            "an empty path; give the aircraft file's name, or leave --out out for the default <id>.toml"
        )
    if text == "-":
        raise argparse.ArgumentTypeError("'-': gflat writes the file to a path, not to the standard output")
    if text.endswith(("/", os.sep)):
        raise argparse.ArgumentTypeError(
            f"{text!r} ends with a '/', a folder's name; give the file's name (e.g. {text}<id>.toml)"
        )
    return _expanded(text)


def add_out(p: argparse.ArgumentParser, help: str, *, metavar: str = "DIR", required: bool = False) -> None:
    """Declare ``--out`` (a folder, or with ``metavar="FILE"`` a file) and ``--replace``.

    Parameters
    ----------
    p : argparse.ArgumentParser
        The command's parser.
    help : str
        What ``--out`` is, and its default.
    metavar : {"DIR", "FILE"}
        A run's folder or one file.
    required : bool
        ``--out`` must be given.
    """
    file = metavar == "FILE"
    p.add_argument(
        "--out", type=out_file if file else out_path, default=None, required=required, metavar=metavar, help=help
    )
    what = "file" if file else "folder (a gflat run's only)"
    p.add_argument(
        "--replace",
        action="store_true",
        help=f"replace the existing --out {what} once the new one is complete; without it an existing one is refused",
    )


def default_out(*parts: str, command: str) -> RunDir:
    """``reports/out/<parts>`` as the run folder of ``command``: parents made, an earlier gflat run there replaced
    (the tool owns its default folders; anything else there is refused), a name that leaves it refused.

    Parameters
    ----------
    *parts : str
        The folder under :data:`DEFAULT_ROOT` (``<scenario>``, ``plan``).
    command : str
        The command writing, recorded in the manifest.

    Returns
    -------
    RunDir

    Raises
    ------
    InputError
        The folder would leave :data:`DEFAULT_ROOT`, or :class:`~harness.rundir.RunDir` refuses it.
    """
    base = DEFAULT_ROOT.resolve()
    target = base.joinpath(*parts).resolve()
    if not target.is_relative_to(base) or target == base:
        raise InputError(f"output folder {'/'.join(parts)!r} leaves {base}: rename the scenario or give --out")
    return RunDir(target, command=command, replace=True, parents=True)


def run_dir(args, *default: str, command: str) -> RunDir:
    """The run folder of a command: ``--out`` (an existing one replaced only with ``--replace``), else
    :func:`default_out` of ``default``.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed options (``out``, ``replace``).
    *default : str
        The default folder's parts under :data:`DEFAULT_ROOT`; none: ``--out`` is required.
    command : str
        The command writing, recorded in the manifest.

    Returns
    -------
    RunDir

    Raises
    ------
    InputError
        As :class:`~harness.rundir.RunDir`; ``--replace`` without ``--out`` where the default is not a run.
    """
    if args.out is None:
        if not default:
            raise InputError("--out DIR is needed here")
        return default_out(*default, command=command)
    return RunDir(args.out, command=command, replace=getattr(args, "replace", False))


def output_file(args, default: Path, what: str = "file") -> OutputFile:
    """The one output file of a command: ``--out FILE``, else ``default``, refused when it exists unless
    ``--replace`` (:class:`~harness.rundir.OutputFile`).

    Parameters
    ----------
    args : argparse.Namespace
        The parsed options (``out``, ``replace``).
    default : Path
        The file without ``--out``.
    what : str
        What the file is, for the message of a folder given instead (``"aircraft file"``).

    Returns
    -------
    OutputFile

    Raises
    ------
    InputError
        As :class:`~harness.rundir.OutputFile`, or the path is a folder.
    """
    out = args.out if args.out is not None else default
    if out.is_dir():
        raise InputError(f"--out {out}: a folder; give the {what}'s name (e.g. {out / default.name})")
    return OutputFile(out, replace=getattr(args, "replace", False))
