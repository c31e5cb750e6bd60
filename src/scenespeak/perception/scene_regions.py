"""Stage: named segments → objects (geometry first, appearance names).

:mod:`scenespeak.perception.regions` finds what stands on the support; this stage gives each
recognised detection its segment (the one holding most of its inlier keypoints), keeps only the
pixels whose depth agrees with the object's own keypoints (an occluder never lends its depth),
removes outliers with a radius scaled to the object, and turns the segments no detection
claims into unknown objects. A detection whose keypoints fall in no segment keeps its carried
outline (minus the support and the far background) at its keypoints' stereo depth, and with no
dense points at all its keypoints. A detection with no keypoint depth is placed only by a segment
of its own; otherwise it is not placed (a :class:`Skipped` saying why), never at the depth of
what stands in front of it.

>>> RegionStageOptions().depth_margin
0.1
"""

from __future__ import annotations

import dataclasses
import math
from concurrent.futures import Executor
from dataclasses import dataclass, field
from functools import partial
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

from scenespeak.geometry.frames import plane_basis
from scenespeak.geometry.polygons import polygon_area, polygon_centroid
from scenespeak.perception.objects import SceneObject, Skipped, make_object
from scenespeak.perception.regions import (
    RegionOptions,
    SceneGeometry,
    Segments,
    components,
    name_segments,
    scene_geometry,
)
from scenespeak.perception.scene_instances import SplitOptions, merge_split_instances, size_misfits
from scenespeak.perception.scene_unknown import (
    even_sample,
    name_instances,
    near_same_label,
    unknown_segments,
    vote_segments,
)
from scenespeak.perception.sharing import run_shared

__all__ = [
    "RegionStageOptions",
    "SceneGeometry",
    "SceneInputs",
    "detection_confidence",
    "objects_from_regions",
    "volume_centre",
    "vote_segments",
]


@dataclass(frozen=True)
class RegionStageOptions:
    """Knobs of :func:`objects_from_regions`.

    Attributes
    ----------
    regions : RegionOptions
        The geometric segmentation.
    outline_grow : float
        The carried outline is grown by this share of its size before it is intersected with
        the segment (a homography fits a cylinder's label only roughly).
    depth_margin : float
        Points are kept within ``depth_margin`` (metres) plus the object's own depth spread of
        the median depth of its keypoints.
    min_region_pixels : int
        A named segment smaller than this is not trusted (the carried outline is used).
    max_points : int
        Dense points per object (an even, seeded sample).
    min_points : int
        Fewer dense points than this: the keypoints are used.
    unknown : bool
        Unclaimed segments become unknown objects.
    unknown_min_pixels, unknown_min_keypoints : int
        Least size of such a segment, and least SIFT keypoints in it (the dense map streaks
        over a plain floor; a real object shows some texture).
    unknown_min_keypoints_plain, unknown_min_textured : int, float
        The least keypoints instead when the plain background was taken out of the segments
        (:attr:`SceneGeometry.plain`): its streaks are gone, and a far dark face (the night
        sky of a cereal box 1.8 m away on tuning-40) shows 1-3 keypoints; a segment must then
        have at least ``unknown_min_textured`` of its pixels textured (the far cereal box and
        the other textured objects: 1.0; a plain red block, whose face is plain inside its
        edges: 0.44-0.48 — a piece of it with 5 keypoints, 0.62, was named 'tea' by colour on
        leave-half-out stress60).
    unknown_max_extent, unknown_max_distance : float
        Larger or farther segments are background, not objects (metres).
    min_votes, min_votes_instance, vote_share, vote_lead : int, int, float, float
        Naming an unclaimed segment by keypoint votes (:func:`vote_segments`): ``min_votes``
        for an object not verified anywhere in the scene, ``min_votes_instance`` for another
        instance of one that was (on the tuning set 3-6 chance votes for one object landed on
        a plain distractor and on the sky, so an unverified object needs many). Both 8 (the
        instance's was 4): another instance needs evidence of its own as strong as a first
        one needs — a detection elsewhere in the scene says the label is there, not that this
        segment is it (a never-learnt object beside a verified one collects chance votes for
        it as readily as anywhere).
    lone_share, lone_gap : float
        A detection with no keypoint depth and no segment holding its keypoints is placed by
        the one unclaimed segment with at least ``lone_share`` of its pixels inside its
        outline, when its keypoints lie within ``lone_gap`` pixels of it (median); otherwise
        it is not placed (never at the depth of what stands in front of it).
    vote_agree : float
        0.8 — ... and at least this share of the winner's matched keypoints agree in scale
        and orientation (:func:`~scenespeak.perception.scene_unknown.agreeing_votes`).
    split : SplitOptions
        Two detections of one label closer in 3-D than one object's size are one object
        (:func:`~scenespeak.perception.scene_instances.merge_split_instances`).
    """

    regions: RegionOptions = field(default_factory=RegionOptions)
    outline_grow: float = 0.15
    depth_margin: float = 0.1
    min_region_pixels: int = 30
    max_points: int = 300
    min_points: int = 30
    unknown: bool = True
    unknown_min_pixels: int = 400
    unknown_min_keypoints: int = 4
    unknown_min_keypoints_plain: int = 1
    unknown_min_textured: float = 0.8
    unknown_max_extent: float = 0.6
    unknown_max_distance: float = 2.5
    min_votes: int = 8
    min_votes_instance: int = 8
    vote_share: float = 0.6
    vote_lead: float = 2.0
    lone_share: float = 0.5
    lone_gap: float = 12.0
    vote_agree: float = 0.8
    split: SplitOptions = field(default_factory=SplitOptions)


def detection_confidence(inliers: int, distinct: int | None = None) -> float:
    """A confidence in [0, 1] from a detection's verified inliers: ``1 − exp(−n / 6)`` over the
    inliers at distinct positions (4 → 0.49, 8 → 0.74, 20 → 0.96).

    >>> round(detection_confidence(8), 2)
    0.74
    """
    n = inliers if distinct is None else distinct
    return float(1.0 - math.exp(-max(n, 0) / 6.0))


def _outline_mask(outline: NDArray[np.float64], shape: tuple[int, int], grow: float) -> Any:
    mask = np.zeros(shape, dtype=np.uint8)
    pts = np.asarray(outline, dtype=np.float64)
    if len(pts) < 3:
        return mask.astype(bool)
    cv2.fillPoly(mask, [np.round(pts * 16).astype(np.int32).reshape(-1, 1, 2)], 1, cv2.LINE_8, 4)
    if grow > 0:
        x0, y0 = pts.min(axis=0)
        x1, y1 = pts.max(axis=0)
        r = round(grow * max(x1 - x0, y1 - y0, 1.0))
        if r > 0:
            disc = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * r + 1, 2 * r + 1))
            # Only the filled pixels' box grown by r can change, and outside it every pixel
            # is 0 as the image border is to a dilation: the same mask as dilating it whole.
            bx, by, bw, bh = cv2.boundingRect(mask)
            if bw > 0 and bh > 0:
                y0, y1 = max(by - r, 0), min(by + bh + r, shape[0])
                c0, c1 = max(bx - r, 0), min(bx + bw + r, shape[1])
                mask[y0:y1, c0:c1] = cv2.dilate(np.ascontiguousarray(mask[y0:y1, c0:c1]), disc)
    return mask.astype(bool)


def _agreeing(
    pts: NDArray[np.float64], kp: NDArray[np.float64], margin: float
) -> NDArray[np.float64]:
    """Points whose depth agrees with the object's own keypoints (median ± spread + margin).

    One keypoint is a depth too (spread 0: its depth ± ``margin``); with none every point is
    kept, so the caller must hold other evidence that the region is the object's (a segment
    of its own, :func:`_own_region`).

    >>> pts = np.array([[0.0, 0, 0.8], [0, 0, 1.85], [0, 0, 1.9]])
    >>> _agreeing(pts, np.array([[0.0, 0, 1.88]]), 0.1)[:, 2].tolist()
    [1.85, 1.9]
    """
    if not len(kp) or not len(pts):
        return pts
    return pts[_agrees(pts[:, 2], kp, margin)]


def _agrees(z: NDArray[np.floating], kp: NDArray[np.float64], margin: float) -> NDArray[np.bool_]:
    """Which depths ``z`` agree with the keypoints ``kp`` (median ± 90th-percentile spread +
    ``margin``; NaN never agrees). ``kp`` must hold at least one point."""
    zk = kp[:, 2]
    med = float(np.median(zk))
    spread = float(np.percentile(np.abs(zk - med), 90)) if len(zk) > 1 else 0.0
    with np.errstate(invalid="ignore"):
        return np.asarray(np.abs(np.asarray(z) - med) <= spread + margin)


def _region_for(work: _Work, det_idx: int) -> NDArray[np.bool_] | None:
    """The pixels of detection ``det_idx``: its segment within its grown outline.

    A segment several detections share (the dense map joins a mug to the shoebox behind it)
    is split where their outlines overlap: when both have keypoints with a stereo depth, each
    pixel goes to the one whose keypoints' median depth is nearer to its own (the mug in front
    keeps its pixels, the shoebox its own), otherwise to the better detection (detections come
    best first)."""
    k = work.seg_of[det_idx]
    geo = work.geo
    if k < 0 or geo is None:
        return None
    region = geo.segments.mask(k) & work.outlines[det_idx]
    z = geo.points[..., 2]
    depths = work.depths
    mine = depths[det_idx]
    for other in work.owners.get(k, []):
        if other == det_idx:
            continue
        theirs = depths[other]
        overlap = region & work.outlines[other]
        if math.isfinite(mine) and math.isfinite(theirs):
            with np.errstate(invalid="ignore"):
                nearer = np.abs(z - theirs) < np.abs(z - mine)
            region &= ~(overlap & nearer)
        elif other < det_idx:
            region &= ~overlap
    if int(region.sum()) < work.opts.min_region_pixels:
        return None
    return region


@dataclass(frozen=True, eq=False)
class SceneInputs:
    """What :func:`objects_from_regions` reads from the earlier stages.

    Attributes
    ----------
    shape : (h, w)
        The left image's size.
    dense : DenseDisparity or None
        The stereo stage's dense map (None: keypoints only).
    points : Points3D
        The triangulated stereo keypoints.
    labelling : Labelling
        The database's detections, keypoint labels and ratio-test matches.
    keypoints_xy : (N, 2)
        Positions of the left image's keypoints (the labelling's query).
    up : (3,)
        World up in the left camera frame.
    id_to_label : dict
        Database object id -> label (for the keypoint votes of :func:`vote_segments`; empty:
        no votes).
    geometry : SceneGeometry or None
        The scene's geometry when already computed, by :func:`scene_geometry` of ``dense``,
        ``up``, ``shape`` and the options' ``regions`` (it needs no labels: the pipeline
        computes it in its stereo thread while the labelling runs); None: computed here.
    """

    shape: tuple[int, int]
    dense: Any
    points: Any
    labelling: Any
    keypoints_xy: NDArray[np.float64]
    up: NDArray[np.float64]
    id_to_label: dict[int, str] = field(default_factory=dict)
    geometry: SceneGeometry | None = None


@dataclass
class _Work:
    """The state shared by the steps of :func:`objects_from_regions`."""

    inp: SceneInputs
    opts: RegionStageOptions
    kw: dict[str, Any]
    geo: SceneGeometry | None
    outlines: list[NDArray[np.bool_]]
    seg_of: list[int]
    owners: dict[int, list[int]]
    own: list[NDArray[np.float64]]
    taken: list[NDArray[np.bool_]] = field(default_factory=list)

    @property
    def depths(self) -> list[float]:
        """Median depth (Z) of each detection's own keypoints with a stereo depth (NaN: none)."""
        return [float(np.median(p[:, 2])) if len(p) else math.nan for p in self.own]


def objects_from_regions(
    inputs: SceneInputs,
    options: RegionStageOptions | None = None,
    object_options: dict[str, Any] | None = None,
    executor: Executor | None = None,
) -> tuple[list[SceneObject], list[Skipped], SceneGeometry | None]:
    """Objects of a scene: named segments, segments named by votes, then unknown segments.

    Parameters
    ----------
    inputs : SceneInputs
    options : RegionStageOptions, optional
    object_options : dict, optional
        Passed to :func:`~scenespeak.perception.objects.make_object` (``outliers``, ``eps``,
        ``min_points``; ``radius`` defaults to the object-scaled radius).
    executor : Executor, optional
        Shares the detections' outlines and objects with one task of it
        (:func:`~scenespeak.perception.sharing.run_shared`: the same result without it).

    Returns
    -------
    objects, skipped, geometry
    """
    opts = options or RegionStageOptions()
    inp = dataclasses.replace(inputs, up=np.asarray(inputs.up, dtype=np.float64))
    dets = list(inp.labelling.detections)
    geo = inp.geometry
    if geo is None and inp.dense is not None:
        geo = scene_geometry(inp.dense, inp.up, inp.shape, opts.regions)
    seg_of = (
        name_segments(
            geo.segments, [inp.keypoints_xy[np.asarray(d.inliers, np.intp)] for d in dets]
        )
        if geo is not None
        else [-1] * len(dets)
    )
    owners: dict[int, list[int]] = {}
    for i, k in enumerate(seg_of):
        owners.setdefault(k, []).append(i)
    xyz = np.asarray(inp.points.xyz, dtype=np.float64)
    left_index = np.asarray(inp.points.left_index, dtype=np.intp)
    own = [xyz[np.isin(left_index, np.asarray(d.inliers, np.intp))] for d in dets]
    grow = opts.outline_grow
    outlines = [partial(_outline_mask, d.outline_in_scene, inp.shape, grow) for d in dets]
    kw = {"radius": None, **(object_options or {})}
    work = _Work(inp, opts, kw, geo, run_shared(outlines, executor), seg_of, owners, own)
    objects, skipped = _detected_objects(work, dets, executor)
    if geo is None:
        return objects, skipped, geo
    residual = _residual(geo, work.taken, opts)
    claimed = _voted_objects(work, residual, objects)
    name_instances(objects)
    if opts.unknown:
        objects += unknown_segments(
            geo.points, residual, inp.keypoints_xy, claimed, inp.up, opts, work.kw, geo.textured
        )
    return [volume_centre(o, inp.up) for o in objects], skipped, geo


def _detected_objects(
    work: _Work, dets: list[Any], executor: Executor | None = None
) -> tuple[list[SceneObject], list[Skipped]]:
    """The detections' objects and those not placed; with the geometry, instances checked
    and joined in metres (:mod:`~scenespeak.perception.scene_instances`). Each detection's
    object depends on its own inputs only (shared with ``executor``, taken in order after)."""
    placed: list[tuple[SceneObject, NDArray[np.float64], int]] = []
    skipped: list[Skipped] = []
    made = run_shared(
        [partial(_known_object, work, i, det) for i, det in enumerate(dets)], executor
    )
    for i, (det, (got, taken)) in enumerate(zip(dets, made, strict=True)):
        if taken is not None:
            work.taken.append(taken)
        if isinstance(got, SceneObject):
            placed.append((got, np.asarray(det.outline_in_scene, np.float64), work.seg_of[i]))
        else:
            skipped.append(got)
    if work.geo is None:
        return [obj for obj, _, _ in placed], skipped
    focal = float(np.asarray(work.inp.dense.rect.rig.K_left)[0, 0])
    misfits = size_misfits(placed, focal, work.opts.split)
    skipped += [Skipped(placed[j][0].key, why) for j, why in misfits.items()]
    placed = [p for j, p in enumerate(placed) if j not in misfits]
    return merge_split_instances(placed, work.inp.up, focal, work.kw, work.opts.split), skipped


def volume_centre(obj: SceneObject, up: NDArray[np.float64]) -> SceneObject:
    """``obj`` with its centroid moved to an estimate of the centre of its volume.

    A region's points lie on the faces the camera sees, so their mean sits in front of the
    volume's centre by up to half the object's depth (9-11 cm for a 19 cm deep shoebox seen
    from the front: all of the dev set's centroid errors above 8 cm). The convex hull of the
    points on the plane spans what is seen of the footprint (the top face of a box lower than
    the camera, the front half of a cylinder), so the centroid becomes the hull's area
    centroid on the plane, at the points' mean height. Objects placed from dense or segment
    pixels only; keypoint objects and degenerate hulls keep the mean of their points.

    Examples
    --------
    >>> import numpy as np
    >>> from scenespeak.perception.objects import make_object
    >>> rng = np.random.default_rng(0)
    >>> front = np.c_[rng.uniform(-0.1, 0.1, 200), rng.uniform(0.0, 0.1, 200), np.full(200, 1.0)]
    >>> top = np.c_[rng.uniform(-0.1, 0.1, 20), np.zeros(20), rng.uniform(1.0, 1.2, 20)]
    >>> up = np.array([0.0, -1.0, 0.0])
    >>> obj = make_object("box", np.r_[front, top], up, source="dense", outliers="none")
    >>> round(float(obj.centroid[2]), 2), round(float(volume_centre(obj, up).centroid[2]), 2)
    (1.01, 1.08)
    """
    if obj.source not in ("dense", "segment") or len(obj.hull) < 3 or obj.n_points < 3:
        return obj
    if float(abs(polygon_area(obj.hull))) < 1e-6:  # a sliver: no footprint to speak of
        return obj
    basis = plane_basis(up)
    cx, cy = polygon_centroid(obj.hull)
    centre = cx * basis[0] + cy * basis[1] + float(np.mean(obj.heights)) * basis[2]
    return dataclasses.replace(obj, centroid=centre)


def _known_object(
    work: _Work, i: int, det: Any
) -> tuple[SceneObject | Skipped, NDArray[np.bool_] | None]:
    """One detection: its segment (or outline) points agreeing with its keypoints' depth; and
    the pixels it takes from the unknown objects (:func:`_taken`; None without geometry)."""
    inp, opts, geo = work.inp, work.opts, work.geo
    name = getattr(det, "name", "") or det.label
    own_kp = work.own[i]
    dense_pts = np.zeros((0, 3))
    region_note = taken = None
    if geo is not None:
        placed, taken = _own_region(work, i)
        if isinstance(placed, str):
            return Skipped(name, placed), taken
        region, region_note = placed
        dense_pts = geo.points[region].astype(np.float64)
        dense_pts = dense_pts[np.all(np.isfinite(dense_pts), axis=1)]
        dense_pts = even_sample(_agreeing(dense_pts, own_kp, opts.depth_margin), opts.max_points)
    note = None
    if len(dense_pts) >= opts.min_points:
        result = make_object(det.label, dense_pts, inp.up, source="dense", **work.kw)
    else:
        note = f"dense stereo gave {len(dense_pts)} points in its region, keypoints used"
        result = make_object(det.label, own_kp, inp.up, source="keypoints", **work.kw)
        region_note = None
    if isinstance(result, Skipped):
        reason = result.reason
        if not len(own_kp):
            reason = (
                "recognised in the left image, but none of its keypoints was matched "
                "in the right image"
            )
        return Skipped(name, f"{reason}; {note}" if note else reason), taken
    notes = (*result.notes, note) if note else result.notes
    if region_note:
        notes = (*notes, region_note)
    conf = detection_confidence(int(det.score))
    return dataclasses.replace(result, name=name, confidence=conf, notes=tuple(notes)), taken


def _own_region(
    work: _Work, i: int
) -> tuple[tuple[NDArray[np.bool_], str | None] | str, NDArray[np.bool_]]:
    """The pixels that place detection ``i`` and a note on where they came from, or why it is
    not placed; and what it takes from the unknown objects (:func:`_taken`).

    The depth of a region must come from the object itself: its keypoints with a stereo depth
    (:func:`_agreeing` keeps the region's points at their depth), or, without any, a segment
    of its own — the one holding its keypoints when no other detection shares it, or the one
    segment no other detection claims that lies mostly inside its outline, next to its
    keypoints (:func:`_lone_segment`). Without either, the carried outline or a shared segment
    holds whatever stands in front of the object: on the generated default set three far
    objects (1.9 m) seen with 3-5 keypoints and no stereo depth were placed at the depth of
    the book or tin in front of them, 0.4-1.2 m too near. Such an object is not placed rather
    than placed on its occluder.
    """
    geo = work.geo
    assert geo is not None
    det = work.inp.labelling.detections[i]
    above = geo.segments.labels >= 0
    region = _region_for(work, i)
    taken = _taken(work, i, region, above)
    has_depth = len(work.own[i]) > 0
    if region is not None and (has_depth or len(work.owners.get(work.seg_of[i], [])) == 1):
        return (region, None), taken
    why = "their segment holds other objects"
    if region is None:
        outline = _outline_mask(det.outline_in_scene, work.inp.shape, 0.0) & above
        if has_depth:
            return (outline, "no segment held its keypoints: points from its outline"), taken
        lone = _lone_segment(work, i, outline)
        if lone is not None:
            note = "no keypoint depth: placed by the one unclaimed segment in its outline"
            return (lone, note), taken
        why = "no segment of its own holds them"
    return (
        f"recognised in the left image ({len(det.inliers)} keypoints), but none of its keypoints "
        f"has a stereo depth and {why}: not placed, so that what stands in front of it does "
        "not lend it its depth"
    ), taken


def _taken(
    work: _Work, i: int, region: NDArray[np.bool_] | None, above: NDArray[np.bool_]
) -> NDArray[np.bool_]:
    """The segment pixels detection ``i`` takes from the unknown objects: its region and its
    grown outline's segment pixels — of those, with keypoint depths, only the ones at its
    depth (:func:`_agrees`). Its grown outline reaches over the objects beside and behind it
    (on tuning-40 a crate's took the cube behind it and the colour wheel beside it, so
    neither was reported at all); what stands at another depth is not the object's."""
    taken = work.outlines[i] & above
    kp = work.own[i]
    if len(kp) and work.geo is not None:
        taken &= _agrees(work.geo.points[..., 2], kp, work.opts.depth_margin)
    return taken if region is None else taken | region


def _lone_segment(work: _Work, i: int, outline: NDArray[np.bool_]) -> NDArray[np.bool_] | None:
    """The one segment that can be detection ``i``'s visible part, or None.

    Candidates are the segments inside its (ungrown) carried outline that no other detection
    claims, that have at least ``lone_share`` of their pixels inside it (an unrecognised
    object in front of it reaches out of the outline) and that its keypoints lie next to
    (median distance at most ``lone_gap`` pixels); there must be exactly one. A sliver away
    from the keypoints is no candidate: on the default set a 72-pixel piece of floor edge 22
    pixels from a far shoebox's keypoints left it with two and unplaced."""
    geo, opts = work.geo, work.opts
    assert geo is not None
    labels = geo.segments.labels
    inside = labels[outline]
    ks, counts = np.unique(inside[inside >= 0], return_counts=True)
    claimed = {k for k, v in work.owners.items() if any(j != i for j in v)}
    xy = work.inp.keypoints_xy[np.asarray(work.inp.labelling.detections[i].inliers, np.intp)]
    if not len(xy):
        return None
    h, w = labels.shape
    c = np.clip(np.rint(xy[:, 0]).astype(np.intp), 0, w - 1)
    r = np.clip(np.rint(xy[:, 1]).astype(np.intp), 0, h - 1)
    cands = []
    for k, n in zip(ks.tolist(), counts.tolist(), strict=True):
        if k in claimed or n < opts.lone_share * int(geo.segments.sizes[k]):
            continue
        dist = cv2.distanceTransform((labels != k).astype(np.uint8), cv2.DIST_L2, 3)
        if float(np.median(dist[r, c])) <= opts.lone_gap:
            cands.append(int(k))
    if len(cands) != 1:
        return None
    region = (labels == cands[0]) & outline
    if int(region.sum()) < opts.min_region_pixels:
        return None
    return region


def _residual(
    geo: SceneGeometry, taken: list[NDArray[np.bool_]], opts: RegionStageOptions
) -> Segments:
    """What the detections did not take — the rest of their segments and the other segments —
    split again into components (two objects merged by the dense map come apart here), minus
    the slivers along the taken regions' borders."""
    rest = geo.segments.labels >= 0
    grow = np.ones((9, 9), np.uint8)
    for region in taken:
        rest &= cv2.dilate(region.astype(np.uint8), grow) == 0
    opened = cv2.morphologyEx(rest.astype(np.uint8), cv2.MORPH_OPEN, np.ones((5, 5), np.uint8))
    return components(opened > 0, geo.level, opts.regions.min_pixels)


def _voted_objects(work: _Work, residual: Segments, objects: list[SceneObject]) -> set[int]:
    """Residual segments named by keypoint votes, appended to ``objects``; their indices."""
    inp, opts, geo = work.inp, work.opts, work.geo
    claimed: set[int] = set()
    if geo is None or not inp.id_to_label:
        return claimed
    verified = frozenset(d.label for d in inp.labelling.detections)
    lab = inp.labelling
    voted = vote_segments(
        residual,
        inp.keypoints_xy,
        lab.matched,
        inp.id_to_label,
        claimed,
        opts,
        verified,
        (lab.match_scale, lab.match_turn),
    )
    for k, label, n_votes, agree in voted:
        pts = geo.points[residual.mask(k)].astype(np.float64)
        pts = even_sample(pts[np.all(np.isfinite(pts), axis=1)], opts.max_points)
        result = make_object(label, pts, inp.up, source="segment", **work.kw)
        if isinstance(result, SceneObject) and not near_same_label(result, objects):
            claimed.add(k)
            note = f"named by {n_votes} keypoint votes (no geometric check passed)"
            if agree >= 0:
                note = (
                    f"named by {n_votes} keypoint votes, {agree} agreeing in scale and "
                    "orientation (no geometric check passed)"
                )
            objects.append(
                dataclasses.replace(
                    result,
                    name=label,
                    confidence=0.7 * detection_confidence(n_votes),
                    notes=(*result.notes, note),
                )
            )
    return claimed
