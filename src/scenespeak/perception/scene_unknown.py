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

__all__ = ["even_sample", "name_instances", "near_same_label", "unknown_segments", "vote_segments"]


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


def vote_segments(
    segments: Segments,
    keypoints_xy: NDArray[np.float64],
    matched: NDArray[np.integer],
    id_to_label: dict[int, str],
    claimed: set[int],
    opts: RegionStageOptions,
    verified: frozenset[str] = frozenset(),
) -> list[tuple[int, str, int]]:
    """Unclaimed segments named by the ratio-test votes of the keypoints inside them.

    A segment is named after the object most of its keypoints matched (before any geometric
    check) when that object has at least ``min_votes`` votes at distinct positions, at least
    ``vote_share`` of the segment's matched keypoints, and at least ``vote_lead`` times the
    runner-up's votes. Chance matches of a never-learnt object spread over many objects (at
    most 2 votes for one object on the tuning set's distractors), a recognised-but-unverified
    object concentrates them. Returns ``(segment, label, votes)``.
    """
    h, w = segments.labels.shape
    xy = np.asarray(keypoints_xy, dtype=np.float64)
    if not len(xy):
        return []
    c = np.clip(np.rint(xy[:, 0]).astype(np.intp), 0, w - 1)
    r = np.clip(np.rint(xy[:, 1]).astype(np.intp), 0, h - 1)
    seg_of_kp = segments.labels[r, c]
    m = np.asarray(matched)
    out: list[tuple[int, str, int]] = []
    for k in range(len(segments.sizes)):
        if k in claimed:
            continue
        sel = (seg_of_kp == k) & (m >= 0)
        if not sel.any():
            continue
        ids = m[sel]
        pos = np.round(xy[sel]).astype(np.int64)
        distinct: dict[int, int] = {}
        for oid in np.unique(ids):
            distinct[int(oid)] = len({tuple(p) for p in pos[ids == oid]})
        ranked = sorted(distinct.items(), key=lambda kv: -kv[1])
        best, votes = ranked[0]
        second = ranked[1][1] if len(ranked) > 1 else 0
        if (
            votes
            >= (opts.min_votes_instance if id_to_label.get(best) in verified else opts.min_votes)
            and votes >= opts.vote_share * sum(distinct.values())
            and votes >= opts.vote_lead * second
            and best in id_to_label
        ):
            out.append((k, id_to_label[best], votes))
    return out


def unknown_segments(
    points: NDArray[np.float32],
    segments: Segments,
    keypoints_xy: NDArray[np.float64],
    claimed: set[int],
    up: NDArray[np.float64],
    opts: RegionStageOptions,
    kw: dict[str, Any],
) -> list[SceneObject]:
    """Segments no detection holds, as unknown objects (left to right)."""
    out: list[tuple[float, SceneObject]] = []
    h, w = segments.labels.shape
    c = np.clip(np.rint(keypoints_xy[:, 0]).astype(np.intp), 0, w - 1)
    r = np.clip(np.rint(keypoints_xy[:, 1]).astype(np.intp), 0, h - 1)
    hit = segments.labels[r, c]
    n_kp = np.bincount(hit[hit >= 0], minlength=len(segments.sizes))
    for k, size in enumerate(segments.sizes.tolist()):
        if k in claimed or size < opts.unknown_min_pixels or n_kp[k] < opts.unknown_min_keypoints:
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
