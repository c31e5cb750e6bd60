"""Small polygon helpers for the language stage (private): validation, area, overlap."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from scenespeak.errors import InputError


def as_polygon(vertices: ArrayLike, name: str) -> NDArray[np.float64]:
    """Validate an ``(N, 2)`` vertex array (N >= 3, finite, non-zero area)."""
    try:
        p = np.asarray(vertices, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InputError(name, f"must be an (N, 2) array of vertices ({exc})") from None
    if p.ndim != 2 or p.shape[1] != 2 or p.shape[0] < 3:
        raise InputError(name, f"must be an (N, 2) array of N >= 3 vertices, got shape {p.shape}")
    if not np.all(np.isfinite(p)):
        raise InputError(name, "has non-finite vertex coordinates (NaN or inf)")
    if abs(polygon_area(p)) <= 1e-15 * max(1.0, float(np.ptp(p, axis=0).max()) ** 2):
        raise InputError(name, "has zero area; pass a polygon that encloses a region")
    return p


def _shift(a: NDArray[np.generic]) -> NDArray[np.generic]:
    """``np.roll(a, -1, axis=0)`` (row i holds row i + 1), without its general overhead."""
    return np.concatenate([a[1:], a[:1]])


def polygon_area(p: NDArray[np.float64]) -> float:
    """Signed shoelace area (positive for counter-clockwise vertices)."""
    x, y = p[:, 0], p[:, 1]
    return 0.5 * float(np.dot(x, _shift(y)) - np.dot(_shift(x), y))


def is_convex(p: NDArray[np.float64]) -> bool:
    """True when every turn of the (closed) vertex sequence goes the same way."""
    d = _shift(p) - p
    cross = d[:, 0] * _shift(d[:, 1]) - d[:, 1] * _shift(d[:, 0])
    scale = float(np.abs(cross).max()) if cross.size else 0.0
    tol = 1e-12 * max(scale, 1e-300)
    return bool(np.all(cross >= -tol) or np.all(cross <= tol))


def _sides(
    out: NDArray[np.float64], p0: NDArray[np.float64], edge: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Which side of the clip edges ``p0 + s * edge`` the points are on (> 0: to the left).

    ``p0`` and ``edge`` may be ``(2,)`` (one edge, result ``(N,)``) or ``(E, 2)`` (result
    ``(E, N)``); the arithmetic is the same for each (edge, point).
    """
    p0, edge = p0[..., None], edge[..., None]
    return edge[..., 0, :] * (out[:, 1] - p0[..., 1, :]) - edge[..., 1, :] * (
        out[:, 0] - p0[..., 0, :]
    )


def _clip_convex(subject: NDArray[np.float64], clip: NDArray[np.float64]) -> NDArray[np.float64]:
    """Sutherland-Hodgman: ``subject`` (any simple polygon) clipped by a convex polygon.

    Each clip edge keeps, in order, every vertex on its inner side (``side >= 0``) and adds
    the crossing ``cur + t * (nxt - cur)``, ``t = side(cur) / (side(cur) - side(nxt))``, of
    every edge that changes side: the loop of the textbook algorithm, vertex by vertex, done
    for all vertices at once (the same operations on the same numbers).
    """
    if polygon_area(clip) < 0:
        clip = clip[::-1]
    out = subject
    n_clip = len(clip)
    for i in range(n_clip):
        if len(out) == 0:
            break
        p0, p1 = clip[i], clip[(i + 1) % n_clip]
        side = _sides(out, p0, p1 - p0)
        inside = side >= 0
        if inside.all():
            continue  # every vertex kept, none added
        nxt_inside = _shift(inside)
        cross = inside != nxt_inside
        if not cross.any():  # every vertex outside
            out = np.zeros((0, 2))
            break
        j = np.flatnonzero(cross)
        k = (j + 1) % len(out)
        sc, sn = side[j], side[k]
        t = sc / (sc - sn)
        cur = out[j]
        candidates = np.empty((len(out), 2, 2))
        candidates[:, 0] = out
        candidates[j, 1] = cur + t[:, None] * (out[k] - cur)
        out = candidates[np.stack([inside, cross], axis=1)]
    # A fresh C-ordered array, as the textbook loop builds: the area's dot products then take
    # the same path (a reversed view of the subject would be summed in another order).
    return np.ascontiguousarray(out)


def _clipped_away(subject: NDArray[np.float64], clip: NDArray[np.float64]) -> bool:
    """Whether some edge of the convex ``clip`` has every vertex of ``subject`` well outside.

    Then :func:`_clip_convex` returns no vertex: every point it makes is a convex combination
    of the subject's vertices (up to rounding, far below the margin of ``1e-9`` times the edge
    length times the coordinates' magnitude), so that edge drops all of them.
    """
    if polygon_area(clip) < 0:
        clip = clip[::-1]
    p1 = _shift(clip)
    edge = p1 - clip
    side = _sides(subject, clip, edge)  # (edges of clip, vertices of subject)
    size = max(float(np.abs(subject).max()), float(np.abs(clip).max()), 1e-300)
    length = np.abs(edge).max(axis=1)
    return bool(np.any(np.all(side < (-1e-9 * size) * length[:, None], axis=1)))


def intersection_area(
    a: NDArray[np.float64],
    b: NDArray[np.float64],
    *,
    a_convex: bool | None = None,
    b_convex: bool | None = None,
) -> float:
    """Area of A ∩ B: exact when either polygon is convex, else a 256 x 256 grid estimate.

    ``a_convex`` / ``b_convex`` pass :func:`is_convex` of a polygon when it is already known.
    """
    if b_convex if b_convex is not None else is_convex(b):
        if _clipped_away(a, b):
            return 0.0
        clipped = _clip_convex(a, b)
    elif a_convex if a_convex is not None else is_convex(a):
        if _clipped_away(b, a):
            return 0.0
        clipped = _clip_convex(b, a)
    else:
        from matplotlib.path import Path

        lo = np.maximum(a.min(axis=0), b.min(axis=0))
        hi = np.minimum(a.max(axis=0), b.max(axis=0))
        if np.any(hi <= lo):
            return 0.0
        k = 256
        xs = lo[0] + (np.arange(k) + 0.5) * (hi[0] - lo[0]) / k
        ys = lo[1] + (np.arange(k) + 0.5) * (hi[1] - lo[1]) / k
        pts = np.stack(np.meshgrid(xs, ys), axis=-1).reshape(-1, 2)
        inside = Path(a).contains_points(pts) & Path(b).contains_points(pts)
        return float(inside.mean() * np.prod(hi - lo))
    return abs(polygon_area(clipped)) if len(clipped) >= 3 else 0.0
