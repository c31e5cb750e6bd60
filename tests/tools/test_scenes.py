"""Tests of the scene generator (pybullet TinyRenderer, real scikit-image photographs)."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from scenespeak.errors import InputError
from scenespeak.perception.calibration import load_rig
from scenespeak.tools.scenes import (
    CATALOGUE,
    CatalogueObject,
    Placement,
    footprint_relation,
    generate_dataset,
    generate_scene,
    load_dataset,
    load_truth,
    make_rig,
)

SMALL = (200, 150)


@pytest.fixture(scope="module")
def dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("ds") / "data"
    return generate_dataset(out, 2, seed=5, pitched="mixed", image_size=SMALL, views=False)


def _project(calib: Path, xyz: np.ndarray) -> np.ndarray:
    rig = load_rig(calib)
    uvw = np.asarray(xyz, float) @ rig.K_left.T
    return uvw[:, :2] / uvw[:, 2:3]


def test_files_and_json_consistent(dataset: Path) -> None:
    meta = json.loads((dataset / "dataset.json").read_text())
    assert meta["format"] == "scenespeak-scenes/1" and meta["seed"] == 5
    assert meta["scenes"] == ["scene_000", "scene_001"] and meta["complete"] is True
    assert {o["label"] for o in meta["objects"]} == {o.label for o in CATALOGUE}
    ds = load_dataset(dataset)
    assert [p.name for p in ds.scenes] == meta["scenes"]
    for scene in ds.scenes:
        for name in ("left.png", "right.png", "left_labels.png", "calib.json", "truth.json"):
            assert (scene / name).is_file()
        left = cv2.imread(str(scene / "left.png"))
        assert left.shape == (SMALL[1], SMALL[0], 3)
        truth = load_truth(scene)
        n = len(truth.objects)
        assert 3 <= n <= 5
        assert len(truth.relations) == n * (n - 1)
        labels = cv2.imread(str(scene / "left_labels.png"), cv2.IMREAD_UNCHANGED)
        assert labels.dtype == np.uint8 and labels.shape == left.shape[:2]
        assert set(np.unique(labels)) - {0} <= set(truth.legend)
        assert sorted(truth.legend.values()) == sorted(o.label for o in truth.objects)
        for o in truth.objects:
            assert 0.5 <= o.distance <= 2.0
            assert o.distance == pytest.approx(np.linalg.norm(o.centroid))
            assert 0.3 <= o.visible_fraction <= 1.0
            # the centroid projects onto (or next to) the object's own pixels
            u, v = np.round(_project(scene / "calib.json", np.array([o.centroid]))[0]).astype(int)
            window = labels[max(v - 2, 0) : v + 3, max(u - 2, 0) : u + 3]
            assert (window == o.index).any() or o.visible_fraction < 0.9
            # the footprint centroid is the centroid's ground projection
            up = np.array(truth.rig["up"])
            assert truth.rig["pitch_deg"] in (0.0, 25.0)
            fp = np.array(o.footprint)
            assert fp.shape[1] == 2
            if truth.rig["pitch_deg"] == 0:
                assert fp.mean(axis=0) == pytest.approx([o.centroid[0], o.centroid[2]], abs=1e-6)
                assert up.tolist() == pytest.approx([0, -1, 0])


def test_level_and_pitched_rigs(dataset: Path) -> None:
    level = json.loads((dataset / "scene_000" / "calib.json").read_text())
    pitched = json.loads((dataset / "scene_001" / "calib.json").read_text())
    assert set(level) == {"baseline", "hfov_deg", "image_size", "up"}
    assert "K_left" in pitched and pitched["T"] == [-0.12, 0.0, 0.0]
    up = np.array(pitched["up"])
    assert up == pytest.approx([0, -np.cos(np.radians(25)), -np.sin(np.radians(25))])
    a, b = (
        load_rig(dataset / "scene_000" / "calib.json"),
        load_rig(dataset / "scene_001" / "calib.json"),
    )
    np.testing.assert_allclose(a.K_left, b.K_left)


def _card(w: float = 0.06) -> CatalogueObject:
    return CatalogueObject("marker", "card", (w, 0.0005, w), "astronaut")


@pytest.mark.parametrize("pitched", [False, True])
def test_projection_matches_rendering(tmp_path: Path, pitched: bool) -> None:
    """Projected face centres and box corners land where the renderer drew them (< 0.5 px)."""
    rig = make_rig(pitched, image_size=(320, 240))
    y0 = 0.9 if pitched else 1.0
    layout = [
        Placement(_card(), (-0.20, y0, 0.0), 0.0),
        Placement(_card(), (0.13, y0 + 0.3, 0.0), 0.0),
        Placement(_card(0.04), (0.05, y0 + 0.7, 0.0), 0.0),
        Placement(_card(), (0.3, y0 - 0.1, 0.0), 0.0),
    ]
    offsets = []
    scene = generate_scene(tmp_path / "s", pitched=pitched, image_size=(320, 240), layout=layout)
    labels = cv2.imread(str(scene / "left_labels.png"), cv2.IMREAD_UNCHANGED)
    cam = rig.camera()
    for k, pl in enumerate(layout, start=1):
        rows, cols = np.nonzero(labels == k)
        w, d, h = pl.obj.size
        corners = np.array(
            [
                [pl.position[0] + sx * w / 2, pl.position[1] - d / 2, sz * h]
                for sx in (-1, 1)
                for sz in (0, 1)
            ]
        )
        xyz = cam.to_camera(corners)
        uv = _project(scene / "calib.json", xyz)
        if not pitched:
            # fronto-parallel square: its image is a square whose centre is the projected centre
            centre = _project(scene / "calib.json", xyz.mean(axis=0, keepdims=True))[0]
            offsets.append((cols.mean() - centre[0], rows.mean() - centre[1]))
        # extreme pixels within half a pixel of the projected outline (pixel centres inside)
        assert abs((cols.min() - 0.5) - uv[:, 0].min()) < 1.0
        assert abs((cols.max() + 0.5) - uv[:, 0].max()) < 1.0
        assert abs((rows.min() - 0.5) - uv[:, 1].min()) < 1.0
        assert abs((rows.max() + 0.5) - uv[:, 1].max()) < 1.0
        # the area matches the projected quadrilateral's, up to half a pixel along the outline
        quad = uv[[0, 2, 3, 1]].astype(np.float32)
        area, perimeter = cv2.contourArea(quad), cv2.arcLength(quad, closed=True)
        assert abs(len(rows) - area) < 0.5 * perimeter
    if offsets:
        # each within half a pixel (pixel quantisation), and no bias on average
        off = np.array(offsets)
        assert np.abs(off).max() < 0.5
        assert np.abs(off.mean(axis=0)).max() < 0.25


def test_right_image_is_shifted_by_the_disparity(tmp_path: Path) -> None:
    layout = [Placement(CATALOGUE[0], (0.05, 1.0, 0.0), 0.0)]
    scene = generate_scene(tmp_path / "s", image_size=(320, 240), layout=layout)
    left = cv2.imread(str(scene / "left.png"), cv2.IMREAD_GRAYSCALE).astype(np.float32)
    right = cv2.imread(str(scene / "right.png"), cv2.IMREAD_GRAYSCALE).astype(np.float32)
    rig = load_rig(scene / "calib.json")
    z = 1.0 - 0.035  # the box's front face
    expected = rig.K_left[0, 0] * 0.12 / z
    row = 150
    errs = [np.abs(left[row, 100:200] - right[row, 100 - s : 200 - s]).mean() for s in range(60)]
    assert abs(int(np.argmin(errs)) - expected) <= 1


def test_relation_rule_on_hand_made_layouts() -> None:
    sq = np.array([[0.0, 0.0], [0.1, 0.0], [0.1, 0.1], [0.0, 0.1]])
    assert footprint_relation(sq + np.array([-0.5, 0.0]), sq) == ("left", 180.0, False)
    assert footprint_relation(sq + np.array([0.5, 0.05]), sq)[0::2] == ("right", False)
    assert footprint_relation(sq + np.array([0.0, 0.5]), sq)[0::2] == ("behind", False)
    assert footprint_relation(sq + np.array([0.1, -0.5]), sq)[0::2] == ("front", False)
    # within ±20° of a diagonal: ambiguous; just outside: not
    assert footprint_relation(sq + np.array([0.5, 0.4]), sq)[2] is True  # 38.7°
    assert footprint_relation(sq + np.array([0.5, 0.2]), sq)[2] is False  # 21.8°
    # overlapping footprints: ambiguous even on an axis
    assert footprint_relation(sq + np.array([0.05, 0.0]), sq) == ("right", 0.0, True)


def test_truth_relations_follow_the_rule(tmp_path: Path) -> None:
    layout = [
        Placement(CATALOGUE[3], (-0.3, 1.0, 0.0), 0.0),  # can, left
        Placement(CATALOGUE[4], (0.3, 1.0, 0.0), 0.0),  # mug, right
        Placement(CATALOGUE[1], (0.0, 1.6, 0.0), 0.0),  # book, behind both (diagonal-ish)
    ]
    truth = load_truth(generate_scene(tmp_path / "s", image_size=SMALL, layout=layout))
    rel = {(r.argument, r.referent): r for r in truth.relations}
    assert rel["can", "mug"].primary == "left" and not rel["can", "mug"].ambiguous
    assert rel["mug", "can"].primary == "right" and not rel["mug", "can"].ambiguous
    assert rel["book", "can"].primary == "behind"  # 63.4°: ambiguous? no: 18.4° off the axis
    assert rel["can", "book"].primary == "front"
    assert truth.object("can").centroid == pytest.approx((-0.3, 0.25 - 0.061, 1.0), abs=1e-9)


def test_same_seed_same_images(tmp_path: Path) -> None:
    a = generate_scene(tmp_path / "a", seed=[7, 1], image_size=(160, 120))
    b = generate_scene(tmp_path / "b", seed=[7, 1], image_size=(160, 120))
    c = generate_scene(tmp_path / "c", seed=[7, 2], image_size=(160, 120))
    for name in ("left.png", "right.png", "truth.json"):
        assert (a / name).read_bytes() == (b / name).read_bytes()
    assert (a / "left.png").read_bytes() != (c / "left.png").read_bytes()


def test_refuses_foreign_folder_and_resumes_own(tmp_path: Path) -> None:
    foreign = tmp_path / "mine"
    foreign.mkdir()
    (foreign / "thesis.tex").write_text("precious")
    with pytest.raises(InputError, match="not a scenespeak dataset"):
        generate_dataset(foreign, 1, image_size=(80, 60), views=False)
    assert (foreign / "thesis.tex").read_text() == "precious"
    (tmp_path / "file").write_text("x")
    with pytest.raises(InputError, match="is a file"):
        generate_dataset(tmp_path / "file", 1, views=False)

    out = tmp_path / "ds"
    generate_dataset(out, 1, seed=2, image_size=(80, 60), views=False)
    stamp = (out / "scene_000" / "left.png").stat().st_mtime_ns
    calls: list[tuple[int, int]] = []
    generate_dataset(
        out, 1, seed=2, image_size=(80, 60), views=False, progress=lambda d, t: calls.append((d, t))
    )
    assert (out / "scene_000" / "left.png").stat().st_mtime_ns == stamp  # kept, not re-rendered
    assert calls == [(1, 1)]
    with pytest.raises(InputError, match="other settings"):
        generate_dataset(out, 1, seed=3, image_size=(80, 60), views=False)
    assert not list(out.glob(".scene_*"))  # no half-written scene left behind


def test_training_views_and_masks(tmp_path: Path) -> None:
    from scenespeak.tools.scenes import render_training_views

    paths = render_training_views(CATALOGUE[3], tmp_path / "can", image_size=(160, 120))
    assert CATALOGUE[3].shape == "cylinder"
    assert len(paths) == 8  # a cylinder is seen all round: every 45 degrees
    assert [p.name for p in paths] == [f"view_{k:02d}.png" for k in range(8)]
    for p in paths:
        img = cv2.imread(str(p))
        mask = cv2.imread(str(p).replace(".png", "_mask.png"), cv2.IMREAD_GRAYSCALE)
        assert set(np.unique(mask)) == {0, 255}
        assert 0.02 < (mask > 0).mean() < 0.6
        # the masked pixels carry the photograph, not the plain floor
        assert img[mask > 0].std() > 10


def test_load_errors(tmp_path: Path) -> None:
    with pytest.raises(InputError, match=r"dataset\.json"):
        load_dataset(tmp_path)
    with pytest.raises(InputError, match=r"truth\.json"):
        load_truth(tmp_path)


def _hull_centroid(uv: np.ndarray) -> np.ndarray:
    """Area centroid of the convex hull of 2-D points."""
    p = cv2.convexHull(uv.astype(np.float32))[:, 0, :].astype(np.float64)
    x, y = p[:, 0], p[:, 1]
    xn, yn = np.roll(x, -1), np.roll(y, -1)
    c = x * yn - xn * y
    return np.array([((x + xn) * c).sum(), ((y + yn) * c).sum()]) / (3.0 * c.sum())


def test_both_cameras_project_through_the_written_calibration(tmp_path: Path) -> None:
    """Turned boxes, pitched rig: their silhouettes' centroids in the left AND right renders
    (pybullet's segmentation at 2x) match the hulls projected with K, R, T of calib.json."""
    from scenespeak.tools import render as _render

    size = (320, 240)
    rig = make_rig(True, image_size=size)
    cube = CatalogueObject("cube", "box", (0.05, 0.05, 0.05), "astronaut")
    layout = [
        Placement(cube, (-0.25, 0.9, 0.0), 25.0),
        Placement(cube, (0.2, 1.3, 0.0), -40.0),
        Placement(cube, (0.0, 0.75, 0.0), 10.0),
    ]
    scene = generate_scene(tmp_path / "s", pitched=True, image_size=size, layout=layout)
    calib = load_rig(scene / "calib.json")
    left, right = rig.camera("left"), rig.camera("right")
    renders = _render.render([p.mesh() for p in layout], [left, right], 2)
    truth = load_truth(scene)
    errors = []
    for k, pl in enumerate(layout):
        x_left = left.to_camera(pl.corners_world())
        assert truth.objects[k].centroid == pytest.approx(
            tuple(left.to_camera(pl.centroid_world()[None])[0]), abs=1e-9
        )
        for (K, xyz), (_, seg) in zip(
            ((calib.K_left, x_left), (calib.K_right, x_left @ calib.R.T + calib.T)),
            renders,
            strict=True,
        ):
            uvw = xyz @ K.T
            expected = _hull_centroid(uvw[:, :2] / uvw[:, 2:3])
            rows, cols = np.nonzero(seg == k)
            # render pixel j (2x) has its centre at final-image coordinate (j - 0.5) / 2
            got = (np.array([cols.mean(), rows.mean()]) - 0.5) / 2
            errors.append(np.abs(got - expected).max())
    print("projection errors (px):", np.round(errors, 3))
    # measured <= 0.1 px; a quarter-pixel error in cx or cy would fail
    assert max(errors) < 0.2


def test_pitched_truth_is_in_the_pipelines_plane_frame(tmp_path: Path) -> None:
    """Footprints and heights agree with calibration.ground_basis / heights for the written up."""
    from scenespeak.perception.calibration import heights, to_ground

    layout = [
        Placement(CATALOGUE[0], (-0.3, 1.2, 0.0), 30.0),  # box, turned
        Placement(CATALOGUE[5], (0.25, 0.9, 0.0), 0.0),  # tin
    ]
    scene = generate_scene(tmp_path / "s", pitched=True, image_size=SMALL, layout=layout)
    truth = load_truth(scene)
    up = load_rig(scene / "calib.json").up
    assert up == pytest.approx(truth.rig["up"])
    for o, pl in zip(truth.objects, layout, strict=True):
        fp = np.array(o.footprint)
        centre = to_ground(np.array([o.centroid]), up)[0]
        assert fp.mean(axis=0) == pytest.approx(centre, abs=1e-6)
        base = np.c_[pl.footprint_world(), np.zeros(len(fp))]
        expected = to_ground(make_rig(True).camera().to_camera(base), up)
        np.testing.assert_allclose(fp, expected, atol=1e-9)
        # the floor is camera-height below the camera; the centroid half the object above it
        h = heights(np.array([o.centroid]), up)[0]
        assert h == pytest.approx(-truth.rig["height"] + o.size[2] / 2, abs=1e-9)
        # and the footprint keeps the object's real area
        x, y = fp[:, 0], fp[:, 1]
        area = 0.5 * abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))
        w, d, _ = o.size
        assert area == pytest.approx(
            w * d if o.shape != "cylinder" else np.pi * w * d / 4, rel=0.01
        )


def test_stacked_object_stands_on_the_other(tmp_path: Path) -> None:
    scene = generate_scene(tmp_path / "s", seed=[1, 2], stacked=True, image_size=SMALL)
    truth = load_truth(scene)
    top = [o for o in truth.objects if o.on is not None]
    assert len(top) == 1
    top_obj = top[0]
    base = truth.object(top_obj.on)
    up = np.array(truth.rig["up"])
    from scenespeak.perception.calibration import heights

    h_top, h_base = heights(np.array([top_obj.centroid, base.centroid]), up)
    assert h_top - h_base == pytest.approx(base.size[2] / 2 + top_obj.size[2] / 2, abs=1e-9)
    for a, b in ((top_obj.label, base.label), (base.label, top_obj.label)):
        (r,) = [r for r in truth.relations if (r.argument, r.referent) == (a, b)]
        assert r.ambiguous and "overlap" in r.reasons


def test_scene_folders_are_readable_and_stale_temporaries_are_removed(tmp_path: Path) -> None:
    out = tmp_path / "ds"
    generate_dataset(out, 1, seed=4, image_size=(80, 60), views=False)
    assert (out / "scene_000").stat().st_mode & 0o755 == 0o755
    stale = out / ".scene_001-abc123"  # as an interrupted generate_scene leaves it
    stale.mkdir()
    (stale / "left.png").write_bytes(b"half")
    generate_dataset(out, 2, seed=4, image_size=(80, 60), views=False, overwrite=True)
    assert not stale.exists()
    assert [p.name for p in load_dataset(out).scenes] == ["scene_000", "scene_001"]
    assert not list(out.glob(".*"))


def test_cylinder_turned_between_the_old_views_is_recognised_at_1_5_m(tmp_path: Path) -> None:
    """A mug 1.47 m away, turned 110 degrees (its side between the old views at 30 and 180
    degrees), is found by the database learnt from its eight training views, and was not with
    the four views (front, +-30, back) the generator used to render."""
    from scenespeak.perception.features import detect, load_image
    from scenespeak.perception.recognition import ObjectDatabase
    from scenespeak.tools.scenes import VIEW_YAWS, render_training_views, view_yaws

    by_label = {o.label: o for o in CATALOGUE}
    mug = by_label["mug"]
    # The distractor is pinned (the catalogue's box texture may change): a cereal box
    # printed with the astronaut photo, as when this test was written.
    box = CatalogueObject("box", "box", (0.19, 0.07, 0.27), "astronaut")
    assert len(view_yaws(mug)) == 8 and len(view_yaws(box)) == 4
    views = {
        "mug": render_training_views(mug, tmp_path / "mug"),
        "mug-old": render_training_views(mug, tmp_path / "mug-old", yaws=VIEW_YAWS),
        "box": render_training_views(box, tmp_path / "box"),
    }
    scene = generate_scene(
        tmp_path / "scene",
        layout=[Placement(mug, (0.15, 1.45, 0.0), 110.0), Placement(box, (-0.3, 1.0, 0.0), 10.0)],
    )
    truth = load_truth(scene)
    assert 1.4 < truth.object("mug").distance < 1.55
    feats = detect(load_image(scene / "left.png", gray=True), precise_upscale=False)
    labels = cv2.imread(str(scene / "left_labels.png"), cv2.IMREAD_UNCHANGED)
    found = {}
    for name in ("mug", "mug-old"):
        with ObjectDatabase.open(tmp_path / f"{name}.db", create=True) as db:
            for label, paths in (("mug", views[name]), ("box", views["box"])):
                masks = [v.with_name(v.stem + "_mask.png") for v in paths]
                db.add_object(label, paths, masks=masks)
            # the pipeline's settings (PipelineOptions: ratio 0.8, min_inliers 8)
            found[name] = db.label(feats, ratio=0.8, min_inliers=8).detection("mug")
    assert found["mug-old"] is None
    det = found["mug"]
    assert det is not None and det.score >= 8
    xy = np.rint(feats.xy[det.inliers]).astype(int)
    assert (labels[xy[:, 1], xy[:, 0]] == truth.object("mug").index).all()
