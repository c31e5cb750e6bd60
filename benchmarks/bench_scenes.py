"""Time the scene generator and summarise what it renders.

Usage::

    python benchmarks/bench_scenes.py [--n 10] [--size 640 480] [--out DIR]

Prints the median seconds per scene (both images, labels and ground truth) for the level and
the pitched rig, the seconds for one dataset's training views, and the objects per distance
band, visible fractions and relation counts (clear / ambiguous, with reasons). Timings on a
shared 2-core machine are noisy: read the medians.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from collections import Counter
from pathlib import Path

from scenespeak.tools.scenes import CATALOGUE, generate_scene, load_truth, render_training_views


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--n", type=int, default=10, help="scenes per rig")
    ap.add_argument("--size", type=int, nargs=2, default=(640, 480))
    ap.add_argument("--out", type=Path, default=None, help="keep the scenes here")
    args = ap.parse_args()
    size = (args.size[0], args.size[1])
    root = args.out or Path(tempfile.mkdtemp(prefix="bench-scenes-"))
    bands: Counter[str] = Counter()
    vis: list[float] = []
    rel: Counter[str] = Counter()
    for pitched in (False, True):
        times = []
        for i in range(args.n):
            t = time.perf_counter()
            d = generate_scene(
                root / f"{'pitched' if pitched else 'level'}_{i:03d}",
                seed=[0, i],
                pitched=pitched,
                image_size=size,
            )
            times.append(time.perf_counter() - t)
            truth = load_truth(d)
            for o in truth.objects:
                lo = min(int(o.distance * 2) / 2, 1.5)
                bands[f"{lo:.1f}-{lo + 0.5:.1f} m"] += 1
                vis.append(o.visible_fraction)
            for r in truth.relations:
                rel["ambiguous" if r.ambiguous else "clear"] += 1
                for reason in r.reasons:
                    rel[reason] += 1
        rig = "pitched" if pitched else "level"
        print(f"{rig:8s} rig: {statistics.median(times):.2f} s per scene (median of {args.n})")
    t = time.perf_counter()
    for obj in CATALOGUE:
        render_training_views(obj, root / "objects" / obj.label, image_size=size)
    print(f"training views: {time.perf_counter() - t:.1f} s for {len(CATALOGUE)} objects x 4 views")
    print("objects per distance band:", dict(sorted(bands.items())))
    print(
        f"visible fraction: median {statistics.median(vis):.2f}, min {min(vis):.2f}, "
        f"objects {len(vis)}"
    )
    print("relations:", dict(rel))
    print("scenes in", root)


if __name__ == "__main__":
    main()
