"""gna: the in-house aircraft model.

Grauer--Morelli generic nonlinear aerodynamics as term tables, the 12-state
wind-frame equations of motion (one definition for floats, arrays and power
series), atmosphere, trim and simulation.
"""

from .aircraft import Aircraft, list_aircraft, load_aircraft
from .atmosphere import ISA, ConstantDensity, Environment
from .eom import CONTROL_NAMES, STATE_NAMES, Controls, HValues, State, derivatives, loads
from .errors import ConvergenceError, DomainError, GflatError, InputError, UnknownAircraftError
from .simulate import SimulationResult, simulate
from .trim import TrimResult, coordinated_turn, sideslip_glide, stall_speed, trim, trim_level

__all__ = [
    "Aircraft",
    "list_aircraft",
    "load_aircraft",
    "ISA",
    "ConstantDensity",
    "Environment",
    "CONTROL_NAMES",
    "STATE_NAMES",
    "Controls",
    "HValues",
    "State",
    "derivatives",
    "loads",
    "ConvergenceError",
    "DomainError",
    "GflatError",
    "InputError",
    "UnknownAircraftError",
    "SimulationResult",
    "simulate",
    "TrimResult",
    "coordinated_turn",
    "sideslip_glide",
    "stall_speed",
    "trim",
    "trim_level",
]
