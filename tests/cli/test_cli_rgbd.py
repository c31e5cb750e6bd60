"""``scenespeak describe`` with any perception in: colour + depth + masks / boxes, masks alone,
and every bad input of issue 11 as one line naming the file with exit status 2."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

import rgbdscene as rs
from scenespeak.cli import main


@pytest.fixture(scope="module")
def scene(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    return rs.write_scene(tmp_path_factory.mktemp("rgbd_cli"))


def _run(args: list[object], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


def _json(args: list[object], capsys: pytest.CaptureFixture[str]) -> dict:
    code, out, err = _run([*args, "--format", "json"], capsys)
    assert code == 0, err
    return json.loads(out)


@pytest.mark.parametrize("depth_key", ["depth", "depth_npy", "depth_tif"])
def test_color_depth_masks(scene: dict[str, Path], capsys, depth_key: str) -> None:
    s = scene
    d = _json(
        [
            "describe",
            s["color"],
            "--depth",
            s[depth_key],
            "--intrinsics",
            s["intrinsics"],
            "--masks",
            s["masks"],
            "--labels",
            s["labels"],
        ],
        capsys,
    )
    assert d["frame"] == "horizontal" and d["up_source"] == "given"
    assert sorted(o["label"] for o in d["objects"]) == ["box", "can", "mug"]
    byname = {o["name"]: o for o in d["objects"]}
    for label, (x, z, _, _) in rs.SLABS.items():
        assert np.allclose(byname[label]["plane_centroid"], [x, z], atol=0.01)
    assert len(d["relations"]) == 6


def test_color_depth_boxes_and_kept_pixels(scene: dict[str, Path], capsys) -> None:
    s = scene
    d = _json(
        [
            "describe",
            s["color"],
            "--depth",
            s["depth"],
            "--intrinsics",
            s["intrinsics"],
            "--boxes",
            s["boxes"],
        ],
        capsys,
    )
    for o in d["objects"]:
        assert o["source"] == "box" and 0 < o["kept_pixels"] < o["pixels"]


def test_masks_alone_in_the_picture(scene: dict[str, Path], capsys) -> None:
    s = scene
    code, out, err = _run(
        ["describe", s["color"], "--masks", s["masks"], "--labels", s["labels"]], capsys
    )
    assert code == 0, err
    assert "The mug is directly to the left of the box in the picture." in out.splitlines() or any(
        line.startswith("The mug is") and "left of the box" in line and "in the picture" in line
        for line in out.splitlines()
    )
    d = _json(["describe", s["color"], "--masks", s["masks"], "--labels", s["labels"]], capsys)
    assert d["frame"] == "image"


def test_up_estimated_without_up(tmp_path: Path, capsys) -> None:
    s = rs.write_scene(tmp_path, up=False)
    d = _json(
        [
            "describe",
            s["color"],
            "--depth",
            s["depth"],
            "--intrinsics",
            s["intrinsics"],
            "--masks",
            s["masks"],
            "--labels",
            s["labels"],
        ],
        capsys,
    )
    assert d["up_source"] == "estimated"
    assert np.allclose(d["up"], [0, -1, 0], atol=0.02)


def _bad(scene: dict[str, Path], tmp: Path, case: str) -> tuple[list[object], Path]:
    s = scene
    base = [
        "describe",
        s["color"],
        "--depth",
        s["depth"],
        "--intrinsics",
        s["intrinsics"],
        "--masks",
        s["masks"],
        "--labels",
        s["labels"],
    ]
    if case == "depth-size":
        p = tmp / "small_depth.png"
        cv2.imwrite(str(p), np.full((rs.H // 2, rs.W // 2), 1000, np.uint16))
        return [*base[:3], p, *base[4:]], p
    if case == "depth-type":
        p = tmp / "depth8.png"
        cv2.imwrite(str(p), np.full((rs.H, rs.W), 100, np.uint8))
        return [*base[:3], p, *base[4:]], p
    if case == "depth-colour":
        return [*base[:3], s["color"], *base[4:]], s["color"]
    if case == "masks-size":
        p = tmp / "small_masks.png"
        cv2.imwrite(str(p), np.ones((rs.H // 2, rs.W // 2), np.uint8))
        return [*base[:7], p, *base[8:]], p
    if case == "labels-missing-instance":
        p = tmp / "labels_extra.json"
        p.write_text(json.dumps({"1": "mug", "2": "can", "3": "box", "9": "hat"}))
        return [*base[:9], p], p
    if case == "masks-empty":
        p = tmp / "empty_masks.png"
        cv2.imwrite(str(p), np.zeros((rs.H, rs.W), np.uint8))
        return [*base[:7], p], p
    if case == "masks-image-plane-size":
        p = tmp / "small_masks2.png"
        cv2.imwrite(str(p), np.ones((rs.H // 2, rs.W // 2), np.uint8))
        return ["describe", s["color"], "--masks", p], p
    if case == "intrinsics-size":
        p = tmp / "cam_other.json"
        p.write_text(json.dumps({**rs.intrinsics(), "width": 640, "height": 480}))
        return [*base[:5], p, *base[6:]], p
    if case == "boxes-outside":
        p = tmp / "boxes_out.json"
        p.write_text(json.dumps([{"bbox": [5000, 10, 20, 20], "label": "mug"}]))
        return [*base[:6], "--boxes", p], p
    if case == "no-objects-source":
        return base[:6], Path("--depth")
    raise AssertionError(case)


CASES = [
    "depth-size",
    "depth-type",
    "depth-colour",
    "masks-size",
    "labels-missing-instance",
    "masks-empty",
    "masks-image-plane-size",
    "intrinsics-size",
    "boxes-outside",
    "no-objects-source",
]


@pytest.mark.parametrize("case", CASES)
def test_bad_input_one_line_exit_2(
    scene: dict[str, Path], tmp_path: Path, capsys, case: str
) -> None:
    args, named = _bad(scene, tmp_path, case)
    code, out, err = _run(args, capsys)
    assert code == 2, (case, out, err)
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("scenespeak: error: "), err
    assert str(named) in lines[0]
    assert "Traceback" not in err and out == ""
