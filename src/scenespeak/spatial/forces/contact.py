"""Whether two regions overlap or touch, and the area they share (exact).

The geometry itself is :mod:`scenespeak.geometry.polygons` (one exact intersection for the
whole package); this module adds the tolerances of the force histograms and the shortcuts for
objects whose bounding boxes are apart.
"""

from __future__ import annotations

from scenespeak.geometry.polygons import (
    boundaries_touch,
    exact_intersection_area,
    winding_numbers,
)
from scenespeak.spatial.forces.regions import _AREA_TOL, _LENGTH_TOL, Region


def _boxes_apart(
    lo_a: list[float], hi_a: list[float], lo_b: list[float], hi_b: list[float]
) -> bool:
    """:func:`_contact`'s first test (bounding boxes apart), on Python floats: the same
    operations on the same numbers, without the small-array overhead."""
    scale = max(max(hi_a[k], hi_b[k]) - min(lo_a[k], lo_b[k]) for k in (0, 1))
    tol = _LENGTH_TOL * scale
    return any(lo_a[k] > hi_b[k] + tol or lo_b[k] > hi_a[k] + tol for k in (0, 1))


def _contact(a: Region, b: Region) -> tuple[float, bool]:
    """Return (area of A∩B, whether the boundaries touch or cross)."""
    lo_a, hi_a = a.start.min(axis=0), a.start.max(axis=0)
    lo_b, hi_b = b.start.min(axis=0), b.start.max(axis=0)
    scale = float(max(max(hi_a[k], hi_b[k]) - min(lo_a[k], lo_b[k]) for k in (0, 1)))
    tol = _LENGTH_TOL * scale
    if (lo_a > hi_b + tol).any() or (lo_b > hi_a + tol).any():
        return 0.0, False  # bounding boxes apart
    if not boundaries_touch(a, b, tol):
        # Boundaries apart: the interiors overlap only if one contains the other.
        if winding_numbers(a.start[:1], b)[0] != 0:
            return a.area, False
        if winding_numbers(b.start[:1], a)[0] != 0:
            return b.area, False
        return 0.0, False
    inter = exact_intersection_area(a, b)
    if inter <= _AREA_TOL * scale * scale:
        inter = 0.0
    return inter, True
