"""Exceptions raised by gflat.

Every error names its cause and, where it makes sense, the time and the value
involved, so that the command-line tool can print one clear line instead of a
traceback.
"""

from __future__ import annotations


class GflatError(Exception):
    """Base class of every error gflat raises on purpose."""


class InputError(GflatError, ValueError):
    """Bad user input: negative mass, non-positive speed, NaN, malformed file."""


class UnknownAircraftError(GflatError, KeyError):
    """An aircraft identifier that is not in the catalogue."""

    def __init__(self, name: str, known: list[str]):
        self.name = name
        self.known = list(known)
        super().__init__(name)

    def __str__(self) -> str:
        return f"unknown aircraft {self.name!r}; known aircraft: {', '.join(self.known)}"


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
