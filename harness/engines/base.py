"""What every dynamics engine is: the :class:`Engine` protocol and :class:`EngineError`."""

from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np

from gna.aircraft import Aircraft
from gna.atmosphere import Environment
from gna.errors import GflatError
from gna.trajectory import SimulationResult


class EngineError(GflatError):
    """An engine could not be set up (JSBSim refused the model, bad settings)."""


@runtime_checkable
class Engine(Protocol):
    """A dynamics engine: flies an aircraft with a control source and an optional controller.

    Attributes
    ----------
    name : str
        Registry name (``harness.engines.registry``), recorded as ``settings.engine``.

    Notes
    -----
    A new simulator is one folder under ``harness/engines/`` with a class
    meeting this protocol, plus one line in the registry; the conformance suite
    (``tests/harness/engines/test_conformance.py``) then runs over it.
    """

    name: str

    def simulate(
        self,
        aircraft: Aircraft,
        controls,
        t_span,
        x0=None,
        *,
        env: Environment | None = None,
        controller=None,
        dt_out: float = 0.02,
        t_eval: np.ndarray | None = None,
    ) -> SimulationResult:
        """Fly ``aircraft`` from ``x0`` over ``t_span``.

        Parameters
        ----------
        aircraft : Aircraft
            The aircraft.
        controls : callable, object with ``controls(t)``, or sequence of 5 floats
            Reference controls ``t [s] -> (F [N], eta [-], dl, dm, dn [rad])``
            (:func:`gna.trajectory.control_function`).
        t_span : pair of float
            ``(t0, t1)`` [s].
        x0 : array_like, shape (12,), optional
            Initial wind-frame state; default the source's ``initial_state``.
        env : Environment, optional
            Default the source's ``env``, else the ISA.
        controller : Controller or callable, optional
            Anything :func:`gna.controller.as_controller` takes; its output is
            added to the reference controls.
        dt_out : float
            Output interval [s].
        t_eval : array_like, shape (n,), optional
            Output times [s] (override ``dt_out``).

        Returns
        -------
        SimulationResult
            ``df`` with columns :data:`gna.trajectory.COLUMNS`; with a
            controller, ``controller_states`` and ``feedback``; ``settings`` a
            :class:`gna.trajectory.RunSettings` naming this engine.
        """
