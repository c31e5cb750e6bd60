"""Names that tell several instances of one label apart, as a person would.

Two mugs in a scene are "the left mug" and "the right mug"; one behind the other, "the front
mug" and "the back mug"; three in a row "the left", "middle" and "right mug"; otherwise "the mug
near the can" (the nearest object whose label is unique), and as the last resort "the second mug
from the left". A pure function of the objects' footprints (the hulls of
:class:`~scenespeak.contract.SpatialObject`), in either frame: on the horizontal plane
(x = right, y = depth) the second axis gives front/back, in the image plane (x = column,
y = image up) it gives top/bottom.

Objects whose label is unique keep their name; so does a group whose names are already
distinct (e.g. "unknown object 1", "unknown object 2"). The question grammar of ``ask`` resolves
these names ("where is the left mug?").

>>> import numpy as np
>>> from scenespeak.contract import SpatialObject
>>> sq = np.array([[0.0, 0.0], [0.1, 0.0], [0.1, 0.1], [0.0, 0.1]])
>>> objs = [
...     SpatialObject("mug", "mug", sq + [0.5, 1.0]),
...     SpatialObject("mug", "mug", sq + [-0.5, 1.0]),
...     SpatialObject("can", "can", sq + [0.0, 1.5]),
... ]
>>> instance_names(objs)
['right mug', 'left mug', 'can']
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from scenespeak.contract import SpatialObject

__all__ = ["instance_names", "name_instances"]

_ORDINALS = ("first", "second", "third", "fourth", "fifth", "sixth", "seventh", "eighth", "ninth")

#: Position words along each axis, from low to high coordinate, per frame and group size.
_WORDS: dict[tuple[str, int], dict[int, tuple[str, ...]]] = {
    ("horizontal", 0): {2: ("left", "right"), 3: ("left", "middle", "right")},
    ("horizontal", 1): {2: ("front", "back"), 3: ("front", "middle", "back")},
    ("image", 0): {2: ("left", "right"), 3: ("left", "middle", "right")},
    ("image", 1): {2: ("bottom", "top"), 3: ("bottom", "middle", "top")},
}


def _centres(objects: Sequence[SpatialObject]) -> NDArray[np.float64]:
    return np.array([np.asarray(o.hull, dtype=np.float64).mean(axis=0) for o in objects])


def _by_position(centres: NDArray[np.float64], frame: str) -> list[str] | None:
    """Position words when the instances are clearly ordered along one axis, else None.

    Along axis ``a``, consecutive instances (sorted by ``a``) must be farther apart along ``a``
    than along the other axis, so that "the left mug" points at one mug without doubt.
    """
    n = len(centres)
    if n not in (2, 3):
        return None
    for axis in (0, 1):
        order = np.argsort(centres[:, axis], kind="stable")
        steps = np.diff(centres[order], axis=0)
        if np.all(np.abs(steps[:, axis]) > np.abs(steps[:, 1 - axis])):
            words = _WORDS[(frame, axis)][n]
            names = [""] * n
            for rank, k in enumerate(order):
                names[int(k)] = words[rank]
            return names
    return None


def _by_neighbour(
    centres: NDArray[np.float64], others: Sequence[tuple[str, NDArray[np.float64]]]
) -> list[str] | None:
    """ "near the can" when each instance's nearest uniquely named object differs, else None."""
    if not others:
        return None
    pos = np.array([c for _, c in others])
    near = [others[int(np.argmin(np.linalg.norm(pos - c, axis=1)))][0] for c in centres]
    return near if len(set(near)) == len(near) else None


def _ordinal(k: int) -> str:
    return _ORDINALS[k] if k < len(_ORDINALS) else f"{k + 1}th"


def instance_names(objects: Sequence[SpatialObject]) -> list[str]:
    """A distinct name for every object, telling instances of one label apart.

    Parameters
    ----------
    objects : sequence of SpatialObject
        The scene's objects (all in one frame); their ``label`` groups them.

    Returns
    -------
    list of str
        One name per object, in order, all distinct: the object's own name when its label is
        unique in the scene (or its group's names are already distinct), otherwise
        ``"left mug"`` / ``"middle mug"`` / ``"right mug"``, ``"front mug"`` / ``"back mug"``
        (``"top"`` / ``"bottom"`` in the image plane), ``"mug near the can"``, or
        ``"second mug from the left"``.

    Examples
    --------
    >>> import numpy as np
    >>> from scenespeak.contract import SpatialObject
    >>> sq = np.array([[0.0, 0.0], [0.1, 0.0], [0.1, 0.1], [0.0, 0.1]])
    >>> near = SpatialObject("mug", "mug", sq + [0, 1])
    >>> far = SpatialObject("mug", "mug", sq + [0, 2])
    >>> instance_names([far, near])
    ['back mug', 'front mug']
    """
    names = [o.name for o in objects]
    groups: dict[str, list[int]] = {}
    for k, o in enumerate(objects):
        groups.setdefault(o.label, []).append(k)
    centres = _centres(objects) if objects else np.zeros((0, 2))
    unique = [(objects[m[0]].name, centres[m[0]]) for m in groups.values() if len(m) == 1]
    for label, members in groups.items():
        if len(members) == 1 or len({names[k] for k in members}) == len(members):
            continue
        new = _group_names(label, centres[members], objects[members[0]].frame, unique)
        for k, name in zip(members, new, strict=True):
            names[k] = name
    return _make_distinct(names)


def _group_names(
    label: str, c: NDArray[np.float64], frame: str, unique: list[tuple[str, NDArray[np.float64]]]
) -> list[str]:
    """Names for the instances of one label at centres ``c``: by position, by a neighbour
    with a unique label, or by rank from the left."""
    words = _by_position(c, frame)
    if words is not None:
        return [f"{w} {label}" for w in words]
    near = _by_neighbour(c, unique)
    if near is not None:
        return [f"{label} near the {n}" for n in near]
    order = np.argsort(c[:, 0], kind="stable")
    new = [""] * len(c)
    for rank, k in enumerate(order):
        new[int(k)] = f"{_ordinal(rank)} {label} from the left"
    return new


def _make_distinct(names: list[str]) -> list[str]:
    """Append " 2", " 3", ... to any name that still repeats (e.g. a label called "left mug")."""
    seen: dict[str, int] = {}
    out = []
    for name in names:
        count = seen.get(name, 0) + 1
        seen[name] = count
        out.append(name if count == 1 else f"{name} {count}")
    return out


def name_instances(objects: Sequence[SpatialObject]) -> tuple[SpatialObject, ...]:
    """The objects with :func:`instance_names` as their ``name`` (labels unchanged).

    Examples
    --------
    >>> import numpy as np
    >>> from scenespeak.contract import SpatialObject
    >>> sq = np.array([[0.0, 0.0], [0.1, 0.0], [0.1, 0.1], [0.0, 0.1]])
    >>> two = [SpatialObject("mug", "mug", sq), SpatialObject("mug", "mug", sq + [1, 0])]
    >>> objs = name_instances(two)
    >>> [(o.name, o.label) for o in objs]
    [('left mug', 'mug'), ('right mug', 'mug')]
    """
    return tuple(
        o if o.name == n else replace(o, name=n)
        for o, n in zip(objects, instance_names(objects), strict=True)
    )
