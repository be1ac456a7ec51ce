"""Almost chained systems besides the aircraft, for :mod:`planners.chained`.

``SYSTEMS`` maps a name to a factory ``f(**parameters) -> ChainedSystem``.
"""

from __future__ import annotations

from .car_trailers import CarTrailers, car_two_trailers, simulate_car_two_trailers
from .first_order_lag import first_order_lag, lag_reference

SYSTEMS = {"first-order-lag": first_order_lag, "car-two-trailers": car_two_trailers}

__all__ = ["SYSTEMS", "CarTrailers", "car_two_trailers", "first_order_lag", "lag_reference",
           "simulate_car_two_trailers"]
