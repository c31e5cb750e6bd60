"""The rule a user would write instead of the forces: the direction of the centroid vector.

Spatial-VQA data generators (e.g. SpatialRGPT's and SpatialVLM's pipelines) say "A is left
of B" from the direction of the vector between the two objects' centroids. :func:`centroid_primary`
is that rule on the horizontal plane (the nearest of right 0°, behind 90°, left 180°, front
270° to the vector from the referent's centre to the argument's); ``scenespeak evaluate``
scores it beside the force histograms. :func:`pair_tags` sorts the true pairs into the cases
where the two may differ: an *elongated* object (footprint 2.5 times longer than wide), a
*close* pair (footprints less than 10 cm apart) and a *partly hidden* one (an object less than
90 % visible, or the generator's "hidden" reason).

The generator's truth (``truth.json``'s ``primary``) *is* the centroid direction of the true
footprints, so scoring against it favours the centroid rule by construction. A second truth,
independent of that rule, comes from the same true footprints by another definition:
:func:`point_pairs_direction` — the direction a majority of point pairs agree on. Points are
taken on a regular grid inside each true footprint and every pair (b, a) votes for the
direction of b → a (the nearest of right, behind, left, front, if within 25° of its axis); the
relation is *clear* on this count when more than half of all pairs vote for one direction and
the footprints do not overlap.
This is the "all point pairs" view of a directional relation (Freeman 1975; Miyajima & Ralescu
1994's histogram of angles; Matsakis & Wendling 1999's F0 histogram of forces is its
area-weighted, continuous form). It is not the forces' own output: the forces run on the hulls
*estimated* from stereo points (partial, noisy, convex hulls of what was seen), combine the F0
and F2 histograms and read the primary through a fuzzy rule base over degrees of truth
(Matsakis et al. 2001); this truth takes the *true* footprints and a plain majority vote.

>>> centroid_primary((-1.0, 0.1), (0.0, 0.0))
'left'
>>> sq = ((0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0))
>>> point_pairs_direction(tuple((x - 3.0, y) for x, y in sq), sq)
('left', 1.0)
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

__all__ = [
    "OPPOSITE",
    "TAGS",
    "centroid_primary",
    "pair_tags",
    "point_pairs_direction",
    "point_pairs_truth",
    "score_point_pairs",
]

TAGS = ("elongated", "close", "partly hidden")
_NAMES = ("right", "behind", "left", "front")
#: The opposite of each direction (the reverse relation of a point-pairs truth).
OPPOSITE = {"right": "left", "left": "right", "behind": "front", "front": "behind"}
#: Grid points per footprint for :func:`point_pairs_direction` (about; the grid is regular).
GRID_POINTS = 144
#: A point pair votes for a direction only when its angle is within this many degrees of that
#: direction's axis: 45° less the generator's ±20° diagonal tolerance
#: (``tools.scenes.DIAGONAL_TOLERANCE_DEG``), the same test the centroid truth applies once.
AXIS_TOLERANCE_DEG = 25.0
#: Share of ALL point pairs the winning direction's votes need for the relation to be clear: a
#: strict majority (pairs near a diagonal vote for nothing, so a diagonal pair is not clear).
CLEAR_SHARE = 0.5


def centroid_primary(argument: Sequence[float], referent: Sequence[float]) -> str:
    """Primary direction of ``argument`` from ``referent`` by their centres (plane x, y)."""
    angle = math.degrees(math.atan2(argument[1] - referent[1], argument[0] - referent[0]))
    return _NAMES[round((angle % 360.0) / 90.0) % 4]


def _elongated(obj: Mapping[str, Any]) -> bool:
    size = obj.get("size") or (0.0, 0.0, 0.0)
    w, d = float(size[0]), float(size[1])
    return min(w, d) > 0 and max(w, d) / min(w, d) >= 2.5


def pair_tags(
    a: Mapping[str, Any], b: Mapping[str, Any], reasons: Sequence[str] = ()
) -> tuple[str, ...]:
    """Which of :data:`TAGS` a true pair has, from two ``truth.json`` objects."""
    from scenespeak.spatial.dialogue.scene import hull_gap

    tags = []
    if _elongated(a) or _elongated(b):
        tags.append("elongated")
    fa = [(float(x), float(y)) for x, y in a.get("footprint") or ()]
    fb = [(float(x), float(y)) for x, y in b.get("footprint") or ()]
    if len(fa) >= 3 and len(fb) >= 3 and hull_gap(fa, fb) < 0.10:
        tags.append("close")
    vis = min(float(a.get("visible_fraction", 1.0)), float(b.get("visible_fraction", 1.0)))
    if vis < 0.9 or "hidden" in reasons:
        tags.append("partly hidden")
    return tuple(tags)


def _grid_inside(poly: Sequence[Sequence[float]], n: int) -> Any:
    """About ``n`` points of a regular grid inside the polygon (even-odd rule), as (k, 2)."""
    import numpy as np

    from scenespeak.geometry.polygons import polygon_area

    p = np.asarray(poly, dtype=np.float64)
    x, y = p[:, 0], p[:, 1]
    area = abs(polygon_area(p))
    lo, hi = p.min(axis=0), p.max(axis=0)
    if area <= 0.0:
        return p.mean(axis=0, keepdims=True)
    step = math.sqrt(area / n)
    gx = np.arange(lo[0] + step / 2, hi[0], step)
    gy = np.arange(lo[1] + step / 2, hi[1], step)
    px, py = (a.ravel() for a in np.meshgrid(gx, gy))
    inside = np.zeros(px.shape, dtype=bool)
    xn, yn = np.roll(x, -1), np.roll(y, -1)
    for x0, y0, x1, y1 in zip(x, y, xn, yn, strict=True):  # ray casting towards +x
        crosses = (y0 > py) != (y1 > py)
        with np.errstate(divide="ignore", invalid="ignore"):
            xc = x0 + (py - y0) * (x1 - x0) / (y1 - y0)
        inside ^= crosses & (px < xc)
    pts = np.column_stack([px[inside], py[inside]])
    return pts if len(pts) else p.mean(axis=0, keepdims=True)


def point_pairs_direction(
    argument: Sequence[Sequence[float]], referent: Sequence[Sequence[float]]
) -> tuple[str, float]:
    """The direction most point pairs of two footprints agree on, and its share of the pairs.

    Every pair of grid points (b in ``referent``, a in ``argument``; :data:`GRID_POINTS` per
    footprint) votes for the nearest of right (0°), behind (90°), left (180°), front (270°) to
    the angle of a − b on the horizontal plane (x right, y away from the camera), when it lies
    within :data:`AXIS_TOLERANCE_DEG` of it (else for none); the share is of all pairs.
    """
    import numpy as np

    a = _grid_inside(argument, GRID_POINTS)
    b = _grid_inside(referent, GRID_POINTS)
    d = a[:, None, :] - b[None, :, :]
    angle = np.degrees(np.arctan2(d[..., 1], d[..., 0])) % 360.0
    nearest = np.rint(angle / 90.0)
    axis_ok = np.abs(angle - 90.0 * nearest) <= AXIS_TOLERANCE_DEG
    votes = np.bincount((nearest[axis_ok].astype(np.intp) % 4).ravel(), minlength=4)
    best = int(np.argmax(votes))
    return _NAMES[best], round(float(votes[best]) / float(angle.size), 4)


def point_pairs_truth(
    a: Mapping[str, Any], b: Mapping[str, Any], reasons: Sequence[str] = ()
) -> tuple[str, bool]:
    """(direction, clear) of argument ``a`` from referent ``b`` (two ``truth.json`` objects) by
    :func:`point_pairs_direction`: clear when more than :data:`CLEAR_SHARE` of all point pairs
    vote for one direction and the footprints do not overlap (the generator's "overlap"
    reason)."""
    fa, fb = a.get("footprint") or (), b.get("footprint") or ()
    if len(fa) < 3 or len(fb) < 3:
        return "", False
    direction, share = point_pairs_direction(fa, fb)
    return direction, share > CLEAR_SHARE and "overlap" not in reasons


def score_point_pairs(
    said: Mapping[tuple[str, str], str],
    by_centroid: Mapping[tuple[str, str], str],
    truth: Sequence[Any],
) -> dict[str, list[int]]:
    """Per tag of :data:`TAGS` (and ``"all"``): ``[forces right, centroid rule right, pairs]``
    against the point-pairs truth, over the pairs it calls clear that both rules described.

    ``said`` and ``by_centroid`` map ``(argument, referent)`` to a primary direction (the
    forces', the centroid rule's); ``truth`` holds relations with ``argument``, ``referent``,
    ``tags``, ``pairs_primary`` and ``pairs_clear``
    (:class:`~scenespeak.tools.evaluation_truth.TruthRelation`).
    """
    by_tag: dict[str, list[int]] = {}
    for rel in truth:
        key = (rel.argument, rel.referent)
        if not rel.pairs_clear or key not in said or key not in by_centroid:
            continue
        for tag in (*rel.tags, "all"):
            t = by_tag.setdefault(tag, [0, 0, 0])
            t[0] += int(said[key] == rel.pairs_primary)
            t[1] += int(by_centroid[key] == rel.pairs_primary)
            t[2] += 1
    return by_tag
