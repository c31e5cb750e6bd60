"""OpenCV's StereoSGBM (3-way mode) again, compiled with Numba: the same map, bit for bit.

:func:`sgbm3way` gives what ``cv2.StereoSGBM_create(..., mode=STEREO_SGBM_MODE_SGBM_3WAY)
.compute(left, right)`` gives for one gray pair (Hirschmüller 2008, "Stereo Processing by
Semiglobal Matching and Mutual Information", IEEE TPAMI 30(2); in OpenCV's variant: block
costs from Birchfield-Tomasi pixel costs, three paths - left, right, top - and a pseudo
left-right check; ``modules/stereo/src/stereosgbm.cpp``):

* OpenCV's image cut into 4 horizontal stripes (fixed, "to make the results fully
  reproducible", whatever ``cv2.getNumThreads()``), each with ``blockSize // 2 + 1 +
  ceil(0.1 · stripe)`` rows of overlap above it, run here on up to ``threads`` threads (the
  compiled loops release the GIL);
* the same int16 arithmetic in the same order (costs, paths, sums; the sub-pixel parabola;
  ties between equal summed costs broken as OpenCV's 8-lane vector loop breaks them, see
  :data:`OPENCV_LANES`);
* then OpenCV's own ``medianBlur`` (3×3) and ``filterSpeckles``, the two steps ``compute``
  ends with.

Where it is used, and why only there: :func:`scenespeak.perception.stereo.dense.use_compiled`
(docs/calibration.md, "The dense map without OpenCV's SGBM").
"""

from __future__ import annotations

import importlib
import importlib.util
import math
import threading
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

__all__ = ["OPENCV_LANES", "available", "fits_int16", "sgbm3way", "supported"]

#: int16 lanes of the vector loop in this OpenCV's SGBM (its baseline build, SSE3: 128-bit
#: registers; ``stereosgbm.cpp`` is not among the dispatched files). Only the choice among
#: equal summed costs depends on it.
OPENCV_LANES = 8
#: OpenCV's 3-way mode always cuts the image into this many stripes.
STRIPES = 4
#: Largest pixel cost of one block pixel: 30 (clipped Sobel, preFilterCap 15) + 255 >> 2.
_PIXEL_COST_MAX = 30 + (255 >> 2)


def available() -> bool:
    """Whether Numba is installed (the compiled loops need it)."""
    return importlib.util.find_spec("numba") is not None


def fits_int16(block_size: int, p2: int, uniqueness: int) -> bool:
    """Whether no int16 sum of the 3-way SGBM can saturate, so that plain int16 arithmetic
    (here) and OpenCV's saturating vector arithmetic give the same numbers.

    A block cost is at most ``P2 + 93 · blockSize²``; a path cost at most the block cost; the
    sum of the three paths three times that; the uniqueness threshold
    ``100 · min / (100 - ratio) + 1`` must fit too.

    >>> fits_int16(3, 32 * 9, 10), fits_int16(11, 32 * 121, 10)
    (True, False)
    """
    total = 3 * (p2 + _PIXEL_COST_MAX * block_size * block_size)
    thresh = (100 * total) // max(1, 100 - uniqueness) + 1 if uniqueness > 0 else 0
    return max(total, thresh) <= 32767


def supported(
    shape: tuple[int, int],
    min_disparity: int,
    num_disparities: int,
    block_size: int,
    p2: int,
    uniqueness: int,
) -> bool:
    """Whether :func:`sgbm3way` computes this call (else it raises ``ValueError``): D a
    positive multiple of 16, an odd block, no int16 saturation (:func:`fits_int16`), at least
    one column with every candidate partner inside the right image (OpenCV fails without),
    and enough rows for OpenCV's 4 overlapping stripes.

    >>> supported((480, 640), 0, 64, 3, 288, 10), supported((8, 640), 0, 64, 3, 288, 10)
    (True, False)
    """
    h, w = int(shape[0]), int(shape[1])
    mn, nd, bs = int(min_disparity), int(num_disparities), int(block_size)
    if nd <= 0 or nd % 16 or bs < 1 or bs % 2 == 0 or not 0 <= uniqueness < 100:
        return False
    if w - max(mn + nd, 0) + min(mn, 0) <= 0:
        return False
    stripe_sz = math.ceil(h / STRIPES)
    return fits_int16(bs, p2, uniqueness) and stripe_sz >= bs // 2 + 1 + math.ceil(0.1 * stripe_sz)


def _kernel() -> Any:
    return importlib.import_module("scenespeak.perception.stereo._sgbm3way")


def sgbm3way(
    left: NDArray[np.uint8],
    right: NDArray[np.uint8],
    *,
    min_disparity: int,
    num_disparities: int,
    block_size: int,
    p1: int,
    p2: int,
    uniqueness: int,
    disp12_max_diff: int,
    speckle_window: int,
    speckle_range: int,
    threads: int = 2,
    lanes: int = OPENCV_LANES,
) -> NDArray[np.int16]:
    """The disparity map of OpenCV's 3-way StereoSGBM with these parameters (int16, 1/16 px,
    ``(min_disparity - 1) · 16`` where unknown), computed by the compiled loops.

    Parameters
    ----------
    left, right : ndarray of uint8, shape (h, w)
        The rectified gray pair (``cv2`` ``img1``, ``img2``).
    min_disparity, num_disparities, block_size, p1, p2, uniqueness, disp12_max_diff,
    speckle_window, speckle_range : int
        ``StereoSGBM_create``'s parameters (``preFilterCap`` 0, i.e. 15). ``num_disparities``
        a positive multiple of 16, ``block_size`` odd, ``0 < p1 < p2``, ``disp12_max_diff >
        0``, and :func:`fits_int16` must hold.
    threads : int
        Threads for the 4 stripes (the loops release the GIL).
    lanes : int
        The vector width whose tie-breaking is reproduced (:data:`OPENCV_LANES`).

    Returns
    -------
    ndarray of int16, shape (h, w)
        ``sgbm.compute(left, right)`` bit for bit.

    Raises
    ------
    ValueError
        Parameters outside that set (use OpenCV for them).
    """
    gl = np.ascontiguousarray(left, dtype=np.uint8)
    gr = np.ascontiguousarray(right, dtype=np.uint8)
    if gl.ndim != 2 or gl.shape != gr.shape:
        raise ValueError(f"sgbm3way needs two gray images of one size, got {gl.shape}, {gr.shape}")
    h, w = gl.shape
    mn, nd, bs = int(min_disparity), int(num_disparities), int(block_size)
    if nd <= 0 or nd % 16 or bs < 1 or bs % 2 == 0:
        raise ValueError(f"sgbm3way: numDisparities {nd} (multiple of 16) / blockSize {bs} (odd)")
    if not (0 < p1 < p2) or disp12_max_diff <= 0 or not 0 <= uniqueness < 100:
        raise ValueError(
            f"sgbm3way: P1 {p1}, P2 {p2} (0 < P1 < P2), disp12MaxDiff {disp12_max_diff} (> 0), "
            f"uniquenessRatio {uniqueness} (0..99)"
        )
    if not fits_int16(bs, p2, uniqueness):
        raise ValueError(f"sgbm3way: blockSize {bs} with P2 {p2} may saturate int16 costs")
    invalid = (mn - 1) * 16
    stripe_sz = math.ceil(h / STRIPES)
    overlap = bs // 2 + 1 + math.ceil(0.1 * stripe_sz)
    if w - max(mn + nd, 0) + min(mn, 0) <= 0:
        raise ValueError(
            f"sgbm3way: no column of the {w}-px images has all of disparities {mn}..{mn + nd - 1}"
            " inside the right image"
        )
    if stripe_sz < overlap:
        raise ValueError(f"sgbm3way: {h} rows are too few for OpenCV's 4 overlapping stripes")
    k = _kernel()
    ch1 = np.empty((h, 2, 3, w), np.uint8)
    ch2 = np.empty((h, 2, 3, w), np.uint8)
    k.channels(gl, ch1, False)
    k.channels(gr, ch2, True)
    ch2r = ch2
    parts = [np.empty((stripe_sz + overlap, w), np.int16) for _ in range(STRIPES)]
    w1 = w - max(mn + nd, 0) + min(mn, 0)
    workers = max(1, min(STRIPES, int(threads)))
    spaces: dict[int, tuple[Any, ...]] = {}  # one set of buffers per thread of this call

    def run(n: int) -> None:
        work = spaces.setdefault(threading.get_ident(), k.workspace(w, w1, nd, bs // 2))
        k.stripe(
            ch1, ch2r, n, stripe_sz, overlap, mn, nd, bs // 2, int(p1), int(p2),
            int(uniqueness), int(disp12_max_diff), int(lanes), parts[n], work,
        )  # fmt: skip

    if workers == 1:
        for n in range(STRIPES):
            run(n)
    else:
        with ThreadPoolExecutor(max_workers=workers) as pool:
            list(pool.map(run, range(STRIPES)))
    raw = np.empty((h, w), np.int16)  # OpenCV's assembly: row i from stripe i // stripe_sz
    for n in range(STRIPES):
        a, b = n * stripe_sz, min(h, (n + 1) * stripe_sz)
        if a < b:
            raw[a:b] = parts[n][overlap : overlap + b - a]
    disp: Any = cv2.medianBlur(raw, 3)
    if speckle_window > 0:
        disp, _ = cv2.filterSpeckles(disp, invalid, int(speckle_window), 16 * int(speckle_range))
    return np.asarray(disp, np.int16)
