"""Benchmark of ``scenespeak points``' computation against SIFT alone.

For a real pair (MiddEval2 "Art", or ``--pair LEFT RIGHT``, e.g. a generated scene's
``left.png right.png``) resized to 640×480, 1280×960 and 1920×1080, read in colour as the
command reads them, prints median wall-clock and process-CPU times, interleaved in one run, of:

* SIFT of both images, one after the other (the floor the target is set against: ``points``
  must take at most this + 25 %), and the two in two threads (as the command runs them);
* what the command computes now (``cli.points._stereo_points``: the pair checks, among them
  ``check_pair_order`` on the stage's own features, and the pipeline's stereo stage:
  threaded SIFT, the dense check cropped to the matches + 16 px, ``StereoOptions``), with
  the SGBM the command runs by default (``SCENESPEAK_SGBM`` as in the environment, ``auto``
  unless set: the C extension ``_sgbm_c`` where it is built, ``dense.sgbm_kernel``; the
  table says which ran);
* the same with OpenCV's SGBM (``SCENESPEAK_SGBM=opencv``: the command before the C
  extension);
* the stage as the command ran it at 55e6388 (this and the next two with OpenCV's SGBM, as
  then) (main before issue 16 session 6: what this
  benchmark timed as "points now" then; it left out the command's ``check_pair_order``;
  its calls, on today's library);
* the whole computation of the command at 55e6388: ``check_pair_order`` with its own two
  SIFT extractions, then that stage;
* the command's computation as at a79dafd (main before issue 16 session 8): today's calls with
  the pair-order check's OpenCV matcher (``BFMatcher.knnMatch``) and the band search's
  two-key ``lexsort`` put back (``--no-before`` leaves this column out);
* with ``--sgbm``: the command's computation with the Numba SGBM
  (``SCENESPEAK_SGBM=numba``, ``perception/stereo/sgbm.py``; Numba loaded in this process
  before timing: a fresh process pays 0.6-0.85 s of CPU more, ``bench_sgbm.py``);

and checks that the command gives describe's points (``stereo_points(...,
**StereoOptions().keywords())``), the points of the stage at 55e6388, and the points saved
from 55e6388 in ``benchmarks/points_golden.json`` (``points_golden.py``; Art only). Images
are decoded before timing.

Run::

    python benchmarks/bench_points.py [--repeat 5] [--pair LEFT RIGHT] [--sizes 640x480 ...]
        [--no-before] [--sgbm]
"""

from __future__ import annotations

import argparse
import contextlib
import hashlib
import json
import os
import statistics
import time
from collections.abc import Callable, Iterator
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from scenespeak.cli.points import _stereo_points
from scenespeak.perception import calibration, plausibility, stereo
from scenespeak.perception.blas import single_threaded_blas
from scenespeak.perception.features import detect, load_image, to_gray
from scenespeak.perception.stage_options import StereoOptions
from scenespeak.perception.stereo import dense, matching

#: the real data (``SCENESPEAK_REAL_DATA``, as the tests take it, or ``../shared/data/real``)
REAL = Path(
    os.environ.get("SCENESPEAK_REAL_DATA")
    or Path(__file__).resolve().parents[1] / "../shared/data/real"
)
ART = REAL / "stereo/middeval2/Art"
GOLDEN = Path(__file__).resolve().parent / "points_golden.json"


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


def _stage_before(left: Any, right: Any, rig: Any) -> Any:
    """The calls of ``cli.points._stereo_points`` at 55e6388: threaded SIFT of the colour
    images, the pipeline's stage on them (each converted to gray again), BLAS
    single-threaded. (The library under it is today's: the dense map's conversion to pixels,
    made cheaper in the same change, is in both columns.)"""
    with single_threaded_blas():
        fl, fr = _threaded_sift(left, right)
        return stereo.stereo_points(
            left,
            right,
            rig,
            features_left=fl,
            features_right=fr,
            min_points=1,
            **StereoOptions(ratio=0.6).keywords(),
        ).points


def _command_before(left: Any, right: Any, rig: Any) -> Any:
    """The command's computation at 55e6388: ``check_pair_order`` (its own SIFT of both
    images), then the stage."""
    plausibility.check_pair_order(left, right, rig, names=("left", "right"))
    return _stage_before(left, right, rig)


def _ratio_matches_a79dafd(left: Any, right: Any, ratio: float) -> tuple[Any, Any]:
    """The pair-order check's matcher at a79dafd: OpenCV's brute force, 2 nearest."""
    knn = cv2.BFMatcher(cv2.NORM_L2).knnMatch(
        left.astype(np.float32), right.astype(np.float32), k=2
    )
    pairs = [
        (m[0].queryIdx, m[0].trainIdx)
        for m in knn
        if len(m) == 2 and m[0].distance < ratio * m[1].distance
    ]
    if not pairs:
        return np.zeros(0, np.intp), np.zeros(0, np.intp)
    li, ri = np.array(pairs).T
    return li, ri


def _group_best_a79dafd(ii: Any, jj: Any, dd: Any, n: int, rxy: Any) -> tuple[Any, Any, Any]:
    """``matching._group_best`` at a79dafd (a two-key ``lexsort``)."""
    best = np.full(n, -1, np.intp)
    d1 = np.full(n, np.inf, np.float32)
    d2 = np.full(n, np.inf, np.float32)
    if len(ii) == 0:
        return best, d1, d2
    o = np.lexsort((dd, ii))
    ii, jj, dd = ii[o], jj[o], dd[o]
    first = np.flatnonzero(np.r_[True, ii[1:] != ii[:-1]])
    best[ii[first]] = jj[first]
    d1[ii[first]] = dd[first]
    far = np.linalg.norm(rxy[jj] - rxy[best[ii]], axis=1) > matching._SAME_PLACE_PX
    fi = np.flatnonzero(far)
    if len(fi):
        grp = ii[fi]
        f2 = fi[np.r_[True, grp[1:] != grp[:-1]]]
        d2[ii[f2]] = dd[f2]
    return best, d1, d2


def _command_a79dafd(left: Any, right: Any, rig: Any) -> Any:
    """The command's computation with a79dafd's check matcher and band sort (this process
    only, restored after the call)."""
    saved = plausibility._ratio_matches, matching._group_best
    plausibility._ratio_matches = _ratio_matches_a79dafd
    matching._group_best = _group_best_a79dafd
    try:
        names = (Path("left"), Path("right"))
        return _stereo_points(stereo, left, right, rig, ratio=0.6, sources=names)
    finally:
        plausibility._ratio_matches, matching._group_best = saved


def _kernel_of(fn: Callable[[], object]) -> str:
    """Which SGBM ``fn`` ran (``dense.sgbm_kernel``'s answer at its last call)."""
    seen: list[str] = []
    real = dense.sgbm_kernel

    def spy(*a: Any) -> str:
        seen.append(real(*a))
        return seen[-1]

    dense.sgbm_kernel = spy  # type: ignore[assignment]
    try:
        fn()
    finally:
        dense.sgbm_kernel = real  # type: ignore[assignment]
    return seen[-1] if seen else "none"


def _golden(size: tuple[int, int], points: Any, pair: bool) -> str:
    """Whether the points are those saved from 55e6388 (Art only)."""
    if pair or not GOLDEN.exists():
        return "n/a"
    want = json.loads(GOLDEN.read_text()).get(f"{size[0]}x{size[1]}", {}).get("middeval2/Art")
    if want is None:
        return "n/a"
    doc = stereo.points_to_json(points)
    got = hashlib.sha256(json.dumps(doc, sort_keys=True).encode()).hexdigest()
    return "yes" if got == want["sha256"] else f"NO ({len(doc['points'])} vs {want['n']})"


def _same(a: Any, b: Any) -> str:
    pa, pb = stereo.points_to_json(a)["points"], stereo.points_to_json(b)["points"]
    if pa == pb:
        return "yes"
    sa, sb = ({json.dumps(p) for p in x} for x in (pa, pb))
    return f"NO (+{len(sa - sb)} -{len(sb - sa)})"


def _ratio(med: dict[str, tuple[float, float]], k: str) -> str:
    """Case ``k`` over SIFT of both images: wall (CPU)."""
    return f"{med[k][0] / med['sift'][0]:.2f} ({med[k][1] / med['sift'][1]:.2f})"


def pair_arguments(description: str, repeat: int) -> tuple[argparse.Namespace, Any, Any]:
    """The points benchmarks' command line (``--repeat``, ``--pair``, ``--sizes``; ``paths``:
    the pair's files, Art unless ``--pair``) and the pair read in colour; prints the load
    average."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--repeat", type=int, default=repeat)
    parser.add_argument("--pair", nargs=2, type=Path, metavar=("LEFT", "RIGHT"))
    parser.add_argument(
        "--sizes", nargs="+", type=_size, default=[(640, 480), (1280, 960), (1920, 1080)]
    )
    parser.add_argument("--no-before", dest="before", action="store_false")
    parser.add_argument("--sgbm", action="store_true", help="a column with the Numba SGBM")
    args = parser.parse_args()
    args.paths = args.pair or (ART / "view1.png", ART / "view5.png")
    left0, right0 = (load_image(p, gray=False) for p in args.paths)
    print(f"load average before: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    return args, left0, right0


@contextlib.contextmanager
def _sgbm(which: str | None) -> Iterator[None]:
    """``SCENESPEAK_SGBM`` set to ``which`` (``opencv``, ``numba``; None: as it is) for the
    block."""
    old = os.environ.get(dense.SGBM_ENV)
    if which is not None:
        os.environ[dense.SGBM_ENV] = which
    try:
        yield
    finally:
        if old is None:
            os.environ.pop(dense.SGBM_ENV, None)
        else:
            os.environ[dense.SGBM_ENV] = old


def resized_pair(left0: Any, right0: Any, size: tuple[int, int]) -> tuple[Any, Any]:
    """Both images resized to ``size`` (area averaging down, bilinear up)."""
    interp = cv2.INTER_AREA if size[0] < left0.shape[1] else cv2.INTER_LINEAR
    left = cv2.resize(left0, size, interpolation=interp)
    return left, cv2.resize(right0, size, interpolation=interp)


def main() -> None:
    args, left0, right0 = pair_arguments(__doc__.splitlines()[0], 5)
    left_path, right_path = args.paths
    print(f"pair: {left_path} / {right_path}, resized; wall (CPU) medians, s\n")
    print(
        "| size | SIFT both | SIFT, 2 threads | points now | now / SIFT | SGBM now "
        "| now, OpenCV SGBM | OpenCV SGBM / SIFT | stage at 55e6388 "
        "| stage 55e6388 / SIFT | command at 55e6388 | command 55e6388 / SIFT "
        "| now = describe's stage | now = stage at 55e6388 | now = saved (55e6388) |"
        + (" command as at a79dafd | a79dafd / SIFT | now = a79dafd |" if args.before else "")
        + (" Numba SGBM | Numba / SIFT | Numba = now |" if args.sgbm else "")
    )
    print(
        "| --- | ---: | ---: | ---: | ---: | --- | ---: | ---: | ---: | ---: | ---: | ---: "
        "| --- | --- | --- |"
        + (" ---: | ---: | --- |" if args.before else "")
        + (" ---: | ---: | --- |" if args.sgbm else "")
    )
    names = (Path("left"), Path("right"))
    for size in args.sizes:
        left, right = resized_pair(left0, right0, size)
        rig = calibration.rig_from_short(0.16, 60.0, size)

        def sift(left: Any = left, right: Any = right) -> object:
            return detect(to_gray(left), precise_upscale=False), detect(
                to_gray(right), precise_upscale=False
            )

        def now(left: Any = left, right: Any = right, rig: Any = rig) -> Any:
            return _stereo_points(stereo, left, right, rig, ratio=0.6, sources=names)

        def now_opencv(left: Any = left, right: Any = right, rig: Any = rig) -> Any:
            with _sgbm("opencv"):
                return _stereo_points(stereo, left, right, rig, ratio=0.6, sources=names)

        def compiled(left: Any = left, right: Any = right, rig: Any = rig) -> Any:
            with _sgbm("numba"):
                return _stereo_points(stereo, left, right, rig, ratio=0.6, sources=names)

        def sift2(left: Any = left, right: Any = right) -> object:
            return _threaded_sift(left, right)

        def stage(left: Any = left, right: Any = right, rig: Any = rig) -> Any:
            with _sgbm("opencv"):
                return _stage_before(left, right, rig)

        def command(left: Any = left, right: Any = right, rig: Any = rig) -> Any:
            with _sgbm("opencv"):
                return _command_before(left, right, rig)

        def before(left: Any = left, right: Any = right, rig: Any = rig) -> Any:
            with _sgbm("opencv"):
                return _command_a79dafd(left, right, rig)

        cases = {
            "sift": sift,
            "sift2": sift2,
            "now": now,
            "opencv": now_opencv,
            "stage": stage,
            "command": command,
        }
        if args.before:
            cases["a79dafd"] = before
        if args.sgbm:
            cases["compiled"] = compiled
        times: dict[str, list[tuple[float, float]]] = {k: [] for k in cases}
        for _ in range(args.repeat):  # interleaved: they share the machine's load
            for k, fn in cases.items():
                times[k].append(timed(fn))
        med = {
            k: (statistics.median(w for w, _ in t), statistics.median(c for _, c in t))
            for k, t in times.items()
        }
        got, old = now(), stage()
        kernel = _kernel_of(now)
        if _same(got, now_opencv()) != "yes":
            kernel += " (NOT OpenCV's points)"
        describe = stereo.stereo_points(left, right, rig, **StereoOptions().keywords()).points
        cell = {k: f"{w:.3f} ({c_:.3f})" for k, (w, c_) in med.items()}

        print(
            f"| {size[0]}×{size[1]} | {cell['sift']} | {cell['sift2']} | {cell['now']} | "
            f"{_ratio(med, 'now')} | {kernel} | {cell['opencv']} | {_ratio(med, 'opencv')} | "
            f"{cell['stage']} | {_ratio(med, 'stage')} | "
            f"{cell['command']} | {_ratio(med, 'command')} | "
            f"{_same(got, describe)} ({len(got.xyz)} points) | {_same(got, old)} | "
            f"{_golden(size, got, args.pair is not None)} |"
            + (
                f" {cell['a79dafd']} | {_ratio(med, 'a79dafd')} | {_same(got, before())} |"
                if args.before
                else ""
            )
            + (
                f" {cell['compiled']} | {_ratio(med, 'compiled')} | {_same(compiled(), got)} |"
                if args.sgbm
                else ""
            ),
            flush=True,
        )
    print(f"\nload average after: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")


if __name__ == "__main__":
    main()
