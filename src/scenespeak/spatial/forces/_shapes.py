"""The compiled helpers of :func:`~scenespeak.spatial.forces.prepare` (private).

The simplicity check of non-convex polygons (:func:`first_contact`, the same answer and error
as the NumPy check of ``regions._first_contact``) and the mask tracer of
:mod:`~scenespeak.spatial.forces._trace`, compiled by Numba. Used once the compiled kernel is
loaded (:mod:`~scenespeak.spatial.forces._jit`); before that, and without Numba, ``prepare``
runs their NumPy and plain-Python versions.
"""

from __future__ import annotations

import math

import numpy as np

from scenespeak.spatial.forces import _trace
from scenespeak.spatial.forces._jit import jit


@jit
def _point_segment(px: float, py: float, ax: float, ay: float, bx: float, by: float) -> float:
    """Distance from point p to segment ab (``geometry.polygons.segment_distances``)."""
    ex = bx - ax
    ey = by - ay
    den = ex * ex + ey * ey
    t = ((px - ax) * ex + (py - ay) * ey) / den if den > 0.0 else 0.0
    t = min(max(t, 0.0), 1.0)
    dx = px - ax - t * ex
    dy = py - ay - t * ey
    return math.sqrt(dx * dx + dy * dy)


@jit
def _segments_near(p: np.ndarray, q: np.ndarray, i: int, j: int, tol: float) -> bool:
    """Whether segments i and j of (p, q) cross or come within ``tol``."""
    d1 = (q[j, 0] - p[j, 0]) * (p[i, 1] - p[j, 1]) - (q[j, 1] - p[j, 1]) * (p[i, 0] - p[j, 0])
    d2 = (q[j, 0] - p[j, 0]) * (q[i, 1] - p[j, 1]) - (q[j, 1] - p[j, 1]) * (q[i, 0] - p[j, 0])
    d3 = (q[i, 0] - p[i, 0]) * (p[j, 1] - p[i, 1]) - (q[i, 1] - p[i, 1]) * (p[j, 0] - p[i, 0])
    d4 = (q[i, 0] - p[i, 0]) * (q[j, 1] - p[i, 1]) - (q[i, 1] - p[i, 1]) * (q[j, 0] - p[i, 0])
    if d1 * d2 < 0.0 and d3 * d4 < 0.0:
        return True
    dist = min(
        _point_segment(p[i, 0], p[i, 1], p[j, 0], p[j, 1], q[j, 0], q[j, 1]),
        _point_segment(q[i, 0], q[i, 1], p[j, 0], p[j, 1], q[j, 0], q[j, 1]),
        _point_segment(p[j, 0], p[j, 1], p[i, 0], p[i, 1], q[i, 0], q[i, 1]),
        _point_segment(q[j, 0], q[j, 1], p[i, 0], p[i, 1], q[i, 0], q[i, 1]),
    )
    return dist <= tol


@jit
def first_contact(p: np.ndarray, q: np.ndarray, tol: float) -> np.ndarray:
    """The first pair ``(i, j)``, ``i < j`` non-adjacent, of edges ``p → q`` that cross or touch.

    ``[-1, -1]`` when the closed polygon is simple. Edges sorted by their smallest x; each is
    compared only with the edges whose x-range can reach it (bounding boxes within ``tol``),
    so the cost is near ``n log n`` for ordinary outlines. "First" is the smallest ``(i, j)``
    in lexicographic order, as the NumPy check reports it.
    """
    n = p.shape[0]
    xlo = np.minimum(p[:, 0], q[:, 0]) - tol
    xhi = np.maximum(p[:, 0], q[:, 0]) + tol
    ylo = np.minimum(p[:, 1], q[:, 1]) - tol
    yhi = np.maximum(p[:, 1], q[:, 1]) + tol
    order = np.argsort(xlo)
    best = np.array([-1, -1], dtype=np.int64)
    for a in range(n):
        i0 = order[a]
        for b in range(a + 1, n):
            j0 = order[b]
            if xlo[j0] > xhi[i0]:
                break
            if ylo[j0] > yhi[i0] or ylo[i0] > yhi[j0]:
                continue
            i = min(i0, j0)
            j = max(i0, j0)
            if j < i + 2 or (i == 0 and j == n - 1):
                continue
            if best[0] >= 0 and (i > best[0] or (i == best[0] and j >= best[1])):
                continue
            if _segments_near(p, q, i, j, tol):
                best[0] = i
                best[1] = j
    return best


#: Mask tracing (:mod:`~scenespeak.spatial.forces._trace`), compiled.
trace_links = jit(_trace.links_loop)
trace_rings = jit(_trace.follow_rings)
