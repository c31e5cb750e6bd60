"""Where RGB-D frames come from: a folder of colour / depth [/ masks] frames, or a ROS 2 bag
with colour, depth (and instance-mask) ``sensor_msgs/Image`` topics and a ``CameraInfo`` topic.

Every source yields :class:`RGBDFrame` values in order; a frame that cannot be read is a
:class:`~scenespeak.live.sources.BrokenFrame` with a one-line reason (the stream goes on).
Problems with the source itself (a missing folder, a bag without the topics) raise
:class:`~scenespeak.errors.InputError` before the first frame.

Folder layouts (``docs/live.md``)::

    DIR/NNNN/color.png (or left.png), DIR/NNNN/depth.png [, masks.png + labels.json]
    DIR/color_NNNN.png, DIR/depth_NNNN.png [, DIR/masks_NNNN.png + DIR/labels_NNNN.json]

with ``DIR/intrinsics.json`` (or ``--intrinsics``); labels per frame, or one ``DIR/labels.json``
(or ``--labels``) for the whole stream. Depth as ``describe --depth`` reads it (16-bit PNG in
``depth_scale`` metres, float TIFF / ``.npy`` in metres); masks 8- or 16-bit instance images.
The scene generator's sequences (:mod:`scenespeak.tools.sequences`) have the first layout.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from os import PathLike
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from scenespeak.errors import InputError, ScenespeakError
from scenespeak.live.sources import _NUM, BrokenFrame, _image_from_msg, _reader, _stamp
from scenespeak.perception.depth import DEFAULT_DEPTH_SCALE, depth_to_metres
from scenespeak.perception.intrinsics import Intrinsics

__all__ = [
    "RGBDFrame",
    "folder_rgbd_frames",
    "present_labels",
    "rosbag_intrinsics",
    "rosbag_rgbd_frames",
]

COLOR_NAMES = ("color.png", "color.jpg", "left.png", "left.jpg", "rgb.png")
DEPTH_NAMES = ("depth.png", "depth.tif", "depth.tiff", "depth.npy")
MASK_NAMES = ("masks.png", "instances.png", "left_labels.png")


@dataclass(frozen=True, eq=False)
class RGBDFrame:
    """One RGB-D frame: colour (RGB, or None when not read), depth in metres (NaN = none),
    the instance image and its labels when the source has them, the time and the origin."""

    index: int
    time_s: float
    color: NDArray[np.uint8] | None
    depth: NDArray[np.float32]
    masks: NDArray[np.int32] | None
    labels: Mapping[int, str] | None
    source: str


RGBDItem = RGBDFrame | BrokenFrame


def _first(folder: Path, names: tuple[str, ...]) -> Path | None:
    return next((folder / n for n in names if (folder / n).is_file()), None)


def _flat(root: Path, kind: str, n: int) -> Path | None:
    found = sorted(root.glob(f"{kind}_*{n}.*"))
    return next((p for p in found if _number(p.stem[len(kind) + 1 :]) == n), None)


def _number(text: str) -> int | None:
    m = _NUM.fullmatch(text)
    return int(m.group(1)) if m else None


def _frame_files(
    root: Path,
) -> list[tuple[str, Path | None, Path | None, Path | None, Path | None]]:
    """(name, colour, depth, masks, labels) per frame, in numeric order."""
    sub = sorted(
        (p for p in root.iterdir() if p.is_dir() and p.name.isdigit()), key=lambda p: int(p.name)
    )
    if sub:
        return [
            (
                p.name,
                _first(p, COLOR_NAMES),
                _first(p, DEPTH_NAMES),
                _first(p, MASK_NAMES),
                _first(p, ("labels.json",)),
            )
            for p in sub
        ]
    numbers = sorted({n for p in root.glob("depth_*.*") if (n := _number(p.stem[6:])) is not None})
    return [
        (
            str(n),
            _flat(root, "color", n),
            _flat(root, "depth", n),
            _flat(root, "masks", n),
            _flat(root, "labels", n),
        )
        for n in numbers
    ]


def _read_frame(
    files: tuple[str, Path | None, Path | None, Path | None, Path | None],
    depth_scale: float,
    labels: Mapping[int, str] | None,
    read_color: bool,
) -> tuple[Any, NDArray[np.float32], Any, Mapping[int, str] | None]:
    from scenespeak.perception.depth import load_depth
    from scenespeak.perception.features import load_image
    from scenespeak.perception.masks import load_instances, load_labels

    name, color_p, depth_p, masks_p, labels_p = files
    if depth_p is None:
        raise InputError(name, f"has no depth image ({' / '.join(DEPTH_NAMES)})")
    depth = load_depth(depth_p, scale=depth_scale)
    color = None
    if read_color or masks_p is None:
        if color_p is None:
            raise InputError(name, f"has no colour image ({' / '.join(COLOR_NAMES)})")
        color = load_image(color_p, gray=False)
    masks = None if masks_p is None else load_instances(masks_p)
    if labels_p is not None:  # this frame's own labels: checked against its masks
        return color, depth, masks, load_labels(labels_p)
    return color, depth, masks, present_labels(labels, masks)


def present_labels(
    labels: Mapping[int, str] | None, masks: NDArray[np.integer[Any]] | None
) -> Mapping[int, str] | None:
    """The stream's labels (one file for every frame) of the instances in this frame's masks:
    an instance out of sight this frame is not an error."""
    if labels is None or masks is None:
        return labels
    counts = np.bincount(np.asarray(masks).ravel().clip(0).astype(np.intp))
    return {k: v for k, v in labels.items() if 0 <= k < len(counts) and counts[k]}


def folder_rgbd_frames(
    root: str | PathLike[str],
    *,
    fps: float = 30.0,
    depth_scale: float = DEFAULT_DEPTH_SCALE,
    labels: Mapping[int, str] | None = None,
    read_color: bool = False,
) -> Iterator[RGBDFrame | BrokenFrame]:
    """RGB-D frames of a folder (module docstring), in numeric order; ``time_s`` = k / fps.

    ``labels`` names the instances of every frame that has no labels file of its own (else
    ``DIR/labels.json`` does, when present). The colour image is read only when
    ``read_color`` or when the frame has no masks (the object database needs it).

    Raises
    ------
    InputError
        If the folder is missing or holds no RGB-D frames.
    """
    from scenespeak.perception.masks import load_labels

    d = Path(root)
    if not d.is_dir():
        raise InputError(d, "no such folder")
    frames = _frame_files(d)
    if not frames or all(f[2] is None for f in frames):
        raise InputError(
            d,
            "holds no RGB-D frames (expected NNNN/color.png + NNNN/depth.png [+ masks.png + "
            "labels.json], or color_NNNN.png + depth_NNNN.png [+ masks_NNNN.png])",
        )
    if labels is None and (d / "labels.json").is_file():
        labels = load_labels(d / "labels.json")
    for k, files in enumerate(frames):
        where = f"{d}/{files[0]}"
        try:
            color, depth, masks, names = _read_frame(files, depth_scale, labels, read_color)
        except ScenespeakError as exc:
            yield BrokenFrame(k, where, str(exc))
            continue
        yield RGBDFrame(k, k / fps, color, depth, masks, names, where)


# --------------------------------------------------------------------------------------------
# ROS 2 bags


def _depth_from_msg(msg: Any, scale: float) -> NDArray[np.float32]:
    """A sensor_msgs/Image depth (16UC1 / mono16 in ``scale`` metres, 32FC1 in metres)."""
    h, w, enc = int(msg.height), int(msg.width), str(msg.encoding).lower()
    data = np.asarray(msg.data, dtype=np.uint8)
    step = int(msg.step)
    kinds = {"16uc1": ("u2", 2), "mono16": ("u2", 2), "32fc1": ("f4", 4)}
    if enc not in kinds:
        raise ValueError(f"depth encoding {enc!r} is not supported (16UC1, mono16, 32FC1)")
    kind, size = kinds[enc]
    if h <= 0 or w <= 0 or step < size * w or data.size < h * step:
        raise ValueError(f"{enc} depth of {w}x{h} (step {step}) has only {data.size} bytes")
    order = ">" if getattr(msg, "is_bigendian", 0) else "<"
    rows = data[: h * step].reshape(h, step)[:, : size * w]
    raw = rows.copy().view(order + kind).reshape(h, w)
    return depth_to_metres(raw.astype(raw.dtype.newbyteorder("=")), scale=scale, source=enc)


def _masks_from_msg(msg: Any) -> NDArray[np.int32]:
    """A sensor_msgs/Image instance image (mono8 / 8UC1 / mono16 / 16UC1) as int32."""
    h, w, enc = int(msg.height), int(msg.width), str(msg.encoding).lower()
    data = np.asarray(msg.data, dtype=np.uint8)
    step = int(msg.step)
    size = {"mono8": 1, "8uc1": 1, "mono16": 2, "16uc1": 2}.get(enc)
    if size is None:
        raise ValueError(f"mask encoding {enc!r} is not supported (mono8, 8UC1, mono16, 16UC1)")
    if h <= 0 or w <= 0 or step < size * w or data.size < h * step:
        raise ValueError(f"{enc} masks of {w}x{h} (step {step}) have only {data.size} bytes")
    rows = data[: h * step].reshape(h, step)[:, : size * w]
    if size == 1:
        return rows.astype(np.int32)
    order = ">u2" if getattr(msg, "is_bigendian", 0) else "<u2"
    return rows.copy().view(order).reshape(h, w).astype(np.int32)


def _open(bag: str | PathLike[str]) -> Any:
    reader = _reader(bag)
    try:
        reader.open()
    except Exception as exc:  # rosbags raises its own error types
        raise InputError(bag, f"cannot be opened as a ROS bag ({exc})") from exc
    return reader


def rosbag_intrinsics(bag: str | PathLike[str], info_topic: str) -> Intrinsics:
    """The colour camera of a bag's first ``sensor_msgs/CameraInfo`` on ``info_topic``
    (``K`` → fx, fy, cx, cy; ``up`` unknown: estimated per frame from the support plane)."""
    reader = _open(bag)
    try:
        conns = [c for c in reader.connections if c.topic == info_topic]
        if not conns:
            topics = ", ".join(sorted({c.topic for c in reader.connections}))
            raise InputError(bag, f"has no topic {info_topic!r} (topics: {topics})")
        for conn, _, raw in reader.messages(connections=conns):
            m = reader.deserialize(raw, conn.msgtype)
            k = [float(v) for v in m.k]
            try:
                return Intrinsics(
                    k[0],
                    k[4],
                    k[2],
                    k[5],
                    int(m.width),
                    int(m.height),
                    source=f"{bag} {info_topic}",
                )
            except (ValueError, IndexError) as exc:
                raise InputError(bag, f"{info_topic}: not a usable CameraInfo ({exc})") from None
    finally:
        reader.close()
    raise InputError(bag, f"has no CameraInfo message on {info_topic!r}")


def _decode(conn: Any, msg: Any, roles: Mapping[str, str], scale: float) -> NDArray[Any]:
    role = roles[conn.topic]
    if role == "depth":
        return _depth_from_msg(msg, scale)
    if role == "masks":
        return _masks_from_msg(msg)
    return _image_from_msg(msg)


def rosbag_rgbd_frames(
    bag: str | PathLike[str],
    color_topic: str,
    depth_topic: str,
    *,
    masks_topic: str | None = None,
    labels: Mapping[int, str] | None = None,
    depth_scale: float = DEFAULT_DEPTH_SCALE,
    max_skew_s: float = 0.02,
) -> Iterator[RGBDFrame | BrokenFrame]:
    """RGB-D frames of a ROS 2 (or ROS 1) bag read with ``rosbags``.

    Colour (rgb8, bgr8, rgba8, bgra8, mono8), depth (16UC1 / mono16 in ``depth_scale``
    metres, 32FC1 in metres) and, when given, instance masks (mono8 / mono16, named by
    ``labels``) are grouped by header stamp: each depth image with the nearest colour (and
    masks) image within ``max_skew_s``; a depth image without its partners is a broken frame.
    """
    reader = _open(bag)
    roles = {color_topic: "color", depth_topic: "depth"}
    if masks_topic is not None:
        roles[masks_topic] = "masks"
    try:
        topics = {c.topic for c in reader.connections}
        for t in roles:
            if t not in topics:
                raise InputError(bag, f"has no topic {t!r} (topics: {', '.join(sorted(topics))})")
        conns = [c for c in reader.connections if c.topic in roles]
        pending: dict[str, list[tuple[int, Any]]] = {r: [] for r in roles.values()}
        state: dict[str, Any] = {"k": 0, "t0": None}
        for conn, ts, raw in reader.messages(connections=conns):
            try:
                msg = reader.deserialize(raw, conn.msgtype)
                pending[roles[conn.topic]].append(
                    (_stamp(msg, ts), _decode(conn, msg, roles, depth_scale))
                )
            except Exception as exc:
                yield BrokenFrame(state["k"], f"{bag} {conn.topic} @ {ts}", f"bad message ({exc})")
                state["k"] += 1
                continue
            yield from _groups(pending, state, bag, labels, max_skew_s)
        for stamp, _ in pending["depth"]:
            yield BrokenFrame(state["k"], f"{bag} @ {stamp}", "a depth image without its partners")
            state["k"] += 1
    finally:
        reader.close()


def _groups(
    pending: dict[str, list[tuple[int, Any]]],
    state: dict[str, Any],
    bag: Any,
    labels: Mapping[int, str] | None,
    max_skew_s: float,
) -> Iterator[RGBDFrame | BrokenFrame]:
    """The complete groups (depth + colour [+ masks] within the skew) pending now."""
    skew = int(max_skew_s * 1e9)
    while pending["depth"]:
        stamp, depth = pending["depth"][0]
        found: dict[str, Any] = {}
        for role, queue in pending.items():
            if role == "depth":
                continue
            while queue and queue[0][0] < stamp - skew:
                queue.pop(0)  # too old for this depth image and every later one
            near = [i for i, (s, _) in enumerate(queue) if abs(s - stamp) <= skew]
            if near:
                found[role] = near[0]
            elif queue and queue[0][0] > stamp + skew:
                found[role] = None  # its partner is missing: the frame is broken
            else:
                return  # wait for more messages
        pending["depth"].pop(0)
        k = state["k"]
        state["k"] += 1
        where = f"{bag} @ {stamp}"
        if any(v is None for v in found.values()):
            yield BrokenFrame(k, where, "a depth image without its colour (or masks) image")
            continue
        items = {r: pending[r].pop(i)[1] for r, i in found.items()}
        state["t0"] = stamp if state["t0"] is None else state["t0"]
        masks = items.get("masks")
        yield RGBDFrame(
            k,
            (stamp - state["t0"]) / 1e9,
            items["color"],
            depth,
            masks,
            present_labels(labels, masks),
            where,
        )
