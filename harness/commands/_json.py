"""``--json`` of every command, in one place: one JSON object on stdout, the human text on stderr.

Every leaf command declares the option with :func:`add_json`, naming the JSON Schema of its output
(``harness/commands/schemas/<name>.json``, shipped in the package; the key tables of docs/cli.md are
generated from them by ``scripts/make_schemas.py``).  While a command runs with ``--json``,
:func:`harness.cli.main` sends whatever the command prints to stderr; the command hands its result to
:func:`emit`, which writes it to the real stdout, once.  An error (exit status 2) or an interruption
writes the one-line message on stderr and, on stdout, the object of ``error.json``
(``{"command", "error", "exit_status"}``) unless the command has already emitted its own.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

#: The folder of the output schemas (package data).
SCHEMAS = Path(__file__).resolve().parent / "schemas"

#: The schema of the object written on an error or an interruption, whatever the command.
ERROR_SCHEMA = "error"

HELP = "print one JSON object (the result; its keys: docs/cli.md) on stdout; the text goes to stderr"


def add_json(p: argparse.ArgumentParser, schema: str, help: str = HELP) -> None:
    """Declare ``--json`` on a (leaf) command's parser and name the schema of its output.

    Parameters
    ----------
    p : argparse.ArgumentParser
        The command's parser.
    schema : str
        The schema's name, ``harness/commands/schemas/<schema>.json``.
    help : str
        The option's help.
    """
    p.add_argument("--json", action="store_true", help=help)
    p.set_defaults(json_schema=schema)


def wants_json(args) -> bool:
    """The command runs with ``--json``.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed options.

    Returns
    -------
    bool
    """
    return bool(getattr(args, "json", False))


def emit(args, obj: dict) -> None:
    """Write the command's result ``obj`` as one JSON object on the real stdout (NaN and infinities as null).

    Parameters
    ----------
    args : argparse.Namespace
        The parsed options; ``json_stream`` (set by :func:`harness.cli.main`) is the stdout of the command
        line, else :data:`sys.stdout` is used.
    obj : dict
        The result.
    """
    from ..artefacts import json_safe

    stream = getattr(args, "json_stream", None) or sys.stdout
    stream.write(json.dumps(json_safe(obj), indent=2, allow_nan=False) + "\n")
    stream.flush()
    args.json_emitted = True


def schema(name: str) -> dict:
    """The JSON Schema ``name`` of the outputs (``"plan"``, ``"campaign-run"``, ``"error"``).

    Parameters
    ----------
    name : str
        The schema's name.

    Returns
    -------
    dict
    """
    return json.loads((SCHEMAS / f"{name}.json").read_text(encoding="utf-8"))
