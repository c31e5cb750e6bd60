"""geometry.points_in_polygon: the one point-in-polygon test (labelling and the forces use it)."""

from __future__ import annotations

import numpy as np
import pytest
from matplotlib.path import Path

from scenespeak.geometry.polygons import points_in_polygon, polygon_area


def _star(rng: np.random.Generator, n: int) -> np.ndarray:
    ang = (np.arange(n) + rng.uniform(0.0, 0.8, n)) * (2.0 * np.pi / n)
    rad = rng.uniform(0.3, 1.0, n)
    return np.column_stack([rad * np.cos(ang), rad * np.sin(ang)])


def _distance_to_boundary(pts: np.ndarray, ring: np.ndarray) -> np.ndarray:
    a, b = ring, np.roll(ring, -1, axis=0)
    ab = b - a
    t = np.clip(
        np.einsum("pei,ei->pe", pts[:, None] - a[None], ab) / np.einsum("ei,ei->e", ab, ab),
        0.0,
        1.0,
    )
    foot = a[None] + t[..., None] * ab[None]
    return np.hypot(*(pts[:, None] - foot).transpose(2, 0, 1)).min(axis=1)


def test_agrees_with_matplotlib_away_from_the_boundary() -> None:
    rng = np.random.default_rng(4)
    for _ in range(40):
        ring = _star(rng, int(rng.integers(5, 40)))
        if rng.random() < 0.5:
            ring = ring[::-1].copy()
        pts = rng.uniform(-1.2, 1.2, (400, 2))
        far = _distance_to_boundary(pts, ring) > 1e-6
        want = Path(ring).contains_points(pts)
        got = points_in_polygon(pts, ring)
        np.testing.assert_array_equal(got[far], want[far])
        np.testing.assert_array_equal(points_in_polygon(pts, ring, "nonzero")[far], want[far])


def test_the_boundary_rule_left_and_bottom_in_right_and_top_out() -> None:
    sq = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    pts = [[0.0, 0.5], [0.5, 0.0], [1.0, 0.5], [0.5, 1.0], [0.0, 0.0], [1.0, 1.0]]
    for ring in (sq, sq[::-1].copy()):
        got = points_in_polygon(pts, ring).tolist()
        assert got == [True, True, False, False, True, False]


def test_two_squares_sharing_an_edge_claim_each_edge_point_once() -> None:
    left = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    right = left + np.array([1.0, 0.0])
    edge = np.column_stack([np.ones(11), np.linspace(0.0, 0.95, 11)])
    a, b = points_in_polygon(edge, left), points_in_polygon(edge, right)
    assert np.all(a ^ b)


def test_self_crossing_rings_and_degenerate_input() -> None:
    star = np.array([[0, 0], [2, 4], [4, 0], [-1, 2.5], [5, 2.5]], float)  # a pentagram
    assert points_in_polygon([[2, 2]], star).tolist() == [False]  # crossed twice
    assert points_in_polygon([[2, 2]], star, "nonzero").tolist() == [True]
    assert points_in_polygon([[2, 3.5]], star).tolist() == [True]  # a tip: once
    assert points_in_polygon([[0.5, 0.5]], [[0, 0], [1, 1]]).tolist() == [False]
    assert points_in_polygon([[0.5, 0.5]], [[0, 0], [1, np.nan], [0, 1]]).tolist() == [False]
    assert points_in_polygon(np.zeros((0, 2)), star).shape == (0,)
    with pytest.raises(ValueError, match="unknown rule"):
        points_in_polygon([[0, 0]], star, "winding")  # type: ignore[arg-type]


def test_orientation_does_not_matter() -> None:
    rng = np.random.default_rng(9)
    ring = _star(rng, 25)
    assert polygon_area(ring) > 0
    pts = rng.uniform(-1, 1, (500, 2))
    np.testing.assert_array_equal(
        points_in_polygon(pts, ring), points_in_polygon(pts, ring[::-1].copy())
    )
