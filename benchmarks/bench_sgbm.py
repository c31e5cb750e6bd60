"""Benchmark of the compiled 3-way SGBM (``perception/stereo/sgbm.py``) against OpenCV's.

For the real Art pair (or ``--pair LEFT RIGHT``) resized to 640×480, 1280×960 and 1920×1080
(as ``bench_points.py`` resizes it), this finds the search range and the crop the stage's
dense check uses (``stereo_points(..., **StereoOptions().keywords())``) and times, interleaved
in one run, median wall (process CPU) in ms:

* ``cv2.StereoSGBM`` (3-way, the stage's parameters, ``compute``: map, median, speckles) with
  OpenCV's threads (``cv2.getNumThreads()``);
* the compiled copy on as many threads (Numba; its cached kernels loaded before timing);

and checks the two maps are identical, pixel for pixel. Also prints the cost volume's size
(matched columns × disparities × rows, what ``dense.COMPILED_MIN_CELLS`` is set against) and
what loading Numba costs a fresh process (import, the first compiled call), measured in a
subprocess.

Run::

    python benchmarks/bench_sgbm.py [--repeat 7] [--pair LEFT RIGHT] [--sizes 1920x1080 ...]
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from scenespeak.perception import calibration, stereo
from scenespeak.perception.features import load_image, to_gray
from scenespeak.perception.stage_options import StereoOptions
from scenespeak.perception.stereo import dense, sgbm

ART = Path(__file__).resolve().parents[1] / "../shared/data/real/stereo/middeval2/Art"

_LOAD = """
import time
t0, c0 = time.perf_counter(), time.process_time()
import numba  # noqa: F401
t1, c1 = time.perf_counter(), time.process_time()
import numpy as np
from scenespeak.perception.stereo import sgbm
g = np.zeros((64, 200), np.uint8)
sgbm.sgbm3way(g, g, sgbm.SgbmParams(0, 16, 3, 72, 288, 10, 1, 100, 2))
t2, c2 = time.perf_counter(), time.process_time()
print(f"{t1 - t0:.3f} {c1 - c0:.3f} {t2 - t1:.3f} {c2 - c1:.3f}")
"""


def timed(fn: Callable[[], object]) -> tuple[float, float]:
    """(wall, process CPU) seconds of one call."""
    t0, c0 = time.perf_counter(), time.process_time()
    fn()
    return time.perf_counter() - t0, time.process_time() - c0


def stage_crop(gl: Any, gr: Any, rig: Any) -> tuple[Any, Any, int, int]:
    """The stage's SGBM input for a gray pair: (left crop, right crop, minD, numD), as
    ``dense_disparity`` makes it (the matches' box + 16 px, black columns on the left)."""
    seen: list[tuple[Any, Any, int, int]] = []
    real = dense.sgbm_map

    def spy(cl: Any, cr: Any, mn: int, num: int, bs: int, u: int) -> Any:
        seen.append((cl, cr, mn, num))
        return real(cl, cr, mn, num, bs, u)

    dense.sgbm_map = spy  # type: ignore[assignment]
    try:
        stereo.stereo_points(gl, gr, rig, **StereoOptions().keywords())
    finally:
        dense.sgbm_map = real  # type: ignore[assignment]
    return seen[-1]


def _size(text: str) -> tuple[int, int]:
    w, h = text.lower().split("x")
    return int(w), int(h)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=7)
    parser.add_argument("--pair", nargs=2, type=Path, metavar=("LEFT", "RIGHT"))
    parser.add_argument(
        "--sizes", nargs="+", type=_size, default=[(640, 480), (1280, 960), (1920, 1080)]
    )
    args = parser.parse_args()
    paths = args.pair or (ART / "view1.png", ART / "view5.png")
    left0, right0 = (load_image(p, gray=False) for p in paths)
    out = subprocess.run(
        [sys.executable, "-c", _LOAD], capture_output=True, text=True, check=True
    ).stdout.split()
    iw, ic, kw, kc = (float(x) for x in out)
    print(
        f"a fresh process: import numba {1000 * iw:.0f} ({1000 * ic:.0f}) ms, first compiled "
        f"SGBM call (cached kernels) {1000 * kw:.0f} ({1000 * kc:.0f}) ms"
    )
    print(f"load average before: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    threads = max(1, cv2.getNumThreads())
    bs = 3
    for size in args.sizes:
        interp = cv2.INTER_AREA if size[0] < left0.shape[1] else cv2.INTER_LINEAR
        gl = to_gray(cv2.resize(left0, size, interpolation=interp))
        gr = to_gray(cv2.resize(right0, size, interpolation=interp))
        rig = calibration.rig_from_short(0.16, 60.0, size)
        cl, cr, mn, num = stage_crop(gl, gr, rig)
        h, w = cl.shape
        cells = max(0, w - max(mn + num, 0) + min(mn, 0)) * num * h
        matcher = dense.opencv_sgbm(mn, num, bs, 10)
        params = dense.compiled_params(mn, num, bs, 10)

        def compiled(cl: Any = cl, cr: Any = cr, params: Any = params) -> Any:
            return sgbm.sgbm3way(cl, cr, params, threads=threads)

        cases: dict[str, Callable[[], object]] = {
            "OpenCV": lambda m=matcher, cl=cl, cr=cr: m.compute(cl, cr),
            "compiled": compiled,
        }
        same = bool(np.array_equal(matcher.compute(cl, cr), compiled()))
        times: dict[str, list[tuple[float, float]]] = {k: [] for k in cases}
        for _ in range(args.repeat):  # interleaved: they share the machine's load
            for k, fn in cases.items():
                times[k].append(timed(fn))
        med = {
            k: (statistics.median(a for a, _ in t), statistics.median(b for _, b in t))
            for k, t in times.items()
        }
        (ow, oc), (nw, nc) = med["OpenCV"], med["compiled"]
        print(
            f"\n{size[0]}×{size[1]}: minDisparity {mn}, numDisparities {num}, SGBM input "
            f"{w}×{h}, {cells / 1e6:.0f}·10⁶ cells, {threads} threads; identical: {same}"
        )
        print("| SGBM | wall (CPU) ms |\n| --- | ---: |")
        print(f"| OpenCV | {1000 * ow:.0f} ({1000 * oc:.0f}) |")
        print(f"| compiled | {1000 * nw:.0f} ({1000 * nc:.0f}) |")
        print(f"| OpenCV / compiled | {ow / nw:.2f} ({oc / nc:.2f}) |", flush=True)
    print(f"\nload average after: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")


if __name__ == "__main__":
    main()
