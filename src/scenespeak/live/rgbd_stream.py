"""An RGB-D stream with the working memory: masks (or the object database) per frame → ids →
:class:`~scenespeak.spatial.memory.WorkingMemory` → the JSON line of ``scenespeak watch``.

Each frame's objects are measured as ``describe`` measures them (:func:`scenespeak.pipeline_rgbd.
measure_masks`: each mask's largest depth mode and the pixels continuous with it; without
masks the database's recognised outlines, :func:`~scenespeak.pipeline_rgbd.describe_rgbd`).
A segmenter's instance numbers need not be stable over frames: the objects are matched to the
stream's tracks by label and 3-D distance (Hungarian assignment, within ``match_distance``,
``unseen_distance`` for a track not seen last frame); an unmatched object gets a new id (ids
are never reused). A track without an object this frame is not seen: ``"out of view"`` when
its last box touched the image's border, otherwise ``"hidden"`` behind the nearer seen object
whose box meets its last box grown by half its size (the last glimpse of an object going behind
another lies beside that one's box), or out of view when none does. The memory (hull and word
hysteresis, events) is the stereo stream's, and so is the JSON line
(:meth:`RGBDStreamFrame.to_dict`), with ``"source": "mask"`` (or ``"database"``) for a
measured object and ``"remembered"`` for one not seen.

>>> import numpy as np
>>> from scenespeak.perception.intrinsics import Intrinsics
>>> cam = Intrinsics(500.0, 500.0, 80.0, 60.0, 160, 120, up=(0.0, -1.0, 0.0))
>>> depth = np.full((120, 160), 3.0, np.float32)
>>> masks = np.zeros((120, 160), np.int32)
>>> depth[50:80, 20:50], masks[50:80, 20:50] = 1.0, 1
>>> depth[50:80, 100:130], masks[50:80, 100:130] = 1.0, 2
>>> stream = RGBDStream(cam)
>>> lines = [stream.process(depth, masks, {1: "mug", 2: "can"}).to_dict() for _ in range(3)]
>>> [o["id"] for o in lines[-1]["objects"]], lines[-1]["relations"][0]["sentence"]
([1, 2], 'The mug is directly to the left of the can.')
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from scenespeak.contract import SpatialObject
from scenespeak.live.stream import relations_json
from scenespeak.perception.intrinsics import Intrinsics
from scenespeak.perception.rgbd import MeasuredObject, RGBDOptions
from scenespeak.spatial.memory import MemoryFrame, MemoryOptions, Sighting, WorkingMemory

__all__ = ["RGBDStream", "RGBDStreamFrame", "RGBDStreamOptions", "RGBDTrack"]


@dataclass(frozen=True)
class RGBDStreamOptions:
    """Knobs of the RGB-D stream.

    Attributes
    ----------
    memory : MemoryOptions
        The working memory's (hysteresis, confirmation, forgetting).
    rgbd : RGBDOptions
        The RGB-D stage's (depth modes, hull trimming, support plane).
    match_distance : float
        Largest 3-D move (metres) between frames of an object matched to a track seen in the
        last frame.
    unseen_distance : float
        The same for a track not seen in the last frame.
    edge_margin : int
        A track whose last box came this close (pixels) to the image's border and is no longer
        seen is out of view.
    """

    memory: MemoryOptions = field(default_factory=MemoryOptions)
    rgbd: RGBDOptions = field(default_factory=RGBDOptions)
    match_distance: float = 0.3
    unseen_distance: float = 0.6
    edge_margin: int = 4


@dataclass(frozen=True, eq=False)
class RGBDTrack:
    """One object as the stream knows it in the current frame."""

    id: int
    label: str
    object: SpatialObject
    where: str
    box: tuple[int, int, int, int]
    source: str
    points: int
    last_seen: int
    behind: int | None = None


@dataclass(frozen=True, eq=False)
class RGBDStreamFrame:
    """One processed RGB-D frame: the tracks, the memory's words, timings."""

    index: int
    time_s: float
    tracks: tuple[RGBDTrack, ...]
    memory: MemoryFrame
    up_source: str
    timings: Mapping[str, float]
    seconds: float

    def to_dict(self) -> dict[str, Any]:
        """The JSON line of ``scenespeak watch`` (the stereo stream's fields, plus
        ``up_source``)."""
        tracks = {t.id: t for t in self.tracks}
        objects = []
        for m in self.memory.objects:
            obj: dict[str, Any] = {
                "id": m.id,
                "label": m.label,
                "name": m.name,
                "status": m.status,
                "hull": [[float(x), float(y)] for x, y in m.hull],
            }
            t = tracks.get(m.id)
            if t is not None:
                obj["points"] = int(t.points)
                c = t.object.centroid
                obj["centroid"] = None if c is None else [round(float(v), 6) for v in c]
                obj["source"] = t.source
                obj["box"] = [float(v) for v in t.box]
            obj["frames_unseen"] = m.frames_unseen
            if m.sentence:
                obj["sentence"] = m.sentence
            objects.append(obj)
        timings = {k: round(v * 1000.0, 2) for k, v in self.timings.items()}
        timings["total"] = round(self.seconds * 1000.0, 2)
        return {
            "frame": self.index,
            "time_s": round(self.time_s, 6),
            "objects": objects,
            "relations": relations_json(self.memory),
            "events": list(self.memory.events),
            "event_records": [dict(r) for r in self.memory.records],
            "recognised": True,
            "reason": "masks" if all(t.source != "database" for t in self.tracks) else "database",
            "up_source": self.up_source,
            "timings_ms": timings,
        }


def _checked_masks(masks: NDArray[np.integer[Any]], depth: NDArray[np.float32]) -> NDArray[Any]:
    """The instance image, refused (one line) when it is not of the depth's size or not of
    instance numbers."""
    from scenespeak.errors import ImageError

    m = np.asarray(masks)
    if m.shape != depth.shape:
        mh, mw = (*m.shape, 0, 0)[:2]
        raise ImageError(
            "masks", f"are {mw}x{mh} but the depth image is {depth.shape[1]}x{depth.shape[0]}"
        )
    if m.dtype.kind not in "iu" or (m.dtype.kind == "i" and m.size and int(m.min()) < 0):
        raise ImageError("masks", "must hold instance numbers 0 (background) or more")
    return m


def _box(m: MeasuredObject, width: int) -> tuple[int, int, int, int]:
    if m.kept is None or len(m.kept) == 0:
        return (0, 0, 0, 0)
    rows, cols = np.divmod(m.kept, width)
    return (int(cols.min()), int(rows.min()), int(cols.max()) + 1, int(rows.max()) + 1)


class RGBDStream:
    """Feed RGB-D frames in order; get an :class:`RGBDStreamFrame` each.

    Parameters
    ----------
    intrinsics : Intrinsics
        The colour (= depth) camera; its ``up``, else up estimated per frame from the support
        plane.
    db : ObjectDatabase, optional
        For frames without masks (recognition on every frame: slow).
    options : RGBDStreamOptions, optional
    """

    def __init__(
        self, intrinsics: Intrinsics, db: Any = None, options: RGBDStreamOptions | None = None
    ) -> None:
        self.cam = intrinsics
        self.db = db
        self.options = options or RGBDStreamOptions()
        self.memory = WorkingMemory(self.options.memory)
        self.tracks: dict[int, RGBDTrack] = {}
        self._next_id = 1
        self._count = 0

    def process(
        self,
        depth: NDArray[np.floating],
        masks: NDArray[np.integer[Any]] | None = None,
        labels: Mapping[int, str] | None = None,
        color: NDArray[np.generic] | None = None,
        time_s: float | None = None,
    ) -> RGBDStreamFrame:
        """Process the next frame (``time_s`` defaults to the frame number / 30).

        Raises
        ------
        ScenespeakError
            For a frame that cannot be used (sizes differ, labels naming absent instances,
            no masks and no database); the stream's state is unchanged.
        """
        t0 = time.perf_counter()
        measured, up_source, timings = self._measure(depth, masks, labels, color)
        t1 = time.perf_counter()
        tracks = self._match(measured, int(np.asarray(depth).shape[1]))
        sightings = [
            Sighting(
                t.id,
                t.object,
                seen=t.where == "seen",
                why=None if t.where == "seen" else t.where,
                behind=t.behind,
            )
            for t in tracks
        ]
        mem = self.memory.update(sightings)
        for i in self.memory.forgotten:
            self.tracks.pop(i, None)
        timings = {
            **timings,
            "match": t1 - t0 - sum(timings.values()),
            "memory": time.perf_counter() - t1,
        }
        index = self._count
        self._count += 1
        when = float(time_s) if time_s is not None else index / 30.0
        return RGBDStreamFrame(
            index, when, tuple(tracks), mem, up_source, timings, time.perf_counter() - t0
        )

    # ---------------------------------------------------------------------------------------
    def _measure(
        self,
        depth: NDArray[np.floating],
        masks: NDArray[np.integer[Any]] | None,
        labels: Mapping[int, str] | None,
        color: NDArray[np.generic] | None,
    ) -> tuple[list[MeasuredObject], str, dict[str, float]]:
        from scenespeak.errors import ImageError, InputError
        from scenespeak.perception.depth import check_depth_size
        from scenespeak.perception.masks import instances_from_array
        from scenespeak.pipeline_rgbd import describe_rgbd, measure_masks, resolve_up

        o = self.options.rgbd
        d = np.asarray(depth, dtype=np.float32)
        size = (d.shape[1], d.shape[0]) if d.ndim == 2 else (0, 0)
        if d.ndim != 2 or size != self.cam.size:
            raise ImageError(
                "depth",
                f"is {size[0]}x{size[1]} but the intrinsics are for "
                f"{self.cam.width}x{self.cam.height}",
            )
        if color is not None:
            ch, cw = np.asarray(color).shape[:2]
            check_depth_size(d, (cw, ch), depth_name="depth", other_name="the colour image")
        t0 = time.perf_counter()
        if masks is None:
            if self.db is None:
                raise InputError("masks", "this frame has no masks and the stream has no --db")
            found = describe_rgbd(color, d, self.cam, db=self.db, options=o, summary=False)
            return list(found.objects), found.up_source, {"objects": time.perf_counter() - t0}
        m = _checked_masks(masks, d)
        exclude = None if self.cam.up is not None else m > 0  # the plane is sought off the objects
        vec, up_source, _ = resolve_up(d, self.cam, exclude, o)
        t1 = time.perf_counter()
        if not m.any():  # nothing segmented in this frame: no object seen
            return [], up_source, {"up": t1 - t0, "objects": 0.0}
        inst = instances_from_array(m, labels, size=size, source="masks")
        out = [x for x in measure_masks(d, self.cam, inst, vec, o) if isinstance(x, MeasuredObject)]
        return out, up_source, {"up": t1 - t0, "objects": time.perf_counter() - t1}

    def _costs(self, measured: Sequence[MeasuredObject], ids: Sequence[int]) -> NDArray[np.float64]:
        """Centroid distances of objects (rows) to tracks (columns) of the same label within
        the gate, 1e6 elsewhere."""
        o = self.options
        cost = np.full((len(measured), len(ids)), 1e6)
        for i, m in enumerate(measured):
            c = m.object.centroid
            for j, tid in enumerate(ids):
                t = self.tracks[tid]
                gate = o.match_distance if t.last_seen == self._count - 1 else o.unseen_distance
                tc = t.object.centroid
                if t.label != m.label or c is None or tc is None:
                    continue
                dist = float(np.linalg.norm(np.asarray(c) - np.asarray(tc)))
                if dist <= gate:
                    cost[i, j] = dist
        return cost

    def _match(self, measured: Sequence[MeasuredObject], width: int) -> list[RGBDTrack]:
        """Each measured object's track (Hungarian on label + 3-D distance), the rest unseen."""
        from scipy.optimize import linear_sum_assignment

        ids = list(self.tracks)
        cost = self._costs(measured, ids)
        big = 1e6
        pairs = {}
        if len(measured) and len(ids):
            rows, cols = linear_sum_assignment(cost)
            pairs = {
                int(r): ids[int(c)] for r, c in zip(rows, cols, strict=True) if cost[r, c] < big
            }
        seen: dict[int, RGBDTrack] = {}
        for i, m in enumerate(measured):
            found = pairs.get(i)
            if found is None:
                tid, self._next_id = self._next_id, self._next_id + 1
            else:
                tid = found
            obj = SpatialObject(
                name=m.label,
                label=m.label,
                hull=m.object.hull,
                heights=m.object.heights,
                centroid=m.object.centroid,
            )
            seen[tid] = RGBDTrack(
                tid, m.label, obj, "seen", _box(m, width), m.source, m.kept_pixels, self._count
            )
        for tid, t in self.tracks.items():
            if tid not in seen:
                seen[tid] = self._unseen(
                    t, list(v for v in seen.values() if v.where == "seen"), width
                )
        self.tracks = dict(sorted(seen.items()))
        return list(self.tracks.values())

    def _unseen(self, t: RGBDTrack, seen: Sequence[RGBDTrack], width: int) -> RGBDTrack:
        """Why a track has no object this frame: out of view (its box was at the border) or
        hidden behind the nearer seen object whose box meets most of its grown last box."""
        from dataclasses import replace

        if t.where != "seen":
            return replace(t, source="remembered")
        x0, y0, x1, y1 = t.box
        margin = self.options.edge_margin
        if x0 <= margin or x1 >= width - margin or y0 <= margin or y1 >= self.cam.height - margin:
            return replace(t, where="out of view", source="remembered", behind=None)
        # the last glimpse of an object going behind another lies beside that one's box: the
        # box grown by half its size (at least 10 px) must meet the nearer object's box
        gx, gy = max(10.0, 0.5 * (x1 - x0)), max(10.0, 0.5 * (y1 - y0))
        cover, best = None, 0.0
        for s in seen:
            ox0, oy0, ox1, oy1 = s.box
            inter = max(0.0, min(x1 + gx, ox1) - max(x0 - gx, ox0)) * max(
                0.0, min(y1 + gy, oy1) - max(y0 - gy, oy0)
            )
            sc, tc = s.object.centroid, t.object.centroid
            if sc is not None and tc is not None and sc[2] < tc[2] and inter > best:
                cover, best = s.id, inter
        if cover is None:
            return replace(t, where="out of view", source="remembered", behind=None)
        return replace(t, where="hidden", source="remembered", behind=cover)
