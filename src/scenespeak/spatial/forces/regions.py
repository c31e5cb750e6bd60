"""Objects as oriented boundary edges: validation of polygons, preparation, tolerances.

A :class:`Region` is what the force sweep reads: boundary edges with the interior on the left,
the area, whether it is convex, and a name for error messages. :func:`prepare` makes one from a
polygon or a boolean mask, once, so that an object used in many pairs is validated and traced
once (``relate_objects`` and :func:`~scenespeak.spatial.forces.pair_histograms_many`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NoReturn

import numpy as np
from numpy.typing import ArrayLike, NDArray

from scenespeak.errors import InputError
from scenespeak.geometry.polygons import (
    bbox_candidates,
    cyclic_next,
    polygon_area,
    segment_distances,
)

FloatArray = NDArray[np.float64]

# Relative tolerances, scaled by the objects' size (lengths) or size squared (areas).
_LENGTH_TOL = 1e-10
_AREA_TOL = 1e-10
#: Simplification of traced mask outlines that keeps every corner of a pixel staircase, in
#: pixels: the floor of the measured rule (``masks.outline_tolerance``).
MASK_TOLERANCE = 0.25
#: The default ``mask_tolerance``: None, i.e. chosen per ring by ``masks.outline_tolerance``.
DEFAULT_MASK_TOLERANCE: float | None = None

_next = cyclic_next
_shoelace = polygon_area


@dataclass(frozen=True)
class Region:
    """An object as a set of oriented boundary edges (interior on the left).

    Made by :func:`prepare`; read-only. ``start[e] → end[e]`` is edge ``e``; ``nxt``/``prv``
    give the next/previous vertex along its ring (several rings for masks with holes).
    """

    start: FloatArray  # (E, 2) vertices; edge e runs from start[e] to end[e] = start[nxt[e]]
    end: FloatArray  # (E, 2)
    nxt: NDArray[np.intp]  # (E,) next vertex along the boundary
    prv: NDArray[np.intp]  # (E,) previous vertex
    area: float
    convex: bool
    name: str


_Region = Region  # the name tests and older callers use


def _polygon_region(polygon: ArrayLike, name: str) -> Region:
    """Validate a simple polygon given as an ``(N, 2)`` vertex array and orient it CCW."""
    p = _distinct_vertices(polygon, name)
    scale = float((p.max(axis=0) - p.min(axis=0)).max())
    area = _shoelace(p)
    if scale == 0.0 or abs(area) <= _AREA_TOL * scale * scale:
        _raise_zero_area(p, scale, name)
    if area < 0:
        p = p[::-1].copy()
        area = -area
    q = _next(p)
    convex = _is_convex(p, q, scale)
    if not convex:
        _check_simple(p, q, scale, name)
    n = len(p)
    idx = np.arange(n)
    return Region(
        start=p,
        end=q,
        nxt=np.concatenate([idx[1:], idx[:1]]),
        prv=np.concatenate([idx[n - 1 :], idx[: n - 1]]),
        area=area,
        convex=convex,
        name=name,
    )


def _distinct_vertices(polygon: ArrayLike, name: str) -> FloatArray:
    """The finite ``(N, 2)`` vertices of ``polygon``, repeated consecutive ones dropped, N >= 3."""
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
    return p


def _raise_zero_area(p: FloatArray, scale: float, name: str) -> NoReturn:
    """Raise for a polygon of (numerically) zero signed area: a bow tie or a degenerate one."""
    # A zero signed area with vertices off one line is a self-intersection (a bow tie).
    d = p - p[0]
    far = d[np.argmax(np.abs(d).sum(axis=1))]
    off_line = np.abs(d[:, 0] * far[1] - d[:, 1] * far[0]).max()
    if scale > 0.0 and float(off_line) > _AREA_TOL * scale * scale:
        _check_simple(p, _next(p), scale, name)
    raise InputError(name, "polygon has zero area (all vertices collinear or coincident)")


def _is_convex(p: FloatArray, q: FloatArray, scale: float) -> bool:
    """Whether the CCW polygon ``p`` (edges ``p → q``) is convex."""
    e = q - p
    e_next = _next(e)
    turn = e[:, 0] * e_next[:, 1] - e[:, 1] * e_next[:, 0]
    # Convex: no right turn, and the edge directions go round exactly once.
    convex = bool((turn >= -_LENGTH_TOL * scale * scale).all())
    if convex:
        angles = np.arctan2(turn, e[:, 0] * e_next[:, 0] + e[:, 1] * e_next[:, 1])
        convex = abs(float(angles.sum()) - 2 * math.pi) < 1e-6
    return convex


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
    found = _first_contact(p, q, _LENGTH_TOL * scale)
    if found is not None:
        raise InputError(
            name,
            f"polygon is not simple: edge {found[0]} and edge {found[1]} cross or touch "
            "(self-intersecting polygons are not supported; split them into simple ones)",
        )


def _first_contact(p: FloatArray, q: FloatArray, tol: float) -> tuple[int, int] | None:
    """The first pair of non-adjacent edges that cross or come within ``tol`` (or None).

    Compiled (:func:`~scenespeak.spatial.forces._shapes.first_contact`) once the compiled
    kernel is loaded; else every pair of edges whose bounding boxes come within ``tol``, in
    NumPy (the same answer).
    """
    from scenespeak.spatial.forces import _jit

    n = len(p)
    if _jit.loaded():
        from scenespeak.spatial.forces._shapes import first_contact

        i, j = (int(x) for x in first_contact(p, q, tol))
        return None if i < 0 else (i, j)
    ii, jj = bbox_candidates(p, q, p, q, tol)
    nonadjacent = (jj >= ii + 2) & ~((ii == 0) & (jj == n - 1))
    ii, jj = ii[nonadjacent], jj[nonadjacent]
    bad = segment_distances(p[ii], q[ii], p[jj], q[jj]) <= tol
    if not np.any(bad):
        return None
    k = int(np.argmax(bad))
    return int(ii[k]), int(jj[k])


def _region(obj: ArrayLike, name: str, mask_tolerance: float | None) -> Region:
    arr = np.asarray(obj)
    if arr.dtype == np.bool_:
        from scenespeak.spatial.forces.masks import _mask_region

        return _mask_region(arr, name, mask_tolerance)
    return _polygon_region(arr, name)


def prepare(
    obj: ArrayLike,
    name: str = "object",
    *,
    mask_tolerance: float | None = DEFAULT_MASK_TOLERANCE,
) -> Region:
    """Validate an object once for many force histograms: a polygon or a boolean mask.

    Parameters
    ----------
    obj : array_like
        An ``(N, 2)`` vertex array of a simple polygon (either orientation) or a 2-D boolean
        mask (``(row, col)`` → ``(x, y) = (col, -row)``).
    name : str
        Named in error messages.
    mask_tolerance : float or None, default None
        For masks: simplification of the traced outline, in pixels (0 keeps every
        marching-squares vertex); ``None`` chooses it per ring by the measured rule of
        :func:`scenespeak.spatial.forces.masks.outline_tolerance` (0.25, 0.5 or 1 px).

    Returns
    -------
    Region

    Raises
    ------
    scenespeak.errors.InputError
        For a degenerate polygon or an empty mask (the message names ``name``).

    Examples
    --------
    >>> sq = prepare([[0, 0], [1, 0], [1, 1], [0, 1]], "square")
    >>> sq.area, sq.convex, len(sq.start)
    (1.0, True, 4)
    """
    return _region(obj, name, mask_tolerance)
