"""A closer look at the unknown objects: each one's own image region, enlarged, searched again.

Geometry first finds what stands on the support whether or not the labelling named it; what it
could not name becomes an *unknown object*. At 1.5–2 m, or where a label wraps round a cylinder,
the first look gave the object too few keypoints to verify (5–20 on the tuning sets' misses),
and the finer search (:mod:`~scenespeak.perception.recognition.finer`) looks only round keypoints
that already voted for something. This looks where geometry says an object *is*: the box round
each unknown object's points projected into the left image is cut out, enlarged ``upscale``
times and searched with a lower contrast threshold (SIFT's answer to small scale, Lowe 2004,
sec. 3.3). Only the keypoints inside the object's own region (the convex hull of its projected
points grown by ``grow`` pixels, minus the regions of the objects already named: a neighbour in
the box is not this object) are labelled, with the ratio test and geometric checks of the whole
image (:func:`~scenespeak.perception.recognition.label.label_features`: the same
``LabelOptions``, the small-object rule in scene pixels).

The unknown object takes the label of the best verified detection (most inliers) when

- the detection's outline carried into the scene is about the object's size: its area within
  ``area_factor`` of the region's either way (on the tuning sets' right namings 0.7–1.7; a
  training view's outline many times the region is a piece of a larger object, one far smaller a
  chance fit on a part of another object);
- the first look's keypoints do not contradict it (``veto``, e.g.
  :meth:`~scenespeak.perception.known_evidence.KeypointEvidence.refuses`: a region SIFT sees
  well, of which almost no keypoint voted for the label, is another object's texture);
- its inliers are at least ``min_share`` of its matches (a few chance agreements among the
  many matches of a texture that only looks alike are not the object), and they cover the
  object, not a patch of it: the box of its inliers at distinct
  positions, along the axes of the region's least-area rectangle, spans at least
  ``min_cover`` of the rectangle's width and height in the geometric mean (:func:`coverage`;
  chance inliers of a texture that only looks alike cluster: a never-learnt cup and crate
  named "cereal" with 5 inliers in 0.02-0.17 of their region, where the right namings with
  4-7 inliers spanned 0.22 and more);
- no object of that label stands within :data:`~scenespeak.perception.recognition.colour.
  PIECE_GAP` of it (then it is a piece of that object, not a second instance).

Its points stay the segment's (geometry placed it); its confidence is that of a detection with
as many inliers at distinct positions, and a note says how it was named.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray

from scenespeak.geometry.polygons import polygon_area
from scenespeak.perception.features import Features, to_gray
from scenespeak.perception.objects import SceneObject
from scenespeak.perception.recognition.colour import _piece_of, _renumbered
from scenespeak.perception.recognition.finer import enlarged_features
from scenespeak.perception.recognition.label import inside_polygon
from scenespeak.perception.recognition.results import Detection, Labelling
from scenespeak.perception.scene_regions import detection_confidence

__all__ = ["CloserOptions", "closer_look", "coverage", "object_region"]

#: The closer look's views from above (:mod:`~scenespeak.perception.recognition.elevated`)
#: have their own veto: a region of at least ``MIN_KEYPOINTS`` keypoints of which less than
#: ``MIN_VOTES`` passed the ratio test for the name is not its texture (the first look's
#: :meth:`~scenespeak.perception.known_evidence.KeypointEvidence.refuses`, with this look's
#: votes: the first look's are few by nature where the views from above are needed).
MIN_KEYPOINTS, MIN_VOTES = 30, 0.05
_ABOVE = "a view from above"


@dataclass(frozen=True)
class CloserOptions:
    """Knobs of :func:`closer_look` (module docstring; set on the tuning sets).

    Attributes
    ----------
    upscale : float
        2 — the box is enlarged this many times before SIFT.
    contrast : float
        0.01 — SIFT's contrast threshold in the enlarged box (a quarter of OpenCV's default).
    pad : float
        16 px — the box round the object's projected points is grown by this much (scene
        pixels) on each side, so that keypoints near the region's edge have their context.
    grow : int
        4 px — the object's region (its projected points' convex hull) is grown this much.
    area_factor : float
        2.5 — the detection's carried outline has an area within this factor of the region's.
    budget : float
        0.5 — the boxes looked at cover at most this share of the image (before enlarging),
        the smallest first (the far objects the first look saw worst).
    min_cover : float
        0.2 — the inliers at distinct positions span at least this share of the region's
        least-area rectangle, geometric mean of its two sides (:func:`coverage`).
    min_share : float
        0.05 — the inliers are at least this share of the detection's matches. The enlarged
        region at a low contrast threshold holds many keypoints, and a texture that only looks
        like a learnt one gives many matches, among which a few line up by chance (Lowe 2004,
        sec. 7.4): never-learnt brick crates were named "cereal" with 8 of 170 matches
        (0.047), 8 of 282, 6 of 247 and 4 of 212 on the leave-part-out runs; the right namings
        had 0.059 (a brick crate seen in several splits: 10 of 169 to 15 of 183) and more. A
        narrow margin, set on these runs.
    """

    upscale: float = 2.0
    contrast: float = 0.01
    pad: float = 16.0
    grow: int = 4
    area_factor: float = 2.5
    budget: float = 0.5
    min_cover: float = 0.2
    min_share: float = 0.05


def object_region(
    obj: SceneObject, camera: NDArray[np.float64], shape: tuple[int, int]
) -> NDArray[np.float64] | None:
    """The convex hull (column, row) of ``obj``'s points projected by the 3 × 3 ``camera``,
    clipped to the image of ``shape`` (rows, columns); None for fewer than 3 points in front.

    >>> from scenespeak.perception.objects import make_object
    >>> sq = [[x, y, 1.0] for x in (-0.1, 0.0, 0.1) for y in (-0.1, 0.0, 0.1)]
    >>> obj = make_object("box", sq, np.array([0.0, -1.0, 0.0]), outliers="none")
    >>> K = np.array([[500.0, 0, 320], [0, 500, 240], [0, 0, 1]])
    >>> object_region(obj, K, (480, 640)).min(axis=0).tolist()
    [270.0, 190.0]
    """
    xyz = np.asarray(obj.xyz, np.float64).reshape(-1, 3)
    xyz = xyz[xyz[:, 2] > 1e-6]
    if len(xyz) < 3:
        return None
    uvw = xyz @ np.asarray(camera, np.float64).T
    uv = uvw[:, :2] / uvw[:, 2:3]
    h, w = shape
    uv = np.clip(uv, [0.0, 0.0], [w - 1.0, h - 1.0])
    hull = cv2.convexHull(uv.astype(np.float32)).reshape(-1, 2).astype(np.float64)
    return hull if len(hull) >= 3 and abs(polygon_area(hull)) > 0 else None


def coverage(xy: NDArray[np.float64], hull: NDArray[np.float64]) -> float:
    """How much of the region ``hull`` the points ``xy`` span: the extent of the points along
    each axis of the region's least-area rectangle over that side, geometric mean of the two
    (0: one point or a line; 1: the whole rectangle).

    Chance inliers of a texture that only looks like a learnt one agree with a model only
    over a small patch, where a handful of matches can line up; the true object's inliers lie
    all over it (Lowe 2004, sec. 7: the pose is verified by features spread over the object).

    >>> sq = np.array([[0.0, 0.0], [40.0, 0.0], [40.0, 20.0], [0.0, 20.0]])
    >>> round(coverage(np.array([[0.0, 0.0], [20.0, 10.0]]), sq), 2)
    0.5
    >>> coverage(np.array([[5.0, 5.0]]), sq)
    0.0
    """
    pts = np.unique(np.rint(np.asarray(xy, np.float64).reshape(-1, 2)), axis=0)
    if len(pts) < 2:
        return 0.0
    (cx, cy), (w, h), angle = cv2.minAreaRect(np.asarray(hull, np.float32).reshape(-1, 1, 2))
    if w <= 0 or h <= 0:
        return 0.0
    t = np.deg2rad(angle)
    axes = np.array([[np.cos(t), np.sin(t)], [-np.sin(t), np.cos(t)]])
    p = (pts - [cx, cy]) @ axes.T
    return float(np.sqrt(min(np.ptp(p[:, 0]) / w, 1.0) * min(np.ptp(p[:, 1]) / h, 1.0)))


def _enlarged_features(
    gray: NDArray[np.uint8], box: tuple[int, int, int, int], o: CloserOptions
) -> Features:
    """SIFT of ``gray[y0:y1, x0:x1]`` enlarged ``o.upscale`` times at ``o.contrast``
    (:func:`~scenespeak.perception.recognition.finer.enlarged_features`)."""
    return enlarged_features(gray, box, o.upscale, o.contrast)


def _region_mask(hull: NDArray[np.float64], shape: tuple[int, int], grow: int) -> NDArray[np.bool_]:
    """The pixels of ``hull`` grown by ``grow`` pixels."""
    m = np.zeros(shape, np.uint8)
    cv2.fillPoly(m, [np.rint(hull).astype(np.int32).reshape(-1, 1, 2)], 1)
    if grow <= 0:
        return m > 0
    return np.asarray(cv2.dilate(m, np.ones((2 * grow + 1, 2 * grow + 1), np.uint8)) > 0)


@dataclass(frozen=True, eq=False)
class _Look:
    """What :func:`closer_look` needs of the scene: the gray image, the camera, the regions of
    the objects already named, the labeller and the options."""

    gray: NDArray[np.uint8]
    camera: NDArray[np.float64]
    named: tuple[NDArray[np.float64], ...]
    look: Callable[[Features], Labelling]
    options: CloserOptions
    elevated: Callable[[SceneObject, Features], Labelling | None] | None = None

    def keypoints(self, hull: NDArray[np.float64]) -> Features:
        """The enlarged box's keypoints inside the (grown) region and no named object's."""
        h, w = self.gray.shape
        o = self.options
        lo = np.maximum(np.floor(hull.min(axis=0) - o.pad), 0).astype(int)
        hi = np.minimum(np.ceil(hull.max(axis=0) + o.pad) + 1, [w, h]).astype(int)
        f = _enlarged_features(self.gray, (int(lo[0]), int(lo[1]), int(hi[0]), int(hi[1])), o)
        if not len(f):
            return f
        mask = _region_mask(hull, (h, w), o.grow)
        c = np.clip(np.rint(f.xy[:, 0]).astype(np.intp), 0, w - 1)
        r = np.clip(np.rint(f.xy[:, 1]).astype(np.intp), 0, h - 1)
        keep = mask[r, c]
        for other in self.named:
            keep &= ~inside_polygon(f.xy, other)
        return f.subset(keep)

    def best(
        self, hull: NDArray[np.float64], obj: SceneObject
    ) -> tuple[Detection, Features] | str | None:
        """The detection with most inliers among those of the object's size, or why the one
        of its size does not cover the object (:func:`coverage`), or None. When the look at
        the learnt views names nothing, the look at the views from where the camera is
        (``elevated``, :mod:`~scenespeak.perception.recognition.elevated`) is judged alike."""
        f = self.keypoints(hull)
        if not len(f):
            return None
        found = self._judge(self.look(f), f, hull)
        if isinstance(found, tuple) or self.elevated is None:
            return found
        again = self.elevated(obj, f)
        if again is None:
            return found
        second = self._judge(again, f, hull)
        if not isinstance(second, tuple):
            return found if found is not None else second
        det = second[0]
        # the first look's votes cannot speak for a view it did not have: this look's do
        code = int(again.matched[det.inliers[0]])
        mine = int(np.count_nonzero(again.matched == code))
        if len(f) >= MIN_KEYPOINTS and mine < MIN_VOTES * len(f):
            return (
                f"not named {det.label} by a view from above: {mine} of its {len(f)} keypoints "
                f"voted for it (< {100 * MIN_VOTES:.0f} %)"
            )
        return dataclasses.replace(det, model=f"{det.model}, {_ABOVE}"), f

    def _judge(
        self, labelling: Labelling, f: Features, hull: NDArray[np.float64]
    ) -> tuple[Detection, Features] | str | None:
        """:meth:`best` on one labelling of the region's keypoints ``f``."""
        area = abs(polygon_area(hull))
        k = self.options.area_factor
        for det in labelling.detections:  # most inliers first
            carried = abs(polygon_area(det.outline_in_scene))
            if not area / k <= carried <= area * k:
                continue
            o = self.options
            if det.score < o.min_share * det.matches:
                return (
                    f"not named {det.label} by a closer look: {int(det.score)} inliers of "
                    f"{det.matches} matches (< {o.min_share:g}), a chance agreement"
                )
            cover = coverage(f.xy[det.inliers], hull)
            if cover >= o.min_cover:
                return det, f
            return (
                f"not named {det.label} by a closer look: its {int(det.score)} inliers span "
                f"{cover:.2f} of its region (< {o.min_cover:g}), a patch of it"
            )
        return None


def _budgeted(hulls: dict[int, NDArray[np.float64]], limit: float) -> list[int]:
    """The objects whose boxes fit the budget of ``limit`` pixels, smallest box first."""
    area = {i: float(np.prod(np.ptp(h, axis=0) + 1.0)) for i, h in hulls.items()}
    out, spent = [], 0.0
    for i in sorted(area, key=lambda j: (area[j], j)):
        spent += area[i]
        if spent > limit:
            break
        out.append(i)
    return sorted(out)


def _verdict(
    found: tuple[Detection, Features] | str | None,
    obj: SceneObject,
    objects: Sequence[SceneObject],
    veto: Callable[[SceneObject, str], str | None] | None,
) -> tuple[Detection, Features] | SceneObject:
    """What :meth:`_Look.best` found, when it may name ``obj``; else ``obj`` as it is, with
    a note when the look was refused (the look's own reason, or the veto's). A piece of an
    object of that label (:func:`~scenespeak.perception.recognition.colour._piece_of`) stays
    as it is."""
    if found is None:
        return obj
    if isinstance(found, str):
        return dataclasses.replace(obj, notes=(*obj.notes, found))
    label = found[0].label
    if _piece_of(obj, label, objects):
        return obj
    above = found[0].model.endswith(_ABOVE)  # vetted by its own votes (MIN_VOTES)
    why = veto(obj, label) if veto is not None and not above else None
    if why is not None:
        return dataclasses.replace(obj, notes=(*obj.notes, f"not named {label}: {why}"))
    return found


def closer_look(
    objects: Sequence[SceneObject],
    image: NDArray[np.generic],
    camera: NDArray[np.float64],
    look: Callable[[Features], Labelling],
    options: CloserOptions | None = None,
    veto: Callable[[SceneObject, str], str | None] | None = None,
    elevated: Callable[[SceneObject, Features], Labelling | None] | None = None,
) -> tuple[SceneObject, ...]:
    """``objects`` with the unknown ones that a closer look at their own region names renamed
    (module docstring), instances numbered ("cup", "cup 2") and the unknown ones renumbered.

    Parameters
    ----------
    objects : sequence of SceneObject
        The scene's objects; those labelled ``"unknown object N"`` are looked at.
    image : ndarray
        The left image the objects' points project into (gray or colour).
    camera : (3, 3)
        The left camera matrix of the objects' frame.
    look : callable
        Labels features against the database, ``look(features) -> Labelling``
        (:meth:`~scenespeak.perception.recognition.ObjectDatabase.labeller`).
    options : CloserOptions, optional
    veto : callable, optional
        ``veto(obj, label)``: why ``obj`` cannot be ``label`` (None: it may be); a vetoed
        object stays unknown with a note saying why.
    elevated : callable, optional
        ``elevated(obj, features)``: the labelling of an unknown object's region keypoints
        against learnt views seen from where the camera sees it
        (:class:`~scenespeak.perception.recognition.elevated.ElevatedLook`), tried when the
        first look names nothing; None: not tried.
    """
    o = options or CloserOptions()
    gray = to_gray(np.asarray(image))
    cam = np.asarray(camera, np.float64)
    shape = (int(gray.shape[0]), int(gray.shape[1]))
    hulls = {
        i: hull
        for i, obj in enumerate(objects)
        if obj.label.startswith("unknown object")
        and (hull := object_region(obj, cam, shape)) is not None
    }
    if not hulls:
        return tuple(objects)
    named = tuple(
        hull
        for obj in objects
        if not obj.label.startswith("unknown object")
        and (hull := object_region(obj, cam, shape)) is not None
    )
    scene = _Look(gray, cam, named, look, o, elevated)
    out = list(objects)
    changed = False
    for i in _budgeted(hulls, o.budget * shape[0] * shape[1]):
        obj = out[i]
        found = _verdict(scene.best(hulls[i], obj), obj, out, veto)
        if not isinstance(found, tuple):
            out[i] = found
            continue
        det, feats = found
        distinct = int(np.unique(np.rint(feats.xy[det.inliers]), axis=0).shape[0])
        cover = coverage(feats.xy[det.inliers], hulls[i])
        note = (
            f"named by a closer look ({o.upscale:g}x enlarged region): {int(det.score)} "
            f"inliers ({det.model}) of {det.matches} matches, spanning {cover:.2f} of its region"
        )
        out[i] = dataclasses.replace(
            obj,
            label=det.label,
            name=det.label,
            confidence=detection_confidence(int(det.score), distinct),
            notes=(*obj.notes, note),
        )
        changed = True
    return tuple(_renumbered(out)) if changed else tuple(out)
