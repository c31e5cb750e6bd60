"""The Histogram of Forces (Matsakis & Wendling 1999), exact for polygons, fast for masks.

For two plane objects A (the *argument*) and B (the *referent*) and a direction θ, the force
histogram ``F_r^{AB}(θ)`` sums, over every line of direction θ, the elementary forces
``d**-r`` between the points of A and the points of B that lie behind them in direction θ. It
is large when A lies in direction θ from B. ``r = 0`` (constant forces, "F0") depends on shape
and size only; ``r = 2`` (gravitational forces, "F2") weighs near parts more.

Method (see ``docs/forces.md``)
-------------------------------
Each object is turned into a set of oriented boundary edges (interior on the left). On one line
the four-term formula of forces.md pairs every endpoint of an A-section with every endpoint of a
B-section, so ``F(θ)`` is a signed sum over (edge of A, edge of B) of ``∫ Φ(s_A(v) - s_B(v)) dv``
over the range of lines both edges cross. Both ``s_A`` and ``s_B`` are linear in ``v``, so each
integral is closed-form (an antiderivative ``Ψ`` of ``Φ``). Only edge pairs whose line ranges
overlap contribute; they are found for a block of directions at once from one sort of the
vertices per direction and cumulative counts, so the cost is close to O((n + m) · directions)
for convex objects. No line is ever sampled: the result is exact up to rounding. With an even
number of directions only half are swept; the pairs give ``F(θ + π)`` too.

Masks are traced into polygons (marching squares at level 0.5, holes included) and computed
exactly in the same way.

Direction convention: ``h[k]`` is the value at angle ``2*pi*k/directions``; angle 0 is +x and
``pi/2`` is +y. For masks, +x is increasing column and +y is *decreasing* row (image "up").

Examples
--------
>>> import numpy as np
>>> from scenespeak.spatial.forces import force_histogram
>>> square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
>>> h = force_histogram(square + [3.0, 0.0], square, r=0.0, directions=4)
>>> h.round(6).tolist()   # A is to the right of B: everything at angle 0
[1.0, 0.0, 0.0, 0.0]
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from scenespeak.errors import InputError

__all__ = [
    "force_histogram",
    "force_histograms",
    "hybrid_histogram",
    "intersection_area",
    "polygon_area",
    "polygons_intersect",
]

FloatArray = NDArray[np.float64]

# Relative tolerances, scaled by the objects' size (lengths) or size squared (areas).
_LENGTH_TOL = 1e-10
_AREA_TOL = 1e-10
# Below this |h| / |m| the divided difference of Ψ is replaced by its Taylor series.
_TAYLOR_RATIO = 1e-3
# Largest temporary (elements) of the quadratic geometry tests; they run in chunks.
_CHUNK = 1 << 21
# Directions are swept in blocks of about this many (direction, vertex) entries.
_BLOCK = 4096
_BLOCK_PAIRS = 32768
# Default simplification of traced mask outlines, in pixels.
_MASK_TOLERANCE = 0.25


# --------------------------------------------------------------------------------------------
# Regions: oriented boundary edges, interior on the left.
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class _Region:
    """An object as a set of oriented boundary edges (interior on the left)."""

    start: FloatArray  # (E, 2) vertices; edge e runs from start[e] to end[e] = start[nxt[e]]
    end: FloatArray  # (E, 2)
    nxt: NDArray[np.intp]  # (E,) next vertex along the boundary
    prv: NDArray[np.intp]  # (E,) previous vertex
    area: float
    convex: bool
    name: str


def _next(p: NDArray[np.generic]) -> NDArray[np.generic]:
    """The array shifted by one along axis 0, cyclically: row i holds row i + 1."""
    return np.concatenate([p[1:], p[:1]])


def _shoelace(p: FloatArray) -> float:
    q = _next(p)
    return 0.5 * float(np.dot(p[:, 0], q[:, 1]) - np.dot(q[:, 0], p[:, 1]))


def _segment_distances(
    p1: FloatArray, q1: FloatArray, p2: FloatArray, q2: FloatArray
) -> FloatArray:
    """Distances between segments ``p1q1`` and ``p2q2`` (broadcasting over leading axes)."""

    def cross(a: FloatArray, b: FloatArray) -> FloatArray:
        return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]

    def point_seg(p: FloatArray, a: FloatArray, b: FloatArray) -> FloatArray:
        ab = b - a
        ap = p - a
        den = np.einsum("...i,...i->...", ab, ab)
        with np.errstate(invalid="ignore", divide="ignore"):
            t = np.where(den > 0, np.einsum("...i,...i->...", ap, ab) / den, 0.0)
        t = np.clip(t, 0.0, 1.0)
        diff = ap - t[..., None] * ab
        return np.sqrt(np.einsum("...i,...i->...", diff, diff))

    d1 = cross(q2 - p2, p1 - p2)
    d2 = cross(q2 - p2, q1 - p2)
    d3 = cross(q1 - p1, p2 - p1)
    d4 = cross(q1 - p1, q2 - p1)
    proper = (d1 * d2 < 0) & (d3 * d4 < 0)
    dist = np.minimum(
        np.minimum(point_seg(p1, p2, q2), point_seg(q1, p2, q2)),
        np.minimum(point_seg(p2, p1, q1), point_seg(q2, p1, q1)),
    )
    return np.where(proper, 0.0, dist)


def _polygon_region(polygon: ArrayLike, name: str) -> _Region:
    """Validate a simple polygon given as an ``(N, 2)`` vertex array and orient it CCW."""
    try:
        p = np.array(polygon, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InputError(name, f"cannot be read as an (N, 2) array of vertices ({exc})") from exc
    if p.ndim != 2 or p.shape[1] != 2:
        hint = ""
        if p.ndim == 2 and np.asarray(polygon).dtype.kind in "uif":
            hint = " (a mask must have dtype bool: pass e.g. `mask > 0`)"
        raise InputError(
            name,
            f"expected an (N, 2) array of polygon vertices or a 2-D boolean mask, "
            f"got an array of shape {p.shape}{hint}",
        )
    if not np.isfinite(p).all():
        raise InputError(name, "polygon vertices contain NaN or infinite coordinates")
    # Drop repeated consecutive vertices (including a closing copy of the first one).
    if len(p) > 1:
        keep = (p != _next(p)).any(axis=1)
        if not keep.all():
            keep[-1] |= not keep.any()  # all equal: keep one
            p = p[keep]
    if len(p) < 3:
        raise InputError(name, f"a polygon needs at least 3 distinct vertices, got {len(p)}")
    scale = float((p.max(axis=0) - p.min(axis=0)).max())
    area = _shoelace(p)
    if scale == 0.0 or abs(area) <= _AREA_TOL * scale * scale:
        # A zero signed area with vertices off one line is a self-intersection (a bow tie).
        d = p - p[0]
        far = d[np.argmax(np.abs(d).sum(axis=1))]
        off_line = np.abs(d[:, 0] * far[1] - d[:, 1] * far[0]).max()
        if scale > 0.0 and float(off_line) > _AREA_TOL * scale * scale:
            _check_simple(p, _next(p), scale, name)
        raise InputError(name, "polygon has zero area (all vertices collinear or coincident)")
    if area < 0:
        p = p[::-1].copy()
        area = -area
    q = _next(p)
    e = q - p
    e_next = _next(e)
    turn = e[:, 0] * e_next[:, 1] - e[:, 1] * e_next[:, 0]
    # Convex: no right turn, and the edge directions go round exactly once.
    convex = bool((turn >= -_LENGTH_TOL * scale * scale).all())
    if convex:
        angles = np.arctan2(turn, e[:, 0] * e_next[:, 0] + e[:, 1] * e_next[:, 1])
        convex = abs(float(angles.sum()) - 2 * math.pi) < 1e-6
    if not convex:
        _check_simple(p, q, scale, name)
    n = len(p)
    idx = np.arange(n)
    return _Region(
        start=p,
        end=q,
        nxt=np.concatenate([idx[1:], idx[:1]]),
        prv=np.concatenate([idx[n - 1 :], idx[: n - 1]]),
        area=area,
        convex=convex,
        name=name,
    )


def _check_simple(p: FloatArray, q: FloatArray, scale: float, name: str) -> None:
    """Raise if the closed polygon ``p`` crosses or touches itself."""
    n = len(p)
    # Adjacent edges that fold back onto each other (a spike) overlap.
    e = q - p
    e_next = _next(e)
    turn = e[:, 0] * e_next[:, 1] - e[:, 1] * e_next[:, 0]
    dot = np.einsum("ij,ij->i", e, e_next)
    norms = np.linalg.norm(e, axis=1) * np.linalg.norm(e_next, axis=1)
    if np.any((np.abs(turn) <= 1e-12 * norms) & (dot < 0)):
        raise InputError(name, "polygon is not simple: an edge folds back onto the previous one")
    if n < 4:
        return
    i, j = _bbox_candidates(p, q, p, q, _LENGTH_TOL * scale)
    nonadjacent = (j >= i + 2) & ~((i == 0) & (j == n - 1))
    i, j = i[nonadjacent], j[nonadjacent]
    d = _segment_distances(p[i], q[i], p[j], q[j])
    bad = d <= _LENGTH_TOL * scale
    if np.any(bad):
        k = int(np.argmax(bad))
        raise InputError(
            name,
            f"polygon is not simple: edge {int(i[k])} and edge {int(j[k])} cross or touch "
            "(self-intersecting polygons are not supported; split them into simple ones)",
        )


def _region(obj: ArrayLike, name: str, mask_tolerance: float) -> _Region:
    arr = np.asarray(obj)
    if arr.dtype == np.bool_:
        return _mask_region(arr, name, mask_tolerance)
    return _polygon_region(arr, name)


def _mask_region(mask: NDArray[np.bool_], name: str, tolerance: float) -> _Region:
    """Trace a boolean mask into oriented boundary edges (holes included).

    Pixel ``(row, col)`` has its centre at ``(x, y) = (col, -row)``. The outline is the
    marching-squares iso-line at level 0.5 (half-way between inside and outside pixel centres,
    which is where the outline of a polygon rasterised by pixel centres lies), simplified by
    Douglas-Peucker to within ``tolerance`` pixels.
    """
    import cv2
    from skimage.measure import find_contours

    if mask.ndim != 2:
        raise InputError(name, f"a mask must be a 2-D boolean array, got shape {mask.shape}")
    rows = np.flatnonzero(mask.any(axis=1))
    if rows.size == 0:
        raise InputError(name, "mask is empty (no pixel set): there is no object to measure")
    cols = np.flatnonzero(mask.any(axis=0))
    r0, c0 = int(rows[0]), int(cols[0])
    # Trace only the bounding box (padded by one pixel so that every outline closes).
    padded = np.pad(mask[r0 : int(rows[-1]) + 1, c0 : int(cols[-1]) + 1], 1).astype(np.float64)
    contours = find_contours(padded, 0.5, fully_connected="high", positive_orientation="high")
    starts: list[FloatArray] = []
    ends: list[FloatArray] = []
    nxts: list[NDArray[np.intp]] = []
    prvs: list[NDArray[np.intp]] = []
    total = 0
    area = 0.0
    for c in contours:
        if len(c) > 1 and np.array_equal(c[0], c[-1]):
            c = c[:-1]
        if tolerance > 0 and len(c) > 4:
            # Marching-squares vertices sit on the half-pixel grid: exact in float32.
            kept = cv2.approxPolyDP(c.astype(np.float32)[:, None, :], tolerance, True)
            if len(kept) >= 3:  # else keep the (tiny) ring as traced
                c = kept[:, 0, :].astype(np.float64)
        # (row, col) in the padded crop → (x, y) = (column, -row) in the mask
        xy = np.column_stack([c[:, 1] + (c0 - 1.0), (1.0 - r0) - c[:, 0]])
        if len(xy) < 3:
            continue
        a = _shoelace(xy)
        if a == 0.0:
            continue
        area += a
        starts.append(xy)
        ends.append(_next(xy))
        idx = total + np.arange(len(xy))
        nxts.append(_next(idx))
        prvs.append(np.concatenate([idx[-1:], idx[:-1]]))
        total += len(xy)
    if not starts or area <= 0:
        raise InputError(name, "mask outline has zero area")
    start = np.concatenate(starts)
    end = np.concatenate(ends)
    return _Region(
        start=start,
        end=end,
        nxt=np.concatenate(nxts),
        prv=np.concatenate(prvs),
        area=area,
        convex=False,
        name=name,
    )


# --------------------------------------------------------------------------------------------
# Geometry helpers on regions.
# --------------------------------------------------------------------------------------------


def _winding(points: FloatArray, reg: _Region) -> NDArray[np.int64]:
    """Winding numbers of ``points`` (P, 2) with respect to the region's oriented edges."""
    out = np.empty(len(points), dtype=np.int64)
    ax, ay = reg.start[:, 0][None, :], reg.start[:, 1][None, :]
    bx, by = reg.end[:, 0][None, :], reg.end[:, 1][None, :]
    step = max(1, _CHUNK // max(len(reg.start), 1))
    for k in range(0, len(points), step):
        px = points[k : k + step, 0][:, None]
        py = points[k : k + step, 1][:, None]
        side = (bx - ax) * (py - ay) - (by - ay) * (px - ax)
        up = (ay <= py) & (by > py) & (side > 0)
        down = (ay > py) & (by <= py) & (side < 0)
        out[k : k + step] = up.sum(axis=1) - down.sum(axis=1)
    return out


def _scale(a: _Region, b: _Region) -> float:
    pts = np.concatenate([a.start, b.start])
    return float((pts.max(axis=0) - pts.min(axis=0)).max())


def _bbox_candidates(
    p1: FloatArray, q1: FloatArray, p2: FloatArray, q2: FloatArray, tol: float
) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """Index pairs of segments ``p1q1[i]``, ``p2q2[j]`` whose bounding boxes come within tol."""
    lo1 = np.minimum(p1, q1) - tol
    hi1 = np.maximum(p1, q1) + tol
    lo2 = np.minimum(p2, q2)
    hi2 = np.maximum(p2, q2)
    step = max(1, _CHUNK // max(len(p2), 1))
    found_i: list[NDArray[np.intp]] = []
    found_j: list[NDArray[np.intp]] = []
    for k in range(0, len(p1), step):
        l1, h1 = lo1[k : k + step], hi1[k : k + step]
        ok = (l1[:, None, 0] <= hi2[None, :, 0]) & (lo2[None, :, 0] <= h1[:, None, 0])
        ok &= (l1[:, None, 1] <= hi2[None, :, 1]) & (lo2[None, :, 1] <= h1[:, None, 1])
        i, j = np.nonzero(ok)
        found_i.append(i + k)
        found_j.append(j)
    if not found_i:
        return np.zeros(0, np.intp), np.zeros(0, np.intp)
    return np.concatenate(found_i), np.concatenate(found_j)


def _boundaries_touch(a: _Region, b: _Region, tol: float) -> bool:
    """Whether some edge of ``a`` comes within ``tol`` of some edge of ``b``."""
    i, j = _bbox_candidates(a.start, a.end, b.start, b.end, tol)
    if i.size == 0:
        return False
    d = _segment_distances(a.start[i], a.end[i], b.start[j], b.end[j])
    return bool(d.min() <= tol)


def _boundary_part_inside(
    a: _Region, b: _Region, keep_shared: bool, origin: FloatArray, scale: float
) -> float:
    """``∮ x dy`` over the part of ``a``'s boundary inside ``b`` (Green's theorem).

    Every edge of ``a`` is split where it crosses an edge of ``b`` (and where a vertex of ``b``
    lies on it); each piece is kept if its midpoint is inside ``b``. Pieces lying on ``b``'s
    boundary are kept (``keep_shared``) only if both interiors are on the same side.
    """
    p, q = a.start - origin, a.end - origin
    f0, f1 = b.start - origin, b.end - origin
    tol = 1e-9 * scale
    i, j = _bbox_candidates(p, q, f0, f1, tol)
    e = q[i] - p[i]
    g = f1[j] - f0[j]
    w = f0[j] - p[i]
    den = e[:, 0] * g[:, 1] - e[:, 1] * g[:, 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (w[:, 0] * g[:, 1] - w[:, 1] * g[:, 0]) / den
        u = (w[:, 0] * e[:, 1] - w[:, 1] * e[:, 0]) / den
        crossing = (den != 0) & (t > 0) & (t < 1) & (u >= 0) & (u <= 1)
        # Vertices of b lying on a's edges (collinear overlaps) split too.
        tv = (w[:, 0] * e[:, 0] + w[:, 1] * e[:, 1]) / (e[:, 0] ** 2 + e[:, 1] ** 2)
    foot = p[i] + tv[:, None] * e
    on = (np.hypot(*(foot - f0[j]).T) <= tol) & (tv > 0) & (tv < 1)
    n_edges = len(p)
    edge = np.concatenate([np.arange(n_edges), np.arange(n_edges), i[crossing], i[on]])
    par = np.concatenate([np.zeros(n_edges), np.ones(n_edges), t[crossing], tv[on]])
    order = np.lexsort((par, edge))
    edge, par = edge[order], par[order]
    piece = (edge[1:] == edge[:-1]) & (par[1:] > par[:-1])
    ei, t0, t1 = edge[:-1][piece], par[:-1][piece], par[1:][piece]
    d = q[ei] - p[ei]
    a0 = p[ei] + t0[:, None] * d
    a1 = p[ei] + t1[:, None] * d
    mid = 0.5 * (a0 + a1)
    # Pieces lying on b's boundary.
    pk, pj = _bbox_candidates(mid, mid, f0, f1, tol)
    near = _segment_distances(mid[pk], mid[pk], f0[pj], f1[pj]) <= tol
    pk, pj = pk[near], pj[near]
    on_b = np.zeros(len(mid), bool)
    on_b[pk] = True
    same = np.zeros(len(mid), bool)
    same[pk[np.einsum("ij,ij->i", (a1 - a0)[pk], f1[pj] - f0[pj]) > 0]] = True
    inside = np.zeros(len(mid), bool)
    rest = np.flatnonzero(~on_b)
    inside[rest] = _winding(mid[rest] + origin, b) != 0
    keep = np.where(on_b, same & keep_shared, inside)
    xdy = 0.5 * (a0[:, 0] + a1[:, 0]) * (a1[:, 1] - a0[:, 1])
    return float(np.sum(xdy[keep]))


def _intersection_area(a: _Region, b: _Region) -> float:
    origin = a.start[0]
    scale = max(_scale(a, b), 1e-300)
    area = _boundary_part_inside(a, b, True, origin, scale) + _boundary_part_inside(
        b, a, False, origin, scale
    )
    return max(area, 0.0)


def _boxes_apart(
    lo_a: list[float], hi_a: list[float], lo_b: list[float], hi_b: list[float]
) -> bool:
    """:func:`_contact`'s first test (bounding boxes apart), on Python floats: the same
    operations on the same numbers, without the small-array overhead."""
    scale = max(max(hi_a[k], hi_b[k]) - min(lo_a[k], lo_b[k]) for k in (0, 1))
    tol = _LENGTH_TOL * scale
    return any(lo_a[k] > hi_b[k] + tol or lo_b[k] > hi_a[k] + tol for k in (0, 1))


def _contact(a: _Region, b: _Region) -> tuple[float, bool]:
    """Return (area of A∩B, whether the boundaries touch or cross)."""
    lo_a, hi_a = a.start.min(axis=0), a.start.max(axis=0)
    lo_b, hi_b = b.start.min(axis=0), b.start.max(axis=0)
    scale = float((np.maximum(hi_a, hi_b) - np.minimum(lo_a, lo_b)).max())
    tol = _LENGTH_TOL * scale
    if (lo_a > hi_b + tol).any() or (lo_b > hi_a + tol).any():
        return 0.0, False  # bounding boxes apart
    if not _boundaries_touch(a, b, tol):
        # Boundaries apart: the interiors overlap only if one contains the other.
        if _winding(a.start[:1], b)[0] != 0:
            return a.area, False
        if _winding(b.start[:1], a)[0] != 0:
            return b.area, False
        return 0.0, False
    inter = _intersection_area(a, b)
    if inter <= _AREA_TOL * scale * scale:
        inter = 0.0
    return inter, True


# --------------------------------------------------------------------------------------------
# Kernels: Φ (Φ'' = φ, Φ(u) = 0 for u <= 0) and its antiderivative Ψ, for u > 0.
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class _Kernel:
    """Elementary force ``φ(d) = d**-r`` (``y0 = 0``) or ``1 / max(d, y0)**2`` (hybrid)."""

    r: float
    y0: float = 0.0

    def force(self, u: FloatArray) -> FloatArray:
        if self.y0 > 0:
            return 1.0 / np.maximum(u, self.y0) ** 2
        if self.r == 0:
            return np.ones_like(u)
        return u ** (-self.r)

    def big_phi(self, u: FloatArray) -> FloatArray:
        r = self.r
        if self.y0 > 0:
            y0 = self.y0
            low = u * u / (2 * y0 * y0)
            with np.errstate(divide="ignore", invalid="ignore"):
                high = 2 * u / y0 - 1.5 - np.log(u / y0)
            return np.where(u <= y0, low, high)
        if r == 0:
            return 0.5 * u * u
        if r == 1:
            return u * np.log(u)
        if r == 2:
            return -np.log(u)
        return u ** (2 - r) / ((1 - r) * (2 - r))

    def psi(self, u: FloatArray) -> FloatArray:
        r = self.r
        if self.y0 > 0:
            y0 = self.y0
            low = u**3 / (6 * y0 * y0)
            with np.errstate(divide="ignore", invalid="ignore"):
                high = u * u / y0 - 0.5 * u - u * np.log(u / y0) - y0 / 3
            return np.where(u <= y0, low, high)
        if r == 0:
            return u * u * u / 6.0
        if r == 1:
            return 0.5 * u * u * np.log(u) - 0.25 * u * u
        if r == 2:
            return u - u * np.log(u)
        if r == 3:
            return 0.5 * np.log(u)
        return u ** (3 - r) / ((1 - r) * (2 - r) * (3 - r))


def _mean_phi(kernel: _Kernel, a0: FloatArray, a1: FloatArray) -> FloatArray:
    """Mean of ``Φ⁺`` over an interval on which the gap goes linearly from a0 to a1 (>= 0).

    ``Φ⁺`` is ``Φ`` on ``u > 0`` and 0 at ``u = 0``. The mean is
    ``(Ψ(a1) - Ψ(a0)) / (a1 - a0)`` (``Ψ' = Φ``, ``Ψ(0) = 0``), replaced by its Taylor series
    about the midpoint, ``Φ(m) + φ(m) (a1 - a0)² / 24``, when ``a1 - a0`` is tiny next to ``m``.
    """
    h = a1 - a0
    m = 0.5 * (a0 + a1)
    small = np.abs(h) <= _TAYLOR_RATIO * m
    pos0 = a0 > 0
    pos1 = a1 > 0
    p0 = np.where(pos0, kernel.psi(np.where(pos0, a0, 1.0)), 0.0)
    p1 = np.where(pos1, kernel.psi(np.where(pos1, a1, 1.0)), 0.0)
    out = (p1 - p0) / np.where(small, 1.0, h)
    idx = np.flatnonzero(small)
    if idx.size:
        ms, hh = m[idx], h[idx]
        safe = np.where(ms > 0, ms, 1.0)
        taylor = kernel.big_phi(safe) + kernel.force(safe) * hh * hh / 24.0
        out[idx] = np.where(ms > 0, taylor, 0.0)
    return out


# --------------------------------------------------------------------------------------------
# The edge-pair engine.
# --------------------------------------------------------------------------------------------


def _expand(start: NDArray[np.intp], end: NDArray[np.intp]) -> tuple[NDArray[np.intp], ...]:
    """Rows and positions of all ``range(start[i], end[i])`` concatenated."""
    counts = np.maximum(end - start, 0)
    csum = np.cumsum(counts)
    total = int(csum[-1]) if len(csum) else 0
    rows = np.repeat(np.arange(len(start)), counts)
    pos = np.arange(total) + (start + counts - csum)[rows]
    return rows, pos


@dataclass(frozen=True)
class _Pairs:
    """Edge pairs of A and B whose ranges of lines overlap, in every direction swept.

    ``a``/``b`` index the columns of the (5, D*E) edge attributes ``[v_lo, v_hi, s(v_lo),
    ds/dv, sign(dv)]``; ``direction`` is the row d of each pair.
    """

    a: NDArray[np.intp]
    b: NDArray[np.intp]
    direction: NDArray[np.intp]
    attrs: FloatArray


def _edge_attributes(
    v0: FloatArray, s0: FloatArray, v1: FloatArray, s1: FloatArray
) -> tuple[FloatArray, NDArray[np.bool_]]:
    """Edges from (s0, v0) to (s1, v1) as ``[v_lo, v_hi, s(v_lo), ds/dv, sign(dv)]``.

    Returns the (5, *v0.shape) attributes and which edges run downwards in ``v`` (their lower
    vertex is the end).
    """
    down = v1 < v0
    attrs = np.empty((5, *v0.shape))
    np.minimum(v0, v1, out=attrs[0])
    np.maximum(v0, v1, out=attrs[1])
    np.copyto(attrs[2], s0)
    np.copyto(attrs[2], s1, where=down)
    dv = v1 - v0
    np.divide(s1 - s0, np.where(dv != 0, dv, np.inf), out=attrs[3])
    np.sign(dv, out=attrs[4])
    return attrs, down


def _pairs(a: _Region, b: _Region, c: FloatArray, s: FloatArray) -> _Pairs:
    """All (edge of A, edge of B) pairs whose v-ranges overlap, for each direction (c, s).

    Both regions' vertices are put in one table (A first). Edge ``e`` runs from vertex ``e``
    to vertex ``nxt[e]``; ``low[e]``/``high[e]`` are its lower and upper vertices in ``v``.
    The vertices of both regions are sorted by ``v`` in each direction; ``≺`` is that order (a
    total order; ties broken arbitrarily). A pair overlaps iff ``low_e ≺ low_f ≺ high_e`` or
    ``low_f ≺ low_e ≺ high_f``: that finds every pair with a common range of positive length
    exactly once (pairs tied at a single ``v`` may come too; they weigh nothing). Cumulative
    counts of lower vertices along the order give, for every edge, the contiguous run (in the
    other region's edges sorted by lower vertex) that satisfies its case.
    """
    n, m = len(a.start), len(b.start)
    width = n + m
    n_dir = len(c)
    centre = 0.5 * (a.start[0] + b.start[0])
    pts = np.concatenate([a.start, b.start]) - centre
    nxt = np.concatenate([a.nxt, b.nxt + n])
    prv = np.concatenate([a.prv, b.prv + n])
    sv = (pts @ np.concatenate([np.stack([c, s]), np.stack([-s, c])], axis=1)).T
    s_all = sv[:n_dir]  # (D, N): position along u = (cos, sin)
    v_all = sv[n_dir:]  # position across, along n = (-sin, cos)
    # Directions in which no line meets both objects (A's range of v strictly below or above
    # B's) have no pair at all: every A-vertex comes before every B-vertex in the order, or
    # after. Leaving them out changes nothing else: the other rows, their pairs and the
    # pairs' order are the same.
    v_a, v_b = v_all[:, :n], v_all[:, n:]
    apart = (v_a.max(axis=1) < v_b.min(axis=1)) | (v_b.max(axis=1) < v_a.min(axis=1))
    kept: NDArray[np.intp] | None = None
    if apart.any():
        kept = np.flatnonzero(~apart)
        if kept.size == 0:
            none = np.zeros(0, dtype=np.intp)
            return _Pairs(a=none, b=none, direction=none, attrs=np.zeros((5, 0)))
        s_all, v_all = s_all[kept], v_all[kept]
        n_dir = kept.size
    attrs, down = _edge_attributes(v_all, s_all, v_all[:, nxt], s_all[:, nxt])
    idx = np.arange(width)
    low = idx + down * (nxt - idx)
    # Per vertex: how many edges it is the lower vertex of (0, 1, 2); an edge that shares its
    # lower vertex with the previous edge ranks second among the two.
    starts_low = ~down
    incoming_low = down[:, prv]
    mult = starts_low.astype(np.intp) + incoming_low
    second = starts_low & incoming_low

    row = np.arange(n_dir)[:, None]
    order = np.argsort(v_all, axis=1)
    is_b = order >= n
    order = (order + row * width).ravel()
    ms = mult.ravel()[order].reshape(n_dir, width)
    ma = np.where(is_b, 0, ms)
    mb = ms - ma
    # Per vertex: d*n + the number of A-edges whose lower vertex comes before it in the order
    # of direction d (cnt_a), and d*m + the same for B-edges (cnt_b). One cumulative sum runs
    # over all directions: each direction has n lower ends of A-edges and m of B-edges.
    cnt_a = np.empty(n_dir * width, dtype=np.intp)
    cnt_b = np.empty(n_dir * width, dtype=np.intp)
    ma = ma.ravel()
    mb = mb.ravel()
    cnt_a[order] = np.cumsum(ma) - ma
    cnt_b[order] = np.cumsum(mb) - mb
    flat_low = low + row * width
    flat_high = (nxt + idx - low) + row * width
    low_a, low_b = flat_low[:, :n].ravel(), flat_low[:, n:].ravel()
    high_a, high_b = flat_high[:, :n].ravel(), flat_high[:, n:].ravel()
    # Flat ids of the edges (columns of attrs), and the same sorted by lower vertex per
    # direction, B's block first, then A's.
    edges_a = (idx[:n] + row * width).ravel()
    edges_b = (idx[n:] + row * width).ravel()
    a_block = n_dir * m  # by_lo holds B's edges, then A's
    by_lo = np.empty(n_dir * width, dtype=np.intp)
    by_lo[cnt_b[low_b] + second[:, n:].ravel()] = edges_b
    by_lo[cnt_a[low_a] + (second[:, :n].ravel() + a_block)] = edges_a
    # Case 1, per A-edge: the B-edges with low_e ≺ low_f ≺ high_e (a run in B's block).
    # Case 2, per B-edge: the A-edges with low_f ≺ low_e ≺ high_f (a run in A's block).
    start = np.concatenate([cnt_b[low_a], cnt_a[low_b] + a_block])
    end = np.concatenate([cnt_b[high_a], cnt_a[high_b] + a_block])
    rows, pos = _expand(start, end)
    first = np.concatenate([edges_a, edges_b])[rows]
    other = by_lo[pos]
    case1 = rows < n_dir * n
    ia = np.where(case1, first, other)
    ib = np.where(case1, other, first)
    direction = ia // width
    return _Pairs(
        a=ia,
        b=ib,
        direction=direction if kept is None else kept[direction],
        attrs=attrs.reshape(5, -1),
    )


def _edge_pair_histograms(
    a: _Region, b: _Region, kernels: list[_Kernel], directions: int
) -> FloatArray:
    """Histograms for several kernels at once, shape ``(len(kernels), directions)``.

    With an even number of directions only the first half is swept: reversing the direction
    turns every ``d = s_A - s_B`` into ``-d`` and leaves the pairs and weights as they are, so
    the same pairs give ``F(θ + π)`` through ``Φ⁺(-d)``.
    """
    half = directions // 2 if directions % 2 == 0 else directions
    theta = 2.0 * np.pi * np.arange(half) / directions
    cos, sin = np.cos(theta), np.sin(theta)
    out = np.empty((len(kernels), directions))
    # Sweep the directions in blocks so that the temporaries stay small (cache-resident).
    width = len(a.start) + len(b.start)
    block = first_block = half if half * width <= 4 * _BLOCK else max(1, _BLOCK // width)
    first = 0
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        while first < half:
            rows = slice(first, min(first + block, half))
            first = rows.stop
            pairs = _pairs(a, b, cos[rows], sin[rows])
            # Next block: about _BLOCK_PAIRS pairs, judging by this one.
            per_row = max(len(pairs.a), 1) / (rows.stop - rows.start)
            block = max(1, min(int(_BLOCK_PAIRS / per_row), 4 * first_block))
            n_rows = rows.stop - rows.start
            for i, values in enumerate(_bin_values(pairs, kernels, n_rows, 2 * n_rows)):
                out[i, rows] = values[:n_rows]
                if half < directions:
                    out[i, rows.start + half : rows.stop + half] = values[n_rows:]
    return out


def _bin_values(
    pairs: _Pairs, kernels: list[_Kernel], n_rows: int, n_bins: int
) -> list[FloatArray]:
    """Sum every edge pair's force into its bin, for each kernel (arrays of ``n_bins``).

    A pair's bin is ``pairs.direction`` where the gap ``d = s_A - s_B`` is positive and
    ``pairs.direction + n_rows`` (the opposite direction) where it is negative.
    """
    lo_a, hi_a, s_a, k_a, sg_a = np.take(pairs.attrs, pairs.a, axis=1)
    lo_b, hi_b, s_b, k_b, sg_b = np.take(pairs.attrs, pairs.b, axis=1)
    lo = np.maximum(lo_a, lo_b)
    hi = np.minimum(hi_a, hi_b)
    d0 = (s_a + k_a * (lo - lo_a)) - (s_b + k_b * (lo - lo_b))
    d1 = (s_a + k_a * (hi - lo_a)) - (s_b + k_b * (hi - lo_b))
    # A-edges count + where they leave A (exit), B-edges + where they enter B.
    weight = (sg_a * sg_b) * np.minimum(lo - hi, 0.0)
    # A pair serves direction θ where d > 0 and θ + π where d < 0 (bin + n_rows). A pair
    # whose gap changes sign is split at the zero into one part for each.
    bins = pairs.direction + n_rows * ((d0 + d1) < 0)
    g0, g1 = np.abs(d0), np.abs(d1)
    cross = np.flatnonzero(d0 * d1 < 0)
    if cross.size:
        c0, c1, cw = d0[cross], d1[cross], weight[cross]
        frac = np.maximum(c0, c1) / (np.abs(c0) + np.abs(c1))
        g0[cross] = 0.0
        g1[cross] = np.maximum(c0, c1)
        weight[cross] = cw * frac
        bins[cross] = pairs.direction[cross]
        g0 = np.concatenate([g0, np.zeros(cross.size)])
        g1 = np.concatenate([g1, -np.minimum(c0, c1)])
        weight = np.concatenate([weight, cw * (1.0 - frac)])
        bins = np.concatenate([bins, pairs.direction[cross] + n_rows])
    return [
        np.bincount(bins, weights=weight * _mean_phi(kernel, g0, g1), minlength=n_bins)
        for kernel in kernels
    ]


def _many_pairs(items: Sequence[tuple[_Region, _Region]], c: FloatArray, s: FloatArray) -> _Pairs:
    """:func:`_pairs` of several pairs of regions at once, for the same directions (c, s).

    Each pair's vertices are projected and sorted exactly as :func:`_pairs` does (the same
    products, the same argsort of the same rows); the rows of all pairs then go through the
    cumulative counts together, laid end to end (row ``r`` of pair ``p`` is one run of
    ``n_p + m_p`` entries). ``direction`` is ``2 * len(c) * p + d`` for direction row ``d`` of
    pair ``p``. Restricted to one pair, the pairs found and their order are those of
    :func:`_pairs`, so binned sums are the same floats.
    """
    n_dir = len(c)
    dirs = np.concatenate([np.stack([c, s]), np.stack([-s, c])], axis=1)
    # Rows where the objects' ranges of v are apart have no pair (see _pairs). Here the ranges
    # come from each region's own vertices, once per region, and a row is left out only when
    # they are apart by more than 1e-9 times the coordinates' size: the pair's own positions
    # (taken from a shifted origin) differ from these by a few ulps of that size, so such a
    # row is apart in them too. A row kept although apart finds no pair either.
    extent: dict[int, tuple[FloatArray, FloatArray, float]] = {}
    for a, b in items:
        for r in (a, b):
            if id(r) not in extent:
                v = r.start @ dirs[:, n_dir:]
                extent[id(r)] = (v.min(axis=0), v.max(axis=0), float(np.abs(r.start).max()))
    lo_a, hi_a, size_a = zip(*(extent[id(a)] for a, _ in items), strict=True)
    lo_b, hi_b, size_b = zip(*(extent[id(b)] for _, b in items), strict=True)
    margin = 1e-9 * np.maximum(size_a, size_b)[:, None]
    apart_all = (np.stack(hi_a) < np.stack(lo_b) - margin) | (
        np.stack(hi_b) < np.stack(lo_a) - margin
    )
    vs, ss, orders, rows_kept, direction = [], [], [], [], []
    widths, firsts, nxt_local, prv_local = [], [], [], []
    for k, (a, b) in enumerate(items):
        kept = np.flatnonzero(~apart_all[k])
        if kept.size == 0:
            continue
        n, m = len(a.start), len(b.start)
        centre = 0.5 * (a.start[0] + b.start[0])
        sv = ((np.concatenate([a.start, b.start]) - centre) @ dirs).T
        s_all = sv[:n_dir]
        v_all = sv[n_dir:]
        if kept.size < n_dir:
            s_all, v_all = s_all[kept], v_all[kept]
        vs.append(v_all.ravel())
        ss.append(s_all.ravel())
        orders.append(np.argsort(v_all, axis=1).ravel())
        direction.append(2 * n_dir * k + kept)
        rows_kept.append(kept.size)
        widths.append(n + m)
        firsts.append(n)
        nxt_local.append(np.concatenate([a.nxt, b.nxt + n]))
        prv_local.append(np.concatenate([a.prv, b.prv + n]))
    if not vs:
        none = np.zeros(0, dtype=np.intp)
        return _Pairs(a=none, b=none, direction=none, attrs=np.zeros((5, 0)))
    # Entry e is column col[e] of a row that starts at entry row0[e]; its pair's vertex tables
    # (concatenated over the pairs) start at table0[e].
    row_width = np.repeat(widths, rows_kept)
    row_start = np.cumsum(row_width) - row_width
    base = int(row_width.sum())
    row0 = np.repeat(row_start, row_width)
    col = np.arange(base) - row0
    table_start = np.cumsum(widths) - widths
    table = np.repeat(table_start, rows_kept)
    table0 = np.repeat(table, row_width) + col
    v_all, s_all = np.concatenate(vs), np.concatenate(ss)
    nxt = row0 + np.concatenate(nxt_local)[table0]
    prv = row0 + np.concatenate(prv_local)[table0]
    order = row0 + np.concatenate(orders)
    b_vertex = col >= np.repeat(np.repeat(firsts, rows_kept), row_width)
    entry_direction = np.repeat(np.concatenate(direction), row_width)
    idx = np.arange(base)
    attrs, down = _edge_attributes(v_all, s_all, v_all[nxt], s_all[nxt])
    low = idx + down * (nxt - idx)
    starts_low = ~down
    incoming_low = down[prv]
    mult = starts_low.astype(np.intp) + incoming_low
    second = starts_low & incoming_low
    ms = mult[order]
    ma = np.where(b_vertex[order], 0, ms)
    mb = ms - ma
    cnt_a = np.empty(base, dtype=np.intp)
    cnt_b = np.empty(base, dtype=np.intp)
    cnt_a[order] = np.cumsum(ma) - ma
    cnt_b[order] = np.cumsum(mb) - mb
    high = nxt + idx - low
    edges_a = np.flatnonzero(~b_vertex)
    edges_b = np.flatnonzero(b_vertex)
    low_a, low_b = low[edges_a], low[edges_b]
    a_block = edges_b.size  # by_lo holds B's edges, then A's
    by_lo = np.empty(base, dtype=np.intp)
    by_lo[cnt_b[low_b] + second[edges_b]] = edges_b
    by_lo[cnt_a[low_a] + (second[edges_a] + a_block)] = edges_a
    start = np.concatenate([cnt_b[low_a], cnt_a[low_b] + a_block])
    end = np.concatenate([cnt_b[high[edges_a]], cnt_a[high[edges_b]] + a_block])
    rows, pos = _expand(start, end)
    first = np.concatenate([edges_a, edges_b])[rows]
    other = by_lo[pos]
    case1 = rows < edges_a.size
    ia = np.where(case1, first, other)
    ib = np.where(case1, other, first)
    return _Pairs(a=ia, b=ib, direction=entry_direction[ia], attrs=attrs)


def _many_f0_f2(items: Sequence[tuple[_Region, _Region]], directions: int) -> FloatArray:
    """``_edge_pair_histograms(a, b, [F0, F2], directions)`` of several pairs, one sweep.

    Returns an array of shape ``(len(items), 2, directions)``, each pair's the same floats as
    its own sweep. Pairs too large for a single block, or an odd number of directions, are
    swept one by one.
    """
    kernels = [_Kernel(0.0), _Kernel(2.0)]
    out = np.empty((len(items), 2, directions))
    half = directions // 2
    batch = [
        k
        for k, (a, b) in enumerate(items)
        if directions % 2 == 0 and half * (len(a.start) + len(b.start)) <= 4 * _BLOCK
    ]
    single = set(range(len(items))) - set(batch)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        if batch:
            theta = 2.0 * np.pi * np.arange(half) / directions
            cos, sin = np.cos(theta), np.sin(theta)
            pairs = _many_pairs([items[k] for k in batch], cos, sin)
            values = _bin_values(pairs, kernels, half, 2 * half * len(batch))
            for i, v in enumerate(values):
                out[batch, i] = v.reshape(len(batch), directions)
    for k in sorted(single):
        out[k] = _edge_pair_histograms(*items[k], kernels, directions)
    return out


# --------------------------------------------------------------------------------------------
# Public API.
# --------------------------------------------------------------------------------------------


def _check_directions(directions: int) -> int:
    if isinstance(directions, bool) or not isinstance(directions, int | np.integer):
        raise InputError("directions", f"must be a positive integer, got {directions!r}")
    if directions < 1:
        raise InputError("directions", f"must be a positive integer, got {directions}")
    return int(directions)


def _pair(
    argument: ArrayLike, referent: ArrayLike, mask_tolerance: float
) -> tuple[_Region, _Region]:
    try:
        a_arr, b_arr = np.asarray(argument), np.asarray(referent)
    except (TypeError, ValueError) as exc:
        raise InputError(
            "argument/referent", f"cannot be read as vertex arrays or masks ({exc})"
        ) from exc
    a_mask, b_mask = a_arr.dtype == np.bool_, b_arr.dtype == np.bool_
    if a_mask != b_mask:
        raise InputError(
            "argument/referent",
            "one object is a boolean mask and the other a polygon: give two polygons or two "
            "masks of the same shape",
        )
    if a_mask and a_arr.shape != b_arr.shape:
        raise InputError(
            "argument/referent",
            f"masks have different shapes {a_arr.shape} and {b_arr.shape}: both must come "
            "from the same image",
        )
    return (
        _region(a_arr, "argument", mask_tolerance),
        _region(b_arr, "referent", mask_tolerance),
    )


def force_histogram(
    argument: ArrayLike,
    referent: ArrayLike,
    r: float = 2.0,
    directions: int = 180,
    *,
    mask_tolerance: float = _MASK_TOLERANCE,
) -> FloatArray:
    """Histogram of forces ``F_r`` of ``argument`` (A) with respect to ``referent`` (B).

    Parameters
    ----------
    argument, referent : array_like
        Either two ``(N, 2)`` vertex arrays of simple polygons (convex or not, either
        orientation, no self-intersection), or two 2-D boolean masks of equal shape.
    r : float, default 2.0
        Exponent of the elementary force ``d**-r``: 0 for constant forces, 2 for gravitational
        forces; any real value where the histogram is defined (``r < 1`` always; ``r < 2`` if
        the objects do not overlap; any ``r`` if they do not touch).
    directions : int, default 180
        Number of directions; ``h[k]`` is the value at angle ``2*pi*k/directions``.
    mask_tolerance : float, default 0.25
        For masks: the traced outline is simplified to within this many pixels (0 keeps every
        marching-squares vertex).

    Returns
    -------
    numpy.ndarray
        Float array of length ``directions``: how much the argument lies in each direction from
        the referent. Not normalised.

    Raises
    ------
    scenespeak.errors.InputError
        Degenerate input (see ``docs/forces.md``), or ``r`` where the histogram is undefined
        (overlapping objects for ``r >= 1``, touching objects for ``r >= 2``); use
        :func:`hybrid_histogram` for those.

    Examples
    --------
    >>> import numpy as np
    >>> a = np.array([[2.0, 0.0], [3.0, 0.0], [3.0, 1.0], [2.0, 1.0]])
    >>> b = a - [2.0, 0.0]
    >>> h = force_histogram(a, b, r=2.0, directions=8)
    >>> int(np.argmax(h))   # A is to the right of B
    0
    """
    return force_histograms(argument, referent, (r,), directions, mask_tolerance=mask_tolerance)[0]


def _check_r(r: object) -> float:
    try:
        value = float(r)  # type: ignore[arg-type]
    except (TypeError, ValueError) as exc:
        raise InputError("r", f"must be a real number, got {r!r}") from exc
    if not math.isfinite(value):
        raise InputError("r", f"must be a finite real number, got {value}")
    return value


def _check_defined(a: _Region, b: _Region, r: float) -> None:
    """Raise if ``F_r`` diverges for these objects (overlap for r >= 1, contact for r >= 2)."""
    if r < 1:
        return
    inter, touch = _contact(a, b)
    if inter > 0:
        raise InputError(
            "argument/referent",
            f"the objects overlap (area of A∩B = {inter:.6g}), so F_r diverges for "
            f"r = {r:g} >= 1; use r < 1 (e.g. F0) or hybrid_histogram() for F02",
        )
    if r >= 2 and touch:
        raise InputError(
            "argument/referent",
            f"the objects touch, so F_r diverges for r = {r:g} >= 2; use r < 2 or "
            "hybrid_histogram() for F02",
        )


def force_histograms(
    argument: ArrayLike,
    referent: ArrayLike,
    r: Sequence[float] = (0.0, 2.0),
    directions: int = 180,
    *,
    mask_tolerance: float = _MASK_TOLERANCE,
) -> FloatArray:
    """Several force histograms of one pair at once (the geometry is shared).

    Same as stacking :func:`force_histogram` for each exponent in ``r``, but faster: the
    objects are validated, traced and swept once.

    Parameters
    ----------
    argument, referent : array_like
        As for :func:`force_histogram`.
    r : sequence of float, default (0.0, 2.0)
        The exponents; every one must be defined for this pair.
    directions : int, default 180
        Number of directions; ``h[i, k]`` is the value for ``r[i]`` at ``2*pi*k/directions``.
    mask_tolerance : float, default 0.25
        As for :func:`force_histogram`.

    Returns
    -------
    numpy.ndarray
        Array of shape ``(len(r), directions)``.

    Examples
    --------
    >>> import numpy as np
    >>> sq = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    >>> f0, f2 = force_histograms(sq + [0.0, 3.0], sq, directions=4)
    >>> int(np.argmax(f0)), int(np.argmax(f2))   # A is above B: angle pi/2
    (1, 1)
    """
    directions = _check_directions(directions)
    exponents = [_check_r(x) for x in np.atleast_1d(np.asarray(r, dtype=object))]
    if not exponents:
        raise InputError("r", "give at least one exponent")
    a, b = _pair(argument, referent, mask_tolerance)
    _check_defined(a, b, max(exponents))
    return _edge_pair_histograms(a, b, [_Kernel(x) for x in exponents], directions)


def hybrid_histogram(
    argument: ArrayLike,
    referent: ArrayLike,
    p0: float = 0.01,
    p1: float = 3.0,
    directions: int = 180,
    *,
    mask_tolerance: float = _MASK_TOLERANCE,
) -> FloatArray:
    """Hybrid histogram F02: gravitational forces, constant below a distance ``Y0``.

    The elementary force is ``1 / max(d, Y0)**2`` with ``Y0 = max(p0 * D_min, p1 * D_AB)``,
    where ``D_X = 2 * sqrt(area(X) / pi)``, ``D_min`` is that of the smaller object and
    ``D_AB`` that of ``A ∩ B``. Defined for touching and intersecting objects; equal to
    ``force_histogram(..., r=2)`` for objects farther apart than ``Y0``.

    Parameters
    ----------
    argument, referent : array_like
        As for :func:`force_histogram`.
    p0, p1 : float
        Positive factors of ``Y0`` (Matsakis' defaults 0.01 and 3).
    directions : int, default 180
        Number of directions; ``h[k]`` is the value at angle ``2*pi*k/directions``.
    mask_tolerance : float, default 0.25
        As for :func:`force_histogram`.

    Returns
    -------
    numpy.ndarray
        Float array of length ``directions``.

    Examples
    --------
    >>> import numpy as np
    >>> a = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [0.0, 1.0]])
    >>> b = a + [1.0, 0.0]   # overlaps A: F2 is undefined, F02 is not
    >>> h = hybrid_histogram(a, b, directions=4)
    >>> bool(h[2] > h[0])    # A sticks out to the left of B
    True
    """
    directions = _check_directions(directions)
    for label, value in (("p0", p0), ("p1", p1)):
        if not (isinstance(value, int | float | np.number) and math.isfinite(value)) or (value < 0):
            raise InputError(label, f"must be a finite number >= 0, got {value!r}")
    a, b = _pair(argument, referent, mask_tolerance)
    inter, _ = _contact(a, b)
    d_min = 2.0 * math.sqrt(min(a.area, b.area) / math.pi)
    d_int = 2.0 * math.sqrt(inter / math.pi)
    y0 = max(float(p0) * d_min, float(p1) * d_int)
    if y0 <= 0:
        raise InputError("p0/p1", "Y0 = max(p0*D_min, p1*D_AB) is 0: give p0 > 0")
    return _edge_pair_histograms(a, b, [_Kernel(2.0, y0)], directions)[0]


def _f0_and_f2(
    a: _Region,
    b: _Region,
    directions: int,
    *,
    try_f2: bool = True,
    contact: tuple[float, bool] | None = None,
) -> tuple[FloatArray, FloatArray, bool]:
    """F0 and F2 of two prepared regions, or F0 and the hybrid F02 where F2 is undefined.

    For regions made once per object (``_polygon_region``) and used in many pairs: the same
    values as ``force_histograms(A, B, (0, 2))`` when that succeeds and gives a finite F2
    (and ``try_f2``), else ``force_histogram(A, B, r=0)`` and ``hybrid_histogram(A, B)``, but
    with one ``_contact`` and one sweep for both kernels (the kernels share the edge pairs and
    are summed separately, so each result is the one of its own sweep, bit for bit).

    ``contact`` is ``_contact(a, b)`` when already known.

    Returns
    -------
    f0, f2, hybrid
        ``f2`` is F02 when ``hybrid``.
    """
    inter, touch = _contact(a, b) if contact is None else contact
    if try_f2 and not inter > 0 and not touch:  # what _check_defined(a, b, 2.0) lets through
        try:
            f0, f2 = _edge_pair_histograms(a, b, [_Kernel(0.0), _Kernel(2.0)], directions)
            if np.all(np.isfinite(f2)):
                return f0, f2, False
        except (ValueError, ArithmeticError):
            pass
    d_min = 2.0 * math.sqrt(min(a.area, b.area) / math.pi)
    d_int = 2.0 * math.sqrt(inter / math.pi)
    y0 = max(0.01 * d_min, 3.0 * d_int)  # hybrid_histogram's defaults p0 = 0.01, p1 = 3
    if y0 <= 0:
        raise InputError("p0/p1", "Y0 = max(p0*D_min, p1*D_AB) is 0: give p0 > 0")
    f0, f02 = _edge_pair_histograms(a, b, [_Kernel(0.0), _Kernel(2.0, y0)], directions)
    return f0, f02, True


def _many_f0_and_f2(
    items: Sequence[tuple[_Region, _Region, bool]], directions: int
) -> list[tuple[FloatArray, FloatArray, bool]]:
    """:func:`_f0_and_f2` of several pairs ``(a, b, try_f2)``: the pairs where F2 is tried
    share one sweep (:func:`_many_f0_f2`); the same results, pair by pair."""
    boxes: dict[int, tuple[list[float], list[float]]] = {}
    for a, b, _ in items:
        for r in (a, b):
            if id(r) not in boxes:
                boxes[id(r)] = (r.start.min(axis=0).tolist(), r.start.max(axis=0).tolist())
    contacts = [
        (0.0, False) if _boxes_apart(*boxes[id(a)], *boxes[id(b)]) else _contact(a, b)
        for a, b, _ in items
    ]
    tried = [
        k
        for k, ((_, _, try_f2), (inter, touch)) in enumerate(zip(items, contacts, strict=True))
        if try_f2 and not inter > 0 and not touch
    ]
    found: dict[int, tuple[FloatArray, FloatArray, bool]] = {}
    if tried:
        try:
            swept = _many_f0_f2([items[k][:2] for k in tried], directions)
        except (ValueError, ArithmeticError):
            swept = None
        if swept is not None:
            for k, (f0, f2) in zip(tried, swept, strict=True):
                if np.all(np.isfinite(f2)):
                    found[k] = (f0, f2, False)
    return [
        found[k] if k in found else _f0_and_f2(a, b, directions, try_f2=try_f2, contact=contacts[k])
        for k, (a, b, try_f2) in enumerate(items)
    ]


def polygon_area(polygon: ArrayLike) -> float:
    """Area of a simple polygon (``(N, 2)`` vertices, either orientation) or of a mask outline.

    Examples
    --------
    >>> polygon_area([[0, 0], [2, 0], [2, 1], [0, 1]])
    2.0
    """
    return _region(np.asarray(polygon), "polygon", _MASK_TOLERANCE).area


def intersection_area(a: ArrayLike, b: ArrayLike) -> float:
    """Area of ``A ∩ B`` for two simple polygons (convex or not), exact up to rounding.

    Computed with Green's theorem: the boundary of ``A ∩ B`` is the part of A's boundary
    inside B plus the part of B's boundary inside A (edges split at every crossing; shared
    boundary pieces counted once when both interiors lie on the same side).

    Examples
    --------
    >>> sq = [[0, 0], [2, 0], [2, 2], [0, 2]]
    >>> intersection_area(sq, [[1, 1], [3, 1], [3, 3], [1, 3]])
    1.0
    """
    ra, rb = _pair(a, b, _MASK_TOLERANCE)
    return _contact(ra, rb)[0]


def polygons_intersect(a: ArrayLike, b: ArrayLike) -> bool:
    """Whether the interiors of two simple polygons overlap (touching does not count).

    Examples
    --------
    >>> sq = [[0, 0], [1, 0], [1, 1], [0, 1]]
    >>> polygons_intersect(sq, [[1, 0], [2, 0], [2, 1], [1, 1]])
    False
    """
    return intersection_area(a, b) > 0.0
