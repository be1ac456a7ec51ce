"""JSBSim as a dynamics engine.

Rooms:

* :mod:`.engine`: :class:`JSBSimEngine` and its run loop (run context, sampled controller);
* :mod:`.fdm`: loading an aircraft with its log captured, :class:`Integrators`, initial conditions;
* :mod:`.states`: JSBSim properties -> the 12 wind-frame states and the common DataFrame;
* :mod:`.export`: the aircraft file generated from a gflat aircraft (``gflat export-jsbsim``).
"""

from .engine import CONTROLLER_SCHEME, JSBSimEngine
from .fdm import (INTEGRATOR_CODES, JSBSIM_DEFAULT_INTEGRATORS, Integrators, initial_condition_properties,
                  load_fdm)

__all__ = ["JSBSimEngine", "CONTROLLER_SCHEME", "Integrators", "INTEGRATOR_CODES", "JSBSIM_DEFAULT_INTEGRATORS",
           "initial_condition_properties", "load_fdm"]
