"""Argument types shared by sub-commands: numbers are checked at parse time."""

from __future__ import annotations

import argparse
import math

from gna.errors import InputError
from planners.flat import MAX_J


def finite_float(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not math.isfinite(v):
        raise argparse.ArgumentTypeError(f"must be finite, got {text}")
    return v


def positive_float(text: str) -> float:
    v = finite_float(text)
    if v <= 0:
        raise argparse.ArgumentTypeError(f"must be positive, got {text}")
    return v


def cost_bound(text: str) -> float:
    """A ``--max-...`` bound: a positive number, or ``inf`` for none (``gflat plan --max-cost``'s rule)."""
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not v > 0:
        raise argparse.ArgumentTypeError(f"must be positive (or inf), got {text}")
    return v


def _int_at_least(text: str, lowest: int) -> int:
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None
    if v < lowest:
        raise argparse.ArgumentTypeError(f"must be >= {lowest}, got {text}")
    return v


def nonnegative_int(text: str) -> int:
    """An integer >= 0."""
    return _int_at_least(text, 0)


def positive_int(text: str) -> int:
    """A count that must be at least 1 (``--jobs``, ``--samples``, ``--workers``)."""
    return _int_at_least(text, 1)


def worker_count(text: str) -> int:
    """``--workers`` / ``--jobs``: a count of worker processes, 1 to :func:`harness.parallel.max_workers`."""
    from ..parallel import check_workers

    v = positive_int(text)
    try:
        return check_workers(v, "")
    except InputError as exc:
        raise argparse.ArgumentTypeError(str(exc).strip()) from None


def bounded_float(upper: float):
    """An argument type: a positive finite number at most ``upper`` (a time or size a flag sets, e.g. ``gflat
    campaign run --dask-timeout``)."""

    def parse(text: str) -> float:
        v = positive_float(text)
        if v > upper:
            raise argparse.ArgumentTypeError(f"{v:g} is above the bound of {upper:g}")
        return v

    parse.__name__ = f"number in (0, {upper:g}]"
    return parse


def within(lowest: float, upper: float):
    """An argument type: a finite number in ``lowest..upper`` (an angle or a rate a flag sets, e.g. ``gflat fit
    --alpha``)."""

    def parse(text: str) -> float:
        v = finite_float(text)
        if not lowest <= v <= upper:
            raise argparse.ArgumentTypeError(f"{v:g} is outside its bounds {lowest:g} .. {upper:g}")
        return v

    parse.__name__ = f"number in [{lowest:g}, {upper:g}]"
    return parse


def bounded_count(upper: int, lowest: int = 0):
    """An argument type: a whole number in ``lowest..upper`` (a count a flag sets, e.g. ``gflat fit --samples``)."""

    def parse(text: str) -> int:
        v = _int_at_least(text, lowest)
        if v > upper:
            raise argparse.ArgumentTypeError(f"{v} is above the bound of {upper}")
        return v

    parse.__name__ = f"count {lowest}..{upper}"
    return parse


def iterations(text: str) -> int | str:
    """``--J``: a number of generalized-flatness iterations (0 to :data:`planners.flat.MAX_J`) or ``auto`` (chosen
    by the convergence test); a value out of range blames the option, not the scenario file."""
    if text.strip() == "auto":
        return "auto"
    try:
        v = nonnegative_int(text)
    except argparse.ArgumentTypeError:
        raise argparse.ArgumentTypeError(f"not a whole number >= 0 or 'auto': {text!r}") from None
    if v > MAX_J:
        raise argparse.ArgumentTypeError(f"must be between 0 and {MAX_J} (or 'auto'), got {text}")
    return v


def add_tracking(p: argparse.ArgumentParser) -> None:
    """``--tracking paper|lqr``: the closed loop's tracking design, over the scenario's ``[tracking] design``."""
    from planners.lqr import DESIGNS

    p.add_argument(
        "--tracking",
        choices=DESIGNS,
        default=None,
        help="closed loop: the tracking design, the paper's pole placement or the time-varying LQR "
        "(default: the scenario's [tracking] design, else paper; docs/tracking.md)",
    )
