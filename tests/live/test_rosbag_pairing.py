"""rosbag_frames pairs left and right images by stamp: partnerless images and pairs of
different sizes are broken frames, in stamp order, numbered with the frames."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from scenespeak.live.sources import BrokenFrame, Frame, rosbag_frames


def _bag(path: Path, images: list[tuple[str, int, tuple[int, int]]]) -> None:
    from rosbags.rosbag2 import Writer
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS2_HUMBLE)
    Image = ts.types["sensor_msgs/msg/Image"]
    Header = ts.types["std_msgs/msg/Header"]
    Time = ts.types["builtin_interfaces/msg/Time"]
    with Writer(path, version=8) as writer:
        conns = {
            side: writer.add_connection(f"/{side}", Image.__msgtype__, typestore=ts)
            for side in ("left", "right")
        }
        for side, ns, (h, w) in images:
            rgb = np.full((h, w, 3), 7, np.uint8)
            stamp = Time(ns // 1_000_000_000, ns % 1_000_000_000)
            msg = Image(Header(stamp, side), h, w, "rgb8", 0, w * 3, rgb.reshape(-1))
            writer.write(conns[side], ns, ts.serialize_cdr(msg, Image.__msgtype__))


def test_partnerless_and_mismatched_images_are_broken_frames(tmp_path: Path) -> None:
    s = 1_000_000_000
    bag = tmp_path / "bag"
    _bag(
        bag,
        [
            ("left", s, (4, 6)),
            ("right", s, (4, 6)),
            ("left", s + s // 10, (4, 6)),  # no right image near it
            ("left", s + 2 * s // 10, (4, 6)),
            ("right", s + 2 * s // 10, (4, 6)),
            ("left", s + 3 * s // 10, (4, 6)),
            ("right", s + 3 * s // 10, (5, 6)),  # another size
        ],
    )
    items = list(rosbag_frames(bag, "/left", "/right"))
    kinds = [type(it).__name__ for it in items]
    assert kinds == ["Frame", "BrokenFrame", "Frame", "BrokenFrame"]
    assert [it.index for it in items] == [0, 1, 2, 3]
    assert isinstance(items[1], BrokenFrame) and "without a partner" in items[1].problem
    assert isinstance(items[3], BrokenFrame) and "(4, 6, 3)" in items[3].problem
    assert isinstance(items[2], Frame)
    assert abs(items[2].time_s - 0.2) < 1e-9
