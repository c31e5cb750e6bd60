"""Benchmark of the object database at 1,000 objects (~500k SIFT descriptors).

Builds (once; cached under the temp folder) a database of 1,000 objects whose descriptors are
real OpenCV SIFT descriptors of scikit-image photos: each object is a random crop of one of
the photos, rotated, scaled, possibly mirrored and taken from one colour channel, with at most
500 keypoints per object. Three of them are the astronaut, the coffee cup and the cat, which
are pasted (with known homographies) into the left image of the Middlebury motorcycle pair to
make the query scene; the other 997 objects come from the other photos.

Then it prints: build time, load + index time, the memory of the descriptor store and index
(tracemalloc of the load, and the index's own count), the median labelling time of the scene
(~2,000 query descriptors) over several runs, the 2-NN recall against exact search on a sample
of the queries, and whether the three pasted objects were found.

Run::

    python benchmarks/bench_database.py                  # default index ("auto")
    python benchmarks/bench_database.py --index ivf      # NumPy inverted file
    python benchmarks/bench_database.py --index faiss    # needs faiss-cpu
    python benchmarks/bench_database.py --rebuild        # rebuild the cached database

The machine is shared and noisy: medians are printed, and ratios hold better than times.
"""

from __future__ import annotations

import argparse
import gc
import statistics
import tempfile
import time
import tracemalloc
from pathlib import Path
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray
from skimage import data

from scenespeak.database import ExactIndex, ObjectDatabase
from scenespeak.features import Features, detect, to_gray

FILLER_PHOTOS = (
    "camera",
    "brick",
    "grass",
    "gravel",
    "horse",
    "hubble_deep_field",
    "immunohistochemistry",
    "moon",
    "page",
    "text",
    "clock",
    "coins",
    "cell",
    "retina",
    "colorwheel",
    "logo",
    "rocket",
)


def _targets() -> dict[str, NDArray[np.uint8]]:
    return {
        "astronaut": to_gray(data.astronaut())[30:330, 100:400],
        "coffee": to_gray(data.coffee())[50:350, 150:450],
        "cat": to_gray(data.chelsea())[20:280, 80:380],
    }


def _photo_channels() -> list[NDArray[np.uint8]]:
    out = []
    for name in FILLER_PHOTOS:
        img = np.asarray(getattr(data, name)())
        if img.ndim == 3:
            rgb = img[:, :, :3]
            out.append(to_gray(rgb))
            out += [np.ascontiguousarray(rgb[:, :, c]) for c in range(3)]
        else:
            out.append(to_gray(img))
        if max(out[-1].shape) > 1000:
            out = [cv2.resize(o, None, fx=0.6, fy=0.6) if max(o.shape) > 1000 else o for o in out]
    return out


def _filler_object(photos: list[NDArray[np.uint8]], rng: np.random.Generator) -> NDArray[np.uint8]:
    img = photos[int(rng.integers(len(photos)))]
    h, w = img.shape
    ch, cw = (
        int(rng.integers(min(160, h), min(360, h) + 1)),
        int(rng.integers(min(160, w), min(360, w) + 1)),
    )
    y, x = int(rng.integers(0, h - ch + 1)), int(rng.integers(0, w - cw + 1))
    crop = img[y : y + ch, x : x + cw]
    if rng.random() < 0.5:
        crop = crop[:, ::-1]
    angle, scale = float(rng.uniform(-180, 180)), float(rng.uniform(0.7, 1.5))
    m = cv2.getRotationMatrix2D((cw / 2, ch / 2), angle, scale)
    return np.ascontiguousarray(cv2.warpAffine(crop, m, (cw, ch), borderMode=cv2.BORDER_REFLECT))


def build(path: Path, n_objects: int, per_object: int, seed: int) -> float:
    """Build the benchmark database; return the wall time in seconds."""
    rng = np.random.default_rng(seed)
    photos = _photo_channels()
    t0 = time.perf_counter()
    with ObjectDatabase.create(path) as db:
        for name, img in _targets().items():
            db.add_object(name, [img], max_features=per_object)
        i = 0
        while i < n_objects - 3:
            img = _filler_object(photos, rng)
            if len(detect(img, max_features=per_object)) < per_object // 2:
                continue  # a flat crop (sky, page margin): draw another
            db.add_object(f"object {i:04d}", [img], max_features=per_object)
            i += 1
    return time.perf_counter() - t0


def scene() -> tuple[Features, dict[str, NDArray[np.float64]]]:
    """Motorcycle left image with the three target objects pasted in; ~2,000 keypoints."""
    left = to_gray(data.stereo_motorcycle()[0])
    out = left.copy()
    size = (left.shape[1], left.shape[0])
    homs = {
        "astronaut": np.array([[0.45, -0.05, 40], [0.05, 0.45, 60], [0, 0, 1.0]]),
        "coffee": np.array([[0.4, 0.08, 420], [-0.08, 0.4, 40], [1e-4, 0, 1.0]]),
        "cat": np.array([[0.5, 0, 250], [0, 0.5, 300], [0, 0, 1.0]]),
    }
    for name, img in _targets().items():
        h = homs[name]
        warped = cv2.warpPerspective(img, h, size)
        m = cv2.warpPerspective(np.full_like(img, 255), h, size, flags=cv2.INTER_NEAREST) > 0
        out[m] = warped[m]
    return detect(out), homs


def _rss_mb() -> float:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    return float("nan")


def main(argv: list[str] | None = None) -> dict[str, Any]:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--objects", type=int, default=1000)
    ap.add_argument("--per-object", type=int, default=500)
    ap.add_argument("--index", default="auto", choices=["auto", "exact", "ivf", "faiss"])
    ap.add_argument("--nprobe", type=int, default=8)
    ap.add_argument("--runs", type=int, default=7)
    ap.add_argument("--cache", type=Path, default=Path(tempfile.gettempdir()) / "scenespeak-bench")
    ap.add_argument("--rebuild", action="store_true")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)

    args.cache.mkdir(parents=True, exist_ok=True)
    path = args.cache / f"objects-{args.objects}x{args.per_object}-s{args.seed}.db"
    if args.rebuild and path.exists():
        path.unlink()
    if path.exists():
        print(f"database: {path} (cached; --rebuild to rebuild)")
    else:
        print(f"building {path} ...", flush=True)
        partial = path.with_suffix(".partial")
        partial.unlink(missing_ok=True)
        t = build(partial, args.objects, args.per_object, args.seed)
        partial.replace(path)
        print(f"build time: {t:.1f} s ({1000 * t / args.objects:.0f} ms per object, SIFT included)")
    results: dict[str, Any] = {}
    feats, homs = scene()
    print(f"scene: motorcycle left + 3 pasted objects, {len(feats)} query descriptors")

    with ObjectDatabase.open(path, readonly=True, index=args.index) as db:
        objs = db.list_objects()
        n_desc = sum(o.descriptors for o in objs)
        print(
            f"database: {len(objs)} objects, {n_desc} descriptors, "
            f"{path.stat().st_size / 2**20:.1f} MB on disk"
        )
        gc.collect()
        rss0 = _rss_mb()
        tracemalloc.start()
        t0 = time.perf_counter()
        db.load(nprobe=args.nprobe)
        t_load = time.perf_counter() - t0
        current, peak = tracemalloc.get_traced_memory()
        tracemalloc.stop()
        rss1 = _rss_mb()
        index = db.index
        index_mb = index.nbytes / 2**20
        print(f"load + index ({type(index).__name__}): {t_load:.2f} s")
        print(
            f"memory held after load: {current / 2**20:.1f} MB (tracemalloc; peak during load "
            f"{peak / 2**20:.1f} MB); index incl. descriptors: {index_mb:.1f} MB; "
            f"RSS delta {rss1 - rss0:.1f} MB"
        )
        times = []
        result = None
        for _ in range(args.runs):
            t0 = time.perf_counter()
            result = db.label(feats)
            times.append(time.perf_counter() - t0)
        assert result is not None
        t_search = []
        for _ in range(args.runs):
            t0 = time.perf_counter()
            index.search(feats.descriptors, 8)
            t_search.append(time.perf_counter() - t0)
        med = statistics.median(times)
        print(
            f"labelling time (median of {args.runs}): {1000 * med:.1f} ms "
            f"(min {1000 * min(times):.1f}, max {1000 * max(times):.1f}); "
            f"of which k-NN search {1000 * statistics.median(t_search):.1f} ms"
        )
        found = {d.label: d for d in result.detections}
        for name in homs:
            det = found.get(name)
            if det is None:
                print(f"  {name}: NOT found")
                continue
            img = _targets()[name]
            h, w = img.shape
            corners = np.array([[-0.5, -0.5], [w - 0.5, -0.5], [w - 0.5, h - 0.5], [-0.5, h - 0.5]])
            true = cv2.perspectiveTransform(corners[None], homs[name])[0]
            err = float(np.abs(det.outline_in_scene - true).max())
            print(f"  {name}: found, {int(det.score)} inliers, outline corners within {err:.2f} px")
        extra = sorted(set(found) - set(homs))
        print(f"  other objects reported: {extra if extra else 'none'}")

        # Recall of the 2-NN against exact search on a sample of the queries.
        rng = np.random.default_rng(1)
        sample = rng.choice(len(feats), min(200, len(feats)), replace=False)
        q = feats.descriptors[sample]
        _, approx = index.search(q, 2)
        del index
        all_desc = np.vstack(
            [
                np.frombuffer(r[0], np.uint8).reshape(-1, 128)
                for r in db.conn.execute("SELECT descriptors FROM views ORDER BY id")
            ]
        )
        _, exact = ExactIndex(all_desc).search(q, 2)
        r1 = float(np.mean(approx[:, 0] == exact[:, 0]))
        r2 = float(np.mean([len(set(a) & set(b)) / 2 for a, b in zip(approx, exact, strict=True)]))
        print(f"recall vs exact on {len(sample)} queries: 1-NN {r1:.3f}, 2-NN {r2:.3f}")
    results.update(
        load_s=t_load,
        label_ms=1000 * med,
        memory_mb=current / 2**20,
        index_mb=index_mb,
        recall1=r1,
        recall2=r2,
        found=sorted(found),
    )
    return results


if __name__ == "__main__":
    main()
