"""Fly one problem on several engines, on the same output grid."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from gna.aircraft import Aircraft
from gna.atmosphere import Environment
from gna.errors import InputError
from gna.trajectory import SimulationResult, environment_of, initial_state

from .registry import get_engine


def fly(
    engines,
    aircraft: Aircraft,
    x0,
    controls,
    t_span,
    *,
    env: Environment | None = None,
    controller=None,
    dt_out: float = 0.02,
    t_eval: np.ndarray | None = None,
) -> dict[str, SimulationResult]:
    """Fly the same problem on several engines, on the same output grid.

    Parameters
    ----------
    engines : iterable of str or Engine, or mapping of str to Engine
        E.g. ``("inhouse", "jsbsim")``, or
        ``{"flat": JSBSimEngine(), "wgs84": JSBSimEngine(earth="wgs84")}``.
    aircraft : Aircraft
        The aircraft.
    x0 : array_like, shape (12,), or None
        Initial wind-frame state (``None``: the control source's ``initial_state``).
    controls : callable, object with ``controls(t)``, or sequence of 5 floats
        Reference controls ``t [s] -> (F, eta, dl, dm, dn)``, a plan exposing
        ``controls(t)`` (and ``initial_state``), or 5 constants.
    t_span : pair of float
        ``(t0, t1)`` [s].
    env : Environment, optional
        Default: the control source's ``env`` (a plan's), else ISA.
    controller : Controller or callable, optional
        Anything :func:`gna.controller.as_controller` takes, flown by every engine.
    dt_out : float
        Output interval [s], the same for every engine.
    t_eval : array_like, shape (n,), optional
        Output times [s], the same for every engine.

    Returns
    -------
    dict
        Label (engine name unless a mapping was given) -> :class:`gna.trajectory.SimulationResult`,
        in the order given.

    Raises
    ------
    InputError
        No engine, an unknown engine, repeated labels, or a bad initial state.
    """
    env = environment_of(controls, env)  # a plan flies in the environment it was planned for
    if isinstance(engines, Mapping):
        pairs = [(str(k), get_engine(e)) for k, e in engines.items()]
    else:
        pairs = [(o.name, o) for o in (get_engine(e) for e in engines)]
    if not pairs:
        raise InputError("no engine to fly")
    labels = [p[0] for p in pairs]
    if len(set(labels)) != len(labels):
        raise InputError(f"engine labels must be distinct, got {', '.join(labels)}; pass a mapping label -> engine")
    y0 = initial_state(controls, x0)
    return {
        label: e.simulate(aircraft, controls, t_span, y0, env=env, controller=controller, dt_out=dt_out, t_eval=t_eval)
        for label, e in pairs
    }
