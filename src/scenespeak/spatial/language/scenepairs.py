"""Every unordered pair of a scene's polygons: overlaps and force histograms, as arrays.

What :func:`~.pairs.pair_histograms` computes for one pair, for all pairs ``i < j`` of a
scene at once: each polygon is validated and prepared once, the overlap is clipped only for
pairs whose bounding boxes are not apart (for the others it is exactly 0: the clipping would
drop every vertex), and F0 and F2 (F02 where F2 is undefined) of all pairs come from one
sweep (:func:`scenespeak.spatial.forces.f0_f2_pairs`). Memory is linear in the pairs.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from scenespeak.errors import ScenespeakError
from scenespeak.geometry.polygons import intersection_area, is_convex, polygon_area
from scenespeak.spatial.language.pairs import _histograms
from scenespeak.spatial.language.rules import _as_histograms

__all__ = ["ScenePairs", "scene_pairs"]


@dataclass(frozen=True)
class ScenePairs:
    """The histograms and overlaps of every unordered pair ``(first[k], second[k])``.

    Attributes
    ----------
    first, second : (P,) int arrays
        The pairs ``i < j`` in the order ``(0, 1), (0, 2), ..., (1, 2), ...``.
    f0, f2 : (P, directions) float64 arrays
        F0 and F2 (or F02) of ``first[k]`` relative to ``second[k]``, checked and clipped at 0
        as :func:`~.pairs.pair_histograms` returns them.
    hybrid : (P,) bool array
        Where ``f2`` is the hybrid F02.
    intersection : (P,) float64 array
        area(A ∩ B).
    area : (N,) float64 array
        Each polygon's area.
    """

    first: NDArray[np.intp]
    second: NDArray[np.intp]
    f0: NDArray[np.float64]
    f2: NDArray[np.float64]
    hybrid: NDArray[np.bool_]
    intersection: NDArray[np.float64]
    area: NDArray[np.float64]


def scene_pairs(
    polygons: Sequence[NDArray[np.float64]], labels: Sequence[str], directions: int
) -> ScenePairs:
    """:class:`ScenePairs` of checked polygons (``as_polygon``): the same floats as
    ``pair_histograms(polygons[i], polygons[j])`` for every ``i < j``.

    Examples
    --------
    >>> sq = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    >>> got = scene_pairs([sq, sq + [3.0, 0.0], sq + [0.5, 0.5]], ["a", "b", "c"], 8)
    >>> got.first.tolist(), got.second.tolist(), got.intersection.tolist()
    ([0, 0, 1], [1, 2, 2], [0.0, 0.25, 0.0])
    >>> got.hybrid.tolist(), int(np.argmax(got.f2[0]))      # a is left of b: bin 4 = 180°
    ([False, True, False], 4)
    """
    n = len(polygons)
    first, second = (np.asarray(x, dtype=np.intp) for x in np.triu_indices(n, 1))
    area = np.array([abs(polygon_area(p)) for p in polygons], dtype=np.float64).reshape(n)
    inter = _intersections(polygons, first, second)
    intersecting = inter > 1e-12 * np.minimum(area[first], area[second])
    f0, f2, hybrid = _forces(polygons, labels, (first, second), intersecting, directions)
    f0, f2 = _checked(f0, f2)
    return ScenePairs(first, second, f0, f2, hybrid, inter, area)


def _boxes_apart(
    polygons: Sequence[NDArray[np.float64]], first: NDArray[np.intp], second: NDArray[np.intp]
) -> NDArray[np.bool_]:
    """Pairs whose bounding boxes are apart by more than ``1e-9`` of the coordinates' size
    (far more than any rounding of the clipping, so that their overlap is exactly 0)."""
    boxes = np.array([[*p.min(axis=0), *p.max(axis=0)] for p in polygons]).reshape(-1, 4)
    size = np.abs(boxes).max(axis=1)
    tol = (1e-9 * np.maximum(np.maximum(size[first], size[second]), 1e-300))[:, None]
    lo_a, hi_a = boxes[first, :2], boxes[first, 2:]
    lo_b, hi_b = boxes[second, :2], boxes[second, 2:]
    return ((lo_a - hi_b > tol) | (lo_b - hi_a > tol)).any(axis=1)


def _intersections(
    polygons: Sequence[NDArray[np.float64]], first: NDArray[np.intp], second: NDArray[np.intp]
) -> NDArray[np.float64]:
    """area(A ∩ B) of every pair: clipped where the boxes meet, 0 where they are apart."""
    inter = np.zeros(len(first))
    near = np.flatnonzero(~_boxes_apart(polygons, first, second))
    convex: dict[int, bool] = {}
    for k in near.tolist():
        i, j = int(first[k]), int(second[k])
        for m in (i, j):
            if m not in convex:
                convex[m] = is_convex(polygons[m])
        inter[k] = intersection_area(
            polygons[i], polygons[j], a_convex=convex[i], b_convex=convex[j]
        )
    return inter


def _prepared_regions(polygons: Sequence[NDArray[np.float64]], labels: Sequence[str]) -> list[Any]:
    """Each polygon prepared once for the force sweep, or None where preparing fails (its
    pairs then take :func:`~.pairs.pair_histograms`' path, and its error)."""
    from scenespeak.spatial import forces

    regions: list[Any] = []
    for p, label in zip(polygons, labels, strict=True):
        try:
            regions.append(forces.prepare(p, label))
        except ScenespeakError:
            regions.append(None)
    return regions


def _forces(
    polygons: Sequence[NDArray[np.float64]],
    labels: Sequence[str],
    pairs: tuple[NDArray[np.intp], NDArray[np.intp]],
    intersecting: NDArray[np.bool_],
    directions: int,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_]]:
    """F0, F2 (F02 where F2 is undefined) and the hybrid flags of every pair: one sweep for
    the pairs whose two polygons are prepared, :func:`~.pairs._histograms` for the others."""
    from scenespeak.spatial import forces

    first, second = pairs
    regions = _prepared_regions(polygons, labels)
    ready = np.array([r is not None for r in regions], dtype=bool).reshape(-1)
    swept = np.flatnonzero(ready[first] & ready[second])
    got = None
    if swept.size:
        # Regions that failed to prepare are None: only the others go to the sweep.
        slot = np.cumsum(ready) - 1
        got = forces.f0_f2_pairs(
            [r for r in regions if r is not None],
            np.column_stack([slot[first[swept]], slot[second[swept]]]),
            directions,
            try_f2=~intersecting[swept],
        )
        if swept.size == len(first):  # every pair swept (the usual case)
            # C-ordered rows: the row sums of the rule base are then those of 1-D arrays (one
            # copy where the sweep's F0 and F2 are views of one array, else none).
            f0, f2 = np.ascontiguousarray(got.f0), np.ascontiguousarray(got.f2)
            return f0, f2, np.asarray(got.hybrid, dtype=bool)
    f0 = np.empty((len(first), directions))
    f2 = np.empty((len(first), directions))
    hybrid = np.ones(len(first), dtype=bool)
    if got is not None:
        f0[swept], f2[swept], hybrid[swept] = got.f0, got.f2, got.hybrid
    for k in np.flatnonzero(~(ready[first] & ready[second])).tolist():
        a, b = polygons[first[k]], polygons[second[k]]
        f0[k], f2[k], hybrid[k] = _histograms(a, b, directions, bool(intersecting[k]))
    return f0, f2, hybrid


def _checked(
    f0: NDArray[np.float64], f2: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``pair_histograms``' checks of every histogram (``_as_histogram``) and its clipping at
    0, on all rows at once; the first bad one raises the same error.

    Finite forces that are all >= 0 (a finite sum, no value below 0) pass unchanged, as the
    clipping would leave them; anything else takes the row-by-row checks."""
    if all(h.size == 0 or (np.isfinite(h.sum()) and h.min() >= 0.0) for h in (f0, f2)):
        return f0, f2
    ok = bool(np.isfinite(f0).all() and np.isfinite(f2).all())
    for h in (f0, f2):
        if ok and h.size:
            floor = -1e-9 * np.maximum(np.abs(h).max(axis=1), 1e-300)
            ok = not bool(np.any(h < floor[:, None]))
    if not ok:
        raw = [h for k in range(len(f0)) for h in (f0[k], f2[k])]
        checked = _as_histograms(raw, ("f0", "f2"))
        return np.array(checked[0::2]).reshape(f0.shape), np.array(checked[1::2]).reshape(f2.shape)
    return np.maximum(f0, 0.0), np.maximum(f2, 0.0)
