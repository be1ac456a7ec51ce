"""The position's scale of delta_pct: the path's diameter, found among far points only, is the largest pair."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.distance import cdist

from harness.metrics.scales import percent_scale


def _brute(points: np.ndarray) -> float:
    points = points - points[0]
    return float(np.max(cdist(points, points)))


def _path(points: np.ndarray) -> dict:
    return {"x": points[:, 0], "y": points[:, 1], "z": points[:, 2]}


t = np.linspace(0.0, 120.0, 2401)


@pytest.mark.parametrize(
    "points",
    [
        np.c_[70.0 * t, 0.0 * t, -500.0 + 0.0 * t],  # a straight level path: its ends
        np.c_[70.0 * t, 3.0 * np.sin(t), -500.0 - 0.1 * t],
        np.c_[1400.0 * np.sin(0.05 * t), 1400.0 * (1.0 - np.cos(0.05 * t)), -500.0 + 0.0 * t],  # a level turn
        np.random.default_rng(4).normal(size=(3000, 3)),
        np.random.default_rng(5).normal(size=(40, 3)),  # below the hull's threshold
    ],
)
def test_position_scale_is_the_largest_distance_between_two_points(points):
    assert percent_scale("position", _path(points)) == _brute(points)


def test_position_scale_of_a_straight_path_is_its_length():
    points = np.c_[70.0 * t, 0.0 * t, 0.0 * t]
    assert percent_scale("position", _path(points)) == pytest.approx(70.0 * 120.0, rel=1e-12)
    assert np.isnan(percent_scale("position", _path(np.r_[points[:3], [[np.nan, 0.0, 0.0]]])))
