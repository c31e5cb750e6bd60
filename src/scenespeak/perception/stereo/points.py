"""Triangulation of rectified correspondences and the 3-D points of a region of a dense map."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from scenespeak.errors import ImageError
from scenespeak.perception.calibration import Rectification
from scenespeak.perception.stereo.results import DenseDisparity

__all__ = ["region_points", "triangulate"]


def triangulate(
    left_rect: ArrayLike, right_rect: ArrayLike, rect: Rectification
) -> NDArray[np.float64]:
    """3-D points from rectified pixel correspondences, in the ORIGINAL left camera frame.

    Closed form for a rectified pair: ``Z = f B / (x_l − x_r + doffs)``,
    ``X = (x_l − cx) Z / f``, ``Y = (ȳ − cy) Z / fy`` with ȳ the mean of both rows; then
    rotated back from the rectified frame (``R1ᵀ``). Non-positive disparities give NaN.

    Parameters
    ----------
    left_rect, right_rect : (N, 2) array
        Rectified positions (column, row) in the left and right images.
    rect : Rectification

    Returns
    -------
    (N, 3) ndarray
    """
    pl = np.asarray(left_rect, dtype=np.float64).reshape(-1, 2)
    pr = np.asarray(right_rect, dtype=np.float64).reshape(-1, 2)
    P1 = rect.P1
    f, fy = P1[0, 0], P1[1, 1]
    cx, cy = P1[0, 2], P1[1, 2]
    skew = P1[0, 1]
    d = pl[:, 0] - pr[:, 0] + rect.doffs
    with np.errstate(divide="ignore", invalid="ignore"):
        Z = np.where(d > 0, f * rect.baseline / d, np.nan)
        y = 0.5 * (pl[:, 1] + pr[:, 1])
        Y = (y - cy) * Z / fy
        X = (pl[:, 0] - cx - skew * (y - cy) / fy) * Z / f
    return rect.to_original(np.column_stack([X, Y, Z]))


def region_points(
    dense: DenseDisparity,
    mask: NDArray[np.bool_],
    *,
    max_points: int | None = 2000,
    seed: int = 0,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """3-D points of every pixel with a disparity inside a region of the INPUT left image.

    Parameters
    ----------
    dense : DenseDisparity
        From :func:`dense_disparity` (computed once per pair).
    mask : (h, w) bool
        The region in the input left image's pixel grid (e.g. a recognised object's training
        outline carried over by a homography).
    max_points : int or None
        Subsample evenly (seeded) to at most this many points.
    seed : int
        Seed of the subsampling.

    Returns
    -------
    xyz : (N, 3) float64
        Points in the original left camera frame.
    left_xy : (N, 2) float64
        Their pixel positions in the input left image.
    """
    rect = dense.rect
    disp = dense.disparity
    h, w = disp.shape
    m = np.asarray(mask, dtype=bool)
    if m.shape != (h, w):
        raise ImageError("region mask", f"has shape {m.shape} but the images are {w}x{h} (w x h)")
    if rect.maps_left is None:
        rows = np.flatnonzero(m.any(axis=1))
        cols = np.flatnonzero(m.any(axis=0))
        if len(rows):  # within the mask's bounding box; row-major as np.nonzero(m) gives
            r0, c0 = int(rows[0]), int(cols[0])
            ys, xs = np.nonzero(m[r0 : int(rows[-1]) + 1, c0 : int(cols[-1]) + 1])
            ys, xs = ys + r0, xs + c0
        else:
            ys = xs = np.zeros(0, dtype=np.intp)
        ok = np.isfinite(disp[ys, xs])
        ys, xs = ys[ok], xs[ok]
        src_x, src_y = xs.astype(np.float64), ys.astype(np.float64)
    else:
        mx, my = rect.maps_left
        ix = np.rint(mx).astype(np.intp)
        iy = np.rint(my).astype(np.intp)
        inside = (ix >= 0) & (ix < w) & (iy >= 0) & (iy < h)
        rmask = np.zeros((h, w), bool)
        rmask[inside] = m[iy[inside], ix[inside]]
        ys, xs = np.nonzero(rmask & np.isfinite(disp))
        src_x, src_y = mx[ys, xs].astype(np.float64), my[ys, xs].astype(np.float64)
    if max_points is not None and len(xs) > max_points:
        rng = np.random.default_rng(seed)
        keep = np.sort(rng.choice(len(xs), size=max_points, replace=False))
        xs, ys, src_x, src_y = xs[keep], ys[keep], src_x[keep], src_y[keep]
    d = disp[ys, xs].astype(np.float64)
    left_rect = np.column_stack([xs, ys]).astype(np.float64)
    right_rect = np.column_stack([xs - d, ys]).astype(np.float64)
    xyz = triangulate(left_rect, right_rect, rect)
    good = np.all(np.isfinite(xyz), axis=1)
    return xyz[good], np.column_stack([src_x, src_y])[good]
