"""A stereo stream with a working memory: tracker (perception) + memory (spatial words).

:class:`SceneStream` composes :class:`scenespeak.perception.tracking.ObjectTracker` (ids,
tracking, recognition when needed) and :class:`scenespeak.spatial.memory.WorkingMemory`
(steady words, out-of-view objects, events), and turns every frame into the JSON line of
``scenespeak watch`` (``interfaces.md``, "Streams"; ``docs/live.md``).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from scenespeak.contract import SpatialObject
from scenespeak.perception.tracking import FrameObjects, ObjectTracker, TrackingOptions
from scenespeak.spatial.memory import MemoryFrame, MemoryOptions, Sighting, WorkingMemory

__all__ = ["SceneStream", "StreamFrame", "StreamOptions", "relations_json"]


def relations_json(memory: MemoryFrame) -> list[dict[str, Any]]:
    """The ``relations`` of a ``watch`` JSON line: the memory's steady words, with ids."""
    return [
        {
            "argument": rel.argument,
            "referent": rel.referent,
            "argument_id": a,
            "referent_id": b,
            "primary": rel.primary,
            "secondary": rel.secondary,
            "hedge": rel.hedge,
            "vertical": rel.vertical,
            "sentence": rel.sentence,
            "degrees": {k: round(float(v), 4) for k, v in rel.degrees.items()},
        }
        for rel, (a, b) in zip(memory.relations, memory.relation_ids, strict=True)
    ]


@dataclass(frozen=True)
class StreamOptions:
    """The knobs of both halves."""

    tracking: TrackingOptions = field(default_factory=TrackingOptions)
    memory: MemoryOptions = field(default_factory=MemoryOptions)
    pipeline: Any = None  # PipelineOptions for the keyframes (None: the tracker's default)


@dataclass(frozen=True, eq=False)
class StreamFrame:
    """One processed frame: the tracker's view, the memory's words, and timings."""

    index: int
    time_s: float
    tracked: FrameObjects
    memory: MemoryFrame
    seconds: float

    def to_dict(self) -> dict[str, Any]:
        """The JSON line of ``scenespeak watch`` (``interfaces.md``, plus extras)."""
        tracks = {t.id: t for t in self.tracked.tracks}
        objects = []
        for m in self.memory.objects:
            t = tracks.get(m.id)
            obj: dict[str, Any] = {
                "id": m.id,
                "label": m.label,
                "name": m.name,
                "status": m.status,
                "hull": [[float(x), float(y)] for x, y in m.hull],
            }
            if t is not None:
                obj["points"] = int(t.obj.n_points)
                obj["centroid"] = [round(float(v), 6) for v in t.obj.centroid]
                obj["source"] = t.source
                obj["box"] = [round(v, 1) for v in t.box]
            obj["frames_unseen"] = m.frames_unseen
            if m.sentence:
                obj["sentence"] = m.sentence
            objects.append(obj)
        timings = {k: round(v * 1000.0, 2) for k, v in self.tracked.timings.items()}
        timings["total"] = round(self.seconds * 1000.0, 2)
        return {
            "frame": self.index,
            "time_s": round(self.time_s, 6),
            "objects": objects,
            "relations": relations_json(self.memory),
            "events": list(self.memory.events),
            "event_records": [dict(r) for r in self.memory.records],
            "recognised": self.tracked.recognised,
            "reason": self.tracked.reason,
            "timings_ms": timings,
        }


class SceneStream:
    """Feed stereo frames in order; get a :class:`StreamFrame` each.

    Parameters
    ----------
    rig : StereoRig
    db : ObjectDatabase
        Used from the calling thread only.
    options : StreamOptions, optional
    """

    def __init__(self, rig: Any, db: Any, options: StreamOptions | None = None) -> None:
        self.options = options or StreamOptions()
        from scenespeak.pipeline import keyframe_describer

        describe = keyframe_describer(rig, db, self.options.pipeline)
        self.tracker = ObjectTracker(rig, describe, self.options.tracking)
        self.memory = WorkingMemory(self.options.memory)
        self._count = 0

    def process(
        self, left: NDArray[np.generic], right: NDArray[np.generic], time_s: float | None = None
    ) -> StreamFrame:
        """Process the next frame (``time_s`` defaults to the frame number / 30).

        Raises
        ------
        ScenespeakError
            For a frame the chain cannot use; the stream's state is unchanged and the next
            frame can follow.
        """
        t0 = time.perf_counter()
        tracked = self.tracker.update(left, right)
        sightings = [
            Sighting(
                t.id,
                SpatialObject(
                    name=t.label,
                    label=t.label,
                    hull=t.obj.hull,
                    heights=t.obj.heights,
                    centroid=t.obj.centroid,
                ),
                seen=t.where == "seen",
                why=None if t.where == "seen" else t.where,
                behind=t.behind,
            )
            for t in tracked.tracks
        ]
        mem = self.memory.update(sightings)
        for i in self.memory.forgotten:
            self.tracker.forget(i)
        index = self._count
        self._count += 1
        when = float(time_s) if time_s is not None else index / 30.0
        return StreamFrame(index, when, tracked, mem, time.perf_counter() - t0)
