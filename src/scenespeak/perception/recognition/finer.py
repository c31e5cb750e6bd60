"""Finer search for small and far appearances: unexplained matches → an upscaled second look.

An object 1.5–2 m away covers 40–70 pixels of a 640 × 480 image and carries a handful of
SIFT keypoints, too few for the geometric check, though often one or two of them pass the
ratio test. Around every keypoint that passed the ratio test but belongs to no detection, the
scene is looked at again: the boxes around them (merged where they overlap) are cut out,
enlarged ``upscale`` times and searched with a lower contrast threshold — SIFT's own answer
to small scale (Lowe 2004, sec. 3.3: doubling the image quadruples the keypoints), paid only
where something was half-seen. What is found there is verified exactly like a detection in
the whole image (the same ratio test, models and thresholds) and must not overlap a
detection of the same label already made.

The found detection's ``inliers`` are the *scene's* keypoints inside its carried outline (its
verified inliers are keypoints of the enlarged crop, which the rest of the pipeline does not
hold); its ``score`` and ``matches`` are those of the crop.

Each box's look (its SIFT and its labelling) depends on nothing but the box, so the boxes can
be shared with another thread (:func:`run_shared`, ``executor=``): the pipeline hands them to
its stereo thread once that thread's own work is done. Only the merging of what the boxes
found depends on the order, and it runs afterwards, box by box in the same order, so the
result is the same whichever thread looked at which box.
"""

from __future__ import annotations

import dataclasses
import functools
from concurrent.futures import Executor

import cv2
import numpy as np
from numpy.typing import NDArray

from scenespeak.perception.features import Features, detect, to_gray
from scenespeak.perception.recognition.label import (
    _apart,
    _Loaded,
    inside_polygon,
    label_features,
)
from scenespeak.perception.recognition.options import LabelOptions
from scenespeak.perception.recognition.results import Detection, Labelling
from scenespeak.perception.sharing import run_shared

__all__ = ["finer_search", "merge_boxes", "run_shared"]


def merge_boxes(boxes: NDArray[np.float64]) -> NDArray[np.float64]:
    """Merge axis-aligned boxes ``(x0, y0, x1, y1)`` that overlap, until none do.

    >>> merge_boxes(np.array([[0, 0, 10, 10], [5, 5, 20, 20], [40, 40, 50, 50]], float)).tolist()
    [[0.0, 0.0, 20.0, 20.0], [40.0, 40.0, 50.0, 50.0]]
    """
    out = [np.asarray(b, np.float64) for b in boxes]
    changed = True
    while changed:
        changed = False
        merged: list[NDArray[np.float64]] = []
        for b in out:
            for i, m in enumerate(merged):
                if b[0] <= m[2] and m[0] <= b[2] and b[1] <= m[3] and m[1] <= b[3]:
                    merged[i] = np.array(
                        [min(b[0], m[0]), min(b[1], m[1]), max(b[2], m[2]), max(b[3], m[3])]
                    )
                    changed = True
                    break
            else:
                merged.append(b)
        out = merged
    return np.array(out, np.float64).reshape(-1, 4)


def _boxes(
    features: Features, labelling: Labelling, shape: tuple[int, int], o: LabelOptions
) -> NDArray[np.float64]:
    """Boxes round the keypoints that passed the ratio test but explain no detection and lie
    outside every detection's outline (there they are the rest of an object found)."""
    lone = (labelling.matched >= 0) & (labelling.labels < 0)
    for det in labelling.detections:
        lone &= ~inside_polygon(features.xy, det.outline_in_scene)
    if not lone.any():
        return np.zeros((0, 4))
    xy = features.xy[lone]
    pad = o.finer_pad
    h, w = shape
    b = np.column_stack([xy[:, 0] - pad, xy[:, 1] - pad, xy[:, 0] + pad, xy[:, 1] + pad])
    b = merge_boxes(b)
    b[:, [0, 2]] = np.clip(b[:, [0, 2]], 0, w)
    b[:, [1, 3]] = np.clip(b[:, [1, 3]], 0, h)
    area = (b[:, 2] - b[:, 0]) * (b[:, 3] - b[:, 1])
    keep = (area > 0) & (area <= o.finer_max_area)
    # the boxes with most unexplained matches first, at most finer_max_boxes of them
    counts = np.array([np.sum(inside_box(xy, bb)) for bb in b[keep]], dtype=np.int64).reshape(-1)
    order = np.argsort(-counts, kind="stable")[: o.finer_max_boxes]
    chosen = b[keep][order]
    # within the budget of enlarged pixels (a share of the scene's), most matches first
    spent = np.cumsum((chosen[:, 2] - chosen[:, 0]) * (chosen[:, 3] - chosen[:, 1]))
    return chosen[spent <= o.finer_budget * h * w]


def inside_box(xy: NDArray[np.float64], box: NDArray[np.float64]) -> NDArray[np.bool_]:
    """Whether each point lies in the box ``(x0, y0, x1, y1)`` (edges included).

    >>> inside_box(np.array([[1.0, 1.0], [5.0, 1.0]]), np.array([0.0, 0.0, 2.0, 2.0])).tolist()
    [True, False]
    """
    return np.asarray(
        (xy[:, 0] >= box[0]) & (xy[:, 0] <= box[2]) & (xy[:, 1] >= box[1]) & (xy[:, 1] <= box[3])
    )


def _crop_features(gray: NDArray[np.uint8], box: NDArray[np.float64], o: LabelOptions) -> Features:
    """SIFT of the box enlarged ``finer_upscale`` times, positions and sizes in scene pixels."""
    x0, y0, x1, y1 = (int(v) for v in np.rint(box))
    return enlarged_features(gray, (x0, y0, x1, y1), o.finer_upscale, o.finer_contrast)


def enlarged_features(
    gray: NDArray[np.uint8], box: tuple[int, int, int, int], upscale: float, contrast: float
) -> Features:
    """SIFT of ``gray[y0:y1, x0:x1]`` enlarged ``upscale`` times (bilinear), at SIFT's
    ``contrast`` threshold, positions and sizes in scene pixels (pixel centres: enlarged
    pixel i covers crop pixels [i / s, (i + 1) / s)); empty for an empty box."""
    x0, y0, x1, y1 = box
    crop = gray[y0:y1, x0:x1]
    if crop.size == 0:
        return Features.empty()
    s = float(upscale)
    big = cv2.resize(crop, None, fx=s, fy=s, interpolation=cv2.INTER_LINEAR)
    f = detect(big, contrast_threshold=contrast, precise_upscale=False)
    xy = (f.xy + 0.5) / s - 0.5 + np.array([x0, y0], np.float64)
    return dataclasses.replace(f, xy=xy, size=(f.size / s).astype(np.float32))


def _scene_inliers(
    det: Detection, crop: Features, features: Features, lone: NDArray[np.bool_]
) -> NDArray[np.intp]:
    """The scene keypoints standing for a crop's detection: those within 3 px of one of its
    verified (crop) inliers, and the unexplained ratio-test matches to its object inside
    its outline (``lone``: a per-keypoint mask for this object)."""
    near = np.zeros(len(features), bool)
    if len(det.inliers):
        d = np.linalg.norm(features.xy[:, None, :] - crop.xy[det.inliers][None, :, :], axis=2)
        near = d.min(axis=1) <= 3.0
    near |= lone & inside_polygon(features.xy, det.outline_in_scene)
    return np.flatnonzero(near).astype(np.intp)


def _new_detection(
    det: Detection,
    crop: Features,
    features: Features,
    found: list[Detection],
    lone: NDArray[np.bool_],
    o: LabelOptions,
) -> Detection | None:
    """A crop's detection in scene terms, or None when it is no instance apart from one
    already made (``_apart``: the other half of a curved label is no second object)."""
    new = dataclasses.replace(det, inliers=_scene_inliers(det, crop, features, lone))
    for f in found:
        if f.label == det.label and not _apart(new, f, features.xy, o):
            return None
    return new


def _look(
    db: _Loaded, gray: NDArray[np.uint8], box: NDArray[np.float64], o: LabelOptions
) -> tuple[Features, Labelling] | None:
    """One box's look: the enlarged crop's features and their labelling (None: no keypoint)."""
    crop = _crop_features(gray, box, o)
    if not len(crop):
        return None
    return crop, label_features(db, crop, o)


def finer_search(
    db: _Loaded,
    image: NDArray[np.generic],
    features: Features,
    labelling: Labelling,
    o: LabelOptions,
    executor: Executor | None = None,
) -> Labelling:
    """``labelling`` with the detections found by a second, enlarged look where keypoints
    passed the ratio test but explain no detection (see the module docstring).

    Parameters
    ----------
    db : _Loaded
        The loaded database.
    image : ndarray
        The scene image the ``features`` were detected in (gray or colour).
    features, labelling
        Its features and their labelling by :func:`label_features`.
    o : LabelOptions
        ``finer_*`` fields: the enlargement, contrast threshold, box padding, box limits.
    executor : Executor, optional
        Shares the boxes' looks with one task of it (:func:`run_shared`); the result is the
        same with it and without it.
    """
    if o.finer_upscale <= 1.0 or not len(features):
        return labelling
    gray = to_gray(np.asarray(image))
    found = list(labelling.detections)
    by_label = {v: k for k, v in db.labels.items()}
    added: list[Detection] = []
    boxes = _boxes(features, labelling, gray.shape[:2], o)
    jobs = [functools.partial(_look, db, gray, b, o) for b in boxes]
    looks = run_shared(jobs, executor)
    for look in looks:
        if look is None:
            continue
        crop, crop_labelling = look
        for det in crop_labelling.detections:
            lone = (labelling.labels < 0) & (labelling.matched == by_label.get(det.label, -2))
            new = _new_detection(det, crop, features, found, lone, o)
            if new is not None and len(new.inliers):
                found.append(new)
                added.append(new)
    if not added:
        return labelling
    detections = tuple(sorted(found, key=lambda d: -d.score))
    labels = np.full(len(features), -1, np.int32)
    # the verified detections' inliers first; a finer one takes only what is left
    for i, det in sorted(enumerate(detections), key=lambda t: any(t[1] is a for a in added)):
        free = det.inliers[labels[det.inliers] < 0]
        labels[free] = i
    return dataclasses.replace(labelling, labels=labels, detections=detections)
