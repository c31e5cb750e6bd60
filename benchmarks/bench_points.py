"""Benchmark of ``scenespeak points``' stereo stage against SIFT alone.

For a real pair (MiddEval2 "Art", or ``--pair LEFT RIGHT``, e.g. a generated scene's
``left.png right.png``) resized to 640×480, 1280×960 and 1920×1080, read in colour as the
command reads them, prints median wall-clock and process-CPU times, interleaved in one run, of:

* SIFT of both images, one after the other (the floor the target is set against: ``points``
  must take at most this + 25 %), and the two in two threads (as the command runs them);
* the command's stage (``cli.points._stereo_points``: the pipeline's stereo stage, threaded
  SIFT, the dense check cropped to the matches + 16 px, ``StereoOptions``);
* the stage the command ran before issue 16 part C (threaded SIFT, the dense check over the
  whole image), to show what the crop saves and how many points it changes;

and checks that the command gives describe's points (``stereo_points(...,
**StereoOptions().keywords())``). Images are decoded before timing.

Run::

    python benchmarks/bench_points.py [--repeat 5] [--pair LEFT RIGHT] [--sizes 640x480 ...]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import cv2

from scenespeak.cli.points import _stereo_points
from scenespeak.perception import calibration, stereo
from scenespeak.perception.features import detect, load_image, to_gray
from scenespeak.perception.stage_options import StereoOptions

ART = Path(__file__).resolve().parents[1] / "../shared/data/real/stereo/middeval2/Art"


def timed(fn: Callable[[], object]) -> tuple[float, float]:
    """(wall, process CPU) seconds of one call."""
    t0, c0 = time.perf_counter(), time.process_time()
    fn()
    return time.perf_counter() - t0, time.process_time() - c0


def _size(text: str) -> tuple[int, int]:
    w, h = text.lower().split("x")
    return int(w), int(h)


def _threaded_sift(left: Any, right: Any) -> tuple[Any, Any]:
    """SIFT of both images, the right one in a second thread."""
    with ThreadPoolExecutor(max_workers=1) as pool:
        future = pool.submit(detect, to_gray(right), precise_upscale=False)
        fl = detect(to_gray(left), precise_upscale=False)
        return fl, future.result()


def _whole(left: Any, right: Any, rig: Any) -> Any:
    """The command before issue 16 part C: threaded SIFT, the dense check over the whole
    image."""
    fl, fr = _threaded_sift(left, right)
    return stereo.stereo_points(
        left, right, rig, features_left=fl, features_right=fr, dense_crop=False, min_points=1
    ).points


def _same(a: Any, b: Any) -> str:
    pa, pb = stereo.points_to_json(a)["points"], stereo.points_to_json(b)["points"]
    if pa == pb:
        return "yes"
    sa, sb = ({json.dumps(p) for p in x} for x in (pa, pb))
    return f"NO (+{len(sa - sb)} -{len(sb - sa)})"


def _ratio(med: dict[str, tuple[float, float]], k: str) -> str:
    """Case ``k`` over SIFT of both images: wall (CPU)."""
    return f"{med[k][0] / med['sift'][0]:.2f} ({med[k][1] / med['sift'][1]:.2f})"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--pair", nargs=2, type=Path, metavar=("LEFT", "RIGHT"))
    parser.add_argument(
        "--sizes", nargs="+", type=_size, default=[(640, 480), (1280, 960), (1920, 1080)]
    )
    args = parser.parse_args()
    left_path, right_path = args.pair or (ART / "view1.png", ART / "view5.png")
    left0, right0 = load_image(left_path, gray=False), load_image(right_path, gray=False)
    print(f"load average before: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    print(f"pair: {left_path} / {right_path}, resized; wall (CPU) medians, s\n")
    print(
        "| size | SIFT both | SIFT, 2 threads | points now | now / SIFT | before (whole image) "
        "| before / SIFT | now = describe's stage | now vs before |"
    )
    print("| --- | ---: | ---: | ---: | ---: | ---: | ---: | --- | --- |")
    names = (Path("left"), Path("right"))
    for size in args.sizes:
        interp = cv2.INTER_AREA if size[0] < left0.shape[1] else cv2.INTER_LINEAR
        left = cv2.resize(left0, size, interpolation=interp)
        right = cv2.resize(right0, size, interpolation=interp)
        rig = calibration.rig_from_short(0.16, 60.0, size)

        def sift(left: Any = left, right: Any = right) -> object:
            return detect(to_gray(left), precise_upscale=False), detect(
                to_gray(right), precise_upscale=False
            )

        def now(left: Any = left, right: Any = right, rig: Any = rig) -> Any:
            return _stereo_points(stereo, left, right, rig, ratio=0.6, sources=names)

        def sift2(left: Any = left, right: Any = right) -> object:
            return _threaded_sift(left, right)

        def before(left: Any = left, right: Any = right, rig: Any = rig) -> Any:
            return _whole(left, right, rig)

        cases = {"sift": sift, "sift2": sift2, "now": now, "before": before}
        times: dict[str, list[tuple[float, float]]] = {k: [] for k in cases}
        for _ in range(args.repeat):  # interleaved: they share the machine's load
            for k, fn in cases.items():
                times[k].append(timed(fn))
        med = {
            k: (statistics.median(w for w, _ in t), statistics.median(c for _, c in t))
            for k, t in times.items()
        }
        got, old = now(), before()
        describe = stereo.stereo_points(left, right, rig, **StereoOptions().keywords()).points
        cell = {k: f"{w:.3f} ({c_:.3f})" for k, (w, c_) in med.items()}

        print(
            f"| {size[0]}×{size[1]} | {cell['sift']} | {cell['sift2']} | {cell['now']} | "
            f"{_ratio(med, 'now')} | {cell['before']} | {_ratio(med, 'before')} | "
            f"{_same(got, describe)} ({len(got.xyz)} points) | {_same(got, old)} |"
        )
    print(f"\nload average after: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")


if __name__ == "__main__":
    main()
