"""RGB-D objects: the object's own surface, boxes against walls, the support plane and up."""

from __future__ import annotations

import numpy as np
import pytest

import rgbdscene as rs
from scenespeak.perception.intrinsics import Intrinsics
from scenespeak.perception.masks import Box
from scenespeak.perception.rgbd import (
    MeasuredObject,
    MeasureOptions,
    RGBDOptions,
    box_span,
    estimate_support_plane,
    measure_object,
    surface_modes,
)
from scenespeak.pipeline_rgbd import DescribeOptions, describe_image_plane, describe_rgbd

CAM = Intrinsics(rs.FX, rs.FY, rs.CX, rs.CY, rs.W, rs.H, up=(0.0, -1.0, 0.0))


def _truth_centroid(depth: np.ndarray, inst: np.ndarray, k: int) -> np.ndarray:
    ys, xs = np.nonzero(inst == k)
    z = depth[ys, xs].astype(float)
    return np.column_stack([(xs - rs.CX) * z / rs.FX, (ys - rs.CY) * z / rs.FY, z]).mean(axis=0)


def test_masks_give_every_object_at_its_place() -> None:
    depth, inst, labels = rs.render()
    d = describe_rgbd(None, depth, CAM, masks=inst, labels=labels)
    assert sorted(o.name for o in d.objects) == ["box", "can", "mug"]
    ids = {v: k for k, v in labels.items()}
    for o in d.objects:
        assert np.linalg.norm(o.object.centroid - _truth_centroid(depth, inst, ids[o.label])) < 1e-3
        x, z = rs.SLABS[o.label][0], rs.SLABS[o.label][1]
        assert np.allclose(o.object.footprint_centroid, [x, z], atol=0.01)
    assert d.relation("mug", "can").primary == "left"
    assert d.relation("box", "mug").primary == "right"


def test_a_box_keeps_the_object_not_the_wall_or_floor() -> None:
    depth, inst, labels = rs.render()
    d_mask = describe_rgbd(None, depth, CAM, masks=inst, labels=labels)
    boxes = []
    for k, label in sorted(labels.items()):
        ys, xs = np.nonzero(inst == k)
        # a detector's box, a few pixels too large all round: wall and floor inside it
        x0, y0 = xs.min() - 4, ys.min() - 4
        boxes.append(Box(label, x0, y0, xs.max() - x0 + 9, ys.max() - y0 + 9))
    d_box = describe_rgbd(None, depth, CAM, boxes=boxes)
    assert [o.name for o in d_box.objects] == [o.name for o in d_mask.objects]
    for a, b in zip(d_mask.objects, d_box.objects, strict=True):
        assert b.source == "box" and b.pixels > b.kept_pixels
        # the box loses the object's bottom 1.5 cm with the floor (plane_clearance), no more
        assert 0.85 * a.kept_pixels <= b.kept_pixels <= a.kept_pixels
        assert np.linalg.norm(a.object.centroid - b.object.centroid) < 0.012
        assert np.allclose(a.object.footprint_centroid, b.object.footprint_centroid, atol=0.005)
    assert d_box.to_dict()["objects"][0]["kept_pixels"] == d_box.objects[0].kept_pixels


def test_flying_pixels_at_edges_do_not_move_the_hull() -> None:
    depth, inst, labels = rs.render()
    clean = describe_rgbd(None, depth, CAM, masks=inst, labels=labels)
    noisy = depth.copy()
    rng = np.random.default_rng(3)
    for k in labels:
        m = inst == k
        edge = m & ~np.roll(m, 1, axis=1) | m & ~np.roll(m, -1, axis=1)
        ys, xs = np.nonzero(edge)
        pick = rng.random(len(ys)) < 0.6
        # flying pixels: depths strewn between the object and the wall behind it
        noisy[ys[pick], xs[pick]] = rng.uniform(depth[ys[pick], xs[pick]], rs.WALL)
    dirty = describe_rgbd(None, noisy, CAM, masks=inst, labels=labels)
    for a, b in zip(clean.objects, dirty.objects, strict=True):
        ya, yb = a.object.hull[:, 1], b.object.hull[:, 1]
        assert abs(ya.max() - yb.max()) < 0.02 and abs(ya.min() - yb.min()) < 0.02
    for ra, rb in zip(clean.relations, dirty.relations, strict=True):
        assert ra.primary == rb.primary


def test_surface_modes_separate_object_and_background() -> None:
    z = np.r_[np.full(400, 1.0), np.linspace(1.0, 3.0, 30), np.full(900, 3.0)]
    modes = surface_modes(z)
    assert len(modes) == 2 and modes[0][0] < 1.01 and modes[1][0] > 2.9


def test_support_plane_gives_up_for_a_tilted_camera() -> None:
    depth, inst, labels = rs.render()
    # the same scene seen by a camera rolled 10 degrees: rotate the image and the masks
    import cv2

    a = 10.0
    M = cv2.getRotationMatrix2D((rs.CX, rs.CY), a, 1.0)
    rot = cv2.warpAffine(depth, M, (rs.W, rs.H), flags=cv2.INTER_NEAREST, borderValue=np.nan)
    plane = estimate_support_plane(rot, CAM)
    assert plane is not None
    # rotating the image by +a (counter-clockwise on screen) turns up by a about Z
    r = np.radians(a)
    expected = np.array([-np.sin(r), -np.cos(r), 0.0])
    assert np.degrees(np.arccos(np.clip(np.dot(plane.normal, expected), -1, 1))) < 1.5
    cam = Intrinsics(rs.FX, rs.FY, rs.CX, rs.CY, rs.W, rs.H)
    rinst = cv2.warpAffine(inst, M, (rs.W, rs.H), flags=cv2.INTER_NEAREST)
    d = describe_rgbd(None, rot, cam, masks=rinst, labels=labels)
    assert d.up_source == "estimated" and d.to_dict()["up_source"] == "estimated"
    assert d.relation("mug", "can").primary == "left"


def test_no_plane_says_so() -> None:
    depth = np.full((rs.H, rs.W), 2.0, np.float32)  # a wall only
    inst = np.zeros((rs.H, rs.W), np.uint8)
    inst[50:100, 50:100] = 1
    inst[50:100, 200:250] = 2
    depth[inst > 0] = 1.5
    cam = Intrinsics(rs.FX, rs.FY, rs.CX, rs.CY, rs.W, rs.H)
    d = describe_rgbd(None, depth, cam, masks=inst, labels={1: "mug", 2: "can"})
    assert d.up_source == "default"
    assert "no support plane" in d.up_note and "no support plane" in d.to_text()
    assert d.relation("mug", "can").primary == "left"


def test_too_few_pixels_is_skipped_with_the_reason() -> None:
    depth, inst, labels = rs.render()
    depth[inst == 2] = np.nan
    d = describe_rgbd(None, depth, CAM, masks=inst, labels=labels)
    assert [s.label for s in d.skipped] == ["can"]
    assert "pixels have depth" in d.skipped[0].reason


def test_two_instances_named_apart_in_sentences_and_json() -> None:
    slabs = [
        ("mug", (-0.3, 1.2, 0.1, 0.12)),
        ("mug", (0.3, 1.2, 0.1, 0.12)),
        ("can", (0.0, 1.6, 0.1, 0.2)),
    ]
    depth, inst, labels = rs.render(slabs)
    d = describe_rgbd(None, depth, CAM, masks=inst, labels=labels)
    js = d.to_dict()
    assert [(o["label"], o["name"]) for o in js["objects"]] == [
        ("mug", "left mug"),
        ("mug", "right mug"),
        ("can", "can"),
    ]
    assert "The left mug is directly to the left of the right mug." in d.to_text()
    assert {r["argument"] for r in js["relations"]} == {"left mug", "right mug", "can"}


def test_image_plane_relations() -> None:
    _, inst, labels = rs.render()
    d = describe_image_plane(inst, labels)
    js = d.to_dict()
    assert js["frame"] == "image" and js["up"] is None
    assert d.relation("mug", "box").primary == "left"
    assert d.relation("mug", "box").sentence.endswith("in the picture.")
    # the can's slab is taller and farther: its top is higher in the picture than the box's?
    assert all(o["centroid"] is None for o in js["objects"])


def test_measure_object_returns_contract_object() -> None:
    depth, inst, _ = rs.render()
    ys, xs = np.nonzero(inst == 1)
    m = measure_object("mug", "mug", ys, xs, depth, CAM, (0, -1, 0))
    assert isinstance(m, MeasuredObject)
    assert m.object.frame == "horizontal" and m.object.heights is not None
    assert m.object.heights.max() == pytest.approx(0.15 - rs.CAM_HEIGHT, abs=0.01)


def _card_over_tin() -> tuple[np.ndarray, np.ndarray, list[Box]]:
    """A tin at 1.3 m whose box is half filled by a nearer card (0.87 m) reaching into it."""
    depth = np.full((240, 320), 3.0, np.float32)  # a wall far behind
    inst = np.zeros((240, 320), np.uint8)
    depth[100:160, 100:160], inst[100:160, 100:160] = 1.3, 1  # the tin
    depth[120:200, 60:140], inst[120:200, 60:140] = 0.87, 2  # the card in front of it
    boxes = []
    for k, label in ((1, "tin"), (2, "card")):  # the tin's box first: measured alone first
        ys, xs = np.nonzero(inst == k)
        boxes.append(
            Box(label, xs.min(), ys.min(), xs.max() - xs.min() + 1, ys.max() - ys.min() + 1)
        )
    return depth, inst, boxes


def test_a_box_keeps_its_own_object_not_a_nearer_one_reaching_into_it() -> None:
    depth, inst, boxes = _card_over_tin()
    cam = Intrinsics(300.0, 300.0, 160.0, 120.0, 320, 240, up=(0.0, -1.0, 0.0))
    d = describe_rgbd(None, depth, cam, boxes=boxes)
    tin, card = d.object("tin"), d.object("card")
    assert tin is not None and card is not None and tin.kept is not None and card.kept is not None
    # the card fills 1600 of the tin box's 3600 pixels and is nearer; the tin spans the box
    assert np.all(inst.ravel()[tin.kept] == 1) and len(tin.kept) == np.count_nonzero(inst == 1)
    assert np.all(inst.ravel()[card.kept] == 2) and len(card.kept) == np.count_nonzero(inst == 2)
    assert tin.object.centroid is not None and abs(tin.object.centroid[2] - 1.3) < 0.01
    rel = d.relation("card", "tin")
    assert rel is not None and rel.primary == "front"


def test_box_span() -> None:
    ys, xs = np.mgrid[10:20, 10:30]
    assert box_span(ys.ravel(), xs.ravel(), (10, 10, 30, 20)) == 1.0
    assert box_span(ys.ravel(), xs.ravel(), (0, 0, 40, 40)) == 0.125
    assert box_span(np.array([], np.intp), np.array([], np.intp), (0, 0, 4, 4)) == 0.0


def _grazing_box() -> tuple[np.ndarray, np.ndarray, Intrinsics]:
    """A box 10 cm below a level camera: its front face at 0.8 m and its top face receding
    from 0.8 to 1.05 m, seen at a grazing angle (about 15 mm of depth per row), in mm."""
    cam = Intrinsics(554.0, 554.0, 319.5, 239.5, 640, 480, up=(0.0, -1.0, 0.0))
    depth = np.full((480, 640), np.nan, np.float32)
    v = np.arange(480, dtype=float)
    with np.errstate(divide="ignore"):
        top = 554.0 * 0.1 / (v - 239.5)  # the top face: Y = 0.1 m below the camera
    rows_top = (top >= 0.8) & (top <= 1.05)
    rows_front = (v > 239.5 + 554.0 * 0.1 / 0.8) & (v <= 239.5 + 554.0 * 0.2 / 0.8)
    depth[rows_top, 250:390] = np.round(top[rows_top, None] * 1000.0) / 1000.0
    depth[rows_front, 250:390] = 0.8
    mask = np.isfinite(depth)
    return depth, mask, cam


def test_a_grazing_top_face_is_kept_with_its_front_face() -> None:
    depth, mask, cam = _grazing_box()
    ys, xs = np.nonzero(mask)
    z = depth[ys, xs].astype(float)
    surface = np.column_stack([(xs - cam.cx) * z / cam.fx, (ys - cam.cy) * z / cam.fy, z])
    truth = surface.mean(axis=0)
    up = (0.0, -1.0, 0.0)
    obj = measure_object("box", "box", ys, xs, depth, cam, up, surface="connected")
    assert isinstance(obj, MeasuredObject) and obj.kept_pixels == len(ys)
    assert obj.object.centroid is not None
    assert np.linalg.norm(obj.object.centroid - truth) < 1e-3
    # the depth modes alone cut the top face (rows 15 mm apart leave empty bins between them)
    only_mode = measure_object("box", "box", ys, xs, depth, cam, up, surface="largest")
    assert isinstance(only_mode, MeasuredObject) and only_mode.object.centroid is not None
    assert np.linalg.norm(only_mode.object.centroid - truth) > 0.01
    # and through describe_rgbd (masks keep the connected surface)
    d = describe_rgbd(None, depth, cam, masks=mask.astype(np.uint8), labels={1: "box"})
    assert np.linalg.norm(d.objects[0].object.centroid - truth) < 1e-3


def test_a_wall_inside_a_mask_does_not_join_the_object() -> None:
    depth, mask, cam = _grazing_box()
    depth[mask.any(axis=1), 390:400] = 2.5  # a sloppy mask: ten columns of wall beside it
    mask = np.isfinite(depth)
    ys, xs = np.nonzero(mask)
    obj = measure_object("box", "box", ys, xs, depth, cam, (0.0, -1.0, 0.0), surface="connected")
    assert isinstance(obj, MeasuredObject)
    assert obj.kept is not None and np.all(obj.kept % 640 < 390)
    assert obj.kept_pixels == np.count_nonzero(mask[:, :390])


def test_options_object_and_the_old_keywords_describe_alike() -> None:
    depth, inst, labels = rs.render()
    stage = RGBDOptions(min_pixels=30)
    old = describe_rgbd(
        None, depth, CAM, masks=inst, labels=labels, options=stage, directions=96, summary=False
    )
    new = describe_rgbd(
        None,
        depth,
        CAM,
        masks=inst,
        labels=labels,
        options=DescribeOptions(rgbd=stage, directions=96, summary=False),
    )
    assert old.summary == new.summary == ""
    assert [o.name for o in old.objects] == [o.name for o in new.objects]
    for a, b in zip(old.relations, new.relations, strict=True):
        assert a.sentence == b.sentence
        assert a.f0.shape == b.f0.shape == (96,)
        assert np.array_equal(a.f0, b.f0)
    # a keyword sets its field on top of the options object
    assert (
        describe_rgbd(
            None, depth, CAM, masks=inst, labels=labels, options=DescribeOptions(), summary=False
        ).summary
        == ""
    )


def test_measure_options_and_the_old_keywords_measure_alike() -> None:
    depth, inst, _ = rs.render()
    ys, xs = np.nonzero(inst == 1)
    stage = RGBDOptions(min_pixels=30)
    old = measure_object("a", "a", ys, xs, depth, CAM, (0, -1, 0), surface="nearest", options=stage)
    how = MeasureOptions(surface="nearest", rgbd=stage)
    new = measure_object("a", "a", ys, xs, depth, CAM, (0, -1, 0), options=how)
    assert isinstance(old, MeasuredObject) and isinstance(new, MeasuredObject)
    assert (old.source, old.pixels, old.kept_pixels) == (new.source, new.pixels, new.kept_pixels)
    assert np.array_equal(old.object.centroid, new.object.centroid)
    # a keyword sets its field on top of the options object
    boxed = measure_object("a", "a", ys, xs, depth, CAM, (0, -1, 0), options=how, source="box")
    assert isinstance(boxed, MeasuredObject) and boxed.source == "box"
