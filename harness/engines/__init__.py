"""Dynamics engines with one interface: the in-house wind-frame model and JSBSim.

Every engine meets :class:`Engine`: a ``name`` and
``simulate(aircraft, controls, t_span, x0=None, *, env=None, controller=None,
dt_out=0.02, t_eval=None) -> SimulationResult``; the result's ``df`` has the
columns :data:`COLUMNS` for every engine and its ``settings`` (a
:class:`gna.trajectory.RunSettings`) record everything that determines the
numbers.  A controller (:class:`gna.controller.Controller`, or a callable
``(t, x) -> 5 corrections``) is flown by every engine: integrated with the
aircraft in-house, sampled at every step (or every ``controller_dt``) by JSBSim.

Rooms:

* :mod:`.base`: the :class:`Engine` protocol and :class:`EngineError`;
* :mod:`.registry`: the one registry name -> engine (:func:`get_engine`,
  :func:`engine_names`, :func:`engines_from_names`); a new simulator is one
  folder here plus one registry line;
* :mod:`.inhouse`: :class:`InHouseEngine`;
* :mod:`.jsbsim`: :class:`JSBSimEngine` (run loop, FDM loading, state
  conversion, aircraft-file export);
* :mod:`.fly`: :func:`fly`, one problem on several engines.
"""

from gna.trajectory import COLUMNS, ControlFunction, control_function, controls_on_grid, initial_state

from .base import Engine, EngineError
from .fly import fly
from .inhouse import InHouseEngine
from .jsbsim import (
    CONTROLLER_SCHEME,
    INTEGRATOR_CODES,
    JSBSIM_DEFAULT_INTEGRATORS,
    Integrators,
    JSBSimEngine,
    initial_condition_properties,
    load_fdm,
)
from .registry import ENGINES, check_engine_names, engine_names, engines_from_names, get_engine

__all__ = [
    "Engine",
    "EngineError",
    "fly",
    "get_engine",
    "engine_names",
    "engines_from_names",
    "check_engine_names",
    "ENGINES",
    "InHouseEngine",
    "JSBSimEngine",
    "Integrators",
    "INTEGRATOR_CODES",
    "JSBSIM_DEFAULT_INTEGRATORS",
    "CONTROLLER_SCHEME",
    "initial_condition_properties",
    "load_fdm",
    "COLUMNS",
    "ControlFunction",
    "control_function",
    "controls_on_grid",
    "initial_state",
]
