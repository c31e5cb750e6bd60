"""Benchmark of ``scenespeak points``' stereo stage against SIFT alone.

For a real pair (MiddEval2 "Art", or ``--pair LEFT RIGHT``) resized to 640×480, 1280×960 and
1920×1080, prints median wall-clock times, interleaved in one run, of:

* SIFT of both images, one after the other (the floor the target is set against: ``points``
  must take at most this + 25 %);
* the command's stage today (``cli.points._stereo_points``: SIFT of both images in two
  threads, the dense check cropped to the matches plus 16 px);
* the stage as it was (``stereo.stereo_points`` over the whole image, SIFT one after the other);

and checks that the two give the same points. Images are decoded before timing.

Run::

    python benchmarks/bench_points.py [--repeat 5] [--pair LEFT RIGHT]
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import cv2

from scenespeak.cli.points import _stereo_points
from scenespeak.perception import calibration, stereo
from scenespeak.perception.features import detect, load_image, to_gray

ART = Path(__file__).resolve().parents[1] / "../shared/data/real/stereo/middeval2/Art"


def median_s(fn: Callable[[], object], repeat: int) -> list[float]:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return times


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--pair", nargs=2, type=Path, metavar=("LEFT", "RIGHT"))
    args = parser.parse_args()
    left_path, right_path = args.pair or (ART / "view1.png", ART / "view5.png")
    left0, right0 = load_image(left_path), load_image(right_path)
    print(f"load average before: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    print(f"pair: {left_path.name} / {right_path.name}, resized\n")
    print("| size | SIFT both (s) | points now (s) | now / SIFT | before (s) | same points |")
    print("| --- | ---: | ---: | ---: | ---: | --- |")
    names = (Path("left"), Path("right"))
    for size in ((640, 480), (1280, 960), (1920, 1080)):
        left = cv2.resize(left0, size, interpolation=cv2.INTER_AREA)
        right = cv2.resize(right0, size, interpolation=cv2.INTER_AREA)
        rig = calibration.rig_from_short(0.16, 60.0, size)

        def sift(left=left, right=right) -> object:
            return detect(to_gray(left), precise_upscale=False), detect(
                to_gray(right), precise_upscale=False
            )

        def now(left=left, right=right, rig=rig) -> Any:
            return _stereo_points(stereo, left, right, rig, ratio=0.6, sources=names)

        def before(left=left, right=right, rig=rig) -> Any:
            return stereo.stereo_points(left, right, rig, ratio=0.6).points

        t_sift: list[float] = []
        t_now: list[float] = []
        t_before: list[float] = []
        for _ in range(args.repeat):  # interleaved: the three share the machine's load
            t_sift += median_s(sift, 1)
            t_now += median_s(now, 1)
            t_before += median_s(before, 1)
        a, b = now(), before()
        same = stereo.points_to_json(a) == stereo.points_to_json(b)
        s, n, o = (statistics.median(t) for t in (t_sift, t_now, t_before))
        print(
            f"| {size[0]}×{size[1]} | {s:.3f} | {n:.3f} | {n / s:.2f} | {o:.3f} | "
            f"{'yes' if same else 'NO'} ({len(a.xyz)} points) |"
        )
    print(f"\nload average after: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")


if __name__ == "__main__":
    main()
