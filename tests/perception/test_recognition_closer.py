"""The closer look at unknown objects (perception/recognition/closer.py): an unknown object's own
image region, enlarged and searched with a lower contrast threshold, names it when what it
verifies is the object's size, the first look's keypoints do not contradict it and it is no
piece of an object of that label."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import cv2
import numpy as np
import pytest
from skimage import data

from scenespeak.perception.features import Features, detect, to_gray
from scenespeak.perception.objects import SceneObject, make_object
from scenespeak.perception.recognition import ObjectDatabase
from scenespeak.perception.recognition.closer import CloserOptions, closer_look, object_region
from scenespeak.perception.recognition.results import Detection, Labelling

K = np.array([[500.0, 0.0, 160.0], [0.0, 500.0, 120.0], [0.0, 0.0, 1.0]])
SHAPE = (240, 320)
UP = np.array([0.0, -1.0, 0.0])
FLOOR = 150


def _faded(image: np.ndarray, scale: float, contrast: float) -> np.ndarray:
    """``image`` shrunk ``scale`` times, its contrast round the floor's grey ``contrast`` times
    (a far, faded label)."""
    small = cv2.resize(image, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA)
    out = FLOOR + contrast * (small.astype(np.float64) - FLOOR)
    return np.clip(out, 0, 255).astype(np.uint8)


def _unknown(x0: float, y0: float, x1: float, y1: float, z: float = 1.0) -> SceneObject:
    """An unknown object whose points project onto the box (x0, y0)-(x1, y1) at depth z."""
    u, v = np.meshgrid(np.arange(x0, x1, 2.0), np.arange(y0, y1, 2.0))
    xyz = np.column_stack([u.ravel(), v.ravel(), np.ones(u.size)]) @ np.linalg.inv(K).T * z
    obj = make_object("unknown", xyz, up=UP, source="segment")
    assert isinstance(obj, SceneObject)
    return dataclasses.replace(obj, label="unknown object 1", name="unknown object 1")


def _scene(patch: np.ndarray, at: tuple[int, int] = (60, 100)) -> np.ndarray:
    img = np.full((*SHAPE, 3), FLOOR, np.uint8)
    x, y = at
    img[y : y + patch.shape[0], x : x + patch.shape[1]] = patch
    return img


@pytest.fixture(scope="module")
def db(tmp_path_factory: pytest.TempPathFactory) -> ObjectDatabase:
    path = Path(tmp_path_factory.mktemp("closer")) / "objects.db"
    database = ObjectDatabase.create(path)
    database.add_object("cat", [data.chelsea()])
    database.add_object("astronaut", [data.astronaut()])
    return database


def test_a_faded_far_object_the_first_look_cannot_see_is_named_by_the_closer_look(
    db: ObjectDatabase,
) -> None:
    patch = _faded(data.chelsea(), 0.16, 0.2)  # 72 x 48 px at a fifth of its contrast
    img = _scene(patch)
    first = db.label(detect(to_gray(img)), image=img)
    assert not first.detections  # the whole image's look (and its finer search) finds nothing
    h, w = patch.shape[:2]
    out = closer_look([_unknown(60, 100, 60 + w, 100 + h)], img, K, db.labeller())
    assert [o.label for o in out] == ["cat"]
    assert out[0].notes[-1].startswith("named by a closer look")
    assert 0.9 < out[0].confidence <= 1.0  # dozens of inliers


def test_a_never_learnt_texture_stays_unknown(db: ObjectDatabase) -> None:
    patch = _faded(data.rocket(), 0.16, 0.5)
    img = _scene(patch)
    h, w = patch.shape[:2]
    out = closer_look([_unknown(60, 100, 60 + w, 100 + h)], img, K, db.labeller())
    assert [o.label for o in out] == ["unknown object 1"]


def test_the_closer_look_is_off_without_an_enlargement_of_the_region(db: ObjectDatabase) -> None:
    """Not enlarged and at OpenCV's contrast threshold, the faded cat gives nothing to verify:
    the enlargement is what names it."""
    patch = _faded(data.chelsea(), 0.16, 0.2)
    img = _scene(patch)
    h, w = patch.shape[:2]
    plain = CloserOptions(upscale=1.0, contrast=0.04)
    out = closer_look([_unknown(60, 100, 60 + w, 100 + h)], img, K, db.labeller(), plain)
    assert [o.label for o in out] == ["unknown object 1"]


# --- the rules, with a labeller that reports what it was given --------------------------------


class _Fixed:
    """A labeller that finds ``label`` with the given outline in whatever it is given, and
    keeps the features it was asked about."""

    def __init__(self, label: str, outline: np.ndarray) -> None:
        self.label, self.outline, self.seen = label, outline, []

    def __call__(self, f: Features) -> Labelling:
        self.seen.append(f)
        n = len(f)
        det = Detection(self.label, 0, np.eye(3), np.arange(n), self.outline, float(n), "h", n)
        return Labelling(np.zeros(n, np.int32), (det,), np.zeros(n, np.int32))


def _textured() -> np.ndarray:
    return _scene(cv2.resize(data.astronaut(), (80, 80)), at=(40, 60))


def _box(x0: float, y0: float, x1: float, y1: float) -> np.ndarray:
    return np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]], np.float64)


def test_only_the_objects_own_keypoints_are_looked_at() -> None:
    """The box round the unknown object takes in its named neighbour; the neighbour's
    keypoints are not handed to the labeller, nor those off the object's region."""
    img = _textured()  # texture over x 40-120, y 60-140
    unknown = _unknown(80, 60, 120, 140)
    neighbour = dataclasses.replace(_unknown(40, 60, 78, 140), label="mug", name="mug")
    look = _Fixed("cat", _box(80, 60, 120, 140))
    out = closer_look([neighbour, unknown], img, K, look)
    assert [o.label for o in out] == ["mug", "cat"]
    (f,) = look.seen
    assert len(f) and f.xy[:, 0].min() >= 76  # nothing of the mug's region (x 40-76)
    region = object_region(unknown, K, SHAPE)
    assert region is not None
    assert f.xy[:, 0].max() <= region[:, 0].max() + CloserOptions().grow + 1


@pytest.mark.parametrize(("scale", "named"), [(1.0, True), (2.0, True), (4.0, False), (0.2, False)])
def test_the_verified_outline_must_be_the_objects_size(scale: float, named: bool) -> None:
    """A training view's outline several times the region is a piece of a larger object, one
    far smaller a chance fit on a part: only within ``area_factor`` (2.5) of its area."""
    img = _textured()
    side = 80 * np.sqrt(scale)
    look = _Fixed("cat", _box(40, 60, 40 + side, 60 + side))
    out = closer_look([_unknown(40, 60, 120, 140)], img, K, look)
    assert (out[0].label == "cat") is named


def test_a_vetoed_name_leaves_the_object_unknown_with_the_reason() -> None:
    img = _textured()
    look = _Fixed("cat", _box(40, 60, 120, 140))
    out = closer_look(
        [_unknown(40, 60, 120, 140)], img, K, look, veto=lambda _o, label: f"not the {label}"
    )
    assert out[0].label == "unknown object 1"
    assert out[0].notes[-1] == "not named cat: not the cat"


def test_a_piece_of_an_object_of_that_label_is_not_a_second_instance() -> None:
    """An unknown object whose footprint comes 1 cm from that of an object already called
    "cat" stays unknown; one whose footprint is 30 cm away becomes "cat 2"."""
    img = _textured()
    look = _Fixed("cat", _box(80, 60, 120, 140))
    unknown = _unknown(80, 60, 120, 140)
    elsewhere = _unknown(200, 60, 240, 140).xyz  # its image region: no overlap
    beside = dataclasses.replace(
        unknown, label="cat", name="cat", xyz=elsewhere, plane_xy=unknown.plane_xy - [0.01, 0.0]
    )
    assert closer_look([beside, unknown], img, K, look)[1].label == "unknown object 1"
    apart = dataclasses.replace(beside, plane_xy=unknown.plane_xy - [0.3, 0.0])
    out = closer_look([apart, unknown], img, K, look)
    assert [o.name for o in out] == ["cat", "cat 2"]


class _Patch(_Fixed):
    """:class:`_Fixed` whose detection's inliers are only the keypoints inside ``patch``
    (a box in scene pixels): a model that agrees with a few matches in one spot."""

    def __init__(self, label: str, outline: np.ndarray, patch: np.ndarray) -> None:
        super().__init__(label, outline)
        self.patch = patch

    def __call__(self, f: Features) -> Labelling:
        self.seen.append(f)
        x0, y0 = self.patch.min(axis=0)
        x1, y1 = self.patch.max(axis=0)
        inl = np.flatnonzero(
            (f.xy[:, 0] >= x0) & (f.xy[:, 0] <= x1) & (f.xy[:, 1] >= y0) & (f.xy[:, 1] <= y1)
        )
        det = Detection(self.label, 0, np.eye(3), inl, self.outline, float(len(inl)), "s", len(inl))
        return Labelling(np.zeros(len(f), np.int32), (det,), np.zeros(len(f), np.int32))


@pytest.mark.parametrize(("side", "named"), [(12.0, False), (24.0, True), (60.0, True)])
def test_inliers_in_one_patch_of_the_region_do_not_name_it(side: float, named: bool) -> None:
    """A model that agrees with matches in a 12-pixel patch of an 80-pixel object (0.15 of its
    region) names nothing: chance inliers of a texture that only looks alike cluster, the
    object's own lie all over it (``min_cover`` 0.2). A 24-pixel patch (0.3) names it."""
    img = _textured()
    look = _Patch("cat", _box(40, 60, 120, 140), _box(70, 90, 70 + side, 90 + side))
    out = closer_look([_unknown(40, 60, 120, 140)], img, K, look)
    assert look.seen and len(look.seen[0]) > 20
    assert (out[0].label == "cat") is named
    if not named:
        assert "a patch of it" in out[0].notes[-1]
    off = closer_look([_unknown(40, 60, 120, 140)], img, K, look, CloserOptions(min_cover=0.0))
    assert off[0].label == "cat"  # without the rule the patch names it


class _Crowded(_Fixed):
    """:class:`_Fixed` whose detection's inliers are ``share`` of its matches."""

    def __init__(self, label: str, outline: np.ndarray, share: float) -> None:
        super().__init__(label, outline)
        self.share = share

    def __call__(self, f: Features) -> Labelling:
        self.seen.append(f)
        n = len(f)
        matches = int(np.ceil(n / self.share))
        det = Detection(
            self.label, 0, np.eye(3), np.arange(n), self.outline, float(n), "s", matches
        )
        return Labelling(np.zeros(n, np.int32), (det,), np.zeros(n, np.int32))


@pytest.mark.parametrize(("share", "named"), [(0.04, False), (0.08, True), (1.0, True)])
def test_a_few_inliers_among_many_matches_name_nothing(share: float, named: bool) -> None:
    """Inliers spread over the whole region, but 4 % of the matches (a never-learnt brick
    crate's 8 of 170 for "cereal"): chance agreement, not named (``min_share`` 0.05)."""
    img = _textured()
    look = _Crowded("cat", _box(40, 60, 120, 140), share)
    out = closer_look([_unknown(40, 60, 120, 140)], img, K, look)
    assert (out[0].label == "cat") is named
    if not named:
        assert "a chance agreement" in out[0].notes[-1]
        off = CloserOptions(min_share=0.0)
        assert closer_look([_unknown(40, 60, 120, 140)], img, K, look, off)[0].label == "cat"
