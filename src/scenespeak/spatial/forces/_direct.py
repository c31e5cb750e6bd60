"""One compiled call for the force histograms of two polygons (private; compiled by Numba).

:func:`~scenespeak.spatial.forces.force_histograms` of two ``(N, 2)`` float64 vertex arrays
spends more time in Python validating, preparing and checking (``guards``, ``prepare``, the
contact test, packing, the final check: about 150 small NumPy operations) than in the sweep
of a small pair. :func:`pair_histograms` does the same steps in one compiled call, for the
case where there is nothing to report: finite vertices, no repeated vertex, coordinates of
ordinary size, a clearly non-zero area, a simple polygon, bounding boxes apart when the
exponents need it, a histogram that passes :func:`~scenespeak.spatial.forces.guards.
checked_histogram`. Whenever any of these does not hold, or a decision is within rounding of
its threshold (the area, the turning angle, a fold), it returns status 1 and the caller runs
the general Python path, which raises the same :class:`~scenespeak.errors.InputError` with the
same message as always, or handles the case (overlap, contact, rescaling).

On the path it takes, the result is bit for bit the one of the Python path: the same oriented
vertices, relative to the same origin, go to the same sweep (``tests/spatial/
test_forces_direct.py`` checks that, and that the decisions agree, on random, degenerate and
near-threshold polygons).
"""

from __future__ import annotations

import math

import numpy as np

from scenespeak.spatial.forces._convex import convex_pair
from scenespeak.spatial.forces._jit import jit
from scenespeak.spatial.forces._shapes import first_contact
from scenespeak.spatial.forces._sweep import sweep

# regions._LENGTH_TOL and regions._AREA_TOL (kept equal by a test).
LENGTH_TOL = 1e-10
AREA_TOL = 1e-10
# guards._SCALE_RANGE and the "far" bound of guards.normalise_pair.
SCALE_LO = 1e-6
SCALE_HI = 1e6
FAR = 1e12


@jit
def _plain(p: np.ndarray) -> bool:
    """Finite vertices, at least 3, no vertex equal to the next one (cyclically)."""
    n = p.shape[0]
    if n < 3:
        return False
    for i in range(n):
        if not (math.isfinite(p[i, 0]) and math.isfinite(p[i, 1])):
            return False
        j = i + 1 if i + 1 < n else 0
        if p[i, 0] == p[j, 0] and p[i, 1] == p[j, 1]:
            return False
    return True


@jit
def _ordinary_size(a: np.ndarray, b: np.ndarray) -> bool:
    """``guards.normalise_pair`` leaves the pair as given (size 1e-6..1e6, |x| <= 1e12)."""
    extent = 0.0
    far = 0.0
    for k in range(2):
        lo = min(a[:, k].min(), b[:, k].min())
        hi = max(a[:, k].max(), b[:, k].max())
        extent = max(extent, hi - lo)
        far = max(far, abs(lo), abs(hi))
    return SCALE_LO <= extent <= SCALE_HI and far <= FAR


@jit
def _scale(p: np.ndarray) -> float:
    return max(p[:, 0].max() - p[:, 0].min(), p[:, 1].max() - p[:, 1].min())


@jit
def _area(p: np.ndarray) -> float:
    """Shoelace area (as ``geometry.polygon_area``, up to the summation order)."""
    n = p.shape[0]
    s1 = 0.0
    s2 = 0.0
    for i in range(n):
        j = i + 1 if i + 1 < n else 0
        s1 += p[i, 0] * p[j, 1]
        s2 += p[j, 0] * p[i, 1]
    return 0.5 * (s1 - s2)


@jit
def _shape(p: np.ndarray, scale: float) -> int:
    """0 convex, 1 simple and not convex, -1 the Python path must decide (or raise).

    The turns are computed with the same operations as ``regions._is_convex`` (the same
    floats); the turning-angle sum and the fold test fall back within a margin of their
    thresholds, where the last bits of ``arctan2`` or ``norm`` could decide.
    """
    n = p.shape[0]
    tol = LENGTH_TOL * scale * scale
    convex = True
    total = 0.0
    for i in range(n):
        j = i + 1 if i + 1 < n else 0
        k = j + 1 if j + 1 < n else 0
        ex = p[j, 0] - p[i, 0]
        ey = p[j, 1] - p[i, 1]
        fx = p[k, 0] - p[j, 0]
        fy = p[k, 1] - p[j, 1]
        turn = ex * fy - ey * fx
        dot = ex * fx + ey * fy
        if not turn >= -tol:
            convex = False
        total += math.atan2(turn, dot)
        if dot < 0.0 and abs(turn) <= 2e-12 * (math.hypot(ex, ey) * math.hypot(fx, fy)):
            return -1  # a fold (or close to one): the Python path raises or decides
    if convex:
        off = abs(abs(total - 2.0 * math.pi) - 1e-6)
        if off <= 1e-8:
            return -1
        if abs(total - 2.0 * math.pi) < 1e-6:
            return 0
    if n >= 4:
        q = np.empty_like(p)
        q[: n - 1] = p[1:]
        q[n - 1] = p[0]
        if first_contact(p, q, LENGTH_TOL * scale)[0] >= 0:
            return -1  # not simple: the Python path raises
    return 1


@jit
def _oriented(p: np.ndarray) -> tuple[np.ndarray, int]:
    """``(counter-clockwise copy, shape)`` of a polygon, shape -1 when the Python path must run."""
    scale = _scale(p)
    area = _area(p)
    if not scale > 0.0 or abs(area) <= 2.0 * AREA_TOL * scale * scale:
        return p, -1
    q = p[::-1].copy() if area < 0.0 else p.copy()
    return q, _shape(q, scale)


@jit
def _boxes_apart(a: np.ndarray, b: np.ndarray) -> bool:
    """``contact._contact``'s first test (the same operations on the same floats)."""
    scale = 0.0
    lo_a = np.empty(2)
    hi_a = np.empty(2)
    lo_b = np.empty(2)
    hi_b = np.empty(2)
    for k in range(2):
        lo_a[k] = a[:, k].min()
        hi_a[k] = a[:, k].max()
        lo_b[k] = b[:, k].min()
        hi_b[k] = b[:, k].max()
        scale = max(scale, max(hi_a[k], hi_b[k]) - min(lo_a[k], lo_b[k]))
    tol = LENGTH_TOL * scale
    for k in range(2):
        if lo_a[k] > hi_b[k] + tol or lo_b[k] > hi_a[k] + tol:
            return True
    return False


@jit
def _checked(h: np.ndarray) -> bool:
    """``guards.checked_histogram`` when it passes (rounding-level negatives cleared); False
    when it would raise."""
    for i in range(h.shape[0]):
        top = 0.0
        low = 0.0
        for k in range(h.shape[1]):
            x = h[i, k]
            if not math.isfinite(x):
                return False
            top = max(top, x)
            low = min(low, x)
        if not top > 0.0 or top < 1e-300:
            return False
        if low < 0.0:
            if -low > 1e-6 * top:
                return False
            for k in range(h.shape[1]):
                if h[i, k] < 0.0:
                    h[i, k] = 0.0
    return True


@jit
def _packed(pa: np.ndarray, pb: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(pts, region_start, origin)`` of the two polygons, as ``kernel._packed`` makes them:
    each polygon's vertices relative to its first vertex, end to end."""
    na = pa.shape[0]
    nb = pb.shape[0]
    pts = np.empty((na + nb, 2))
    for i in range(na):
        pts[i, 0] = pa[i, 0] - pa[0, 0]
        pts[i, 1] = pa[i, 1] - pa[0, 1]
    for i in range(nb):
        pts[na + i, 0] = pb[i, 0] - pb[0, 0]
        pts[na + i, 1] = pb[i, 1] - pb[0, 1]
    region_start = np.array([0, na, na + nb], dtype=np.int64)
    origin = np.empty((2, 2))
    origin[0] = pa[0]
    origin[1] = pb[0]
    return pts, region_start, origin


@jit
def _swept(
    pa: np.ndarray,
    pb: np.ndarray,
    convex: tuple[bool, bool],
    kernels: tuple[np.ndarray, np.ndarray],
    table: np.ndarray,
) -> np.ndarray:
    """``sweep`` of the pair (oriented polygons): F0 + F2 of two convex polygons straight by
    the chain walk (:func:`~scenespeak.spatial.forces._convex.convex_pair`, the same floats),
    anything else by the general sweep."""
    codes, rs = kernels
    pts, region_start, origin = _packed(pa, pb)
    if convex[0] and convex[1] and codes.size == 2 and codes[0] == 0 and codes[1] == 1:
        return convex_pair((pts, region_start, origin), table)
    na = pa.shape[0]
    nxt = np.empty(pts.shape[0], dtype=np.int64)
    for i in range(pts.shape[0]):
        nxt[i] = i + 1
    nxt[na - 1] = 0
    nxt[pts.shape[0] - 1] = na
    pair = np.zeros(1, dtype=np.int64)
    return sweep(
        (pts, nxt, region_start, origin, np.array([convex[0], convex[1]])),
        pair,
        pair + 1,
        np.zeros(1),
        (codes, rs),
        table.shape[0],
    )[0]


@jit
def pair_histograms(
    a: np.ndarray, b: np.ndarray, kernels: tuple[np.ndarray, np.ndarray], table: np.ndarray
) -> tuple[int, np.ndarray]:
    """``(0, histograms)`` of polygons ``a`` (argument) and ``b`` (referent), shape
    ``(kernels, directions)``, or ``(1, empty)`` when the Python path must run.

    ``kernels = (codes, rs)`` as for :func:`~scenespeak.spatial.forces._sweep.sweep`;
    ``table`` the directions' cosines and sines
    (:func:`~scenespeak.spatial.forces.kernel.direction_table`).
    """
    nothing = np.empty((0, 0))
    if not (_plain(a) and _plain(b) and _ordinary_size(a, b)):
        return 1, nothing
    pa, shape_a = _oriented(a)
    if shape_a < 0:
        return 1, nothing
    pb, shape_b = _oriented(b)
    if shape_b < 0:
        return 1, nothing
    if kernels[1].max() >= 1.0 and not _boxes_apart(pa, pb):
        return 1, nothing  # overlap and contact: the exact test of the Python path
    out = _swept(pa, pb, (shape_a == 0, shape_b == 0), kernels, table)
    if not _checked(out):
        return 1, nothing
    return 0, out
