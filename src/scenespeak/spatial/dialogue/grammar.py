"""A small grammar of spatial questions: text → :class:`Query` (no network, no language model).

Normalisation strips what carries no meaning here — polite wrappers ("can you tell me",
"could you please say", "I'd like to know", "please"), a call to the robot ("hey robot,"),
embedded word order ("… where the mug is" → "where is the mug") and "if/whether" clauses —
then a handful of patterns, tried in order, recognise the forms of issue 13:

=========================  ==============================================================
form                       examples
=========================  ==============================================================
``see``                    what do you see? · what is there? · describe the scene
``count``                  how many objects do you see?
``where``                  where is the mug? · where are the mugs? · find the can
``distance``               how far is the mug from the can? · how far away is the box?
``yes-no``                 is the mug to the left of / behind / on top of / near the can?
``between``                is the mug between the can and the box?
``what-between``           what is between the can and the box?
``what``                   what is to the left of the can? · is there anything behind me?
``superlative``            which object is closest to me? · what is the leftmost object?
``about``                  tell me about the mug · what is the unknown object 2?
=========================  ==============================================================

Noun phrases stay text here; :mod:`~scenespeak.spatial.dialogue.answers` resolves them against
the scene's names. "me", "you", "the camera" and "the robot" all mean the camera: the person is
taken to stand at the robot (it has no other viewpoint).

>>> parse("Could you please tell me where the mug is?")
Query(form='where', relation=None, phrases=('the mug',), superlative=None)
>>> parse("is the left mug on top of the can").relation
'on top of'
>>> parse("sing me a song").form
'unparsed'
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass

__all__ = ["RELATION_WORDS", "Query", "normalise", "parse"]

#: Phrases people use → the relation they mean.
RELATION_WORDS: dict[str, str] = {
    "to the left of": "left",
    "on the left of": "left",
    "on the left side of": "left",
    "to the left side of": "left",
    "left of": "left",
    "to the right of": "right",
    "on the right of": "right",
    "on the right side of": "right",
    "to the right side of": "right",
    "right of": "right",
    "behind": "behind",
    "in back of": "behind",
    "at the back of": "behind",
    "beyond": "behind",
    "farther away than": "behind",
    "farther than": "behind",
    "further than": "behind",
    "in front of": "front",
    "before": "front",
    "nearer than": "front",
    "closer than": "front",
    "on top of": "on top of",
    "sitting on": "on top of",
    "standing on": "on top of",
    "upon": "on top of",
    "on": "on top of",
    "above": "above",
    "over": "above",
    "below": "below",
    "under": "below",
    "underneath": "below",
    "beneath": "below",
    "next to": "next to",
    "beside": "next to",
    "alongside": "next to",
    "adjacent to": "next to",
    "by": "next to",
    "near to": "near",
    "near": "near",
    "close to": "near",
    "far away from": "far from",
    "far from": "far from",
    "a long way from": "far from",
}
_REL = "|".join(re.escape(k) for k in sorted(RELATION_WORDS, key=len, reverse=True))
_WH = r"(?:what|which|which (?:object|objects|thing|things|one|ones))"
_BE = r"(?:is|are|'s|lies|sits|stands)"

_POLITE = re.compile(
    r"^(?:(?:hey|hi|hello|ok|okay|so|um|excuse me|sorry)[, ]+)?(?:robot[, ]+)?"
    r"(?:please[, ]+)?"
    r"(?:(?:can|could|would|will) you(?: please)?(?: kindly)? (?:tell me|say|let me know|show me)"
    r"|(?:please )?tell me|do you know|i(?: would|'d) like to know|i want to know|i wonder"
    r"|let me know|please say)?[, ]*"
)
_IF = re.compile(r"^(?:if|whether) (.+?) (is|are) (.+)$")
_EMBEDDED = re.compile(r"^(where|what|which(?: \w+)?) (.+) (is|are)$")

_PATTERNS: tuple[tuple[str, re.Pattern[str]], ...] = tuple(
    (form, re.compile(p))
    for form, p in (
        (
            "see",
            r"^(?:what (?:do|can) you see|what (?:objects|things) (?:do you see|can you see|are "
            r"there)|what(?: is|'s) (?:there|here|around|in the scene|in front of you)"
            r"|describe (?:the scene|what you see|everything)|what(?: is|'s) in (?:the|this) "
            r"(?:scene|picture|image))$",
        ),
        ("count", r"^how many (?:objects|things)(?: (?:do|can) you see| are there)?$"),
        ("where", r"^(?:where (?:is|are)|where's|where can i find|find|locate|show me) (.+)$"),
        (
            "distance",
            r"^how far(?: away)? (?:is|are) (.+?)(?: (?:from|to) (.+?))?(?: away)?$",
        ),
        ("distance", r"^what(?: is|'s) the distance (?:between|from) (.+?) (?:and|to) (.+)$"),
        (
            "what",
            rf"^(?:is there anything|is there something|is anything|are there any (?:objects|"
            rf"things)) ({_REL}) (.+)$",
        ),
        ("between", r"^(?:is|are) (.+?) between (.+?) and (.+)$"),
        ("yes-no", rf"^(?:is|are) (.+?) ({_REL}) (.+)$"),
        ("what-between", rf"^{_WH} {_BE} between (.+?) and (.+)$"),
        (
            "superlative",
            rf"^{_WH}(?: {_BE})?(?: the)? (closest|nearest|farthest|furthest)"
            r"(?: (?:object|one|thing))?(?: (?:to|from) (.+))?$",
        ),
        (
            "superlative",
            rf"^{_WH}(?: {_BE})?(?: the)? (leftmost|rightmost|nearest|closest|farthest|furthest)"
            r"(?: (?:object|one|thing))?$",
        ),
        (
            "superlative",
            rf"^{_WH} {_BE} (?:on the far|furthest to the|farthest to the|most to the) "
            r"(left|right)$",
        ),
        ("what", rf"^{_WH}(?: {_BE})? (?:on|to) (?:my|your|the) (left|right)$"),
        ("what", rf"^{_WH}(?: {_BE})? (behind|in front of) (?:me|you)$"),
        (
            "what",
            rf"^(?:{_WH}(?: {_BE})?|anything) ({_REL}) (.+)$",
        ),
        ("about", r"^(?:tell me about|about|describe|what about|what(?: is|'s)|who is) (.+)$"),
    )
)


@dataclass(frozen=True)
class Query:
    """A parsed question.

    Attributes
    ----------
    form : str
        One of the forms above, or ``"unparsed"``.
    relation : str or None
        The relation asked about ("left", "on top of", "near", ...).
    phrases : tuple of str
        The noun phrases, in order (argument first, then referents).
    superlative : str or None
        "closest", "farthest", "leftmost" or "rightmost".
    """

    form: str
    relation: str | None = None
    phrases: tuple[str, ...] = ()
    superlative: str | None = None


def normalise(question: str) -> str:
    """Lower-case, plain spaces, no end punctuation, no polite wrapper, plain word order.

    >>> normalise("  Hey robot, can you tell me if the Mug is near the can, please?! ")
    'is the mug near the can'
    """
    q = question.replace("\u2019", "'").replace("\u2018", "'").lower()
    q = re.sub(r"[?!.;:\"]+", " ", q)
    q = re.sub(r"\s+", " ", q).strip(" ,")
    q = re.sub(r"(?:,? please)+$", "", q).strip(" ,")
    q = _POLITE.sub("", q, count=1).strip(" ,")
    m = _IF.match(q)
    if m:
        q = f"{m.group(2)} {m.group(1)} {m.group(3)}"
    m = _EMBEDDED.match(q)
    if m and not re.match(rf"^{_WH} {_BE}\b", q):
        q = f"{m.group(1)} {m.group(3)} {m.group(2)}"
    return q


_SUPERLATIVE = {"nearest": "closest", "furthest": "farthest", "left": "leftmost"}


def _query(form: str, groups: tuple[str | None, ...]) -> Query:
    g = [x.strip() for x in groups if x is not None]
    if form in ("yes-no", "what") and len(g) >= 2:
        rel_index = 1 if form == "yes-no" else 0
        rel_text = g[rel_index]
        relation = RELATION_WORDS.get(rel_text) or {
            "left": "left",
            "right": "right",
            "in front of": "front",
            "behind": "behind",
        }.get(rel_text)
        phrases = tuple(x for k, x in enumerate(g) if k != rel_index)
        return Query(form, relation, phrases or ("me",))
    if form == "what" and len(g) == 1:  # "what is on my left"
        relation = {"in front of": "front"}.get(g[0], g[0])
        return Query(form, relation, ("me",))
    if form == "superlative":
        word = _SUPERLATIVE.get(g[0], g[0])
        word = {"right": "rightmost"}.get(word, word)
        return Query(form, None, tuple(g[1:]) or ("me",), word)
    return Query(form, None, tuple(g))


def parse(question: str, names: Sequence[str] = ()) -> Query:
    """Parse a question into a :class:`Query` (form ``"unparsed"`` when nothing fits).

    ``names`` are the scene's object names: a name that holds a relation word ("mug near the
    can", the name :mod:`scenespeak.spatial.naming` gives one of two mugs) is kept whole.

    >>> parse("is the mug near the can behind the box?", ["mug near the can", "box"]).phrases
    ('the mug near the can', 'the box')
    """
    q = normalise(question)
    held: dict[str, str] = {}
    for k, name in enumerate(sorted((n.lower() for n in names if " " in n), key=len, reverse=True)):
        token = f"\x00{k}\x00"
        if re.search(rf"\b{re.escape(name)}\b", q):
            q = re.sub(rf"\b{re.escape(name)}\b", token, q)
            held[token] = name
    for form, pattern in _PATTERNS:
        m = pattern.match(q)
        if m:
            query = _query(form, m.groups())
            if held:
                phrases = []
                for p in query.phrases:
                    for token, name in held.items():
                        p = p.replace(token, name)
                    phrases.append(p)
                query = Query(query.form, query.relation, tuple(phrases), query.superlative)
            return query
    return Query("unparsed")
