"""The words: sentence patterns, phrases and the rendering of a decision into a sentence.

Every phrase is written out whole, so no combination can glue into "to the behind".
"""

from __future__ import annotations

from dataclasses import dataclass

from scenespeak.errors import InputError

__all__ = ["COMPOUND_WORDS", "OBJECT_PATTERNS", "VERTICAL_WORDS", "VIEWER_PATTERNS"]


#: Sentence patterns for a relation between two objects.
OBJECT_PATTERNS: dict[str, str] = {
    "direction": "The {argument} is {hedge}{primary} the {referent}.",
    "direction+secondary": (
        "The {argument} is {hedge}{primary} the {referent} but {secondary_hedge} {secondary}."
    ),
    "direction+extends": (
        "The {argument} is {hedge}{primary} the {referent} but extends {extends} "
        "relative to the {referent}."
    ),
    "compound": "The {argument} is {compound} the {referent}.",
    "surrounded": "The {argument} is surrounded by the {referent}.",
    "partly surrounded": "The {argument} is partly surrounded by the {referent}.",
    "surrounds": "The {argument} surrounds the {referent}.",
    "partly surrounds": "The {argument} partly surrounds the {referent}.",
    "vertical": "The {argument} is {vertical} the {referent}.",
}
#: Sentence patterns with the viewer (camera / robot) as the referent.
VIEWER_PATTERNS: dict[str, str] = {
    "direction": "The {argument} is {hedge}{primary}.",
    "direction+secondary": "The {argument} is {hedge}{primary}, {secondary_hedge} {secondary}.",
    "direction+extends": "The {argument} is {hedge}{primary} but extends {extends}.",
    "compound": "The {argument} is {compound}.",
    "surrounded": "The {argument} is right where I am.",
    "partly surrounded": "The {argument} is partly where I am.",
    "surrounds": "The {argument} is all around me.",
    "partly surrounds": "The {argument} is partly around me.",
    "vertical": "The {argument} is {vertical} me.",
}
_PHRASES: dict[str, dict[str, dict[str, str]]] = {
    "object": {
        "primary": {
            "left": "to the left of",
            "right": "to the right of",
            "front": "in front of",
            "behind": "behind",
        },
        "secondary": {
            "left": "to the left",
            "right": "to the right",
            "front": "to the front",
            "behind": "behind",
        },
        "extends": {
            "left": "to the left",
            "right": "to the right",
            "front": "to the front",
            "behind": "to the rear",
        },
    },
    "viewer": {
        "primary": {
            "left": "to my left",
            "right": "to my right",
            "front": "in front of me",
            "behind": "behind me",
        },
        "secondary": {
            "left": "to the left",
            "right": "to the right",
            "front": "farther ahead",
            "behind": "nearer",
        },
        "extends": {
            "left": "to the left",
            "right": "to the right",
            "front": "farther ahead",
            "behind": "towards me",
        },
    },
}
#: Compound words, keyed by (front/behind, left/right), for each frame.
COMPOUND_WORDS: dict[str, dict[tuple[str, str], str]] = {
    "object": {
        ("front", "left"): "front-left of",
        ("front", "right"): "front-right of",
        ("behind", "left"): "rear-left of",
        ("behind", "right"): "rear-right of",
    },
    "viewer": {
        ("front", "left"): "in front of me and to the left",
        ("front", "right"): "in front of me and to the right",
        ("behind", "left"): "behind me and to the left",
        ("behind", "right"): "behind me and to the right",
    },
}
#: The vertical relations, and the converse of each (A on top of B ⇔ B under A).
VERTICAL_WORDS: dict[str, str] = {
    "on top of": "under",
    "above": "below",
    "under": "on top of",
    "below": "above",
}
_HEDGE_WORDS = {"directly": "directly ", "mostly": "mostly ", "loosely": "loosely ", None: ""}


@dataclass(frozen=True)
class _Decision:
    kind: str
    primary: str
    secondary: str | None
    hedge: str | None
    secondary_hedge: str | None
    confidence: float
    deviation: float
    coverage: float
    extends_share: float


def _render(
    decision: _Decision, argument: str, referent: str, frame: str, vertical: str | None = None
) -> str:
    patterns = OBJECT_PATTERNS if frame == "object" else VIEWER_PATTERNS
    phrases = _PHRASES[frame]
    if vertical is not None:
        return patterns["vertical"].format(argument=argument, referent=referent, vertical=vertical)
    if decision.kind in ("surrounded", "partly surrounded", "surrounds", "partly surrounds"):
        return patterns[decision.kind].format(argument=argument, referent=referent)
    if decision.kind == "compound":
        assert decision.secondary is not None
        word = COMPOUND_WORDS[frame][(decision.primary, decision.secondary)]
        return patterns["compound"].format(argument=argument, referent=referent, compound=word)
    values = {
        "argument": argument,
        "referent": referent,
        "hedge": _HEDGE_WORDS[decision.hedge],
        "primary": phrases["primary"][decision.primary],
    }
    if decision.secondary is None:
        return patterns["direction"].format(**values)
    if decision.secondary_hedge == "extends":
        return patterns["direction+extends"].format(
            **values, extends=phrases["extends"][decision.secondary]
        )
    return patterns["direction+secondary"].format(
        **values,
        secondary_hedge=decision.secondary_hedge,
        secondary=phrases["secondary"][decision.secondary],
    )


def _label(name: object, what: str) -> str:
    if not isinstance(name, str) or not name.strip():
        raise InputError(what, f"must be a non-empty label, got {name!r}")
    return name.strip()
