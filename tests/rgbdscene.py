"""A synthetic RGB-D frame with exact geometry, shared by the RGB-D tests.

A level camera 0.4 m above a floor, a wall 3 m away, and upright fronto-parallel slabs
(cards) standing on the floor; each slab is one instance. The depth is exact (pinhole
geometry), so every expected position is known.
"""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
from numpy.typing import NDArray

W, H = 320, 240
FX = FY = 280.0
CX, CY = (W - 1) / 2, (H - 1) / 2
CAM_HEIGHT = 0.4
WALL = 3.0

#: label → (x centre, Z, width, height) metres
SLABS: dict[str, tuple[float, float, float, float]] = {
    "mug": (-0.35, 1.2, 0.12, 0.15),
    "can": (0.05, 1.5, 0.10, 0.2),
    "box": (0.45, 1.0, 0.2, 0.25),
}


def render(
    slabs: dict[str, tuple[float, float, float, float]]
    | list[tuple[str, tuple[float, float, float, float]]] = SLABS,
) -> tuple[NDArray[np.float32], NDArray[np.uint16], dict[int, str]]:
    """Depth (metres) and instance image (1..n in the order of ``slabs``) and labels."""
    items = list(slabs.items()) if isinstance(slabs, dict) else list(slabs)
    v, u = np.mgrid[0:H, 0:W].astype(np.float64)
    with np.errstate(divide="ignore"):
        floor = np.where(v > CY + 1e-9, CAM_HEIGHT * FY / (v - CY), np.inf)
    depth = np.minimum(floor, WALL)
    inst = np.zeros((H, W), np.uint16)
    labels: dict[int, str] = {}
    # far to near, so nearer slabs paint over farther ones
    order = sorted(range(len(items)), key=lambda k: -items[k][1][1])
    for k in order:
        label, (x, z, w, h) = items[k]
        u0, u1 = CX + FX * (x - w / 2) / z, CX + FX * (x + w / 2) / z
        v0, v1 = CY + FY * (CAM_HEIGHT - h) / z, CY + FY * CAM_HEIGHT / z
        sel = (u >= u0) & (u < u1) & (v >= v0) & (v < v1) & (z < depth)
        depth[sel] = z
        inst[sel] = k + 1
        labels[k + 1] = label
    return depth.astype(np.float32), inst, labels


def intrinsics(up: bool = True) -> dict[str, object]:
    d: dict[str, object] = {"fx": FX, "fy": FY, "cx": CX, "cy": CY, "width": W, "height": H}
    if up:
        d["up"] = [0.0, -1.0, 0.0]
    return d


def color_image(inst: NDArray[np.uint16]) -> NDArray[np.uint8]:
    rng = np.random.default_rng(0)
    img = rng.integers(60, 200, size=(H, W, 3)).astype(np.uint8)
    img[inst > 0] = (40 * inst[inst > 0, None] % 255).astype(np.uint8)
    return img


def write_scene(root: Path, *, up: bool = True) -> dict[str, Path]:
    """color.png, depth.png (16-bit mm), depth.npy, depth.tif, intrinsics.json, instances.png,
    labels.json and boxes.json (the masks' bounding boxes) in ``root``."""
    import tifffile

    depth, inst, labels = render()
    root.mkdir(parents=True, exist_ok=True)
    files = {
        "color": root / "color.png",
        "depth": root / "depth.png",
        "depth_npy": root / "depth.npy",
        "depth_tif": root / "depth.tif",
        "intrinsics": root / "intrinsics.json",
        "masks": root / "instances.png",
        "labels": root / "labels.json",
        "boxes": root / "boxes.json",
    }
    cv2.imwrite(str(files["color"]), color_image(inst))
    mm = np.where(np.isfinite(depth), np.round(depth * 1000), 0).astype(np.uint16)
    cv2.imwrite(str(files["depth"]), mm)
    np.save(files["depth_npy"], depth)
    tifffile.imwrite(str(files["depth_tif"]), depth)
    files["intrinsics"].write_text(json.dumps(intrinsics(up)))
    cv2.imwrite(str(files["masks"]), inst)
    files["labels"].write_text(json.dumps({str(k): v for k, v in labels.items()}))
    dets = []
    for k, label in labels.items():
        ys, xs = np.nonzero(inst == k)
        x0, y0 = int(xs.min()), int(ys.min())
        dets.append(
            {
                "bbox": [x0, y0, int(xs.max()) - x0 + 1, int(ys.max()) - y0 + 1],
                "label": label,
                "score": 0.9,
            }
        )
    files["boxes"].write_text(json.dumps(dets))
    return files
