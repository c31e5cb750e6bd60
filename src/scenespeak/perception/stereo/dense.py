"""Dense disparity of a rectified pair: OpenCV StereoSGBM over a search range from the matches."""

from __future__ import annotations

import math
import os
import sys
from typing import TYPE_CHECKING, Any

import cv2
import numpy as np
from numpy.typing import ArrayLike, NDArray

from scenespeak.errors import ImageError
from scenespeak.perception.calibration import Rectification
from scenespeak.perception.features import to_gray
from scenespeak.perception.stereo.options import DenseOptions
from scenespeak.perception.stereo.results import DenseDisparity

if TYPE_CHECKING:
    from scenespeak.perception.stereo.sgbm import SgbmParams

__all__ = [
    "COMPILED_MIN_CELLS",
    "SGBM_DISP12_MAX_DIFF",
    "SGBM_ENV",
    "SGBM_P1_PER_PIXEL",
    "SGBM_P2_PER_PIXEL",
    "SGBM_SPECKLE_RANGE",
    "SGBM_SPECKLE_WINDOW",
    "compiled_params",
    "dense_disparity",
    "opencv_sgbm",
    "sgbm_kernel",
    "sgbm_map",
    "use_compiled",
]


def _disparity_range(
    rect: Rectification, disparities: NDArray[np.float64] | None, margin: float = 8.0
) -> tuple[int, int]:
    """(minDisparity, numDisparities) for SGBM from keypoint disparities, or a default."""
    w = rect.rig.image_size[0]
    d = None
    if disparities is not None and len(disparities) >= 3:
        # the range of the disparities that at least 3 matches share (within 2 px): isolated
        # mismatches do not widen it, a near object with a few keypoints stays inside
        srt = np.sort(np.asarray(disparities, dtype=np.float64))
        support = np.searchsorted(srt, srt + 2.0, "right") - np.searchsorted(srt, srt - 2.0)
        d = srt[support >= 3]
    if d is not None and len(d):
        lo = float(d.min()) - margin
        hi = float(d.max()) + margin
    else:
        # everything from 0.3 m to infinity, capped at half the image width
        lo = -rect.doffs
        hi = lo + min(w / 2.0, rect.focal * rect.baseline / 0.3)
    lo = max(lo, -rect.doffs)  # nothing behind infinity
    mn = math.floor(lo)
    span = min(max(hi - mn, 16.0), max(64.0, w / 2.0))  # at most half the image width
    num = int(16 * math.ceil(span / 16.0))
    return mn, num


#: SGBM's smoothness penalties per pixel of the block (one gray channel): P1 = 8·bs², P2 =
#: 32·bs², the values OpenCV's StereoSGBM documentation and its stereo_match sample give.
SGBM_P1_PER_PIXEL = 8
SGBM_P2_PER_PIXEL = 32
#: Left-right check: disparities whose right-to-left match differs by more than 1 px are
#: dropped (OpenCV's stereo_match sample uses 1).
SGBM_DISP12_MAX_DIFF = 1
#: Speckle filter: connected regions of at most 100 px whose disparity varies by at most 2 px
#: (OpenCV multiplies speckleRange by 16 for its fixed-point map) are noise and removed;
#: OpenCV's StereoSGBM docs suggest a window "somewhere in the 50-200 range" and a range of
#: "1 or 2".
SGBM_SPECKLE_WINDOW = 100
SGBM_SPECKLE_RANGE = 2
#: ``auto`` | ``c`` | ``opencv`` | ``numba``: which SGBM :func:`sgbm_map` runs
#: (:func:`sgbm_kernel`).
SGBM_ENV = "SCENESPEAK_SGBM"
#: Smallest cost volume (matched columns × disparities × rows) for which ``auto`` runs the
#: compiled SGBM: measured faster at 1280×960 and 1920×1080 (Art: about 2·10⁸ and 6.5·10⁸
#: cells), slower at 640×480 (3·10⁷; ``benchmarks/bench_sgbm.py``).
COMPILED_MIN_CELLS = 150_000_000


def dense_disparity(
    left: NDArray[np.generic],
    right: NDArray[np.generic],
    rect: Rectification,
    *,
    keypoint_disparities: ArrayLike | None = None,
    roi: tuple[int, int, int, int] | None = None,
    options: DenseOptions | None = None,
    **overrides: object,
) -> DenseDisparity:
    """Dense disparity of the rectified pair with OpenCV StereoSGBM (3-way mode).

    Parameters
    ----------
    left, right : ndarray
        The input images as given (gray or colour); they are rectified here if needed.
    rect : Rectification
    keypoint_disparities : array, optional
        Rectified disparities of sparse matches, to narrow the search (faster, fewer errors).
    roi : (x0, y0, x1, y1), optional
        Only compute for this part of the rectified left image (others are NaN); much faster
        for one small object.
    options : DenseOptions, optional
        Search range, block size, uniqueness, the context ``pad`` around ``roi`` (the defaults
        otherwise).
    **overrides
        Single fields of :class:`DenseOptions` (``block_size=5``, ``pad=16``, ...), as the
        keywords this function took before it had options.

    Returns
    -------
    DenseDisparity
        Left-right checked (``disp12MaxDiff = 1``), speckles removed; NaN where unknown.
    """
    o = DenseOptions.with_overrides(options, overrides)
    block_size = o.block_size
    gl = to_gray(left)
    gr = to_gray(right)
    if gl.shape != gr.shape:
        raise ImageError("dense_disparity", f"images differ in size: {gl.shape} vs {gr.shape}")
    # the rectified images' size (the maps'); only the crop below is rectified
    h, w = gl.shape if rect.maps_left is None else rect.maps_left[0].shape
    kd = None if keypoint_disparities is None else np.asarray(keypoint_disparities, float)
    mn_auto, num_auto = _disparity_range(rect, kd)
    mn = mn_auto if o.min_disparity is None else int(o.min_disparity)
    num = num_auto if o.num_disparities is None else int(o.num_disparities)
    num = int(16 * max(1, math.ceil(num / 16)))
    x0, y0, x1, y1 = (0, 0, w, h) if roi is None else roi
    x0, x1 = max(0, int(x0)), min(w, math.ceil(x1))
    y0, y1 = max(0, int(y0)), min(h, math.ceil(y1))
    out = np.full((h, w), np.nan, np.float32)
    box = None if roi is None else (x0, y0, x1, y1)
    if x1 <= x0 or y1 <= y0:
        return DenseDisparity(out, rect, mn, num, box)
    pad = block_size // 2 + 2 if o.pad is None else max(0, int(o.pad))
    # A crop: rows y0..y1; columns from far enough left that every disparity can be searched.
    # OpenCV computes nothing in the first minDisparity + numDisparities columns of its input;
    # where the crop would have to start left of the image, black columns stand in, so that
    # the image's own left part gets the disparities its right-image partners allow (pixels
    # whose partner would lie in the black band match nothing there).
    xa = x0 - max(0, mn + num)
    border = max(0, -xa)
    xa = max(0, xa)
    ya, yb = max(0, y0 - pad), min(h, y1 + pad)
    xb = min(w, x1 + pad)
    # the crop of the rectified pair: only its pixels are resampled (the whole images' remap
    # cost 2 full-size passes for a crop that may be a small part; the same pixels)
    cl, cr = (
        np.ascontiguousarray(g, dtype=np.uint8)
        for g in rect.rectify_images(gl, gr, window=(xa, ya, xb, yb))
    )
    if border:
        cl = np.asarray(cv2.copyMakeBorder(cl, 0, 0, border, 0, cv2.BORDER_CONSTANT, value=0))
        cr = np.asarray(cv2.copyMakeBorder(cr, 0, 0, border, 0, cv2.BORDER_CONSTANT, value=0))
    raw = sgbm_map(cl, cr, mn, num, int(block_size) | 1, o.uniqueness)
    _to_pixels(raw[y0 - ya : y1 - ya, border + x0 - xa : border + x1 - xa], mn, out[y0:y1, x0:x1])
    return DenseDisparity(out, rect, mn, num, box)


def sgbm_map(
    cl: NDArray[np.uint8], cr: NDArray[np.uint8], mn: int, num: int, bs: int, uniqueness: int
) -> NDArray[np.int16]:
    """OpenCV's 3-way StereoSGBM map of a gray pair with the stage's parameters (the
    module's constants), from OpenCV or from one of the compiled copies of it (the C
    extension or the Numba loops), which give the same int16 map bit for bit
    (:mod:`~scenespeak.perception.stereo.sgbm`); :func:`sgbm_kernel` chooses."""
    kernel = sgbm_kernel(cl.shape, mn, num, bs, uniqueness)
    if kernel != "opencv":
        from scenespeak.perception.stereo import sgbm

        params = compiled_params(mn, num, bs, uniqueness)
        threads = max(1, cv2.getNumThreads())
        return sgbm.sgbm3way(cl, cr, params, threads=threads, kernel=kernel)
    return np.asarray(opencv_sgbm(mn, num, bs, uniqueness).compute(cl, cr))


def opencv_sgbm(mn: int, num: int, bs: int, uniqueness: int) -> Any:
    """OpenCV's ``StereoSGBM`` (3-way mode) with the stage's parameters: P1 = 8·bs², P2 =
    32·bs², the left-right check and the speckle filter of this module's constants."""
    return cv2.StereoSGBM_create(  # type: ignore[attr-defined]
        minDisparity=mn,
        numDisparities=num,
        blockSize=bs,
        P1=SGBM_P1_PER_PIXEL * bs * bs,
        P2=SGBM_P2_PER_PIXEL * bs * bs,
        disp12MaxDiff=SGBM_DISP12_MAX_DIFF,
        uniquenessRatio=uniqueness,
        speckleWindowSize=SGBM_SPECKLE_WINDOW,
        speckleRange=SGBM_SPECKLE_RANGE,
        mode=cv2.STEREO_SGBM_MODE_SGBM_3WAY,
    )


def compiled_params(mn: int, num: int, bs: int, uniqueness: int) -> SgbmParams:
    """The same parameters as :func:`opencv_sgbm` for the compiled copy
    (:class:`~scenespeak.perception.stereo.sgbm.SgbmParams`)."""
    from scenespeak.perception.stereo import sgbm

    return sgbm.SgbmParams(
        min_disparity=mn,
        num_disparities=num,
        block_size=bs,
        p1=SGBM_P1_PER_PIXEL * bs * bs,
        p2=SGBM_P2_PER_PIXEL * bs * bs,
        uniqueness=uniqueness,
        disp12_max_diff=SGBM_DISP12_MAX_DIFF,
        speckle_window=SGBM_SPECKLE_WINDOW,
        speckle_range=SGBM_SPECKLE_RANGE,
    )


def use_compiled(shape: tuple[int, ...], mn: int, num: int, bs: int, uniqueness: int) -> bool:
    """Whether :func:`sgbm_map` runs a compiled copy of the SGBM (the C extension or the
    Numba loops) rather than OpenCV's: :func:`sgbm_kernel` is not ``"opencv"``."""
    return sgbm_kernel(shape, mn, num, bs, uniqueness) != "opencv"


def sgbm_kernel(shape: tuple[int, ...], mn: int, num: int, bs: int, uniqueness: int) -> str:
    """Which SGBM :func:`sgbm_map` runs: ``"c"``, ``"numba"`` or ``"opencv"``. The map is the
    same bit for bit whichever runs, so the choice changes only the time.

    ``SCENESPEAK_SGBM`` (read at every call):

    * ``opencv``: OpenCV's;
    * ``c``: the C extension (``_sgbm_c``, built at install time where a C compiler was
      found) wherever it can compute the call
      (:func:`~scenespeak.perception.stereo.sgbm.supported`), else OpenCV's;
    * ``numba``: the Numba loops wherever they can (Numba installed), else OpenCV's;
    * ``auto`` (default): the C extension where it is built and can compute the call (it
      was measured cheaper than OpenCV's at 640×480, 1280×960 and 1920×1080 and loads in
      about a millisecond; docs/calibration.md); without it, the Numba loops only for a cost
      volume of at least :data:`COMPILED_MIN_CELLS` cells **and** only when Numba is already
      loaded in this process (loading it costs a process 0.6-0.85 s of CPU, more than it
      saves on one 1920×1080 pair), else OpenCV's.

    ``SCENESPEAK_NO_NUMBA=1`` rules the Numba loops out.

    >>> sgbm_kernel((480, 737), 26, 96, 11, 10)  # blockSize 11: int16 sums could saturate
    'opencv'
    """
    value = os.environ.get(SGBM_ENV, "auto").strip().lower()
    if value not in ("auto", "c", "opencv", "numba"):
        raise ValueError(f"{SGBM_ENV}={value!r}: expected auto, c, opencv or numba")
    if value == "opencv":
        return "opencv"
    # imported only now: a process that never runs a copy does not pay for the module
    from scenespeak.perception.stereo import sgbm

    p2 = SGBM_P2_PER_PIXEL * bs * bs
    if not sgbm.supported((shape[0], shape[1]), mn, num, bs, p2, uniqueness):
        return "opencv"
    if value in ("auto", "c") and sgbm.c_available():
        return "c"
    if value == "c" or os.environ.get("SCENESPEAK_NO_NUMBA", "") not in ("", "0"):
        return "opencv"
    cells = max(0, shape[1] - max(mn + num, 0) + min(mn, 0)) * num * shape[0]
    if value == "auto" and (cells < COMPILED_MIN_CELLS or "numba" not in sys.modules):
        return "opencv"
    return "numba" if sgbm.available() else "opencv"


def _to_pixels(raw: NDArray[np.int16], mn: int, out: NDArray[np.float32]) -> None:
    """OpenCV's fixed-point disparities (1/16 px) as float32 pixels into ``out``, NaN where
    unknown (OpenCV marks those with ``(minDisparity - 1) * 16``).

    Only the part that is kept is converted, in place: at 1920×1080 the whole crop's
    ``astype`` / divide / mask / copy cost about 20 ms (issue 16). Exact: an int16 is a
    float32 exactly and 1/16 is a power of two, so the values are those of
    ``raw.astype(np.float32) / 16.0`` bit for bit.

    >>> out = np.zeros((1, 3), np.float32)
    >>> _to_pixels(np.array([[-16, 0, 40]], np.int16), 0, out)
    >>> out.tolist()
    [[nan, 0.0, 2.5]]
    """
    np.multiply(raw, np.float32(1.0 / 16.0), out=out)
    out[raw < mn * 16] = np.nan
