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


def polygon_area(p: NDArray[np.float64]) -> float:
    """Signed shoelace area (positive for counter-clockwise vertices)."""
    x, y = p[:, 0], p[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


def is_convex(p: NDArray[np.float64]) -> bool:
    """True when every turn of the (closed) vertex sequence goes the same way."""
    d = np.roll(p, -1, axis=0) - p
    cross = d[:, 0] * np.roll(d[:, 1], -1) - d[:, 1] * np.roll(d[:, 0], -1)
    scale = float(np.abs(cross).max()) if cross.size else 0.0
    tol = 1e-12 * max(scale, 1e-300)
    return bool(np.all(cross >= -tol) or np.all(cross <= tol))


def _clip_convex(subject: NDArray[np.float64], clip: NDArray[np.float64]) -> NDArray[np.float64]:
    """Sutherland-Hodgman: ``subject`` (any simple polygon) clipped by a convex polygon."""
    if polygon_area(clip) < 0:
        clip = clip[::-1]
    out = subject
    for i in range(len(clip)):
        if len(out) == 0:
            break
        p0, p1 = clip[i], clip[(i + 1) % len(clip)]
        edge = p1 - p0
        side = edge[0] * (out[:, 1] - p0[1]) - edge[1] * (out[:, 0] - p0[0])
        new: list[NDArray[np.float64]] = []
        for j in range(len(out)):
            cur, nxt = out[j], out[(j + 1) % len(out)]
            sc, sn = side[j], side[(j + 1) % len(out)]
            if sc >= 0:
                new.append(cur)
            if (sc >= 0) != (sn >= 0):
                t = sc / (sc - sn)
                new.append(cur + t * (nxt - cur))
        out = np.array(new) if new else np.zeros((0, 2))
    return out


def intersection_area(a: NDArray[np.float64], b: NDArray[np.float64]) -> float:
    """Area of A ∩ B: exact when either polygon is convex, else a 256 x 256 grid estimate."""
    if is_convex(b):
        clipped = _clip_convex(a, b)
    elif is_convex(a):
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
