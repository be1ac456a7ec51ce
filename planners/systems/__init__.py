"""Almost chained systems besides the aircraft, for :mod:`planners.chained`.

``SYSTEMS`` maps a name to a factory ``f(**parameters) -> ChainedSystem``.
"""

from __future__ import annotations

from .first_order_lag import first_order_lag, lag_reference

SYSTEMS = {"first-order-lag": first_order_lag}

__all__ = ["SYSTEMS", "first_order_lag", "lag_reference"]
