"""One object seen as two detections: faces of one box taken as two instances, merged in 3-D.

Part of the region stage (:func:`scenespeak.perception.scene_regions.objects_from_regions`).
The labelling searches an object again after each detection (Lowe 2004, sec. 7) and accepts a
further instance when its outline in the image lies apart from the first one's
(:func:`scenespeak.perception.recognition.label._apart`). Two *faces* of one box (the front
face matched to one training view, the side face to another) also lie apart in the image, side
by side: in 2-D they look like two instances. In 3-D they do not. A detection's carried
outline at its points' depth gives the object's size in metres (``width_px · Z / f``, the
pinhole model); two separate solid objects of one label stand at least about one such size
apart, centre to centre, while two faces of one box have their centres
``√((w/2)² + (d/2)²) ≤ 0.71 · max(w, d)`` apart. Two detections of one label whose objects'
centres are closer than :attr:`SplitOptions.share` of the larger detection's size, and whose
keypoints lie in one geometric segment (no depth jump, no support between them), are one
object: their points are joined and it is made again.

>>> SplitOptions().share
0.8
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

from scenespeak.perception.objects import SceneObject, make_object

__all__ = ["SplitOptions", "detection_size", "merge_split_instances", "size_misfits"]


@dataclass(frozen=True)
class SplitOptions:
    """Knobs of :func:`merge_split_instances`.

    Attributes
    ----------
    share : float
        0.8 — two detections of one label are one object when their objects' centres are
        closer than this share of the larger detection's size in metres (faces of one box:
        at most 0.71; two objects side by side: at least about 1).
    size_ratio : float
        2.5 — instances of one label are one object's copies, of one size: a further
        detection whose size in metres differs from the best detection's by more than this
        factor is no instance of it (:func:`size_misfits`).
    """

    share: float = 0.8
    size_ratio: float = 2.5


def detection_size(outline: NDArray[np.float64], depth: float, focal: float) -> float:
    """The size in metres of a carried outline at ``depth``: the long side of its least-area
    rectangle in pixels times ``depth / focal`` (pinhole camera).

    >>> sq = np.array([[0.0, 0.0], [100.0, 0.0], [100.0, 50.0], [0.0, 50.0]])
    >>> round(detection_size(sq, 1.5, 500.0), 3)
    0.3
    """
    pts = np.asarray(outline, dtype=np.float32).reshape(-1, 2)
    if len(pts) < 2 or not np.all(np.isfinite(pts)) or focal <= 0 or not math.isfinite(depth):
        return 0.0
    (_cx, _cy), (w, h), _angle = cv2.minAreaRect(pts)
    return float(max(w, h)) * float(depth) / float(focal)


def _size_of(obj: SceneObject, outline: NDArray[np.float64], focal: float) -> float:
    """The metric size of a detection placed as ``obj`` (at its points' median depth)."""
    if not len(obj.xyz):
        return 0.0
    return detection_size(outline, float(np.median(obj.xyz[:, 2])), focal)


def merge_split_instances(
    placed: Sequence[tuple[SceneObject, NDArray[np.float64], int]],
    up: NDArray[np.float64],
    focal: float,
    kw: dict[str, Any],
    options: SplitOptions | None = None,
) -> list[SceneObject]:
    """The objects of ``placed`` (each with its detection's carried outline, best first) with
    the detections of one object joined.

    Parameters
    ----------
    placed : sequence of (SceneObject, outline, segment)
        The recognised objects in the order of their detections (best first), the outline
        each detection carried into the left image (pixels) and the geometric segment that
        holds its keypoints (-1: none). Only detections in one segment are joined: between
        two segments lies a depth jump or the support.
    up : (3,)
        World up in the left camera frame.
    focal : float
        The left camera's focal length in pixels.
    kw : dict
        :func:`~scenespeak.perception.objects.make_object`'s overrides, as the stage uses.
    options : SplitOptions, optional

    Returns
    -------
    list of SceneObject
        The first object of each group keeps its name and confidence, made again of the
        group's points; a note says how many detections were joined.

    Examples
    --------
    Two faces of one 30 cm box at 1.5 m, side by side (f = 500 px: the front face's outline
    is 100 px wide), are one object; a second box 40 cm away stays a second instance:

    >>> from scenespeak.perception.objects import make_object
    >>> up = np.array([0.0, -1.0, 0.0])
    >>> def box(x):
    ...     g = np.stack(np.meshgrid(np.linspace(-0.05, 0.05, 6), np.linspace(0, 0.1, 6)), -1)
    ...     g = g.reshape(-1, 2)
    ...     return make_object("crate", np.c_[g[:, 0] + x, g[:, 1], np.full(36, 1.5)], up)
    >>> wide = np.array([[0.0, 0], [100, 0], [100, 40], [0, 40]])
    >>> narrow = wide * [0.5, 1]
    >>> kept = merge_split_instances([(box(0.0), wide, 3), (box(0.1), narrow, 3)], up, 500.0, {})
    >>> len(kept), kept[0].n_points, kept[0].notes[-1]
    (1, 72, 'joined with 1 other detection of one object (centres 0.10 m apart, size 0.30 m)')
    >>> len(merge_split_instances([(box(0.0), wide, 3), (box(0.4), narrow, 3)], up, 500.0, {}))
    2

    In two segments (a depth jump or the floor between them) they are two objects:

    >>> len(merge_split_instances([(box(0.0), wide, 3), (box(0.1), narrow, 4)], up, 500.0, {}))
    2
    """
    o = options or SplitOptions()
    group, why = _groups(placed, focal, o)
    out: list[SceneObject] = []
    for i, (obj, _outline, _seg) in enumerate(placed):
        if group[i] != i:
            continue
        members = [placed[j][0] for j in range(len(placed)) if group[j] == i]
        if len(members) == 1:
            out.append(obj)
            continue
        out.append(_joined(obj, members, up, kw, why[i]))
    return out


def _groups(
    placed: Sequence[tuple[SceneObject, NDArray[np.float64], int]],
    focal: float,
    o: SplitOptions,
) -> tuple[list[int], dict[int, list[str]]]:
    """Each detection's group (the index of its first, best member) and, per group, why
    its members were joined."""
    sizes = [_size_of(obj, outline, focal) for obj, outline, _seg in placed]
    group = list(range(len(placed)))
    why: dict[int, list[str]] = {}
    for j in range(len(placed)):
        for i in range(j):
            if group[i] != i or placed[i][0].label != placed[j][0].label:
                continue
            if placed[i][2] < 0 or placed[i][2] != placed[j][2]:
                continue  # a depth jump or the support lies between them: two objects
            gap = float(np.linalg.norm(placed[i][0].centroid - placed[j][0].centroid))
            size = max(sizes[i], sizes[j])
            if size > 0 and gap < o.share * size:
                group[j] = i
                why.setdefault(i, []).append(f"centres {gap:.2f} m apart, size {size:.2f} m")
                break
    return group, why


def _joined(
    first: SceneObject,
    members: list[SceneObject],
    up: NDArray[np.float64],
    kw: dict[str, Any],
    why: list[str],
) -> SceneObject:
    """``first`` made again of all ``members``' points (``first`` itself if that fails)."""
    pts = np.concatenate([m.xyz for m in members])
    source = first.source if all(m.source == first.source for m in members) else "dense"
    made = make_object(first.label, pts, up, source=source, **kw)
    if not isinstance(made, SceneObject):
        return first
    n = len(members) - 1
    note = (
        f"joined with {n} other detection{'s' if n != 1 else ''} of one object ({'; '.join(why)})"
    )
    return dataclasses.replace(
        made, name=first.name, confidence=first.confidence, notes=(*made.notes, note)
    )


def size_misfits(
    placed: Sequence[tuple[SceneObject, NDArray[np.float64], int]],
    focal: float,
    options: SplitOptions | None = None,
) -> dict[int, str]:
    """Detections that cannot be another instance of a label found better elsewhere in the
    scene, each with the reason: their carried outline, at their points' depth, makes the
    object a different size.

    The training view a detection carries into the scene has one size in metres whatever
    the distance: ``width_px · Z / f`` is the same for every instance (within the stretch of
    a homography fitted to part of the object). Five chance matches in an enlarged box of the
    finer search that carried a cereal box 27 cm tall onto a cup 0.57 m away made it 6 cm
    tall, beside the real cereal box found at 1.6 m.

    Examples
    --------
    >>> from scenespeak.perception.objects import make_object
    >>> up = np.array([0.0, -1.0, 0.0])
    >>> box = lambda z: make_object("cereal", [[0, 0, z], [0.05, 0, z], [0, 0.05, z]], up)
    >>> tall = np.array([[0.0, 0], [40, 0], [40, 90], [0, 90]])
    >>> print(size_misfits([(box(1.6), tall, 1), (box(0.57), tall * 0.6, 2)], 554.0)[1])
    its outline at 0.57 m makes it 0.06 m, the cereal found best is 0.26 m: not another instance
    >>> size_misfits([(box(1.6), tall, 1), (box(0.8), tall * 2, 2)], 554.0)
    {}
    """
    o = options or SplitOptions()
    out: dict[int, str] = {}
    best: dict[str, tuple[float, int]] = {}
    for j, (obj, outline, _seg) in enumerate(placed):
        size = _size_of(obj, outline, focal)
        if obj.label not in best:
            best[obj.label] = (size, j)
            continue
        ref = best[obj.label][0]
        if size > 0 and ref > 0 and max(size / ref, ref / size) > o.size_ratio:
            z = float(np.median(obj.xyz[:, 2]))
            out[j] = (
                f"its outline at {z:.2f} m makes it {size:.2f} m, the {obj.label} found best "
                f"is {ref:.2f} m: not another instance"
            )
    return out
