"""The one registry of dynamics engines: name -> factory.

Adding a simulator is one folder under ``harness/engines/`` and one line in
:data:`ENGINES`; the CLI's ``--engines`` choices and the conformance suite
come from here.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from functools import partial
from types import MappingProxyType

from gna.errors import InputError

from .base import Engine
from .inhouse import InHouseEngine
from .jsbsim import JSBSimEngine
from .jsbsim.source import JSBSimSourceEngine

#: Engine name -> factory (called without arguments), in display order.
ENGINES: Mapping[str, Callable[[], Engine]] = MappingProxyType(
    {
        "inhouse": InHouseEngine,
        "jsbsim": JSBSimEngine,
        "jsbsim-wgs84": partial(JSBSimEngine, earth="wgs84"),
        "jsbsim-source": JSBSimSourceEngine,
    }
)


def engine_names() -> tuple[str, ...]:
    """Names of the registered engines.

    Returns
    -------
    tuple of str
        ``("inhouse", "jsbsim", "jsbsim-wgs84")`` and any added engine.
    """
    return tuple(ENGINES)


def get_engine(engine) -> Engine:
    """An engine object from a registry name or an engine object.

    Parameters
    ----------
    engine : str or Engine
        A name of :func:`engine_names`, or an object with a ``simulate`` method.

    Returns
    -------
    Engine

    Raises
    ------
    InputError
        Unknown name, or an object that is not an engine.
    """
    if isinstance(engine, str):
        try:
            return ENGINES[engine]()
        except KeyError:
            raise InputError(f"unknown engine {engine!r}; choose from {', '.join(ENGINES)}") from None
    if not callable(getattr(engine, "simulate", None)):
        raise InputError(f"{engine!r} is not an engine (it has no simulate method)")
    return engine


def check_engine_names(names: str | Iterable[str], minimum: int = 1) -> tuple[str, ...]:
    """The registry names of ``names``, checked: known, distinct, at least ``minimum`` (the CLI's ``--engines`` rule).

    Parameters
    ----------
    names : str or iterable of str
        A comma-separated text (``"inhouse,jsbsim"``) or a list of registry names.
    minimum : int
        Least number of engines required (2 for a comparison).

    Returns
    -------
    tuple of str
        The names, in the order given.

    Raises
    ------
    InputError
        Unknown or repeated names, or fewer than ``minimum``.
    """
    if not isinstance(names, str):
        try:
            names = list(names)
        except TypeError:
            raise InputError(f"engines: a list of names of {', '.join(ENGINES)} needed; got {names!r}") from None
        if not all(isinstance(n, str) for n in names):
            raise InputError(f"engines: names of {', '.join(ENGINES)} needed; got {names!r}")
    text = names if isinstance(names, str) else ",".join(names)
    items = [e.strip() for e in text.split(",") if e.strip()]
    bad = [e for e in items if e not in ENGINES]
    if bad or len(items) < minimum or len(set(items)) != len(items):
        need = f"at least {minimum} distinct" if minimum > 1 else "distinct names"
        raise InputError(
            f"engines: {need} of {', '.join(ENGINES)} needed; got {text!r}"
            + (f" (unknown: {', '.join(bad)})" if bad else "")
        )
    return tuple(items)


def engines_from_names(names: str | Iterable[str], minimum: int = 1) -> dict[str, Engine]:
    """Label -> engine for a comma-separated text or a list of registry names (the CLI's ``--engines``).

    Parameters
    ----------
    names : str or iterable of str
        E.g. ``"inhouse,jsbsim"``.
    minimum : int
        Least number of engines required.

    Returns
    -------
    dict
        Name -> engine object, in the order given.

    Raises
    ------
    InputError
        Unknown or repeated names, or fewer than ``minimum``.
    """
    return {n: get_engine(n) for n in check_engine_names(names, minimum)}
