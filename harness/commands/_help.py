"""The parser of every command, in one place: a description in plain text and worked examples.

:func:`add_command` adds a (sub-)command's parser with its one-line help, its description (reST markup such
as double backticks and roles rendered as plain text: a description may come from a module docstring) and
an ``examples:`` epilog printed as written; ``tests/harness/test_json_output.py`` checks that every command
has both.
"""

from __future__ import annotations

import argparse
import re

_ROLE = re.compile(r":[a-z]+:`~?([^`<]*?)(?:\s*<[^>]*>)?`")
_LITERAL = re.compile(r"``([^`]*)``")


def plain(text: str) -> str:
    """``text`` with its reST markup as plain text: ````x```` -> ``x``, ``:func:`~a.b``` -> ``b``.

    Parameters
    ----------
    text : str
        reST text (a docstring paragraph).

    Returns
    -------
    str
    """

    def role(m: re.Match) -> str:
        name = m.group(1).strip()
        return name.rsplit(".", 1)[-1] if m.group(0).split("`")[1].startswith("~") else name

    return _LITERAL.sub(r"\1", _ROLE.sub(role, " ".join(text.split())))


class HelpFormatter(argparse.HelpFormatter):
    """argparse's formatter, but the epilog (the examples) printed line by line as written."""

    def _fill_text(self, text, width, indent):
        if text.startswith("examples:"):
            return "".join(indent + line for line in text.splitlines(keepends=True))
        return super()._fill_text(text, width, indent)


def add_command(sub, name: str, *, help: str, description: str, examples: list[str], **kw) -> argparse.ArgumentParser:
    """Add a command's parser to the sub-commands ``sub``.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The parent's sub-commands.
    name : str
        The command's word.
    help : str
        Its line in the parent's ``--help``.
    description : str
        What it does (reST markup rendered plain).
    examples : list of str
        Command lines (a ``#`` comment after one explains it), printed under ``examples:``.
    **kw
        More :meth:`argparse._SubParsersAction.add_parser` keywords.

    Returns
    -------
    argparse.ArgumentParser
    """
    return sub.add_parser(
        name,
        help=help,
        description=plain(description),
        epilog="examples:\n" + "\n".join(f"  {e}" for e in examples),
        formatter_class=HelpFormatter,
        **kw,
    )
