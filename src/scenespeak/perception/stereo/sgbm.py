"""OpenCV's StereoSGBM (3-way mode) again, compiled (C or Numba): the same map, bit for bit.

:func:`sgbm3way` gives what ``cv2.StereoSGBM_create(..., mode=STEREO_SGBM_MODE_SGBM_3WAY)
.compute(left, right)`` gives for one gray pair (Hirschmüller 2008, "Stereo Processing by
Semiglobal Matching and Mutual Information", IEEE TPAMI 30(2); in OpenCV's variant: block
costs from Birchfield-Tomasi pixel costs, three paths - left, right, top - and a pseudo
left-right check; ``modules/stereo/src/stereosgbm.cpp``):

* OpenCV's image cut into 4 horizontal stripes (fixed, "to make the results fully
  reproducible", whatever ``cv2.getNumThreads()``), each with ``blockSize // 2 + 1 +
  ceil(0.1 · stripe)`` rows of overlap above it, run here on up to ``threads`` threads (the
  compiled loops release the GIL);
* the same int16 integers (costs, paths, sums; the sub-pixel parabola;
  ties between equal summed costs broken as OpenCV's 8-lane vector loop breaks them, see
  :data:`OPENCV_LANES`);
* then OpenCV's own ``medianBlur`` (3×3) and ``filterSpeckles``, the two steps ``compute``
  ends with.

Two kernels compute the raw map (``kernel=``): ``_sgbm_c`` (``_sgbm_c.c``, an ahead-of-time
C extension that ``setup.py`` builds where a C compiler is found: loads in milliseconds) and
``_sgbm3way`` (Numba loops, the readable reference; loading Numba costs a process 0.6-0.85 s).
Which one the dense stage runs: :func:`scenespeak.perception.stereo.dense.sgbm_kernel`
(docs/calibration.md, "The dense map without OpenCV's SGBM" and "The dense map in C").
"""

from __future__ import annotations

import importlib
import math
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

__all__ = [
    "OPENCV_LANES",
    "SgbmParams",
    "available",
    "c_available",
    "fits_int16",
    "sgbm3way",
    "supported",
]

#: int16 lanes of the vector loop in this OpenCV's SGBM (its baseline build, SSE3: 128-bit
#: registers; ``stereosgbm.cpp`` is not among the dispatched files). Only the choice among
#: equal summed costs depends on it.
OPENCV_LANES = 8
#: OpenCV's 3-way mode always cuts the image into this many stripes.
STRIPES = 4
#: Largest pixel cost of one block pixel: 30 (clipped Sobel, preFilterCap 15) + 255 >> 2.
_PIXEL_COST_MAX = 30 + (255 >> 2)


def available() -> bool:
    """Whether Numba is installed (the Numba loops need it)."""
    import importlib.util  # here: ``scenespeak points`` does not pay for it at start-up

    return importlib.util.find_spec("numba") is not None


def c_available() -> bool:
    """Whether the C kernel (``_sgbm_c``, built by ``setup.py`` where a C compiler was found
    at install time) can be imported.

    >>> isinstance(c_available(), bool)
    True
    """
    try:
        importlib.import_module(_C_MODULE)
    except ImportError:
        return False
    return True


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


_C_MODULE = "scenespeak.perception.stereo._sgbm_c"


def _kernel() -> Any:
    return importlib.import_module("scenespeak.perception.stereo._sgbm3way")


@dataclass(frozen=True)
class SgbmParams:
    """``cv2.StereoSGBM_create``'s parameters for the 3-way mode (``preFilterCap`` 0, i.e. 15).

    Attributes
    ----------
    min_disparity, num_disparities : int
        The search range; ``num_disparities`` a positive multiple of 16.
    block_size : int
        Odd; :func:`fits_int16` must hold with ``p2`` and ``uniqueness``.
    p1, p2 : int
        The smoothness penalties, ``0 < p1 < p2``.
    uniqueness : int
        uniquenessRatio, 0..99 (0: no test).
    disp12_max_diff : int
        > 0.
    speckle_window, speckle_range : int
        ``filterSpeckles``' region size (0: none) and range (in pixels; × 16 for the map).
    """

    min_disparity: int
    num_disparities: int
    block_size: int
    p1: int
    p2: int
    uniqueness: int
    disp12_max_diff: int
    speckle_window: int
    speckle_range: int

    def check(self, shape: tuple[int, int]) -> None:
        """Raise ``ValueError`` naming what is outside the set the copy computes."""
        h, w = shape
        mn, nd, bs = self.min_disparity, self.num_disparities, self.block_size
        if nd <= 0 or nd % 16 or bs < 1 or bs % 2 == 0:
            raise ValueError(
                f"sgbm3way: numDisparities {nd} (multiple of 16) / blockSize {bs} (odd)"
            )
        if (
            not (0 < self.p1 < self.p2)
            or self.disp12_max_diff <= 0
            or not 0 <= self.uniqueness < 100
        ):
            raise ValueError(
                f"sgbm3way: P1 {self.p1}, P2 {self.p2} (0 < P1 < P2), disp12MaxDiff "
                f"{self.disp12_max_diff} (> 0), uniquenessRatio {self.uniqueness} (0..99)"
            )
        if not fits_int16(bs, self.p2, self.uniqueness):
            raise ValueError(f"sgbm3way: blockSize {bs} with P2 {self.p2} may saturate int16 costs")
        if w - max(mn + nd, 0) + min(mn, 0) <= 0:
            raise ValueError(
                f"sgbm3way: no column of the {w}-px images has all of disparities "
                f"{mn}..{mn + nd - 1} inside the right image"
            )
        if not supported(shape, mn, nd, bs, self.p2, self.uniqueness):
            raise ValueError(f"sgbm3way: {h} rows are too few for OpenCV's 4 overlapping stripes")


def sgbm3way(
    left: NDArray[np.uint8],
    right: NDArray[np.uint8],
    params: SgbmParams,
    *,
    threads: int = 2,
    lanes: int = OPENCV_LANES,
    kernel: str = "numba",
) -> NDArray[np.int16]:
    """The disparity map of OpenCV's 3-way StereoSGBM with these parameters (int16, 1/16 px,
    ``(min_disparity - 1) · 16`` where unknown), computed by the compiled loops.

    Parameters
    ----------
    left, right : ndarray of uint8, shape (h, w)
        The rectified gray pair (``cv2`` ``img1``, ``img2``).
    params : SgbmParams
        ``StereoSGBM_create``'s parameters (:meth:`SgbmParams.check` must pass).
    threads : int
        Threads for the 4 stripes (the loops release the GIL).
    lanes : int
        The vector width whose tie-breaking is reproduced (:data:`OPENCV_LANES`).
    kernel : {"numba", "c"}
        The Numba loops (``_sgbm3way.py``, the readable reference) or the C extension
        (``_sgbm_c.c``, built at install time; :func:`c_available`): the same integers.

    Returns
    -------
    ndarray of int16, shape (h, w)
        ``sgbm.compute(left, right)`` bit for bit.

    Raises
    ------
    ValueError
        Parameters outside that set (use OpenCV for them), images of different sizes, or an
        unknown ``kernel``.
    ImportError
        ``kernel="c"`` where the extension was not built (reinstall with a C compiler).
    """
    gl = np.ascontiguousarray(left, dtype=np.uint8)
    gr = np.ascontiguousarray(right, dtype=np.uint8)
    if gl.ndim != 2 or gl.shape != gr.shape:
        raise ValueError(f"sgbm3way needs two gray images of one size, got {gl.shape}, {gr.shape}")
    h, w = gl.shape
    params.check((h, w))
    workers = max(1, min(STRIPES, int(threads)))
    if kernel == "c":
        raw = _raw_c(gl, gr, params, workers, int(lanes))
    elif kernel == "numba":
        k = _kernel()
        ch1 = np.empty((h, 2, 3, w), np.uint8)
        ch2 = np.empty((h, 2, 3, w), np.uint8)
        k.channels(gl, ch1, False)
        k.channels(gr, ch2, True)
        raw = _stripes(k, (ch1, ch2), params, workers, int(lanes))
    else:
        raise ValueError(f"sgbm3way: kernel {kernel!r}, expected 'c' or 'numba'")
    disp: Any = cv2.medianBlur(raw, 3)
    if params.speckle_window > 0:
        invalid = (params.min_disparity - 1) * 16
        win, rng = int(params.speckle_window), 16 * int(params.speckle_range)
        disp, _ = cv2.filterSpeckles(disp, invalid, win, rng)
    return np.asarray(disp, np.int16)


def _raw_c(
    gl: NDArray[np.uint8], gr: NDArray[np.uint8], p: SgbmParams, workers: int, lanes: int
) -> NDArray[np.int16]:
    """The C kernel's raw map (before the median and speckle filters): its own threads over
    OpenCV's 4 stripes, without the GIL."""
    c = importlib.import_module(_C_MODULE)
    h, w = gl.shape
    raw = np.empty((h, w), np.int16)
    c.raw(
        gl, gr, raw, h, w, p.min_disparity, p.num_disparities, p.block_size, p.p1, p.p2,
        p.uniqueness, p.disp12_max_diff, lanes, workers,
    )  # fmt: skip
    return raw


def _stripes(k: Any, imgs: tuple[Any, Any], p: SgbmParams, workers: int, lanes: int) -> Any:
    """OpenCV's 4 stripes on ``workers`` threads, assembled as OpenCV assembles them (row i
    from stripe ``i // stripe_sz``): the raw map before the median and speckle filters."""
    import threading  # here, as the thread pool: not paid by a process that never comes here
    from concurrent.futures import ThreadPoolExecutor

    h, w = imgs[0].shape[0], imgs[0].shape[3]
    mn, nd, bs = p.min_disparity, p.num_disparities, p.block_size
    stripe_sz = math.ceil(h / STRIPES)
    overlap = bs // 2 + 1 + math.ceil(0.1 * stripe_sz)
    parts = [np.empty((stripe_sz + overlap, w), np.int16) for _ in range(STRIPES)]
    w1 = w - max(mn + nd, 0) + min(mn, 0)
    cfg = (mn, nd, bs // 2, p.p1, p.p2, p.uniqueness, p.disp12_max_diff, lanes)
    spaces: dict[int, tuple[Any, ...]] = {}  # one set of buffers per thread of this call

    def run(n: int) -> None:
        work = spaces.setdefault(threading.get_ident(), k.workspace(w, w1, nd, bs // 2))
        k.stripe(imgs, n, (stripe_sz, overlap), cfg, parts[n], work)

    if workers == 1:
        for n in range(STRIPES):
            run(n)
    else:
        with ThreadPoolExecutor(max_workers=workers) as pool:
            list(pool.map(run, range(STRIPES)))
    raw = np.empty((h, w), np.int16)
    for n in range(STRIPES):
        a, b = n * stripe_sz, min(h, (n + 1) * stripe_sz)
        if a < b:
            raw[a:b] = parts[n][overlap : overlap + b - a]
    return raw
