"""Where the wall time of ``scenespeak points`` goes on this machine: a timeline of its phases.

For the real Art pair (or ``--pair LEFT RIGHT``) resized as ``bench_points.py`` resizes it,
this runs the command's computation (``cli.points._stereo_points``) ``--repeat`` times per
size with the functions it calls wrapped, in this process only, by a recorder: SIFT of each
image (``features.detect``, the left in the calling thread, the right in the worker),
``plausibility.check_pair_order`` (worker), the stage's sparse matching (``_candidates``,
``_select``), its dense SGBM map (``dense_disparity``: crop, OpenCV's StereoSGBM with its
median and speckle filters, conversion) and the dense check (``_verify_dense``). For each
call it prints the median start and end (s from the computation's start), wall and the
calling thread's CPU (OpenCV's own worker threads are not in that column; they are in the
process CPU of the total line).

It also times SIFT of one image with OpenCV at 1 and 2 threads (``cv2.setNumThreads``):
wall, the calling thread's CPU and the process CPU, i.e. how much of SIFT already runs in
OpenCV's worker thread (the floor ``bench_points.py`` sets the target against, SIFT of both
images one after the other, is itself partly multi-threaded).

Run::

    python benchmarks/points_timeline.py [--repeat 3] [--pair LEFT RIGHT] [--sizes 640x480 ...]
"""

from __future__ import annotations

import functools
import os
import statistics
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import cv2

from bench_points import pair_arguments, resized_pair
from scenespeak.cli.points import _stereo_points
from scenespeak.perception import calibration, features, plausibility, stereo
from scenespeak.perception.features import detect, to_gray

#: the real data (``SCENESPEAK_REAL_DATA``, as the tests take it, or ``../shared/data/real``)
REAL = Path(
    os.environ.get("SCENESPEAK_REAL_DATA")
    or Path(__file__).resolve().parents[1] / "../shared/data/real"
)
ART = REAL / "stereo/middeval2/Art"
#: (module, attribute, phase name) of the calls recorded, in the order they run.
PHASES = (
    (features, "detect", "SIFT"),
    (plausibility, "check_pair_order", "pair-order check"),
    (stereo, "_candidates", "matching: candidates"),
    (stereo, "_select", "matching: selection"),
    (stereo, "dense_disparity", "dense SGBM map"),
    (stereo, "_verify_dense", "dense check"),
)


class Recorder:
    """Start, end (wall) and calling-thread CPU of every recorded call, from ``t0``."""

    def __init__(self) -> None:
        self.t0 = time.perf_counter()
        self.calls: list[tuple[str, str, float, float, float]] = []
        self._lock = threading.Lock()

    def wrap(self, name: str, fn: Callable[..., Any]) -> Callable[..., Any]:
        """``fn`` recording each of its calls as phase ``name``."""

        @functools.wraps(fn)
        def recorded(*args: Any, **kwargs: Any) -> Any:
            start, cpu = time.perf_counter(), time.thread_time()
            try:
                return fn(*args, **kwargs)
            finally:
                end, used = time.perf_counter(), time.thread_time() - cpu
                thread = (
                    "main" if threading.current_thread() is threading.main_thread() else "worker"
                )
                with self._lock:
                    self.calls.append((name, thread, start - self.t0, end - self.t0, used))

        return recorded


@contextmanager
def recording(rec: Recorder) -> Iterator[None]:
    """The :data:`PHASES` wrapped by ``rec`` while inside."""
    saved = [(mod, attr, getattr(mod, attr)) for mod, attr, _ in PHASES]
    try:
        for mod, attr, name in PHASES:
            setattr(mod, attr, rec.wrap(name, getattr(mod, attr)))
        yield
    finally:
        for mod, attr, fn in saved:
            setattr(mod, attr, fn)


def _size(text: str) -> tuple[int, int]:
    w, h = text.lower().split("x")
    return int(w), int(h)


def _sift_threads(gray: Any, repeat: int) -> list[str]:
    """SIFT of one image at 1 and 2 OpenCV threads: wall, caller CPU, process CPU."""
    rows = []
    before = cv2.getNumThreads()
    try:
        for n in (1, 2):
            cv2.setNumThreads(n)
            runs = []
            for _ in range(repeat):
                t, c, p = time.perf_counter(), time.thread_time(), time.process_time()
                detect(gray, precise_upscale=False)
                runs.append(
                    (time.perf_counter() - t, time.thread_time() - c, time.process_time() - p)
                )
            wall, caller, process = (statistics.median(r[i] for r in runs) for i in range(3))
            share = 1.0 - caller / process if process > 0 else 0.0
            rows.append(
                f"| SIFT of one image, OpenCV at {n} thread(s) | {wall:.3f} | {caller:.3f} "
                f"| {process:.3f} | {share:.0%} |"
            )
    finally:
        cv2.setNumThreads(before)
    return rows


def main() -> None:
    args, left0, right0 = pair_arguments(__doc__.splitlines()[0], 3)
    names = (Path("left"), Path("right"))
    for size in args.sizes:
        left, right = resized_pair(left0, right0, size)
        rig = calibration.rig_from_short(0.16, 60.0, size)
        runs = []
        for _ in range(args.repeat):
            rec = Recorder()
            p0 = time.process_time()
            with recording(rec):
                _stereo_points(stereo, left, right, rig, ratio=0.6, sources=names)
            total = (time.perf_counter() - rec.t0, time.process_time() - p0)
            runs.append((total, sorted(rec.calls, key=lambda c: c[2])))
        wall = statistics.median(r[0][0] for r in runs)
        cpu = statistics.median(r[0][1] for r in runs)
        print(f"\n{size[0]}×{size[1]}: the computation {wall:.3f} s wall, {cpu:.3f} s process CPU")
        print("| phase | thread | start | end | wall | caller CPU |")
        print("| --- | --- | ---: | ---: | ---: | ---: |")
        for i, (name, thread, *_) in enumerate(runs[0][1]):
            cols = [statistics.median(r[1][i][k] for r in runs) for k in (2, 3, 4)]
            print(
                f"| {name} | {thread} | {cols[0]:.3f} | {cols[1]:.3f} | "
                f"{cols[1] - cols[0]:.3f} | {cols[2]:.3f} |"
            )
        print("\n| SIFT | wall | caller CPU | process CPU | in OpenCV's workers |")
        print("| --- | ---: | ---: | ---: | ---: |")
        print("\n".join(_sift_threads(to_gray(left), args.repeat)), flush=True)
    print(f"\nload average after: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")


if __name__ == "__main__":
    main()
