"""What session 8 of issue 16 changed in ``scenespeak points``, part by part, before and after.

For the real Art pair (or ``--pair LEFT RIGHT``) resized as ``bench_points.py`` resizes it,
this times, interleaved in one process, on the stage's own SIFT features:

* the pair-order check (``plausibility.check_pair_order(..., features=...)``) with the matcher
  of a79dafd (OpenCV's ``BFMatcher.knnMatch``) and with today's (NumPy, the same pairs);
* the stage's match candidates (``matching._candidates``, band search) with a79dafd's
  two-key ``lexsort`` in ``_group_best`` and with today's one-key sort;
* for scale: SIFT of both images, and the dense SGBM map (``dense_disparity`` on the stage's
  crop), which session 8 did not change;

and prints median wall and process CPU (ms), with BLAS single-threaded as in the command,
and whether each before/after pair gives the same result.

Run::

    python benchmarks/points_parts.py [--repeat 15] [--pair LEFT RIGHT] [--sizes 640x480 ...]
"""

from __future__ import annotations

import os
import statistics
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from bench_points import (
    _group_best_a79dafd,
    _ratio_matches_a79dafd,
    pair_arguments,
    resized_pair,
)
from scenespeak.perception import calibration, plausibility, stereo
from scenespeak.perception.blas import single_threaded_blas
from scenespeak.perception.features import detect, to_gray
from scenespeak.perception.stage_options import StereoOptions
from scenespeak.perception.stereo import matching


def _with(module: Any, name: str, fn: Callable[..., Any], call: Callable[[], Any]) -> Any:
    """``call()`` with ``module.name`` replaced by ``fn`` (restored after)."""
    saved = getattr(module, name)
    setattr(module, name, fn)
    try:
        return call()
    finally:
        setattr(module, name, saved)


def _row(size: tuple[int, int], left0: Any, right0: Any, repeat: int) -> str:
    """One size's table row."""
    left, right = resized_pair(left0, right0, size)
    gl, gr = to_gray(left), to_gray(right)
    rig = calibration.rig_from_short(0.16, 60.0, size)
    rect = calibration.rectify(rig)
    fl, fr = (detect(g, precise_upscale=False) for g in (gl, gr))
    o = stereo.PointsOptions.with_overrides(None, dict(StereoOptions().keywords()))
    mo = stereo.MatchOptions(band_px=o.band_px, min_disparity=0.0, mutual=True)
    cand = matching._candidates(fl, fr, rect, o.band_px, 0.0, None, need_global=False)
    strict = matching._select(cand, fl, rect, "band", o.ratio, mo)
    m = matching._select(cand, fl, rect, "band", o.band_ratio, mo)
    roi = stereo._dense_box(m, rect, None, o.dense_margin)

    def check() -> Any:
        feats = (fl, fr)
        return plausibility.check_pair_order(gl, gr, rig, rect=rect, features=feats)

    def candidates() -> Any:
        return matching._candidates(fl, fr, rect, o.band_px, 0.0, None, need_global=False)

    cases: dict[str, Callable[[], Any]] = {
        "sift": lambda: [detect(g, precise_upscale=False) for g in (gl, gr)],
        "check before": lambda: _with(
            plausibility, "_ratio_matches", _ratio_matches_a79dafd, check
        ),
        "check now": check,
        "candidates before": lambda: _with(
            matching, "_group_best", _group_best_a79dafd, candidates
        ),
        "candidates now": candidates,
        "dense": lambda: stereo.dense_disparity(
            gl, gr, rect, keypoint_disparities=strict.disparity, roi=roi, pad=16
        ),
    }
    times: dict[str, list[tuple[float, float]]] = {k: [] for k in cases}
    results: dict[str, Any] = {}
    with single_threaded_blas():
        for _ in range(repeat):
            for k, fn in cases.items():
                t, c = time.perf_counter(), time.process_time()
                results[k] = fn()
                times[k].append((time.perf_counter() - t, time.process_time() - c))
    cell = {
        k: f"{statistics.median(w for w, _ in v) * 1e3:.1f} "
        f"({statistics.median(c for _, c in v) * 1e3:.1f})"
        for k, v in times.items()
    }
    same_check = results["check before"] == results["check now"]
    cb, cn = results["candidates before"], results["candidates now"]
    same_cand = all(
        np.array_equal(getattr(cb, f), getattr(cn, f)) for f in ("b_best", "b_d1", "b_d2", "b_back")
    )
    return (
        f"| {size[0]}×{size[1]} | {len(fl)} / {len(fr)} | {cell['sift']} | "
        f"{cell['check before']} | {cell['check now']} | {'yes' if same_check else 'NO'} | "
        f"{cell['candidates before']} | {cell['candidates now']} | "
        f"{'yes' if same_cand else 'NO'} | {cell['dense']} |"
    )


def main() -> None:
    args, left0, right0 = pair_arguments(__doc__.splitlines()[0], 15)
    print(f"pair: {args.paths[0]} / {args.paths[1]}, resized; medians, ms: wall (process CPU)\n")
    print(
        "| size | features | SIFT both | check at a79dafd | check now | same | candidates at "
        "a79dafd | candidates now | same | dense SGBM map |"
    )
    print("| --- | --- | ---: | ---: | ---: | --- | ---: | ---: | --- | ---: |")
    for size in args.sizes:
        print(_row(size, left0, right0, args.repeat), flush=True)
    print(f"\nload average after: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")


if __name__ == "__main__":
    main()
