"""A small deterministic XML writer for the JSBSim aircraft files (:mod:`.export`)."""

from __future__ import annotations

import math

from gna.errors import InputError


def number_text(v: float) -> str:
    """Shortest round-trip text of a float (deterministic, exact).

    Parameters
    ----------
    v : float
        A finite number.

    Returns
    -------
    str

    Raises
    ------
    InputError
        For a non-finite number.
    """
    v = float(v)
    if not math.isfinite(v):
        raise InputError(f"cannot write a non-finite number ({v}) to a JSBSim file")
    if v == 0.0:
        return "0"
    if v == int(v) and abs(v) < 1e15:
        return str(int(v))
    return repr(v)


def comment_text(text: str) -> str:
    """Text safe inside an XML comment.

    Parameters
    ----------
    text : str
        Any text.

    Returns
    -------
    str
        One line without ``--``.
    """
    return " ".join(str(text).replace("--", "- -").split())


class XMLWriter:
    """An indented XML text built line by line (deterministic)."""

    def __init__(self):
        self.lines: list[str] = []
        self.level = 0

    def line(self, text: str = "") -> None:
        """Append one line at the current indentation (two spaces a level).

        Parameters
        ----------
        text : str
            The line's text; empty gives an empty line (no indentation).
        """
        self.lines.append(("  " * self.level + text) if text else "")

    def open(self, tag: str, attrs: str = "") -> None:
        """Append an opening tag and indent what follows one level more.

        Parameters
        ----------
        tag : str
            Element name.
        attrs : str
            Attribute text written as is, e.g. ``'unit="IN"'``; empty for none.
        """
        self.line(f"<{tag}{(' ' + attrs) if attrs else ''}>")
        self.level += 1

    def close(self, tag: str) -> None:
        """Indent one level less and append a closing tag.

        Parameters
        ----------
        tag : str
            Element name (of the matching :meth:`open`).
        """
        self.level -= 1
        self.line(f"</{tag}>")

    def leaf(self, tag: str, value, attrs: str = "") -> None:
        """Append an element with its value on one line: ``<tag attrs> value </tag>``.

        Parameters
        ----------
        tag : str
            Element name.
        value : str or float
            Text written as is, or a number written by :func:`number_text`.
        attrs : str
            Attribute text written as is; empty for none.

        Raises
        ------
        InputError
            A non-finite number (from :func:`number_text`).
        """
        text = value if isinstance(value, str) else number_text(value)
        self.line(f"<{tag}{(' ' + attrs) if attrs else ''}> {text} </{tag}>")

    def location(self, name: str | None, x_in: float, y_in: float, z_in: float) -> None:
        """Append a JSBSim ``<location unit="IN">`` element (structural frame, inches).

        Parameters
        ----------
        name : str or None
            The ``name`` attribute (e.g. ``"AERORP"``), or None for none.
        x_in, y_in, z_in : float
            Coordinates in JSBSim's structural frame [in]: x aft, y right, z up.

        Raises
        ------
        InputError
            A non-finite coordinate (from :func:`number_text`).
        """
        attrs = (f'name="{name}" ' if name else "") + 'unit="IN"'
        self.open("location", attrs)
        self.leaf("x", x_in)
        self.leaf("y", y_in)
        self.leaf("z", z_in)
        self.close("location")

    def text(self) -> str:
        """The document so far.

        Returns
        -------
        str
            The lines joined by newlines, with a final newline.
        """
        return "\n".join(self.lines) + "\n"
