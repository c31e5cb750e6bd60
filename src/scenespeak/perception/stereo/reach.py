"""The dense map's reach: objects nearer or farther than every matched keypoint.

The stereo stage searches SGBM over the disparity range of its keypoint matches ± 8 px
(:func:`~scenespeak.perception.stereo.dense._disparity_range`), over the box round them
(``dense_crop``). That map is what the matches are checked against, and it must stay so (the
``points`` command gives the same points as ``describe``). But an object with no matched
keypoint in that range — a far postcard behind nearer objects, a near card below them — gets
no depth there: SGBM cannot find a disparity it does not search, and the values it gives at the
range's ends are cleaned away as no depth. Geometry first then has no segment for it.

:func:`widened` looks at the whole scene once more, coarsely: SGBM on the pair shrunk
``factor`` times (a sixteenth of the pixels at 4) over everything from ``near`` metres to
infinity — what the rig itself can see, not a guess at where the objects are. Where that
coarse map holds a depth the fine map could not have measured (outside its search range, or
outside the box it computed), over at least ``min_pixels`` pixels, the fine map is computed
again over those pixels' box and range only (± ``margin``), and those values are written into
a copy of it. The copy is the segmentation's map (the describe path's scene geometry); the
stereo stage's own map and its points are left as they are. A scene whose keypoints span its
objects pays the coarse look only (under a millisecond at 640 × 480).

>>> ReachOptions().factor, ReachOptions().near
(4, 0.3)
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray

from scenespeak.perception.features import to_gray
from scenespeak.perception.regions import clean_disparity
from scenespeak.perception.stereo.dense import dense_disparity, sgbm_map
from scenespeak.perception.stereo.results import DenseDisparity

__all__ = ["ReachOptions", "coarse_disparity", "widened"]


@dataclass(frozen=True)
class ReachOptions:
    """Knobs of :func:`widened`.

    Attributes
    ----------
    factor : int
        4 — the coarse look's shrink factor (each side).
    near : float
        0.3 m — the nearest depth the coarse look searches (the far end is infinity).
    min_pixels : int
        800 — least full-resolution pixels of one connected piece the fine map missed, below
        which nothing is redone (twice the region stage's least unknown segment: the coarse
        look's mismatches beside an occluding edge come in pieces of 30 coarse pixels, 480).
    margin : float
        8 px — the second fine pass searches the missed pixels' coarse disparities ± this (the
        stereo stage's own margin round its keypoints).
    pad : int
        16 px — context computed round the missed pixels' box (the stage's ``dense_margin``).
    """

    factor: int = 4
    near: float = 0.3
    min_pixels: int = 800
    margin: float = 8.0
    pad: int = 16


def coarse_disparity(
    left: NDArray[np.generic], right: NDArray[np.generic], dense: DenseDisparity, o: ReachOptions
) -> NDArray[np.float32]:
    """SGBM on the pair shrunk ``o.factor`` times, from ``o.near`` to infinity, as full-scale
    disparities on the shrunk grid (NaN where unknown or at the range's ends)."""
    rect = dense.rect
    f = max(int(o.factor), 1)
    gl, gr = to_gray(left), to_gray(right)
    size = (max(gl.shape[1] // f, 1), max(gl.shape[0] // f, 1))
    sl = np.ascontiguousarray(cv2.resize(gl, size, interpolation=cv2.INTER_AREA), np.uint8)
    sr = np.ascontiguousarray(cv2.resize(gr, size, interpolation=cv2.INTER_AREA), np.uint8)
    lo = -float(rect.doffs)
    hi = lo + min(gl.shape[1] / 2.0, rect.focal * rect.baseline / o.near)
    mn = math.floor(lo / f)
    num = int(16 * math.ceil(max(hi / f - mn, 16.0) / 16.0))
    # OpenCV computes nothing in the first mn + num columns: black columns stand in on the
    # left (as dense_disparity does), so that the image's own left part is searched too
    border = max(0, mn + num)
    if border:
        sl = np.asarray(cv2.copyMakeBorder(sl, 0, 0, border, 0, cv2.BORDER_CONSTANT, value=0))
        sr = np.asarray(cv2.copyMakeBorder(sr, 0, 0, border, 0, cv2.BORDER_CONSTANT, value=0))
    raw = sgbm_map(sl, sr, mn, num, 3, 10)[:, border:].astype(np.float32) / 16.0
    return clean_disparity(raw, mn, num) * np.float32(f)


def _missed(
    coarse: NDArray[np.float32], dense: DenseDisparity, o: ReachOptions
) -> NDArray[np.bool_]:
    """The coarse pixels inside the box the fine map computed whose depth lies outside its
    search range (with a pixel to spare at each end), in pieces of at least ``o.min_pixels``
    full-resolution pixels (a coarse look's lone mismatches are no object). Outside the box lie
    the floor and the background beyond the matched objects."""
    f = max(int(o.factor), 1)
    lo, hi = dense.min_disparity + 1.0, dense.min_disparity + dense.num_disparities - 2.0
    with np.errstate(invalid="ignore"):
        out = np.isfinite(coarse) & ((coarse < lo) | (coarse > hi))
    if dense.roi is not None:
        x0, y0, x1, y1 = dense.roi
        rows, cols = np.indices(coarse.shape)
        cx, cy = (cols + 0.5) * f, (rows + 0.5) * f
        out &= (cx >= x0) & (cx < x1) & (cy >= y0) & (cy < y1)
    if not out.any():
        return np.asarray(out)
    _n, lab, stats, _ = cv2.connectedComponentsWithStats(out.astype(np.uint8), connectivity=8)
    big = np.flatnonzero(stats[:, cv2.CC_STAT_AREA] * f * f >= o.min_pixels)
    return np.asarray(np.isin(lab, big[big > 0]))


def widened(
    left: NDArray[np.generic],
    right: NDArray[np.generic],
    dense: DenseDisparity,
    options: ReachOptions | None = None,
) -> DenseDisparity:
    """``dense`` with the depths it could not have measured added (module docstring), or
    ``dense`` itself when the coarse look finds none (or the pair is resampled).

    The result's search range spans both passes; each pass's values at its own range's ends
    are cleaned away first (NaN, :func:`~scenespeak.perception.regions.clean_disparity`), as the
    segmentation cleans a single map.
    """
    o = options or ReachOptions()
    rect = dense.rect
    if rect.maps_left is not None:
        return dense
    f = max(int(o.factor), 1)
    coarse = coarse_disparity(left, right, dense, o)
    missed = _missed(coarse, dense, o)
    if not missed.any():
        return dense
    rows, cols = np.nonzero(missed)
    h, w = dense.disparity.shape
    box = (
        max(int(cols.min()) * f - o.pad, 0),
        max(int(rows.min()) * f - o.pad, 0),
        min((int(cols.max()) + 1) * f + o.pad, w),
        min((int(rows.max()) + 1) * f + o.pad, h),
    )
    d = coarse[missed]
    mn = math.floor(float(d.min()) - o.margin)
    num = int(16 * math.ceil((float(d.max()) + o.margin - mn) / 16.0))
    extra = dense_disparity(left, right, rect, roi=box, min_disparity=mn, num_disparities=num)
    first = clean_disparity(dense.disparity, dense.min_disparity, dense.num_disparities)
    second = clean_disparity(extra.disparity, mn, num)
    # the second pass's values outside the first's range, where the coarse look saw that
    # depth (within ``margin`` of it): the missed object, not whatever else the wider search
    # lets through
    lo, hi = dense.min_disparity + 1.0, dense.min_disparity + dense.num_disparities - 2.0
    near = cv2.resize(
        np.where(missed, coarse, np.float32(np.nan)), (w, h), interpolation=cv2.INTER_NEAREST
    )
    with np.errstate(invalid="ignore"):
        take = (second < lo) | (second > hi)
        take &= np.abs(second - near) <= o.margin
    merged = np.where(take, second, first).astype(np.float32)
    lo_all = min(dense.min_disparity, mn)
    hi_all = max(dense.min_disparity + dense.num_disparities, mn + num)
    roi = dense.roi
    if roi is not None:
        roi = (min(roi[0], box[0]), min(roi[1], box[1]), max(roi[2], box[2]), max(roi[3], box[3]))
    return dataclasses.replace(
        dense, disparity=merged, min_disparity=lo_all, num_disparities=hi_all - lo_all, roi=roi
    )
