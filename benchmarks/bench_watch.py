"""Throughput of the stream with its working memory, 640×480 stereo frames.

On the rendered sequences (``benchmarks/livecache.py``; by default the four scripts of tuning
seed 100, 24 frames each, played forward and back to ``--frames`` frames in all), the images
decoded beforehand, this runs side by side in one process:

``memory``
    ``SceneStream.process`` per frame: tracking, recognition only when needed (every
    ``--keyframe-every`` frames, a lost track, a changed scene), the working memory;
``full``
    the full chain (``describe_scene``) on every frame, what a stream costs without the memory.

It prints, for each, the sustained frames per second (frames / wall time), the per-frame
latency (median and 95th percentile, wall), the CPU seconds per frame (all threads of the
process: a figure that holds better than wall time on a loaded machine) and how many frames
were recognised. Target of issue 14: ≥ 10 frames per second with memory.

``--rgbd`` measures the RGB-D + masks path instead (target of issue 14: ≥ 30 frames per
second): the same scripts rendered with the left camera's depth (16-bit mm) and instance
image per frame (``cache/rgbd``), read beforehand, through

``rgbd-memory``
    ``RGBDStream.process`` per frame: each mask's object measured, ids matched, the memory;
``rgbd-full``
    ``describe_rgbd`` per frame (objects and every ordered relation, no memory).

Run::

    python benchmarks/bench_watch.py                  # 96 frames each
    python benchmarks/bench_watch.py --rgbd --frames 192
    python benchmarks/bench_watch.py --frames 200 --keyframe-every 15

The machine is shared: say the load (``uptime``) with every figure; the ratio of the two rows
measured together holds better than either.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from livecache import DEFAULT_CACHE, TUNING_SEEDS, database, sequences


def _frames(seqs, total: int) -> list[tuple[np.ndarray, np.ndarray, int]]:
    from scenespeak.perception.features import load_image

    per = []
    for si, seq in enumerate(seqs):
        pairs = [
            tuple(load_image(p, gray=False) for p in seq.pair(k)) for k in range(len(seq.frames))
        ]
        per.append([(a, b, si) for a, b in pairs])
    out = []
    k = 0
    while len(out) < total:
        seq = per[k % len(per)]
        out.extend(seq if (k // len(per)) % 2 == 0 else seq[::-1])
        k += 1
    return out[:total]


def _run_memory(frames, rig_of, db, keyframe_every: int) -> tuple[list[float], float, float, int]:
    from scenespeak.live.stream import SceneStream, StreamOptions
    from scenespeak.perception.tracking import TrackingOptions

    opts = StreamOptions(tracking=TrackingOptions(keyframe_every=keyframe_every))
    stream, current = None, None
    lat, rec = [], 0
    w0, c0 = time.perf_counter(), time.process_time()
    for left, right, si in frames:
        if si != current:  # a new sequence: a new stream (a new scene)
            stream, current = SceneStream(rig_of(si), db, opts), si
        t = time.perf_counter()
        f = stream.process(left, right)
        lat.append(time.perf_counter() - t)
        rec += int(f.tracked.recognised)
    return lat, time.perf_counter() - w0, time.process_time() - c0, rec


def _run_full(frames, rig_of, db) -> tuple[list[float], float, float, int]:
    from scenespeak.pipeline import describe_scene

    lat = []
    w0, c0 = time.perf_counter(), time.process_time()
    for left, right, si in frames:
        t = time.perf_counter()
        describe_scene(left, right, rig_of(si), db)
        lat.append(time.perf_counter() - t)
    return lat, time.perf_counter() - w0, time.process_time() - c0, len(frames)


def _rgbd_frames(seqs, total: int) -> list[tuple[np.ndarray, np.ndarray, dict, int]]:
    """Depth (metres), instance image and labels of every frame, read beforehand."""
    from scenespeak.perception.depth import load_depth
    from scenespeak.perception.masks import load_instances, load_labels

    per = []
    for si, seq in enumerate(seqs):
        frames = []
        for k in range(len(seq.frames)):
            d = Path(seq.root) / f"{k:04d}"
            frames.append(
                (
                    load_depth(d / "depth.png"),
                    load_instances(d / "masks.png"),
                    load_labels(d / "labels.json"),
                    si,
                )
            )
        per.append(frames)
    out = []
    k = 0
    while len(out) < total:
        seq = per[k % len(per)]
        out.extend(seq if (k // len(per)) % 2 == 0 else seq[::-1])
        k += 1
    return out[:total]


def _run_rgbd_memory(frames, cam_of) -> tuple[list[float], float, float, int]:
    from scenespeak.live.rgbd_stream import RGBDStream

    stream, current = None, None
    lat = []
    w0, c0 = time.perf_counter(), time.process_time()
    for depth, masks, labels, si in frames:
        if si != current:
            stream, current = RGBDStream(cam_of(si)), si
        t = time.perf_counter()
        stream.process(depth, masks, labels)
        lat.append(time.perf_counter() - t)
    return lat, time.perf_counter() - w0, time.process_time() - c0, len(frames)


def _run_rgbd_full(frames, cam_of) -> tuple[list[float], float, float, int]:
    from scenespeak.pipeline_rgbd import describe_rgbd

    lat = []
    w0, c0 = time.perf_counter(), time.process_time()
    for depth, masks, labels, si in frames:
        t = time.perf_counter()
        describe_rgbd(None, depth, cam_of(si), masks=masks, labels=labels, summary=False)
        lat.append(time.perf_counter() - t)
    return lat, time.perf_counter() - w0, time.process_time() - c0, len(frames)


def _print(rows) -> None:
    print(
        f"{'mode':12} {'frames':>6} {'fps':>7} {'p50 ms':>8} {'p95 ms':>8} "
        f"{'CPU ms/frame':>13} {'recognised':>10}"
    )
    for name, lat, wall, cpu, rec in rows:
        n = len(lat)
        print(
            f"{name:12} {n:>6} {n / wall:>7.2f} {1000 * np.median(lat):>8.1f} "
            f"{1000 * np.percentile(lat, 95):>8.1f} {1000 * cpu / n:>13.1f} {rec:>10}"
        )


def main_rgbd(args) -> int:
    """``--rgbd``: RGB-D + masks frames (depth 16-bit mm, instance image, labels per frame)."""
    from scenespeak.perception.intrinsics import load_intrinsics

    seqs = sequences(args.cache / "rgbd", tuple(args.seeds))
    frames = _rgbd_frames(seqs, args.frames)
    cams = [load_intrinsics(Path(s.root) / "intrinsics.json") for s in seqs]
    h, w = frames[0][0].shape
    n_obj = np.mean([len(f[2]) for f in frames])
    print(f"{len(frames)} RGB-D + masks frames of {w}x{h}, {n_obj:.1f} objects a frame")
    print(f"load before: {os.getloadavg()[0]:.2f} (1-min average, {os.cpu_count()} cores)")
    _run_rgbd_memory(frames[:8], cams.__getitem__)  # warm-up (imports, caches)
    rows = [
        ("rgbd-memory", *_run_rgbd_memory(frames, cams.__getitem__)),
        ("rgbd-full", *_run_rgbd_full(frames, cams.__getitem__)),
    ]
    _print(rows)
    print(f"load after: {os.getloadavg()[0]:.2f}")
    return 0


def main(argv: list[str] | None = None) -> int:
    from scenespeak.perception.calibration import load_rig
    from scenespeak.perception.database import ObjectDatabase

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=96)
    ap.add_argument("--seeds", type=int, nargs="+", default=[TUNING_SEEDS[0]])
    ap.add_argument("--keyframe-every", type=int, default=10)
    ap.add_argument("--full-frames", type=int, default=None, help="frames of the full-chain row")
    ap.add_argument("--cache", type=Path, default=DEFAULT_CACHE)
    ap.add_argument(
        "--rgbd", action="store_true", help="RGB-D + masks frames (RGBDStream) instead of stereo"
    )
    args = ap.parse_args(argv)
    if args.rgbd:
        return main_rgbd(args)
    db_path = database(args.cache)
    seqs = sequences(args.cache, tuple(args.seeds))
    frames = _frames(seqs, args.frames)
    rigs = [load_rig(s.calib) for s in seqs]
    print(f"load before: {os.getloadavg()[0]:.2f} (1-min average, {os.cpu_count()} cores)")
    rows = []
    with ObjectDatabase.open(db_path, readonly=True) as db:
        rows.append(("memory", *_run_memory(frames, rigs.__getitem__, db, args.keyframe_every)))
        full = frames[: args.full_frames or len(frames)]
        rows.append(("full", *_run_full(full, rigs.__getitem__, db)))
    _print(rows)
    fps = {name: len(lat) / wall for name, lat, wall, _, _ in rows}
    print(f"memory / full: {fps['memory'] / fps['full']:.2f}x the frame rate")
    print(f"load after: {os.getloadavg()[0]:.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
