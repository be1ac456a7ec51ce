"""planners: flat and generalized-flat motion planning on truncated power series."""

from .flat import FlatOutput, FlatProblem, parametrize
from .generalized import plan_motion, plan_scenario
from .newton import newton, newton_series
from .plan import Plan, save_plan
from .scenario import Scenario, list_scenarios, load_scenario
from .series import Series

__all__ = [
    "FlatOutput",
    "FlatProblem",
    "parametrize",
    "plan_motion",
    "plan_scenario",
    "newton",
    "newton_series",
    "Plan",
    "save_plan",
    "Scenario",
    "list_scenarios",
    "load_scenario",
    "Series",
]
