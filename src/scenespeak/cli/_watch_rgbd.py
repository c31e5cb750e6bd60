"""``scenespeak watch`` on RGB-D frames: a folder (``--rgbd DIR``) or a ROS 2 bag (``--rosbag BAG
--color-topic T --depth-topic T``), through :class:`scenespeak.live.rgbd_stream.RGBDStream`."""

from __future__ import annotations

import itertools
import json
import sys
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from scenespeak.errors import InputError, ScenespeakError


@dataclass(frozen=True)
class RGBDWatch:
    """The RGB-D options of ``watch`` (``docs/live.md``)."""

    folder: Path | None = None
    rosbag: Path | None = None
    color_topic: str | None = None
    depth_topic: str | None = None
    masks_topic: str | None = None
    info_topic: str | None = None
    intrinsics: Path | None = None
    labels: Path | None = None
    depth_scale: float = 0.001
    fps: float = 30.0
    max_frames: int | None = None

    @property
    def wanted(self) -> bool:
        """Whether the RGB-D form was asked for."""
        return self.folder is not None or self.depth_topic is not None


def _intrinsics(w: RGBDWatch) -> Any:
    from scenespeak.perception.intrinsics import load_intrinsics

    if w.intrinsics is not None:
        return load_intrinsics(w.intrinsics)
    if w.folder is not None and (w.folder / "intrinsics.json").is_file():
        return load_intrinsics(w.folder / "intrinsics.json")
    if w.rosbag is not None and w.info_topic is not None:
        from scenespeak.live.rgbd_sources import rosbag_intrinsics

        return rosbag_intrinsics(w.rosbag, w.info_topic)
    where = "--rgbd" if w.folder is not None else "--rosbag"
    raise InputError(
        where,
        "RGB-D frames need the colour camera: --intrinsics FILE"
        + (" (or DIR/intrinsics.json)" if w.folder is not None else " or --info-topic T"),
    )


def _items(w: RGBDWatch) -> Iterator[Any]:
    from scenespeak.live import rgbd_sources as rs
    from scenespeak.perception.masks import load_labels

    labels = None if w.labels is None else load_labels(w.labels)
    if w.folder is not None:
        if w.rosbag is not None:
            raise InputError("watch", "give --rgbd DIR or --rosbag BAG, not both")
        if not w.folder.is_dir():
            raise InputError(w.folder, "no such folder")
        return rs.folder_rgbd_frames(w.folder, fps=w.fps, depth_scale=w.depth_scale, labels=labels)
    if w.rosbag is None or w.color_topic is None:
        raise InputError(
            "--depth-topic", "RGB-D from a bag needs --rosbag BAG --color-topic T --depth-topic T"
        )
    assert w.depth_topic is not None
    return rs.rosbag_rgbd_frames(
        w.rosbag,
        w.color_topic,
        w.depth_topic,
        masks_topic=w.masks_topic,
        labels=labels,
        depth_scale=w.depth_scale,
    )


def _first_checked(items: Iterator[Any], db: Path | None) -> Iterator[Any]:
    """The frames, after refusing (one line, before any output) a stream whose first readable
    frame has no masks while there is no database to recognise the objects."""
    from scenespeak.live.rgbd_sources import RGBDFrame

    head: list[Any] = []
    for item in items:
        head.append(item)
        if isinstance(item, RGBDFrame):
            if item.masks is None and db is None:
                raise InputError(
                    item.source,
                    "has no masks (masks.png + labels.json, or --masks-topic): give them, or "
                    "--db to recognise the objects",
                )
            break
    return itertools.chain(head, items)


def watch_rgbd(w: RGBDWatch, db: Path | None) -> None:
    """Run the RGB-D stream and print one JSON line per frame (broken frames: stderr)."""
    from scenespeak.live.rgbd_stream import RGBDStream
    from scenespeak.live.sources import BrokenFrame

    items = _first_checked(_items(w), db)
    cam = _intrinsics(w)
    database = None
    if db is not None:
        from scenespeak.perception.database import ObjectDatabase

        database = ObjectDatabase.open(db, readonly=True)
    try:
        stream = RGBDStream(cam, database)
        done = 0
        for item in items:
            if w.max_frames is not None and done >= w.max_frames:
                break
            done += 1
            if isinstance(item, BrokenFrame):
                _warn(item.source, item.problem)
                continue
            try:
                frame = stream.process(item.depth, item.masks, item.labels, item.color, item.time_s)
            except ScenespeakError as exc:
                _warn(item.source, str(exc))
                continue
            line = frame.to_dict()
            line["frame"] = item.index
            sys.stdout.write(json.dumps(line) + "\n")
            sys.stdout.flush()
    finally:
        if database is not None:
            database.close()


def _warn(where: str, problem: str) -> None:
    sys.stderr.write(f"scenespeak: warning: {where}: {problem}\n")
    sys.stderr.flush()
