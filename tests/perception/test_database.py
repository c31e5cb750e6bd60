"""Tests of the object database: real SQLite files, real photos, a scene with known homographies."""

from __future__ import annotations

import hashlib
import shutil
import sqlite3
from pathlib import Path

import cv2
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from numpy.typing import NDArray
from skimage import data

from scenespeak.errors import DatabaseError, ImageError, ScenespeakError
from scenespeak.perception.features import Features, detect, to_gray
from scenespeak.perception.recognition import (
    APPLICATION,
    SCHEMA_VERSION,
    Detection,
    ExactIndex,
    FaissIndex,
    IVFIndex,
    Labelling,
    ObjectDatabase,
    build_index,
    outline_from_mask,
)

# --------------------------------------------------------------------------------------------
# Real photos as training objects, and a scene made by warping them into another photo
# --------------------------------------------------------------------------------------------


def _objects() -> dict[str, NDArray[np.uint8]]:
    return {
        "astronaut": to_gray(data.astronaut())[30:330, 100:400],
        "coffee": to_gray(data.coffee())[50:350, 150:450],
        "cat": to_gray(data.chelsea())[20:280, 80:380],
        "rocket": to_gray(data.rocket())[0:420, 200:420],
    }


def _similarity(
    s: float, deg: float, tx: float, ty: float, persp: tuple[float, float] = (0.0, 0.0)
) -> NDArray[np.float64]:
    c, si = s * np.cos(np.radians(deg)), s * np.sin(np.radians(deg))
    return np.array([[c, -si, tx], [si, c, ty], [persp[0], persp[1], 1.0]])


def _corners(img: NDArray[np.uint8]) -> NDArray[np.float64]:
    h, w = img.shape
    return np.array([[-0.5, -0.5], [w - 0.5, -0.5], [w - 0.5, h - 0.5], [-0.5, h - 0.5]])


def _warp_pts(h: NDArray[np.float64], pts: NDArray[np.float64]) -> NDArray[np.float64]:
    return cv2.perspectiveTransform(pts[None].astype(np.float64), h)[0]


class Scene:
    """Astronaut, coffee and cat pasted into the gravel photo; the rocket is absent."""

    def __init__(self) -> None:
        self.objects = _objects()
        self.background = cv2.resize(to_gray(data.gravel()), (1000, 750))
        self.homographies = {
            "astronaut": _similarity(0.8, 10, 60, 60),
            "coffee": _similarity(0.7, -15, 520, 120, (2e-4, 1e-4)),
            "cat": _similarity(0.9, 5, 330, 420),
        }
        image = self.background.copy()
        size = (image.shape[1], image.shape[0])
        self.masks: dict[str, NDArray[np.bool_]] = {}
        for name, h in self.homographies.items():
            obj = self.objects[name]
            warped = cv2.warpPerspective(obj, h, size, flags=cv2.INTER_LINEAR)
            m = cv2.warpPerspective(np.full_like(obj, 255), h, size, flags=cv2.INTER_NEAREST) > 0
            image[m] = warped[m]
            self.masks[name] = m
        self.image = image
        self.features = detect(image)
        self.background_features = detect(self.background)


@pytest.fixture(scope="module")
def scene() -> Scene:
    return Scene()


@pytest.fixture(scope="module")
def built_db(tmp_path_factory: pytest.TempPathFactory, scene: Scene) -> Path:
    """A database of the four objects, built once; tests copy it before writing."""
    path = tmp_path_factory.mktemp("db") / "objects.db"
    with ObjectDatabase.create(path) as db:
        for name, img in scene.objects.items():
            db.add_object(name, [img])
    return path


@pytest.fixture
def db_copy(built_db: Path, tmp_path: Path) -> Path:
    path = tmp_path / "objects.db"
    shutil.copy(built_db, path)
    return path


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _rows(path: Path) -> list[tuple[object, ...]]:
    with sqlite3.connect(path) as conn:
        out: list[tuple[object, ...]] = []
        for table in ("meta", "objects", "views"):
            out += [(table, *r) for r in conn.execute(f"SELECT * FROM {table} ORDER BY 1")]
    conn.close()
    return out


# --------------------------------------------------------------------------------------------
# Writing and reading
# --------------------------------------------------------------------------------------------


def test_add_list_remove_round_trip(tmp_path: Path, scene: Scene) -> None:
    path = tmp_path / "objects.db"
    with ObjectDatabase.open(path, create=True) as db:
        assert db.labels() == []
        info = db.add_object("cat", [scene.objects["cat"]])
        assert info.label == "cat" and info.views == 1 and info.descriptors > 100
        db.add_object("coffee", [scene.objects["coffee"], scene.objects["coffee"][::2, ::2]])
        assert db.labels() == ["cat", "coffee"]
        listed = {o.label: o for o in db.list_objects()}
        assert listed["coffee"].views == 2
        assert listed["cat"].descriptors == info.descriptors
        assert listed["cat"].added.endswith("+00:00")
        assert "cat" in db and "dog" not in db and len(db) == 2
        db.remove("cat")
        assert db.labels() == ["coffee"]
        assert all(v.label == "coffee" for v in db.views())
        with pytest.raises(DatabaseError, match="no object labelled 'cat'"):
            db.remove("cat")


def test_persistence_across_open(tmp_path: Path, scene: Scene) -> None:
    path = tmp_path / "objects.db"
    cat = scene.objects["cat"]
    with ObjectDatabase.create(path) as db:
        info = db.add_object("cat", [cat])
    with ObjectDatabase.open(path, readonly=True) as db:
        assert [(o.label, o.views, o.descriptors) for o in db.list_objects()] == [
            ("cat", 1, info.descriptors)
        ]
        (view,) = db.views("cat")
        assert (view.width, view.height) == (cat.shape[1], cat.shape[0])
        np.testing.assert_allclose(view.outline, _corners(cat))
        assert view.keypoints == info.descriptors
        with pytest.raises(DatabaseError, match="read-only"):
            db.remove("cat")
    with sqlite3.connect(path) as conn:
        meta = dict(conn.execute("SELECT key, value FROM meta"))
        (blob,) = conn.execute("SELECT descriptors FROM views").fetchone()
    conn.close()
    assert meta["application"] == APPLICATION
    assert meta["schema_version"] == str(SCHEMA_VERSION)
    stored = np.frombuffer(blob, np.uint8).reshape(-1, 128)
    # add_object detects with its own default contrast threshold (0.02)
    np.testing.assert_array_equal(stored, detect(cat, contrast_threshold=0.02).descriptors)


def test_create_refuses_existing_file(db_copy: Path) -> None:
    with pytest.raises(DatabaseError, match="already exists"):
        ObjectDatabase.create(db_copy)


def test_duplicate_label_and_replace(db_copy: Path, scene: Scene) -> None:
    with ObjectDatabase.open(db_copy) as db:
        before = {o.label: o for o in db.list_objects()}
        with pytest.raises(DatabaseError, match="already has an object labelled 'cat'"):
            db.add_object("cat", [scene.objects["coffee"]])
        info = db.add_object("cat", [scene.objects["cat"]] * 2, replace=True)
        after = {o.label: o for o in db.list_objects()}
    assert info.views == 2 and after["cat"].views == 2
    assert after["cat"].descriptors == 2 * before["cat"].descriptors
    assert set(after) == set(before)


def test_failed_add_leaves_file_unchanged(db_copy: Path, tmp_path: Path, scene: Scene) -> None:
    good1, good2 = tmp_path / "a.png", tmp_path / "b.png"
    cv2.imwrite(str(good1), scene.objects["cat"])
    cv2.imwrite(str(good2), scene.objects["coffee"])
    bad = tmp_path / "broken.png"
    bad.write_bytes(b"\x89PNG\r\n\x1a\n this is not really a PNG")
    sha, rows = _sha(db_copy), _rows(db_copy)
    with ObjectDatabase.open(db_copy) as db:
        with pytest.raises(ImageError, match=r"broken\.png"):
            db.add_object("mug", [good1, good2, bad])
        assert "mug" not in db
    assert _sha(db_copy) == sha
    assert _rows(db_copy) == rows


def test_interrupt_while_storing_rolls_back(db_copy: Path, scene: Scene) -> None:
    sha, rows = _sha(db_copy), _rows(db_copy)
    stages: list[tuple[str, int, int]] = []

    def ctrl_c_on_second_view(stage: str, done: int, total: int) -> None:
        stages.append((stage, done, total))
        if stage == "store" and done == 2:
            raise KeyboardInterrupt

    imgs = [scene.objects["cat"], scene.objects["coffee"], scene.objects["rocket"]]
    with ObjectDatabase.open(db_copy) as db:
        with pytest.raises(KeyboardInterrupt):
            db.add_object("cat", imgs, replace=True, progress=ctrl_c_on_second_view)
        # The connection is still usable and shows the old state.
        assert db.views("cat")[0].keypoints == len(
            detect(scene.objects["cat"], contrast_threshold=0.02)
        )
    assert stages[:3] == [("extract", 1, 3), ("extract", 2, 3), ("extract", 3, 3)]
    assert stages[-1] == ("store", 2, 3)
    assert _sha(db_copy) == sha
    assert _rows(db_copy) == rows


def test_image_without_keypoints_is_named(tmp_path: Path) -> None:
    flat = tmp_path / "blank.png"
    cv2.imwrite(str(flat), np.full((120, 160), 128, np.uint8))
    with ObjectDatabase.open(tmp_path / "o.db", create=True) as db:
        with pytest.raises(ImageError, match=r"blank\.png: no SIFT keypoints"):
            db.add_object("wall", [flat])
        assert db.labels() == []


def test_bad_arguments(tmp_path: Path, scene: Scene) -> None:
    cat = scene.objects["cat"]
    with ObjectDatabase.open(tmp_path / "o.db", create=True) as db:
        with pytest.raises(DatabaseError, match="label must not be empty"):
            db.add_object("  ", [cat])
        with pytest.raises(DatabaseError, match="no training images"):
            db.add_object("cat", [])
        with pytest.raises(DatabaseError, match="2 masks for 1 images"):
            db.add_object("cat", [cat], masks=[None, None])
        with pytest.raises(ImageError, match="mask size"):
            db.add_object("cat", [cat], masks=[np.ones((10, 10), bool)])
        with pytest.raises(ImageError, match="mask is empty"):
            db.add_object("cat", [cat], masks=[np.zeros(cat.shape, bool)])
        with pytest.raises(ImageError, match="no such file"):
            db.add_object("cat", [tmp_path / "missing.png"])
        assert db.labels() == []


def test_mask_gives_outline_and_limits_keypoints(tmp_path: Path, scene: Scene) -> None:
    cat = scene.objects["cat"]
    mask = np.zeros(cat.shape, np.uint8)
    cv2.circle(mask, (150, 130), 100, 255, -1)
    mask_file = tmp_path / "mask.png"
    cv2.imwrite(str(mask_file), mask)
    with ObjectDatabase.open(tmp_path / "o.db", create=True) as db:
        info = db.add_object("cat", [cat], masks=[mask_file])
        (view,) = db.views("cat")
    assert view.has_mask
    radius = np.linalg.norm(view.outline - [150, 130], axis=1)
    assert view.outline.shape[0] >= 8 and np.all(np.abs(radius - 100) < 2.5)
    assert info.descriptors < len(detect(cat))


@given(x=st.integers(0, 40), y=st.integers(0, 30), w=st.integers(2, 20), h=st.integers(2, 20))
def test_outline_of_rectangle_mask(x: int, y: int, w: int, h: int) -> None:
    m = np.zeros((60, 70), bool)
    m[y : y + h, x : x + w] = True
    poly = outline_from_mask(m)
    assert poly.shape == (4, 2)
    assert poly[:, 0].min() == x and poly[:, 0].max() == x + w - 1
    assert poly[:, 1].min() == y and poly[:, 1].max() == y + h - 1


# --------------------------------------------------------------------------------------------
# Files that are not ours
# --------------------------------------------------------------------------------------------


def _other_sqlite(path: Path) -> None:
    with sqlite3.connect(path) as conn:
        conn.execute("CREATE TABLE songs (title TEXT)")
    conn.close()


def _foreign_meta(path: Path) -> None:
    with sqlite3.connect(path) as conn:
        conn.execute("CREATE TABLE meta (key TEXT PRIMARY KEY, value TEXT)")
        conn.execute("INSERT INTO meta VALUES ('application', 'someone-else')")
    conn.close()


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (lambda p: p.write_bytes(b""), "the file is empty"),
        (lambda p: p.write_text("label,descriptor\nmug,1 2 3\n"), "not an SQLite file"),
        (_other_sqlite, "without our 'meta' table"),
        (_foreign_meta, "names another application"),
    ],
    ids=["empty-file", "text-file", "other-sqlite", "foreign-meta"],
)
def test_files_that_are_not_ours(tmp_path: Path, make: object, message: str) -> None:
    path = tmp_path / "thing.db"
    make(path)  # type: ignore[operator]
    sha = _sha(path)
    with pytest.raises(DatabaseError, match=message) as err:
        ObjectDatabase.open(path)
    assert str(err.value).startswith(str(path) + ": ")
    assert "\n" not in str(err.value)
    if message != "the file is empty":
        assert "is not a scenespeak object database" in str(err.value)
    assert _sha(path) == sha  # opening never writes to a file that is not ours


def test_other_schema_version(db_copy: Path) -> None:
    with sqlite3.connect(db_copy) as conn:
        conn.execute("UPDATE meta SET value = '99' WHERE key = 'schema_version'")
    conn.close()
    with pytest.raises(DatabaseError, match="schema version 99, this scenespeak reads 1, 2 and 3"):
        ObjectDatabase.open(db_copy)


def test_corrupt_file(db_copy: Path) -> None:
    raw = bytearray(db_copy.read_bytes())
    rng = np.random.default_rng(7)
    # Keep the 100-byte header (so it still looks like SQLite) and scramble the pages.
    raw[100:] = rng.integers(0, 256, len(raw) - 100, dtype=np.uint8).tobytes()
    db_copy.write_bytes(bytes(raw))
    with pytest.raises(DatabaseError, match="is not a scenespeak object database"):
        with ObjectDatabase.open(db_copy) as db:
            db.label(detect(data.camera()))


def test_missing_file_and_folder(tmp_path: Path) -> None:
    with pytest.raises(DatabaseError, match="no such file"):
        ObjectDatabase.open(tmp_path / "nope.db")
    assert not (tmp_path / "nope.db").exists()
    with pytest.raises(DatabaseError, match="is a folder"):
        ObjectDatabase.open(tmp_path)
    with pytest.raises(DatabaseError, match="does not exist"):
        ObjectDatabase.create(tmp_path / "no" / "such" / "o.db")


def test_empty_database_cannot_label(tmp_path: Path, scene: Scene) -> None:
    path = tmp_path / "empty.db"
    ObjectDatabase.create(path).close()
    with ObjectDatabase.open(path) as db:
        with pytest.raises(DatabaseError, match="has no objects") as err:
            db.label(scene.features)
    assert isinstance(err.value, ScenespeakError) and str(path) in str(err.value)


# --------------------------------------------------------------------------------------------
# Recognition
# --------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def labelling(built_db: Path, scene: Scene) -> Labelling:
    with ObjectDatabase.open(built_db, readonly=True) as db:
        return db.label(scene.features)


def test_recognises_pasted_objects_with_their_homography(
    labelling: Labelling, scene: Scene
) -> None:
    found = {d.label: d for d in labelling.detections}
    assert set(found) == {"astronaut", "coffee", "cat"}  # the rocket is not in the scene
    for name, det in found.items():
        assert isinstance(det, Detection)
        true = _warp_pts(scene.homographies[name], _corners(scene.objects[name]))
        assert det.outline_in_scene.shape == (4, 2)
        assert np.abs(det.outline_in_scene - true).max() < 3.0, name
        assert det.homography.shape == (3, 3)
        assert det.score >= 8 and len(det.inliers) == det.score
    scores = [d.score for d in labelling.detections]
    assert scores == sorted(scores, reverse=True)


def test_labelled_keypoints_lie_on_their_object(labelling: Labelling, scene: Scene) -> None:
    xy = np.rint(scene.features.xy).astype(int)
    for i, det in enumerate(labelling.detections):
        on = scene.masks[det.label][xy[labelling.labels == i, 1], xy[labelling.labels == i, 0]]
        assert on.all(), det.label
        np.testing.assert_array_equal(np.flatnonzero(labelling.labels == i), det.inliers)
    names = labelling.names()
    assert names.count("cat") == int(labelling.detection("cat").score)  # type: ignore[union-attr]


def test_unknown_keypoints_stay_unknown(labelling: Labelling, scene: Scene) -> None:
    xy = np.rint(scene.features.xy).astype(int)
    on_any = np.zeros(len(xy), bool)
    for m in scene.masks.values():
        on_any |= m[xy[:, 1], xy[:, 0]]
    assert (labelling.labels[~on_any] == -1).all()
    assert (~on_any).sum() > 1000  # the gravel background has many keypoints of its own
    assert labelling.labels.dtype == np.int32 and labelling.labels.shape == (len(xy),)


def test_background_alone_gives_no_object(built_db: Path, scene: Scene) -> None:
    with ObjectDatabase.open(built_db, readonly=True) as db:
        result = db.label(scene.background_features)
    assert result.detections == ()
    assert (result.labels == -1).all()


def _with_stray(
    background: Features, donor: Features, picks: NDArray[np.intp], xy: NDArray[np.float64]
) -> Features:
    """The background's features plus copies of some donor descriptors at given positions."""
    extra = donor.subset(picks)
    return Features(
        xy=np.vstack([background.xy, xy]),
        size=np.concatenate([background.size, extra.size]),
        angle=np.concatenate([background.angle, extra.angle]),
        response=np.concatenate([background.response, extra.response]),
        octave=np.concatenate([background.octave, extra.octave]),
        descriptors=np.vstack([background.descriptors, extra.descriptors]),
    )


def test_stray_matches_do_not_make_an_object(built_db: Path, scene: Scene) -> None:
    rocket = detect(scene.objects["rocket"])
    rng = np.random.default_rng(3)
    picks = rng.choice(len(rocket), 30, replace=False)
    # 30 exact rocket descriptors scattered at random places: every one passes the ratio test,
    # but they agree on no geometry.
    scattered = rng.uniform([0, 0], [1000, 750], (30, 2))
    query = _with_stray(scene.background_features, rocket, picks, scattered)
    # 6 rocket descriptors in their true layout: consistent, but fewer than min_inliers.
    few = _with_stray(scene.background_features, rocket, picks[:6], rocket.xy[picks[:6]] + 300)
    with ObjectDatabase.open(built_db, readonly=True) as db:
        scattered_result = db.label(query)
        few_result = db.label(few, min_inliers=8)
        few_lenient = db.label(few, min_inliers=5)
    n_bg = len(scene.background_features)
    assert (scattered_result.matched[n_bg:] >= 0).sum() >= 25  # they did match...
    assert scattered_result.detections == ()  # ...but make no object
    assert (scattered_result.labels == -1).all()
    assert few_result.detections == ()
    assert [d.label for d in few_lenient.detections] == ["rocket"]  # the check can pass


def _placed(donor: Features, picks: NDArray[np.intp], h: NDArray[np.float64]) -> Features:
    """Donor keypoints carried into a scene by a similarity ``h`` (positions, sizes, angles)."""
    f = donor.subset(picks)
    s = float(np.sqrt(abs(np.linalg.det(h[:2, :2]))))
    rot = float(np.degrees(np.arctan2(h[1, 0], h[0, 0])))
    return Features(
        xy=_warp_pts(h, f.xy),
        size=(f.size * s).astype(np.float32),
        angle=((f.angle + rot) % 360.0).astype(np.float32),
        response=f.response,
        octave=f.octave,
        descriptors=f.descriptors,
    )


def _concat(a: Features, b: Features) -> Features:
    return Features(
        xy=np.vstack([a.xy, b.xy]),
        size=np.concatenate([a.size, b.size]),
        angle=np.concatenate([a.angle, b.angle]),
        response=np.concatenate([a.response, b.response]),
        octave=np.concatenate([a.octave, b.octave]),
        descriptors=np.vstack([a.descriptors, b.descriptors]),
    )


def test_small_far_object_needs_fewer_inliers(built_db: Path, scene: Scene) -> None:
    rocket = detect(scene.objects["rocket"])
    rng = np.random.default_rng(5)
    # keypoints at distinct positions (SIFT repeats a position once per orientation)
    _, first = np.unique(np.rint(rocket.xy), axis=0, return_index=True)
    picks = rng.choice(first, 6, replace=False)
    # The rocket (220 x 420 px) seen 7x smaller, ~31 x 60 px: only 6 of its keypoints survive.
    far = _similarity(1 / 7, 8, 400, 300)
    small = _concat(scene.background_features, _placed(rocket, picks, far))
    # The same 6 keypoints on a full-size rocket: a big outline with 6 inliers is not enough.
    big = _concat(scene.background_features, _placed(rocket, picks, _similarity(1, 8, 300, 100)))
    # And 6 scattered over a small area with random sizes and angles: no geometry.
    stray = _placed(rocket, picks, far)
    stray = Features(
        xy=stray.xy + rng.uniform(-25, 25, stray.xy.shape),
        size=stray.size * rng.uniform(0.3, 3, len(picks)).astype(np.float32),
        angle=rng.uniform(0, 360, len(picks)).astype(np.float32),
        response=stray.response,
        octave=stray.octave,
        descriptors=stray.descriptors,
    )
    scattered = _concat(scene.background_features, stray)
    n_bg = len(scene.background_features)
    with ObjectDatabase.open(built_db, readonly=True) as db:
        found = db.label(small)  # the defaults: min_inliers 8, min_inliers_small 5
        off = db.label(small, small_area=0)
        big_result = db.label(big)
        stray_result = db.label(scattered)
    assert [d.label for d in found.detections] == ["rocket"]
    det = found.detections[0]
    assert set(det.inliers.tolist()) <= set(range(n_bg, n_bg + 6)) and det.score >= 5
    true = _warp_pts(far, _corners(scene.objects["rocket"]))
    assert np.abs(det.outline_in_scene - true).max() < 2.0
    assert off.detections == ()  # without the small-object rule: below min_inliers = 8
    assert big_result.detections == ()
    assert stray_result.detections == ()


def test_a_few_inliers_among_many_matches_are_chance(built_db: Path, scene: Scene) -> None:
    """The 6 keypoints of the far rocket are a small detection; with 64 more of the rocket's
    descriptors scattered over the scene (they pass the ratio test into the same views, but
    agree on no geometry) the 6 are under a tenth of the matches: the many matches of a
    texture that only looks alike, among which a handful line up by chance (``small_share``).
    A detection with ``min_inliers`` inliers needs no share."""
    rocket = detect(scene.objects["rocket"])
    rng = np.random.default_rng(5)
    _, first = np.unique(np.rint(rocket.xy), axis=0, return_index=True)
    picks = rng.choice(first, 6, replace=False)
    far = _similarity(1 / 7, 8, 400, 300)
    others = rng.choice(np.setdiff1d(np.arange(len(rocket)), picks), 64, replace=False)
    scattered = rng.uniform([0, 0], [1000, 750], (64, 2))
    small = _concat(scene.background_features, _placed(rocket, picks, far))
    query = _with_stray(small, rocket, others, scattered)
    with ObjectDatabase.open(built_db, readonly=True) as db:
        alone = db.label(small)
        crowded = db.label(query)
        no_share = db.label(query, small_share=0.0)
    assert [d.label for d in alone.detections] == ["rocket"]
    assert [d.label for d in no_share.detections] == ["rocket"]  # the rule is what refuses it
    det = no_share.detections[0]
    assert det.score < 8 and det.matches > 10 * det.score
    assert crowded.detections == ()


def test_matches_split_between_views_are_pooled(tmp_path: Path, scene: Scene) -> None:
    # Two overlapping training views of one photo (its left and right parts): a keypoint of the
    # shared middle has a near-copy in both, and which one is its nearest neighbour is chance.
    cat = scene.objects["cat"]
    left, right = cat[:, :190], cat[:, 110:]
    fl, fr = detect(left), detect(right)
    # keypoints of the middle found in both views at the same place (and orientation)
    d = np.linalg.norm((fl.xy - [110, 0])[:, None, :] - fr.xy[None], axis=2)
    da = np.abs((fl.angle[:, None] - fr.angle[None] + 180) % 360 - 180)
    pairs = [(i, int(np.argmin(d[i]))) for i in range(len(fl)) if d[i].min() < 0.3]
    pairs = [(i, j) for i, j in pairs if da[i, j] < 3 and 0.02 < fl.xy[i, 0] - 110]
    assert len(pairs) >= 12
    pairs = pairs[:12]
    # The scene holds the 12 keypoints, half of them with the left view's descriptor and half
    # with the right view's: 6 nearest neighbours in each view, 12 correspondences in each.
    idx_l = np.array([i for i, _ in pairs])
    idx_r = np.array([j for _, j in pairs])
    h = _similarity(0.9, 5, 300, 200)
    query = _placed(fl, idx_l, h)
    desc = query.descriptors.copy()
    desc[1::2] = fr.descriptors[idx_r[1::2]]
    query = Features(query.xy, query.size, query.angle, query.response, query.octave, desc)
    query = _concat(scene.background_features, query)
    with ObjectDatabase.open(tmp_path / "two-views.db", create=True) as db:
        db.add_object("cat", [left, right])
        db.add_object("coffee", [scene.objects["coffee"]])
        result = db.label(query)
        views = result.matched[-12:]
    assert (views >= 0).all()
    assert [d.label for d in result.detections] == ["cat"]
    assert result.detections[0].score >= 10  # more than either view's 6 nearest neighbours


def test_second_neighbour_comes_from_another_object(tmp_path: Path, scene: Scene) -> None:
    cat = scene.objects["cat"]
    # Two views of one object hold identical descriptors: the ratio test must not compare a
    # match with its own copy, or no keypoint of a multi-view object would ever pass.
    with ObjectDatabase.open(tmp_path / "one.db", create=True) as db:
        db.add_object("cat", [cat, cat])
        db.add_object("coffee", [scene.objects["coffee"]])
        found = [d.label for d in db.label(scene.features).detections]
    assert "cat" in found
    # The same picture under two labels is ambiguous: the ratio test rejects every match.
    with ObjectDatabase.open(tmp_path / "two.db", create=True) as db:
        db.add_object("cat", [cat])
        db.add_object("kitten", [cat])
        result = db.label(scene.features)
    assert result.detections == ()
    assert (result.matched == -1).all()


def test_empty_query(built_db: Path) -> None:
    with ObjectDatabase.open(built_db, readonly=True) as db:
        result = db.label(Features.empty())
    assert result.detections == () and result.labels.shape == (0,)


# --------------------------------------------------------------------------------------------
# Indexes
# --------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def real_descriptors() -> NDArray[np.uint8]:
    parts = [
        detect(to_gray(getattr(data, n)())).descriptors
        for n in ("camera", "coffee", "astronaut", "grass")
    ]
    return np.vstack(parts)


def test_exact_index_matches_brute_force(real_descriptors: NDArray[np.uint8]) -> None:
    base, query = real_descriptors[:3000], real_descriptors[3000:3200]
    d, _ = ExactIndex(base, block=1000).search(query, 3)
    q, b = query.astype(np.float64), base.astype(np.float64)  # exact: integers below 2**53
    full = (q**2).sum(1)[:, None] + (b**2).sum(1)[None, :] - 2 * q @ b.T
    order = np.argsort(full, axis=1, kind="stable")[:, :3]
    np.testing.assert_allclose(d, np.take_along_axis(full, order, axis=1), rtol=1e-5, atol=1)
    np.testing.assert_array_equal(d[:, 0], full.min(axis=1))


def test_ivf_recall_against_exact(real_descriptors: NDArray[np.uint8]) -> None:
    n = len(real_descriptors)
    rng = np.random.default_rng(0)
    qsel = rng.choice(n, 300, replace=False)
    base = np.delete(real_descriptors, qsel, axis=0)
    query = real_descriptors[qsel]
    _, exact = ExactIndex(base).search(query, 2)
    ivf = IVFIndex(base, nlist=64, nprobe=8, seed=0)
    _, approx = ivf.search(query, 2)
    recall1 = np.mean(approx[:, 0] == exact[:, 0])
    recall2 = np.mean([len(set(a) & set(b)) / 2 for a, b in zip(approx, exact, strict=True)])
    assert recall1 >= 0.9 and recall2 >= 0.85
    # Two threads scanning the cells give the same answer.
    ivf.threads = 2
    np.testing.assert_array_equal(ivf.search(query, 2)[1], approx)
    # More cells (another selection path) find at least as many.
    ivf.nprobe = 16
    assert np.mean(ivf.search(query, 2)[1][:, 0] == exact[:, 0]) >= recall1
    # Probing every cell is exact.
    ivf.nprobe = ivf.nlist
    _, every = ivf.search(query, 2)
    np.testing.assert_array_equal(every[:, 0], exact[:, 0])
    assert ivf.nbytes - ivf.centroids.nbytes < base.nbytes * 1.1


def test_build_index_kinds(real_descriptors: NDArray[np.uint8]) -> None:
    small = real_descriptors[:500]
    assert isinstance(build_index(small), ExactIndex)
    assert isinstance(build_index(small, "ivf", nlist=8), IVFIndex)
    with pytest.raises(ValueError, match="unknown index kind"):
        build_index(small, "kdtree")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"\(N, 128\)"):
        build_index(small[:, :64])


def test_faiss_index_agrees_when_installed(real_descriptors: NDArray[np.uint8]) -> None:
    pytest.importorskip("faiss")
    base, query = real_descriptors[300:], real_descriptors[:300]
    _, exact = ExactIndex(base).search(query, 1)
    _, got = build_index(base, "faiss", nlist=64, nprobe=64).search(query, 1)
    assert np.mean(got[:, 0] == exact[:, 0]) > 0.99


def test_faiss_finds_the_neighbours_of_the_numpy_index(real_descriptors: NDArray[np.uint8]) -> None:
    """The same quantiser and cells: the same squared distances (integers, exact in float32)
    and the same neighbours wherever the two nearest are not tied."""
    pytest.importorskip("faiss")
    base, query = real_descriptors[300:], real_descriptors[:300]
    ivf = build_index(base, "ivf", nlist=64, nprobe=4)
    assert isinstance(ivf, IVFIndex)
    fast = build_index(
        base, "faiss", nlist=64, nprobe=4, centroids=ivf.centroids, cells=ivf.cells()
    )
    assert isinstance(fast, FaissIndex)
    d_ivf, i_ivf = ivf.search(query, 2)
    d_fast, i_fast = fast.search(query, 2)
    np.testing.assert_array_equal(d_fast, d_ivf)
    clear = d_ivf[:, 0] < d_ivf[:, 1]
    assert clear.mean() > 0.9
    np.testing.assert_array_equal(i_fast[clear, 0], i_ivf[clear, 0])


def test_faiss_lists_hold_what_one_add_makes(
    real_descriptors: NDArray[np.uint8], monkeypatch: pytest.MonkeyPatch
) -> None:
    """The inverted lists filled in small blocks, each list sized once beforehand, hold the
    codes and ids, list by list and in the same order, that one ``add_core`` of all the
    descriptors gives; the searches agree to the bit."""
    faiss = pytest.importorskip("faiss")
    from scenespeak.perception.recognition import ivf

    base, query = real_descriptors[300:], real_descriptors[:300]
    monkeypatch.setattr(ivf, "_FILL_ROWS", 1000)
    assert len(base) > 3 * 1000
    chunks = [base[s : s + 700] for s in range(0, len(base), 700)]
    fast = FaissIndex.from_chunks(lambda: iter(chunks), len(base), nlist=64, nprobe=4)
    assert fast.ntotal == len(base) == fast._index.ntotal
    ref = faiss.IndexIVFScalarQuantizer(
        fast._quantizer, 128, 64, faiss.ScalarQuantizer.QT_8bit_direct, faiss.METRIC_L2
    )
    ref.by_residual = False
    ref.train(np.zeros((1, 128), np.float32))
    x = base.astype(np.float32)
    cells = np.ascontiguousarray(fast.cells(), np.int64)
    ref.add_core(len(x), faiss.swig_ptr(x), None, faiss.swig_ptr(cells))
    mine, theirs = fast._index.invlists, ref.invlists
    for cell in range(64):
        n = theirs.list_size(cell)
        assert mine.list_size(cell) == n
        if n == 0:
            continue
        codes = [faiss.rev_swig_ptr(lists.get_codes(cell), n * 128) for lists in (mine, theirs)]
        ids = [faiss.rev_swig_ptr(lists.get_ids(cell), n) for lists in (mine, theirs)]
        np.testing.assert_array_equal(codes[0], codes[1])
        np.testing.assert_array_equal(ids[0], ids[1])
    ref.nprobe = 4
    d_ref, i_ref = ref.search(query.astype(np.float32), 16)
    d_fast, i_fast = fast.search(query, 16)
    np.testing.assert_array_equal(i_fast, i_ref)
    np.testing.assert_array_equal(d_fast, np.where(i_ref < 0, np.inf, d_ref))


@pytest.mark.parametrize("kind", ["ivf", "faiss"])
def test_labelling_with_an_inverted_file(built_db: Path, scene: Scene, kind: str) -> None:
    if kind == "faiss":
        pytest.importorskip("faiss")
    with ObjectDatabase.open(built_db, readonly=True, index=kind) as db:  # type: ignore[arg-type]
        result = db.label(scene.features)
    assert {d.label for d in result.detections} == {"astronaut", "coffee", "cat"}


@pytest.mark.parametrize("kind", ["ivf", "faiss"])
def test_quantiser_is_cached_in_the_file(db_copy: Path, scene: Scene, kind: str) -> None:
    if kind == "faiss":
        pytest.importorskip("faiss")
    cls = IVFIndex if kind == "ivf" else FaissIndex
    with ObjectDatabase.open(db_copy, index=kind) as db:  # type: ignore[arg-type]
        gen = db.generation()
        db.load(seed=0)
        first = db.index
        assert isinstance(first, cls)
        assert db.generation() == gen  # caching is not a change of the objects
    with ObjectDatabase.open(db_copy, readonly=True, index=kind) as db:  # type: ignore[arg-type]
        db.load(seed=1)  # a different seed would train other centroids: the cache is used
        second = db.index
        assert isinstance(second, cls)
        np.testing.assert_array_equal(second.centroids, first.centroids)
        np.testing.assert_array_equal(second.cells(), first.cells())
    with ObjectDatabase.open(db_copy, index=kind) as db:  # type: ignore[arg-type]
        db.add_object("rocket 2", [scene.objects["rocket"][::-1]])
        db.load(seed=1)  # the objects changed: the cache is stale and not used
        third = db.index
        assert isinstance(third, cls)
        assert third.ntotal > first.ntotal
        assert not np.array_equal(third.centroids[: first.nlist], first.centroids)


_KILL_SCRIPT = """
import os, signal, sys
import cv2
from scenespeak.perception.recognition import ObjectDatabase

def die(stage, done, total):
    if stage == "store" and done == 2:
        os.kill(os.getpid(), signal.SIGKILL)

images = [cv2.imread(p, cv2.IMREAD_GRAYSCALE) for p in sys.argv[2:]]
with ObjectDatabase.open(sys.argv[1]) as db:
    db.add_object("mug", images, progress=die)
"""


@pytest.mark.skipif(not hasattr(__import__("signal"), "SIGKILL"), reason="needs SIGKILL")
def test_killed_process_leaves_database_as_it_was(
    db_copy: Path, tmp_path: Path, scene: Scene
) -> None:
    import subprocess
    import sys

    files = []
    for name in ("cat", "coffee", "rocket"):
        f = tmp_path / f"{name}.png"
        cv2.imwrite(str(f), scene.objects[name])
        files.append(str(f))
    rows = _rows(db_copy)
    proc = subprocess.run(
        [sys.executable, "-c", _KILL_SCRIPT, str(db_copy), *files], capture_output=True
    )
    assert proc.returncode == -9, proc.stderr.decode()
    # SQLite rolls a hot journal back on the next open: the rows are those from before.
    with ObjectDatabase.open(db_copy) as db:
        assert "mug" not in db
    assert _rows(db_copy) == rows


@given(
    n=st.integers(1, 60),
    nq=st.integers(1, 12),
    k=st.integers(1, 5),
    seed=st.integers(0, 2**16),
)
def test_exact_index_property(n: int, nq: int, k: int, seed: int) -> None:
    rng = np.random.default_rng(seed)
    base = rng.integers(0, 256, (n, 128), dtype=np.uint8)
    query = rng.integers(0, 256, (nq, 128), dtype=np.uint8)
    d, i = ExactIndex(base, block=7).search(query, k)
    full = ((query[:, None].astype(np.int64) - base[None].astype(np.int64)) ** 2).sum(-1)
    want = np.sort(full, axis=1)[:, :k]
    got = d[:, : min(k, n)]
    np.testing.assert_allclose(got, want, rtol=1e-6)
    np.testing.assert_allclose(np.take_along_axis(full, i[:, : min(k, n)], axis=1), want, rtol=1e-6)
    assert np.all(np.isinf(d[:, n:])) and np.all(i[:, n:] == -1)


def test_faiss_index_without_faiss_is_a_clear_error(
    built_db: Path, scene: Scene, monkeypatch: pytest.MonkeyPatch
) -> None:
    # As on a machine without faiss-cpu, whether or not this one has it.
    from scenespeak.perception.recognition import loading

    monkeypatch.setattr(loading, "_have_faiss", lambda: False)
    with ObjectDatabase.open(built_db, readonly=True, index="faiss") as db:
        with pytest.raises(DatabaseError, match="needs the faiss-cpu package"):
            db.label(scene.features)
