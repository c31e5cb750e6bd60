"""One dispatch from the input files a user has to the right pipeline (every command uses it).

:class:`SceneInputs` names the files of any input form of ``scenespeak describe``
(``interfaces.md``, "Any perception in"); :func:`describe_inputs` reads them, checks that
they fit together (one line naming the file otherwise) and runs:

- LEFT RIGHT ``--calib`` ``--db``: the stereo pipeline
  (:func:`scenespeak.pipeline.describe_files`);
- LEFT RIGHT ``--calib`` ``--masks``: :func:`~scenespeak.pipeline_rgbd.describe_stereo_masks`;
- COLOR ``--depth`` ``--intrinsics`` with ``--masks``, ``--boxes`` or ``--db``:
  :func:`~scenespeak.pipeline_rgbd.describe_rgbd`;
- COLOR ``--masks`` (or ``--boxes``) alone:
  :func:`~scenespeak.pipeline_rgbd.describe_image_plane` (relations in the picture).

:func:`describe_scene_folder` does the same for a scene folder (``annotate``'s dataset layout):
``left.png`` + ``right.png`` + ``calib.json`` (stereo), or ``color.png`` + ``depth.png`` +
``intrinsics.json`` (RGB-D) with ``instances.png`` + ``labels.json`` when present.

>>> SceneInputs(color="c.png", masks="m.png").form
'image'
>>> SceneInputs(color="c.png", depth="d.png", intrinsics="k.json", db="o.db").form
'rgbd'
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from os import PathLike
from pathlib import Path
from typing import Any, Literal

import numpy as np

from scenespeak.errors import InputError
from scenespeak.perception.depth import DEFAULT_DEPTH_SCALE
from scenespeak.perception.rgbd import RGBDOptions

__all__ = ["SceneInputs", "describe_inputs", "describe_scene_folder"]

PathIn = str | PathLike[str]


def _p(v: PathIn | None) -> Path | None:
    return None if v is None else Path(v)


@dataclass(frozen=True)
class SceneInputs:
    """The files of one scene, in any input form.

    Attributes
    ----------
    color : path
        The colour image (RGB-D or image plane) or the LEFT image of a stereo pair.
    right, calib, calib_right : path, optional
        The RIGHT image and the rig's calibration (``calib_right``: a ROS pair's right
        camera_info).
    depth : path, optional
        Registered depth (16-bit PNG in units of ``depth_scale`` metres, float TIFF / .npy in
        metres).
    depth_scale : float
        Metres per unit of an integer depth image.
    intrinsics : path, optional
        The colour camera (JSON, ROS camera_info YAML, OpenCV YAML).
    masks, labels : path, optional
        Instance image and its labels JSON.
    boxes : path, optional
        COCO detection results (``labels`` then maps category ids to names).
    min_score : float
        Boxes with a lower score are ignored.
    db : path, optional
        The object database.
    estimate_up : bool
        Estimate up from the support plane even when the intrinsics give it.
    """

    color: PathIn
    right: PathIn | None = None
    calib: PathIn | None = None
    calib_right: PathIn | None = None
    depth: PathIn | None = None
    depth_scale: float = DEFAULT_DEPTH_SCALE
    intrinsics: PathIn | None = None
    masks: PathIn | None = None
    labels: PathIn | None = None
    boxes: PathIn | None = None
    min_score: float = 0.0
    db: PathIn | None = None
    estimate_up: bool = False

    @property
    def form(self) -> Literal["stereo", "stereo-masks", "rgbd", "image"]:
        """Which pipeline these inputs take."""
        if self.right is not None:
            return "stereo-masks" if self.masks is not None else "stereo"
        if self.depth is not None:
            return "rgbd"
        return "image"

    def sources(self) -> dict[str, str]:
        """File names per input, for messages and the record."""
        names = ("color", "right", "calib", "depth", "intrinsics", "masks", "labels", "boxes", "db")
        out = {k: str(getattr(self, k)) for k in names if getattr(self, k) is not None}
        if self.right is not None:
            out["left"] = out.pop("color")
        return out

    def check(self) -> None:
        """Refuse combinations that do not make one input form (one line saying what to give).

        Raises
        ------
        InputError
        """
        form = self.form
        if self.masks is not None and self.boxes is not None:
            raise InputError("--boxes", "give --masks or --boxes, not both")
        if self.labels is not None and self.masks is None and self.boxes is None:
            raise InputError(
                "--labels", "names the instances of --masks (or --boxes' categories); give --masks"
            )
        if form in ("stereo", "stereo-masks"):
            self._check_stereo(form)
        elif form == "rgbd":
            self._check_rgbd()
        elif self.masks is None and self.boxes is None:
            raise InputError(
                str(self.color),
                "a single image needs --depth and --intrinsics (with --db, --masks or --boxes), "
                "or --masks / --boxes for relations in the image plane; or give the right image "
                "too: a stereo pair needs LEFT RIGHT --calib",
            )

    def _check_stereo(self, form: str) -> None:
        """A stereo pair: its calibration, no depth, no boxes, the database unless masks."""
        if self.calib is None:
            need = "" if self.db or self.masks else " and the object database (--db or --masks)"
            raise InputError("--calib", f"a stereo pair (LEFT RIGHT) needs its calibration{need}")
        if self.depth is not None:
            raise InputError("--depth", "give a stereo pair or a depth image, not both")
        if self.boxes is not None:
            raise InputError(
                "--boxes", "boxes work with --depth or alone; with a stereo pair give --masks"
            )
        if form == "stereo" and self.db is None:
            raise InputError("--db", "a stereo pair needs the object database (or --masks)")

    def _check_rgbd(self) -> None:
        """Colour + depth: the intrinsics and what the objects are."""
        if self.intrinsics is None:
            raise InputError("--intrinsics", "a depth image needs the colour camera's intrinsics")
        if self.masks is None and self.boxes is None and self.db is None:
            raise InputError("--depth", "say what the objects are: give --masks, --boxes or --db")


def _labels(inputs: SceneInputs) -> dict[int, str] | None:
    from scenespeak.perception.masks import load_labels

    return None if inputs.labels is None else load_labels(inputs.labels)


def _instances(inputs: SceneInputs, size: tuple[int, int], other: str) -> Any:
    from scenespeak.perception.masks import instances_from_array, load_instances

    assert inputs.masks is not None
    return instances_from_array(
        load_instances(inputs.masks),
        _labels(inputs),
        size=size,
        source=str(inputs.masks),
        labels_source=str(inputs.labels) if inputs.labels is not None else "labels",
        other_name=other,
    )


def _boxes(inputs: SceneInputs, size: tuple[int, int]) -> Any:
    from scenespeak.perception.masks import load_boxes

    assert inputs.boxes is not None
    return load_boxes(inputs.boxes, size=size, names=_labels(inputs), min_score=inputs.min_score)


def _size(image: Any) -> tuple[int, int]:
    h, w = np.asarray(image).shape[:2]
    return (int(w), int(h))


def describe_inputs(
    inputs: SceneInputs,
    *,
    options: RGBDOptions | None = None,
    progress: Callable[[str], None] | None = None,
    **stereo_options: Any,
) -> Any:
    """Describe a scene from files in any input form (see the module's table).

    Parameters
    ----------
    inputs : SceneInputs
        The files.
    options : RGBDOptions, optional
        Knobs of the RGB-D / mask stage.
    progress : callable, optional
        Called with the name of each stage (stereo pipeline only).
    **stereo_options
        Passed to :func:`scenespeak.pipeline.describe_files` (``dense``, ``unknown``, ...).

    Returns
    -------
    SceneDescription or RGBDDescription
        Both have ``to_dict()`` (the ``describe --format json`` object) and ``to_text()``;
        RGB-D, mask and box inputs add ``"frame"`` at the top of the JSON.

    Raises
    ------
    ScenespeakError
        One line naming the file for every problem with the inputs.
    """
    from scenespeak import pipeline_rgbd as prg
    from scenespeak.perception.features import load_image

    inputs.check()
    form = inputs.form
    src = inputs.sources()
    if form == "stereo":
        from scenespeak.pipeline import describe_files

        assert inputs.right is not None and inputs.calib is not None and inputs.db is not None
        return describe_files(
            inputs.color,
            inputs.right,
            inputs.calib,
            inputs.db,
            calib_right=inputs.calib_right,
            progress=progress,
            **stereo_options,
        )
    if form == "stereo-masks":
        from scenespeak.perception.calibration import load_rig, load_ros_rig

        assert inputs.right is not None and inputs.calib is not None
        rig = (
            load_rig(inputs.calib)
            if inputs.calib_right is None
            else load_ros_rig(inputs.calib, inputs.calib_right)
        )
        left = load_image(inputs.color, gray=False)
        right = load_image(inputs.right, gray=False)
        inst = _instances(inputs, _size(left), f"the left image {inputs.color}")
        return prg.describe_stereo_masks(
            left, right, rig, inst, options=options, sources=src, progress=progress
        )
    color = load_image(inputs.color, gray=False)
    size = _size(color)
    if form == "image":
        if inputs.masks is not None:
            inst = _instances(inputs, size, f"the colour image {inputs.color}")
            return prg.describe_image_plane(inst, sources=src)
        return prg.describe_image_plane(boxes=_boxes(inputs, size), size=size, sources=src)
    return _describe_rgbd_files(inputs, color, size, options, src)


def _describe_rgbd_files(
    inputs: SceneInputs,
    color: Any,
    size: tuple[int, int],
    options: RGBDOptions | None,
    src: dict[str, str],
) -> Any:
    from scenespeak import pipeline_rgbd as prg
    from scenespeak.perception.depth import check_depth_size, load_depth
    from scenespeak.perception.intrinsics import load_intrinsics

    assert inputs.depth is not None and inputs.intrinsics is not None
    depth = load_depth(inputs.depth, scale=inputs.depth_scale)
    check_depth_size(
        depth, size, depth_name=str(inputs.depth), other_name=f"the colour image {inputs.color}"
    )
    cam = load_intrinsics(inputs.intrinsics)
    if cam.size != size:
        raise InputError(
            inputs.intrinsics,
            f"are for {cam.width}x{cam.height} images but {inputs.color} is {size[0]}x{size[1]}",
        )
    if inputs.estimate_up:
        cam = cam.with_up(None)
    if inputs.masks is not None:
        inst = _instances(inputs, size, f"the colour image {inputs.color}")
        return prg.describe_rgbd(color, depth, cam, masks=inst, options=options, sources=src)
    if inputs.boxes is not None:
        return prg.describe_rgbd(
            color, depth, cam, boxes=_boxes(inputs, size), options=options, sources=src
        )
    from scenespeak.perception.database import ObjectDatabase

    assert inputs.db is not None
    with ObjectDatabase.open(inputs.db, readonly=True) as db:
        return prg.describe_rgbd(color, depth, cam, db=db, options=options, sources=src)


def _first(folder: Path, names: tuple[str, ...]) -> Path | None:
    return next((folder / n for n in names if (folder / n).is_file()), None)


def scene_folder_inputs(
    folder: PathIn,
    *,
    db: PathIn | None = None,
    layout: Literal["auto", "stereo", "rgbd"] = "auto",
    use_masks: bool = True,
) -> SceneInputs:
    """The :class:`SceneInputs` of a scene folder.

    RGB-D layout: ``color.png`` (or the generator's ``left.png``), ``depth.png`` (16-bit mm),
    ``intrinsics.json``, and, when present and ``use_masks``, ``instances.png`` (or the
    generator's ``left_labels.png``) with ``labels.json``. Stereo layout: ``left.png``,
    ``right.png``, ``calib.json``. ``layout="auto"`` takes stereo when ``right.png`` and
    ``calib.json`` exist, RGB-D otherwise.

    Raises
    ------
    InputError
        If the folder holds neither layout (naming the files it needs).
    """
    d = Path(folder)
    if not d.is_dir():
        raise InputError(d, "no such scene folder")
    stereo = (
        (d / "left.png").is_file() and (d / "right.png").is_file() and (d / "calib.json").is_file()
    )
    if layout == "stereo" or (layout == "auto" and stereo):
        if not stereo:
            raise InputError(
                d, "is not a stereo scene folder (needs left.png, right.png, calib.json)"
            )
        return SceneInputs(
            color=d / "left.png", right=d / "right.png", calib=d / "calib.json", db=db
        )
    return _rgbd_folder_inputs(d, db, use_masks)


def _rgbd_folder_inputs(d: Path, db: PathIn | None, use_masks: bool) -> SceneInputs:
    """The RGB-D layout of :func:`scene_folder_inputs` (the folder holds no stereo scene)."""
    color = _first(d, ("color.png", "color.jpg", "left.png"))
    depth = _first(d, ("depth.png", "depth.tif", "depth.tiff", "depth.npy"))
    if color is None or depth is None or not (d / "intrinsics.json").is_file():
        raise InputError(
            d,
            "holds neither a stereo scene (left.png, right.png, calib.json) nor an RGB-D scene "
            "(color.png, depth.png, intrinsics.json)",
        )
    masks = _first(d, ("instances.png", "left_labels.png")) if use_masks else None
    labels = d / "labels.json" if masks is not None and (d / "labels.json").is_file() else None
    if masks is None and db is None:
        raise InputError(
            d, "an RGB-D scene needs instances.png (+ labels.json) or an object database"
        )
    return SceneInputs(
        color=color,
        depth=depth,
        intrinsics=d / "intrinsics.json",
        masks=masks,
        labels=labels,
        db=db if masks is None else None,
    )


def describe_scene_folder(
    folder: PathIn,
    db: PathIn | None = None,
    *,
    layout: Literal["auto", "stereo", "rgbd"] = "auto",
    use_masks: bool = True,
    options: RGBDOptions | None = None,
    **stereo_options: Any,
) -> Any:
    """Describe one scene folder (stereo or RGB-D layout; see :func:`scene_folder_inputs`).

    Examples
    --------
    >>> describe_scene_folder("/nonexistent")  # doctest: +IGNORE_EXCEPTION_DETAIL
    Traceback (most recent call last):
    scenespeak.errors.InputError: /nonexistent: no such scene folder
    """
    inputs = scene_folder_inputs(folder, db=db, layout=layout, use_masks=use_masks)
    return describe_inputs(inputs, options=options, **stereo_options)


def with_files(inputs: SceneInputs, **changes: Any) -> SceneInputs:
    """A copy of ``inputs`` with some files changed (e.g. ``depth=...``)."""
    return replace(inputs, **changes)
