"""Relations to the viewer: "The mug is in front of me, slightly to the left."."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from scenespeak.errors import InputError
from scenespeak.geometry.polygons import as_polygon, intersection_area, polygon_area
from scenespeak.spatial.language.pairs import _histograms
from scenespeak.spatial.language.relation import Relation
from scenespeak.spatial.language.rules import _as_histogram, _Facts, _relation_from
from scenespeak.spatial.language.thresholds import DEFAULT_THRESHOLDS, Thresholds
from scenespeak.spatial.language.words import _label

__all__ = ["describe_viewer_relation"]


def describe_viewer_relation(
    polygon: ArrayLike,
    label: str,
    *,
    directions: int = 180,
    viewer_size: float = 0.1,
    thresholds: Thresholds | None = None,
) -> Relation:
    """Describe where an object is relative to the camera: "The mug is in front of me, ...".

    The viewer is a square of side ``viewer_size`` (metres) centred on the camera, at the
    origin of the horizontal plane, looking along +y. Relative to the viewer an object at +y
    is "in front of me" (for objects relative to each other, +y is "behind"), so the histogram
    is mirrored in y before the same rule base runs; ``primary`` and ``secondary`` use the
    viewer's directions (``"front"`` = farther from the camera).

    Examples
    --------
    >>> mug = np.array([[-0.45, 1.0], [-0.25, 1.0], [-0.25, 1.2], [-0.45, 1.2]])
    >>> describe_viewer_relation(mug, "mug").sentence
    'The mug is in front of me, slightly to the left.'
    """
    t = thresholds or DEFAULT_THRESHOLDS
    p = as_polygon(polygon, f"{label} polygon")
    label = _label(label, "label")
    if not (math.isfinite(viewer_size) and viewer_size > 0):
        raise InputError("viewer_size", f"must be a positive size in metres, got {viewer_size}")
    s = 0.5 * viewer_size
    viewer = np.array([[-s, -s], [s, -s], [s, s], [-s, s]])
    inter = intersection_area(p, viewer)
    intersecting = inter > 0.0
    f0, f2, hybrid = _histograms(p, viewer, directions, intersecting)
    mirror = (-np.arange(directions)) % directions  # θ → −θ: +y becomes "front"
    overlap = inter / abs(polygon_area(p)) if intersecting else 0.0
    referent_overlap = inter / viewer_size**2 if intersecting else 0.0
    return _relation_from(
        _as_histogram(f0[mirror], "f0"),
        _as_histogram(f2[mirror], "f2"),
        (label, "me"),
        t,
        _Facts(overlap, referent_overlap, None, hybrid, "viewer"),
    )
