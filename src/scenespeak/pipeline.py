"""The whole chain: a stereo pair, its rig and an object database → objects, relations, words.

:func:`describe_scene` runs the stages of ``docs/architecture.md`` once each and keeps every
stage's result in a frozen :class:`SceneDescription`:

1. SIFT on both images and stereo matching
   (:func:`scenespeak.perception.stereo.stereo_points`; SIFT runs once per image and the left
   features are reused for labelling);
2. labelling of the left keypoints against the database (ratio test + geometric check,
   :meth:`scenespeak.perception.recognition.ObjectDatabase.label`);
3. the distance strategy: for each recognised object its training outline, carried into the left
   image by the fitted homography, selects a region whose depth is taken from dense stereo
   (OpenCV StereoSGBM, computed once per pair over the disparity range the keypoints need and
   only over the bounding box of the keypoints it verifies and of the recognised outlines), so
   that a far object gets the hull of its visible surface rather than of three keypoints; the
   keypoints are the fallback;
4. objects on the horizontal plane (:mod:`scenespeak.perception.objects`): outlier removal,
   convex hull, unknown points clustered into "unknown object N"; objects that cannot be
   described are listed in ``skipped`` with the reason;
5. every ordered pair of objects through the Histogram of Forces and the rule base
   (:mod:`scenespeak.spatial.language`), with the heights along up for the vertical relations; all
   pairs in one call (``language.relate_objects``: each hull prepared once, each unordered
   pair's histograms computed once and read both ways).

Threads: the two SIFT extractions run at the same time; then the second thread runs the whole
stereo stage (matching, SGBM around the matches, triangulation) while this one labels the left
keypoints (``docs/architecture.md``).

Speed (``benchmarks/bench_pipeline.py --only timing``, 640×480 rendered pair with 5 objects,
shared 2-core machine): the whole call takes about 0.9–1.0× the two SIFT extractions run one
after the other and about 1.4–1.5× the two run in two threads as here; after SIFT, labelling
14, waiting for the stereo stage 10, objects 8 and relations 4.5 ms (README, "Speed"). BLAS is
limited to one thread (the matrices are small; a second OpenBLAS thread made a 200 × 128 ×
200 product 150× slower when the other core was busy).

:meth:`SceneDescription.to_dict` gives exactly the JSON of ``docs/interfaces.md`` (plus extra
fields); :meth:`SceneDescription.to_text` the sentences for people.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator, Mapping
from concurrent.futures import Future, ThreadPoolExecutor
from contextlib import contextmanager
from dataclasses import dataclass, field
from os import PathLike
from pathlib import Path
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

from scenespeak.errors import DatabaseError, ImageError, InputError
from scenespeak.perception.blas import single_threaded_blas
from scenespeak.perception.features import detect, to_gray
from scenespeak.perception.objects import SceneObject, Skipped, build_objects, make_object

__all__ = [
    "PairRelation",
    "PipelineOptions",
    "SceneDescription",
    "database_from_dataset",
    "describe_files",
    "describe_scene",
]


@dataclass(frozen=True)
class PipelineOptions:
    """Knobs of :func:`describe_scene` (defaults are the ones the CLI uses).

    Attributes
    ----------
    ratio : float
        Lowe's ratio for left/right matching (the paper's 0.6).
    label_ratio : float
        Ratio test for labelling against the database (the second neighbour is the nearest
        descriptor of another object, so a looser value than for stereo is right).
    min_inliers : int
        Geometric inliers needed to accept a recognised object.
    min_inliers_small, small_area : int, float
        A *small* detection (its outline in the scene covers at most ``small_area`` square
        pixels: a far object, with few keypoints) needs only ``min_inliers_small`` inliers at
        distinct positions (``ObjectDatabase.label``; figures in ``docs/database.md``).
    dense : bool
        Take recognised objects' points from dense stereo inside their carried outline.
    dense_min_points : int
        Fewer valid dense points than this: fall back to the keypoints.
    dense_max_points : int
        Dense points used per object (an even random sample of the region's pixels).
    dense_crop : bool
        Compute the dense map only over the bounding box of the stereo matches it verifies,
        plus ``dense_margin`` pixels (``stereo.stereo_points(dense_crop=True)``), not the whole
        image. A recognised outline reaches beyond that box only by a few textureless pixels,
        where SGBM finds little anyway (``docs/calibration.md``); the map does not wait for the
        labels, so it is computed while the objects are recognised.
    dense_margin : int
        Pixels around the matches' box for ``dense_crop``.
    unknown : bool
        Cluster unlabelled keypoints into unknown objects.
    unknown_max_distance : float
        Unknown clusters farther than this from the camera (metres) are background, not
        objects (the seed paper's scenes are 0.5–2 m away).
    min_points : int
        Points an object needs after outlier removal (3 for a hull; see ``objects.make_object``).
    outliers : str
        ``"both"``, ``"radius"``, ``"dbscan"`` or ``"none"`` (see ``objects.make_object``).
    radius, eps : float
        The paper's fixed radius and DBSCAN's neighbourhood radius, metres.
    directions : int
        Bins of the force histograms.
    summary : bool
        Also write a short scene summary (``language.summarize_scene``).
    geometry : bool
        Geometry first (``perception.scene_regions``): segments standing on the support plane,
        named by keypoints, depth agreeing with the object's own (False: the carried outlines).
    threads : int
        Threads one scene may use: 2 runs the two SIFT extractions at the same time and the
        stereo stage beside the labelling (module docstring); 1 runs every stage one after the
        other in the calling thread, for a process that already has one scene per core (a
        cluster worker, :mod:`scenespeak.tools.engine`). The result is the same either way.
    """

    ratio: float = 0.6
    label_ratio: float = 0.8
    min_inliers: int = 8
    min_inliers_small: int = 4
    small_area: float = 8000.0
    dense: bool = True
    dense_min_points: int = 30
    dense_max_points: int = 300
    dense_crop: bool = True
    dense_margin: int = 16
    unknown: bool = True
    unknown_max_distance: float = 2.5
    min_points: int = 3
    outliers: str = "both"
    radius: float = 0.5
    eps: float = 0.05
    directions: int = 180
    summary: bool = True
    geometry: bool = True
    threads: int = 2

    def __post_init__(self) -> None:
        if self.threads not in (1, 2):
            raise InputError("threads", f"must be 1 or 2, got {self.threads!r}")


@dataclass(frozen=True, eq=False)
class PairRelation:
    """The relation of one ordered pair with the force histograms it was decided from.

    Attributes
    ----------
    relation : Relation
        The words and numbers of :mod:`scenespeak.spatial.language` (``primary``, ``secondary``,
        ``sentence``, ``hedge``, ``vertical``, ...; also readable directly on this object).
    f0, f2 : (directions,) float64
        F0 and F2 of the argument relative to the referent; ``f2`` is the hybrid F02 where F2 is
        undefined (touching or overlapping hulls, ``relation.hybrid``).
    """

    relation: Any
    f0: NDArray[np.float64]
    f2: NDArray[np.float64]

    def __getattr__(self, name: str) -> Any:
        # Only called for names that are not fields: read them from the Relation.
        if name.startswith("__") or name in ("relation", "f0", "f2"):
            raise AttributeError(name)
        return getattr(self.relation, name)

    def to_dict(self) -> dict[str, Any]:
        """The ``relations`` entry of ``docs/interfaces.md`` plus ``Relation.to_dict``'s extras."""
        rel = self.relation
        head: dict[str, Any] = {
            "argument": rel.argument,
            "referent": rel.referent,
            "primary": rel.primary,
            "secondary": rel.secondary,
            "sentence": rel.sentence,
            "f0": [float(v) for v in self.f0],
            "f2": [float(v) for v in self.f2],
        }
        head.update({k: v for k, v in rel.to_dict().items() if k not in head})
        return head


@dataclass(frozen=True, eq=False)
class SceneDescription:
    """Everything :func:`describe_scene` computed, stage by stage.

    Attributes
    ----------
    left, right : ndarray
        The input images (as given).
    rig : StereoRig
        The calibration.
    features_left, features_right : Features
        SIFT features of each image.
    points : Points3D
        Matched and triangulated keypoints (left camera frame).
    stereo : StereoResult
        The whole stereo stage (rectification, matches, the dense disparity map if computed).
    point_labels : tuple of (str or None)
        The object each stereo point was labelled with, None for unknown.
    labelling : Labelling or None
        The database's labelling of the left keypoints (with its detections).
    objects : tuple of SceneObject
        Described objects.
    skipped : tuple of Skipped
        Objects that could not be described, with the reason.
    relations : tuple of PairRelation
        Every ordered pair of described objects: the Relation and its histograms.
    summary : str
        A short paragraph about the scene ("" without objects or when switched off).
    timings : dict of str to float
        Seconds spent per stage: ``sift`` (the left image; the right one runs at the same time
        in a second thread), ``label``, ``stereo`` (in the second thread, while ``label`` runs),
        ``wait`` (for the stereo stage after labelling), ``objects``, ``relations``. The wall
        time is about ``sift + label + wait + objects + relations``.
    sources : dict of str to str
        The files the inputs came from, when known.
    """

    left: NDArray[np.generic]
    right: NDArray[np.generic]
    rig: Any
    features_left: Any
    features_right: Any
    points: Any
    stereo: Any
    point_labels: tuple[str | None, ...]
    labelling: Any
    objects: tuple[SceneObject, ...]
    skipped: tuple[Skipped, ...]
    relations: tuple[PairRelation, ...]
    summary: str = ""
    timings: Mapping[str, float] = field(default_factory=dict)
    sources: Mapping[str, str] = field(default_factory=dict)

    @property
    def up(self) -> NDArray[np.float64]:
        """The world's up direction in the left camera frame."""
        return np.asarray(self.rig.up, dtype=np.float64)

    @property
    def detections(self) -> tuple[Any, ...]:
        """Objects recognised in the left image (``Detection``), best first."""
        return () if self.labelling is None else tuple(self.labelling.detections)

    def object(self, label: str) -> SceneObject | None:
        """The described object with this label, if any."""
        for obj in self.objects:
            if obj.label == label:
                return obj
        return None

    def relation(self, argument: str, referent: str) -> PairRelation | None:
        """The relation of ``argument`` to ``referent``, or None."""
        for rel in self.relations:
            if rel.argument == argument and rel.referent == referent:
                return rel
        return None

    def to_dict(self) -> dict[str, Any]:
        """The JSON of ``scenespeak describe --format json`` (``docs/interfaces.md``), plus extras.

        ``objects`` (label, points, centroid, hull; extras: source, notes, plane_centroid,
        height_range), ``relations`` (argument, referent, primary, secondary, sentence, f0, f2;
        extras from :meth:`Relation.to_dict`), ``skipped`` (label, reason); extras ``summary``,
        ``up``, ``camera`` (``focal_px``, ``baseline_m``: the depth error Z²·σ/(f·B) of the
        dialogue's hedges), ``stereo_points``, ``timings_ms``.
        """
        objects = []
        for o in self.objects:
            objects.append(
                {
                    "label": o.label,
                    "name": o.key,
                    "confidence": round(float(o.confidence), 4),
                    "points": int(o.n_points),
                    "centroid": [float(v) for v in o.centroid],
                    "hull": [[float(x), float(y)] for x, y in o.hull],
                    "source": o.source,
                    "notes": list(o.notes),
                    "plane_centroid": [float(v) for v in o.plane_centroid],
                    "height_range": [float(o.heights.min()), float(o.heights.max())],
                }
            )
        relations = [rel.to_dict() for rel in self.relations]
        return {
            "objects": objects,
            "relations": relations,
            "skipped": [{"label": s.label, "reason": s.reason} for s in self.skipped],
            "summary": self.summary,
            "up": [float(v) for v in self.up],
            "camera": _camera(self.rig),
            "stereo_points": len(self.point_labels),
            "timings_ms": {k: round(v * 1000.0, 2) for k, v in self.timings.items()},
        }

    def to_text(self) -> str:
        """The sentences for people: every ordered pair, then what was not described."""
        lines = [rel.sentence for rel in self.relations]
        if not self.objects:
            lines.append("No object could be described in this scene.")
        elif len(self.objects) == 1:
            lines.append(f"Only the {self.objects[0].label} was described: nothing to relate.")
        for s in self.skipped:
            lines.append(f"Not described: the {s.label} ({s.reason}).")
        return "\n".join(lines)


def _camera(rig: Any) -> dict[str, float]:
    """Focal length (px) and baseline (m) of the rig, for the depth error of a scene's words."""
    try:
        return {"focal_px": float(rig.K_left[0][0]), "baseline_m": float(rig.baseline)}
    except (AttributeError, TypeError, IndexError):
        return {}


# --------------------------------------------------------------------------------------------
# the chain


@contextmanager
def _timed(timings: dict[str, float], name: str) -> Iterator[None]:
    t0 = time.perf_counter()
    try:
        yield
    finally:
        timings[name] = timings.get(name, 0.0) + time.perf_counter() - t0


def _outline_mask(outline: NDArray[np.float64], shape: tuple[int, int]) -> NDArray[np.bool_]:
    """Fill a polygon (pixel coordinates, column/row) into a boolean mask of ``shape``."""
    mask = np.zeros(shape, dtype=np.uint8)
    pts = np.round(np.asarray(outline, dtype=np.float64) * 16).astype(np.int32)
    if len(pts) >= 3:
        cv2.fillPoly(mask, [pts.reshape(-1, 1, 2)], 1, lineType=cv2.LINE_8, shift=4)
    return mask.astype(bool)


def _points_inside(xy: NDArray[np.float64], mask: NDArray[np.bool_]) -> NDArray[np.bool_]:
    h, w = mask.shape
    c = np.clip(np.round(xy[:, 0]).astype(np.intp), 0, w - 1)
    r = np.clip(np.round(xy[:, 1]).astype(np.intp), 0, h - 1)
    inside = (xy[:, 0] >= -0.5) & (xy[:, 0] < w - 0.5) & (xy[:, 1] >= -0.5) & (xy[:, 1] < h - 0.5)
    return inside & mask[r, c]


def _relate_all(objects: tuple[SceneObject, ...], directions: int) -> list[PairRelation]:
    """Every ordered pair through the force histograms and the rule base.

    :func:`scenespeak.spatial.language.relate_objects` prepares each hull once, computes each
    unordered pair's F0 and F2 (or the hybrid F02 where the hulls touch) in one sweep over all
    pairs and describes both orderings (F(B, A) is F(A, B) turned by 180°), with the heights
    along up for the vertical relations.
    """
    from scenespeak.spatial.language import relate_objects

    found = relate_objects(
        [o.hull for o in objects],
        names=[o.key for o in objects],
        heights=[o.heights for o in objects],
        directions=directions,
    )
    relations = [PairRelation(rel, hist.f0, hist.f2) for rel, hist in found]
    order = {o.key: k for k, o in enumerate(objects)}
    relations.sort(key=lambda r: (order[r.argument], order[r.referent]))
    return relations


class _InlineExecutor:
    """``ThreadPoolExecutor``'s ``submit`` run at once in the calling thread (``threads=1``)."""

    def __enter__(self) -> _InlineExecutor:
        return self

    def __exit__(self, *exc: object) -> None:
        return None

    def submit(self, fn: Callable[..., Any], /, *args: Any, **kwargs: Any) -> Future[Any]:
        """Run ``fn(*args, **kwargs)`` now; its result (or exception) in a finished future."""
        future: Future[Any] = Future()
        try:
            future.set_result(fn(*args, **kwargs))
        except BaseException as exc:  # handed to whoever asks for the result, as a pool does
            future.set_exception(exc)
        return future


def describe_scene(
    left: NDArray[np.generic],
    right: NDArray[np.generic],
    rig: Any,
    db: Any,
    *,
    options: PipelineOptions | None = None,
    sources: Mapping[str, str] | None = None,
    progress: Callable[[str], None] | None = None,
    **overrides: Any,
) -> SceneDescription:
    """Describe a stereo pair: objects, their hulls, and every ordered pair in words.

    Parameters
    ----------
    left, right : ndarray
        The stereo pair (gray or RGB, same size, the rig's size).
    rig : StereoRig
        Its calibration (``scenespeak.perception.calibration.load_rig``).
    db : ObjectDatabase
        The object database (``scenespeak.perception.recognition.ObjectDatabase.open``).
    options : PipelineOptions, optional
        The knobs; keyword ``overrides`` replace single fields (``dense=False``, ...).
    sources : mapping, optional
        File names of the inputs ("left", "right", "calib", "db"), for messages and the record.
    progress : callable, optional
        Called with the name of each stage as it starts.

    Returns
    -------
    SceneDescription

    Raises
    ------
    ImageError
        Images of different sizes, or a scene without any stereo match (no texture).
    DatabaseError
        An empty database.
    """
    from dataclasses import replace

    from scenespeak.perception import stereo

    opts = options or PipelineOptions()
    if overrides:
        opts = replace(opts, **overrides)
    src = dict(sources or {})
    lname, rname = src.get("left", "left image"), src.get("right", "right image")
    stereo.check_pair(left, right, rig, left_name=lname, right_name=rname)
    if len(db) == 0:
        raise DatabaseError(
            src.get("db", getattr(db, "path", "database")),
            "the database holds no objects; add some with `scenespeak db add`",
        )
    timings: dict[str, float] = {}
    say = progress or (lambda _stage: None)

    # SIFT once per image, the two images at the same time (OpenCV releases the GIL). Once the
    # right image's features exist, the worker thread runs the whole stereo stage (matching,
    # SGBM, triangulation: none of it needs the labels) while this thread labels the left
    # keypoints (the database stays here: SQLite connections belong to their thread). The
    # rest works on small matrices (a few hundred keypoints and points): OpenBLAS's second
    # thread only costs there, and a lot when the other core is busy (a 200 x 128 x 200
    # product took 16 ms instead of 0.1 ms on the shared 2-core machine), so BLAS runs
    # single-threaded throughout.
    say("sift")
    pool_cm = ThreadPoolExecutor(max_workers=1) if opts.threads > 1 else _InlineExecutor()
    with single_threaded_blas(), pool_cm as pool:
        t0 = time.perf_counter()
        future_r = pool.submit(detect, to_gray(right), precise_upscale=False)
        feats_l = detect(to_gray(left), precise_upscale=False)
        timings["sift"] = time.perf_counter() - t0
        future_st = pool.submit(
            _stereo_stage, left, right, rig, opts, feats_l, future_r, (lname, rname), timings
        )
        with _timed(timings, "label"):
            labelling = db.label(
                feats_l,
                ratio=opts.label_ratio,
                min_inliers=opts.min_inliers,
                min_inliers_small=opts.min_inliers_small,
                small_area=opts.small_area,
            )
        say("stereo")
        with _timed(timings, "wait"):
            feats_r, result = future_st.result()
        id_to_label = {o.id: o.label for o in db.list_objects()} if opts.geometry else {}
        return _after_stereo(
            left,
            right,
            opts,
            src,
            timings,
            say,
            feats_l,
            feats_r,
            result,
            labelling,
            lname,
            id_to_label,
        )


def _stereo_stage(
    left: NDArray[np.generic],
    right: NDArray[np.generic],
    rig: Any,
    opts: PipelineOptions,
    feats_l: Any,
    future_r: Future[Any],
    names: tuple[str, str],
    timings: dict[str, float],
) -> tuple[Any, Any]:
    """The right image's features (from ``future_r``), then the stereo stage (worker thread)."""
    from scenespeak.perception import stereo

    feats_r = future_r.result()
    with _timed(timings, "stereo"):
        result = stereo.stereo_points(
            left,
            right,
            rig,
            ratio=opts.ratio,
            features_left=feats_l,
            features_right=feats_r,
            left_name=names[0],
            right_name=names[1],
            dense_crop=opts.dense_crop,
            dense_margin=opts.dense_margin,
        )
    return feats_r, result


def _no_matches_error(src: Mapping[str, str], rig: Any, n_left: int, n_right: int) -> Exception:
    """Name what is most likely wrong when a pair gives no stereo match: the image with no
    texture, or (when both have plenty of keypoints) the calibration."""
    from scenespeak.errors import CalibrationError

    counts = f"{n_left} SIFT keypoints in the left image, {n_right} in the right"
    if min(n_left, n_right) >= 50:
        return CalibrationError(
            src.get("calib", getattr(rig, "source", "calibration")),
            f"no stereo matches ({counts}): the calibration does not seem to fit these images "
            "(rectification, image size, or LEFT and RIGHT swapped)",
        )
    side = "left" if n_left <= n_right else "right"
    return ImageError(
        src.get(side, f"{side} image"),
        f"no stereo matches ({counts}): the {side} image has too little texture to describe",
    )


def _after_stereo(
    left: NDArray[np.generic],
    right: NDArray[np.generic],
    opts: PipelineOptions,
    src: dict[str, str],
    timings: dict[str, float],
    say: Callable[[str], None],
    feats_l: Any,
    feats_r: Any,
    result: Any,
    labelling: Any,
    lname: str,
    id_to_label: dict[int, str] | None = None,
) -> SceneDescription:
    """Stages 3-5 of :func:`describe_scene` once the labels and the stereo points are known."""
    rig = result.rect.rig
    points = result.points
    if len(points.xyz) == 0:
        raise _no_matches_error(src, rig, len(feats_l), len(feats_r))
    kp_names = labelling.names()
    point_labels = tuple(kp_names[int(i)] for i in points.left_index)

    say("objects")
    with _timed(timings, "objects"):
        if _use_geometry(opts, result):
            objects, skipped = _geometry_objects(
                left.shape[:2], result, labelling, opts, id_to_label
            )
        else:
            objects, skipped = _objects(left, right, result, point_labels, labelling, opts)

    say("relations")
    with _timed(timings, "relations"):
        relations = _relate_all(objects, opts.directions)
        summary = ""
        if opts.summary and relations:
            from scenespeak.spatial.language import summarize_scene

            summary = summarize_scene(
                [r.relation for r in relations],
                centroids={o.key: o.plane_centroid for o in objects},
            )

    return SceneDescription(
        left=left,
        right=right,
        rig=rig,
        features_left=feats_l,
        features_right=feats_r,
        points=points,
        stereo=result,
        point_labels=point_labels,
        labelling=labelling,
        objects=objects,
        skipped=tuple(skipped),
        relations=tuple(relations),
        summary=summary,
        timings=timings,
        sources=src,
    )


def _objects(
    left: NDArray[np.generic],
    right: NDArray[np.generic],
    result: Any,
    point_labels: tuple[str | None, ...],
    labelling: Any,
    opts: PipelineOptions,
) -> tuple[tuple[SceneObject, ...], list[Skipped]]:
    """Known objects (dense region or keypoints), then unknown clusters."""
    points = result.points
    up = np.asarray(result.rect.rig.up, dtype=np.float64)
    shape = left.shape[:2]
    obj_opts: dict[str, Any] = {
        "outliers": opts.outliers,
        "radius": opts.radius,
        "eps": opts.eps,
        "min_points": opts.min_points,
    }
    labels_arr = np.array(["" if v is None else v for v in point_labels], dtype=object)
    claimed = labels_arr != ""
    objects: list[SceneObject] = []
    skipped: list[Skipped] = []
    masks = {d.label: _outline_mask(d.outline_in_scene, shape) for d in labelling.detections}
    dense_xyz = (
        _dense_regions(
            left, right, result, _visible_parts(masks, points, labels_arr), opts.dense_max_points
        )
        if opts.dense
        else {}
    )
    for det in labelling.detections:
        name = det.label
        claimed |= _points_inside(points.left_xy, masks[name])
        kp = np.asarray(points.xyz)[labels_arr == name]
        region = dense_xyz.get(name)
        result_obj: SceneObject | Skipped
        note = None
        if region is not None and len(region) >= opts.dense_min_points:
            result_obj = make_object(name, region, up, source="dense", **obj_opts)
        else:
            if opts.dense:
                n_dense = 0 if region is None else len(region)
                note = f"dense stereo gave {n_dense} points in its outline, keypoints used"
            result_obj = make_object(name, kp, up, source="keypoints", **obj_opts)
        if isinstance(result_obj, Skipped):
            reason = result_obj.reason
            if not len(kp):
                reason = (
                    "recognised in the left image, but none of its keypoints was matched "
                    "in the right image"
                )
            skipped.append(Skipped(name, f"{reason}; {note}" if note else reason))
        else:
            if note:
                result_obj = _with_note(result_obj, note)
            objects.append(result_obj)
    if opts.unknown:
        free = ~claimed
        extra, extra_skipped = build_objects(
            np.asarray(points.xyz)[free],
            [None] * int(free.sum()),
            up,
            unknown=True,
            unknown_max_distance=opts.unknown_max_distance,
            **obj_opts,
        )
        objects.extend(extra)
        skipped.extend(extra_skipped)
    return tuple(objects), skipped


def _use_geometry(opts: PipelineOptions, result: Any) -> bool:
    """Geometry first needs the dense map on the input grid (no resampling rectification)."""
    dense = opts.dense and result.dense is not None
    return bool(opts.geometry and dense and not result.rect.needs_resampling)


def _geometry_objects(
    shape: tuple[int, int],
    result: Any,
    labelling: Any,
    opts: PipelineOptions,
    id_to_label: dict[int, str] | None,
) -> tuple[tuple[SceneObject, ...], list[Skipped]]:
    """Geometry first (``perception.scene_regions``): named segments, votes, unknown segments."""
    from scenespeak.perception.scene_regions import SceneInputs, objects_from_regions

    xy = np.asarray(result.features_left.xy, dtype=np.float64)
    up = np.asarray(result.rect.rig.up, dtype=np.float64)
    inputs = SceneInputs(shape, result.dense, result.points, labelling, xy, up, id_to_label or {})
    # the outlier radius is scaled to each object (objects.scaled_radius), not opts.radius
    kw = {"outliers": opts.outliers, "eps": opts.eps, "min_points": opts.min_points}
    objs, skipped, _geo = objects_from_regions(inputs, object_options=kw)
    return tuple(objs), skipped


def _visible_parts(
    masks: Mapping[str, NDArray[np.bool_]], points: Any, labels_arr: NDArray[np.object_]
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


def _with_note(obj: SceneObject, note: str) -> SceneObject:
    from dataclasses import replace

    return replace(obj, notes=(*obj.notes, note))


def _dense_regions(
    left: NDArray[np.generic],
    right: NDArray[np.generic],
    result: Any,
    masks: Mapping[str, NDArray[np.bool_]],
    max_points: int,
) -> dict[str, NDArray[np.float64]]:
    """3-D points of each recognised object's outline from dense stereo.

    At most ``max_points`` per object (an even random sample: enough for outlier removal and
    the hull). The stereo stage's own SGBM map (computed once per pair to verify the matches)
    is reused; without one, SGBM runs once over the bounding box of all outlines and the
    disparity range of the keypoints.
    """
    from scenespeak.perception import stereo

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
            left, right, result.rect, keypoint_disparities=result.points.disparity, roi=roi
        )
    out: dict[str, NDArray[np.float64]] = {}
    for name, m in masks.items():
        xyz, _ = stereo.region_points(dense, m, max_points=max_points)
        out[name] = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
    return out


# --------------------------------------------------------------------------------------------
# files


def describe_files(
    left_path: str | PathLike[str],
    right_path: str | PathLike[str],
    calib_path: str | PathLike[str],
    db_path: str | PathLike[str],
    *,
    calib_right: str | PathLike[str] | None = None,
    progress: Callable[[str], None] | None = None,
    **options: Any,
) -> SceneDescription:
    """:func:`describe_scene` on files: calibration, two images and a database file.

    Every problem with the inputs raises a :class:`~scenespeak.errors.ScenespeakError` that
    names the file (missing, corrupt or empty image, images of different sizes, a calibration
    with NaN or a singular matrix, a file that is not an object database, an empty database,
    a scene without texture).
    """
    from scenespeak.perception.calibration import load_rig, load_ros_rig
    from scenespeak.perception.features import load_image
    from scenespeak.perception.recognition import ObjectDatabase

    rig = load_rig(calib_path) if calib_right is None else load_ros_rig(calib_path, calib_right)
    left = load_image(left_path, gray=False)
    right = load_image(right_path, gray=False)
    sources = {
        "left": str(left_path),
        "right": str(right_path),
        "calib": str(calib_path),
        "db": str(db_path),
    }
    with ObjectDatabase.open(db_path, readonly=True) as db:
        return describe_scene(left, right, rig, db, sources=sources, progress=progress, **options)


def database_from_dataset(
    dataset: str | PathLike[str], db_path: str | PathLike[str], *, replace: bool = True
) -> list[str]:
    """Learn every object of a generated dataset into a database file (created if missing).

    Reads ``DATASET/objects/<label>/view_NN.png`` with their ``view_NN_mask.png`` (the folder
    format of ``docs/scenes.md``). Returns the labels learnt.

    Raises
    ------
    InputError
        If the dataset has no ``objects`` folder.
    """
    from scenespeak.perception.recognition import ObjectDatabase

    root = Path(dataset) / "objects"
    if not root.is_dir():
        raise InputError(root, "no training views here (expected objects/<label>/view_NN.png)")
    labels: list[str] = []
    with ObjectDatabase.open(db_path, create=True) as database:
        for folder in sorted(p for p in root.iterdir() if p.is_dir()):
            views = sorted(v for v in folder.glob("view_*.png") if not v.stem.endswith("_mask"))
            if not views:
                continue
            masks = [v.with_name(v.stem + "_mask.png") for v in views]
            use_masks: Any = masks if all(m.exists() for m in masks) else None
            if use_masks is None:
                use_masks = [_auto_mask(v) for v in views]
            database.add_object(folder.name, views, masks=use_masks, replace=replace)
            labels.append(folder.name)
    return labels


def _auto_mask(path: Path) -> Any:
    from scenespeak.perception.features import load_image
    from scenespeak.perception.segmentation import object_mask

    img = load_image(path, gray=False)
    feats = detect(to_gray(img))
    return object_mask(img, feats.xy)
