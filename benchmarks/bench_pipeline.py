"""Benchmark of the whole pipeline: describe vs SIFT alone, distance bands, and the database.

Three parts (all by default; choose with ``--only``):

``timing``
    On the first scene of a generated dataset (640×480), the median time over ``--runs`` runs
    of (a) the two SIFT extractions alone, the same calls the pipeline makes, one after the
    other and in two threads as the pipeline runs them, and (b) the whole ``describe_scene`` on
    the same arrays (SIFT, labelling, stereo matching, dense region, objects, relations).
    Prints wall and CPU medians, the ratios (target of issue 4: whole ≤ 1.3 × SIFT alone) and
    the median time of each stage.
``bands``
    Over every scene of the dataset, how many of the ground-truth objects are described, by
    their distance from the left camera (0.5–1, 1–1.5, 1.5–2 m, and beyond), with keypoints only
    (``dense=False``) and with the dense region (the default), plus the primary direction of
    the unambiguous relations between described objects against the ground truth.
``database``
    Labelling time and memory against 1,000 objects (~500k descriptors): runs the database
    engineer's ``benchmarks/bench_database.py`` (its figures are printed as they come).

Run::

    python benchmarks/bench_pipeline.py                         # all parts, level rig
    python benchmarks/bench_pipeline.py --only bands --scenes 24 --pitched
    python benchmarks/bench_pipeline.py --only timing --runs 9

The dataset is generated once into the temp folder (``--cache``) and reused. The machine is
shared and noisy: medians are printed; ratios hold better than times.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

from scenespeak.perception.calibration import load_rig
from scenespeak.perception.features import detect, load_image, to_gray
from scenespeak.perception.objects import project_to_plane
from scenespeak.perception.recognition import ObjectDatabase
from scenespeak.pipeline import database_from_dataset, describe_scene

BANDS = ((0.5, 1.0), (1.0, 1.5), (1.5, 2.0), (2.0, 9.0))


def dataset(cache: Path, n: int, seed: int, pitched: bool) -> tuple[Path, Path]:
    """A generated dataset and its object database (made once, then reused)."""
    from scenespeak.tools.scenes import generate_dataset

    root = cache / f"scenes-n{n}-s{seed}{'-pitched' if pitched else ''}"
    if not (root / "dataset.json").exists():
        print(f"generating {n} scenes into {root} ...", flush=True)
        t0 = time.perf_counter()
        generate_dataset(root, n, seed=seed, pitched=pitched, progress=None)
        print(f"  {time.perf_counter() - t0:.1f} s")
    db = root / "objects.db"
    if not db.exists():
        partial = root / "objects.db.partial"
        partial.unlink(missing_ok=True)
        database_from_dataset(root, partial)
        partial.replace(db)
    return root, db


def scenes_of(root: Path) -> list[Path]:
    meta = json.loads((root / "dataset.json").read_text())
    return [root / s for s in meta["scenes"]]


def load_scene(scene: Path) -> tuple[Any, Any, Any]:
    left = load_image(scene / "left.png", gray=False)
    right = load_image(scene / "right.png", gray=False)
    return left, right, load_rig(scene / "calib.json")


def _median_ms(values: list[float]) -> float:
    return 1000.0 * statistics.median(values)


def _two_sift_sequential(left: Any, right: Any) -> None:
    detect(to_gray(left), precise_upscale=False)
    detect(to_gray(right), precise_upscale=False)


def _two_sift_parallel(left: Any, right: Any, pool: ThreadPoolExecutor) -> None:
    # exactly what describe_scene does: the right image in a worker thread, the left here
    future = pool.submit(detect, to_gray(right), precise_upscale=False)
    detect(to_gray(left), precise_upscale=False)
    future.result()


def timing(root: Path, db_path: Path, runs: int) -> dict[str, Any]:
    """Two SIFT extractions alone vs the whole describe on one 640×480 pair.

    Both start from the images in memory (RGB arrays, as ``describe_scene`` gets them) and
    include the gray conversion. The SIFT baseline is the two calls the pipeline makes
    (``features.detect(..., precise_upscale=False)``), timed two ways: one after the other, and
    at the same time in two threads the way the pipeline runs them (the stricter baseline). The
    three are interleaved run by run so that they see the same machine load; wall time and CPU
    time of the process (all threads) are both reported.
    """
    scene = scenes_of(root)[0]
    left, right, rig = load_scene(scene)
    rows: dict[str, list[float]] = {k: [] for k in ("seq", "par", "whole")}
    cpu: dict[str, list[float]] = {k: [] for k in ("seq", "par", "whole")}
    stages = []
    with ObjectDatabase.open(db_path, readonly=True) as db, ThreadPoolExecutor(1) as pool:
        describe_scene(left, right, rig, db)  # warm up: imports, index, OpenCV buffers
        _two_sift_parallel(left, right, pool)
        desc = None
        for _ in range(runs):
            for key in ("seq", "par", "whole"):
                c0, t0 = time.process_time(), time.perf_counter()
                if key == "seq":
                    _two_sift_sequential(left, right)
                elif key == "par":
                    _two_sift_parallel(left, right, pool)
                else:
                    desc = describe_scene(left, right, rig, db)
                rows[key].append(time.perf_counter() - t0)
                cpu[key].append(time.process_time() - c0)
            assert desc is not None
            stages.append(dict(desc.timings))
    assert desc is not None
    s, p, w = (_median_ms(rows[k]) for k in ("seq", "par", "whole"))
    cs, cp, cw = (_median_ms(cpu[k]) for k in ("seq", "par", "whole"))
    print(f"\n== timing: {scene} ({left.shape[1]}x{left.shape[0]}), median of {runs} runs")
    print(f"{'':<38}{'wall':>9}{'cpu':>10}")
    print(f"{'two SIFT extractions, one after other':<38}{s:7.1f} ms{cs:7.1f} ms")
    print(f"{'two SIFT extractions, two threads':<38}{p:7.1f} ms{cp:7.1f} ms")
    print(f"{'whole describe_scene':<38}{w:7.1f} ms{cw:7.1f} ms")
    print(
        f"ratio whole / SIFT: {w / s:.2f} (sequential SIFT), {w / p:.2f} (SIFT in two threads, "
        f"as the pipeline runs it); cpu {cw / cs:.2f} / {cw / cp:.2f}   (target <= 1.3)"
    )
    for name in stages[0]:
        print(f"  {name:<10} {_median_ms([st[name] for st in stages]):7.1f} ms")
    print(f"  objects {len(desc.objects)}, relations {len(desc.relations)}, ", end="")
    print(f"skipped {len(desc.skipped)}, stereo points {len(desc.point_labels)}")
    return {
        "sift_ms": s,
        "sift_parallel_ms": p,
        "whole_ms": w,
        "ratio": w / s,
        "ratio_parallel": w / p,
        "cpu_ratio": cw / cs,
    }


def _band(d: float) -> int:
    for i, (lo, hi) in enumerate(BANDS):
        if lo <= d < hi:
            return i
    return 0 if d < BANDS[0][0] else len(BANDS) - 1


def _primary_truth(relations: list[dict[str, Any]]) -> dict[tuple[str, str], str]:
    return {
        (r["argument"], r["referent"]): r["primary"]
        for r in relations
        if not r.get("ambiguous", False)
    }


def bands(root: Path, db_path: Path, min_visible: float) -> dict[str, Any]:
    """How many ground-truth objects are described, by distance band, keypoints vs dense."""
    counts = {mode: np.zeros((len(BANDS), 2), int) for mode in ("keypoints", "dense")}
    right_dirs = {"keypoints": [0, 0], "dense": [0, 0]}
    cent_err: dict[str, list[float]] = {"keypoints": [], "dense": []}
    reasons: dict[str, dict[str, int]] = {"keypoints": {}, "dense": {}}
    scenes = scenes_of(root)
    with ObjectDatabase.open(db_path, readonly=True) as db:
        for scene in scenes:
            truth = json.loads((scene / "truth.json").read_text())
            left, right, rig = load_scene(scene)
            for mode in ("keypoints", "dense"):
                desc = describe_scene(left, right, rig, db, dense=mode == "dense", unknown=False)
                got = {o.label: o for o in desc.objects}
                for t in truth["objects"]:
                    if t.get("visible_fraction", 1.0) < min_visible:
                        continue
                    b = _band(float(t["distance"]))
                    counts[mode][b, 0] += 1
                    if t["label"] in got:
                        counts[mode][b, 1] += 1
                        c = np.asarray(t["centroid"], float)
                        true_xy = project_to_plane(c[None], rig.up)[0]
                        cent_err[mode].append(
                            float(np.linalg.norm(got[t["label"]].plane_centroid - true_xy))
                        )
                for s in desc.skipped:
                    key = s.reason.split(" (")[0].split(";")[0]
                    reasons[mode][key] = reasons[mode].get(key, 0) + 1
                for (a, b_), primary in _primary_truth(truth["relations"]).items():
                    rel = desc.relation(a, b_)
                    if rel is None:
                        continue
                    right_dirs[mode][1] += 1
                    right_dirs[mode][0] += int(rel.primary == primary)
    print(f"\n== distance bands: {len(scenes)} scenes of {root}")
    print(f"objects with visible fraction >= {min_visible:.2f}, described / present")
    print(f"{'band (m)':<12}{'keypoints only':>18}{'with dense region':>20}")
    for i, (lo, hi) in enumerate(BANDS):
        n = counts["dense"][i, 0]
        if n == 0:
            continue
        label = f"{lo:g}-{hi:g}" if hi < 9 else f">= {lo:g}"
        k, d = counts["keypoints"][i, 1], counts["dense"][i, 1]
        print(f"{label:<12}{k:>8} / {n:<4} {100 * k / n:4.0f}%{d:>9} / {n:<4} {100 * d / n:4.0f}%")
    for mode in ("keypoints", "dense"):
        ok, n = right_dirs[mode]
        err = cent_err[mode]
        med = f"{100 * statistics.median(err):.1f} cm" if err else "-"
        print(
            f"{mode:<10} unambiguous relations with the right primary: {ok}/{n}; "
            f"median centroid error on the plane {med}"
        )
        if reasons[mode]:
            print(f"           skipped: {reasons[mode]}")
    return {
        mode: {"counts": counts[mode].tolist(), "relations": right_dirs[mode]} for mode in counts
    }


def database_part(runs: int) -> None:
    print("\n== labelling against 1,000 objects (benchmarks/bench_database.py)", flush=True)
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import bench_database

    bench_database.main(["--runs", str(runs)])


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", choices=["timing", "bands", "database"], action="append")
    ap.add_argument("--scenes", type=int, default=12, help="scenes for the bands (default 12)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--pitched", action="store_true", help="the pitched rig")
    ap.add_argument("--runs", type=int, default=7)
    ap.add_argument("--min-visible", type=float, default=0.5)
    ap.add_argument(
        "--dataset", type=Path, help="use this dataset folder (docs/scenes.md format) instead"
    )
    ap.add_argument("--cache", type=Path, default=Path(tempfile.gettempdir()) / "scenespeak-bench")
    args = ap.parse_args(argv)
    parts = args.only or ["timing", "bands", "database"]
    args.cache.mkdir(parents=True, exist_ok=True)
    if "timing" in parts or "bands" in parts:
        if args.dataset is not None:
            root, db = args.dataset, args.dataset / "objects.db"
            if not db.exists():
                database_from_dataset(root, db)
        else:
            root, db = dataset(args.cache, args.scenes, args.seed, args.pitched)
        if "timing" in parts:
            timing(root, db, args.runs)
        if "bands" in parts:
            bands(root, db, args.min_visible)
    if "database" in parts:
        database_part(args.runs)


if __name__ == "__main__":
    main()
