"""Depth, intrinsics, masks and boxes as users' cameras and segmenters write them."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from scenespeak.errors import ImageError, InputError
from scenespeak.perception.depth import check_depth_size, load_depth
from scenespeak.perception.intrinsics import load_intrinsics
from scenespeak.perception.masks import (
    instances_from_array,
    load_boxes,
    load_instances,
    load_labels,
)


def test_png_millimetres_and_scale(tmp_path: Path) -> None:
    p = tmp_path / "d.png"
    cv2.imwrite(str(p), np.array([[0, 1000], [2500, 65535]], np.uint16))
    d = load_depth(p)
    assert np.isnan(d[0, 0]) and d[0, 1] == pytest.approx(1.0) and d[1, 0] == pytest.approx(2.5)
    assert load_depth(p, scale=0.0001)[0, 1] == pytest.approx(0.1)


def test_float_tiff_and_npy_in_metres_with_holes(tmp_path: Path) -> None:
    import tifffile

    a = np.array([[np.nan, 1.25], [np.inf, -1.0], [0.0, 3.0]], np.float32)
    tifffile.imwrite(str(tmp_path / "d.tif"), a)
    np.save(tmp_path / "d.npy", a.astype(np.float64))
    for name in ("d.tif", "d.npy"):
        d = load_depth(tmp_path / name)
        assert d.dtype == np.float32
        assert np.isnan(d).sum() == 4, name
        assert d[0, 1] == pytest.approx(1.25) and d[2, 1] == pytest.approx(3.0)


@pytest.mark.parametrize(
    ("make", "needle"),
    [
        (lambda p: cv2.imwrite(str(p), np.full((4, 4), 9, np.uint8)), "uint8"),
        (lambda p: cv2.imwrite(str(p), np.full((4, 4, 3), 9, np.uint8)), "one channel"),
        (lambda p: cv2.imwrite(str(p), np.zeros((4, 4), np.uint16)), "no valid depth"),
        (lambda p: p.write_text("not an image"), "cannot be read"),
    ],
    ids=["8-bit", "colour", "all-zero", "text"],
)
def test_bad_depth_names_the_file(tmp_path: Path, make, needle: str) -> None:
    p = tmp_path / "depth.png"
    make(p)
    with pytest.raises(ImageError, match=needle) as info:
        load_depth(p)
    assert str(p) in str(info.value)


def test_depth_of_another_size() -> None:
    with pytest.raises(ImageError, match="320x240 but the colour image is 640x480"):
        check_depth_size(np.zeros((240, 320)), (640, 480))


def test_intrinsics_three_forms(tmp_path: Path) -> None:
    (tmp_path / "a.json").write_text(
        json.dumps({"fx": 600, "fy": 601, "cx": 320, "cy": 240, "width": 640, "height": 480})
    )
    (tmp_path / "ros.yaml").write_text(
        "image_width: 640\nimage_height: 480\ncamera_name: rgb\n"
        "camera_matrix:\n  rows: 3\n  cols: 3\n  data: [600, 0, 320, 0, 601, 240, 0, 0, 1]\n"
        "distortion_model: plumb_bob\n"
    )
    (tmp_path / "cv.yaml").write_text(
        "%YAML:1.0\n---\nimage_width: 640\nimage_height: 480\ncamera_matrix: !!opencv-matrix\n"
        "   rows: 3\n   cols: 3\n   dt: d\n"
        "   data: [ 600., 0., 320., 0., 601., 240., 0., 0., 1. ]\n"
    )
    for name in ("a.json", "ros.yaml", "cv.yaml"):
        cam = load_intrinsics(tmp_path / name)
        assert (cam.fx, cam.fy, cam.cx, cam.cy, cam.size, cam.up) == (
            600.0,
            601.0,
            320.0,
            240.0,
            (640, 480),
            None,
        ), name


def test_intrinsics_up_and_pose(tmp_path: Path) -> None:
    base = {"fx": 600, "fy": 600, "cx": 320, "cy": 240, "width": 640, "height": 480}
    (tmp_path / "up.json").write_text(json.dumps({**base, "up": [0, -2, 0]}))
    assert load_intrinsics(tmp_path / "up.json").up == (0.0, -1.0, 0.0)
    # a camera pitched 30 deg down, camera-to-world pose of a z-up world
    a = np.radians(30)
    R = np.array([[1, 0, 0], [0, -np.sin(a), np.cos(a)], [0, -np.cos(a), -np.sin(a)]])
    T = np.eye(4)
    T[:3, :3] = R
    (tmp_path / "pose.json").write_text(
        json.dumps({**base, "camera_pose_cam_to_world": T.tolist()})
    )
    up = np.array(load_intrinsics(tmp_path / "pose.json").up)
    assert np.allclose(R @ up, [0, 0, 1])


@pytest.mark.parametrize(
    ("text", "needle"),
    [
        ('{"fx": 600, "fy": 600, "cx": 320, "width": 640, "height": 480}', 'missing "cy"'),
        ('{"fx": -1, "fy": 600, "cx": 320, "cy": 2, "width": 640, "height": 480}', "positive"),
        ('{"fx": 600, "fy": 600, "cx": 320, "cy": 240}', "image size"),
        ("{not json", "not valid JSON"),
        ("", "empty"),
    ],
)
def test_bad_intrinsics(tmp_path: Path, text: str, needle: str) -> None:
    p = tmp_path / "cam.json"
    p.write_text(text)
    with pytest.raises(InputError, match=needle) as info:
        load_intrinsics(p)
    assert str(p) in str(info.value)


def test_hostile_intrinsics_are_refused_before_they_cost(tmp_path: Path) -> None:
    """The intrinsics go through the calibration readers' bounds (docs/trust.md)."""
    laughs = ["a: &a [x, x, x, x, x, x, x, x, x]"]
    laughs += [f"{k}: &{k} [*{p}, *{p}, *{p}, *{p}, *{p}, *{p}, *{p}, *{p}]"
               for p, k in zip("abcdefgh", "bcdefghi", strict=True)]  # fmt: skip
    bomb = tmp_path / "bomb.yaml"
    bomb.write_text("\n".join(laughs) + "\nfx: *i\n")
    with pytest.raises(InputError, match=r"bomb\.yaml"):
        load_intrinsics(bomb)
    tag = tmp_path / "tag.yaml"
    tag.write_text("fx: !!python/object/apply:os.system ['true']\n")
    with pytest.raises(InputError, match=r"tag\.yaml"):
        load_intrinsics(tag)
    folder = tmp_path / "cam.json"
    folder.mkdir()
    with pytest.raises(InputError, match=r"cam\.json"):
        load_intrinsics(folder)


def test_masks_and_labels(tmp_path: Path) -> None:
    inst = np.zeros((10, 20), np.uint16)
    inst[2:5, 2:6] = 1
    inst[2:5, 10:16] = 7
    p = tmp_path / "inst.png"
    cv2.imwrite(str(p), inst)
    (tmp_path / "labels.json").write_text(json.dumps({"1": "mug", "7": {"label": "can"}}))
    m = instances_from_array(
        load_instances(p), load_labels(tmp_path / "labels.json"), size=(20, 10)
    )
    assert m.ids == (1, 7) and m.labels == ("mug", "can")
    assert m.boxes == ((2, 2, 6, 5), (10, 2, 16, 5))
    # an instance the labels do not name is "unknown"
    assert instances_from_array(inst, {1: "mug"}).labels == ("mug", "unknown")


def test_bad_masks() -> None:
    inst = np.zeros((10, 20), np.uint16)
    inst[2:5, 2:6] = 1
    with pytest.raises(ImageError, match="is 20x10 but the colour image is 40x30"):
        instances_from_array(inst, size=(40, 30), source="m.png")
    with pytest.raises(InputError, match=r"labels\.json: names instance 3 that is not in m\.png"):
        instances_from_array(
            inst, {1: "mug", 3: "can"}, source="m.png", labels_source="labels.json"
        )
    with pytest.raises(ImageError, match=r"m\.png: is empty"):
        instances_from_array(np.zeros((10, 20), np.uint8), source="m.png")


def test_colour_masks_refused(tmp_path: Path) -> None:
    p = tmp_path / "m.png"
    img = np.zeros((8, 8, 3), np.uint8)
    img[2:4, 2:4] = (10, 200, 30)
    cv2.imwrite(str(p), img)
    with pytest.raises(ImageError, match="colour image"):
        load_instances(p)


def test_boxes(tmp_path: Path) -> None:
    p = tmp_path / "dets.json"
    p.write_text(
        json.dumps(
            [
                {"bbox": [1, 2, 3, 4], "label": "mug", "score": 0.9},
                {"bbox": [5, 5, 2, 2], "category_id": 3, "score": 0.2},
            ]
        )
    )
    boxes = load_boxes(p, size=(20, 20), names={3: "can"})
    assert [(b.label, b.score) for b in boxes] == [("mug", 0.9), ("can", 0.2)]
    assert [b.label for b in load_boxes(p, min_score=0.5)] == ["mug"]
    assert boxes[0].pixel_box((20, 20)) == (1, 2, 4, 6)


@pytest.mark.parametrize(
    ("data", "needle"),
    [
        ([{"bbox": [1, 2, 3], "label": "a"}], "bbox must be"),
        ({"bbox": [1, 2, 3, 4]}, "a JSON list"),
        ([{"bbox": [1, 2, 0, 4], "label": "a"}], "no area"),
        ([{"bbox": [100, 100, 4, 4], "label": "a"}], "outside"),
        ([{"bbox": [1, 1, 4, 4]}], 'no "label"'),
        ([], "no detection"),
    ],
)
def test_bad_boxes(tmp_path: Path, data: object, needle: str) -> None:
    p = tmp_path / "dets.json"
    p.write_text(json.dumps(data))
    with pytest.raises(InputError, match=needle) as info:
        load_boxes(p, size=(20, 20))
    assert str(p) in str(info.value)
