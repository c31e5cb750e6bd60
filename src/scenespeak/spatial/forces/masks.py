"""Boolean masks as polygons: the traced outline, simplified without its pixel staircase.

Pixel ``(row, col)`` has its centre at ``(x, y) = (col, -row)``. The outline is the
marching-squares iso-line at level 0.5 (half-way between inside and outside pixel centres, which
is where the outline of a polygon rasterised by pixel centres lies; traced by
:mod:`~scenespeak.spatial.forces._trace`, the same rings as ``skimage.measure.find_contours``
with ``fully_connected="high"``), holes included, then
simplified by Douglas-Peucker to within a tolerance (pixels) so that the force sweep does not
pay for every step of a staircase.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from scenespeak.errors import InputError
from scenespeak.spatial.forces.regions import MASK_TOLERANCE, Region, _next, _shoelace

FloatArray = NDArray[np.float64]

__all__ = ["outline_tolerance"]


def outline_tolerance(mask_size: int) -> float:
    """The simplification (pixels) used for a traced outline when none is given.

    Measured on a frozen set (``benchmarks/bench_masks.py``): see ``docs/forces.md``.
    """
    del mask_size
    return MASK_TOLERANCE


def _mask_region(mask: NDArray[np.bool_], name: str, tolerance: float | None) -> Region:
    """Trace a boolean mask into oriented boundary edges (holes included).

    The marching-squares outline, simplified by Douglas-Peucker to within ``tolerance``
    pixels (``None``: :func:`outline_tolerance`).
    """
    import cv2

    from scenespeak.spatial.forces._trace import rings

    if mask.ndim != 2:
        raise InputError(name, f"a mask must be a 2-D boolean array, got shape {mask.shape}")
    rows = np.flatnonzero(mask.any(axis=1))
    if rows.size == 0:
        raise InputError(name, "mask is empty (no pixel set): there is no object to measure")
    cols = np.flatnonzero(mask.any(axis=0))
    r0, c0 = int(rows[0]), int(cols[0])
    if tolerance is None:
        tolerance = outline_tolerance(max(mask.shape))
    # Trace only the bounding box (padded by one pixel so that every outline closes).
    padded = np.pad(mask[r0 : int(rows[-1]) + 1, c0 : int(cols[-1]) + 1], 1)
    contours = rings(padded)
    starts: list[FloatArray] = []
    ends: list[FloatArray] = []
    nxts: list[NDArray[np.intp]] = []
    prvs: list[NDArray[np.intp]] = []
    total = 0
    area = 0.0
    for c in contours:
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
    return Region(
        start=np.concatenate(starts),
        end=np.concatenate(ends),
        nxt=np.concatenate(nxts),
        prv=np.concatenate(prvs),
        area=area,
        convex=False,
        name=name,
    )
