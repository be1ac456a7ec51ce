"""Almost chained systems for :mod:`planners.chained`: the aircraft and others.

``SYSTEMS`` maps a name to a factory ``f(**parameters) -> ChainedSystem`` of the bundled systems
besides the aircraft (:func:`aircraft_system`, built from a :class:`planners.flat.FlatProblem`);
their scenario files are read by :mod:`planners.systems.scenario`.
"""

from __future__ import annotations

from ..flat import aircraft_system
from .car_trailers import CarTrailers, car_two_trailers, simulate_car_two_trailers
from .first_order_lag import first_order_lag, lag_exact, lag_reference

SYSTEMS = {"first-order-lag": first_order_lag, "car-two-trailers": car_two_trailers}

__all__ = [
    "SYSTEMS",
    "CarTrailers",
    "aircraft_system",
    "car_two_trailers",
    "first_order_lag",
    "lag_exact",
    "lag_reference",
    "simulate_car_two_trailers",
]
