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
from typing import Any, TypedDict, Unpack

import numpy as np
from numpy.typing import NDArray

from scenespeak.errors import ImageError, InputError
from scenespeak.geometry.frames import DEFAULT_UP
from scenespeak.perception.depth import check_depth_size
from scenespeak.perception.intrinsics import Intrinsics
from scenespeak.perception.masks import Box
from scenespeak.perception.objects import Skipped
from scenespeak.perception.rgbd import (
    MeasuredObject,
    RGBDOptions,
    SupportPlane,
    estimate_support_plane,
    image_object,
)
from scenespeak.rgbd_description import MasksIn, RGBDDescription, as_instances, finish, name_objects
from scenespeak.rgbd_regions import (
    box_objects,
    box_pixels,
    database_objects,
    from_points,
    mask_pixels,
    measure_masks,
)

__all__ = [
    "DEFAULT_UP",
    "DescribeOptions",
    "RGBDDescription",
    "describe_image_plane",
    "describe_rgbd",
    "describe_stereo_masks",
    "measure_masks",
    "name_objects",
    "resolve_up",
]


@dataclass(frozen=True)
class DescribeOptions:
    """How :func:`describe_rgbd` and :func:`describe_stereo_masks` describe a frame.

    Attributes
    ----------
    rgbd : RGBDOptions
        The object stage's options (depth modes, support plane, minimum pixels).
    up : (3,) floats or None
        World up in the camera frame; ``None``: the intrinsics' ``up``, else estimated from
        the support plane (``describe_rgbd`` only; a stereo rig has its own up).
    directions : int
        Histogram bins of the force histograms.
    summary : bool
        Also write the short summary.
    sources : mapping of str to str or None
        Input file names for messages and the record (``"depth"``, ``"masks"``, ...).
    progress : callable or None
        Called with the name of each long step (``describe_stereo_masks``: ``"stereo"``).

    Examples
    --------
    >>> DescribeOptions(directions=96, summary=False).rgbd == RGBDOptions()
    True
    """

    rgbd: RGBDOptions = field(default_factory=RGBDOptions)
    up: Sequence[float] | None = None
    directions: int = 180
    summary: bool = True
    sources: Mapping[str, str] | None = None
    progress: Callable[[str], None] | None = None


class DescribeKeywords(TypedDict, total=False):
    """The keywords of :func:`describe_rgbd` and :func:`describe_stereo_masks` before
    :class:`DescribeOptions` (still accepted; each sets its field of the options)."""

    db: Any
    up: Sequence[float] | None
    directions: int
    summary: bool
    sources: Mapping[str, str] | None
    progress: Callable[[str], None] | None


def _options(
    options: DescribeOptions | RGBDOptions | None, keywords: Mapping[str, Any]
) -> DescribeOptions:
    """The options of a call: ``options`` (an RGBDOptions is the object stage's) with the
    old keywords on top."""
    if isinstance(options, DescribeOptions):
        o = options
    else:
        o = DescribeOptions(rgbd=options or RGBDOptions())
    fields = {k: v for k, v in keywords.items() if k != "db"}
    return replace(o, **fields) if fields else o


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
    options: DescribeOptions | RGBDOptions | None = None,
    **keywords: Unpack[DescribeKeywords],
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
    options : DescribeOptions or RGBDOptions, optional
        Up, histogram bins, summary, input names and the object stage's options (an
        RGBDOptions alone is the object stage's, the rest default).
    **keywords
        ``db`` (an ObjectDatabase, used when neither masks nor boxes are given: the
        recognised outlines are the regions) and the earlier keywords ``up``, ``directions``,
        ``summary``, ``sources``, each setting its field of ``options``
        (:class:`DescribeKeywords`).

    Raises
    ------
    ImageError
        Depth, colour and masks of different sizes; empty masks.
    InputError
        Labels naming instances not in the masks; none of masks, boxes, db given.
    """
    opts = _options(options, keywords)
    o, db = opts.rgbd, keywords.get("db")
    src = dict(opts.sources or {})
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
    inst = None if masks is None else as_instances(masks, labels, size, src)
    exclude = None if inst is None else inst.image > 0
    resolved = _resolve_up(d, intrinsics, opts.up, exclude, inst is None, o)
    timings["up"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    vec, plane = resolved[0], resolved[3]
    measured: list[MeasuredObject | Skipped] = []
    if inst is not None:
        measured.extend(measure_masks(d, intrinsics, inst, vec, o))
    elif boxes is not None:
        measured.extend(box_objects(boxes, d, intrinsics, vec, plane, o))
    elif db is not None:
        if color is None:
            raise InputError("color", "the object database needs the colour image")
        measured.extend(database_objects(color, d, intrinsics, vec, plane, db, o, timings))
    else:
        raise InputError(None, "give masks, boxes or an object database with the depth image")
    timings["objects"] = time.perf_counter() - t0
    return finish("horizontal", measured, resolved, timings, src, opts.directions, opts.summary)


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
        inst = as_instances(masks, labels, size, src)
        height = inst.image.shape[0]
        for k, label in enumerate(inst.labels):
            ys, xs = mask_pixels(inst, k)
            measured.append(image_object(label, label, ys, xs, height, source="mask"))
    elif boxes is not None:
        if size is None:
            raise InputError("size", "boxes in the image plane need the image size")
        for box in boxes:
            ys, xs = box_pixels(box, size)
            x0, y0, x1, y1 = box.pixel_box(size)
            cy = np.array([y0, y0, y1 - 1, y1 - 1])
            cx = np.array([x0, x1 - 1, x1 - 1, x0])
            m = image_object(box.label, box.label, cy, cx, size[1], source="box")
            measured.append(replace(m, pixels=len(ys), kept_pixels=len(ys)))
    else:
        raise InputError(None, "the image plane needs masks or boxes")
    timings["objects"] = time.perf_counter() - t0
    none = (None, "none", "", None)
    return finish("image", measured, none, timings, src, directions, summary)


def describe_stereo_masks(
    left: NDArray[np.generic],
    right: NDArray[np.generic],
    rig: Any,
    masks: MasksIn,
    labels: Mapping[int, str] | None = None,
    *,
    options: DescribeOptions | RGBDOptions | None = None,
    **keywords: Unpack[DescribeKeywords],
) -> RGBDDescription:
    """A stereo pair and an instance image of the LEFT image: depth from dense stereo.

    The pair is rectified and matched as in :func:`scenespeak.pipeline.describe_scene`; the
    dense SGBM map over the whole image gives each mask's 3-D points (in the original left
    camera frame), and each object keeps the largest depth mode of its pixels as with RGB-D.
    ``up`` is the rig's (``options.up`` is not used).

    ``options`` and the earlier keywords (``directions``, ``summary``, ``sources``,
    ``progress``) as in :func:`describe_rgbd`.
    """
    from scenespeak.perception import stereo

    opts = _options(options, keywords)
    o, progress = opts.rgbd, opts.progress
    src = dict(opts.sources or {})
    lname, rname = src.get("left", "left image"), src.get("right", "right image")
    stereo.check_pair(left, right, rig, left_name=lname, right_name=rname)
    h, w = np.asarray(left).shape[:2]
    inst = as_instances(masks, labels, (w, h), src)
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
            from_points(label, xyz, int(np.count_nonzero(inst.image == inst.ids[k])), up, o)
        )
    timings["objects"] = time.perf_counter() - t0
    return finish(
        "horizontal",
        measured,
        (up / np.linalg.norm(up), "given", "", None),
        timings,
        src,
        opts.directions,
        opts.summary,
    )
