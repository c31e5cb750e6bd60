"""RGBDStream on synthetic RGB-D + masks frames: ids kept when a segmenter renumbers its
instances, an object going behind a nearer one is hidden, one leaving the picture is out of
view, a new one appears; words steady while nothing moves."""

from __future__ import annotations

import numpy as np
import pytest

from scenespeak.errors import ScenespeakError
from scenespeak.live.rgbd_sources import present_labels
from scenespeak.live.rgbd_stream import RGBDStream
from scenespeak.perception.intrinsics import Intrinsics

CAM = Intrinsics(500.0, 500.0, 160.0, 120.0, 320, 240, up=(0.0, -1.0, 0.0))


def _frame(objects: list[tuple[int, int, int, float]]) -> tuple[np.ndarray, np.ndarray]:
    """Depth and masks of slabs ``(instance, column, width, depth)`` (far ones drawn first)."""
    depth = np.full((240, 320), 4.0, np.float32)
    masks = np.zeros((240, 320), np.int32)
    for k, u, w, z in sorted(objects, key=lambda o: -o[3]):
        u0, u1 = max(0, u), min(320, u + w)
        if u1 > u0:
            depth[100:160, u0:u1], masks[100:160, u0:u1] = z, k
    return depth, masks


def _run(stream: RGBDStream, frames, labels) -> list[dict]:
    out = []
    for f, lab in zip(frames, labels, strict=True):
        depth, masks = _frame(f)
        # one labels mapping for the stream: the instances out of sight this frame dropped
        out.append(stream.process(depth, masks, present_labels(lab, masks)).to_dict())
    return out


def test_ids_survive_renumbered_instances_and_an_object_goes_behind_another() -> None:
    stream = RGBDStream(CAM)
    frames, labels = [], []
    for k in range(12):  # the mug (2 m) slides right, behind the box (1 m), and is hidden
        mug = (1, 60 + 12 * k, 30, 2.0) if k < 8 else None
        box = (2, 170, 60, 1.0)
        objs = [o for o in (mug, box) if o is not None]
        if k % 2:  # the segmenter swaps its instance numbers every other frame
            objs = [(3 - i, u, w, z) for i, u, w, z in objs]
        frames.append(objs)
        labels.append({i: ("mug" if (i == 1) == (k % 2 == 0) else "box") for i, *_ in objs})
    lines = _run(stream, frames, labels)
    ids = {(o["label"], o["id"]) for ln in lines for o in ln["objects"]}
    assert ids == {("mug", 1), ("box", 2)}
    last = {o["label"]: o for o in lines[-1]["objects"]}
    assert last["mug"]["status"] == "hidden" and last["mug"]["source"] == "remembered"
    assert last["mug"]["sentence"] == "The mug is hidden behind the box."
    events = [e for ln in lines for e in ln["events"]]
    assert "The mug is hidden behind the box." in events
    assert not any("out of view" in e for e in events)


def test_leaving_the_picture_is_out_of_view_and_a_new_object_appears() -> None:
    stream = RGBDStream(CAM)
    frames = [
        [(1, 200 + 20 * k, 40, 2.0)] + ([(2, 20, 40, 1.5)] if k >= 4 else []) for k in range(9)
    ]
    labels = [{1: "can", 2: "tin"} if k >= 4 else {1: "can"} for k in range(9)]
    lines = _run(stream, frames, labels)
    events = [(ln["frame"], e) for ln in lines for e in ln["events"]]
    assert (5, "A tin appeared.") in events
    assert any(e == "The can is out of view." for _, e in events)
    assert len(events) == 2
    assert [o["status"] for o in lines[-1]["objects"]] == ["out of view", "seen"]


def test_static_frames_say_the_same_words() -> None:
    stream = RGBDStream(CAM)
    objs = [(1, 40, 40, 1.5), (2, 200, 40, 1.5)]
    lines = _run(stream, [objs] * 5, [{1: "mug", 2: "can"}] * 5)
    sentences = {tuple(r["sentence"] for r in ln["relations"]) for ln in lines}
    assert sentences == {("The mug is directly to the left of the can.",
                          "The can is directly to the right of the mug.")}  # fmt: skip
    assert all(not ln["events"] for ln in lines)
    assert lines[0]["timings_ms"]["total"] > 0


def test_bad_frames_leave_the_stream_as_it_was() -> None:
    stream = RGBDStream(CAM)
    depth, masks = _frame([(1, 40, 40, 1.5)])
    stream.process(depth, masks, {1: "mug"})
    with pytest.raises(ScenespeakError, match="10x10"):
        stream.process(depth, np.zeros((10, 10), np.int32), {1: "mug"})
    with pytest.raises(ScenespeakError, match="intrinsics"):
        stream.process(depth[:100], masks[:100], {1: "mug"})
    with pytest.raises(ScenespeakError, match="names instance 7"):
        stream.process(depth, masks, {7: "mug"})
    with pytest.raises(ScenespeakError, match="no masks"):
        stream.process(depth)
    empty = stream.process(depth, np.zeros_like(masks), {}).to_dict()
    assert [o["status"] for o in empty["objects"]] == ["out of view"]


def _msg(enc: str, a: np.ndarray, bigendian: bool = False):
    from types import SimpleNamespace

    h, w = a.shape
    return SimpleNamespace(
        height=h, width=w, encoding=enc, step=a.itemsize * w, is_bigendian=int(bigendian),
        data=np.frombuffer(a.tobytes(), np.uint8),
    )  # fmt: skip


def test_ros_depth_and_mask_encodings() -> None:
    from scenespeak.live.rgbd_sources import _depth_from_msg, _masks_from_msg

    mm = np.array([[0, 1000], [1500, 65535]], np.uint16)
    d = _depth_from_msg(_msg("16UC1", mm.astype("<u2")), 0.001)
    assert np.isnan(d[0, 0]) and d[0, 1] == pytest.approx(1.0) and d[1, 0] == pytest.approx(1.5)
    big = _depth_from_msg(_msg("16UC1", mm.astype(">u2"), bigendian=True), 0.001)
    assert np.array_equal(np.nan_to_num(big), np.nan_to_num(d))
    f = _depth_from_msg(_msg("32FC1", np.array([[np.nan, 1.0], [1.5, 2.0]], "<f4")), 0.001)
    assert np.isnan(f[0, 0]) and f[1, 1] == pytest.approx(2.0)
    m = _masks_from_msg(_msg("mono16", np.array([[0, 3], [300, 3]], "<u2")))
    assert m.dtype == np.int32 and m.tolist() == [[0, 3], [300, 3]]
    with pytest.raises(ValueError, match="not supported"):
        _depth_from_msg(_msg("rgb8", np.zeros((2, 2), np.uint8)), 0.001)
    short = _msg("16UC1", mm)
    short.data = short.data[:3]
    with pytest.raises(ValueError, match="only 3 bytes"):
        _depth_from_msg(short, 0.001)
