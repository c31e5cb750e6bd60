"""Several instances of one label, a label wrapped round a cylinder, and the finer search.

The cylinder is rendered by ray casting (an orthographic camera looking down ``elev`` degrees
at an upright cylinder whose label is wrapped once round it), the other scenes are photos
pasted on a plain background: every expected answer is known exactly.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
from numpy.typing import NDArray
from skimage import data

from scenespeak.perception.features import detect, to_gray
from scenespeak.perception.recognition import ObjectDatabase

ASTRONAUT = data.astronaut()[40:300, 120:380]


def render_cylinder(
    label: NDArray[np.uint8],
    yaw_deg: float,
    elev_deg: float,
    radius: float,
    height: float,
    size: tuple[int, int] = (320, 240),
    centre: tuple[int, int] = (160, 120),
) -> tuple[NDArray[np.uint8], NDArray[np.bool_]]:
    """An upright cylinder of ``radius`` × ``height`` pixels, turned ``yaw_deg`` about its
    axis, seen from ``elev_deg`` above (orthographic), on grey; and its mask."""
    w, h = size
    img = np.full((h, w, 3), 128, np.uint8)
    e = np.radians(elev_deg)
    u, v = np.meshgrid(np.arange(w) - centre[0], np.arange(h) - centre[1])
    ox, oy, oz = u.astype(float), -v * np.cos(e), v * np.sin(e)
    dy, dz = -np.sin(e), np.cos(e)
    disc = radius * radius - ox * ox
    hit = disc > 0
    zc = -np.sqrt(np.where(hit, disc, 0.0))  # the near side of the surface
    y = oy + (zc - oz) / dz * dy
    hit &= np.abs(y) <= height / 2
    phi = np.arctan2(ox, -zc) + np.radians(yaw_deg)
    th, tw = label.shape[:2]
    mapx = (((phi / (2 * np.pi)) % 1.0) * (tw - 1)).astype(np.float32)
    mapy = ((height / 2 - y) / height * (th - 1)).astype(np.float32)
    sampled = cv2.remap(label, mapx, mapy, cv2.INTER_LINEAR)
    shade = (0.55 + 0.45 * np.clip(-zc / radius, 0, 1))[..., None]
    img[hit] = (sampled * shade)[hit].astype(np.uint8)
    return img, hit


@pytest.fixture(scope="module")
def can_db(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A can learnt from three views 120° apart (with masks), and a photo never in a scene."""
    label = cv2.resize(data.astronaut(), (900, 300))
    views = [render_cylinder(label, yaw, 10, 70, 140) for yaw in (0, 120, 240)]
    path = tmp_path_factory.mktemp("cylinder") / "objects.db"
    with ObjectDatabase.create(path) as db:
        db.add_object("can", [v[0] for v in views], masks=[v[1] for v in views])
        db.add_object("coffee", [data.coffee()])
    return path


@pytest.fixture(scope="module")
def photo_db(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("photos") / "objects.db"
    with ObjectDatabase.create(path) as db:
        db.add_object("astronaut", [ASTRONAUT])
        db.add_object("coffee", [data.coffee()])
    return path


def _paste(scene: NDArray[np.uint8], img: NDArray[np.uint8], x: int, y: int) -> None:
    scene[y : y + img.shape[0], x : x + img.shape[1]] = img


def test_oblique_cylinder_is_one_object(can_db: Path) -> None:
    """Seen about halfway between two training views, each view explains the half of the
    label it saw: one can, not two side by side, and nothing else."""
    label = cv2.resize(data.astronaut(), (900, 300))
    halves = 0
    for yaw, elev in ((55, 5), (65, 10), (70, 5)):
        img, mask = render_cylinder(label, yaw, elev, 56, 112, size=(480, 360), centre=(200, 180))
        feats = detect(to_gray(img), precise_upscale=False)
        with ObjectDatabase.open(can_db) as db:
            found = db.label(feats, image=img)
            # without the rules that tell two instances from two halves of one
            loose = db.label(feats, image=img, instance_overlap=1.0, instance_span=0.0)
        assert [d.label for d in found.detections] == ["can"], (yaw, elev)
        (det,) = found.detections
        rows, cols = np.rint(feats.xy[det.inliers][:, ::-1]).astype(int).T
        assert mask[rows, cols].mean() > 0.9
        assert {d.label for d in loose.detections} == {"can"}
        halves += len(loose.detections) > 1
    assert halves >= 2


def test_cylinder_seen_from_above_between_views(can_db: Path) -> None:
    label = cv2.resize(data.astronaut(), (900, 300))
    for yaw in (30, 45, 90):
        img, _ = render_cylinder(label, yaw, 25, 56, 112, size=(480, 360), centre=(200, 180))
        with ObjectDatabase.open(can_db) as db:
            found = db.label(detect(to_gray(img), precise_upscale=False), image=img)
        assert [d.label for d in found.detections] == ["can"], yaw


def test_two_instances_of_one_label(photo_db: Path) -> None:
    scene = np.full((480, 640, 3), 120, np.uint8)
    small = cv2.resize(ASTRONAUT, None, fx=0.5, fy=0.5, interpolation=cv2.INTER_AREA)
    _paste(scene, small, 60, 150)
    _paste(scene, small, 400, 200)
    feats = detect(to_gray(scene), precise_upscale=False)
    with ObjectDatabase.open(photo_db) as db:
        both = db.label(feats)
        one = db.label(feats, max_instances=1)
    assert [d.label for d in both.detections] == ["astronaut", "astronaut"]
    xs = sorted(float(feats.xy[d.inliers][:, 0].mean()) for d in both.detections)
    assert xs[0] < 200 < 400 < xs[1]
    assert len(set(both.labels[both.labels >= 0].tolist())) == 2
    assert [d.label for d in one.detections] == ["astronaut"]


def test_finer_search_finds_a_small_far_object(photo_db: Path) -> None:
    """A 21-pixel astronaut: too few keypoints for the whole-image check; the enlarged second
    look round its lone ratio-test match finds it, in the right place, and nothing else."""
    scene = np.full((480, 640, 3), 120, np.uint8)
    tiny = cv2.resize(ASTRONAUT, None, fx=0.08, fy=0.08, interpolation=cv2.INTER_AREA)
    _paste(scene, tiny, 400, 300)
    _paste(scene, cv2.resize(data.rocket(), (200, 130)), 40, 40)  # clutter never learnt
    feats = detect(to_gray(scene), precise_upscale=False)
    with ObjectDatabase.open(photo_db) as db:
        coarse = db.label(feats)
        finer = db.label(feats, image=scene)
        off = db.label(feats, image=scene, finer_upscale=1.0)
    assert coarse.detections == () and off.detections == ()
    assert [d.label for d in finer.detections] == ["astronaut"]
    (det,) = finer.detections
    centre = det.outline_in_scene.mean(axis=0)
    assert np.linalg.norm(centre - [410, 310]) < 6
    assert len(det.inliers) and np.all(finer.labels[det.inliers] == 0)
