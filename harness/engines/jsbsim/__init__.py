"""JSBSim as a dynamics engine.

Rooms:

* :mod:`.run`: :class:`~.run.JSBSimRun`, the run loop every JSBSim engine shares (stepping, sampled
  controller with AB2 states, stop handling, result) with the hooks an engine fills;
* :mod:`.engine`: :class:`JSBSimEngine`, the exported aircraft file flown;
* :mod:`.source`: :class:`~.source.JSBSimSourceEngine`, the JSBSim aircraft a GNA set was fitted from;
* :mod:`.fdm`: loading an aircraft with its log captured, :class:`Integrators`, initial conditions;
* :mod:`.states`: JSBSim properties -> the 12 wind-frame states and the common DataFrame;
* :mod:`.export`: the aircraft file generated from a gflat aircraft (``gflat export-jsbsim``);
* :mod:`.script`: a plan as stock JSBSim files, replayed natively (``gflat export-jsbsim-script``).
"""

from .engine import CONTROLLER_SCHEME, JSBSimEngine
from .fdm import INTEGRATOR_CODES, JSBSIM_DEFAULT_INTEGRATORS, Integrators, initial_condition_properties, load_fdm

__all__ = [
    "JSBSimEngine",
    "CONTROLLER_SCHEME",
    "Integrators",
    "INTEGRATOR_CODES",
    "JSBSIM_DEFAULT_INTEGRATORS",
    "initial_condition_properties",
    "load_fdm",
]
