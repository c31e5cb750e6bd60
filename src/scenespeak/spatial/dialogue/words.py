"""Words of the dialogue: direction phrases, distance words, what an unknown object looks like.

Distance words are fuzzy sets on the gap between two footprints (metres): "next to" is fully
true up to 5 cm and false from 20 cm, "near" fully true up to 25 cm and false from 60 cm, "far
from" false below 50 cm and fully true from 1 m (the table in ``docs/dialogue.md``). An object
nothing named is described by what is known of it — its size, its shape along up and its colour
when the scene has colour — ("a small red object") instead of "unknown object 7".

>>> distance_word(0.03), distance_word(0.4), distance_word(1.2)
('next to', 'near', 'far from')
>>> colour_name((200, 30, 30)), colour_name((128, 128, 128))
('red', 'grey')
"""

from __future__ import annotations

import colorsys
import re
from collections.abc import Sequence

from scenespeak.spatial.dialogue.scene import DialogueObject, DialogueScene

__all__ = [
    "DIRECTION_ANGLE",
    "OPPOSITE",
    "bare_phrase",
    "colour_name",
    "degree_of_distance",
    "describe_object",
    "display_name",
    "distance_word",
    "indefinite",
    "is_clutter",
    "join",
    "relation_phrase",
    "rename_in",
]

#: Angles of the four directions on the horizontal plane (``interfaces.md``), degrees.
DIRECTION_ANGLE = {"right": 0.0, "behind": 90.0, "left": 180.0, "front": 270.0}
OPPOSITE = {"right": "left", "left": "right", "front": "behind", "behind": "front"}

_PHRASE = {
    "left": "to the left of",
    "right": "to the right of",
    "front": "in front of",
    "behind": "behind",
    "on top of": "on top of",
    "above": "above",
    "below": "below",
    "under": "under",
    "next to": "next to",
    "near": "near",
    "far from": "far from",
}
_BARE = {"left": "to the left", "right": "to the right", "front": "in front", "behind": "behind"}

#: (fully true up to, false from) in metres of gap, for the rising words; "far from" rises.
DISTANCE_SETS = {"next to": (0.05, 0.20), "near": (0.25, 0.60), "far from": (0.50, 1.00)}


def relation_phrase(relation: str) -> str:
    """ "left" → "to the left of", "behind" → "behind", "near" → "near"."""
    return _PHRASE[relation]


def bare_phrase(direction: str) -> str:
    """ "left" → "to the left" (no referent after it)."""
    return _BARE[direction]


def degree_of_distance(word: str, gap: float) -> float:
    """Degree of truth in [0, 1] of "A is ``word`` B" for a footprint gap in metres.

    >>> round(degree_of_distance("next to", 0.1), 3), degree_of_distance("far from", 0.75)
    (0.667, 0.5)
    """
    full, zero = DISTANCE_SETS[word]
    if word == "far from":
        return min(1.0, max(0.0, (gap - full) / (zero - full)))
    if gap <= full:
        return 1.0
    return max(0.0, (zero - gap) / (zero - full))


def distance_word(gap: float) -> str:
    """The distance word that fits a gap best: "next to", "near", "far from" or ""."""
    if gap <= 0.10:
        return "next to"
    if gap <= 0.45:
        return "near"
    if gap >= 0.75:
        return "far from"
    return ""


def colour_name(rgb: Sequence[float]) -> str:
    """A basic colour term (Berlin and Kay's eleven) for a mean RGB colour, 0-255."""
    r, g, b = (max(0.0, min(255.0, float(v))) / 255.0 for v in rgb)
    h, light, s = colorsys.rgb_to_hls(r, g, b)
    if s < 0.18 or light < 0.12 or light > 0.92:
        return "black" if light < 0.2 else "white" if light > 0.8 else "grey"
    hue = h * 360.0
    if light < 0.35 and 15 <= hue < 50:
        return "brown"
    for limit, name in (
        (15, "red"),
        (40, "orange"),
        (70, "yellow"),
        (170, "green"),
        (260, "blue"),
        (300, "purple"),
        (340, "pink"),
    ):
        if hue < limit:
            return name
    return "red"


def is_clutter(obj: DialogueObject) -> bool:
    """Background clutter: an unknown cluster too sparse, too flat or too large to be a thing.

    Such clusters (a patch of floor texture, a wall far behind) stay out of the sentences;
    they are answered about only when asked for by name.
    """
    if obj.known:
        return False
    width, depth = obj.extent
    height = obj.height
    return (
        (0 < obj.points < 12)
        or (height is not None and height < 0.02)
        or max(width, depth) > 0.5
        or obj.distance > 4.0
    )


def _size_word(obj: DialogueObject) -> str:
    width, depth = obj.extent
    size = max(width, depth, obj.height or 0.0)
    if size < 0.10:
        return "small"
    if size > 0.30:
        return "large"
    return ""


def _shape_word(obj: DialogueObject) -> str:
    height = obj.height
    if height is None:
        return ""
    width = max(obj.extent)
    if height > 0.12 and height > 1.6 * width:
        return "tall"
    if height < 0.04 and width > 2.0 * height:
        return "flat"
    return ""


def describe_object(obj: DialogueObject) -> str:
    """Adjectives and a noun for an object: "small red object", "tall object", "mug".

    >>> o = DialogueObject("unknown object 1", "unknown object 1",
    ...                    ((0, 1), (0.05, 1), (0.05, 1.05), (0, 1.05)), colour=(200, 30, 30))
    >>> describe_object(o)
    'small red object'
    """
    if obj.known:
        return obj.name
    words = [_size_word(obj), _shape_word(obj)]
    if obj.colour is not None:
        words.append(colour_name(obj.colour))
    return " ".join(w for w in words if w) + (" object" if any(words) else "object")


def display_name(obj: DialogueObject, scene: DialogueScene) -> str:
    """What to call an object in a sentence: its name, or its description when unknown.

    The description is used only when no other unknown object shares it; otherwise the name
    stays ("unknown object 2") so that the listener can tell them apart.
    """
    if obj.known:
        return obj.name
    mine = describe_object(obj)
    others = [describe_object(o) for o in scene.objects if not o.known and o.name != obj.name]
    return obj.name if mine in others else mine


def rename_in(sentence: str, scene: DialogueScene) -> str:
    """Replace "the unknown object N" in a sentence by what is known of that object."""
    for obj in scene.objects:
        if obj.known:
            continue
        shown = display_name(obj, scene)
        if shown != obj.name:
            pattern = re.compile(rf"\b([Tt])he {re.escape(obj.name)}\b")
            sentence = pattern.sub(rf"\1he {shown}", sentence)
    return sentence


def indefinite(noun: str) -> str:
    """ "cup" → "a cup", "apple" → "an apple"."""
    return ("an " if noun[:1] in "aeiou" else "a ") + noun


def join(items: Sequence[str]) -> str:
    """ "a", "a and b", "a, b and c"."""
    items = list(items)
    if len(items) <= 1:
        return "".join(items)
    return ", ".join(items[:-1]) + " and " + items[-1]
