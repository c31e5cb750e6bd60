"""Labelling: the scene's keypoints → recognised objects (ratio test, then geometric checks).

Lowe's recipe: a ratio test whose second neighbour is the nearest descriptor *of a different
object*, then per training view a RANSAC homography (a similarity where there are few
matches), each inlier's SIFT scale and orientation checked against the model
(:mod:`~scenespeak.perception.recognition.verify`).
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray

from scenespeak.geometry.polygons import points_in_polygon
from scenespeak.perception.features import Features
from scenespeak.perception.recognition.index import DescriptorIndex
from scenespeak.perception.recognition.options import LabelOptions
from scenespeak.perception.recognition.ratio import Candidates as _Candidates
from scenespeak.perception.recognition.ratio import ratio_candidates as _ratio_candidates
from scenespeak.perception.recognition.results import Detection, Labelling
from scenespeak.perception.recognition.verify import _apply_h, _fit_view, _Keys, _small_enough

__all__ = ["inside_polygon", "label_features"]


@dataclass(frozen=True)
class _Loaded:
    """Everything :meth:`ObjectDatabase.label` needs, loaded once."""

    generation: int
    index: DescriptorIndex
    object_of: NDArray[np.int32]  # per descriptor: object id
    view_of: NDArray[np.int32]  # per descriptor: view id
    xy: NDArray[np.float32]  # (N, 2)
    size: NDArray[np.float32]
    angle: NDArray[np.float32]
    labels: dict[int, str]
    outlines: dict[int, NDArray[np.float32]]
    synthetic: NDArray[np.bool_] | None = None  # per descriptor: of a synthesised view


def _detect_in_view(
    db: _Loaded,
    features: Features,
    qi: NDArray[np.intp],
    ti: NDArray[np.int64],
    ids: tuple[int, int],
    o: LabelOptions,
    floor: int,
) -> Detection | None:
    """The detection of object ``ids[0]`` in training view ``ids[1]`` from the matches
    ``qi`` ↔ ``ti``, if it has more than ``floor`` inliers and passes the small-object rule."""
    oid, vid = ids
    outline = db.outlines[vid]
    train = _Keys(db.xy[ti].astype(np.float64), db.size[ti], db.angle[ti])
    query = _Keys(features.xy[qi], features.size[qi], features.angle[qi])
    fit = _fit_view(train, query, outline, o)
    if fit is None:
        return None
    n_in = int(fit.inliers.sum())
    if n_in <= floor:
        return None
    in_scene = _apply_h(fit.h, outline.astype(np.float64))
    if n_in < o.min_inliers and (
        not _small_enough(in_scene, features.xy[qi[fit.inliers]], o.small_area, o.min_inliers_small)
        or n_in < o.small_share * len(qi)
    ):
        return None
    return Detection(
        label=db.labels[oid],
        view_id=int(vid),
        homography=fit.h,
        inliers=np.sort(qi[fit.inliers]).astype(np.intp),
        outline_in_scene=in_scene,
        score=float(n_in),
        model=fit.model,
        matches=len(qi),
    )


def _best_view(
    db: _Loaded,
    features: Features,
    c: _Candidates,
    sel_o: NDArray[np.bool_],
    ids: tuple[int, int],
    o: LabelOptions,
) -> Detection | None:
    """The best view's detection of object ``ids[0]`` (most inliers) among the candidates
    ``sel_o``, with at least ``ids[1]`` inliers, or None."""
    oid, need = ids
    if not sel_o.any():
        return None
    vids, counts = np.unique(c.view[sel_o], return_counts=True)
    if counts.max() < need:
        return None
    best: Detection | None = None
    order = np.argsort(-counts, kind="stable")[: o.max_views]
    for vid, count in zip(vids[order].tolist(), counts[order].tolist(), strict=True):
        # A view needs ``need`` inliers, and strictly more than the best view so far.
        floor = need - 1 if best is None else int(best.score)
        # Views come most matched first, and a view's inliers are a subset of its matches:
        # once a view has no more matches than ``floor``, no view that follows can win.
        if count <= floor:
            break
        sel = sel_o & (c.view == vid)
        det = _detect_in_view(db, features, c.q_idx[sel], c.t_idx[sel], (oid, vid), o, floor)
        if det is not None:
            best = det
    return best


def inside_polygon(xy: NDArray[np.float64], polygon: NDArray[np.float64]) -> NDArray[np.bool_]:
    """Whether each point lies inside a polygon (even-odd rule; geometry's one point-in-polygon
    test, :func:`~scenespeak.geometry.polygons.points_in_polygon`, and its boundary rule).

    >>> sq = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]])
    >>> inside_polygon(np.array([[5.0, 5.0], [15.0, 5.0]]), sq).tolist()
    [True, False]
    """
    return points_in_polygon(xy, polygon, "even-odd")


def _overlap_share(a: NDArray[np.float64], b: NDArray[np.float64]) -> float:
    """Area of the intersection of two outlines' convex hulls over the smaller hull's area."""
    ha = cv2.convexHull(np.asarray(a, np.float32).reshape(-1, 1, 2))
    hb = cv2.convexHull(np.asarray(b, np.float32).reshape(-1, 1, 2))
    smaller = min(cv2.contourArea(ha), cv2.contourArea(hb))
    if smaller <= 0:
        return 1.0
    area, _ = cv2.intersectConvexConvex(ha, hb)
    return float(area) / smaller


def _apart(a: Detection, b: Detection, xy: NDArray[np.float64], o: LabelOptions) -> bool:
    """Whether two detections of one object are two instances, not two faces or strips of
    one: their outlines overlap by at most ``instance_overlap`` of the smaller, neither
    outline holds more than ``instance_overlap`` of the other's inliers, and their inliers
    together span more than ``instance_span`` objects (:func:`_one_span`)."""
    if _overlap_share(a.outline_in_scene, b.outline_in_scene) > o.instance_overlap:
        return False
    for x, y in ((a, b), (b, a)):
        if len(y.inliers) and (
            inside_polygon(xy[y.inliers], x.outline_in_scene).mean() > o.instance_overlap
        ):
            return False
    return not _one_span(a, b, xy, o.instance_span)


def _one_span(a: Detection, b: Detection, xy: NDArray[np.float64], limit: float) -> bool:
    """Whether the two detections' inliers together span no more than ``limit`` times one
    object along the line between them: two views' halves of one curved label (each
    training view explains the side it saw), not two objects side by side (each covered by
    its own inliers)."""
    pa, pb = xy[a.inliers], xy[b.inliers]
    if not len(pa) or not len(pb):
        return False
    d = pb.mean(axis=0) - pa.mean(axis=0)
    norm = float(np.hypot(*d))
    if norm == 0.0:
        return True
    d = d / norm
    both = np.concatenate([pa, pb]) @ d
    extent = min(float(np.ptp(np.asarray(det.outline_in_scene, np.float64) @ d)) for det in (a, b))
    return bool(float(np.ptp(both)) <= limit * extent)


def _detect_object(
    db: _Loaded, features: Features, c: _Candidates, oid: int, need: int, o: LabelOptions
) -> list[Detection]:
    """Every instance of one object: the best view's detection, then again with the matches
    inside the instances found so far taken away (Lowe 2004, sec. 7: each cluster of
    consistent matches is one hypothesis). A further instance needs the same evidence as the
    first and an outline that overlaps no earlier instance's by more than
    ``instance_overlap`` (a second face or strip of the same object carried into the scene
    lands on it, a second instance beside it)."""
    sel_o = c.first_obj[c.q_idx] == oid
    found: list[Detection] = []
    q_xy = features.xy[c.q_idx]
    while len(found) < max(o.max_instances, 1):
        det = _best_view(db, features, c, sel_o, (oid, need), o)
        if det is None:
            break
        if found and not all(_apart(det, f, features.xy, o) for f in found):
            break
        found.append(det)
        sel_o = sel_o & ~np.isin(c.q_idx, det.inliers) & ~inside_polygon(q_xy, det.outline_in_scene)
    return found


def label_features(db: _Loaded, features: Features, o: LabelOptions) -> Labelling:
    """Label query keypoints with the loaded database's objects (:meth:`ObjectDatabase.label`)."""
    need = min(o.min_inliers, o.min_inliers_small) if o.small_area > 0 else o.min_inliers
    nq = len(features)
    labels = np.full(nq, -1, np.int32)
    matched = np.full(nq, -1, np.int32)
    if nq == 0:
        return Labelling(labels, (), matched)
    c = _ratio_candidates(db, features, o)
    matched[c.passed] = c.first_obj[c.passed]
    scale, turn = _match_geometry(db, features, c)
    found = []
    for oid in np.unique(c.first_obj[c.q_idx]).tolist():
        found.extend(_detect_object(db, features, c, oid, need, o))
    found.sort(key=lambda d: -d.score)
    detections = tuple(found)
    for i, det in enumerate(detections):
        labels[det.inliers] = i
    return Labelling(labels, detections, matched, scale, turn, c.synthesised_only)


def _match_geometry(
    db: _Loaded, features: Features, c: _Candidates
) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
    """Per query keypoint that passed the ratio test: its scale over its nearest training
    keypoint's and the orientation difference (degrees, [0, 360)); NaN elsewhere."""
    n = len(features)
    scale = np.full(n, np.nan, np.float32)
    turn = np.full(n, np.nan, np.float32)
    q = np.flatnonzero(c.passed)
    t = c.nearest[q]
    scale[q] = features.size[q] / np.maximum(db.size[t], 1e-6)
    turn[q] = np.mod(features.angle[q] - db.angle[t], 360.0)
    return scale, turn
