"""Noun phrases → the scene's objects: names as the scene has them, labels, plurals, "me".

A phrase resolves, after its article is dropped, by the first rule that fits:

1. "me", "you", "yourself", "the camera", "the robot" → the camera (``status="me"``);
2. an object's name ("left mug", "unknown object 2") or, for an unknown object, what it looks
   like ("small red object");
3. a label: one object with it → that object; several → ``"ambiguous"`` (the answer asks
   "which mug?"), or all of them for a plural ("the mugs");
4. "the mug on the left" → the name "left mug"; "object 2" → "unknown object 2";
5. the last word as a label ("the coffee mug" when the scene has one mug);
6. otherwise ``"missing"`` (the answer says "I don't see a cup.").

>>> from scenespeak.spatial.dialogue.scene import DialogueObject, DialogueScene
>>> sq = ((0.0, 1.0), (0.1, 1.0), (0.1, 1.1), (0.0, 1.1))
>>> scene = DialogueScene((DialogueObject("left mug", "mug", sq),
...                        DialogueObject("right mug", "mug", sq)), {})
>>> resolve("the mug", scene).status, resolve("the mugs", scene).status
('ambiguous', 'many')
>>> [o.name for o in resolve("the mug on the right", scene).objects]
['right mug']
>>> resolve("a cup", scene).status
'missing'
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from scenespeak.spatial.dialogue.scene import DialogueObject, DialogueScene
from scenespeak.spatial.dialogue.words import describe_object

__all__ = ["VIEWER_WORDS", "Reference", "resolve", "singular"]

VIEWER_WORDS = frozenset(
    {"me", "you", "yourself", "myself", "us", "camera", "the camera", "robot", "the robot"}
)
_ARTICLE = re.compile(r"^(?:the|a|an|that|this|these|those|my|your|any|some|one)\s+")
_POSITION = re.compile(
    r"^(?P<noun>.+?) (?:on|to|at|in) the (?P<where>left|right|front|back|middle|centre|center)$"
)


@dataclass(frozen=True)
class Reference:
    """What a phrase refers to.

    Attributes
    ----------
    status : {"one", "many", "ambiguous", "missing", "me"}
    objects : tuple of DialogueObject
        The object(s); for ``"ambiguous"`` the candidates.
    text : str
        The phrase without its article (for "I don't see a cup.").
    plural : bool
        The phrase was plural ("the mugs").
    """

    status: str
    objects: tuple[DialogueObject, ...] = ()
    text: str = ""
    plural: bool = False

    @property
    def one(self) -> DialogueObject:
        """The single object (only for ``status == "one"``)."""
        return self.objects[0]


def singular(word: str) -> str:
    """English singular of a plural noun (regular forms only).

    >>> singular("mugs"), singular("boxes"), singular("batteries"), singular("glass")
    ('mug', 'box', 'battery', 'glass')
    """
    if word.endswith("ies") and len(word) > 4:
        return word[:-3] + "y"
    if re.search(r"(?:s|x|z|ch|sh)es$", word):
        return word[:-2]
    if word.endswith("s") and not word.endswith("ss"):
        return word[:-1]
    return word


def _by_label(text: str, scene: DialogueScene, plural: bool) -> Reference | None:
    found = tuple(o for o in scene.objects if o.label.lower() == text)
    if not found:
        return None
    if len(found) == 1:
        return Reference("one", found, text, plural)
    return Reference("many" if plural else "ambiguous", found, text, plural)


def _by_name(text: str, scene: DialogueScene) -> Reference | None:
    for o in scene.objects:
        if o.name.lower() == text:
            return Reference("one", (o,), text)
    unknown = [o for o in scene.objects if not o.known and describe_object(o) == text]
    if len(unknown) == 1:
        return Reference("one", (unknown[0],), text)
    if unknown:
        return Reference("ambiguous", tuple(unknown), text)
    m = re.fullmatch(r"(?:unknown )?(?:object|thing) (\d+)", text)
    if m:
        return _by_name(f"unknown object {m.group(1)}", scene) if "unknown" not in text else None
    return None


def _exact(text: str, scene: DialogueScene) -> Reference | None:
    found = _by_name(text, scene) or _by_label(text, scene, False)
    if found is not None:
        return found
    single = " ".join([*text.split()[:-1], singular(text.split()[-1])])
    if single != text:
        return _by_name(single, scene) or _by_label(single, scene, True)
    return None


def resolve(phrase: str, scene: DialogueScene) -> Reference:
    """Resolve a noun phrase against the scene (rules in the module docstring)."""
    text = re.sub(r"\s+", " ", phrase.strip().lower())
    if text in VIEWER_WORDS:
        return Reference("me", (), text)
    text = _ARTICLE.sub("", text).strip()
    if not text:
        return Reference("missing", (), phrase)
    if text in VIEWER_WORDS:
        return Reference("me", (), text)
    found = _exact(text, scene)
    if found is not None:
        return found
    m = _POSITION.match(text)
    if m:
        where = {"centre": "middle", "center": "middle"}.get(m.group("where"), m.group("where"))
        found = _exact(f"{where} {m.group('noun')}", scene)
        if found is not None:
            return found
    words = text.split()
    if len(words) > 1:
        found = _exact(words[-1], scene)
        if found is not None and found.status != "missing":
            return found
    plural = singular(words[-1]) != words[-1]
    return Reference("missing", (), text, plural)
