"""Benchmark of the compiled 3-way SGBMs (``perception/stereo/sgbm.py``: C, Numba) against OpenCV's.

For the real Art pair (or ``--pair LEFT RIGHT``) resized to 640×480, 1280×960 and 1920×1080
(as ``bench_points.py`` resizes it), this finds the search range and the crop the stage's
dense check uses (``stereo_points(..., **StereoOptions().keywords())``) and times, interleaved
in one run, median wall (process CPU) in ms:

* ``cv2.StereoSGBM`` (3-way, the stage's parameters, ``compute``: map, median, speckles) with
  OpenCV's threads (``cv2.getNumThreads()``);
* the C extension (``_sgbm_c``, the copy of its loops for this CPU: ``_sgbm_c.isa()``) on as
  many threads, then OpenCV's median and speckle filters as ``compute`` ends with;
* the Numba loops on as many threads (their cached kernels loaded before timing; left out
  without Numba);

and checks the maps are identical, pixel for pixel. Also prints the cost volume's size
(matched columns × disparities × rows, what ``dense.COMPILED_MIN_CELLS`` is set against) and
what loading each copy costs a fresh process (import of the C extension; import of Numba and
the first compiled call), measured in subprocesses. The C column's ms per phase (its raw map
on 1 thread and on the threads, the median, the speckle filter) follow each table.

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

#: the real data (``SCENESPEAK_REAL_DATA``, as the tests take it, or ``../shared/data/real``)
REAL = Path(
    os.environ.get("SCENESPEAK_REAL_DATA")
    or Path(__file__).resolve().parents[1] / "../shared/data/real"
)
ART = REAL / "stereo/middeval2/Art"

_LOAD_C = """
import time
import scenespeak.perception.stereo  # what is loaded anyway where the SGBM runs
t0, c0 = time.perf_counter(), time.process_time()
from scenespeak.perception.stereo import _sgbm_c, sgbm
t1, c1 = time.perf_counter(), time.process_time()
print(f"{t1 - t0:.4f} {c1 - c0:.4f}")
"""

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


def _load_costs(numba: bool) -> None:
    """Print what loading each copy costs a fresh process (subprocesses)."""
    run = [sys.executable, "-c"]
    if sgbm.c_available():
        cw, cc = (float(x) for x in subprocess.run(
            [*run, _LOAD_C], capture_output=True, text=True, check=True
        ).stdout.split())  # fmt: skip
        print(
            f"a fresh process: import of sgbm.py and the C extension (after the stereo "
            f"package) {1000 * cw:.1f} ({1000 * cc:.1f}) ms"
        )
    if numba:
        out = subprocess.run([*run, _LOAD], capture_output=True, text=True, check=True)
        iw, ic, kw, kc = (float(x) for x in out.stdout.split())
        print(
            f"a fresh process: import numba {1000 * iw:.0f} ({1000 * ic:.0f}) ms, first "
            f"compiled SGBM call (cached kernels) {1000 * kw:.0f} ({1000 * kc:.0f}) ms"
        )


def _c_phases(cl: Any, cr: Any, params: Any, threads: int, repeat: int) -> str:
    """The C column's phases, median wall (CPU) ms: raw map on 1 thread and on ``threads``,
    OpenCV's median and speckle filter on it."""
    from scenespeak.perception.stereo import _sgbm_c

    h, w = cl.shape
    p = params
    raw = np.empty((h, w), np.int16)

    def kernel(t: int) -> Callable[[], object]:
        return lambda: _sgbm_c.raw(
            cl, cr, raw, h, w, p.min_disparity, p.num_disparities, p.block_size, p.p1, p.p2,
            p.uniqueness, p.disp12_max_diff, sgbm.OPENCV_LANES, t,
        )  # fmt: skip

    kernel(threads)()
    med = cv2.medianBlur(raw, 3)
    inv, rng = (p.min_disparity - 1) * 16, 16 * p.speckle_range
    phases: dict[str, Callable[[], object]] = {
        "raw map, 1 thread": kernel(1),
        f"raw map, {threads} threads": kernel(threads),
        "medianBlur": lambda: cv2.medianBlur(raw, 3),
        "filterSpeckles": lambda: cv2.filterSpeckles(med.copy(), inv, p.speckle_window, rng),
    }
    out = []
    for name, fn in phases.items():
        t = [timed(fn) for _ in range(repeat)]
        wall, cpu = statistics.median(a for a, _ in t), statistics.median(b for _, b in t)
        out.append(f"{name} {1000 * wall:.1f} ({1000 * cpu:.1f})")
    return "C phases, ms: " + "; ".join(out)


def _row(name: str, med: dict[str, tuple[float, float]]) -> str:
    w, c = med[name]
    ow, oc = med["OpenCV"]
    return f"| {name} | {1000 * w:.0f} ({1000 * c:.0f}) | {ow / w:.2f} ({oc / c:.2f}) |"


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
    kernels = [k for k, ok in (("C", sgbm.c_available()), ("Numba", sgbm.available())) if ok]
    _load_costs("Numba" in kernels)
    if "C" in kernels:
        from scenespeak.perception.stereo import _sgbm_c

        print(f"C loops for this CPU: copy {_sgbm_c.isa()} (2 x86-64-v4, 1 x86-64-v3, 0 base)")
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
        cases: dict[str, Callable[[], object]] = {
            "OpenCV": lambda m=matcher, cl=cl, cr=cr: m.compute(cl, cr)
        }
        for k in kernels:
            cases[k] = lambda cl=cl, cr=cr, p=params, k=k: sgbm.sgbm3way(
                cl, cr, p, threads=threads, kernel=k.lower()
            )
        want = cases["OpenCV"]()
        same = {k: bool(np.array_equal(want, cases[k]())) for k in kernels}
        times: dict[str, list[tuple[float, float]]] = {k: [] for k in cases}
        for _ in range(args.repeat):  # interleaved: they share the machine's load
            for k, fn in cases.items():
                times[k].append(timed(fn))
        med = {
            k: (statistics.median(a for a, _ in t), statistics.median(b for _, b in t))
            for k, t in times.items()
        }
        print(
            f"\n{size[0]}×{size[1]}: minDisparity {mn}, numDisparities {num}, SGBM input "
            f"{w}×{h}, {cells / 1e6:.0f}·10⁶ cells, {threads} threads; identical to OpenCV's: "
            + ", ".join(f"{k} {v}" for k, v in same.items())
        )
        print("| SGBM | wall (CPU) ms | OpenCV / this |\n| --- | ---: | ---: |")
        for k in cases:
            print(_row(k, med))
        if "C" in kernels and "Numba" in kernels:
            (nw, nc), (cw, cc) = med["Numba"], med["C"]
            print(f"| Numba / C | | {nw / cw:.2f} ({nc / cc:.2f}) |")
        if "C" in kernels:
            print(_c_phases(cl, cr, params, threads, args.repeat), flush=True)
    print(f"\nload average after: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")


if __name__ == "__main__":
    main()
