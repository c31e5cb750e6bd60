"""``scenespeak watch`` on every kind of source: both folder layouts, two videos, a side-by-side
video, a real ROS 2 bag written with rosbags (Image and CameraInfo topics); broken frames."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import cv2
import numpy as np
import pytest

from scenespeak.cli import main


def _run(args: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, list[dict], str]:
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, [json.loads(line) for line in out.splitlines() if line.strip()], err


def _labels(lines: list[dict]) -> list[set[str]]:
    return [{o["label"] for o in ln["objects"] if o["status"] == "seen"} for ln in lines]


def test_frames_folder_numbered_subfolders(live_data, capsys) -> None:
    code, lines, err = _run(
        ["watch", "--db", live_data.db, "--calib", live_data.calib, "--frames", live_data.sequence,
         "--max-frames", 5],
        capsys,
    )  # fmt: skip
    assert code == 0, err
    assert [ln["frame"] for ln in lines] == [0, 1, 2, 3, 4]
    assert lines[1]["time_s"] == pytest.approx(1 / 30, abs=1e-6)
    ids = [{o["label"]: o["id"] for o in ln["objects"]} for ln in lines]
    assert all(d["box"] == ids[0]["box"] for d in ids)
    assert "A tin appeared." in [e for ln in lines for e in ln["events"]]


def test_flat_layout_and_a_broken_frame(live_data, tmp_path, capsys) -> None:
    for k in range(4):
        left, right = live_data.pair(k)
        shutil.copy(left, tmp_path / f"left_{k:04d}.png")
        shutil.copy(right, tmp_path / f"right_{k:04d}.png")
    (tmp_path / "left_0001.png").write_bytes(b"not a png")
    (tmp_path / "right_0002.png").unlink()
    code, lines, err = _run(
        ["watch", "--db", live_data.db, "--calib", live_data.calib, "--frames", tmp_path], capsys
    )
    assert code == 0
    assert [ln["frame"] for ln in lines] == [0, 3]
    problems = err.strip().splitlines()
    assert len(problems) == 2
    assert "left_0001.png" in problems[0] and "cannot be read" in problems[0]
    assert "right_0002.png" in problems[1] and "no such file" in problems[1]


def _write_video(path: Path, frames: list[np.ndarray]) -> None:
    h, w = frames[0].shape[:2]
    vw = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 10.0, (w, h))
    assert vw.isOpened()
    for f in frames:
        vw.write(f)
    vw.release()


def test_two_videos_and_side_by_side(live_data, tmp_path, capsys) -> None:
    pairs = [tuple(cv2.imread(str(p)) for p in live_data.pair(k)) for k in range(3)]
    _write_video(tmp_path / "l.avi", [p[0] for p in pairs])
    _write_video(tmp_path / "r.avi", [p[1] for p in pairs])
    _write_video(tmp_path / "sbs.avi", [np.hstack(p) for p in pairs])
    base = ["watch", "--db", live_data.db, "--calib", live_data.calib]
    code, two, err = _run(
        [*base, "--left-video", tmp_path / "l.avi", "--right-video", tmp_path / "r.avi"], capsys
    )
    assert code == 0, err
    code, sbs, err = _run([*base, "--sbs", tmp_path / "sbs.avi"], capsys)
    assert code == 0, err
    assert len(two) == len(sbs) == 3
    assert _labels(two)[0] == _labels(sbs)[0] == {"box", "book"}
    assert two[1]["time_s"] == pytest.approx(0.1, abs=1e-3)


def _write_bag(path: Path, live_data, n: int) -> None:
    from rosbags.rosbag2 import Writer
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS2_HUMBLE)
    Image = ts.types["sensor_msgs/msg/Image"]
    Info = ts.types["sensor_msgs/msg/CameraInfo"]
    Header = ts.types["std_msgs/msg/Header"]
    Time = ts.types["builtin_interfaces/msg/Time"]
    ROI = ts.types["sensor_msgs/msg/RegionOfInterest"]
    calib = json.loads(live_data.calib.read_text())
    w, h = calib["image_size"]
    f = (w / 2) / np.tan(np.radians(calib["hfov_deg"]) / 2)
    cx, cy = (w - 1) / 2, (h - 1) / 2
    K = np.array([f, 0, cx, 0, f, cy, 0, 0, 1.0])
    R = np.eye(3).ravel()

    def info(stamp, frame, tx):
        P = np.array([f, 0, cx, tx, 0, f, cy, 0, 0, 0, 1, 0.0])
        return Info(
            Header(stamp, frame), h, w, "plumb_bob", np.zeros(5), K, R, P, 0, 0,
            ROI(0, 0, 0, 0, False),
        )  # fmt: skip

    with Writer(path, version=8) as writer:
        conns = {
            t: writer.add_connection(t, m.__msgtype__, typestore=ts)
            for t, m in (("/left/image_raw", Image), ("/right/image_raw", Image),
                         ("/left/camera_info", Info), ("/right/camera_info", Info))
        }  # fmt: skip
        for k in range(n):
            ns = 1_000_000_000 + k * 100_000_000
            stamp = Time(ns // 1_000_000_000, ns % 1_000_000_000)
            for side, tx in (("left", 0.0), ("right", -f * calib["baseline"])):
                rgb = cv2.cvtColor(
                    cv2.imread(str(live_data.pair(k)[side == "right"])), cv2.COLOR_BGR2RGB
                )
                msg = Image(Header(stamp, side), h, w, "rgb8", 0, w * 3, rgb.reshape(-1))
                writer.write(
                    conns[f"/{side}/image_raw"], ns, ts.serialize_cdr(msg, Image.__msgtype__)
                )
                writer.write(
                    conns[f"/{side}/camera_info"], ns,
                    ts.serialize_cdr(info(stamp, side, tx), Info.__msgtype__),
                )  # fmt: skip


def test_ros2_bag_with_camera_info(live_data, tmp_path, capsys) -> None:
    bag = tmp_path / "bag"
    _write_bag(bag, live_data, 3)
    code, lines, err = _run(
        ["watch", "--db", live_data.db, "--rosbag", bag,
         "--left-topic", "/left/image_raw", "--right-topic", "/right/image_raw",
         "--left-info", "/left/camera_info", "--right-info", "/right/camera_info"],
        capsys,
    )  # fmt: skip
    assert code == 0, err
    assert len(lines) == 3
    assert [ln["time_s"] for ln in lines] == pytest.approx([0.0, 0.1, 0.2])
    assert _labels(lines)[0] == {"box", "book"}
    # the same frames from the folder (with the calibration file) give the same objects
    code, ref, _ = _run(
        ["watch", "--db", live_data.db, "--calib", live_data.calib, "--frames", live_data.sequence,
         "--max-frames", 3],
        capsys,
    )  # fmt: skip
    a = {o["label"]: o["centroid"] for o in lines[0]["objects"]}
    b = {o["label"]: o["centroid"] for o in ref[0]["objects"]}
    assert a.keys() == b.keys()
    for k in a:
        assert np.allclose(a[k], b[k], atol=0.01)


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        ([], "give exactly one source"),
        (["--frames", "MISSING"], "no such folder"),
        (["--left-video", "MISSING.avi"], "go together"),
        (["--sbs", "MISSING.avi"], "no such file"),
        (["--rosbag", "MISSING"], "left-topic"),
    ],
)
def test_bad_sources_are_one_line_errors(live_data, tmp_path, capsys, extra, message) -> None:
    extra = [str(tmp_path / e) if e.startswith("MISSING") else e for e in extra]
    code = main(["watch", "--db", str(live_data.db), "--calib", str(live_data.calib), *extra])
    out, err = capsys.readouterr()
    assert code == 2 and out == ""
    assert len(err.strip().splitlines()) == 1 and message in err
