"""The segments no detection took: named by keypoint votes, or unknown objects.

Part of the region stage (:func:`scenespeak.perception.scene_regions.objects_from_regions`):
after the detections have taken their regions, each remaining segment is named after the object
most of its ratio-test matches voted for (:func:`vote_segments`), or becomes an unknown object
when it is object-sized and textured (:func:`unknown_segments`).
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from scenespeak.perception.objects import SceneObject, make_object
from scenespeak.perception.regions import Segments

if TYPE_CHECKING:
    from scenespeak.perception.scene_regions import RegionStageOptions

__all__ = [
    "agreeing_votes",
    "even_sample",
    "name_instances",
    "near_same_label",
    "unknown_segments",
    "vote_segments",
]

#: Votes agree (:func:`agreeing_votes`) within this many octaves of scale ratio either side ...
AGREE_OCTAVES = 0.5
#: ... and this many degrees of orientation difference either side.
AGREE_DEGREES = 20.0


def even_sample(pts: NDArray[np.float64], n: int, seed: int = 0) -> NDArray[np.float64]:
    """At most ``n`` of the points, a seeded sample in their order."""
    if len(pts) <= n:
        return pts
    rng = np.random.default_rng(seed)
    return pts[np.sort(rng.choice(len(pts), size=n, replace=False))]


def near_same_label(obj: SceneObject, objects: list[SceneObject], gap: float = 0.12) -> bool:
    """Whether an object of the same label stands within ``gap`` metres (on the plane) of
    ``obj``'s points: then ``obj`` is a piece of it, not a second instance."""
    for o in objects:
        if o.label != obj.label:
            continue
        d = np.linalg.norm(obj.plane_xy[:, None, :] - o.plane_xy[None, ::4, :], axis=2)
        if float(d.min()) < gap:
            return True
    return False


def name_instances(objects: list[SceneObject]) -> None:
    """Several objects of one label get distinct names: the label, "label 2", ..."""
    seen: dict[str, int] = {}
    for i, o in enumerate(objects):
        seen[o.label] = seen.get(o.label, 0) + 1
        if seen[o.label] > 1:
            objects[i] = dataclasses.replace(o, name=f"{o.label} {seen[o.label]}")


def agreeing_votes(scale: NDArray[np.floating], turn: NDArray[np.floating]) -> int:
    """The most votes that agree in scale ratio and orientation difference with one of them.

    A vote is a keypoint matched to an object's training keypoint: its SIFT scale over the
    training keypoint's, and its orientation minus that one's. For one object seen once, its
    true matches share both (the object is seen at one scale and turn: Lowe 2004, sec. 7, the
    Hough transform's scale and orientation bins); chance matches of a texture that only looks
    alike (bricks voting for a photo of a lattice tower) scatter. Counted in a window of
    ±:data:`AGREE_OCTAVES` octaves and ±:data:`AGREE_DEGREES`° round each vote.

    >>> agreeing_votes(np.array([1.0, 1.1, 0.9, 4.0]), np.array([10.0, 15.0, 355.0, 10.0]))
    3
    """
    ls = np.log2(np.asarray(scale, np.float64))
    tn = np.asarray(turn, np.float64)
    ok = np.isfinite(ls) & np.isfinite(tn)
    ls, tn = ls[ok], tn[ok]
    if not len(ls):
        return 0
    near_scale = np.abs(ls[:, None] - ls[None, :]) <= AGREE_OCTAVES
    dt = np.abs(tn[:, None] - tn[None, :]) % 360.0
    near_turn = np.minimum(dt, 360.0 - dt) <= AGREE_DEGREES
    return int((near_scale & near_turn).sum(axis=1).max())


def vote_segments(
    segments: Segments,
    keypoints_xy: NDArray[np.float64],
    matched: NDArray[np.integer],
    id_to_label: dict[int, str],
    claimed: set[int],
    opts: RegionStageOptions,
    verified: frozenset[str] = frozenset(),
    match_geometry: tuple[NDArray[np.float32], NDArray[np.float32]] | None = None,
) -> list[tuple[int, str, int, int]]:
    """Unclaimed segments named by the ratio-test votes of the keypoints inside them.

    A segment is named after the object most of its keypoints matched (before any geometric
    check) when that object has at least ``min_votes`` votes at distinct positions, at least
    ``vote_share`` of the segment's matched keypoints, and at least ``vote_lead`` times the
    runner-up's votes. Chance matches of a never-learnt object spread over many objects (at
    most 2 votes for one object on the tuning set's distractors), a recognised-but-unverified
    object concentrates them. With ``match_geometry`` (the labelling's ``match_scale`` and
    ``match_turn``), at least ``vote_agree`` of the winner's votes must also agree in scale and
    orientation (:func:`agreeing_votes`). Returns ``(segment, label, votes, agreeing)``.

    The share was measured by leaving half the tuning objects out of the database, so that
    their scenes' objects become distractors (``docs/evaluation.md``): 12 of 13 false known
    objects were distractors named by 8-96 votes of which 11-75 % agreed; the 4 true objects
    named by votes on the four sets had 29 % (a crate, 66 votes) and 100 % (a cube, a tin, a
    postcard).
    """
    h, w = segments.labels.shape
    xy = np.asarray(keypoints_xy, dtype=np.float64)
    if not len(xy):
        return []
    c = np.clip(np.rint(xy[:, 0]).astype(np.intp), 0, w - 1)
    r = np.clip(np.rint(xy[:, 1]).astype(np.intp), 0, h - 1)
    seg_of_kp = segments.labels[r, c]
    m = np.asarray(matched)
    geometry = match_geometry
    if geometry is not None and len(geometry[0]) != len(m):
        geometry = None
    out: list[tuple[int, str, int, int]] = []
    for k in range(len(segments.sizes)):
        if k in claimed:
            continue
        sel = (seg_of_kp == k) & (m >= 0)
        if not sel.any():
            continue
        won = _winner(xy[sel], m[sel], id_to_label, opts, verified)
        if won is None:
            continue
        best, votes = won
        agree = -1
        if geometry is not None:
            mine = sel & (m == best)
            agree = agreeing_votes(geometry[0][mine], geometry[1][mine])
            if agree < opts.vote_agree * int(mine.sum()):
                continue
        out.append((k, id_to_label[best], votes, agree))
    return out


def _winner(
    xy: NDArray[np.float64],
    ids: NDArray[np.integer],
    id_to_label: dict[int, str],
    opts: RegionStageOptions,
    verified: frozenset[str],
) -> tuple[int, int] | None:
    """The object one segment's matched keypoints vote for and its votes at distinct
    positions, if it wins by the rules of :func:`vote_segments`; else None."""
    pos = np.round(xy).astype(np.int64)
    distinct: dict[int, int] = {}
    for oid in np.unique(ids):
        distinct[int(oid)] = len({tuple(p) for p in pos[ids == oid]})
    ranked = sorted(distinct.items(), key=lambda kv: -kv[1])
    best, votes = ranked[0]
    second = ranked[1][1] if len(ranked) > 1 else 0
    need = opts.min_votes_instance if id_to_label.get(best) in verified else opts.min_votes
    if (
        votes >= need
        and votes >= opts.vote_share * sum(distinct.values())
        and votes >= opts.vote_lead * second
        and best in id_to_label
    ):
        return best, votes
    return None


def unknown_segments(
    points: NDArray[np.float32],
    segments: Segments,
    keypoints_xy: NDArray[np.float64],
    claimed: set[int],
    up: NDArray[np.float64],
    opts: RegionStageOptions,
    kw: dict[str, Any],
    textured: NDArray[np.bool_] | None = None,
) -> list[SceneObject]:
    """Segments no detection holds, as unknown objects (left to right). A segment needs
    ``opts.unknown_min_keypoints`` SIFT keypoints; with the ``textured`` pixels (the plain
    background was left out of the segments) ``opts.unknown_min_keypoints_plain`` are
    enough, and at least ``opts.unknown_min_textured`` of its pixels must be textured."""
    out: list[tuple[float, SceneObject]] = []
    h, w = segments.labels.shape
    c = np.clip(np.rint(keypoints_xy[:, 0]).astype(np.intp), 0, w - 1)
    r = np.clip(np.rint(keypoints_xy[:, 1]).astype(np.intp), 0, h - 1)
    hit = segments.labels[r, c]
    n_kp = np.bincount(hit[hit >= 0], minlength=len(segments.sizes))
    low = opts.unknown_min_keypoints if textured is None else opts.unknown_min_keypoints_plain
    for k, size in enumerate(segments.sizes.tolist()):
        if k in claimed or size < opts.unknown_min_pixels or n_kp[k] < low:
            continue
        if textured is not None and (
            float(textured[segments.mask(k)].mean()) < opts.unknown_min_textured
        ):
            continue
        pts = points[segments.mask(k)].astype(np.float64)
        pts = pts[np.all(np.isfinite(pts), axis=1)]
        if not len(pts):
            continue
        centre = np.median(pts, axis=0)
        if float(np.linalg.norm(centre)) > opts.unknown_max_distance:
            continue
        ext = np.percentile(pts, 95, axis=0) - np.percentile(pts, 5, axis=0)
        if float(np.max(ext)) > opts.unknown_max_extent:
            continue
        obj = make_object("unknown", even_sample(pts, opts.max_points), up, source="segment", **kw)
        if isinstance(obj, SceneObject):
            out.append((float(obj.plane_centroid[0]), obj))
    out.sort(key=lambda t: t[0])
    return [
        dataclasses.replace(o, label=f"unknown object {j}", name=f"unknown object {j}")
        for j, (_x, o) in enumerate(out, 1)
    ]
