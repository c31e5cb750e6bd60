"""Stage: recognised detections and stereo points → the scene's objects (the region strategy).

Two strategies, chosen by :class:`StrategyOptions` (``docs/architecture.md``):

- *geometry first* (``geometry=True``, the default when the dense map lies on the input grid):
  segments standing on the support plane, named by keypoints, depth agreeing with the object's
  own (:func:`scenespeak.perception.scene_regions.objects_from_regions`);
- *carried outlines*: each recognised object's training outline, carried into the left image
  by the fitted homography, selects a region whose depth is taken from dense stereo (the
  stereo stage's own SGBM map, or one computed over the outlines' bounding box), minus the
  outlines of recognised objects in front of it; its keypoints are the fallback. Unlabelled
  keypoints are clustered into unknown objects.

Objects that cannot be described are listed as :class:`~scenespeak.perception.objects.Skipped`
with the reason.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from concurrent.futures import Executor
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import cv2
import numpy as np
from numpy.typing import NDArray

from scenespeak.perception import stereo
from scenespeak.perception.objects import (
    ObjectOptions,
    SceneObject,
    Skipped,
    UnknownOptions,
    build_objects,
    make_object,
)
from scenespeak.perception.recognition.results import Labelling
from scenespeak.perception.stereo import StereoResult

if TYPE_CHECKING:
    from scenespeak.perception.regions import PlainParts
    from scenespeak.perception.scene_regions import SceneGeometry

__all__ = [
    "StrategyOptions",
    "geometry_for",
    "outline_mask",
    "plain_for",
    "points_inside",
    "scene_objects",
]


@dataclass(frozen=True)
class StrategyOptions:
    """Knobs of :func:`scene_objects`: where an object's points come from.

    Attributes
    ----------
    dense : bool
        True — take recognised objects' points from dense stereo inside their carried outline.
    dense_min_points : int
        30 — fewer valid dense points than this: fall back to the keypoints.
    dense_max_points : int
        300 — dense points used per object (an even random sample of the region's pixels).
    geometry : bool
        True — geometry first (``perception.scene_regions``): segments standing on the support
        plane, named by keypoints (False: the carried outlines).
    unknown : bool
        True — cluster unlabelled keypoints into unknown objects.
    unknown_max_distance : float
        2.5 m — unknown clusters farther than this from the camera are background, not objects
        (the seed paper's scenes are 0.5–2 m away).

    Examples
    --------
    >>> StrategyOptions(dense=False).uses_geometry(dense_map=True, resampled=False)
    False
    """

    dense: bool = True
    dense_min_points: int = 30
    dense_max_points: int = 300
    geometry: bool = True
    unknown: bool = True
    unknown_max_distance: float = 2.5

    def uses_geometry(self, *, dense_map: bool, resampled: bool) -> bool:
        """Geometry first needs the dense map on the input grid (no resampling rectification)."""
        return bool(self.geometry and self.dense and dense_map and not resampled)


def scene_objects(
    images: tuple[NDArray[np.generic], NDArray[np.generic]],
    result: StereoResult,
    labelling: Labelling,
    id_to_label: Mapping[int, str],
    strategy: StrategyOptions,
    objects: ObjectOptions,
    geometry: SceneGeometry | None = None,
    executor: Executor | None = None,
) -> tuple[tuple[SceneObject, ...], list[Skipped]]:
    """The scene's objects by the strategy of ``strategy`` (module docstring).

    Parameters
    ----------
    images : (left, right)
        The stereo pair as given (the left image's size; SGBM when the stereo stage made no
        dense map).
    result : StereoResult
        The stereo stage (points, rectification, the dense map when computed).
    labelling : Labelling
        The database's labelling of the left keypoints.
    id_to_label : mapping
        Database object id → label (geometry first's keypoint votes; empty: no votes).
    strategy, objects : StrategyOptions, ObjectOptions
        Where the points come from; how an object is made of them.
    geometry : SceneGeometry, optional
        Geometry first's support plane and segments, when already computed
        (:func:`geometry_for`); None: computed here when the strategy uses them.
    executor : Executor, optional
        Geometry first shares its detections' work with one task of it (the same result).
    """
    shape = images[0].shape[:2]
    resampled = bool(result.rect.needs_resampling)
    if strategy.uses_geometry(dense_map=result.dense is not None, resampled=resampled):
        return _geometry_objects(
            (shape[0], shape[1]), result, labelling, objects, id_to_label, geometry, executor
        )
    return _outline_objects(images, result, labelling, strategy, objects)


def geometry_for(
    shape: tuple[int, int],
    result: StereoResult,
    strategy: StrategyOptions,
    image: NDArray[np.generic] | None = None,
    plain: Callable[[], PlainParts] | None = None,
    right: NDArray[np.generic] | None = None,
) -> SceneGeometry | None:
    """The support plane and segments :func:`scene_objects` will use with this strategy (None
    when it uses none): they need the stereo stage only, not the labels, so the pipeline
    computes them in its stereo thread while this one labels (the call
    :func:`scenespeak.perception.scene_regions.objects_from_regions` makes, plus the left
    ``image`` whose plain background takes part in no segment; ``plain``: a call returning
    :func:`plain_for` of that image, when another thread makes it). With the ``right`` image
    too, the segments are made on the stereo stage's map widened to the depths its keypoints'
    range and box could not measure (:func:`scenespeak.perception.stereo.reach.widened`: an
    object nearer or farther than every matched keypoint); the stage's own map, which its
    points were checked against, is left as it is."""
    resampled = bool(result.rect.needs_resampling)
    if result.dense is None or not strategy.uses_geometry(dense_map=True, resampled=resampled):
        return None
    from scenespeak.perception.scene_regions import RegionStageOptions, scene_geometry

    dense = result.dense
    if image is not None and right is not None:
        from scenespeak.perception.stereo.reach import widened

        dense = widened(image, right, dense)
    up = np.asarray(result.rect.rig.up, dtype=np.float64)
    regions = RegionStageOptions().regions
    return scene_geometry(dense, up, (shape[0], shape[1]), regions, image=image, plain=plain)


def plain_for(image: NDArray[np.generic], shape: tuple[int, int]) -> PlainParts:
    """What :func:`geometry_for` takes from the left image alone (its plain backgrounds and
    textured pixels, :func:`scenespeak.perception.regions.plain_parts`): it needs no stereo,
    so the pipeline makes it in the labelling thread and hands it to ``geometry_for(plain=)``."""
    from scenespeak.perception.regions import plain_parts
    from scenespeak.perception.scene_regions import RegionStageOptions

    return plain_parts(image, (shape[0], shape[1]), RegionStageOptions().regions)


def _geometry_objects(
    shape: tuple[int, int],
    result: StereoResult,
    labelling: Labelling,
    o: ObjectOptions,
    id_to_label: Mapping[int, str],
    geometry: SceneGeometry | None = None,
    executor: Executor | None = None,
) -> tuple[tuple[SceneObject, ...], list[Skipped]]:
    """Geometry first (``perception.scene_regions``): named segments, votes, unknown segments
    (``executor``: shares the detections' work, the same result)."""
    from scenespeak.perception.scene_regions import SceneInputs, objects_from_regions

    xy = np.asarray(result.features_left.xy, dtype=np.float64)
    up = np.asarray(result.rect.rig.up, dtype=np.float64)
    inputs = SceneInputs(
        shape, result.dense, result.points, labelling, xy, up, dict(id_to_label), geometry
    )
    # the outlier radius is scaled to each object (objects.scaled_radius), not o.radius
    kw = {"outliers": o.outliers, "eps": o.eps, "min_points": o.min_points}
    objs, skipped, _geo = objects_from_regions(inputs, object_options=kw, executor=executor)
    return tuple(objs), skipped


def _outline_objects(
    images: tuple[NDArray[np.generic], NDArray[np.generic]],
    result: StereoResult,
    labelling: Labelling,
    strategy: StrategyOptions,
    o: ObjectOptions,
) -> tuple[tuple[SceneObject, ...], list[Skipped]]:
    """Known objects (dense region or keypoints), then unknown clusters."""
    shape = (images[0].shape[0], images[0].shape[1])
    points = result.points
    up = np.asarray(result.rect.rig.up, dtype=np.float64)
    kp_names = labelling.names()
    labels_arr = np.array(
        ["" if kp_names[int(i)] is None else kp_names[int(i)] for i in points.left_index],
        dtype=object,
    )
    claimed = labels_arr != ""
    objects: list[SceneObject] = []
    skipped: list[Skipped] = []
    masks = {d.label: outline_mask(d.outline_in_scene, shape) for d in labelling.detections}
    dense_xyz = (
        _dense_regions(
            images, result, _visible_parts(masks, points, labels_arr), strategy.dense_max_points
        )
        if strategy.dense
        else {}
    )
    for det in labelling.detections:
        name = det.label
        claimed |= points_inside(points.left_xy, masks[name])
        kp = np.asarray(points.xyz)[labels_arr == name]
        made = _known_object(name, kp, dense_xyz.get(name), up, strategy, o)
        (objects if isinstance(made, SceneObject) else skipped).append(made)  # type: ignore[arg-type]
    if strategy.unknown:
        free = ~claimed
        extra, extra_skipped = build_objects(
            np.asarray(points.xyz)[free],
            [None] * int(free.sum()),
            up,
            unknown=True,
            unknown_options=UnknownOptions(max_distance=strategy.unknown_max_distance),
            options=o,
        )
        objects.extend(extra)
        skipped.extend(extra_skipped)
    return tuple(objects), skipped


def _known_object(
    name: str,
    kp: NDArray[np.float64],
    region: NDArray[np.float64] | None,
    up: NDArray[np.float64],
    strategy: StrategyOptions,
    o: ObjectOptions,
) -> SceneObject | Skipped:
    """A recognised object from its dense region, or from its keypoints (with a note why)."""
    note = None
    if region is not None and len(region) >= strategy.dense_min_points:
        made = make_object(name, region, up, source="dense", options=o)
    else:
        if strategy.dense:
            n_dense = 0 if region is None else len(region)
            note = f"dense stereo gave {n_dense} points in its outline, keypoints used"
        made = make_object(name, kp, up, source="keypoints", options=o)
    if isinstance(made, Skipped):
        reason = made.reason
        if not len(kp):
            reason = (
                "recognised in the left image, but none of its keypoints was matched "
                "in the right image"
            )
        return Skipped(name, f"{reason}; {note}" if note else reason)
    return replace(made, notes=(*made.notes, note)) if note else made


def outline_mask(outline: NDArray[np.float64], shape: tuple[int, int]) -> NDArray[np.bool_]:
    """Fill a polygon (pixel coordinates, column/row) into a boolean mask of ``shape``.

    Examples
    --------
    >>> int(outline_mask(np.array([[1.0, 1.0], [5.0, 1.0], [5.0, 4.0], [1.0, 4.0]]), (6, 8)).sum())
    20
    """
    mask = np.zeros(shape, dtype=np.uint8)
    pts = np.round(np.asarray(outline, dtype=np.float64) * 16).astype(np.int32)
    if len(pts) >= 3:
        cv2.fillPoly(mask, [pts.reshape(-1, 1, 2)], 1, lineType=cv2.LINE_8, shift=4)
    return mask.astype(bool)


def points_inside(xy: NDArray[np.float64], mask: NDArray[np.bool_]) -> NDArray[np.bool_]:
    """Which pixel positions (column, row) fall on a true pixel of ``mask`` (outside: False)."""
    h, w = mask.shape
    c = np.clip(np.round(xy[:, 0]).astype(np.intp), 0, w - 1)
    r = np.clip(np.round(xy[:, 1]).astype(np.intp), 0, h - 1)
    inside = (xy[:, 0] >= -0.5) & (xy[:, 0] < w - 0.5) & (xy[:, 1] >= -0.5) & (xy[:, 1] < h - 0.5)
    return inside & mask[r, c]


def _visible_parts(
    masks: Mapping[str, NDArray[np.bool_]],
    points: stereo.Points3D,
    labels_arr: NDArray[np.object_],
) -> dict[str, NDArray[np.bool_]]:
    """Each outline minus the outlines of recognised objects in front of it.

    A carried outline covers the whole object, also where a nearer object hides it; those
    pixels would give the nearer object's depth. Objects are ordered by the median disparity
    of their labelled keypoints (larger is nearer); an object without keypoints keeps its
    outline whole.
    """
    disparity = np.asarray(points.disparity, dtype=np.float64)
    near = {
        name: float(np.median(disparity[labels_arr == name]))
        for name in masks
        if np.any(labels_arr == name)
    }
    out: dict[str, NDArray[np.bool_]] = {}
    for name, mask in masks.items():
        visible = mask.copy()
        if name in near:
            for other, d in near.items():
                if other != name and d > near[name]:
                    visible &= ~masks[other]
        out[name] = visible
    return out


def _dense_regions(
    images: tuple[NDArray[np.generic], NDArray[np.generic]],
    result: StereoResult,
    masks: Mapping[str, NDArray[np.bool_]],
    max_points: int,
) -> dict[str, NDArray[np.float64]]:
    """3-D points of each recognised object's outline from dense stereo.

    At most ``max_points`` per object (an even random sample: enough for outlier removal and
    the hull). The stereo stage's own SGBM map (computed once per pair to verify the matches)
    is reused; without one, SGBM runs once over the bounding box of all outlines and the
    disparity range of the keypoints.
    """
    if not masks:
        return {}
    dense = result.dense
    if dense is None:
        union = np.logical_or.reduce(list(masks.values()))
        if not union.any():
            return {}
        ys, xs = np.nonzero(union)
        roi: tuple[int, int, int, int] | None = (
            int(xs.min()),
            int(ys.min()),
            int(xs.max()) + 1,
            int(ys.max()) + 1,
        )
        if result.rect.needs_resampling:
            roi = None  # the outline is in input pixels; the map is rectified
        dense = stereo.dense_disparity(
            images[0], images[1], result.rect, keypoint_disparities=result.points.disparity, roi=roi
        )
    out: dict[str, NDArray[np.float64]] = {}
    for name, m in masks.items():
        xyz, _ = stereo.region_points(dense, m, max_points=max_points)
        out[name] = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
    return out
