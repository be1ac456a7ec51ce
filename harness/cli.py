"""The ``gflat`` command-line tool.

Each sub-command lives in a module of :mod:`harness.commands` exposing
``register(subparsers)``; the module adds its parser and sets ``func`` to a
callable ``func(args) -> int``.  Errors gflat raises on purpose
(:class:`gna.errors.GflatError`) are printed as one line naming the cause, with
exit status 2; anything else is a bug and keeps its traceback.
"""

from __future__ import annotations

import argparse
import importlib
import sys

from gna.errors import GflatError

#: Modules of harness.commands, in the order their commands are listed.
COMMAND_MODULES: tuple[str, ...] = (
    "aircraft",
    "trim",
    "plan",
    "compare",
    "paper",
    "export_jsbsim",
    "export_script",
    "fit",
    "campaign",
)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="gflat",
        description="Flatness-based motion planning of aircraft (GNA aerodynamics) and its validation "
                    "across dynamics engines.")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for name in COMMAND_MODULES:
        importlib.import_module(f"harness.commands.{name}").register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except GflatError as exc:
        print(f"gflat {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:   # an output that cannot be written (missing or read-only folder, a file in the way)
        print(f"gflat {args.command}: error: cannot write {exc.filename or 'the output'}: {exc.strerror or exc}",
              file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("gflat: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
