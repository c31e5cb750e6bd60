"""Another instance by colour or grey levels must look like the one its keypoints verified.

The colour and grey cues (:mod:`~scenespeak.perception.recognition.colour`) name an unknown
segment by comparing it with the learnt object's training views. When the scene already holds
an instance of that label verified by its keypoints (a detection or the closer look), a second
instance is a copy of an object that is *in this scene*, in its light and at its scale: its
appearance is that instance's. A never-learnt object as near the training views as the cue
allows may still be far from the object beside it (the Hellinger distance is a metric: two
segments each within 0.22 of the views can be 0.44 apart). A segment farther than
:data:`INSTANCE_DISTANCE` from every verified instance of its label stays unknown.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from scenespeak.perception.objects import SceneObject
from scenespeak.perception.recognition.colour import (
    _GREY_NOTE,
    _chroma,
    _object_pixels,
    chromatic_pixels,
    colour_signature,
    hellinger,
)
from scenespeak.perception.recognition.grey import grey_pixels

if TYPE_CHECKING:
    from scenespeak.perception.recognition.colour import _Scene

__all__ = ["INSTANCE_DISTANCE", "keypoint_verified", "unlike_verified"]

#: Largest Hellinger distance between a further instance's colours (or grey signature) and
#: those of the instance its keypoints verified. A cup seen from the other side of its
#: wrapped logo lay 0.29 from the verified cup on stress60 (the colour cue's own 0.22 refused
#: it); the right second cups were 0.09-0.29 from the verified one.
INSTANCE_DISTANCE = 0.35


#: Notes of names given without a geometric check (by colour, grey levels or keypoint votes):
#: an object with none of them was verified by its keypoints (a detection, the closer look).
_UNVERIFIED_NOTES = ("named by colour", _GREY_NOTE, "keypoint votes")


def keypoint_verified(obj: SceneObject) -> bool:
    """Whether ``obj`` is a known object whose name a geometric check of its keypoints gave
    (a detection or the closer look), not colour, grey levels or keypoint votes alone."""
    if obj.label.startswith("unknown object"):
        return False
    return not any(m in n for n in obj.notes for m in _UNVERIFIED_NOTES)


def unlike_verified(
    obj: SceneObject, label: str, note: str, objects: Sequence[SceneObject], scene: _Scene
) -> SceneObject | None:
    """``obj`` still unknown with a note saying why, when ``label`` already has an instance
    verified by its keypoints in this scene and ``obj``'s colours (or grey levels, for a name
    by grey levels) are farther than :data:`INSTANCE_DISTANCE` from that instance's pixels;
    None when it may be named.

    (The module docstring.)
    """
    verified = [o for o in objects if o is not obj and o.label == label and keypoint_verified(o)]
    if not verified:
        return None
    grey = note.startswith(_GREY_NOTE)
    mine = _appearance(obj, scene, grey)
    theirs = [a for o in verified if (a := _appearance(o, scene, grey)) is not None]
    if mine is None or not theirs:
        return None
    d = min(float(hellinger(mine, t)) for t in theirs)
    limit = INSTANCE_DISTANCE
    if d <= limit:
        return None
    what = "grey levels" if grey else "colours"
    why = (
        f"not named {label}: its {what} are {d:.2f} from those of the {label} verified by its "
        f"keypoints in this scene (> {limit:g}): not another {label}"
    )
    return dataclasses.replace(obj, notes=(*obj.notes, why))


def _appearance(obj: SceneObject, scene: _Scene, grey: bool) -> NDArray[np.float64] | None:
    """The signature the colour cue (chromatic part, renormalised) or the grey cue (without
    the floor-like pixels) compares for ``obj``'s pixels; None when it has too few."""
    rgb, uv, _idx = _object_pixels(obj, scene.rgb, scene.camera)
    chroma = chromatic_pixels(rgb)
    if not grey:
        if int(chroma.sum()) < scene.colour.min_pixels:
            return None
        return np.asarray(_chroma(colour_signature(rgb))[0], np.float64)
    if scene.grey is None or not len(rgb):
        return None
    got = grey_pixels((uv.astype(np.intp), chroma), scene.gray(), scene.grey)
    return None if got is None else np.asarray(got[0], np.float64)
