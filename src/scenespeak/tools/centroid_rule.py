"""The rule a user would write instead of the forces: the direction of the centroid vector.

Spatial-VQA data generators (e.g. SpatialRGPT's and SpatialVLM's pipelines) say "A is left
of B" from the direction of the vector between the two objects' centroids. :func:`centroid_primary`
is that rule on the horizontal plane (the nearest of right 0°, behind 90°, left 180°, front
270° to the vector from the referent's centre to the argument's); ``scenespeak evaluate``
scores it beside the force histograms. :func:`pair_tags` sorts the true pairs into the cases
where the two may differ: an *elongated* object (footprint 2.5 times longer than wide), a
*close* pair (footprints less than 10 cm apart) and a *partly hidden* one (an object less than
90 % visible, or the generator's "hidden" reason).

>>> centroid_primary((-1.0, 0.1), (0.0, 0.0))
'left'
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

__all__ = ["TAGS", "centroid_primary", "pair_tags"]

TAGS = ("elongated", "close", "partly hidden")
_NAMES = ("right", "behind", "left", "front")


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
