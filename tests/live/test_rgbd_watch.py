"""``scenespeak watch`` on RGB-D + masks frames: the rendered sequence's folder (ids, the
scripted event, nothing else said), the same frames from a real ROS 2 bag written with rosbags
(colour, 16UC1 depth, mono8 masks, CameraInfo), broken frames, bad sources."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import cv2
import numpy as np
import pytest

from scenespeak.cli import main


def _run(args: list, capsys: pytest.CaptureFixture[str]) -> tuple[int, list[dict], str]:
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, [json.loads(line) for line in out.splitlines() if line.strip()], err


def test_rgbd_folder_keeps_ids_and_says_the_appearance(live_data, capsys) -> None:
    code, lines, err = _run(["watch", "--rgbd", live_data.sequence], capsys)
    assert code == 0, err
    truth = json.loads((live_data.sequence / "truth.json").read_text())
    assert [ln["frame"] for ln in lines] == list(range(len(truth["frames"])))
    ids: dict[str, set[int]] = {}
    for ln, fr in zip(lines, truth["frames"], strict=True):
        seen = {o["label"]: o for o in ln["objects"] if o["status"] == "seen"}
        visible = {o["label"]: o for o in fr["objects"] if o["visible_fraction"] > 0.2}
        assert set(visible) <= set(seen), (ln["frame"], set(seen), set(visible))
        for label, o in seen.items():
            ids.setdefault(label, set()).add(o["id"])
            assert o["source"] == "mask" and o["points"] > 50
            if label in visible:  # the visible surface's centroid vs the body's centre
                gap = np.linalg.norm(np.subtract(o["centroid"], visible[label]["centroid"]))
                assert gap < 0.08, (label, gap)
        assert ln["up_source"] == "given" and ln["recognised"] and ln["reason"] == "masks"
    assert all(len(v) == 1 for v in ids.values()), ids  # one id per object, every frame
    assert len({i for v in ids.values() for i in v}) == len(ids)
    (appeared,) = [e for e in truth["events"] if e["kind"] == "appeared"]
    label = truth["labels"][str(appeared["object"])]
    said = [(ln["frame"], e) for ln in lines for e in ln["events"]]
    assert said and said[0][1] == f"A {label} appeared."
    assert appeared["frame"] <= said[0][0] <= appeared["frame"] + 3
    assert len(said) == 1, said  # nothing else changed
    assert lines[-1]["relations"] and all(r["sentence"] for r in lines[-1]["relations"])


def _copy_frames(src: Path, dst: Path, n: int) -> Path:
    dst.mkdir()
    shutil.copy(src / "intrinsics.json", dst / "intrinsics.json")
    for k in range(n):
        shutil.copytree(src / f"{k:04d}", dst / f"{k:04d}")
    return dst


def test_flat_layout_gives_the_subfolders_lines(live_data, tmp_path, capsys) -> None:
    flat = tmp_path / "flat"
    flat.mkdir()
    shutil.copy(live_data.sequence / "intrinsics.json", flat / "intrinsics.json")
    for k in range(4):
        d = live_data.sequence / f"{k:04d}"
        for src, dst in (("left.png", "color"), ("depth.png", "depth"), ("masks.png", "masks")):
            shutil.copy(d / src, flat / f"{dst}_{k:04d}.png")
        shutil.copy(d / "labels.json", flat / f"labels_{k:04d}.json")
    code, lines, err = _run(["watch", "--rgbd", flat], capsys)
    assert code == 0, err
    code, ref, err = _run(
        ["watch", "--rgbd", _copy_frames(live_data.sequence, tmp_path / "s", 4)], capsys
    )
    assert code == 0, err
    strip = [{k: v for k, v in ln.items() if k != "timings_ms"} for ln in lines]
    assert strip == [{k: v for k, v in ln.items() if k != "timings_ms"} for ln in ref]


def test_a_broken_frame_is_one_warning_and_the_stream_goes_on(live_data, tmp_path, capsys) -> None:
    d = _copy_frames(live_data.sequence, tmp_path / "seq", 4)
    (d / "0001" / "depth.png").write_bytes(b"not a png")
    cv2.imwrite(str(d / "0002" / "masks.png"), np.zeros((10, 10), np.uint8))  # another size
    code, lines, err = _run(["watch", "--rgbd", d], capsys)
    assert code == 0
    assert [ln["frame"] for ln in lines] == [0, 3]
    warnings = err.strip().splitlines()
    assert len(warnings) == 2 and all(w.startswith("scenespeak: warning: ") for w in warnings)
    assert "0001" in warnings[0] and "depth.png" in warnings[0]
    assert "0002" in warnings[1] and "10x10" in warnings[1]
    first = {o["label"]: o["id"] for o in lines[0]["objects"]}
    assert {o["label"]: o["id"] for o in lines[1]["objects"] if o["label"] in first} == first


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--rgbd", "MISSING"], "no such folder"),
        (["--depth-topic", "/d"], "--color-topic"),
    ],
)
def test_bad_rgbd_sources_are_one_line_errors(extra, message, capsys) -> None:
    code, lines, err = _run(["watch", *extra], capsys)
    assert code == 2 and not lines
    assert message in err and len(err.strip().splitlines()) == 1


def test_rgbd_frames_without_masks_need_the_database(live_data, tmp_path, capsys) -> None:
    d = _copy_frames(live_data.sequence, tmp_path / "seq", 3)
    for k in range(3):
        (d / f"{k:04d}" / "masks.png").unlink()
    code, lines, err = _run(["watch", "--rgbd", d], capsys)
    assert code == 2 and not lines and "--db" in err and len(err.strip().splitlines()) == 1
    code, lines, err = _run(["watch", "--rgbd", d, "--db", live_data.db], capsys)
    assert code == 0, err
    assert len(lines) == 3 and all(o["source"] == "database" for o in lines[0]["objects"])
    assert lines[0]["reason"] == "database" and lines[0]["objects"]


def test_rgbd_folder_without_intrinsics(live_data, tmp_path, capsys) -> None:
    d = _copy_frames(live_data.sequence, tmp_path / "seq", 2)
    (d / "intrinsics.json").unlink()
    code, _, err = _run(["watch", "--rgbd", d], capsys)
    assert code == 2 and "--intrinsics" in err and len(err.strip().splitlines()) == 1


def _write_rgbd_bag(path: Path, seq: Path, n: int) -> None:
    from rosbags.rosbag2 import Writer
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS2_HUMBLE)
    Image = ts.types["sensor_msgs/msg/Image"]
    Info = ts.types["sensor_msgs/msg/CameraInfo"]
    Header = ts.types["std_msgs/msg/Header"]
    Time = ts.types["builtin_interfaces/msg/Time"]
    ROI = ts.types["sensor_msgs/msg/RegionOfInterest"]
    cam = json.loads((seq / "intrinsics.json").read_text())
    w, h = cam["width"], cam["height"]
    K = np.array([cam["fx"], 0, cam["cx"], 0, cam["fy"], cam["cy"], 0, 0, 1.0])
    P = np.array([cam["fx"], 0, cam["cx"], 0, 0, cam["fy"], cam["cy"], 0, 0, 0, 1, 0.0])
    topics = {"/cam/color": Image, "/cam/depth": Image, "/cam/masks": Image, "/cam/info": Info}
    with Writer(path, version=8) as writer:
        conns = {
            t: writer.add_connection(t, m.__msgtype__, typestore=ts) for t, m in topics.items()
        }
        for k in range(n):
            d = seq / f"{k:04d}"
            ns = 1_000_000_000 + k * 33_000_000
            hd = Header(Time(ns // 1_000_000_000, ns % 1_000_000_000), "camera")
            rgb = cv2.cvtColor(cv2.imread(str(d / "left.png")), cv2.COLOR_BGR2RGB)
            depth = cv2.imread(str(d / "depth.png"), cv2.IMREAD_UNCHANGED).astype("<u2")
            masks = cv2.imread(str(d / "masks.png"), cv2.IMREAD_UNCHANGED)
            msgs = {
                "/cam/color": Image(hd, h, w, "rgb8", 0, w * 3, rgb.reshape(-1)),
                "/cam/depth": Image(hd, h, w, "16UC1", 0, w * 2, depth.view(np.uint8).reshape(-1)),
                "/cam/masks": Image(hd, h, w, "mono8", 0, w, masks.reshape(-1)),
                "/cam/info": Info(
                    hd, h, w, "plumb_bob", np.zeros(5), K, np.eye(3).ravel(), P, 0, 0,
                    ROI(0, 0, 0, 0, False),
                ),
            }  # fmt: skip
            for t, msg in msgs.items():
                writer.write(conns[t], ns, ts.serialize_cdr(msg, topics[t].__msgtype__))


def test_ros2_bag_gives_the_folder_s_lines(live_data, tmp_path, capsys) -> None:
    pytest.importorskip("rosbags")
    n = 5
    seq = _copy_frames(live_data.sequence, tmp_path / "seq", n)
    labels = json.loads((live_data.sequence / "truth.json").read_text())["labels"]
    (tmp_path / "labels.json").write_text(json.dumps(labels))
    bag = tmp_path / "bag"
    _write_rgbd_bag(bag, seq, n)
    topics = ["--color-topic", "/cam/color", "--depth-topic", "/cam/depth",
              "--masks-topic", "/cam/masks", "--labels", tmp_path / "labels.json"]  # fmt: skip
    code, from_bag, err = _run(
        ["watch", "--rosbag", bag, *topics, "--intrinsics", seq / "intrinsics.json"], capsys
    )
    assert code == 0, err
    code, from_folder, err = _run(["watch", "--rgbd", seq], capsys)
    assert code == 0, err
    assert len(from_bag) == len(from_folder) == n
    for a, b in zip(from_bag, from_folder, strict=True):
        assert [(o["id"], o["label"], o["centroid"]) for o in a["objects"]] == [
            (o["id"], o["label"], o["centroid"]) for o in b["objects"]
        ]
        assert [r["sentence"] for r in a["relations"]] == [r["sentence"] for r in b["relations"]]
    assert from_bag[1]["time_s"] == pytest.approx(0.033)
    # the camera from CameraInfo (no up in it: estimated from the floor)
    code, lines, err = _run(
        ["watch", "--rosbag", bag, *topics, "--info-topic", "/cam/info"], capsys
    )
    assert code == 0, err
    assert len(lines) == n and lines[0]["up_source"] == "estimated"
    assert {o["label"] for o in lines[0]["objects"]} == {
        o["label"] for o in from_folder[0]["objects"]
    }
