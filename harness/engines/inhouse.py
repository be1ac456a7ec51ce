"""The in-house engine: the 12-state wind-frame model integrated by :func:`gna.simulate.simulate`."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from gna.aircraft import Aircraft
from gna.atmosphere import Environment
from gna.simulate import simulate
from gna.trajectory import SimulationResult, control_function, environment_of, initial_state


@dataclass(frozen=True)
class InHouseEngine:
    """The in-house 12-state wind-frame model (:func:`gna.simulate.simulate`).

    Parameters
    ----------
    method : str
        scipy integrator (DOP853 by default: a reference).
    rtol, atol : float
        Its tolerances.
    max_step : float
        Its largest step [s].
    model : {"full", "simple"}
        Equations of motion.
    """

    method: str = "DOP853"
    rtol: float = 1e-10
    atol: float = 1e-10
    max_step: float = math.inf
    model: str = "full"
    name: ClassVar[str] = "inhouse"

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
        """Integrate the wind-frame equations, a controller's states with them.

        Parameters
        ----------
        aircraft : Aircraft
            The aircraft.
        controls : callable, object with ``controls(t)``, or sequence of 5 floats
            Reference controls ``t [s] -> (F [N], eta [-], dl, dm, dn [rad])``,
            a plan, or 5 constants.
        t_span : pair of float
            ``(t0, t1)`` [s].
        x0 : array_like, shape (12,), optional
            Initial wind-frame state; default the source's ``initial_state``.
        env : Environment, optional
            Default the source's ``env`` (a plan's), else the ISA.
        controller : Controller or callable, optional
            Evaluated continuously; its states are integrated with the aircraft's.
        dt_out : float
            Output interval [s].
        t_eval : array_like, shape (n,), optional
            Output times [s].

        Returns
        -------
        SimulationResult
            ``settings.engine == "inhouse"``.
        """
        y0 = initial_state(controls, x0)
        env = environment_of(controls, env)
        res = simulate(
            aircraft,
            control_function(controls),
            t_span,
            y0,
            env=env,
            model=self.model,
            controller=controller,
            dt_out=dt_out,
            t_eval=t_eval,
            rtol=self.rtol,
            atol=self.atol,
            method=self.method,
            max_step=self.max_step,
        )
        res.settings = dataclasses.replace(res.settings, engine=self.name)
        return res
