"""Whole-scene words: each object relative to the camera, the summary, the referent a person
would choose, and relation sentences with the uncertainty in them.

The camera ("me") is the referent of :func:`viewer_entries` (Skubic et al., Autonomous Robots
14(1), 2003: the robot describes objects in its own frame), computed by
:func:`scenespeak.spatial.language.describe_viewer_relation` (imported only when needed, so a
saved scene that already holds its ``viewer`` entries is answered without NumPy).

:func:`choose_referent` picks, for "where is X?", the object that makes the answer useful:

    score(R) = clarity · (0.4 + 0.6 · nearness) · (0.5 + 0.5 · salience)

with clarity = the degree of truth of the relation's primary direction (1 for "on top of",
halved when the depth error could flip it), nearness = 1 / (1 + gap / 0.25 m) and salience
= how large (√area / 15 cm, at most 1) and how surely recognised R is (unknown objects count
half). Below :data:`MIN_REFERENT_SCORE` no object helps and the camera's own frame is used.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from scenespeak.spatial.dialogue.scene import (
    DialogueObject,
    DialogueRelation,
    DialogueScene,
    hull_gap,
)
from scenespeak.spatial.dialogue.uncertainty import uncertain
from scenespeak.spatial.dialogue.words import (
    DIRECTION_ANGLE,
    display_name,
    is_clutter,
    join,
    relation_phrase,
    rename_in,
)

__all__ = [
    "MIN_REFERENT_SCORE",
    "ViewerWords",
    "bearing_deg",
    "choose_referent",
    "relation_sentence",
    "salient_objects",
    "summarize",
    "viewer_entries",
    "viewer_words",
]

#: Below this referent score, "where is X?" is answered in the camera's frame.
MIN_REFERENT_SCORE = 0.3

#: An object this many degrees off the camera's axis is "slightly to the left/right" even when
#: the viewer relation's secondary direction is too weak to be said (a person would say it).
LATERAL_DEG = 10.0


@dataclass(frozen=True)
class ViewerWords:
    """An object relative to the camera: directions in the viewer's frame (front = away)."""

    primary: str
    secondary: str | None
    sentence: str
    degree: float
    distance_m: float


def bearing_deg(obj: DialogueObject) -> float:
    """Angle of the object's centre from the camera's axis on the plane (left negative)."""
    x, y = obj.plane_centroid
    return math.degrees(math.atan2(x, y))


def salient_objects(scene: DialogueScene) -> list[DialogueObject]:
    """The objects worth talking about (no background clutter), left to right as seen."""
    return sorted((o for o in scene.objects if not is_clutter(o)), key=bearing_deg)


def viewer_words(obj: DialogueObject, scene: DialogueScene) -> ViewerWords:
    """Where the object is relative to the camera (saved ``viewer`` entry or computed)."""
    saved = scene.viewer.get(obj.name)
    if saved is not None and "primary" in saved and "sentence" in saved:
        degrees = saved.get("degrees") or {}
        return ViewerWords(
            str(saved["primary"]),
            saved.get("secondary"),
            rename_in(str(saved["sentence"]), scene),
            float(degrees.get(str(saved["primary"]), 1.0)),
            float(saved.get("distance_m", obj.distance)),
        )
    from scenespeak.spatial.language import describe_viewer_relation

    rel = describe_viewer_relation(list(obj.hull), display_name(obj, scene))
    secondary, sentence = rel.secondary, rel.sentence
    b = bearing_deg(obj)
    if rel.primary == "front" and secondary is None and abs(b) >= LATERAL_DEG:
        secondary = "left" if b < 0 else "right"
        sentence = f"{sentence.rstrip('.')}, slightly to the {secondary}."
    return ViewerWords(
        rel.primary, secondary, sentence, float(rel.degrees.get(rel.primary, 0.0)), obj.distance
    )


def viewer_entries(scene: DialogueScene) -> list[dict[str, Any]]:
    """The ``viewer`` field of ``describe --viewer``: one entry per object.

    Each entry: ``object`` (name), ``sentence``, ``primary``, ``secondary`` (viewer frame:
    ``front`` = away from the camera), ``distance_m`` (camera to centre) and ``bearing_deg``.
    """
    out = []
    for obj in scene.objects:
        w = viewer_words(obj, scene)
        out.append(
            {
                "object": obj.name,
                "sentence": w.sentence,
                "primary": w.primary,
                "secondary": w.secondary,
                "distance_m": round(w.distance_m, 4),
                "bearing_deg": round(bearing_deg(obj), 2),
            }
        )
    return out


def relation_sentence(rel: DialogueRelation, scene: DialogueScene) -> str:
    """The relation's sentence with names as displayed, and "probably" when the stereo depth
    error could change the direction ("The mug is probably behind the can.")."""
    arg = display_name(scene.object(rel.argument), scene)
    ref = display_name(scene.object(rel.referent), scene)
    if rel.vertical is None and rel.primary in DIRECTION_ANGLE and uncertain(rel, scene):
        return f"The {arg} is probably {relation_phrase(rel.primary)} the {ref}."
    return (
        rename_in(rel.sentence, scene)
        if rel.sentence
        else (f"The {arg} is {relation_phrase(rel.primary)} the {ref}.")
    )


def _clarity(rel: DialogueRelation, scene: DialogueScene) -> float:
    if rel.vertical in ("on top of", "above", "below", "under"):
        return 1.0
    if rel.primary not in DIRECTION_ANGLE:
        return 0.2
    c = rel.degree(rel.primary)
    return 0.5 * c if uncertain(rel, scene) else c


def _salience(obj: DialogueObject) -> float:
    size = min(1.0, math.sqrt(obj.area) / 0.15)
    known = 1.0 if obj.known else 0.5
    return (0.5 + 0.5 * size) * known * max(0.0, min(1.0, obj.confidence))


def choose_referent(
    obj: DialogueObject, scene: DialogueScene
) -> tuple[DialogueObject, DialogueRelation, float] | None:
    """The referent a person would pick for "where is ``obj``?" (see the module docstring), or
    None when no object scores :data:`MIN_REFERENT_SCORE` (then use the camera)."""
    best: tuple[DialogueObject, DialogueRelation, float] | None = None
    for ref in scene.objects:
        if ref.name == obj.name or is_clutter(ref):
            continue
        rel = scene.relation(obj.name, ref.name)
        if rel is None:
            continue
        near = 1.0 / (1.0 + hull_gap(obj.hull, ref.hull) / 0.25)
        score = _clarity(rel, scene) * (0.4 + 0.6 * near) * (0.5 + 0.5 * _salience(ref))
        if best is None or score > best[2]:
            best = (ref, rel, score)
    if best is None or best[2] < MIN_REFERENT_SCORE:
        return None
    return best


def _said_pairs(order: Sequence[DialogueObject], scene: DialogueScene) -> list[DialogueRelation]:
    chosen: list[DialogueRelation] = []
    said: set[frozenset[str]] = set()
    for obj in order:
        ref = choose_referent(obj, scene)
        if ref is None:
            continue
        pair = frozenset((obj.name, ref[0].name))
        if pair in said:
            continue
        said.add(pair)
        chosen.append(ref[1])
    return chosen


def summarize(scene: DialogueScene) -> str:
    """At most n + 1 sentences about the scene, every (non-clutter) object in the first.

    The first sentence names the objects from left to right as the camera sees them; then, for
    each object in that order, the relation to the referent a person would choose
    (:func:`choose_referent`), skipping a pair already said the other way round.

    >>> from scenespeak.spatial.dialogue.scene import scene_from_dict
    >>> summarize(scene_from_dict({"objects": [], "relations": []}))
    'I see nothing I can describe.'
    """
    order = salient_objects(scene)
    if not order:
        return "I see nothing I can describe."
    names = [f"the {display_name(o, scene)}" for o in order]
    if len(order) == 1:
        return f"I see only {names[0]}; it is {order[0].distance:.1f} m from me."
    sentences = [f"From left to right I see {join(names)}."]
    sentences += [relation_sentence(rel, scene) for rel in _said_pairs(order, scene)]
    return " ".join(sentences)
