"""Colour and shape as a second cue (recognition/colour.py) and schema version 2."""

from __future__ import annotations

import dataclasses
import hashlib
import sqlite3
from pathlib import Path

import numpy as np
import pytest
from skimage import data

from scenespeak.perception.objects import ObjectOptions, SceneObject, make_object
from scenespeak.perception.recognition import ObjectDatabase
from scenespeak.perception.recognition.colour import (
    ColourModel,
    colour_signature,
    name_by_colour,
    name_unknown_objects,
    view_colour,
)

ORANGE, GREEN, RED, FLOOR = (230, 120, 30), (40, 170, 60), (200, 25, 25), (150, 146, 136)
K = np.array([[500.0, 0.0, 160.0], [0.0, 500.0, 120.0], [0.0, 0.0, 1.0]])


def _pixels(*colours: tuple[int, int, int], n: int = 50) -> np.ndarray:
    return np.repeat(np.array(colours, np.uint8), n, axis=0)


def _model(*colours: tuple[int, int, int], aspect: float = 1.3) -> ColourModel:
    sig = colour_signature(_pixels(*colours))
    return ColourModel(sig[None].astype(np.float32), np.array([aspect], np.float32))


MODELS = {
    "cup": _model(ORANGE, GREEN, (245, 245, 245)),  # a two-colour logo on white
    "novel": _model(RED),  # one colour
    "jar": _model((60, 60, 62), (90, 90, 90)),  # greys
}


def test_the_colourful_object_is_named_and_grey_or_one_colour_ones_never() -> None:
    assert name_by_colour(colour_signature(_pixels(ORANGE, GREEN)), 1.2, MODELS)[0] == "cup"  # type: ignore[index]
    # a plain red distractor is not the one-colour "novel", however close its colour
    assert name_by_colour(colour_signature(_pixels(RED)), 1.3, MODELS) is None
    # a grey object (or a streak of floor) is never named: greys are what floors look like
    assert name_by_colour(colour_signature(_pixels((62, 61, 60), FLOOR)), 1.3, MODELS) is None


def test_proportions_and_a_rival_of_the_same_colours_keep_it_unknown() -> None:
    sig = colour_signature(_pixels(ORANGE, GREEN))
    assert name_by_colour(sig, 1.2, MODELS)[0] == "cup"  # type: ignore[index]
    assert name_by_colour(sig, 3.0, MODELS) is None  # a tall thing of the cup's colours
    assert name_by_colour(sig, 0.5, MODELS) is None  # a flat one
    # two learnt objects of the same colours: colour cannot tell them apart, whatever the shape
    rival = {**MODELS, "bottle": _model(ORANGE, GREEN, aspect=3.4)}
    assert name_by_colour(sig, 1.2, rival) is None
    assert name_by_colour(sig, 3.0, rival) is None


def _patch_object(image: np.ndarray, box: tuple[int, int, int, int], z: float) -> SceneObject:
    """An unknown object whose points are the pixels of ``box`` (x0, y0, x1, y1) at depth z."""
    x0, y0, x1, y1 = box
    u, v = np.meshgrid(np.arange(x0, x1, 2.0), np.arange(y0, y1, 2.0))
    uv1 = np.column_stack([u.ravel(), v.ravel(), np.ones(u.size)])
    xyz = (uv1 @ np.linalg.inv(K).T) * z
    xyz[:, 2] += np.linspace(0, 0.02, len(xyz))  # a little depth, as a real surface has
    obj = make_object("unknown", xyz, up=np.array([0.0, -1.0, 0.0]), source="segment")
    assert isinstance(obj, SceneObject)
    return obj


def test_unknown_objects_in_an_image_are_named_and_renumbered() -> None:
    image = np.zeros((240, 320, 3), np.uint8)
    image[:] = FLOOR
    image[60:130, 40:60] = ORANGE  # a cup-like patch, 70 x 40 px: aspect 1.75 ... 1.3
    image[60:130, 60:80] = GREEN
    image[100:110, 80:160] = FLOOR  # the dense map's streak over the floor beside it
    image[150:200, 200:240] = (90, 90, 90)  # a grey thing
    cup = _patch_object(image, (40, 70, 85, 130), 1.0)
    streaked = _patch_object(image, (40, 70, 160, 130), 1.0)
    grey = _patch_object(image, (200, 150, 240, 200), 1.2)
    named = name_unknown_objects(
        [
            dataclass_replace(grey, "unknown object 1"),
            dataclass_replace(cup, "unknown object 2"),
        ],
        image,
        K,
        MODELS,
    )
    assert [(o.label, o.name) for o in named] == [
        ("unknown object 1", "unknown object 1"),
        ("cup", "cup"),
    ]
    assert "named by colour" in named[1].notes[-1]
    assert named[1].confidence < 1.0
    # the floor the dense map smeared into the segment adds grey, not hue: still the cup; made
    # again of the points in the box round its colours, it loses the streak
    streak = [dataclass_replace(streaked, "unknown object 1")]
    (kept,) = name_unknown_objects(streak, image, K, MODELS)
    (trimmed,) = name_unknown_objects(
        streak, image, K, MODELS, remake=(np.array([0.0, -1.0, 0.0]), ObjectOptions(radius=None))
    )
    assert kept.label == trimmed.label == "cup"
    u = (kept.xyz @ K.T)[:, 0] / kept.xyz[:, 2]
    u_trimmed = (trimmed.xyz @ K.T)[:, 0] / trimmed.xyz[:, 2]
    assert u.max() > 150 and u_trimmed.max() < 90 and u_trimmed.min() < 45
    # a gray image names nothing; neither do no models
    gray = image.mean(axis=2).astype(np.uint8)
    assert (
        name_unknown_objects([dataclass_replace(cup, "unknown object 1")], gray, K, MODELS)[0].label
        == "unknown object 1"
    )
    assert (
        name_unknown_objects([dataclass_replace(cup, "unknown object 1")], image, K, {})[0].label
        == "unknown object 1"
    )


def dataclass_replace(obj: SceneObject, label: str) -> SceneObject:
    import dataclasses

    return dataclasses.replace(obj, label=label, name=label)


def _sha(path: Path) -> str:
    return hashlib.sha1(path.read_bytes()).hexdigest()


def test_colour_signatures_stored_with_masked_views_and_version_1_files_upgraded(
    tmp_path: Path,
) -> None:
    img = data.astronaut()
    mask = np.zeros(img.shape[:2], bool)
    mask[50:400, 100:300] = True
    path = tmp_path / "objects.db"
    with ObjectDatabase.create(path) as db:
        db.add_object("astronaut", [img], masks=[mask])
        db.add_object("cat", [data.chelsea()])  # no mask: no colour
        models = db.colour_models()
        assert list(models) == ["astronaut"]
        sig, aspect = view_colour(img, mask)  # type: ignore[misc]
        np.testing.assert_array_equal(models["astronaut"].signatures[0], sig)
        assert models["astronaut"].aspects[0] == pytest.approx(aspect)
        db.add_object("astronaut", [img, img], masks=[mask, mask], replace=True)
        assert len(db.colour_models()["astronaut"].signatures) == 2
        db.remove("astronaut")
        assert db.colour_models() == {}
        db.add_object("astronaut", [img], masks=[mask])
    with sqlite3.connect(path) as conn:  # as a session-4 scenespeak wrote it: version 1
        assert conn.execute("SELECT COUNT(*) FROM view_colours").fetchone() == (1,)
        conn.execute("DROP TABLE view_colours")
        conn.execute("UPDATE meta SET value = '1' WHERE key = 'schema_version'")
    conn.close()
    sha = _sha(path)
    with ObjectDatabase.open(path, readonly=True) as db:  # read as it is, not written
        assert db.labels() == ["astronaut", "cat"]
        assert db.colour_models() == {}
    assert _sha(path) == sha
    with ObjectDatabase.open(path) as db:  # opened for writing: upgraded
        assert db.colour_models() == {}  # the old views have no signature
        db.add_object("astronaut", [img], masks=[mask], replace=True)
        assert list(db.colour_models()) == ["astronaut"]
    with sqlite3.connect(path) as conn:
        version = conn.execute("SELECT value FROM meta WHERE key = 'schema_version'").fetchone()
    conn.close()
    assert version == ("3",)


@pytest.mark.parametrize(("green_columns", "named"), [(20, True), (2, False)])
def test_another_instance_by_colour_must_look_like_the_one_its_keypoints_verified(
    green_columns: int, named: bool
) -> None:
    """The cup is verified by its keypoints in the scene (no cue's note). An unknown object
    whose colours fit the cup's training views (orange and green, half and half) is a second
    cup only if it also looks like that cup: beside a verified cup that is all orange but
    for a sliver of green (Hellinger 0.39 from it, > INSTANCE_DISTANCE 0.35) it stays unknown, with
    the reason; beside one of the same colours it is "cup 2"."""
    image = np.zeros((240, 320, 3), np.uint8)
    image[:] = FLOOR
    image[60:130, 40:60] = ORANGE  # the unknown object: orange and green, 70 x 40 px
    image[60:130, 60:80] = GREEN
    image[60:130, 200 : 240 - green_columns] = ORANGE  # the verified cup
    image[60:130, 240 - green_columns : 240] = GREEN
    unknown = dataclass_replace(_patch_object(image, (40, 60, 80, 130), 1.0), "unknown object 1")
    cup = _patch_object(image, (200, 60, 240, 130), 1.0)
    cup = dataclasses.replace(cup, label="cup", name="cup")
    out = name_unknown_objects([cup, unknown], image, K, MODELS)
    assert (out[1].label == "cup") is named
    if named:
        assert out[1].name == "cup 2"
    else:
        assert "verified by its keypoints in this scene" in out[1].notes[-1]
    # with no cup verified in the scene (or one named by colour alone) the cue names it
    alone = name_unknown_objects([unknown], image, K, MODELS)
    assert alone[0].label == "cup"
    by_colour = dataclasses.replace(cup, notes=("named by colour and shape (distance 0.1)",))
    assert name_unknown_objects([by_colour, unknown], image, K, MODELS)[1].label == "cup"


def test_colours_only_near_the_views_name_nothing() -> None:
    """Orange and green 85 / 15 against the cup's half and half: Hellinger 0.27, as near as the
    never-learnt books named "can" on the default set's leave-half-out split (0.23-0.27; every
    right colour naming of the session-9 runs 0.21 or nearer): not named with ``max_distance``
    0.22, named with the old 0.3."""
    from scenespeak.perception.recognition.colour import ColourOptions

    sig = colour_signature(np.r_[_pixels(ORANGE, n=85), _pixels(GREEN, n=15)])
    assert name_by_colour(sig, 1.2, MODELS) is None
    old = name_by_colour(sig, 1.2, MODELS, ColourOptions(max_distance=0.3))
    assert old is not None and old[0] == "cup" and 0.22 < old[1] < 0.3
    near = colour_signature(np.r_[_pixels(ORANGE, n=65), _pixels(GREEN, n=35)])
    assert name_by_colour(near, 1.2, MODELS)[0] == "cup"  # type: ignore[index]
