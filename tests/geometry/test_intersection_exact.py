"""``geometry.polygons.intersection_area`` is exact for two non-convex polygons too (no grid)."""

from __future__ import annotations

import numpy as np

from scenespeak.geometry.polygons import intersection_area, is_convex


def test_two_non_convex_polygons_intersect_exactly() -> None:
    ell = np.array([[0, 0], [2, 0], [2, 1], [1, 1], [1, 2], [0, 2]], float)  # an L, area 3
    # a second L, shifted by (0.5, 0.5): the overlap is three unit-square pieces, 1.25 in all
    other = ell + 0.5
    assert not is_convex(ell) and not is_convex(other)
    assert intersection_area(ell, other) == 1.25
    # either orientation, either order
    assert intersection_area(ell[::-1].copy(), other) == 1.25
    assert intersection_area(other, ell[::-1].copy()) == 1.25
    # apart, and touching along an edge only
    assert intersection_area(ell, ell + 5.0) == 0.0
    assert intersection_area(ell, ell + np.array([2.0, 0.0])) == 0.0


def test_exact_area_matches_a_fine_grid_on_random_non_convex_pairs() -> None:
    from matplotlib.path import Path

    rng = np.random.default_rng(9)
    for _ in range(20):

        def star(c: np.ndarray) -> np.ndarray:
            t = np.sort(rng.uniform(0, 2 * np.pi, 9))
            r = rng.uniform(0.4, 1.0, 9)
            return np.column_stack([r * np.cos(t), r * np.sin(t)]) + c

        a, b = star(np.zeros(2)), star(rng.uniform(-0.5, 0.5, 2))
        lo, hi = np.minimum(a.min(0), b.min(0)), np.maximum(a.max(0), b.max(0))
        k = 800
        xs = lo[0] + (np.arange(k) + 0.5) * (hi[0] - lo[0]) / k
        ys = lo[1] + (np.arange(k) + 0.5) * (hi[1] - lo[1]) / k
        pts = np.stack(np.meshgrid(xs, ys), axis=-1).reshape(-1, 2)
        both = Path(a).contains_points(pts) & Path(b).contains_points(pts)
        grid = both.mean() * np.prod(hi - lo)
        assert abs(intersection_area(a, b) - grid) <= 0.01 * max(grid, 0.05)
