"""The words of a relation in the image plane: left / right / above / below "in the picture".

Without depth the Histogram of Forces runs on the objects' regions in the image (x = column,
y = image up), and the same rule base decides; only the words change: the direction the
horizontal plane calls "behind" (+y) is "above" in the picture, "in front of" (-y) is "below",
and every sentence says "in the picture" (a person reading it knows it is not the room's left
of the camera's depth). ``primary`` and ``secondary`` become ``"above"`` / ``"below"`` for the
vertical directions; the degrees keep their four keys (``"behind"`` = above, ``"front"`` =
below).

>>> import numpy as np
>>> from scenespeak.spatial.language import relate
>>> sq = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]])
>>> in_picture(relate(sq + [0, 40], sq, argument="lamp", referent="desk")).sentence
'The lamp is directly above the desk in the picture.'
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

__all__ = ["PICTURE_WORDS", "in_picture"]

#: The image plane's name of each horizontal-plane direction.
PICTURE_WORDS: dict[str, str] = {
    "left": "left",
    "right": "right",
    "behind": "above",
    "front": "below",
}

_PRIMARY = {
    "left": "to the left of",
    "right": "to the right of",
    "behind": "above",
    "front": "below",
}
_SECONDARY = {"left": "to the left", "right": "to the right", "behind": "higher", "front": "lower"}
_EXTENDS = {
    "left": "to the left",
    "right": "to the right",
    "behind": "upwards",
    "front": "downwards",
}
_COMPOUND = {
    ("front", "left"): "below and to the left of",
    ("front", "right"): "below and to the right of",
    ("behind", "left"): "above and to the left of",
    ("behind", "right"): "above and to the right of",
}
_HEDGE = {"directly": "directly ", "mostly": "mostly ", "loosely": "loosely ", None: ""}
_SURROUND = {
    "surrounded": "The {a} is surrounded by the {r} in the picture.",
    "partly surrounded": "The {a} is partly surrounded by the {r} in the picture.",
    "surrounds": "The {a} surrounds the {r} in the picture.",
    "partly surrounds": "The {a} partly surrounds the {r} in the picture.",
}


def _sentence(rel: Any) -> str:
    a, r = rel.argument, rel.referent
    if rel.kind in _SURROUND:
        return _SURROUND[rel.kind].format(a=a, r=r)
    if rel.kind == "compound" and (rel.primary, rel.secondary) in _COMPOUND:
        return f"The {a} is {_COMPOUND[(rel.primary, rel.secondary)]} the {r} in the picture."
    head = f"The {a} is {_HEDGE.get(rel.hedge, '')}{_PRIMARY[rel.primary]} the {r}"
    if rel.secondary is None:
        return head + " in the picture."
    if rel.secondary_hedge == "extends":
        return f"{head} but extends {_EXTENDS[rel.secondary]} in the picture."
    return f"{head} but {rel.secondary_hedge} {_SECONDARY[rel.secondary]} in the picture."


def in_picture(rel: Any) -> Any:
    """A :class:`~scenespeak.spatial.language.Relation` of image-plane regions, in its words.

    The relation must come from hulls in the contract's image frame (x = column, y = image
    up) and carry no vertical relation (there are no heights in a picture).

    Examples
    --------
    >>> import numpy as np
    >>> from scenespeak.spatial.language import relate
    >>> sq = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]])
    >>> rel = in_picture(relate(sq - [30, 15], sq, argument="cup", referent="book"))
    >>> rel.primary, rel.secondary
    ('left', 'below')
    >>> rel.sentence
    'The cup is mostly to the left of the book but slightly lower in the picture.'
    """
    if rel.primary not in _PRIMARY:  # "surrounded": no direction to rename
        sentence = _sentence(rel)
        return replace(rel, sentence=sentence, horizontal_sentence=sentence)
    sentence = _sentence(rel)
    return replace(
        rel,
        primary=PICTURE_WORDS[rel.primary],
        secondary=None if rel.secondary is None else PICTURE_WORDS[rel.secondary],
        sentence=sentence,
        horizontal_sentence=sentence,
        vertical=None,
    )
