"""Stage 2: left/right matching, triangulation, and dense depth for recognised regions.

Keypoints are detected once in each input image (as given); their positions are mapped into
rectified coordinates (:meth:`Rectification.rectify_points`), so sparse matching never resamples
an image. A match must

* pass Lowe's ratio test (default 0.6, as in the paper), where keypoints that OpenCV reports
  twice at the same place with different orientations do not count as the "second best";
* lie on the same rectified row within ``band_px`` (the epipolar band) with a positive
  disparity (a point in front of the cameras);
* be mutual: the right keypoint's best left keypoint is the same (cross check).

With a dense disparity map (OpenCV StereoSGBM with its left-right check, computed once per
pair) the matches are verified against it: the keypoint's disparity must agree with the dense
one and the dense map must be smooth around it (no depth edge, where a keypoint's position is
ambiguous between the two surfaces). In that mode the ratio test looks at the best and second
best right keypoints inside the epipolar band, which finds more correct matches, and the dense
check removes the wrong ones. :func:`stereo_points` does all of it in one call.

On the Middlebury 2014 *motorcycle* pair (``benchmarks/bench_stereo.py``) plain matching gives
751 matches with 93.1 % within 1 px of the ground-truth disparity; the default here gives more
than 750 with more than 97 %.

>>> import numpy as np
>>> from skimage import data
>>> from scenespeak.perception.calibration import StereoRig
>>> from scenespeak.perception.stereo import stereo_points
>>> L, R, _ = data.stereo_motorcycle()
>>> f, B = 994.978, 0.193001
>>> K1 = [[f, 0, 311.193], [0, f, 254.877], [0, 0, 1]]
>>> K2 = [[f, 0, 311.193 + 31.086], [0, f, 254.877], [0, 0, 1]]
>>> rig = StereoRig((741, 500), K1, K2, None, None, np.eye(3), [-B, 0, 0])
>>> res = stereo_points(L, R, rig)
>>> len(res.points) > 700, bool(np.all(res.points.xyz[:, 2] > 1.5))
(True, True)

The stage is a small package by concern; every name is importable from here:

* :mod:`~scenespeak.perception.stereo.results`: the frozen results (matches, points, the
  dense map, all of a pair);
* :mod:`~scenespeak.perception.stereo.images`: checking and reading a pair;
* :mod:`~scenespeak.perception.stereo.matching`: sparse matching (:func:`match_stereo`);
* :mod:`~scenespeak.perception.stereo.dense`: dense SGBM disparity (:func:`dense_disparity`);
* :mod:`~scenespeak.perception.stereo.sgbm`: OpenCV's 3-way SGBM compiled with Numba, the same
  map bit for bit (``dense`` chooses; imported by name, not re-exported: kept out of the start-up);
* :mod:`~scenespeak.perception.stereo.points`: triangulation and a region's dense points;
* :mod:`~scenespeak.perception.stereo.options`: the options objects (:class:`MatchOptions`,
  :class:`DenseOptions`, :class:`PointsOptions`); the old single keywords still work;
* :mod:`~scenespeak.perception.stereo.output`: the JSON object and PLY files;
* this module: :func:`stereo_points`, all of it in one call.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from scenespeak.errors import ImageError
from scenespeak.perception.calibration import Rectification, StereoRig, rectify
from scenespeak.perception.features import Features, detect, to_gray
from scenespeak.perception.stereo.dense import (
    SGBM_DISP12_MAX_DIFF,
    SGBM_P1_PER_PIXEL,
    SGBM_P2_PER_PIXEL,
    SGBM_SPECKLE_RANGE,
    SGBM_SPECKLE_WINDOW,
    dense_disparity,
)
from scenespeak.perception.stereo.images import check_pair, load_pair
from scenespeak.perception.stereo.matching import (
    _candidates,
    _no_matches,
    _select,
    _verify_dense,
    match_stereo,
)
from scenespeak.perception.stereo.options import (
    PLAIN_DENSE_MARGIN,
    DenseOptions,
    MatchOptions,
    PointsOptions,
)
from scenespeak.perception.stereo.output import points_to_json, write_ply
from scenespeak.perception.stereo.points import region_points, triangulate
from scenespeak.perception.stereo.results import (
    DenseDisparity,
    Points3D,
    StereoMatches,
    StereoResult,
)

__all__ = [
    "PLAIN_DENSE_MARGIN",
    "SGBM_DISP12_MAX_DIFF",
    "SGBM_P1_PER_PIXEL",
    "SGBM_P2_PER_PIXEL",
    "SGBM_SPECKLE_RANGE",
    "SGBM_SPECKLE_WINDOW",
    "DenseDisparity",
    "DenseOptions",
    "MatchOptions",
    "Points3D",
    "PointsOptions",
    "StereoMatches",
    "StereoResult",
    "check_pair",
    "dense_disparity",
    "load_pair",
    "match_stereo",
    "points_to_json",
    "region_points",
    "stereo_points",
    "triangulate",
    "write_ply",
]


def _dense_box(
    m: StereoMatches,
    rect: Rectification,
    extra: tuple[float, float, float, float] | None,
    margin: int,
) -> tuple[int, int, int, int]:
    """Bounding box (rectified pixels) of the matches to verify and of an input-image region."""
    return _pixel_box([m.left_rect], rect, extra, margin)


def _pixel_box(
    pts: list[NDArray[np.float64]],
    rect: Rectification,
    extra: tuple[float, float, float, float] | None,
    margin: int,
) -> tuple[int, int, int, int]:
    """Bounding box (rectified pixels) of rectified points and of an input-image region."""
    w, h = rect.rig.image_size
    pts = list(pts)
    if extra is not None:
        x0, y0, x1, y1 = (float(v) for v in extra)
        corners = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]], dtype=np.float64)
        pts.append(rect.rectify_points(corners, "left") if rect.needs_resampling else corners)
    if not pts:
        return (0, 0, 0, 0)
    xy = np.concatenate(pts)
    xy = xy[np.all(np.isfinite(xy), axis=1)]
    if len(xy) == 0:
        return (0, 0, 0, 0)
    lo = np.floor(xy.min(axis=0)).astype(int) - margin
    hi = np.ceil(xy.max(axis=0)).astype(int) + margin + 1
    return (max(0, int(lo[0])), max(0, int(lo[1])), min(w, int(hi[0])), min(h, int(hi[1])))


def _match_pair(
    fl: Features,
    fr: Features,
    gray: tuple[NDArray[np.generic], NDArray[np.generic]],
    rect: Rectification,
    o: PointsOptions,
) -> tuple[StereoMatches, DenseDisparity | None]:
    """The matches of :func:`stereo_points` and, with ``o.verify``, the dense map they passed."""
    if not (len(fl) and len(fr)):
        return _no_matches(), None
    cand = _candidates(fl, fr, rect, o.band_px, 0.0, None, need_global=not o.verify)
    mo = MatchOptions(band_px=o.band_px, min_disparity=0.0, max_disparity=None, mutual=True)
    if not o.verify:
        return _select(cand, fl, rect, "global", o.ratio, mo), None
    # the disparity range for SGBM comes from the strict in-band matches
    strict = _select(cand, fl, rect, "band", o.ratio, mo)
    m = _select(cand, fl, rect, "band", o.band_ratio, mo)
    roi = _dense_box(m, rect, o.dense_roi, o.dense_margin) if o.dense_crop else None
    dense = dense_disparity(
        gray[0], gray[1], rect, keypoint_disparities=strict.disparity, roi=roi, pad=16
    )
    m = m.subset(_verify_dense(m, dense, mo.dense_tol_px, mo.edge_px, mo.edge_window))
    return m, dense


def stereo_points(
    left_image: NDArray[np.generic],
    right_image: NDArray[np.generic],
    rig: StereoRig,
    *,
    rect: Rectification | None = None,
    features_left: Features | None = None,
    features_right: Features | None = None,
    options: PointsOptions | None = None,
    **overrides: object,
) -> StereoResult:
    """Match and triangulate a stereo pair in one call (SIFT runs once per image).

    Steps: check the pair against the rig; SIFT on each input image (OpenCV's classic
    upscaling, offset-corrected); the paper's matching (global ratio test, band, positive
    disparity, cross check); then, with ``verify``, dense SGBM over the disparity range of
    those matches, band-restricted ratio-test matching verified against it; triangulation.

    Parameters
    ----------
    left_image, right_image : ndarray
        The input images as given (gray or colour).
    rig : StereoRig
    rect : Rectification, optional
        Reuse a rectification (``rectify(rig)`` otherwise).
    features_left, features_right : Features, optional
        Reuse already detected features of these images.
    options : PointsOptions, optional
        Ratios, band, dense check, cropped dense map, minimum points, the names in error
        messages (a plain call's defaults otherwise; the pipeline's stereo stage passes
        ``stage_options.StereoOptions().keywords()``: the cropped map, 16 px margin).
    **overrides
        Single fields of :class:`PointsOptions` (``ratio=0.7``, ``dense_crop=True``,
        ``dense_roi=(x0, y0, x1, y1)``, ``left_name="l.png"``, ...), as the keywords this
        function took before it had options.

    Returns
    -------
    StereoResult
    """
    o = PointsOptions.with_overrides(options, overrides)
    left_name, right_name = o.left_name, o.right_name
    check_pair(left_image, right_image, rig, left_name=left_name, right_name=right_name)
    rect = rectify(rig) if rect is None else rect
    gl = to_gray(left_image)
    gr = to_gray(right_image)
    fl = detect(gl, precise_upscale=False) if features_left is None else features_left
    fr = detect(gr, precise_upscale=False) if features_right is None else features_right
    m, dense = _match_pair(fl, fr, (gl, gr), rect, o)
    if len(m) < o.min_points:
        raise ImageError(
            f"{left_name}, {right_name}",
            f"only {len(m)} stereo matches (need {o.min_points}): the images may be "
            "textureless, out of focus, or not a stereo pair of the same scene",
        )
    xyz = triangulate(m.left_rect, m.right_rect, rect)
    good = np.all(np.isfinite(xyz), axis=1)
    m = m.subset(good)
    pts = Points3D(
        xyz=xyz[good],
        left_xy=fl.xy[m.left_index],
        right_xy=fr.xy[m.right_index],
        descriptors=fl.descriptors[m.left_index],
        left_index=m.left_index,
        right_index=m.right_index,
        disparity=m.disparity,
    )
    return StereoResult(pts, fl, fr, rect, dense, m)
