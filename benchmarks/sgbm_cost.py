"""What the dense check's SGBM costs next to the two SIFT extractions, at each size.

For the real Art pair resized to 640×480, 1280×960 and 1920×1080 (as ``bench_points.py``
resizes it), this finds the search range and the crop the stage uses
(``stereo_points(..., **StereoOptions().keywords())``: minDisparity, numDisparities, the
box of the matches + 16 px) and times, interleaved, median wall (CPU) in ms:

* SIFT of both images one after the other, and in two threads, with OpenCV at 1 and at 2
  threads (``cv2.setNumThreads``);
* OpenCV's StereoSGBM (3-way, the stage's parameters) on the stage's crop with 1 and 2 threads,
  and at other ``numDisparities`` (64, 128, 192, 304) and block size 5 (2 threads);
* its median filter and speckle filter alone (in ``compute``, single-threaded).

It also checks that SGBM's map is the same, pixel for pixel, with 1 and 2 threads (OpenCV's
3-way mode cuts the image into 4 stripes whatever the thread count).

Run::

    python benchmarks/sgbm_cost.py [--repeat 3]
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from scenespeak.perception import calibration, stereo
from scenespeak.perception.features import detect, load_image, to_gray
from scenespeak.perception.stage_options import StereoOptions

#: the real data (``SCENESPEAK_REAL_DATA``, as the tests take it, or ``../shared/data/real``)
REAL = Path(
    os.environ.get("SCENESPEAK_REAL_DATA")
    or Path(__file__).resolve().parents[1] / "../shared/data/real"
)
ART = REAL / "stereo/middeval2/Art"


def _timed(fn: Callable[[], object]) -> tuple[float, float]:
    t0, c0 = time.perf_counter(), time.process_time()
    fn()
    return time.perf_counter() - t0, time.process_time() - c0


def _sgbm(cl: Any, cr: Any, mn: int, num: int, bs: int = 3) -> Any:
    matcher = cv2.StereoSGBM_create(  # the stage's parameters (stereo/dense.py)
        minDisparity=mn,
        numDisparities=num,
        blockSize=bs,
        P1=stereo.SGBM_P1_PER_PIXEL * bs * bs,
        P2=stereo.SGBM_P2_PER_PIXEL * bs * bs,
        disp12MaxDiff=stereo.SGBM_DISP12_MAX_DIFF,
        uniquenessRatio=10,
        speckleWindowSize=stereo.SGBM_SPECKLE_WINDOW,
        speckleRange=stereo.SGBM_SPECKLE_RANGE,
        mode=cv2.STEREO_SGBM_MODE_SGBM_3WAY,
    )
    return matcher.compute(cl, cr)


def _crop(gl: Any, gr: Any, dense: Any, pad: int = 16) -> tuple[Any, Any]:
    """The stage's SGBM input (``dense_disparity``'s crop and black border)."""
    h, w = gl.shape
    x0, y0, x1, y1 = dense.roi
    mn, num = dense.min_disparity, dense.num_disparities
    xa = x0 - max(0, mn + num)
    border = max(0, -xa)
    xa = max(0, xa)
    ya, yb, xb = max(0, y0 - pad), min(h, y1 + pad), min(w, x1 + pad)
    out = []
    for g in (gl, gr):
        c = np.ascontiguousarray(g[ya:yb, xa:xb])
        if border:
            c = cv2.copyMakeBorder(c, 0, 0, border, 0, cv2.BORDER_CONSTANT, value=0)
        out.append(c)
    return out[0], out[1]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    left0 = load_image(ART / "view1.png", gray=False)
    right0 = load_image(ART / "view5.png", gray=False)
    print(f"load average before: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    pool = ThreadPoolExecutor(max_workers=1)
    for size in ((640, 480), (1280, 960), (1920, 1080)):
        interp = cv2.INTER_AREA if size[0] < left0.shape[1] else cv2.INTER_LINEAR
        gl = to_gray(cv2.resize(left0, size, interpolation=interp))
        gr = to_gray(cv2.resize(right0, size, interpolation=interp))
        rig = calibration.rig_from_short(0.16, 60.0, size)
        dense = stereo.stereo_points(gl, gr, rig, **StereoOptions().keywords()).dense
        assert dense is not None and dense.roi is not None
        mn, num = dense.min_disparity, dense.num_disparities
        cl, cr = _crop(gl, gr, dense)

        def sift_seq(gl: Any = gl, gr: Any = gr) -> None:
            detect(gl, precise_upscale=False), detect(gr, precise_upscale=False)

        def sift_two(gl: Any = gl, gr: Any = gr) -> None:
            future = pool.submit(detect, gr, precise_upscale=False)
            detect(gl, precise_upscale=False)
            future.result()

        cases: dict[str, tuple[int, Callable[[], object]]] = {}
        for n in (1, 2):
            cases[f"SIFT both, cv {n} thr"] = (n, sift_seq)
            cases[f"SIFT 2 threads, cv {n} thr"] = (n, sift_two)
            cases[f"SGBM D={num}, {n} thr"] = (
                n,
                lambda cl=cl, cr=cr, mn=mn, num=num: _sgbm(cl, cr, mn, num),
            )
        for d in (64, 128, 192, 304):
            cases[f"SGBM D={d}"] = (2, lambda cl=cl, cr=cr, mn=mn, d=d: _sgbm(cl, cr, mn, d))
        cases["SGBM block 5"] = (2, lambda cl=cl, cr=cr, mn=mn, num=num: _sgbm(cl, cr, mn, num, 5))
        raw = _sgbm(cl, cr, mn, num)
        cases["median + speckles"] = (
            2,
            lambda raw=raw, mn=mn: cv2.filterSpeckles(
                cv2.medianBlur(raw, 3), (mn - 1) * 16, stereo.SGBM_SPECKLE_WINDOW, 32
            ),
        )
        times: dict[str, list[tuple[float, float]]] = {k: [] for k in cases}
        for _ in range(args.repeat):
            for k, (n, fn) in cases.items():
                cv2.setNumThreads(n)
                times[k].append(_timed(fn))
        maps = []
        for n in (1, 2):
            cv2.setNumThreads(n)
            maps.append(_sgbm(cl, cr, mn, num))
        cv2.setNumThreads(2)
        same = int(np.count_nonzero(maps[0] != maps[1]))
        print(
            f"\n{size[0]}×{size[1]}: minDisparity {mn}, numDisparities {num}, crop "
            f"{dense.roi}, SGBM input {cl.shape[1]}×{cl.shape[0]}; pixels that differ between "
            f"1 and 2 threads: {same}"
        )
        print("| case | wall (CPU) ms |\n| --- | ---: |")
        for k, t in times.items():
            w = 1000 * statistics.median(a for a, _ in t)
            c = 1000 * statistics.median(b for _, b in t)
            print(f"| {k} | {w:.0f} ({c:.0f}) |", flush=True)
    print(f"\nload average after: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")


if __name__ == "__main__":
    main()
