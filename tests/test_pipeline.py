"""The pipeline end to end: stereo pairs with known object positions → objects and relations.

Two kinds of scenes:

- photo cards: crops of scikit-image's photos pasted as fronto-parallel cards at known places
  (exactly ``f·B/Z`` pixels apart in the right image) in front of a textured wall. A card is
  flat, so its visible surface *is* its position: centroids must be within 2 cm.
- rendered scenes from ``scenespeak.tools.scenes`` (pybullet), level and pitched rig, generated once
  per session (see the ``rendered`` fixture).
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import pytest

from cardscene import BASELINE, HFOV, H, W, card_pair, photo
from scenespeak.errors import DatabaseError, ImageError, InputError
from scenespeak.perception.calibration import rig_from_short
from scenespeak.perception.objects import SceneObject, project_to_plane
from scenespeak.perception.recognition import LabelOptions, ObjectDatabase
from scenespeak.pipeline import PipelineOptions, SceneDescription, describe_files, describe_scene

_photo = photo


@pytest.fixture(scope="module")
def card_db(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("cards") / "objects.db"
    with ObjectDatabase.create(path) as db:
        for name in ("astronaut", "chelsea", "coffee"):
            db.add_object(name, [_photo(name, (240, 240))])
    return path


def _describe(cards: dict[str, tuple[float, float, float]], db_path: Path, **kw: Any) -> Any:
    left, right = card_pair(cards)
    rig = rig_from_short(BASELINE, HFOV, (W, H))
    with ObjectDatabase.open(db_path, readonly=True) as db:
        return describe_scene(left, right, rig, db, **kw)


NEAR = {"astronaut": (-0.25, 1.2, 0.2), "chelsea": (0.22, 1.0, 0.2), "coffee": (0.0, 1.8, 0.25)}


def test_cards_are_where_they_were_put(card_db: Path) -> None:
    desc = _describe(NEAR, card_db, unknown=False)
    assert isinstance(desc, SceneDescription)
    assert {o.label for o in desc.objects} == set(NEAR)
    for obj in desc.objects:
        x, z, _ = NEAR[obj.label]
        assert obj.source == "dense"
        assert obj.plane_centroid == pytest.approx([x, z], abs=0.02), obj.label
    assert desc.skipped == ()
    # every ordered pair, with the primary direction of the layout
    assert len(desc.relations) == 6
    assert desc.relation("astronaut", "chelsea").primary == "left"
    assert desc.relation("chelsea", "astronaut").primary == "right"
    assert desc.relation("coffee", "chelsea").primary == "behind"
    assert desc.relation("chelsea", "coffee").primary == "front"
    # the stages are kept
    assert len(desc.features_left) > 500 and len(desc.point_labels) == len(desc.points)
    assert {"sift", "label", "stereo", "objects", "relations"} <= set(desc.timings)
    assert desc.summary.startswith("From left to right: the astronaut")


def test_to_dict_is_the_interface_json(card_db: Path) -> None:
    doc = json.loads(json.dumps(_describe(NEAR, card_db, unknown=False).to_dict()))
    assert set(doc) >= {"objects", "relations", "skipped"}
    for o in doc["objects"]:
        assert set(o) >= {"label", "points", "centroid", "hull"}
    for r in doc["relations"]:
        assert set(r) >= {"argument", "referent", "primary", "secondary", "sentence", "f0", "f2"}
        assert len(r["f0"]) == 180 and len(r["f2"]) == 180
        # F(B, A) is F(A, B) turned by 180°
    rel = {(r["argument"], r["referent"]): r for r in doc["relations"]}
    f_ab = np.array(rel[("astronaut", "chelsea")]["f0"])
    f_ba = np.array(rel[("chelsea", "astronaut")]["f0"])
    assert np.allclose(np.roll(f_ab, 90), f_ba)


def test_far_small_cards_need_the_dense_region(card_db: Path) -> None:
    # 15 cm cards 1.7-1.9 m away: ~45 px wide, recognised, but few keypoints match in stereo.
    far = {"astronaut": (-0.3, 1.9, 0.15), "chelsea": (0.2, 1.0, 0.2), "coffee": (0.1, 1.7, 0.15)}
    sparse = _describe(far, card_db, dense=False, unknown=False)
    dense = _describe(far, card_db, dense=True, unknown=False)
    described_sparse = {o.label for o in sparse.objects}
    described_dense = {o.label for o in dense.objects}
    assert described_dense == set(far)
    assert len(described_sparse) < len(described_dense)
    missing = set(far) - described_sparse
    assert {s.label for s in sparse.skipped} == missing
    assert all("point" in s.reason for s in sparse.skipped)
    obj = dense.object("astronaut")
    assert isinstance(obj, SceneObject)
    assert obj.n_points > 100
    assert obj.plane_centroid == pytest.approx([-0.3, 1.9], abs=0.03)


def test_an_unrecognised_card_becomes_an_unknown_object(card_db: Path) -> None:
    # The camera photo is not in the database: its card's points are clustered.
    cards = {"camera": (-0.3, 1.6, 0.15), "chelsea": (0.2, 1.0, 0.2)}
    desc = _describe(cards, card_db)
    labels = [o.label for o in desc.objects]
    assert "chelsea" in labels and "camera" not in labels
    unknown = [o for o in desc.objects if o.label.startswith("unknown object")]
    assert len(unknown) == 1  # the wall 4 m away is background, not an object
    assert unknown[0].source == "segment"  # geometry first: an unnamed segment
    assert unknown[0].plane_centroid == pytest.approx([-0.3, 1.6], abs=0.03)
    rel = desc.relation("unknown object 1", "chelsea")
    assert (rel.primary, rel.secondary) == ("behind", "left")  # 0.6 m behind, 0.5 m left


def test_a_small_far_card_is_recognised_by_the_small_object_rule(card_db: Path) -> None:
    # A 10 cm astronaut card 1.9 m away (about 30 px wide) carries only a few matches: the
    # small-detection rule (an outline of at most 8,000 px² needs 4 inliers at distinct
    # positions) recognises it where the general rule (8 inliers) cannot.
    cards = {"astronaut": (-0.3, 1.9, 0.1), "chelsea": (0.2, 1.0, 0.2)}
    desc = _describe(cards, card_db)
    far = desc.object("astronaut")
    assert far is not None and far.source == "dense"
    assert far.plane_centroid == pytest.approx([-0.3, 1.9], abs=0.03)
    # the finer search (an enlarged look round its lone matches) verifies it with 8 inliers
    finer = _describe(cards, card_db, min_inliers_small=8)
    assert finer.object("astronaut") is not None
    no_finer = LabelOptions(min_inliers_small=8, finer_upscale=1.0, closer=False)
    strict = _describe(cards, card_db, labels=no_finer)
    assert strict.object("astronaut") is None
    assert any(o.label.startswith("unknown object") for o in strict.objects)  # clustered
    # the closer look at that unknown object's own region (recognition/closer.py) names it
    closer = _describe(cards, card_db, labels=dataclasses.replace(no_finer, closer=True))
    named = closer.object("astronaut")
    assert named is not None and named.notes[-1].startswith("named by a closer look")
    assert named.plane_centroid == pytest.approx([-0.3, 1.9], abs=0.03)
    assert not any(o.label.startswith("unknown object") for o in closer.objects)


def test_textureless_pair_is_an_image_error(card_db: Path) -> None:
    blank = np.full((H, W), 90, np.uint8)
    rig = rig_from_short(BASELINE, HFOV, (W, H))
    with (
        ObjectDatabase.open(card_db, readonly=True) as db,
        pytest.raises(ImageError, match="texture"),
    ):
        describe_scene(blank, blank, rig, db, sources={"left": "blank.png"})


def test_empty_database_is_a_database_error(tmp_path: Path) -> None:
    path = tmp_path / "empty.db"
    ObjectDatabase.create(path).close()
    left, right = card_pair(NEAR)
    rig = rig_from_short(BASELINE, HFOV, (W, H))
    with ObjectDatabase.open(path) as db, pytest.raises(DatabaseError, match="no objects"):
        describe_scene(left, right, rig, db)


def test_describe_files_names_the_inputs(card_db: Path, tmp_path: Path) -> None:
    left, right = card_pair(NEAR)
    cv2.imwrite(str(tmp_path / "l.png"), cv2.cvtColor(left, cv2.COLOR_RGB2BGR))
    cv2.imwrite(str(tmp_path / "r.png"), cv2.cvtColor(right, cv2.COLOR_RGB2BGR))
    (tmp_path / "c.json").write_text(
        json.dumps({"baseline": BASELINE, "hfov_deg": HFOV, "image_size": [W, H]})
    )
    desc = describe_files(tmp_path / "l.png", tmp_path / "r.png", tmp_path / "c.json", card_db)
    assert desc.sources["left"].endswith("l.png")
    assert {o.label for o in desc.objects} >= set(NEAR)
    text = desc.to_text()
    assert text.count("\n") + 1 >= 6
    assert "The astronaut is" in text


# --------------------------------------------------------------------------------------------
# rendered scenes (scenespeak.tools.scenes)


def _truth_xy(obj: dict[str, Any], up: np.ndarray) -> np.ndarray:
    return project_to_plane(np.asarray(obj["centroid"], float)[None], up)[0]


@pytest.fixture(scope="module", params=["level", "pitched"])
def rendered(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A few rendered scenes (fixed seeds) and the database learnt from their training views."""
    scenes = pytest.importorskip("scenespeak.tools.scenes")
    from scenespeak.pipeline import database_from_dataset

    pitched = request.param == "pitched"
    root = tmp_path_factory.mktemp(f"rendered_{request.param}")
    scenes.generate_dataset(root, 3, seed=13 if pitched else 7, pitched=pitched, progress=None)
    database_from_dataset(root, root / "objects.db")
    return root


def _scenes(root: Path) -> list[Path]:
    return [root / s for s in json.loads((root / "dataset.json").read_text())["scenes"]]


def _describe_rendered(scene: Path, db: Path) -> SceneDescription:
    return describe_files(
        scene / "left.png", scene / "right.png", scene / "calib.json", db, unknown=False
    )


def test_rendered_relations_and_centroids(rendered: Path) -> None:
    """Every unambiguous relation right; every centroid within its tolerance.

    Tolerance on the horizontal plane: the points are on the visible surface, not in the
    object's volume, so their centroid lies inside the footprint, on the camera's side: it may
    be off the centre of the volume by up to half the footprint's larger side (a box turned
    towards the camera shows one face more than the other, so this holds across as well as in
    depth), plus 3 cm of stereo noise (one pixel of disparity is 6 cm of depth at 2 m), and it
    may not be more than those 3 cm behind the centre.
    """
    db = rendered / "objects.db"
    sizes = {
        o["label"]: o["size"]
        for o in json.loads((rendered / "dataset.json").read_text())["objects"]
    }
    described = present = checked_relations = 0
    for scene in _scenes(rendered):
        truth = json.loads((scene / "truth.json").read_text())
        desc = _describe_rendered(scene, db)
        got = {o.label: o for o in desc.objects}
        recognised = {d.label for d in desc.detections}
        skipped = {s.label for s in desc.skipped}
        # every recognised object is described or listed as skipped with a reason
        assert recognised <= set(got) | skipped
        assert set(got) <= {t["label"] for t in truth["objects"]}  # nothing invented
        for t in truth["objects"]:
            present += 1
            obj = got.get(t["label"])
            if obj is None:
                continue
            described += 1
            dx, dy = obj.plane_centroid - _truth_xy(t, desc.up)
            tol = 0.5 * max(sizes[t["label"]][:2]) + 0.03
            where = f"{scene.name} {t['label']}: off by ({dx:.3f}, {dy:.3f}) m"
            assert np.hypot(dx, dy) <= tol and dy <= 0.03, where
        for r in truth["relations"]:
            rel = desc.relation(r["argument"], r["referent"])
            if r["ambiguous"] or rel is None:
                continue
            checked_relations += 1
            assert rel.primary == r["primary"], (scene.name, r, rel.sentence)
    # Recognition (the database's ratio test + homography check) is the limit: the curved
    # cylinders (can, mug, tin) and far objects are often not recognised, boxes, books and cards
    # are. On these seeds 4-6 of 13-14 objects are described, so the floor is low.
    assert described >= 0.25 * present, f"{described}/{present} objects described"
    assert checked_relations >= 2


def test_cropped_dense_map_describes_the_scene_like_the_full_one(card_db: Path) -> None:
    full = _describe(NEAR, card_db, dense_crop=False)
    crop = _describe(NEAR, card_db, dense_crop=True)
    assert [o.label for o in crop.objects] == [o.label for o in full.objects]
    for a, b in zip(crop.objects, full.objects, strict=True):
        assert np.linalg.norm(a.plane_centroid - b.plane_centroid) < 0.01
    assert [r.sentence for r in crop.relations] == [r.sentence for r in full.relations]
    # the cropped map was computed around the matches only (here the textured wall fills the
    # image, so the crop is most of it)
    assert full.stereo.dense.roi is None and crop.stereo.dense.roi is not None
    assert full.stereo.dense.valid_fraction() >= crop.stereo.dense.valid_fraction()
    # each unordered pair's histograms are computed once: the reverse is the same turned by 180°
    ab = crop.relation("astronaut", "chelsea")
    ba = crop.relation("chelsea", "astronaut")
    assert np.array_equal(ba.f0, np.roll(ab.f0, 90)) and np.array_equal(ba.f2, np.roll(ab.f2, 90))


def test_a_failing_labelling_is_raised_not_hung(
    card_db: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # the stereo stage runs in a second thread while the objects are labelled: when the
    # labelling fails, its error comes out (after the worker has finished), nothing hangs
    def broken(self: ObjectDatabase, *args: Any, **kwargs: Any) -> Any:
        raise DatabaseError(str(self.path), "database disk image is malformed")

    monkeypatch.setattr(ObjectDatabase, "label", broken)
    with pytest.raises(DatabaseError, match="malformed"):
        _describe(NEAR, card_db)


def test_stage_timings_are_reported(card_db: Path) -> None:
    desc = _describe(NEAR, card_db)
    # "geometry": the support plane and segments, made in the stereo thread (geometry first)
    assert set(desc.timings) == {
        "sift",
        "label",
        "stereo",
        "geometry",
        "wait",
        "objects",
        "relations",
    }
    assert all(v >= 0.0 for v in desc.timings.values())


def test_one_thread_gives_the_same_description_as_two(card_db: Path) -> None:
    # threads=1 is what a cluster worker runs (one scene per core): every stage one after the
    # other in the calling thread; the JSON must be the same as the two-thread default's
    two = _describe(NEAR, card_db).to_dict()
    one = _describe(NEAR, card_db, threads=1).to_dict()
    two.pop("timings_ms", None)
    one.pop("timings_ms", None)
    assert one == two
    assert len(one["objects"]) == 3


def test_threads_other_than_one_or_two_are_refused() -> None:
    with pytest.raises(InputError, match="threads"):
        PipelineOptions(threads=3)
