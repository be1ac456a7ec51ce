"""Exceptions raised by gflat.

Every error names its cause and, where it makes sense, the time and the value
involved, so that the command-line tool can print one clear line instead of a
traceback.
"""

from __future__ import annotations

import contextlib
import os
from pathlib import Path


def describe(exc: BaseException) -> str:
    """The text naming an exception's cause, never empty (messages end in a cause, not an empty clause).

    The exception's own text (an OS error's ``strerror``), else that of the exception it was raised from
    (its ``__cause__`` or ``__context__``), else its type's name.

    Parameters
    ----------
    exc : BaseException

    Returns
    -------
    str
    """
    seen, e = set(), exc
    while e is not None and id(e) not in seen:
        seen.add(id(e))
        text = (e.strerror if isinstance(e, OSError) and e.strerror else str(e)).strip()
        if text:
            return text if e is exc else f"{type(exc).__name__} ({type(e).__name__}: {text})"
        e = e.__cause__ or e.__context__
    return f"{type(exc).__name__} (without a message)"


class GflatError(Exception):
    """Base class of every error gflat raises on purpose (its text is never empty: :func:`describe`)."""

    def __str__(self) -> str:
        text = super().__str__()
        return text if text.strip() else f"{type(self).__name__} (without a message)"


class InputError(GflatError, ValueError):
    """Bad user input: negative mass, non-positive speed, NaN, malformed file."""


class UnknownAircraftError(GflatError, KeyError):
    """An aircraft identifier that is not in the catalogue."""

    def __init__(self, name: str, known: list[str]):
        self.name = name
        self.known = list(known)
        super().__init__(name)

    def __str__(self) -> str:
        return f"unknown aircraft {self.name!r}; known aircraft: {', '.join(self.known) or 'none'}"


class DomainError(GflatError):
    """The state left the physical domain of the model (V <= 0, |beta| >= pi/2, ...)."""

    def __init__(
        self, message: str, *, time: float | None = None, variable: str | None = None, value: float | None = None
    ):
        self.time = time
        self.variable = variable
        self.value = value
        super().__init__(message)


class ConvergenceError(GflatError):
    """A Newton iteration (trim, planning) did not converge."""

    def __init__(
        self, message: str, *, residual: float | None = None, iterations: int | None = None, time: float | None = None
    ):
        self.residual = residual
        self.iterations = iterations
        self.time = time
        super().__init__(message)


@contextlib.contextmanager
def writing(path):
    """Name the file in the error of a write that fails (a full disk, a file-size limit, a read-only folder):
    an :class:`OSError` raised in the block becomes ``InputError("cannot write <path>: <cause>")``.

    Parameters
    ----------
    path : str or Path
        The file written in the block.

    Yields
    ------
    None

    Raises
    ------
    InputError
        The block raised an :class:`OSError` (its cause by :func:`describe`).
    """
    try:
        yield
    except OSError as exc:
        raise InputError(f"cannot write {path}: {describe(exc)}") from None


def expand_home(path) -> Path:
    """``path`` with a leading ``~`` or ``~user`` expanded, as :meth:`pathlib.Path.expanduser`.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    Path

    Raises
    ------
    InputError
        The home folder cannot be found (``~nosuchuser``, or no ``HOME`` and no user entry): one line naming
        the path, where ``expanduser`` raises a bare ``RuntimeError``.
    """
    text = str(path)
    if (text == "~" or text.startswith("~/")) and os.environ.get("HOME") == "":
        # expanduser would make '~/x' the root's '/x'
        raise InputError(f"{text!r}: cannot expand '~': HOME is set but empty")
    try:
        return Path(path).expanduser()
    except RuntimeError:
        user = str(path).split("/", 1)[0]
        raise InputError(
            f"{str(path)!r}: cannot expand {user!r}: "
            + ("no such user" if user != "~" else "the home folder is unknown (HOME is unset)")
        ) from None
