"""What the cropped dense check changes in ``scenespeak points``, on every real stereo pair.

Since issue 16 part C, ``points`` runs the pipeline's stereo stage: the dense SGBM check
cropped to the matches' bounding box plus 16 px (``StereoOptions``). Before, it checked them
against a map of the whole image. For every pair of ``../shared/data/real/stereo`` (34
Middlebury, 2 KITTI) resized to each size (as ``bench_points.py`` resizes them), this runs
SIFT once and both checks on the same features, and prints one JSON line per pair: the number
of points of each, how many only one of them has, and, where the ground truth is known, how
many points have a disparity within one ground-truth pixel (scaled with the resize) of it.
The last lines sum them per size.

Run::

    python benchmarks/points_crop.py [--sizes 640x480 1280x960 1920x1080] [--pairs Art Cones]
"""

from __future__ import annotations

import argparse
import json
import os
from collections import Counter
from pathlib import Path
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

from scenespeak.perception import calibration, stereo
from scenespeak.perception.features import detect, load_image, to_gray
from scenespeak.perception.stage_options import StereoOptions

ROOT = Path(__file__).resolve().parents[1] / "../shared/data/real/stereo"
#: (left, right, ground truth, its scale) of each set's file names (data README).
LAYOUTS = (
    ("view1.png", "view5.png", "disp1.png", 3.0),
    ("imL.png", "imR.png", "disp2.png", 4.0),
    ("imL.png", "imR.png", "truedisp.pgm", 16.0),
    ("imL.png", "imR.png", "disp2.pgm", 8.0),
    ("im2.ppm", "im6.ppm", "disp2.pgm", 8.0),
    ("left.png", "right.png", "disp_occ.png", 256.0),
)


def _pair(folder: Path) -> tuple[Path, Path, Path, float] | None:
    for left, right, truth, scale in LAYOUTS:
        if all((folder / f).exists() for f in (left, right, truth)):
            return folder / left, folder / right, folder / truth, scale
    return None


def _truth(path: Path, scale: float) -> NDArray[np.float64]:
    raw = np.asarray(cv2.imread(str(path), cv2.IMREAD_UNCHANGED), dtype=np.float64)
    return np.where(raw > 0, raw / scale, np.nan)


def _within_1px(
    points: list[dict[str, Any]], truth: NDArray[np.float64], size: tuple[int, int]
) -> tuple[int, int]:
    """(points with a known ground truth, of which within one ground-truth pixel)."""
    if not points:
        return 0, 0
    h0, w0 = truth.shape
    sx, sy = size[0] / w0, size[1] / h0
    xy = np.array([p["left"] for p in points], dtype=np.float64)
    disparity = np.array([p["left"][0] - p["right"][0] for p in points], dtype=np.float64)
    col = np.clip(np.rint((xy[:, 0] + 0.5) / sx - 0.5).astype(int), 0, w0 - 1)
    row = np.clip(np.rint((xy[:, 1] + 0.5) / sy - 0.5).astype(int), 0, h0 - 1)
    expected = truth[row, col] * sx
    known = np.isfinite(expected)
    return int(known.sum()), int((np.abs(disparity[known] - expected[known]) <= sx).sum())


def _size(text: str) -> tuple[int, int]:
    w, h = text.lower().split("x")
    return int(w), int(h)


def compare(folder: Path, size: tuple[int, int]) -> dict[str, Any] | None:
    """One pair at one size: both checks on the same SIFT features."""
    found = _pair(folder)
    if found is None:
        return None
    left_path, right_path, truth_path, scale = found
    left0, right0 = load_image(left_path, gray=False), load_image(right_path, gray=False)
    interp = cv2.INTER_AREA if size[0] < left0.shape[1] else cv2.INTER_LINEAR
    left = cv2.resize(left0, size, interpolation=interp)
    right = cv2.resize(right0, size, interpolation=interp)
    rig = calibration.rig_from_short(0.16, 60.0, size)
    fl = detect(to_gray(left), precise_upscale=False)
    fr = detect(to_gray(right), precise_upscale=False)
    got: dict[str, list[dict[str, Any]]] = {}
    for name, keywords in (
        ("whole", {"dense_crop": False}),
        ("crop", dict(StereoOptions().keywords())),
    ):
        result = stereo.stereo_points(
            left, right, rig, features_left=fl, features_right=fr, min_points=1, **keywords
        )
        got[name] = stereo.points_to_json(result.points)["points"]
    whole, crop = (Counter(json.dumps(p) for p in got[k]) for k in ("whole", "crop"))
    truth = _truth(truth_path, scale)
    return {
        "pair": f"{folder.parent.name}/{folder.name}",
        "size": f"{size[0]}x{size[1]}",
        "whole": len(got["whole"]),
        "crop": len(got["crop"]),
        "only_whole": sum((whole - crop).values()),
        "only_crop": sum((crop - whole).values()),
        "same": got["whole"] == got["crop"],
        "within_1px_whole": _within_1px(got["whole"], truth, size),
        "within_1px_crop": _within_1px(got["crop"], truth, size),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--sizes", nargs="+", type=_size, default=[(640, 480), (1280, 960), (1920, 1080)]
    )
    parser.add_argument("--pairs", nargs="*", help="folder names (default: every pair)")
    args = parser.parse_args()
    folders = [d for sub in ("middeval2", "kitti2012") for d in sorted((ROOT / sub).iterdir())
               if d.is_dir() and (not args.pairs or d.name in args.pairs)]  # fmt: skip
    print(f"load average before: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    for size in args.sizes:
        rows = [r for r in (compare(d, size) for d in folders) if r is not None]
        for r in rows:
            print(json.dumps(r), flush=True)
        total = {k: sum(r[k] for r in rows) for k in ("whole", "crop", "only_whole", "only_crop")}
        acc = {k: np.sum([r[f"within_1px_{k}"] for r in rows], axis=0) for k in ("whole", "crop")}
        print(
            f"{size[0]}x{size[1]}: {len(rows)} pairs, {sum(r['same'] for r in rows)} identical; "
            f"points {total['whole']} -> {total['crop']} (-{total['only_whole']} "
            f"+{total['only_crop']}); within 1 px: {acc['whole'][1]}/{acc['whole'][0]} -> "
            f"{acc['crop'][1]}/{acc['crop'][0]}",
            flush=True,
        )
    print(f"load average after: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")


if __name__ == "__main__":
    main()
