"""Geometric verification: RANSAC homography / similarity between a training view's keypoints
and the scene's, each inlier's SIFT scale and orientation checked against the model."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import cv2
import numpy as np
from numpy.typing import NDArray

from scenespeak.geometry.polygons import polygon_area
from scenespeak.perception.recognition.options import LabelOptions

# --------------------------------------------------------------------------------------------
# Geometric verification
# --------------------------------------------------------------------------------------------


#: RANSAC iterations for the homography and the similarity: OpenCV's default for
#: ``estimateAffinePartial2D`` (2000), also used for ``findHomography`` (default 2000 too).
RANSAC_MAX_ITERS = 2000
#: ``findHomography``'s RANSAC confidence (OpenCV's default is 0.995). The labelling's
#: figures in ``docs/database.md`` (recall, false objects) were measured with 0.999.
RANSAC_CONFIDENCE = 0.999
#: The similarity replaces a homography only with this many times its inliers: a looser
#: model that explains about as many matches is no better evidence.
SIMILARITY_MARGIN = 1.2
#: A plausible view is stretched at most this much in one direction relative to the other
#: (ratio of the singular values of the Jacobian at the matches' centre).
MAX_ANISOTROPY = 8.0
#: ... and scaled by at most this factor, up or down (a 64× zoom is no view of the object).
MAX_ZOOM = 64.0


def _local_jacobians(
    h: NDArray[np.float64], pts: NDArray[np.float64]
) -> tuple[tuple[NDArray[np.float64], ...], NDArray[np.float64]]:
    """Per-point 2×2 Jacobians of the homography (j00, j01, j10, j11, each (n,)) and w."""
    x, y = pts[:, 0], pts[:, 1]
    u = h[0, 0] * x + h[0, 1] * y + h[0, 2]
    v = h[1, 0] * x + h[1, 1] * y + h[1, 2]
    w = _w_of(h, pts)
    w2 = w**2
    j00 = (h[0, 0] * w - u * h[2, 0]) / w2
    j01 = (h[0, 1] * w - u * h[2, 1]) / w2
    j10 = (h[1, 0] * w - v * h[2, 0]) / w2
    j11 = (h[1, 1] * w - v * h[2, 1]) / w2
    return (j00, j01, j10, j11), w


def _w_of(h: NDArray[np.float64], pts: NDArray[np.float64]) -> NDArray[np.float64]:
    """The homogeneous coordinate ``w`` of each point mapped by ``h``."""
    return h[2, 0] * pts[:, 0] + h[2, 1] * pts[:, 1] + h[2, 2]


def _apply_h(h: NDArray[np.float64], pts: NDArray[np.float64]) -> NDArray[np.float64]:
    ph = np.hstack([pts, np.ones((len(pts), 1))]) @ h.T
    return ph[:, :2] / ph[:, 2:3]


@dataclass(frozen=True)
class _Fit:
    h: NDArray[np.float64]
    inliers: NDArray[np.bool_]
    model: str


class _Keys(NamedTuple):
    """Keypoints of one side of the matches: positions, SIFT scales and orientations."""

    xy: NDArray[np.float64]
    size: NDArray[np.float32]
    angle: NDArray[np.float32]


def _consistent(
    h: NDArray[np.float64], train: _Keys, query: _Keys, o: LabelOptions
) -> NDArray[np.bool_]:
    """Matches that agree with ``h`` in position, keypoint scale and orientation."""
    t_xy, t_size, t_angle = train
    q_xy, q_size, q_angle = query
    (j00, j01, j10, j11), w = _local_jacobians(h, t_xy)
    ok = w > 0
    proj = _apply_h(h, t_xy)
    ok &= np.linalg.norm(proj - q_xy, axis=1) <= o.ransac_threshold
    det = j00 * j11 - j01 * j10
    with np.errstate(invalid="ignore", divide="ignore"):
        scale = np.sqrt(np.abs(det))
        ratio = (q_size / np.maximum(t_size, 1e-6)) / scale
        ok &= np.abs(np.log(ratio)) <= math.log(o.max_scale_ratio)
    rot = np.degrees(np.arctan2(j10 - j01, j00 + j11))
    dang = (q_angle.astype(np.float64) - t_angle - rot + 180.0) % 360.0 - 180.0
    ok &= np.abs(dang) <= o.max_angle_deg
    return ok & np.isfinite(ratio)


def _plausible(
    h: NDArray[np.float64], outline: NDArray[np.float32], t_xy: NDArray[np.float64]
) -> bool:
    """Reject homographies that fold, mirror, or shrink/stretch the view beyond belief."""
    if not np.all(np.isfinite(h)):
        return False
    if np.any(_w_of(h, outline.astype(np.float64)) <= 0) or np.any(_w_of(h, t_xy) <= 0):
        return False
    # The Jacobian at the centre, in Python floats: the same IEEE operations, in the same
    # order, as _local_jacobians on a one-point array (and the same numbers), without the
    # overhead of NumPy calls on one element.
    x, y = t_xy.mean(axis=0).tolist()
    (h00, h01, h02), (h10, h11, h12), (h20, h21, h22) = h.tolist()
    u = h00 * x + h01 * y + h02
    v = h10 * x + h11 * y + h12
    w = h20 * x + h21 * y + h22
    w2 = w * w
    a = np.array(
        [
            [(h00 * w - u * h20) / w2, (h01 * w - u * h21) / w2],
            [(h10 * w - v * h20) / w2, (h11 * w - v * h21) / w2],
        ]
    )
    if np.linalg.det(a) <= 0:
        return False
    sv = np.linalg.svd(a, compute_uv=False)
    if sv[1] <= 0 or sv[0] / sv[1] > MAX_ANISOTROPY:
        return False
    scale = math.sqrt(sv[0] * sv[1])
    return 1.0 / MAX_ZOOM <= scale <= MAX_ZOOM


def _small_enough(
    outline_in_scene: NDArray[np.float64],
    inlier_xy: NDArray[np.float64],
    small_area: float,
    min_inliers_small: int,
) -> bool:
    """Whether a detection with fewer than ``min_inliers`` inliers may still be accepted.

    A far object covers few pixels and so carries few keypoints; a large projected outline
    with only a handful of inliers is more likely a chance agreement. Inliers are counted at
    distinct positions (SIFT gives one keypoint per dominant orientation at one place, and
    those copies are no independent evidence).
    """
    if small_area <= 0 or not np.all(np.isfinite(outline_in_scene)):
        return False
    distinct = np.unique(np.rint(inlier_xy), axis=0).shape[0]
    return distinct >= min_inliers_small and abs(polygon_area(outline_in_scene)) <= small_area


def _fit_homography(
    train: _Keys, query: _Keys, outline: NDArray[np.float32], o: LabelOptions
) -> _Fit | None:
    """RANSAC homography, refitted on its consistent inliers (least squares) when that keeps
    at least as many; None when it is implausible."""
    t_xy = train.xy
    src = t_xy.astype(np.float32)
    dst = query.xy.astype(np.float32)
    found, _ = cv2.findHomography(
        src,
        dst,
        cv2.RANSAC,
        ransacReprojThreshold=o.ransac_threshold,
        maxIters=RANSAC_MAX_ITERS,
        confidence=RANSAC_CONFIDENCE,
    )
    if found is None:
        return None
    h = np.asarray(found, dtype=np.float64)  # OpenCV returns float64: the same array
    if not _plausible(h, outline, t_xy):
        return None
    inl = _consistent(h, train, query, o)
    if inl.sum() >= 4:
        # Refit on the consistent inliers (least squares), then re-check.
        refit, _ = cv2.findHomography(src[inl], dst[inl], 0)
        h2 = None if refit is None else np.asarray(refit, dtype=np.float64)
        if h2 is not None and _plausible(h2, outline, t_xy[inl]):
            # The refit often returns the very same matrix (then so is the verdict).
            inl2 = inl if np.array_equal(h2, h) else _consistent(h2, train, query, o)
            if inl2.sum() >= inl.sum():
                h, inl = h2, inl2
    return _Fit(h / h[2, 2], inl, "homography")


def _fit_similarity(
    train: _Keys, query: _Keys, outline: NDArray[np.float32], o: LabelOptions
) -> _Fit | None:
    """RANSAC similarity (rotation, uniform scale, translation); None when implausible."""
    a, _ = cv2.estimateAffinePartial2D(
        train.xy.astype(np.float32),
        query.xy.astype(np.float32),
        method=cv2.RANSAC,
        ransacReprojThreshold=o.ransac_threshold,
        maxIters=RANSAC_MAX_ITERS,
    )
    if a is None:
        return None
    h = np.vstack([a, [0.0, 0.0, 1.0]]).astype(np.float64, copy=False)
    if not _plausible(h, outline, train.xy):
        return None
    return _Fit(h, _consistent(h, train, query, o), "similarity")


def _fit_view(
    train: _Keys, query: _Keys, outline: NDArray[np.float32], o: LabelOptions
) -> _Fit | None:
    """Fit a homography (with enough matches) and a similarity; return the better, or None."""
    n = train.xy.shape[0]
    best = _fit_homography(train, query, outline, o) if n >= o.homography_min else None
    # The similarity replaces the homography only if its inliers (a subset of the n matches)
    # exceed SIMILARITY_MARGIN times the homography's: when n itself does not, it cannot.
    if n >= 2 and (best is None or n > SIMILARITY_MARGIN * best.inliers.sum()):
        sim = _fit_similarity(train, query, outline, o)
        # Prefer the homography unless the similarity explains clearly more matches.
        if sim is not None and (
            best is None or sim.inliers.sum() > SIMILARITY_MARGIN * best.inliers.sum()
        ):
            best = sim
    return best
