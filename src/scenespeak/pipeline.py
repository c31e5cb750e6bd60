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
stereo stage (matching, SGBM around the matches, triangulation) and geometry first's support
plane and segments while this one makes the left image's plain background and labels the left
keypoints, and then the objects and the relations on that first labelling, kept when the finer
search that follows (its boxes go to whichever thread is free) adds nothing
(:class:`scenespeak.pipeline_threads.Guess`); meanwhile this thread helps with the objects'
detections (:class:`scenespeak.pipeline_threads.Helper`; ``docs/architecture.md``; the result
is the same with one thread).

Speed (``benchmarks/bench_pipeline.py --only timing``, 640×480 pair, 5 objects): 1.14–1.34×
the two SIFT extractions one after the other, median 1.24× over nine runs (idle 2-core
AVX-512 machine, 2 Dec 2026 19:18–19:25 UTC); the target is 1.3×. Thread CPU per phase, idle
(``benchmarks/pipeline_timeline.py``): SIFT 34 + 58 ms, plain background 7, stereo 11,
labelling 8, finer search 25, plane and segments 8, objects 22, relations 6 ms.

:meth:`SceneDescription.to_dict` gives exactly the JSON of ``docs/interfaces.md`` (plus extra
fields); :meth:`SceneDescription.to_text` the sentences for people.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Collection, Mapping
from concurrent.futures import Executor, ThreadPoolExecutor
from dataclasses import dataclass, field, replace
from functools import partial
from os import PathLike
from pathlib import Path
from typing import Any, cast

import numpy as np
from numpy.typing import NDArray

from scenespeak.description import PairRelation, SceneDescription
from scenespeak.errors import DatabaseError, ImageError, InputError
from scenespeak.perception.blas import single_threaded_blas
from scenespeak.perception.features import Features, detect, to_gray
from scenespeak.perception.known_evidence import KeypointEvidence
from scenespeak.perception.objects import ObjectOptions, SceneObject
from scenespeak.perception.recognition.closer import closer_look
from scenespeak.perception.recognition.colour import ColourModel, name_unknown_objects
from scenespeak.perception.recognition.elevated import add_elevated_views, elevated_look
from scenespeak.perception.recognition.options import LabelOptions
from scenespeak.perception.recognition.results import Labelling
from scenespeak.perception.recognition.shape_guard import ShapeGuard
from scenespeak.perception.scene_objects import StrategyOptions, plain_for, scene_objects
from scenespeak.perception.scene_objects import outline_mask as _outline_mask  # noqa: F401  (pipeline_rgbd)
from scenespeak.perception.stage_options import StereoOptions
from scenespeak.pipeline_threads import (
    InlineExecutor,
    Say,
    StereoStage,
    label_and_finish,
)
from scenespeak.pipeline_threads import fill as _fill
from scenespeak.pipeline_threads import plain_promise as _plain_promise
from scenespeak.pipeline_threads import stereo_stage as _stereo_stage
from scenespeak.pipeline_threads import timed as _timed
from scenespeak.spatial.options import RelationOptions

__all__ = [
    "LabelOptions",
    "ObjectOptions",
    "PairRelation",
    "PipelineOptions",
    "RelationOptions",
    "SceneDescription",
    "StereoOptions",
    "StrategyOptions",
    "database_from_dataset",
    "dataset_labels",
    "describe_files",
    "describe_scene",
]


#: The flat keywords of :class:`PipelineOptions` (one knob each, as the CLI and the callers
#: name them) → (the stage's options field, the field there).
FLAT_OPTIONS: dict[str, tuple[str, str]] = {
    "ratio": ("stereo", "ratio"),
    "dense_crop": ("stereo", "dense_crop"),
    "dense_margin": ("stereo", "dense_margin"),
    "label_ratio": ("labels", "ratio"),
    "min_inliers": ("labels", "min_inliers"),
    "min_inliers_small": ("labels", "min_inliers_small"),
    "small_area": ("labels", "small_area"),
    "dense": ("strategy", "dense"),
    "dense_min_points": ("strategy", "dense_min_points"),
    "dense_max_points": ("strategy", "dense_max_points"),
    "geometry": ("strategy", "geometry"),
    "unknown": ("strategy", "unknown"),
    "unknown_max_distance": ("strategy", "unknown_max_distance"),
    "min_points": ("objects", "min_points"),
    "outliers": ("objects", "outliers"),
    "radius": ("objects", "radius"),
    "eps": ("objects", "eps"),
    "directions": ("relations", "directions"),
    "summary": ("relations", "summary"),
}


@dataclass(frozen=True, init=False)
class PipelineOptions:
    """Knobs of :func:`describe_scene`: each stage's own options (defaults: the CLI's).

    Attributes
    ----------
    stereo : StereoOptions
        Matching ratio and the cropped dense map (:mod:`scenespeak.perception.stage_options`).
    labels : LabelOptions
        Labelling against the database (:mod:`scenespeak.perception.recognition.options`).
    strategy : StrategyOptions
        Where objects' points come from: geometry first, dense regions, unknown clusters
        (:mod:`scenespeak.perception.scene_objects`).
    objects : ObjectOptions
        Outlier removal and hulls (:mod:`scenespeak.perception.objects`).
    relations : RelationOptions
        Histogram directions and the summary (:mod:`scenespeak.spatial.options`).
    threads : int
        Threads one scene may use: 2 runs the two SIFT extractions at the same time and the
        stereo stage beside the labelling (module docstring); 1 runs every stage one after the
        other in the calling thread, for a process that already has one scene per core (a
        cluster worker, :mod:`scenespeak.tools.engine`). The result is the same either way.

    The single knobs are also accepted and readable by their flat names
    (:data:`FLAT_OPTIONS`: ``ratio``, ``label_ratio``, ``min_inliers``, ``min_inliers_small``,
    ``small_area``, ``dense``, ``dense_min_points``, ``dense_max_points``, ``dense_crop``,
    ``dense_margin``, ``unknown``, ``unknown_max_distance``, ``min_points``, ``outliers``,
    ``radius``, ``eps``, ``directions``, ``summary``, ``geometry``), applied on top of the
    stage options given.

    Examples
    --------
    >>> opts = PipelineOptions(dense=False, threads=1)
    >>> opts.strategy.dense, opts.dense, opts.labels.ratio, opts.label_ratio
    (False, False, 0.8, 0.8)
    >>> replace(opts, label_ratio=0.7).labels.ratio
    0.7
    """

    stereo: StereoOptions
    labels: LabelOptions
    strategy: StrategyOptions
    objects: ObjectOptions
    relations: RelationOptions
    threads: int

    def __init__(
        self,
        stereo: StereoOptions | None = None,
        labels: LabelOptions | None = None,
        strategy: StrategyOptions | None = None,
        objects: ObjectOptions | None = None,
        relations: RelationOptions | None = None,
        threads: int = 2,
        **flat: object,
    ) -> None:
        stages: dict[str, object] = {
            "stereo": stereo or StereoOptions(),
            "labels": labels or LabelOptions(),
            "strategy": strategy or StrategyOptions(),
            "objects": objects or ObjectOptions(),
            "relations": relations or RelationOptions(),
        }
        unknown = sorted(set(flat) - set(FLAT_OPTIONS))
        if unknown:
            raise TypeError(
                f"PipelineOptions got unexpected keyword argument(s) {unknown}; "
                f"the knobs are {sorted(FLAT_OPTIONS)}"
            )
        changes: dict[str, dict[str, object]] = {}
        for key, value in flat.items():
            stage, name = FLAT_OPTIONS[key]
            changes.setdefault(stage, {})[name] = value
        for stage, change in changes.items():
            stages[stage] = replace(stages[stage], **change)  # type: ignore[type-var]
        for stage, value in stages.items():
            object.__setattr__(self, stage, value)
        object.__setattr__(self, "threads", threads)
        if threads not in (1, 2):
            raise InputError("threads", f"must be 1 or 2, got {threads!r}")

    def __getattr__(self, name: str) -> Any:
        # Only called for names that are not fields: the flat knobs, read from their stage.
        where = FLAT_OPTIONS.get(name)
        if where is None:
            raise AttributeError(f"PipelineOptions has no option {name!r}")
        return getattr(object.__getattribute__(self, where[0]), where[1])


# --------------------------------------------------------------------------------------------
# the chain


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
    # keypoints (the database stays here: SQLite connections belong to their thread); then it
    # runs the rest of the chain on that first labelling (pipeline_threads.Guess), kept when
    # the finer search here adds nothing to it. The rest works on small matrices (a few
    # hundred keypoints and points): OpenBLAS's second thread only costs there, and a lot when
    # the other core is busy (a 200 x 128 x 200 product took 16 ms instead of 0.1 ms on the
    # shared 2-core machine), so BLAS runs single-threaded throughout.
    say("sift")
    pool_cm = ThreadPoolExecutor(max_workers=1) if opts.threads > 1 else InlineExecutor()
    with single_threaded_blas(), pool_cm as pool:
        t0 = time.perf_counter()
        future_r = pool.submit(detect, to_gray(right), precise_upscale=False)
        feats_l = detect(to_gray(left), precise_upscale=False)
        timings["sift"] = time.perf_counter() - t0
        plain = _plain_promise(opts.threads, opts.strategy)  # the left image's, made here
        future_st = pool.submit(
            _stereo_stage,
            (left, right, rig),
            (opts.stereo, opts.strategy),
            feats_l,
            future_r,
            (lname, rname),
            timings,
            plain,
        )
        if plain is not None:
            _fill(plain, plain_for, left, left.shape[:2])
        id_to_label = {o.id: o.label for o in db.list_objects()} if opts.strategy.geometry else {}
        colours = db.colour_models() if opts.labels.colour and hasattr(db, "colour_models") else {}
        early = partial(
            _EarlyStages,
            (left, right),
            feats_l,
            id_to_label=id_to_label,
            colours=colours,
            look=_closer_labeller(db, opts.labels, bool(id_to_label)),
            elevated=elevated_look(db, opts.labels, bool(id_to_label)),
        )

        def rest(
            labelling: Labelling, share: Executor | None, times: dict[str, float], tell: Say
        ) -> SceneDescription:
            stage = early(stereo=future_st.result(), labelling=labelling)
            return _after_stereo(stage, opts, src, times, tell, share)

        return label_and_finish(db, (feats_l, left), opts, pool, rest, future_st, timings, say)


def _closer_labeller(
    db: Any, labels: LabelOptions, geometry: bool
) -> Callable[[Features], Labelling] | None:
    """The closer look's labeller (``recognition.closer``; None when off), loaded here: it
    reads no SQLite in the thread that runs it."""
    if not (labels.closer and geometry and hasattr(db, "labeller")):
        return None
    return cast(Callable[[Features], Labelling], db.labeller(labels))


@dataclass(frozen=True, eq=False)
class _EarlyStages:
    """Stages 1-2 of :func:`describe_scene`: the pair, the left features, stereo and labels."""

    images: tuple[NDArray[np.generic], NDArray[np.generic]]
    features_left: Features
    stereo: StereoStage
    labelling: Labelling
    id_to_label: Mapping[int, str]
    colours: Mapping[str, ColourModel] = field(default_factory=dict)
    look: Callable[[Features], Labelling] | None = None
    elevated: Any = None


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
    early: _EarlyStages,
    opts: PipelineOptions,
    src: dict[str, str],
    timings: dict[str, float],
    say: Callable[[str], None],
    share: Executor | None = None,
) -> SceneDescription:
    """Stages 3-5 of :func:`describe_scene` once the labels and the stereo points are known
    (``share``: an executor to share the objects' work with)."""
    result = early.stereo.result
    rig = result.rect.rig
    points = result.points
    if len(points.xyz) == 0:
        raise _no_matches_error(
            src, rig, len(early.features_left), len(early.stereo.features_right)
        )
    kp_names = early.labelling.names()
    point_labels = tuple(kp_names[int(i)] for i in points.left_index)

    say("objects")
    with _timed(timings, "objects"):
        objects, skipped = scene_objects(
            early.images,
            result,
            early.labelling,
            early.id_to_label,
            opts.strategy,
            opts.objects,
            early.stereo.geometry,
            share,
        )
        if (early.colours or early.look) and not result.rect.needs_resampling:
            # unknown objects named by a closer look at their region (recognition.closer), then
            # by colour and shape (recognition.colour); the points project into the left image
            # as given only when it was not resampled
            left, matched = early.images[0], early.labelling.votes()
            evidence = KeypointEvidence.of_labelling(
                rig.K_left, left.shape, early.features_left.xy, matched, early.id_to_label
            )
            veto = None if evidence is None else evidence.refuses
            geo, shape = early.stereo.geometry, None
            if geo is not None:  # names by colour or grey must fit the segment's shape
                shape = ShapeGuard(geo.normal, geo.level)
            if early.look is not None:
                above = early.elevated(shape) if early.elevated and shape else None
                objects = closer_look(
                    objects, left, rig.K_left, early.look, veto=veto, elevated=above
                )
            trim = (np.asarray(rig.up, np.float64), replace(opts.objects, radius=None))
            objects = name_unknown_objects(  # the keypoints veto or corroborate a cue's name
                objects, left, rig.K_left, early.colours, remake=trim, veto=evidence, shape=shape
            )

    say("relations")
    with _timed(timings, "relations"):
        relations = _relate_all(objects, opts.relations.directions)
        summary = ""
        if opts.relations.summary and relations:
            from scenespeak.spatial.language import summarize_scene

            summary = summarize_scene(
                [r.relation for r in relations],
                centroids={o.key: o.plane_centroid for o in objects},
            )

    return SceneDescription(
        left=early.images[0],
        right=early.images[1],
        rig=rig,
        features_left=early.features_left,
        features_right=early.stereo.features_right,
        points=points,
        stereo=result,
        point_labels=point_labels,
        labelling=early.labelling,
        objects=objects,
        skipped=tuple(skipped),
        relations=tuple(relations),
        summary=summary,
        timings=timings,
        sources=src,
    )


#: The keyframes' options of a stream (``keyframe_describer``): the CLI's, without unknown
#: objects (clusters of unlabelled points are not stable enough to keep an id) or a summary.
KEYFRAME_OPTIONS = PipelineOptions(unknown=False, summary=False)


def keyframe_describer(
    rig: Any, db: Any, options: PipelineOptions | None = None
) -> Callable[[NDArray[np.generic], NDArray[np.generic]], SceneDescription]:
    """``describe(left, right)``: :func:`describe_scene` with this rig, database and options.

    What :class:`scenespeak.perception.tracking.ObjectTracker` runs on its keyframes (the
    stream composes the pipeline and the tracker, so perception never imports the pipeline).
    ``options`` defaults to :data:`KEYFRAME_OPTIONS`.
    """
    opts = options or KEYFRAME_OPTIONS

    def describe(left: NDArray[np.generic], right: NDArray[np.generic]) -> SceneDescription:
        return describe_scene(left, right, rig, db, options=opts)

    return describe


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


def _training_views(folder: Path) -> list[Path]:
    return sorted(v for v in folder.glob("view_*.png") if not v.stem.endswith("_mask"))


def _object_folders(dataset: str | PathLike[str]) -> list[Path]:
    root = Path(dataset) / "objects"
    if not root.is_dir():
        raise InputError(root, "no training views here (expected objects/<label>/view_NN.png)")
    return sorted(p for p in root.iterdir() if p.is_dir() and _training_views(p))


def dataset_labels(dataset: str | PathLike[str]) -> list[str]:
    """The labels a generated dataset has training views of (``objects/<label>/``), sorted.

    Raises
    ------
    InputError
        If the dataset has no ``objects`` folder.
    """
    return [p.name for p in _object_folders(dataset)]


def database_from_dataset(
    dataset: str | PathLike[str],
    db_path: str | PathLike[str],
    *,
    replace: bool = True,
    labels: Collection[str] | None = None,
) -> list[str]:
    """Learn every object of a generated dataset into a database file (created if missing).

    Reads ``DATASET/objects/<label>/view_NN.png`` with their ``view_NN_mask.png`` (the folder
    format of ``docs/scenes.md``); ``labels``: learn only these (leave-part-out evaluation).
    Returns the labels learnt.

    Raises
    ------
    InputError
        If the dataset has no ``objects`` folder.
    """
    from scenespeak.perception.recognition import ObjectDatabase
    from scenespeak.perception.segmentation import training_mask

    learnt: list[str] = []
    folders = _object_folders(dataset)
    with ObjectDatabase.open(db_path, create=True) as database:
        for folder in folders:
            if labels is not None and folder.name not in labels:
                continue
            views = _training_views(folder)
            masks = [v.with_name(v.stem + "_mask.png") for v in views]
            use_masks: Any = masks if all(m.exists() for m in masks) else None
            if use_masks is None:
                use_masks = [training_mask(v) for v in views]
            database.add_object(folder.name, views, masks=use_masks, replace=replace)
            add_elevated_views(database, folder.name, views, use_masks)
            learnt.append(folder.name)
    return learnt
