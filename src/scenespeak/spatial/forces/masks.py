"""Boolean masks as polygons: the traced outline, simplified without its pixel staircase.

Pixel ``(row, col)`` has its centre at ``(x, y) = (col, -row)``. The outline is the
marching-squares iso-line at level 0.5 (half-way between inside and outside pixel centres, which
is where the outline of a polygon rasterised by pixel centres lies; traced by
:mod:`~scenespeak.spatial.forces._trace`, the same rings as ``skimage.measure.find_contours``
with ``fully_connected="high"``), holes included, then each ring simplified by Douglas-Peucker
(Douglas & Peucker 1973; OpenCV's ``approxPolyDP``) to within a tolerance in pixels, so that
the force sweep does not pay for every step of a staircase.

The default tolerance is chosen per ring by a measured rule (:func:`outline_tolerance`, the
table :data:`RULE`) from the ring's size ``sqrt|A|`` and its mean half-width ``w = 2|A| / P``
(area over half the perimeter: the radius of a disc, about 1 for a line one pixel wide):
small or thin rings keep :data:`~scenespeak.spatial.forces.regions.MASK_TOLERANCE` (0.25 px,
every corner of the staircase), large ones are simplified further. Douglas-Peucker's chords
lie inside every convex run they replace, so after it each chord is moved back along its
normal to give its run's area back (:func:`_offset_vertices`): on the tuning set this cut the
error of a 0.5 px simplification 3-5 times. The rule was chosen on the tuning half of
:mod:`scenespeak.tools.mask_set` and its error is reported on the validation half
(``benchmarks/bench_masks.py``; ``docs/forces.md``, "Masks: the outline rule"). It reads only
the ring, so it is deterministic: the same mask gives the same outline, the same sweep and the
same bits.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
from numpy.typing import NDArray

from scenespeak.errors import InputError
from scenespeak.spatial.forces.regions import MASK_TOLERANCE, Region

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.intp]

__all__ = ["RULE", "outline_tolerance"]

#: The measured rule, ``(side, width, tolerance)`` rows: a ring with ``sqrt|A| >= side`` and
#: ``2|A| / P >= width`` (pixels) is simplified to ``tolerance`` pixels (the first row that
#: applies); every other ring to ``MASK_TOLERANCE``.
RULE: tuple[tuple[float, float, float], ...] = (
    (0.0, 50.0, 1.0),
    (100.0, 5.0, 0.75),
    (40.0, 5.0, 0.5),
)


#: A vertex moved back (:func:`_offset_vertices`) moves at most this many tolerances (so the
#: outline stays within twice the tolerance of the traced one).
SHIFT_LIMIT = 1.0


def outline_tolerance(area: float, perimeter: float) -> float:
    """The simplification (pixels) of one traced ring when ``mask_tolerance`` is None.

    Parameters
    ----------
    area, perimeter : float
        The ring's area (either sign: holes run clockwise) and perimeter, in pixels.

    Returns
    -------
    float
        The tolerance of the first row of :data:`RULE` that the ring meets, else
        ``MASK_TOLERANCE`` (0.25: keeps every corner of a pixel staircase).

    Examples
    --------
    >>> r = 100.0   # a disc of radius 100 px: w = 100
    >>> outline_tolerance(math.pi * r * r, 2 * math.pi * r)
    1.0
    >>> outline_tolerance(10_000.0, 20_002.0)   # a 1 x 10 000 px line: w < 1
    0.25
    """
    side = math.sqrt(abs(area))
    for min_side, min_width, tolerance in RULE:
        if side >= min_side and 2.0 * abs(area) >= min_width * perimeter:
            return tolerance
    return MASK_TOLERANCE


def _fewest_points() -> float:
    """The fewest traced points a ring that some row of :data:`RULE` applies to can have.

    A traced segment is at most 1 px long, so ``P <= points``; and ``4 pi |A| <= P²``
    (isoperimetric), so ``P >= 2 sqrt(pi) side`` and ``P >= 2 pi width``.
    """
    bounds = [max(2 * math.sqrt(math.pi) * s, 2 * math.pi * w) for s, w, _ in RULE]
    return min(bounds, default=math.inf)


def _ring_tolerance(ring: FloatArray) -> float:
    """:func:`outline_tolerance` of a traced ring (``(row, col)`` points)."""
    if len(ring) < _fewest_points():
        return MASK_TOLERANCE  # too short for any row: no need to measure it
    nxt = np.roll(ring, -1, axis=0)
    area = 0.5 * float(np.sum(ring[:, 0] * nxt[:, 1] - nxt[:, 0] * ring[:, 1]))
    perimeter = float(np.hypot(*(nxt - ring).T).sum())
    return outline_tolerance(area, perimeter)


def _douglas_peucker(ring: FloatArray, tolerance: float) -> FloatArray:
    """The vertices Douglas-Peucker keeps of the closed ``ring`` (OpenCV, in its order)."""
    import cv2

    # Marching-squares vertices sit on the half-pixel grid: exact in float32.
    kept = cv2.approxPolyDP(ring.astype(np.float32)[:, None, :], tolerance, True)
    return np.asarray(kept[:, 0, :], dtype=np.float64)


def _kept_indices(ring: FloatArray, tolerance: float) -> IntArray | None:
    """Douglas-Peucker on ``ring``: the indices of the vertices it keeps, in ring order
    (None when fewer than 3 are kept or the order cannot be recovered)."""
    # Each crack midpoint is visited once, so a kept point names its index.
    kept = _douglas_peucker(ring, tolerance)
    if len(kept) < 3:
        return None
    width = int(4 * ring[:, 1].max()) + 1

    def key(p: NDArray[np.floating]) -> IntArray:
        q = np.rint(4 * np.asarray(p, dtype=np.float64)).astype(np.intp)
        return np.asarray(q[:, 0] * width + q[:, 1], dtype=np.intp)

    keys = key(ring)
    order = np.argsort(keys)
    idx = order[np.searchsorted(keys[order], key(kept))]
    idx = np.roll(idx, -int(np.argmin(idx)))
    if np.any(np.diff(idx) <= 0):
        return None
    return idx


def _offset_vertices(ring: FloatArray, idx: IntArray, tolerance: float) -> FloatArray:
    """The kept vertices ``ring[idx]`` moved so that each chord keeps the area of its run.

    Chord ``k`` (``ring[idx[k]] → ring[idx[k + 1]]``) replaces a run of the traced outline;
    a chord of a convex run lies inside it, so plain Douglas-Peucker shrinks convex parts
    and moves the outline towards its neighbours. Here each chord is shifted along its
    normal by ``δ_k = -(signed area between run and chord) / length``, which gives the run's
    area back, and each vertex is put where its two shifted chords meet (their mean shift
    where they are within ~12° of parallel), at most ``SHIFT_LIMIT * tolerance`` from where
    it was.
    """
    n, m = len(ring), len(idx)
    a = ring[idx]
    d = np.roll(a, -1, axis=0) - a
    length = np.hypot(d[:, 0], d[:, 1])
    normal = np.column_stack([-d[:, 1], d[:, 0]]) / length[:, None]
    seg = np.searchsorted(idx, np.arange(n), side="right") - 1
    seg[seg < 0] = m - 1  # the points before the first kept one close the last run
    rel = ring - a[seg]
    nxt = np.roll(ring, -1, axis=0) - a[seg]
    cross = rel[:, 0] * nxt[:, 1] - rel[:, 1] * nxt[:, 0]
    delta = -0.5 * np.bincount(seg, weights=cross, minlength=m) / length
    n1, n2 = np.roll(normal, 1, axis=0), normal  # the chords before and after each vertex
    d1, d2 = np.roll(delta, 1), delta
    det = n1[:, 0] * n2[:, 1] - n1[:, 1] * n2[:, 0]
    meet = np.abs(det) > 0.2
    safe = np.where(meet, det, 1.0)
    shift = np.where(
        meet[:, None],
        np.column_stack([d1 * n2[:, 1] - d2 * n1[:, 1], n1[:, 0] * d2 - n2[:, 0] * d1])
        / safe[:, None],
        0.5 * (d1[:, None] * n1 + d2[:, None] * n2),
    )
    norm = np.hypot(shift[:, 0], shift[:, 1])
    limit = SHIFT_LIMIT * tolerance
    far = norm > limit
    shift[far] *= (limit / norm[far])[:, None]
    return a + shift


def _simplified(ring: FloatArray, tolerance: float | None) -> FloatArray:
    """One traced ring simplified (``None``: the ring's rule): Douglas-Peucker to within the
    tolerance, then (above ``MASK_TOLERANCE``) the kept vertices moved by
    :func:`_offset_vertices`."""
    if len(ring) <= 4:
        return ring
    tol = _ring_tolerance(ring) if tolerance is None else tolerance
    if tol <= 0.0:
        return ring
    if tol <= MASK_TOLERANCE:
        # Within 0.25 px every run is a straight line of crack midpoints (no area to give
        # back): Douglas-Peucker's own vertices, as before the rule.
        kept = _douglas_peucker(ring, tol)
        return ring if len(kept) < 3 else kept  # keep a tiny ring as traced
    idx = _kept_indices(ring, tol)
    if idx is None:
        return ring
    return _offset_vertices(ring, idx, tol)


def _ring_links(lengths: IntArray) -> tuple[IntArray, IntArray]:
    """``(nxt, prv)`` of the vertices of rings of ``lengths`` stored one after the other."""
    offsets = np.concatenate([[0], np.cumsum(lengths)[:-1]]).astype(np.intp)
    ring = np.repeat(np.arange(len(lengths)), lengths)
    off, n = offsets[ring], lengths[ring]
    local = np.arange(int(lengths.sum()), dtype=np.intp) - off
    return off + (local + 1) % n, off + (local - 1) % n


def _outline(padded: NDArray[np.bool_], tolerance: float | None) -> list[FloatArray]:
    """The simplified rings of ``padded`` (False all round), ``(row, col)`` points."""
    from scenespeak.spatial.forces._trace import ring_table

    points, starts = ring_table(padded)
    bounds = starts.tolist()
    return [_simplified(points[i:j], tolerance) for i, j in itertools.pairwise(bounds)]


def _mask_region(mask: NDArray[np.bool_], name: str, tolerance: float | None) -> Region:
    """Trace a boolean mask into oriented boundary edges (holes included).

    The marching-squares outline, each ring simplified by Douglas-Peucker to within
    ``tolerance`` pixels (``None``: per ring, :func:`outline_tolerance`).
    """
    if mask.ndim != 2:
        raise InputError(name, f"a mask must be a 2-D boolean array, got shape {mask.shape}")
    rows = np.flatnonzero(mask.any(axis=1))
    if rows.size == 0:
        raise InputError(name, "mask is empty (no pixel set): there is no object to measure")
    cols = np.flatnonzero(mask.any(axis=0))
    r0, c0 = int(rows[0]), int(cols[0])
    # Trace only the bounding box (padded by one pixel so that every outline closes).
    kept = _outline(np.pad(mask[r0 : int(rows[-1]) + 1, c0 : int(cols[-1]) + 1], 1), tolerance)
    kept = [c for c in kept if len(c) >= 3]
    if not kept:
        raise InputError(name, "mask outline has zero area")
    lengths = np.array([len(c) for c in kept], dtype=np.intp)
    rc = np.concatenate(kept)
    # (row, col) in the padded crop → (x, y) = (column, -row) in the mask
    xy = np.column_stack([rc[:, 1] + (c0 - 1.0), (1.0 - r0) - rc[:, 0]])
    nxt, _ = _ring_links(lengths)
    cross = xy[:, 0] * xy[nxt, 1] - xy[nxt, 0] * xy[:, 1]
    ring_areas = 0.5 * np.add.reduceat(cross, np.concatenate([[0], np.cumsum(lengths)[:-1]]))
    keep = ring_areas != 0.0
    area = sum(ring_areas[keep].tolist())
    if not keep.any() or area <= 0:
        raise InputError(name, "mask outline has zero area")
    if not keep.all():
        xy = xy[np.repeat(keep, lengths)]
        lengths = lengths[keep]
    nxt, prv = _ring_links(lengths)
    return Region(start=xy, end=xy[nxt], nxt=nxt, prv=prv, area=area, convex=False, name=name)
