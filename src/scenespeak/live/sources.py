"""Where stereo frames come from: folders, two videos, a side-by-side video, two cameras, or a
ROS 2 bag (``interfaces.md``, "Streams").

Every source yields :class:`Frame` values in order. A frame that cannot be read does not stop
the stream: it is yielded as a :class:`BrokenFrame` carrying a one-line reason, and the
caller says it on stderr and goes on. Problems with the source itself (a missing folder, a
video OpenCV cannot open, a bag without the topics) raise
:class:`~scenespeak.errors.InputError` before the first frame.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from dataclasses import dataclass
from os import PathLike
from pathlib import Path
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

from scenespeak.errors import InputError, ScenespeakError

__all__ = [
    "BrokenFrame",
    "Frame",
    "camera_frames",
    "folder_frames",
    "rosbag_frames",
    "rosbag_rig",
    "sbs_frames",
    "video_frames",
]


@dataclass(frozen=True, eq=False)
class Frame:
    """One stereo frame: RGB images, its time (seconds) and where it came from."""

    index: int
    time_s: float
    left: NDArray[np.uint8]
    right: NDArray[np.uint8]
    source: str


@dataclass(frozen=True)
class BrokenFrame:
    """A frame that could not be read, with why (one line)."""

    index: int
    source: str
    problem: str


Item = Frame | BrokenFrame

_NUM = re.compile(r"(\d+)")


def _read(path: Path) -> NDArray[np.uint8]:
    from scenespeak.perception.features import load_image

    return load_image(path, gray=False)


def _folder_pairs(root: Path) -> list[tuple[str, Path, Path]]:
    """``DIR/NNNN/{left,right}.png`` or ``DIR/left_NNNN.png`` + ``DIR/right_NNNN.png``."""
    sub = sorted(
        (p for p in root.iterdir() if p.is_dir() and p.name.isdigit()), key=lambda p: int(p.name)
    )
    if sub:
        return [(p.name, p / "left.png", p / "right.png") for p in sub]
    lefts = {}
    for p in root.glob("left_*.*"):
        m = _NUM.search(p.stem[5:])
        if m:
            lefts[int(m.group(1))] = p
    pairs = []
    for n in sorted(lefts):
        lp = lefts[n]
        rp = lp.with_name("right_" + lp.name[5:])
        pairs.append((str(n), lp, rp))
    return pairs


def folder_frames(root: str | PathLike[str], *, fps: float = 30.0) -> Iterator[Item]:
    """Frames of a folder, in numeric order; ``time_s`` = position / ``fps``.

    Raises
    ------
    InputError
        If the folder is missing or holds neither layout.
    """
    d = Path(root)
    if not d.is_dir():
        raise InputError(d, "no such folder")
    pairs = _folder_pairs(d)
    if not pairs:
        raise InputError(
            d, "holds no frames (expected NNNN/left.png + NNNN/right.png or left_NNNN.png + "
            "right_NNNN.png)",
        )  # fmt: skip
    for k, (name, lp, rp) in enumerate(pairs):
        try:
            yield Frame(k, k / fps, _read(lp), _read(rp), f"{d}/{name}")
        except ScenespeakError as exc:
            yield BrokenFrame(k, f"{d}/{name}", str(exc))


def _open_video(path: str | PathLike[str] | int) -> Any:
    from scenespeak.safeio import captured_stderr

    with captured_stderr() as noise:  # FFmpeg's own "moov atom not found": said once, by us
        cap = cv2.VideoCapture(path if isinstance(path, int) else str(path))
        opened = cap.isOpened()
    if not opened:
        what = f"camera {path}" if isinstance(path, int) else str(path)
        said = " ".join("".join(noise).split())[:120]
        raise InputError(
            what,
            "cannot be opened as a video (missing, or a codec OpenCV lacks"
            + (f": {said})" if said else ")"),
        )
    return cap


def _time(cap: Any, k: int) -> float:
    """The time of the frame just read: the container's timestamp, else ``k / fps``."""
    t = float(cap.get(cv2.CAP_PROP_POS_MSEC)) / 1000.0
    if t > 0 or k == 0:
        return t
    fps = float(cap.get(cv2.CAP_PROP_FPS))
    return k / fps if fps > 0 else float(k)


def _rgb(frame: NDArray[np.uint8]) -> NDArray[np.uint8]:
    return np.asarray(cv2.cvtColor(frame, cv2.COLOR_BGR2RGB), dtype=np.uint8)


def video_frames(
    left: str | PathLike[str], right: str | PathLike[str], *, max_frames: int | None = None
) -> Iterator[Item]:
    """Frames of two synchronised videos (the shorter one ends the stream)."""
    if not Path(left).exists():
        raise InputError(left, "no such file")
    if not Path(right).exists():
        raise InputError(right, "no such file")
    cl, cr = _open_video(left), _open_video(right)
    try:
        k = 0
        while max_frames is None or k < max_frames:
            okl, fl = cl.read()
            okr, fr = cr.read()
            if not okl or not okr:
                return
            t = _time(cl, k)
            yield Frame(k, t, _rgb(fl), _rgb(fr), f"{left} frame {k}")
            k += 1
    finally:
        cl.release()
        cr.release()


def sbs_frames(path: str | PathLike[str], *, max_frames: int | None = None) -> Iterator[Item]:
    """Frames of a side-by-side video: the left half is the left image."""
    if not Path(path).exists():
        raise InputError(path, "no such file")
    cap = _open_video(path)
    try:
        k = 0
        while max_frames is None or k < max_frames:
            ok, f = cap.read()
            if not ok:
                return
            t = _time(cap, k)
            w = f.shape[1]
            if w % 2:
                yield BrokenFrame(k, f"{path} frame {k}", f"odd width {w}: not side by side")
            else:
                img = _rgb(f)
                yield Frame(k, t, img[:, : w // 2].copy(), img[:, w // 2 :].copy(), f"{path} {k}")
            k += 1
    finally:
        cap.release()


def camera_frames(
    left: int, right: int, *, max_frames: int | None = None
) -> Iterator[Item]:  # pragma: no cover - needs cameras
    """Frames of two cameras (OpenCV ``VideoCapture`` indices): both grabbed, then read, so
    the two images are as close in time as the drivers allow."""
    import time

    cl, cr = _open_video(left), _open_video(right)
    t0 = time.monotonic()
    try:
        k = 0
        while max_frames is None or k < max_frames:
            if not (cl.grab() and cr.grab()):
                yield BrokenFrame(k, f"cameras {left} {right}", "a camera gave no frame")
                return
            okl, fl = cl.retrieve()
            okr, fr = cr.retrieve()
            t = time.monotonic() - t0
            if okl and okr:
                yield Frame(k, t, _rgb(fl), _rgb(fr), f"cameras {left} {right} frame {k}")
            else:
                yield BrokenFrame(k, f"cameras {left} {right}", "a camera frame could not be read")
            k += 1
    finally:
        cl.release()
        cr.release()


# --------------------------------------------------------------------------------------------
# ROS 2 bags


def _image_from_msg(msg: Any) -> NDArray[np.uint8]:
    """A sensor_msgs/Image as RGB uint8 (rgb8, bgr8, rgba8, bgra8, mono8, mono16)."""
    h, w, enc = int(msg.height), int(msg.width), str(msg.encoding).lower()
    data = np.asarray(msg.data, dtype=np.uint8)
    step = int(msg.step)
    channels = {"rgb8": 3, "bgr8": 3, "rgba8": 4, "bgra8": 4, "mono8": 1, "8uc1": 1}
    if enc in ("mono16", "16uc1"):
        if data.size < h * step or step < 2 * w:
            raise ValueError(f"{enc} image of {w}x{h} has only {data.size} bytes")
        rows = data[: h * step].reshape(h, step)[:, : 2 * w]
        order = ">u2" if getattr(msg, "is_bigendian", 0) else "<u2"
        img16 = rows.copy().view(order).reshape(h, w)
        gray = (img16 >> 8).astype(np.uint8)
        return np.repeat(gray[..., None], 3, axis=2)
    if enc not in channels:
        raise ValueError(f"encoding {enc!r} is not supported (rgb8, bgr8, rgba8, bgra8, mono8)")
    c = channels[enc]
    if h <= 0 or w <= 0 or step < c * w or data.size < h * step:
        raise ValueError(f"{enc} image of {w}x{h} (step {step}) has only {data.size} bytes")
    img = data[: h * step].reshape(h, step)[:, : c * w].reshape(h, w, c)
    if c == 1:
        return np.repeat(img, 3, axis=2)
    if enc.startswith("bgr"):
        img = img[..., 2::-1]
    return np.ascontiguousarray(img[..., :3])


def _stamp(msg: Any, fallback_ns: int) -> int:
    try:
        return int(msg.header.stamp.sec) * 1_000_000_000 + int(msg.header.stamp.nanosec)
    except AttributeError:
        return fallback_ns


def _reader(bag: str | PathLike[str]) -> Any:
    from rosbags.highlevel import AnyReader

    p = Path(bag)
    if not p.exists():
        raise InputError(p, "no such bag (a ROS 2 bag folder or a ROS 1 .bag file)")
    try:
        return AnyReader([p])
    except Exception as exc:  # rosbags raises its own error types
        raise InputError(p, f"cannot be read as a ROS bag ({exc})") from exc


def rosbag_frames(
    bag: str | PathLike[str], left_topic: str, right_topic: str, *, max_skew_s: float = 0.02
) -> Iterator[Item]:
    """Stereo frames of a ROS 2 (or ROS 1) bag read with the ``rosbags`` library.

    Left and right ``sensor_msgs/Image`` messages are paired by header stamp (nearest within
    ``max_skew_s``); an image without a partner is a broken frame.
    """
    reader = _reader(bag)
    try:
        reader.open()
    except Exception as exc:
        raise InputError(bag, f"cannot be opened as a ROS bag ({exc})") from exc
    try:
        conns = _stereo_connections(reader, bag, left_topic, right_topic)
        yield from _paired_frames(reader, conns, bag, (left_topic, right_topic), max_skew_s)
    finally:
        reader.close()


def _stereo_connections(
    reader: Any, bag: str | PathLike[str], left_topic: str, right_topic: str
) -> list[Any]:
    """The bag's connections of the two image topics (an error naming the topics it has)."""
    topics = {c.topic for c in reader.connections}
    for t in (left_topic, right_topic):
        if t not in topics:
            raise InputError(bag, f"has no topic {t!r} (topics: {', '.join(sorted(topics))})")
    return [c for c in reader.connections if c.topic in (left_topic, right_topic)]


def _paired_frames(
    reader: Any,
    conns: list[Any],
    bag: str | PathLike[str],
    topics: tuple[str, str],
    max_skew_s: float,
) -> Iterator[Item]:
    """The messages of ``conns`` paired by stamp into frames (see :func:`rosbag_frames`)."""
    left_topic, right_topic = topics
    pending: dict[str, list[tuple[int, Any]]] = {left_topic: [], right_topic: []}
    k = 0
    t_first: int | None = None
    for conn, ts, raw in reader.messages(connections=conns):
        try:
            msg = reader.deserialize(raw, conn.msgtype)
            img = _image_from_msg(msg)
            stamp = _stamp(msg, ts)
        except Exception as exc:
            yield BrokenFrame(k, f"{bag} {conn.topic} @ {ts}", f"bad image message ({exc})")
            k += 1
            continue
        pending[conn.topic].append((stamp, img))
        other = right_topic if conn.topic == left_topic else left_topic
        match = _take_partner(pending[other], stamp, max_skew_s)
        if match is None:
            continue
        pending[conn.topic].pop()
        ls, li = (stamp, img) if conn.topic == left_topic else match
        _, ri = match if conn.topic == left_topic else (stamp, img)
        t_first = ls if t_first is None else t_first
        # Drop the partnerless images older than this pair: they will never be paired.
        for _ in range(_drop_older(pending, ls - int(max_skew_s * 1e9))):
            yield BrokenFrame(k, f"{bag} @ {ls}", "an image without a partner")
            k += 1
        if li.shape != ri.shape:
            yield BrokenFrame(k, f"{bag} @ {ls}", f"left {li.shape} and right {ri.shape}")
        else:
            yield Frame(k, (ls - t_first) / 1e9, li, ri, f"{bag} @ {ls}")
        k += 1


def _drop_older(pending: dict[str, list[tuple[int, Any]]], oldest: int) -> int:
    """Drop the queued images stamped before ``oldest``; how many were dropped."""
    n = 0
    for q in pending.values():
        while q and q[0][0] < oldest:
            q.pop(0)
            n += 1
    return n


def _take_partner(
    queue: list[tuple[int, Any]], stamp: int, max_skew_s: float
) -> tuple[int, Any] | None:
    best, best_d = None, int(max_skew_s * 1e9)
    for i, (s, _) in enumerate(queue):
        d = abs(s - stamp)
        if d <= best_d:
            best, best_d = i, d
    return None if best is None else queue.pop(best)


def rosbag_rig(
    bag: str | PathLike[str], left_info: str, right_info: str, out_dir: str | PathLike[str]
) -> Any:
    """The rig of a bag's two ``sensor_msgs/CameraInfo`` topics (their first messages),
    through :func:`scenespeak.perception.calibration.load_ros_rig` (written as camera_info
    YAML files into ``out_dir``)."""
    import yaml

    from scenespeak.perception.calibration import load_ros_rig

    reader = _reader(bag)
    try:
        reader.open()
    except Exception as exc:
        raise InputError(bag, f"cannot be opened as a ROS bag ({exc})") from exc
    found: dict[str, Any] = {}
    try:
        conns = [c for c in reader.connections if c.topic in (left_info, right_info)]
        for conn, _, raw in reader.messages(connections=conns):
            if conn.topic not in found:
                found[conn.topic] = reader.deserialize(raw, conn.msgtype)
            if len(found) == 2:
                break
    finally:
        reader.close()
    paths = []
    for topic in (left_info, right_info):
        if topic not in found:
            raise InputError(bag, f"has no CameraInfo message on {topic!r}")
        m = found[topic]
        data = {
            "width": int(m.width),
            "height": int(m.height),
            "distortion_model": str(m.distortion_model or "plumb_bob"),
            "K": [float(v) for v in m.k],
            "D": [float(v) for v in m.d] or [0.0] * 5,
            "R": [float(v) for v in m.r],
            "P": [float(v) for v in m.p],
        }
        p = Path(out_dir) / (topic.strip("/").replace("/", "_") + ".yaml")
        p.write_text(yaml.safe_dump(data), encoding="utf-8")
        paths.append(p)
    return load_ros_rig(paths[0], paths[1])
