"""A working memory of the scene: steady words over a stream, and what changed.

The seed paper's future work names a *working memory*: the objects of the current task kept as
chunks. This module keeps, per object id (perception's tracks, through
:class:`~scenespeak.contract.SpatialObject`), where the object was last said to be, and says
the relations of every ordered pair so that the words do not flicker:

- **hull hysteresis**: an object's hull is replaced only when its footprint centroid moved
  more than ``move_threshold`` from the hull in use (or its area changed by more than a factor
  ``area_ratio``); small frame-to-frame jitter leaves the words' input unchanged;
- **word hysteresis**: a pair's words (primary, secondary, hedges, vertical relation) change
  only when the new words came out ``confirm`` frames in a row; a word seen for one frame is
  never said;
- **memory**: an object that is not seen keeps its last hull for ``forget_after`` frames and
  is said to be ``"out of view"`` or ``"hidden"`` (behind another object); relations are said
  among the objects present (seen or hidden);
- **events**, once a change has lasted ``confirm`` frames: "A can appeared.", "The mug is out
  of view.", "The mug is hidden behind the box.", "The mug is back in view.", "The mug moved
  behind the can." (a pair's primary direction changed; said of the object that moved more).

Only spatial words here; perception (ids, tracking) is :mod:`scenespeak.perception.tracking`.

>>> import numpy as np
>>> from scenespeak.contract import SpatialObject
>>> sq = np.array([[0, 0], [0.1, 0], [0.1, 0.1], [0, 0.1]])
>>> mem = WorkingMemory()
>>> def frame(x):
...     return [Sighting(1, SpatialObject("mug", "mug", sq + [x, 1.0])),
...             Sighting(2, SpatialObject("can", "can", sq + [0.0, 1.0]))]
>>> [mem.update(frame(-0.3)).relations[0].primary for _ in range(3)]
['left', 'left', 'left']
>>> out = [mem.update(frame(0.3)) for _ in range(3)]
>>> [o.relations[0].primary for o in out], out[1].events
(['left', 'right', 'right'], ('The mug moved to the right of the can.',))
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from scenespeak.contract import SpatialObject
from scenespeak.geometry.polygons import polygon_area

__all__ = ["MemoryFrame", "MemoryObject", "MemoryOptions", "Sighting", "WorkingMemory"]

Status = Literal["seen", "hidden", "out of view"]


@dataclass(frozen=True)
class MemoryOptions:
    """Knobs of :class:`WorkingMemory`.

    Attributes
    ----------
    confirm : int
        Frames in a row a change must last before it is said (words, status, events).
    move_threshold : float
        Metres the footprint centroid must move before the object's hull is replaced.
    area_ratio : float
        ... or the factor by which its area must change.
    forget_after : int
        Frames an unseen object is remembered.
    directions : int
        Bins of the force histograms.
    """

    confirm: int = 2
    move_threshold: float = 0.04
    area_ratio: float = 1.8
    forget_after: int = 300
    directions: int = 180


@dataclass(frozen=True)
class Sighting:
    """One object of a frame as perception reports it.

    Attributes
    ----------
    id : int
        Stable id (perception's track).
    object : SpatialObject
        Its footprint (the last known one when it is not seen), label and heights.
    seen : bool
        Whether it was seen in this frame.
    why : {"hidden", "out of view"} or None
        For an unseen object, perception's guess of why.
    behind : int or None
        For ``"hidden"``: the id of the object hiding it.
    """

    id: int
    object: SpatialObject
    seen: bool = True
    why: str | None = None
    behind: int | None = None


@dataclass(frozen=True, eq=False)
class MemoryObject:
    """An object the memory holds, with the hull it says the words from."""

    id: int
    label: str
    name: str
    hull: NDArray[np.float64]
    heights: NDArray[np.float64] | None
    status: Status
    frames_unseen: int
    behind: int | None = None
    sentence: str = ""


@dataclass(frozen=True, eq=False)
class MemoryFrame:
    """What the memory says after one frame.

    Attributes
    ----------
    objects : tuple of MemoryObject
        Every remembered object, by id.
    relations : tuple of Relation
        The steady relations of every ordered pair of present (seen or hidden) objects.
    relation_ids : tuple of (int, int)
        The (argument, referent) ids of each relation.
    events : tuple of str
        Sentences about what changed, said in this frame.
    records : tuple of dict
        The same events as data: ``kind`` ("appeared", "out of view", "hidden", "back in
        view", "moved"), ``object`` (id), ``referent`` (id or None), ``relation``.
    """

    objects: tuple[MemoryObject, ...]
    relations: tuple[Any, ...]
    relation_ids: tuple[tuple[int, int], ...]
    events: tuple[str, ...]
    records: tuple[dict[str, Any], ...]


@dataclass
class _Entry:
    id: int
    label: str
    hull: NDArray[np.float64]
    heights: NDArray[np.float64] | None
    status: Status = "seen"
    said_status: Status | None = None  # None until first confirmed
    pending: Status | None = None
    pending_n: int = 0
    unseen: int = 0
    behind: int | None = None
    seen_n: int = 0
    version: int = 0


@dataclass
class _PairWords:
    said: Any = None  # the Relation being said
    said_key: tuple[Any, ...] | None = None
    pending_key: tuple[Any, ...] | None = None
    pending_n: int = 0
    where: dict[int, NDArray[np.float64]] = field(default_factory=dict)


_WORDS = {
    "left": "to the left of",
    "right": "to the right of",
    "front": "in front of",
    "behind": "behind",
    "surrounded": "surrounded by",
}


def _key(rel: Any) -> tuple[Any, ...]:
    return (rel.primary, rel.secondary, rel.hedge, rel.secondary_hedge, rel.vertical, rel.kind)


def _article(label: str) -> str:
    return ("An " if label[:1].lower() in "aeiou" else "A ") + label


def _centre(hull: NDArray[np.float64]) -> NDArray[np.float64]:
    return np.asarray(hull, dtype=np.float64).mean(axis=0)


def _area(hull: NDArray[np.float64]) -> float:
    return abs(polygon_area(np.asarray(hull, dtype=np.float64)))


class WorkingMemory:
    """Keep objects across frames and say steady relations and events (module docstring)."""

    def __init__(self, options: MemoryOptions | None = None) -> None:
        self.options = options or MemoryOptions()
        self._entries: dict[int, _Entry] = {}
        self._pairs: dict[tuple[int, int], _PairWords] = {}
        self._frames = 0
        self._cache_key: tuple[Any, ...] | None = None
        self._cache: list[tuple[Any, tuple[int, int]]] = []
        self._dropped: list[int] = []

    @property
    def forgotten(self) -> list[int]:
        """Ids dropped by the last :meth:`update` (to tell perception)."""
        return list(self._dropped)

    def update(self, sightings: list[Sighting]) -> MemoryFrame:
        """Take one frame's sightings; return what to say."""
        opts = self.options
        self._frames += 1
        events: list[tuple[str, dict[str, Any]]] = []
        present = {s.id for s in sightings}
        for s in sightings:
            self._see(s, events)
        self._dropped = []
        for i, e in list(self._entries.items()):
            if i not in present:
                e.unseen += 1
                self._status(e, "out of view" if e.status == "seen" else e.status, events)
            if e.unseen > opts.forget_after:
                del self._entries[i]
                self._dropped.append(i)
        names = self._names()
        rels = self._relations(names, events)
        objects = tuple(
            MemoryObject(
                e.id,
                e.label,
                names[e.id],
                e.hull,
                e.heights,
                e.said_status or e.status,
                e.unseen,
                e.behind,
                self._status_sentence(e, names),
            )
            for e in sorted(self._entries.values(), key=lambda e: e.id)
        )
        texts = tuple(self._event_text(r, names) for _, r in events)
        return MemoryFrame(
            objects,
            tuple(r for r, _ in rels),
            tuple(ids for _, ids in rels),
            texts,
            tuple(r for _, r in events),
        )

    # ---------------------------------------------------------------------------------------
    def _see(self, s: Sighting, events: list[tuple[str, dict[str, Any]]]) -> None:
        opts = self.options
        hull = np.asarray(s.object.hull, dtype=np.float64)
        e = self._entries.get(s.id)
        if e is None:
            e = _Entry(s.id, s.object.label, hull, s.object.heights)
            self._entries[s.id] = e
        elif s.seen:
            moved = float(np.linalg.norm(_centre(hull) - _centre(e.hull)))
            ratio = max(_area(hull), 1e-12) / max(_area(e.hull), 1e-12)
            if moved > opts.move_threshold or not 1 / opts.area_ratio < ratio < opts.area_ratio:
                e.hull, e.heights, e.version = hull, s.object.heights, e.version + 1
        if s.seen:
            e.unseen = 0
            e.seen_n += 1
            e.behind = None
            self._status(e, "seen", events)
        else:
            e.unseen += 1
            now: Status = "hidden" if s.why == "hidden" else "out of view"
            e.behind = s.behind if now == "hidden" else None
            self._status(e, now, events)

    def _status(self, e: _Entry, now: Status, events: list[tuple[str, dict[str, Any]]]) -> None:
        """Debounced status change, with its event."""
        e.status = now
        if e.said_status == now:
            e.pending, e.pending_n = None, 0
            return
        if e.pending == now:
            e.pending_n += 1
        else:
            e.pending, e.pending_n = now, 1
        if e.pending_n < self.options.confirm:
            return
        before, e.said_status = e.said_status, now
        e.pending, e.pending_n = None, 0
        first = self._frames <= self.options.confirm
        if before is None:
            if now == "seen" and not first:
                events.append(("", {"kind": "appeared", "object": e.id, "referent": None}))
            return
        if now == "seen":
            events.append(("", {"kind": "back in view", "object": e.id, "referent": None}))
        elif now == "hidden":
            events.append(("", {"kind": "hidden", "object": e.id, "referent": e.behind}))
        elif before == "seen" or before == "hidden":
            events.append(("", {"kind": "out of view", "object": e.id, "referent": None}))

    def _names(self) -> dict[int, str]:
        count: dict[str, int] = {}
        for e in self._entries.values():
            count[e.label] = count.get(e.label, 0) + 1
        return {
            e.id: e.label if count[e.label] == 1 else f"{e.label} {e.id}"
            for e in self._entries.values()
        }

    def _relations(
        self, names: dict[int, str], events: list[tuple[str, dict[str, Any]]]
    ) -> list[tuple[Any, tuple[int, int]]]:
        """Raw relations of the present objects (recomputed only when a hull changed), then
        the debounced words of each ordered pair."""
        self._refresh_raw(names)
        out = []
        changed: dict[frozenset[int], tuple[int, int]] = {}
        for rel, ids in self._cache:
            pw = self._pairs.setdefault(ids, _PairWords())
            if self._debounce(pw, rel, ids):
                changed.setdefault(frozenset(ids), ids)
            if pw.said.argument != names[ids[0]] or pw.said.referent != names[ids[1]]:
                pw.said = rel  # renamed (a second object with the same label)
            out.append((pw.said, ids))
        said = {ids: rel for rel, ids in out}
        for a, b in changed.values():
            self._moved_event(a, b, said, events)
        return out

    def _refresh_raw(self, names: dict[int, str]) -> None:
        """The raw relations of the objects in view, recomputed when one's hull or name changed."""
        from scenespeak.spatial.language import relate_objects

        present = [
            e
            for e in sorted(self._entries.values(), key=lambda e: e.id)
            if (e.said_status or e.status) != "out of view"
        ]
        key = tuple((e.id, e.version, names[e.id]) for e in present)
        if key == self._cache_key:
            return
        heights = [e.heights for e in present if e.heights is not None]
        raw = (
            relate_objects(
                [e.hull for e in present],
                names=[names[e.id] for e in present],
                heights=heights if len(heights) == len(present) else None,
                directions=self.options.directions,
            )
            if len(present) >= 2
            else []
        )
        by_name = {names[e.id]: e.id for e in present}
        self._cache = [(rel, (by_name[rel.argument], by_name[rel.referent])) for rel, _ in raw]
        self._cache_key = key

    def _debounce(self, pw: _PairWords, rel: Any, ids: tuple[int, int]) -> bool:
        """Take this frame's relation of a pair into its words: a new wording is said only
        after ``confirm`` frames in a row. True when the primary direction said changed."""
        k = _key(rel)
        if pw.said is None:
            pw.said, pw.said_key = rel, k
            pw.where = {i: _centre(self._entries[i].hull) for i in ids}
            return False
        if k == pw.said_key:
            pw.said, pw.pending_key, pw.pending_n = rel, None, 0
            return False
        pw.pending_n = pw.pending_n + 1 if k == pw.pending_key else 1
        pw.pending_key = k
        if pw.pending_n < self.options.confirm:
            return False
        moved = bool(rel.primary != pw.said.primary)
        pw.said, pw.said_key, pw.pending_key, pw.pending_n = rel, k, None, 0
        return moved

    def _moved_event(
        self,
        a: int,
        b: int,
        said: dict[tuple[int, int], Any],
        events: list[tuple[str, dict[str, Any]]],
    ) -> None:
        """One event per pair whose primary changed: of the object that moved more."""
        pw = self._pairs[(a, b)]
        da = float(np.linalg.norm(_centre(self._entries[a].hull) - pw.where.get(a, 0.0)))
        db = float(np.linalg.norm(_centre(self._entries[b].hull) - pw.where.get(b, 0.0)))
        arg, ref = (a, b) if da >= db else (b, a)
        rel = said.get((arg, ref))
        if rel is None:
            return
        for ids in ((a, b), (b, a)):
            p = self._pairs.get(ids)
            if p is not None:
                p.where = {i: _centre(self._entries[i].hull) for i in ids}
        events.append(
            ("", {"kind": "moved", "object": arg, "referent": ref, "relation": rel.primary})
        )

    def _status_sentence(self, e: _Entry, names: dict[int, str]) -> str:
        status = e.said_status or e.status
        if status == "out of view":
            return f"The {names[e.id]} is out of view."
        if status == "hidden":
            if e.behind is not None and e.behind in names:
                return f"The {names[e.id]} is hidden behind the {names[e.behind]}."
            return f"The {names[e.id]} is hidden."
        return ""

    def _event_text(self, r: dict[str, Any], names: dict[int, str]) -> str:
        name = names.get(r["object"], "object")
        kind = r["kind"]
        if kind == "appeared":
            return f"{_article(name)} appeared."
        if kind == "back in view":
            return f"The {name} is back in view."
        if kind == "out of view":
            return f"The {name} is out of view."
        if kind == "hidden":
            ref = r.get("referent")
            if ref is not None and ref in names:
                return f"The {name} is hidden behind the {names[ref]}."
            return f"The {name} is hidden."
        ref_name = names.get(r["referent"], "object")
        return f"The {name} moved {_WORDS.get(r['relation'], r['relation'])} the {ref_name}."
