"""Answers to questions about a scene: :func:`ask`.

Each form of :mod:`~scenespeak.spatial.dialogue.grammar` has one small answering function.
Yes/no answers are graded by the degree of truth ``d`` of the asked relation (for a direction,
the mean of F0's and F2's degrees, ``docs/language.md``):

- ``d ≥ 0.8``: "Yes."
- the asked direction is the primary one but ``d < 0.8``: "Mostly — …" with the rest;
- another direction wins but ``d ≥ 0.3``: "Partly — it is more behind than to the left of …";
- otherwise "No, it is to the right of the can.";

and say "probably" where the stereo depth error could flip the relation
(:mod:`~scenespeak.spatial.dialogue.uncertainty`). A question that does not parse, or names
something the scene does not hold, gets a plain answer saying so (kind ``"unknown"``).

>>> from scenespeak.spatial.dialogue.scene import scene_from_dict
>>> sq = [[0.0, 1.0], [0.1, 1.0], [0.1, 1.1], [0.0, 1.1]]
>>> scene = scene_from_dict({"objects": [{"label": "mug", "hull": sq}], "relations": []})
>>> ask("Where is the cup?", scene).answer
"I don't see a cup."
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from scenespeak.spatial.dialogue.grammar import Query, parse
from scenespeak.spatial.dialogue.resolve import Reference, resolve
from scenespeak.spatial.dialogue.scene import (
    DialogueObject,
    DialogueRelation,
    DialogueScene,
    hull_gap,
    scene_from,
)
from scenespeak.spatial.dialogue.uncertainty import relation_confidence, uncertain
from scenespeak.spatial.dialogue.views import (
    bearing_deg,
    choose_referent,
    relation_sentence,
    salient_objects,
    viewer_words,
)
from scenespeak.spatial.dialogue.words import (
    DIRECTION_ANGLE,
    bare_phrase,
    degree_of_distance,
    describe_object,
    display_name,
    distance_word,
    indefinite,
    join,
    relation_phrase,
)

__all__ = ["KINDS", "Answer", "ask"]

KINDS = ("where", "yes-no", "which", "unknown")
_HELP = (
    'I can answer questions like "where is the mug?", "is the mug to the left of the can?", '
    '"what is near the can?", "which object is closest to me?" or "what do you see?".'
)
_VERTICAL = {
    "on top of": ("on top of",),
    "above": ("on top of", "above"),
    "below": ("below", "under"),
}


@dataclass(frozen=True)
class Answer:
    """An answer, as ``scenespeak ask --format json`` prints it (``interfaces.md``).

    Attributes
    ----------
    question : str
        The question as asked.
    answer : str
        One or two sentences.
    kind : {"where", "yes-no", "which", "unknown"}
    degree : float or None
        The degree of truth in [0, 1] of a yes/no question's relation.
    objects : tuple of str
        Names of the objects the answer is about (not "me").
    confidence : float or None
        Calibrated probability that the direction the answer rests on is right.
    distance_m : float or None
        The distance the answer states (gap between footprints, or camera to object).
    """

    question: str
    answer: str
    kind: str
    degree: float | None = None
    objects: tuple[str, ...] = ()
    confidence: float | None = None
    distance_m: float | None = None

    def to_dict(self) -> dict[str, Any]:
        """``{"question", "answer", "kind", "degree", "objects"}`` plus ``confidence`` and
        ``distance_m`` when the answer has them."""
        out: dict[str, Any] = {
            "question": self.question,
            "answer": self.answer,
            "kind": self.kind,
            "degree": None if self.degree is None else round(float(self.degree), 4),
            "objects": list(self.objects),
        }
        if self.confidence is not None:
            out["confidence"] = round(float(self.confidence), 4)
        if self.distance_m is not None:
            out["distance_m"] = round(float(self.distance_m), 4)
        return out


class _Refusal(Exception):
    """Raised inside an answering function when the honest answer is that it cannot."""

    def __init__(self, answer: str, objects: tuple[str, ...] = ()) -> None:
        super().__init__(answer)
        self.answer = answer
        self.objects = objects


def _metres(m: float) -> str:
    return f"{round(m * 100):d} cm" if m < 1.0 else f"{m:.1f} m"


def _one(phrase: str, scene: DialogueScene, allow_me: bool = False) -> DialogueObject | None:
    """The single object a phrase names; None for "me" (when allowed); else a refusal."""
    ref = resolve(phrase, scene)
    if ref.status == "me" and allow_me:
        return None
    if ref.status == "one":
        return ref.one
    _refuse(ref)
    raise AssertionError("unreachable")  # pragma: no cover


def _refuse(ref: Reference) -> None:
    if ref.status == "missing":
        what = f"any {ref.text}" if ref.plural else indefinite(ref.text)
        raise _Refusal(f"I don't see {what}.")
    if ref.status in ("ambiguous", "many"):
        names = join([f"the {o.name}" for o in ref.objects])
        raise _Refusal(
            f"Which {ref.text} do you mean? I see {names}.", tuple(o.name for o in ref.objects)
        )
    raise _Refusal("I can only answer that about the objects I see, not about myself.")


def _name(obj: DialogueObject, scene: DialogueScene) -> str:
    return display_name(obj, scene)


def _cap(s: str) -> str:
    return s[:1].upper() + s[1:]


# --------------------------------------------------------------------------------------------
# where


def _where_one(obj: DialogueObject, scene: DialogueScene) -> tuple[str, Answer]:
    """(first sentence, whole answer) of "where is ``obj``?"."""
    chosen = choose_referent(obj, scene)
    if chosen is None:
        w = viewer_words(obj, scene)
        text = f"{w.sentence} It is {_metres(w.distance_m)} away."
        return w.sentence, Answer("", text, "where", None, (obj.name,), None, w.distance_m)
    ref, rel, _ = chosen
    gap = hull_gap(obj.hull, ref.hull)
    word = distance_word(gap)
    rname = _name(ref, scene)
    if rel.vertical is not None:
        second = f"It is {_metres(obj.distance)} from me."
    elif gap < 0.01:
        second = f"It touches the {rname}, {_metres(obj.distance)} from me."
    elif word in ("next to", "near"):
        second = (
            f"It is {word} the {rname} ({_metres(gap)} apart), {_metres(obj.distance)} from me."
        )
    else:
        second = f"It is {_metres(gap)} from the {rname} and {_metres(obj.distance)} from me."
    first = relation_sentence(rel, scene)
    conf = relation_confidence(rel, scene)
    return first, Answer("", f"{first} {second}", "where", None, (obj.name, ref.name), conf, gap)


def _where(q: Query, scene: DialogueScene) -> Answer:
    ref = resolve(q.phrases[0], scene)
    if ref.status == "me":
        return Answer("", "I am the camera: everything I describe is relative to me.", "where")
    if ref.status == "many":
        parts = [_where_one(o, scene) for o in ref.objects]
        names = tuple(n for _, a in parts for n in a.objects)
        return Answer("", " ".join(first for first, _ in parts), "where", None, names)
    if ref.status != "one":
        _refuse(ref)
    return _where_one(ref.one, scene)[1]


def _distance(q: Query, scene: DialogueScene) -> Answer:
    a = _one(q.phrases[0], scene)
    assert a is not None
    b = _one(q.phrases[1], scene, allow_me=True) if len(q.phrases) > 1 else None
    if b is None:
        text = f"The {_name(a, scene)} is {_metres(a.distance)} from me."
        return Answer("", text, "where", None, (a.name,), None, a.distance)
    gap = hull_gap(a.hull, b.hull)
    word = distance_word(gap)
    extra = f" ({word} it)" if word else ""
    text = f"The {_name(a, scene)} is {_metres(gap)} from the {_name(b, scene)}{extra}."
    return Answer("", text, "where", None, (a.name, b.name), None, gap)


# --------------------------------------------------------------------------------------------
# yes / no


def _graded(rel: DialogueRelation, asked: str, scene: DialogueScene) -> tuple[str, float]:
    d = rel.degree(asked)
    ref = _name(scene.object(rel.referent), scene)
    p = rel.primary
    probably = uncertain(rel, scene)
    if p not in DIRECTION_ANGLE:  # surrounded
        return (
            f"Partly — {_lower(relation_sentence(rel, scene))}"
            if d >= 0.3
            else f"No — {_lower(relation_sentence(rel, scene))}"
        ), d
    if d >= 0.8:
        return ("Probably yes." if probably else "Yes."), d
    if p == asked or (rel.kind == "compound" and asked == rel.secondary and d >= 0.3):
        rest = _lower(relation_sentence(rel, scene))
        return f"{'Probably, mostly' if probably else 'Mostly'} — {rest}", d
    if d >= 0.3:
        more = bare_phrase(p) if p != "behind" else "behind"
        return (
            f"Partly — it is more {more} than {relation_phrase(asked)} the {ref}.",
            d,
        )
    hedge = "probably " if probably else ""
    if rel.kind == "compound" and rel.secondary is not None:
        side = {"front": "front", "behind": "rear"}[p]
        return f"No, it is {hedge}{side}-{rel.secondary} of the {ref}.", d
    return f"No, it is {hedge}{relation_phrase(p)} the {ref}.", d


def _lower(sentence: str) -> str:
    """ "The mug is ..." → "the mug is ..." for use after a dash."""
    return sentence[:1].lower() + sentence[1:]


def _yes_no_viewer(obj: DialogueObject, asked: str, scene: DialogueScene) -> Answer:
    name = _name(obj, scene)
    if asked in ("next to", "near", "far from"):
        d = degree_of_distance(asked, obj.distance)
        word = "Yes" if d >= 0.5 else "No"
        text = f"{word}, the {name} is {_metres(obj.distance)} from me."
        return Answer("", text, "yes-no", d, (obj.name,), None, obj.distance)
    b = bearing_deg(obj)
    side = {"left": -b, "right": b, "front": 90.0 - abs(b), "behind": abs(b) - 90.0}
    if asked not in side:
        raise _Refusal(f"I cannot tell whether the {name} is {relation_phrase(asked)} me.")
    d = (
        max(0.0, min(1.0, side[asked] / 30.0))
        if asked in ("left", "right")
        else (1.0 if side[asked] > 0 else 0.0)
    )
    w = viewer_words(obj, scene)
    lead = "Yes." if d >= 0.8 else "Partly." if d >= 0.3 else "No."
    return Answer("", f"{lead} {w.sentence}", "yes-no", d, (obj.name,), None, obj.distance)


def _yes_no(q: Query, scene: DialogueScene) -> Answer:
    a = _one(q.phrases[0], scene)
    assert a is not None and q.relation is not None
    b = _one(q.phrases[1], scene, allow_me=True)
    if b is None:
        return _yes_no_viewer(a, q.relation, scene)
    if a.name == b.name:
        raise _Refusal("That is one and the same object.", (a.name,))
    names = (a.name, b.name)
    if q.relation in ("next to", "near", "far from"):
        gap = hull_gap(a.hull, b.hull)
        d = degree_of_distance(q.relation, gap)
        lead = "Yes" if d >= 0.8 else "Fairly" if d >= 0.3 else "No"
        text = f"{lead}, they are {_metres(gap)} apart."
        return Answer("", text, "yes-no", d, names, None, gap)
    rel = scene.relation(a.name, b.name)
    if rel is None:
        raise _Refusal(f"I could not relate the {_name(a, scene)} to the {_name(b, scene)}.", names)
    conf = relation_confidence(rel, scene)
    if q.relation in _VERTICAL:
        yes = rel.vertical in _VERTICAL[q.relation]
        text = "Yes." if yes else f"No — {_lower(relation_sentence(rel, scene))}"
        return Answer("", text, "yes-no", 1.0 if yes else 0.0, names, conf)
    text, d = _graded(rel, q.relation, scene)
    return Answer("", text, "yes-no", d, names, conf)


def between_degree(a: DialogueObject, b: DialogueObject, c: DialogueObject) -> float:
    """Degree to which ``a`` lies between ``b`` and ``c``: 1 when the directions from ``a`` to
    them are opposite, falling to 0 when they are 60° from opposite (angle ≤ 120°)."""
    ax, ay = a.plane_centroid
    bx, by = b.plane_centroid
    cx, cy = c.plane_centroid
    u, v = (bx - ax, by - ay), (cx - ax, cy - ay)
    nu, nv = math.hypot(*u), math.hypot(*v)
    if nu == 0 or nv == 0:
        return 1.0
    cos = (u[0] * v[0] + u[1] * v[1]) / (nu * nv)
    angle = math.degrees(math.acos(max(-1.0, min(1.0, cos))))
    return max(0.0, min(1.0, (angle - 120.0) / 60.0))


def _between(q: Query, scene: DialogueScene) -> Answer:
    a, b, c = (_one(p, scene) for p in q.phrases[:3])
    assert a is not None and b is not None and c is not None
    d = between_degree(a, b, c)
    lead = "Yes." if d >= 0.8 else "Roughly." if d >= 0.3 else "No."
    text = f"{lead} The {_name(a, scene)} is {_metres(a.distance)} from me; " + (
        f"the {_name(b, scene)} and the {_name(c, scene)} are on either side of it."
        if d >= 0.3
        else f"the {_name(b, scene)} and the {_name(c, scene)} are on the same side of it."
    )
    return Answer("", text, "yes-no", d, (a.name, b.name, c.name))


def _what_between(q: Query, scene: DialogueScene) -> Answer:
    b, c = (_one(p, scene) for p in q.phrases[:2])
    assert b is not None and c is not None
    found = [
        (between_degree(o, b, c), o)
        for o in salient_objects(scene)
        if o.name not in (b.name, c.name)
    ]
    hits = [o for d, o in sorted(found, key=lambda t: -t[0]) if d >= 0.5]
    ends = f"the {_name(b, scene)} and the {_name(c, scene)}"
    if not hits:
        return Answer("", f"Nothing is between {ends}.", "which", None, (b.name, c.name))
    names = join([f"the {_name(o, scene)}" for o in hits])
    verb = "is" if len(hits) == 1 else "are"
    return Answer(
        "", _cap(f"{names} {verb} between {ends}."), "which", None, tuple(o.name for o in hits)
    )


# --------------------------------------------------------------------------------------------
# which / what


def _matches(
    obj: DialogueObject, relation: str, ref: DialogueObject, scene: DialogueScene
) -> float:
    if relation in ("next to", "near", "far from"):
        return degree_of_distance(relation, hull_gap(obj.hull, ref.hull))
    rel = scene.relation(obj.name, ref.name)
    if rel is None:
        return 0.0
    if relation in _VERTICAL:
        return 1.0 if rel.vertical in _VERTICAL[relation] else 0.0
    return rel.degree(relation) if (rel.primary == relation or rel.degree(relation) >= 0.5) else 0.0


def _what(q: Query, scene: DialogueScene) -> Answer:
    assert q.relation is not None
    ref = _one(q.phrases[0], scene, allow_me=True)
    candidates = [o for o in salient_objects(scene) if ref is None or o.name != ref.name]
    if ref is None:
        hits, where = _what_of_me(q.relation, candidates)
    else:
        hits, where = _what_of(q.relation, ref, candidates, scene)
    about = () if ref is None else (ref.name,)
    if not hits:
        return Answer("", f"Nothing is {where}.", "which", None, about)
    names = join([f"the {_name(o, scene)}" for o in hits])
    verb = "is" if len(hits) == 1 else "are"
    return Answer("", _cap(f"{names} {verb} {where}."), "which", None, tuple(o.name for o in hits))


def _what_of_me(
    relation: str, candidates: list[DialogueObject]
) -> tuple[list[DialogueObject], str]:
    """The objects in ``relation`` to the viewer ("what is on my left?") and the phrase for it."""
    side = {"left": lambda o: bearing_deg(o) < -5, "right": lambda o: bearing_deg(o) > 5}
    test: Callable[[DialogueObject], bool] = side.get(relation, lambda o: relation == "front")
    hits = [o for o in candidates if test(o)]
    where = {"left": "on my left", "right": "on my right", "front": "in front of me"}.get(
        relation, f"{relation_phrase(relation)} me"
    )
    return hits, where


def _what_of(
    relation: str, ref: DialogueObject, candidates: list[DialogueObject], scene: DialogueScene
) -> tuple[list[DialogueObject], str]:
    """The objects in ``relation`` to ``ref``, best first, and the phrase for it."""
    scored = sorted(
        ((_matches(o, relation, ref, scene), o) for o in candidates), key=lambda t: -t[0]
    )
    hits = [o for d, o in scored if d >= 0.5]
    return hits, f"{relation_phrase(relation)} the {_name(ref, scene)}"


def _superlative(q: Query, scene: DialogueScene) -> Answer:
    word = q.superlative or "closest"
    ref = _one(q.phrases[0], scene, allow_me=True) if q.phrases else None
    candidates = [o for o in salient_objects(scene) if ref is None or o.name != ref.name]
    if not candidates:
        return Answer("", "I see nothing to compare.", "which")
    if word in ("leftmost", "rightmost"):
        best = (min if word == "leftmost" else max)(candidates, key=bearing_deg)
        side = "left" if word == "leftmost" else "right"
        text = f"The {_name(best, scene)} is the one farthest to the {side}, as I see it."
        return Answer("", text, "which", None, (best.name,), None, best.distance)
    if ref is None:

        def key(o: DialogueObject) -> float:
            return o.distance

        where = "me"
    else:

        def key(o: DialogueObject) -> float:
            return hull_gap(o.hull, ref.hull)

        where = f"the {_name(ref, scene)}"
    best = (min if word == "closest" else max)(candidates, key=key)
    text = f"The {_name(best, scene)} is the {word} to {where}, {_metres(key(best))} away."
    if word == "farthest":
        text = f"The {_name(best, scene)} is the farthest from {where}, {_metres(key(best))} away."
    return Answer("", text, "which", None, (best.name,), None, key(best))


def _see(q: Query, scene: DialogueScene) -> Answer:
    objs = salient_objects(scene)
    if not objs:
        return Answer("", "I don't see anything I can describe.", "which")
    names = [f"the {_name(o, scene)}" for o in objs]
    if len(objs) == 1:
        text = f"I see one object: {names[0]}, {_metres(objs[0].distance)} from me."
    else:
        text = f"I see {len(objs)} objects; from left to right: {join(names)}."
    return Answer("", text, "which", None, tuple(o.name for o in objs))


def _count(q: Query, scene: DialogueScene) -> Answer:
    objs = salient_objects(scene)
    n = len(objs)
    text = f"I see {n} object{'s' if n != 1 else ''}."
    return Answer("", text, "which", None, tuple(o.name for o in objs))


def _about(q: Query, scene: DialogueScene) -> Answer:
    ref = resolve(q.phrases[0], scene)
    if ref.status == "missing" and len(ref.text.split()) > 2:
        raise _Refusal(f"Sorry, I did not understand the question. {_HELP}")
    if ref.status != "one":
        _refuse(ref)
    obj = ref.one
    where = _where_one(obj, scene)[1]
    if obj.known:
        return where
    parts = [describe_object(obj)]
    if obj.height is not None:
        parts.append(f"{_metres(obj.height)} tall")
    lead = (
        f"It is {indefinite(parts[0])} I cannot name"
        + (f", {parts[1]}" if len(parts) > 1 else "")
        + "."
    )
    return Answer(
        "",
        f"{lead} {where.answer}",
        "where",
        None,
        where.objects,
        where.confidence,
        where.distance_m,
    )


_HANDLERS: dict[str, Callable[[Query, DialogueScene], Answer]] = {
    "see": _see,
    "count": _count,
    "where": _where,
    "distance": _distance,
    "yes-no": _yes_no,
    "between": _between,
    "what-between": _what_between,
    "what": _what,
    "superlative": _superlative,
    "about": _about,
}


def ask(question: str, scene: Any) -> Answer:
    """Answer a question about a scene.

    Parameters
    ----------
    question : str
        In English, e.g. "where is the mug?" (forms: :mod:`~scenespeak.spatial.dialogue.grammar`).
    scene : SceneDescription, dict, DialogueScene or path
        A :class:`~scenespeak.pipeline.SceneDescription`, the dict of a saved
        ``describe --format json`` output, or the path of such a file.

    Returns
    -------
    Answer
        ``kind`` is ``"unknown"`` for a question it cannot parse or about an object it did not
        see; the answer then says so.

    Raises
    ------
    InputError
        Only for a scene that cannot be read.
    """
    s = scene_from(scene)
    q = parse(question, s.names)
    handler = _HANDLERS.get(q.form)
    try:
        if handler is None:
            raise _Refusal(f"Sorry, I did not understand the question. {_HELP}")
        a = handler(q, s)
    except _Refusal as r:
        a = Answer("", r.answer, "unknown", None, r.objects)
    return Answer(question, a.answer, a.kind, a.degree, a.objects, a.confidence, a.distance_m)
