"""Stereo stage on the Middlebury 2014 *motorcycle* pair (scikit-image, ground-truth disparity).

Prints, for the plain baseline (OpenCV SIFT, brute-force kNN, ratio 0.6, epipolar band,
positive disparity) and for ``scenespeak.perception.stereo.stereo_points``:

* matches, % within 1 px and 2 px of the ground-truth disparity (where it is known), median
  depth error;
* timings (medians of ``--repeat`` runs; the machine is shared, so read ratios, not absolutes):
  SIFT on both images, matching, dense SGBM, triangulation, a dense region's points.

    python benchmarks/bench_stereo.py [--repeat 5]
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections.abc import Callable
from typing import Any

import cv2
import numpy as np
from skimage import data

from scenespeak.perception.calibration import StereoRig, rectify
from scenespeak.perception.features import Features, detect, to_gray
from scenespeak.perception.stereo import (
    MatchOptions,
    _candidates,
    _select,
    _verify_dense,
    dense_disparity,
    region_points,
    stereo_points,
    triangulate,
)

F, CX, CY, DOFFS, B = 994.978, 311.193, 254.877, 31.086, 0.193001


def rig() -> StereoRig:
    K1 = [[F, 0, CX], [0, F, CY], [0, 0, 1]]
    K2 = [[F, 0, CX + DOFFS], [0, F, CY], [0, 0, 1]]
    return StereoRig((741, 500), K1, K2, None, None, np.eye(3), [-B, 0, 0], source="middlebury")


def score(name: str, lxy: np.ndarray, rxy: np.ndarray, z: np.ndarray, gt: np.ndarray) -> None:
    d = lxy[:, 0] - rxy[:, 0]
    c = np.rint(lxy).astype(int)
    g = gt[c[:, 1], c[:, 0]]
    known = np.isfinite(g)
    err = np.abs(d[known] - g[known])
    zerr = np.abs(z[known] - F * B / (g[known] + DOFFS))
    print(
        f"  {name:44s} {len(d):5d} matches ({known.sum()} with ground truth)  "
        f"{100 * np.mean(err <= 1):5.1f} % <= 1 px  {100 * np.mean(err <= 2):5.1f} % <= 2 px  "
        f"median depth error {1000 * np.median(zerr):.2f} mm"
    )


def plain(fl: Features, fr: Features) -> tuple[np.ndarray, np.ndarray]:
    """The baseline of the vision notes: BFMatcher kNN, ratio 0.6, band 1.5 px, d > 0."""
    bf = cv2.BFMatcher(cv2.NORM_L2)
    knn = bf.knnMatch(fl.descriptors.astype(np.float32), fr.descriptors.astype(np.float32), k=2)
    li, ri = [], []
    for pair in knn:
        if len(pair) == 2 and pair[0].distance < 0.6 * pair[1].distance:
            li.append(pair[0].queryIdx)
            ri.append(pair[0].trainIdx)
    lxy, rxy = fl.xy[li], fr.xy[ri]
    ok = (np.abs(lxy[:, 1] - rxy[:, 1]) <= 1.5) & (lxy[:, 0] - rxy[:, 0] > 0)
    return lxy[ok], rxy[ok]


def timed(fn: Callable[[], Any], repeat: int) -> tuple[float, Any]:
    times, out = [], None
    for _ in range(repeat):
        t = time.perf_counter()
        out = fn()
        times.append(1000 * (time.perf_counter() - t))
    return statistics.median(times), out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    L, R, gt = data.stereo_motorcycle()
    r = rig()
    rect = rectify(r)
    gl, gr = to_gray(L), to_gray(R)

    print("Middlebury 2014 motorcycle, 741x500 (skimage.data.stereo_motorcycle)")
    fl = detect(gl, precise_upscale=False)
    fr = detect(gr, precise_upscale=False)
    print(f"  SIFT keypoints: {len(fl)} left, {len(fr)} right")
    lxy, rxy = plain(fl, fr)
    z = F * B / (lxy[:, 0] - rxy[:, 0] + DOFFS)
    score("plain: BF kNN, ratio 0.6, band, d > 0", lxy, rxy, z, gt)
    res = stereo_points(L, R, r, verify=False)
    p = res.points
    score("stereo_points(verify=False): + cross check", p.left_xy, p.right_xy, p.xyz[:, 2], gt)
    res = stereo_points(L, R, r)
    p = res.points
    score("stereo_points (default): + dense check", p.left_xy, p.right_xy, p.xyz[:, 2], gt)
    res = stereo_points(L, R, r, dense_crop=True)
    p = res.points
    score("stereo_points(dense_crop=True)", p.left_xy, p.right_xy, p.xyz[:, 2], gt)

    print(f"\nTimings, median of {args.repeat} runs (ms; shared 2-core machine, noisy)")
    t_sift, _ = timed(
        lambda: (detect(gl, precise_upscale=False), detect(gr, precise_upscale=False)), args.repeat
    )
    t_cand, cand = timed(
        lambda: _candidates(fl, fr, rect, 1.5, 0.0, None, need_global=False), args.repeat
    )
    # the same band, disparity range and cross check as before, now one MatchOptions
    opts = MatchOptions(band_px=1.5, min_disparity=0.0, max_disparity=None, mutual=True)
    strict = _select(cand, fl, rect, "band", 0.6, opts)
    t_dense, dense = timed(
        lambda: dense_disparity(gl, gr, rect, keypoint_disparities=strict.disparity), args.repeat
    )
    t_sel, m = timed(
        lambda: _select(cand, fl, rect, "band", 0.8, opts).subset(
            _verify_dense(_select(cand, fl, rect, "band", 0.8, opts), dense, 0.75, 1.0, 5)
        ),
        args.repeat,
    )
    t_tri, _ = timed(lambda: triangulate(m.left_rect, m.right_rect, rect), args.repeat)
    mask = np.zeros(gl.shape, bool)
    mask[300:380, 420:520] = True
    t_reg, (xyz, _) = timed(lambda: region_points(dense, mask), args.repeat)
    roi = (400, 280, 540, 400)
    t_roi, _ = timed(
        lambda: dense_disparity(gl, gr, rect, keypoint_disparities=strict.disparity, roi=roi),
        args.repeat,
    )
    t_all, _ = timed(lambda: stereo_points(L, R, r), args.repeat)
    t_plain, _ = timed(lambda: stereo_points(L, R, r, verify=False), args.repeat)
    t_crop, _ = timed(lambda: stereo_points(L, R, r, dense_crop=True), args.repeat)
    rows = [
        ("SIFT, both images", t_sift),
        ("candidates (distance matrix + band pairs)", t_cand),
        ("dense SGBM, whole image, keypoint range", t_dense),
        ("selection + dense check", t_sel),
        (f"triangulation ({len(m)} matches)", t_tri),
        (f"region_points, 100x80 px region ({len(xyz)} points)", t_reg),
        ("dense SGBM on a 140x120 crop (roi)", t_roi),
        ("stereo_points, whole call (default)", t_all),
        ("stereo_points(verify=False), whole call", t_plain),
        ("stereo_points(dense_crop=True), whole call", t_crop),
    ]
    for name, t in rows:
        print(f"  {name:50s} {t:8.1f}")
    print(
        f"  whole call / SIFT alone: {t_all / t_sift:.2f}x (verify=False: {t_plain / t_sift:.2f}x)"
    )


if __name__ == "__main__":
    main()
