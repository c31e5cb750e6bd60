"""Benchmark of the RGB-D path with masks (issue 11): a 640×480 frame with 5 objects.

Times :func:`scenespeak.pipeline_rgbd.describe_rgbd` (arrays in, described objects and all 20
ordered relations out; no SIFT) on a synthetic frame with exact geometry (a floor, a wall and
five upright objects 0.8-2 m away) with the imitation depth-camera noise of
``scenespeak.tools.depthnoise``, or on a generated scene (``--scene DIR`` with ``depth.png``,
``intrinsics.json``, ``left_labels.png``, ``labels.json``). Forms timed in one run, side by side:

* ``masks, up given``   — the issue's target (≤ 15 ms on an idle machine, 30 fps);
* ``masks, up estimated`` — with the support-plane RANSAC;
* ``boxes``             — boxes (the masks' bounding boxes) with the plane removal;
* ``image plane``       — masks alone, no depth;
* ``read files``        — reading the 16-bit PNG depth, the instance PNG and labels (only with
  ``--scene``).

Prints the median and 90th percentile over ``--repeat`` runs, the per-stage medians and the load
average (the machine is shared: read the medians with the load).

Run::

    python benchmarks/bench_rgbd.py [--repeat 200] [--scene DIR]
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from scenespeak.perception.intrinsics import Intrinsics
from scenespeak.perception.masks import Box, InstanceMasks, instances_from_array
from scenespeak.pipeline_rgbd import describe_image_plane, describe_rgbd
from scenespeak.tools.depthnoise import imitate_depth_camera

W, H = 640, 480
FX = FY = 554.26
CX, CY = (W - 1) / 2, (H - 1) / 2
#: label → (x, Z, width, height) metres: upright objects on a floor 0.3 m below the camera
OBJECTS = {
    "mug": (-0.45, 0.9, 0.09, 0.1),
    "can": (-0.1, 1.3, 0.07, 0.12),
    "box": (0.35, 1.1, 0.19, 0.27),
    "book": (0.0, 1.9, 0.16, 0.23),
    "tin": (0.7, 1.6, 0.1, 0.16),
}


def synthetic() -> tuple[np.ndarray, np.ndarray, dict[int, str], Intrinsics]:
    v, u = np.mgrid[0:H, 0:W].astype(np.float64)
    with np.errstate(divide="ignore"):
        depth = np.minimum(np.where(v > CY, 0.3 * FY / (v - CY), np.inf), 4.0)
    inst = np.zeros((H, W), np.uint16)
    labels = {}
    items = sorted(OBJECTS.items(), key=lambda kv: -kv[1][1])
    for k, (label, (x, z, w, h)) in enumerate(items, start=1):
        u0, u1 = CX + FX * (x - w / 2) / z, CX + FX * (x + w / 2) / z
        v0, v1 = CY + FY * (0.3 - h) / z, CY + FY * 0.3 / z
        sel = (u >= u0) & (u < u1) & (v >= v0) & (v < v1)
        depth[sel] = z
        inst[sel] = k
        labels[k] = label
    noisy = imitate_depth_camera(depth.astype(np.float32), fx=FX, seed=0)
    return noisy, inst, labels, Intrinsics(FX, FY, CX, CY, W, H, up=(0.0, -1.0, 0.0))


def from_scene(d: Path) -> tuple[np.ndarray, np.ndarray, dict[int, str], Intrinsics]:
    from scenespeak.perception.depth import load_depth
    from scenespeak.perception.intrinsics import load_intrinsics
    from scenespeak.perception.masks import load_instances, load_labels

    depth = d / "depth_noisy.png" if (d / "depth_noisy.png").exists() else d / "depth.png"
    return (
        load_depth(depth),
        load_instances(d / "left_labels.png"),
        load_labels(d / "labels.json"),
        load_intrinsics(d / "intrinsics.json"),
    )


def run(fn: Callable[[], object], repeat: int) -> tuple[list[float], list[float]]:
    """Wall-clock and process CPU milliseconds of each call (the CPU time is what the call
    itself costs when other processes take the cores; on an idle machine both agree)."""
    fn()
    wall, cpu = [], []
    for _ in range(repeat):
        t0, c0 = time.perf_counter(), time.process_time()
        fn()
        wall.append((time.perf_counter() - t0) * 1000.0)
        cpu.append((time.process_time() - c0) * 1000.0)
    return wall, cpu


def show(name: str, ms: tuple[list[float], list[float]]) -> None:
    wall, cpu = ms
    q = statistics.quantiles(wall, n=10)
    print(
        f"{name:22s} wall median {statistics.median(wall):7.2f} ms  p90 {q[-1]:7.2f} ms   "
        f"CPU median {statistics.median(cpu):6.2f} ms"
    )


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeat", type=int, default=200)
    ap.add_argument("--scene", type=Path, default=None)
    args = ap.parse_args()
    depth, inst_img, labels, cam = synthetic() if args.scene is None else from_scene(args.scene)
    inst: InstanceMasks = instances_from_array(inst_img, labels)
    n = len(inst.ids)
    print(f"frame {depth.shape[1]}x{depth.shape[0]}, {n} objects, {n * (n - 1)} ordered pairs")
    print(f"load average before: {os.getloadavg()[0]:.2f} {os.getloadavg()[1]:.2f}")
    boxes = [
        Box(label, x0, y0, x1 - x0, y1 - y0)
        for label, (x0, y0, x1, y1) in zip(inst.labels, inst.boxes, strict=True)
    ]
    unknown_up = cam.with_up(None)
    stages: dict[str, list[float]] = {}

    def masks_given() -> None:
        d = describe_rgbd(None, depth, cam, masks=inst)
        for k, v in d.timings.items():
            stages.setdefault(k, []).append(v * 1000.0)

    forms = {
        "masks, up given": masks_given,
        "masks, up estimated": lambda: describe_rgbd(None, depth, unknown_up, masks=inst),
        "boxes": lambda: describe_rgbd(None, depth, cam, boxes=boxes),
        "image plane": lambda: describe_image_plane(inst),
    }
    if args.scene is not None:
        forms["read files"] = lambda: from_scene(args.scene)
    results = {name: run(fn, args.repeat) for name, fn in forms.items()}
    for name, ms in results.items():
        show(name, ms)
    print(
        "stages (masks, up given): "
        + ", ".join(f"{k} {statistics.median(v):.2f} ms" for k, v in stages.items())
    )
    print(f"load average after: {os.getloadavg()[0]:.2f} {os.getloadavg()[1]:.2f}")


if __name__ == "__main__":
    main()
