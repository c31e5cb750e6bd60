"""Pixels of each region (masks, boxes, recognised outlines, stereo points) → measured objects.

The object steps of :mod:`scenespeak.pipeline_rgbd`'s input forms, before naming and
relations: :func:`measure_masks` (also used by the RGB-D stream), the boxes' nearest coherent
surfaces cut by nearer boxes, the database's outlines cut by nearer outlines, and stereo
points through the same surface filter. Split out of :mod:`scenespeak.pipeline_rgbd`, which
re-exports :func:`measure_masks`.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from scenespeak.perception.intrinsics import Intrinsics
from scenespeak.perception.masks import Box, InstanceMasks
from scenespeak.perception.objects import Skipped
from scenespeak.perception.rgbd import MeasuredObject, RGBDOptions, SupportPlane, measure_object

__all__ = [
    "box_objects",
    "box_pixels",
    "database_objects",
    "from_points",
    "mask_pixels",
    "measure_masks",
]


def box_pixels(box: Box, size: tuple[int, int]) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    x0, y0, x1, y1 = box.pixel_box(size)
    ys, xs = np.mgrid[y0:y1, x0:x1]
    return ys.ravel(), xs.ravel()


def mask_pixels(inst: InstanceMasks, k: int) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    m, (x0, y0) = inst.mask(k)
    ys, xs = np.nonzero(m)
    return ys + y0, xs + x0


def measure_masks(
    depth: NDArray[np.floating],
    cam: Intrinsics,
    inst: InstanceMasks,
    up: NDArray[np.float64],
    options: RGBDOptions | None = None,
) -> list[MeasuredObject | Skipped]:
    """Each instance's object: its mask's largest depth mode and the pixels continuous with it.

    The objects of :func:`describe_rgbd` with masks, before naming and relations (a stream
    relates them in its working memory). ``depth`` in metres (NaN = none), ``up`` a unit
    vector in the camera frame.
    """
    o = options or RGBDOptions()
    out: list[MeasuredObject | Skipped] = []
    for k, label in enumerate(inst.labels):
        ys, xs = mask_pixels(inst, k)
        out.append(
            measure_object(label, label, ys, xs, depth, cam, up, surface="connected", options=o)
        )
    return out


def box_objects(
    boxes: Sequence[Box],
    depth: NDArray[np.float32],
    cam: Intrinsics,
    up: NDArray[np.float64],
    plane: SupportPlane | None,
    o: RGBDOptions,
) -> list[MeasuredObject | Skipped]:
    """Each box's nearest coherent surface, nearer objects first.

    A box of an object partly hidden by a nearer one also holds the nearer object's pixels;
    they belong to the nearer object. Each box is measured alone first; then, from the nearest
    object to the farthest, each box is measured again without the pixels kept by the nearer
    boxes (as a recognised outline is cut by the outlines of nearer objects).
    """
    size = (depth.shape[1], depth.shape[0])
    pixels = [box_pixels(box, size) for box in boxes]

    def measure(k: int, ys: NDArray[np.intp], xs: NDArray[np.intp]) -> MeasuredObject | Skipped:
        label = boxes[k].label
        return measure_object(
            label,
            label,
            ys,
            xs,
            depth,
            cam,
            up,
            surface="spanning",
            plane=plane,
            source="box",
            options=o,
        )

    first = [measure(k, ys, xs) for k, (ys, xs) in enumerate(pixels)]
    dist = [
        float(m.object.centroid[2])
        if isinstance(m, MeasuredObject) and m.object.centroid is not None
        else np.inf
        for m in first
    ]
    claimed = np.zeros(depth.shape, dtype=bool).ravel()
    out: list[MeasuredObject | Skipped] = list(first)
    for k in np.argsort(dist, kind="stable").tolist():
        ys, xs = pixels[k]
        flat = ys * size[0] + xs
        free = ~claimed[flat]
        m = first[k] if free.all() else measure(k, ys[free], xs[free])
        if isinstance(m, MeasuredObject):
            if not free.all():
                note = f"{int((~free).sum())} pixels of nearer objects left to them"
                m = replace(m, pixels=len(ys), notes=(*m.notes, note))
            if m.kept is not None:
                claimed[m.kept] = True
        out[k] = m
    return out


def database_objects(
    color: NDArray[np.generic],
    depth: NDArray[np.float32],
    cam: Intrinsics,
    up: NDArray[np.float64],
    plane: SupportPlane | None,
    db: Any,
    o: RGBDOptions,
    timings: dict[str, float],
) -> list[MeasuredObject | Skipped]:
    """Objects recognised by the database: each outline's largest coherent surface.

    The outline carried by the homography covers the whole object, also where a nearer
    recognised object hides it: outlines are cut by those of nearer objects (median depth
    inside the outline) before the surface is taken.
    """
    from scenespeak.perception.features import detect, to_gray
    from scenespeak.pipeline import _outline_mask

    t0 = time.perf_counter()
    feats = detect(to_gray(np.asarray(color)), precise_upscale=False)
    # the stereo pipeline's labelling (its LabelOptions, several instances of a label, the
    # finer search for small far objects in the image), so both paths recognise alike
    labelling = db.label(feats, image=np.asarray(color))
    timings["label"] = time.perf_counter() - t0
    shape = depth.shape
    found = [
        (det.label, _outline_mask(det.outline_in_scene, shape)) for det in labelling.detections
    ]
    near = [
        float(np.nanmedian(depth[m])) if np.isfinite(depth[m]).any() else np.inf for _, m in found
    ]
    out: list[MeasuredObject | Skipped] = []
    for k, (name, m) in enumerate(found):
        visible = m.copy()
        for j, (_, other) in enumerate(found):
            if j != k and near[j] < near[k]:
                visible &= ~other
        ys, xs = np.nonzero(visible)
        if len(ys) == 0:
            out.append(Skipped(name, "recognised, but its outline is hidden by nearer objects"))
            continue
        out.append(
            measure_object(
                name,
                name,
                ys,
                xs,
                depth,
                cam,
                up,
                surface="largest",
                plane=plane,
                source="database",
                options=o,
            )
        )
    return out


def from_points(
    label: str, xyz: NDArray[np.float64], pixels: int, up: NDArray[np.float64], o: RGBDOptions
) -> MeasuredObject | Skipped:
    """An object of 3-D points (from stereo) through the same surface filter as depth pixels."""
    from scenespeak.perception.rgbd import _spatial, surface_modes

    p = np.asarray(xyz, np.float64).reshape(-1, 3)
    p = p[np.all(np.isfinite(p), axis=1)]
    notes: list[str] = []
    modes = surface_modes(p[:, 2], bin_width=o.bin_width, mode_fraction=o.mode_fraction)
    if modes:
        near, far, _ = max(modes, key=lambda m: m[2])
        keep = (p[:, 2] >= near) & (p[:, 2] <= far)
        if (~keep).any():
            notes.append(f"{int((~keep).sum())} points off the object's surface dropped")
        p = p[keep]
    if len(p) < o.min_pixels:
        return Skipped(
            label,
            f"only {len(p)} of its {pixels} pixels have a stereo depth on the object "
            f"(at least {o.min_pixels} needed)",
        )
    return MeasuredObject(
        _spatial(label, label, p, up, o), "stereo mask", pixels, len(p), tuple(notes)
    )
