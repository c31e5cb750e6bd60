"""Any perception in: colour + depth (with masks, boxes or the object database), a stereo pair
with masks, or masks alone in the image plane → the same words out.

Each input form has an array API returning an :class:`RGBDDescription`, whose
:meth:`~RGBDDescription.to_dict` is the JSON of ``scenespeak describe --format json`` with
``"frame": "horizontal" | "image"`` at the top (``interfaces.md``, "Any perception in"):

- :func:`describe_rgbd` — a colour image, its registered depth (metres, NaN = none) and
  intrinsics, with an instance image, boxes, or an object database;
- :func:`describe_stereo_masks` — a stereo pair and an instance image of the left image (depth
  from dense stereo);
- :func:`describe_image_plane` — masks (or boxes) alone, relations in the picture.

Several instances of one label get distinct names (:mod:`scenespeak.spatial.naming`: "left
mug", "mug near the can") used in the sentences and the JSON ``name``; ``label`` stays. When
``up`` is not known it is estimated from the dominant support plane
(:func:`scenespeak.perception.rgbd.estimate_support_plane`) and the JSON says
``"up_source": "estimated"``; when no plane is found the level-camera default is used and
``"up_note"`` says why.

Files in, one dispatch for every command (``describe``, ``ask``, ``serve``, ``annotate``):
:func:`scenespeak.inputs.describe_inputs`.

>>> import numpy as np
>>> from scenespeak.perception.intrinsics import Intrinsics
>>> cam = Intrinsics(500.0, 500.0, 160.0, 120.0, 320, 240, up=(0.0, -1.0, 0.0))
>>> depth = np.full((240, 320), 3.0, np.float32)
>>> inst = np.zeros((240, 320), np.uint16)
>>> inst[100:140, 40:80] = 1; depth[100:140, 40:80] = 1.0     # a mug on the left
>>> inst[100:140, 240:280] = 2; depth[100:140, 240:280] = 1.0  # another on the right
>>> inst[100:140, 140:180] = 3; depth[100:140, 140:180] = 1.5  # a can between, farther
>>> d = describe_rgbd(None, depth, cam, masks=inst, labels={1: "mug", 2: "mug", 3: "can"})
>>> [o.name for o in d.objects]
['left mug', 'right mug', 'can']
>>> d.relation("left mug", "right mug").sentence
'The left mug is directly to the left of the right mug.'
>>> d.to_dict()["frame"], d.to_dict()["up_source"]
('horizontal', 'given')
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from scenespeak.contract import SpatialObject
from scenespeak.errors import ImageError, InputError
from scenespeak.geometry.frames import DEFAULT_UP
from scenespeak.perception.depth import check_depth_size
from scenespeak.perception.intrinsics import Intrinsics
from scenespeak.perception.masks import Box, InstanceMasks, instances_from_array
from scenespeak.perception.objects import Skipped
from scenespeak.perception.rgbd import (
    MeasuredObject,
    RGBDOptions,
    SupportPlane,
    estimate_support_plane,
    image_object,
    measure_object,
)
from scenespeak.pipeline import PairRelation

__all__ = [
    "DEFAULT_UP",
    "RGBDDescription",
    "describe_image_plane",
    "describe_rgbd",
    "describe_stereo_masks",
    "measure_masks",
    "name_objects",
    "resolve_up",
]

MasksIn = InstanceMasks | NDArray[np.integer[Any]]


@dataclass(frozen=True, eq=False)
class RGBDDescription:
    """Objects and relations of a scene seen through any perception (RGB-D, masks, boxes).

    Attributes
    ----------
    frame : {"horizontal", "image"}
        Where the hulls and relations live.
    objects : tuple of MeasuredObject
        Described objects (``.object`` is the :class:`SpatialObject`; ``.name`` distinct).
    skipped : tuple of Skipped
        Objects that could not be described, with the reason.
    relations : tuple of PairRelation
        Every ordered pair, with the histograms, named by the objects' names.
    summary : str
        A short paragraph ("" when switched off or without relations).
    up : (3,) float64 or None
        World up in the camera frame (None in the image plane).
    up_source : str
        ``"given"`` (intrinsics, calibration or argument), ``"estimated"`` (support plane),
        ``"default"`` (no plane found: ``[0, -1, 0]``) or ``"none"`` (image plane).
    up_note : str
        Why up is what it is, when it was not given.
    plane : SupportPlane or None
        The support plane found (when up was estimated or boxes needed it).
    timings : dict of str to float
        Seconds per stage.
    sources : dict of str to str
        The input files, when known.
    """

    frame: str
    objects: tuple[MeasuredObject, ...]
    skipped: tuple[Skipped, ...]
    relations: tuple[PairRelation, ...]
    summary: str = ""
    up: NDArray[np.float64] | None = None
    up_source: str = "given"
    up_note: str = ""
    plane: SupportPlane | None = None
    timings: Mapping[str, float] = field(default_factory=dict)
    sources: Mapping[str, str] = field(default_factory=dict)

    @property
    def spatial_objects(self) -> tuple[SpatialObject, ...]:
        """The objects as the spatial half sees them."""
        return tuple(o.object for o in self.objects)

    def object(self, name: str) -> MeasuredObject | None:
        """The object with this name (or, if no name matches, the first with this label)."""
        for o in self.objects:
            if o.name == name:
                return o
        return next((o for o in self.objects if o.label == name), None)

    def relation(self, argument: str, referent: str) -> PairRelation | None:
        """The relation of ``argument`` to ``referent`` (names), or None."""
        for rel in self.relations:
            if rel.argument == argument and rel.referent == referent:
                return rel
        return None

    def _object_dict(self, m: MeasuredObject) -> dict[str, Any]:
        o = m.object
        d: dict[str, Any] = {
            "label": o.label,
            "name": o.name,
            "points": int(m.kept_pixels),
            "centroid": None if o.centroid is None else [float(v) for v in o.centroid],
            "hull": [[float(x), float(y)] for x, y in o.hull],
            "source": m.source,
            "pixels": int(m.pixels),
            "kept_pixels": int(m.kept_pixels),
            "notes": list(m.notes),
            "plane_centroid": [float(v) for v in o.footprint_centroid],
        }
        if o.heights is not None and len(o.heights):
            d["height_range"] = [float(o.heights.min()), float(o.heights.max())]
        return d

    def to_dict(self) -> dict[str, Any]:
        """The JSON of ``describe --format json`` (``interfaces.md``) with ``frame`` on top.

        Objects: ``label``, ``name``, ``points`` (kept pixels), ``centroid`` (camera frame,
        metres; null in the image plane), ``hull`` (in ``frame``), ``source``, ``pixels``,
        ``kept_pixels``, ``notes``, ``plane_centroid``, ``height_range``. Relations and
        skipped as for a stereo pair; extras ``summary``, ``up``, ``up_source``, ``up_note``,
        ``timings_ms``.
        """
        return {
            "frame": self.frame,
            "objects": [self._object_dict(m) for m in self.objects],
            "relations": [rel.to_dict() for rel in self.relations],
            "skipped": [{"label": s.label, "reason": s.reason} for s in self.skipped],
            "summary": self.summary,
            "up": None if self.up is None else [float(v) for v in self.up],
            "up_source": self.up_source,
            "up_note": self.up_note,
            "timings_ms": {k: round(v * 1000.0, 3) for k, v in self.timings.items()},
        }

    def to_text(self) -> str:
        """The sentences for people: every ordered pair, then what was not described."""
        lines = [rel.sentence for rel in self.relations]
        if not self.objects:
            lines.append("No object could be described in this scene.")
        elif len(self.objects) == 1:
            lines.append(f"Only the {self.objects[0].name} was described: nothing to relate.")
        for s in self.skipped:
            lines.append(f"Not described: the {s.label} ({s.reason}).")
        if self.up_note:
            lines.append(f"Note: {self.up_note}")
        return "\n".join(lines)


# --------------------------------------------------------------------------------------------
# shared steps


def _as_instances(
    masks: MasksIn,
    labels: Mapping[int, str] | None,
    size: tuple[int, int] | None,
    sources: Mapping[str, str],
) -> InstanceMasks:
    if isinstance(masks, InstanceMasks):
        if size is not None and masks.size != tuple(size):
            w, h = masks.size
            raise ImageError(
                masks.source,
                f"is {w}x{h} but the colour image is {size[0]}x{size[1]}: "
                "masks must be of its size",
            )
        return masks
    return instances_from_array(
        np.asarray(masks),
        labels,
        size=size,
        source=sources.get("masks", "masks"),
        labels_source=sources.get("labels", "labels"),
    )


def _relate(objects: Sequence[MeasuredObject], directions: int, frame: str) -> list[PairRelation]:
    """Every ordered pair of the objects through the force histograms and the rule base."""
    from scenespeak.spatial.language import relate_objects

    if len(objects) < 2:
        return []
    heights = [o.object.heights for o in objects]
    found = relate_objects(
        [o.object.hull for o in objects],
        names=[o.name for o in objects],
        heights=None if any(h is None for h in heights) else heights,  # type: ignore[arg-type]
        directions=directions,
    )
    rels = [PairRelation(_in_frame(rel, frame), hist.f0, hist.f2) for rel, hist in found]
    order = {o.name: k for k, o in enumerate(objects)}
    rels.sort(key=lambda r: (order[r.argument], order[r.referent]))
    return rels


def _in_frame(rel: Any, frame: str) -> Any:
    """The image plane's words for a relation computed on image-plane hulls."""
    if frame != "image":
        return rel
    from scenespeak.spatial.language.picture import in_picture

    return in_picture(rel)


def _summary(rels: Sequence[PairRelation], objects: Sequence[MeasuredObject]) -> str:
    from scenespeak.spatial.language import summarize_scene

    if not rels:
        return ""
    return summarize_scene(
        [r.relation for r in rels],
        centroids={o.name: o.object.footprint_centroid for o in objects},
    )


def name_objects(
    measured: Sequence[MeasuredObject | Skipped],
) -> tuple[list[MeasuredObject], list[Skipped]]:
    """Split described and skipped objects; name the instances apart (spatial/naming)."""
    from scenespeak.spatial.naming import instance_names

    objs = [m for m in measured if isinstance(m, MeasuredObject)]
    skipped = [m for m in measured if isinstance(m, Skipped)]
    names = instance_names([m.object for m in objs])
    out = [
        m if m.name == n else replace(m, object=replace(m.object, name=n))
        for m, n in zip(objs, names, strict=True)
    ]
    return out, skipped


def _finish(
    frame: str,
    measured: Sequence[MeasuredObject | Skipped],
    up: tuple[NDArray[np.float64] | None, str, str, SupportPlane | None],
    timings: dict[str, float],
    sources: Mapping[str, str],
    directions: int,
    summary: bool,
) -> RGBDDescription:
    t0 = time.perf_counter()
    objects, skipped = name_objects(measured)
    rels = _relate(objects, directions, frame)
    text = _summary(rels, objects) if summary else ""
    timings["relations"] = time.perf_counter() - t0
    vec, source, note, plane = up
    return RGBDDescription(
        frame=frame,
        objects=tuple(objects),
        skipped=tuple(skipped),
        relations=tuple(rels),
        summary=text,
        up=vec,
        up_source=source,
        up_note=note,
        plane=plane,
        timings=timings,
        sources=dict(sources),
    )


def _resolve_up(
    depth: NDArray[np.floating],
    cam: Intrinsics,
    up: Sequence[float] | None,
    exclude: NDArray[np.bool_] | None,
    need_plane: bool,
    options: RGBDOptions,
) -> tuple[NDArray[np.float64], str, str, SupportPlane | None]:
    """Up as given, or from the support plane (or the default with a note)."""
    given = up if up is not None else cam.up
    plane = None
    if given is None or need_plane:
        hint = DEFAULT_UP if given is None else given
        plane = estimate_support_plane(depth, cam, exclude=exclude, up_hint=hint, options=options)
    if given is not None:
        return np.asarray(given, np.float64) / np.linalg.norm(given), "given", "", plane
    if plane is None:
        note = (
            "up was not given and no support plane (floor, table, shelf) was found in the "
            f"depth image within {options.max_tilt_deg:g} degrees of the camera's up: the level "
            'camera\'s [0, -1, 0] is used; give "up" in the intrinsics for other poses'
        )
        return np.asarray(DEFAULT_UP, np.float64), "default", note, None
    note = (
        f"up estimated from the support plane ({plane.inliers} of {plane.samples} sampled "
        "pixels on it)"
    )
    return np.asarray(plane.normal, np.float64), "estimated", note, plane


def _box_pixels(box: Box, size: tuple[int, int]) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    x0, y0, x1, y1 = box.pixel_box(size)
    ys, xs = np.mgrid[y0:y1, x0:x1]
    return ys.ravel(), xs.ravel()


def _mask_pixels(inst: InstanceMasks, k: int) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    m, (x0, y0) = inst.mask(k)
    ys, xs = np.nonzero(m)
    return ys + y0, xs + x0


# --------------------------------------------------------------------------------------------
# the input forms


def describe_rgbd(
    color: NDArray[np.generic] | None,
    depth: NDArray[np.floating],
    intrinsics: Intrinsics,
    *,
    masks: MasksIn | None = None,
    labels: Mapping[int, str] | None = None,
    boxes: Sequence[Box] | None = None,
    db: Any = None,
    up: Sequence[float] | None = None,
    options: RGBDOptions | None = None,
    directions: int = 180,
    summary: bool = True,
    sources: Mapping[str, str] | None = None,
) -> RGBDDescription:
    """Describe a colour + depth frame with masks, boxes or the object database.

    Parameters
    ----------
    color : (H, W[, 3]) array or None
        The colour image (needed only with ``db``; its size is checked against ``depth``).
    depth : (H, W) float
        Registered depth in metres, NaN (or 0, inf) where there is none.
    intrinsics : Intrinsics
        The colour camera's; ``intrinsics.up`` is used unless ``up`` is given.
    masks : InstanceMasks or (H, W) int array, optional
        Instance image (0 = background); ``labels`` names its instances.
    boxes : sequence of Box, optional
        Detections; each keeps the pixels of the nearest coherent surface in its box.
    db : ObjectDatabase, optional
        Used when neither masks nor boxes are given: the recognised outlines are the regions.
    up : (3,) floats, optional
        World up in the camera frame; when neither this nor the intrinsics give it, it is
        estimated from the support plane.
    options : RGBDOptions, optional
    directions : int
        Histogram bins.
    summary : bool
        Also write the short summary.
    sources : mapping, optional
        Input file names for messages and the record.

    Raises
    ------
    ImageError
        Depth, colour and masks of different sizes; empty masks.
    InputError
        Labels naming instances not in the masks; none of masks, boxes, db given.
    """
    o = options or RGBDOptions()
    src = dict(sources or {})
    d = np.asarray(depth, dtype=np.float32)
    if d.ndim != 2:
        raise ImageError(src.get("depth", "depth"), f"must be one channel, got shape {d.shape}")
    # 0, inf and negative values mean "no depth" like NaN: each stage tests only the pixels
    # it reads (no pass over the whole image)
    size = (d.shape[1], d.shape[0])
    if color is not None:
        ch, cw = np.asarray(color).shape[:2]
        check_depth_size(
            d,
            (cw, ch),
            depth_name=src.get("depth", "depth"),
            other_name=src.get("color", "the colour image"),
        )
    if intrinsics.size != size:
        raise InputError(
            src.get("intrinsics", intrinsics.source),
            f"are for {intrinsics.width}x{intrinsics.height} images but the depth image is "
            f"{size[0]}x{size[1]}",
        )
    timings: dict[str, float] = {}
    t0 = time.perf_counter()
    inst = None if masks is None else _as_instances(masks, labels, size, src)
    exclude = None if inst is None else inst.image > 0
    resolved = _resolve_up(d, intrinsics, up, exclude, inst is None, o)
    timings["up"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    vec, plane = resolved[0], resolved[3]
    measured: list[MeasuredObject | Skipped] = []
    if inst is not None:
        measured.extend(measure_masks(d, intrinsics, inst, vec, o))
    elif boxes is not None:
        measured.extend(_box_objects(boxes, d, intrinsics, vec, plane, o))
    elif db is not None:
        if color is None:
            raise InputError("color", "the object database needs the colour image")
        measured.extend(_database_objects(color, d, intrinsics, vec, plane, db, o, timings))
    else:
        raise InputError(None, "give masks, boxes or an object database with the depth image")
    timings["objects"] = time.perf_counter() - t0
    return _finish("horizontal", measured, resolved, timings, src, directions, summary)


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
        ys, xs = _mask_pixels(inst, k)
        out.append(
            measure_object(label, label, ys, xs, depth, cam, up, surface="connected", options=o)
        )
    return out


def resolve_up(
    depth: NDArray[np.floating],
    cam: Intrinsics,
    exclude: NDArray[np.bool_] | None = None,
    options: RGBDOptions | None = None,
) -> tuple[NDArray[np.float64], str, str]:
    """Up (unit, camera frame), its source (``"given"``, ``"estimated"``, ``"default"``) and
    the note, as :func:`describe_rgbd` finds it: the intrinsics' ``up``, else the support plane
    of the depth outside ``exclude`` (the objects), else ``[0, -1, 0]`` with the reason."""
    vec, source, note, _ = _resolve_up(depth, cam, None, exclude, False, options or RGBDOptions())
    return vec, source, note


def _box_objects(
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
    pixels = [_box_pixels(box, size) for box in boxes]

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


def _database_objects(
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
    labelling = db.label(feats, ratio=0.8, min_inliers=8, min_inliers_small=4, small_area=8000.0)
    timings["label"] = time.perf_counter() - t0
    shape = depth.shape
    masks = {det.label: _outline_mask(det.outline_in_scene, shape) for det in labelling.detections}
    near = {
        name: float(np.nanmedian(depth[m])) if np.isfinite(depth[m]).any() else np.inf
        for name, m in masks.items()
    }
    out: list[MeasuredObject | Skipped] = []
    for name, m in masks.items():
        visible = m.copy()
        for other, z in near.items():
            if other != name and z < near[name]:
                visible &= ~masks[other]
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


def describe_image_plane(
    masks: MasksIn | None = None,
    labels: Mapping[int, str] | None = None,
    *,
    boxes: Sequence[Box] | None = None,
    size: tuple[int, int] | None = None,
    directions: int = 180,
    summary: bool = True,
    sources: Mapping[str, str] | None = None,
) -> RGBDDescription:
    """Relations in the picture (left / right / above / below) from masks or boxes, no depth.

    Parameters
    ----------
    masks : InstanceMasks or (H, W) int array, optional
        Instance image; ``labels`` names its instances.
    boxes : sequence of Box, optional
        Used when no masks are given; ``size`` (width, height) is then needed.
    size : (width, height), optional
        The colour image's size (masks are checked against it).

    Examples
    --------
    >>> inst = np.zeros((100, 200), np.uint8); inst[40:60, 10:40] = 1; inst[40:60, 150:190] = 2
    >>> d = describe_image_plane(inst, {1: "mug", 2: "can"})
    >>> d.frame, d.relations[0].sentence
    ('image', 'The mug is directly to the left of the can in the picture.')
    """
    src = dict(sources or {})
    timings: dict[str, float] = {}
    t0 = time.perf_counter()
    measured: list[MeasuredObject | Skipped] = []
    if masks is not None:
        inst = _as_instances(masks, labels, size, src)
        height = inst.image.shape[0]
        for k, label in enumerate(inst.labels):
            ys, xs = _mask_pixels(inst, k)
            measured.append(image_object(label, label, ys, xs, height, source="mask"))
    elif boxes is not None:
        if size is None:
            raise InputError("size", "boxes in the image plane need the image size")
        for box in boxes:
            ys, xs = _box_pixels(box, size)
            x0, y0, x1, y1 = box.pixel_box(size)
            cy = np.array([y0, y0, y1 - 1, y1 - 1])
            cx = np.array([x0, x1 - 1, x1 - 1, x0])
            m = image_object(box.label, box.label, cy, cx, size[1], source="box")
            measured.append(replace(m, pixels=len(ys), kept_pixels=len(ys)))
    else:
        raise InputError(None, "the image plane needs masks or boxes")
    timings["objects"] = time.perf_counter() - t0
    none = (None, "none", "", None)
    return _finish("image", measured, none, timings, src, directions, summary)


def describe_stereo_masks(
    left: NDArray[np.generic],
    right: NDArray[np.generic],
    rig: Any,
    masks: MasksIn,
    labels: Mapping[int, str] | None = None,
    *,
    options: RGBDOptions | None = None,
    directions: int = 180,
    summary: bool = True,
    sources: Mapping[str, str] | None = None,
    progress: Callable[[str], None] | None = None,
) -> RGBDDescription:
    """A stereo pair and an instance image of the LEFT image: depth from dense stereo.

    The pair is rectified and matched as in :func:`scenespeak.pipeline.describe_scene`; the
    dense SGBM map over the whole image gives each mask's 3-D points (in the original left
    camera frame), and each object keeps the largest depth mode of its pixels as with RGB-D.
    ``up`` is the rig's.
    """
    from scenespeak.perception import stereo

    o = options or RGBDOptions()
    src = dict(sources or {})
    lname, rname = src.get("left", "left image"), src.get("right", "right image")
    stereo.check_pair(left, right, rig, left_name=lname, right_name=rname)
    h, w = np.asarray(left).shape[:2]
    inst = _as_instances(masks, labels, (w, h), src)
    timings: dict[str, float] = {}
    t0 = time.perf_counter()
    if progress is not None:
        progress("stereo")
    result = stereo.stereo_points(
        left, right, rig, left_name=lname, right_name=rname, dense_crop=False
    )
    dense = result.dense
    if dense is None:
        raise ImageError(lname, "dense stereo gave no disparity map for this pair")
    timings["stereo"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    up = np.asarray(result.rect.rig.up, np.float64)
    measured: list[MeasuredObject | Skipped] = []
    for k, label in enumerate(inst.labels):
        xyz, _ = stereo.region_points(dense, inst.full_mask(k), max_points=None)
        measured.append(
            _from_points(label, xyz, int(np.count_nonzero(inst.image == inst.ids[k])), up, o)
        )
    timings["objects"] = time.perf_counter() - t0
    return _finish(
        "horizontal",
        measured,
        (up / np.linalg.norm(up), "given", "", None),
        timings,
        src,
        directions,
        summary,
    )


def _from_points(
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
