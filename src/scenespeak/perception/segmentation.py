"""The object in its own training photo, when the user gives no mask.

A user photographs an object on a plain background (a table, a floor, a wall). Without a mask,
the view's "outline" would be the whole image, and everything carried into a scene with it —
floor, background, the objects behind — would be taken for the object. :func:`object_mask`
finds the object instead:

1. **Background colours** from the image border (a strip of ``border`` pixels): k-means in
   CIE L*a*b* (``k`` centres, so that a floor lit unevenly and a wall above the horizon are both
   background).
2. **Foreground** = pixels farther from every background centre than a threshold scaled to the
   border's own spread (``max(min_distance, spread_factor × 90th percentile of the border's
   distances)``), opened and closed, holes filled; the largest component and those at least
   a fifth of its size are kept.
3. **GrabCut** (Rother, Kolmogorov, Blake, "GrabCut: interactive foreground extraction using
   iterated graph cuts", SIGGRAPH 2004) refines that mask on a half-size image: the mask's
   pixels are *probably foreground*, the rest *probably background*, the border strip *surely
   background*.

The result is trusted only when it holds most of the image's SIFT keypoints
(``min_keypoint_share``) and covers a plausible share of the image; otherwise ``None`` is
returned and the caller keeps the whole image (a close-up that fills the frame, like OpenCV's
``box.png``, has no background to find).

>>> import numpy as np
>>> img = np.full((120, 160, 3), 150, np.uint8)
>>> rng = np.random.default_rng(0)
>>> img[30:90, 50:110] = rng.integers(0, 255, (60, 60, 3))
>>> m = object_mask(img)
>>> m is not None and bool(m[60, 80]) and not bool(m[5, 5])
True
>>> int(m.sum()) in range(3000, 4200)
True
"""

from __future__ import annotations

from dataclasses import dataclass
from os import PathLike

import cv2
import numpy as np
from numpy.typing import NDArray

__all__ = ["MaskOptions", "object_mask", "training_mask"]


@dataclass(frozen=True)
class MaskOptions:
    """Knobs of :func:`object_mask`.

    Attributes
    ----------
    border : int
        Width in pixels of the strip that samples the background.
    k : int
        Background colour centres (k-means in L*a*b*).
    min_distance : float
        Least L*a*b* distance from the background that counts as object.
    spread_factor : float
        The threshold is at least this times the border's own 90th-percentile distance.
    grabcut_iterations : int
        GrabCut iterations (0: no refinement).
    min_area, max_area : float
        Shares of the image a believable object covers.
    min_keypoint_share : float
        The mask must hold at least this share of the given keypoints.
    """

    border: int = 6
    k: int = 4
    min_distance: float = 10.0
    spread_factor: float = 2.0
    grabcut_iterations: int = 3
    min_area: float = 0.002
    max_area: float = 0.9
    min_keypoint_share: float = 0.6


def _lab(image: NDArray[np.generic]) -> NDArray[np.float32]:
    img = np.asarray(image)
    if img.ndim == 2:
        img = np.repeat(img[:, :, None], 3, axis=2)
    img = np.ascontiguousarray(img[:, :, :3])
    if img.dtype != np.uint8:
        img = np.clip(img, 0, 255).astype(np.uint8)
    # cv2 wants BGR; the order only matters for the a*/b* signs, not for distances
    return cv2.cvtColor(img[:, :, ::-1], cv2.COLOR_BGR2LAB).astype(np.float32)


def _border_pixels(lab: NDArray[np.float32], b: int) -> NDArray[np.float32]:
    return np.concatenate(
        [
            lab[:b].reshape(-1, 3),
            lab[-b:].reshape(-1, 3),
            lab[b:-b, :b].reshape(-1, 3),
            lab[b:-b, -b:].reshape(-1, 3),
        ]
    )


def _distance_to_background(
    lab: NDArray[np.float32], opts: MaskOptions
) -> tuple[NDArray[np.float32], float]:
    """Per-pixel L*a*b* distance to the nearest background centre, and the threshold."""
    samples = _border_pixels(lab, opts.border)
    if len(samples) > 6000:
        samples = samples[:: len(samples) // 6000 + 1]
    k = int(min(opts.k, len(np.unique(samples.round(), axis=0))))
    criteria = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 20, 0.5)
    cv2.setRNGSeed(0)
    best = np.zeros((len(samples), 1), np.int32)
    _c, _lab_idx, centres = cv2.kmeans(samples, max(k, 1), best, criteria, 2, cv2.KMEANS_PP_CENTERS)
    flat = lab.reshape(-1, 3)
    d2 = ((flat**2).sum(1)[:, None] - 2.0 * flat @ centres.T + (centres**2).sum(1)[None, :]).min(
        axis=1
    )
    dist = np.sqrt(np.maximum(d2, 0.0)).reshape(lab.shape[:2])
    border = np.sqrt(
        np.maximum(
            (
                (samples**2).sum(1)[:, None]
                - 2.0 * samples @ centres.T
                + (centres**2).sum(1)[None, :]
            ).min(axis=1),
            0.0,
        )
    )
    spread = float(np.percentile(border, 90))
    return dist.astype(np.float32), max(opts.min_distance, opts.spread_factor * spread)


def _clean(fg: NDArray[np.bool_]) -> NDArray[np.bool_]:
    """Open, close, fill holes, keep the large components."""
    m = fg.astype(np.uint8)
    m = np.asarray(cv2.morphologyEx(m, cv2.MORPH_OPEN, np.ones((3, 3), np.uint8)), np.uint8)
    m = np.asarray(cv2.morphologyEx(m, cv2.MORPH_CLOSE, np.ones((7, 7), np.uint8)), np.uint8)
    n, lab, stats, _ = cv2.connectedComponentsWithStats(m, connectivity=8)
    if n <= 1:
        return np.zeros(fg.shape, bool)
    areas = stats[1:, cv2.CC_STAT_AREA]
    keep = np.flatnonzero(areas >= 0.2 * areas.max()) + 1
    m = np.isin(lab, keep).astype(np.uint8)
    contours, _ = cv2.findContours(m, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    filled = np.zeros_like(m)
    cv2.drawContours(filled, contours, -1, 1, thickness=cv2.FILLED)
    return filled.astype(bool)


def _grabcut(
    image: NDArray[np.generic], fg: NDArray[np.bool_], opts: MaskOptions
) -> NDArray[np.bool_]:
    """Refine ``fg`` with GrabCut on a half-size image; the border strip is sure background."""
    img = np.asarray(image)
    if img.ndim == 2:
        img = np.repeat(img[:, :, None], 3, axis=2)
    img = np.ascontiguousarray(img[:, :, :3]).astype(np.uint8)
    h, w = fg.shape
    small = np.asarray(
        cv2.resize(img, (max(w // 2, 1), max(h // 2, 1)), interpolation=cv2.INTER_AREA), np.uint8
    )
    init = cv2.resize(fg.astype(np.uint8), small.shape[1::-1], interpolation=cv2.INTER_NEAREST)
    gc = np.where(init > 0, cv2.GC_PR_FGD, cv2.GC_PR_BGD).astype(np.uint8)
    b = max(opts.border // 2, 1)
    gc[:b], gc[-b:], gc[:, :b], gc[:, -b:] = cv2.GC_BGD, cv2.GC_BGD, cv2.GC_BGD, cv2.GC_BGD
    bgd = np.zeros((1, 65), np.float64)
    fgd = np.zeros((1, 65), np.float64)
    try:
        cv2.grabCut(
            small, gc, (0, 0, 1, 1), bgd, fgd, opts.grabcut_iterations, cv2.GC_INIT_WITH_MASK
        )
    except cv2.error:
        return fg
    out = ((gc == cv2.GC_FGD) | (gc == cv2.GC_PR_FGD)).astype(np.uint8)
    out = cv2.resize(out, (w, h), interpolation=cv2.INTER_NEAREST).astype(bool)
    return _clean(out)


def object_mask(
    image: NDArray[np.generic],
    keypoints_xy: NDArray[np.floating] | None = None,
    options: MaskOptions | None = None,
) -> NDArray[np.bool_] | None:
    """The object's pixels in a photo of it on a plain background, or None.

    Parameters
    ----------
    image : (H, W) or (H, W, 3) array
        The training photo (RGB or gray, ``uint8``).
    keypoints_xy : (N, 2) array, optional
        SIFT keypoint positions (column, row): the mask must hold ``min_keypoint_share`` of them.
    options : MaskOptions, optional

    Returns
    -------
    (H, W) bool or None
        None when no believable object was found (no plain background): keep the whole image.
    """
    opts = options or MaskOptions()
    img = np.asarray(image)
    h, w = img.shape[:2]
    if min(h, w) < 4 * opts.border + 8:
        return None
    dist, threshold = _distance_to_background(_lab(img), opts)
    fg = _clean(dist > threshold)
    if fg.any() and opts.grabcut_iterations > 0:
        fg = _grabcut(img, fg, opts)
    share = float(fg.mean())
    if not opts.min_area <= share <= opts.max_area:
        return None
    if keypoints_xy is not None and len(keypoints_xy):
        xy = np.asarray(keypoints_xy, dtype=np.float64)
        c = np.clip(np.round(xy[:, 0]).astype(np.intp), 0, w - 1)
        r = np.clip(np.round(xy[:, 1]).astype(np.intp), 0, h - 1)
        if float(fg[r, c].mean()) < opts.min_keypoint_share:
            return None
    return fg


def training_mask(path: str | PathLike[str]) -> NDArray[np.bool_] | None:
    """:func:`object_mask` of the training photo at ``path`` (in colour, with its SIFT
    keypoints), or None to keep the whole image: what ``scenespeak db add`` and ``scenespeak
    evaluate`` use for a view given without a mask.

    Raises
    ------
    ImageError
        If the file cannot be read as an image (its name and the problem).
    """
    from scenespeak.perception.features import detect, load_image, to_gray

    img = load_image(path, gray=False)
    return object_mask(img, detect(to_gray(img)).xy)
