"""The keypoints' veto on names given by colour (perception/known_evidence.py): a region SIFT
sees well whose keypoints did not vote for the named object is another object."""

from __future__ import annotations

import dataclasses

import numpy as np

from scenespeak.perception.known_evidence import EvidenceOptions, KeypointEvidence
from scenespeak.perception.objects import SceneObject, make_object
from scenespeak.perception.recognition.colour import (
    ColourModel,
    colour_signature,
    name_unknown_objects,
)

ORANGE, GREEN, FLOOR = (230, 120, 30), (40, 170, 60), (150, 146, 136)
K = np.array([[500.0, 0.0, 160.0], [0.0, 500.0, 120.0], [0.0, 0.0, 1.0]])
SHAPE = (240, 320)


def _model(*colours: tuple[int, int, int]) -> ColourModel:
    sig = colour_signature(np.repeat(np.array(colours, np.uint8), 50, axis=0))
    return ColourModel(sig[None].astype(np.float32), np.array([1.3], np.float32))


def _cup_model() -> dict[str, ColourModel]:
    """A two-colour logo on white, and a one-colour object (never named by colour)."""
    return {"cup": _model(ORANGE, GREEN, (245, 245, 245)), "novel": _model((200, 25, 25))}


def _scene() -> tuple[np.ndarray, SceneObject]:
    """A cup-coloured patch (x 40-80, y 60-130) seen as an unknown object (x 40-85, y 70-130)
    at 1 m."""
    image = np.zeros((*SHAPE, 3), np.uint8)
    image[:] = FLOOR
    image[60:130, 40:60] = ORANGE
    image[60:130, 60:80] = GREEN
    u, v = np.meshgrid(np.arange(40, 85, 2.0), np.arange(70, 130, 2.0))
    xyz = np.column_stack([u.ravel(), v.ravel(), np.ones(u.size)]) @ np.linalg.inv(K).T
    xyz[:, 2] += np.linspace(0, 0.02, len(xyz))
    obj = make_object("unknown", xyz, up=np.array([0.0, -1.0, 0.0]), source="segment")
    assert isinstance(obj, SceneObject)
    return image, dataclasses.replace(obj, label="unknown object 1", name="unknown object 1")


def _evidence(n_inside: int, n_cup: int) -> KeypointEvidence:
    """``n_inside`` keypoints on the patch (``n_cup`` of them matched to the cup), 30 outside
    (all matched to the cup: they must not count)."""
    rng = np.random.default_rng(0)
    inside = np.c_[rng.uniform(42, 82, n_inside), rng.uniform(72, 126, n_inside)]
    outside = np.c_[rng.uniform(200, 300, 30), rng.uniform(20, 200, 30)]
    votes: list[str | None] = ["cup"] * n_cup + [None] * (n_inside - n_cup) + ["cup"] * 30
    return KeypointEvidence(K, SHAPE, np.r_[inside, outside], votes)


def test_a_textured_region_that_never_voted_for_the_cup_is_not_named_cup() -> None:
    image, obj = _scene()
    models = _cup_model()
    (plain,) = name_unknown_objects([obj], image, K, models)
    assert plain.label == "cup"  # colour alone names it
    (vetoed,) = name_unknown_objects([obj], image, K, models, veto=_evidence(60, 3).refuses)
    assert vetoed.label == "unknown object 1"
    assert vetoed.notes[-1].startswith("not named cup: 60 keypoints in its image region, 3 voted")
    # the cup's own texture gives some votes: named
    (voted,) = name_unknown_objects([obj], image, K, models, veto=_evidence(60, 8).refuses)
    assert voted.label == "cup"
    # few keypoints (SIFT-poor, far, small): the keypoints say nothing, colour decides
    (poor,) = name_unknown_objects([obj], image, K, models, veto=_evidence(25, 0).refuses)
    assert poor.label == "cup"


def test_the_thresholds_and_what_is_counted() -> None:
    _image, obj = _scene()
    ev = _evidence(40, 3)
    assert ev.refuses(obj, "cup") is not None  # 40 in, 3 for the cup: 7.5 % < 10 %
    assert ev.refuses(obj, "tea") is not None  # none for the tea
    assert _evidence(40, 4).refuses(obj, "cup") is None  # exactly 10 %
    assert _evidence(29, 0).refuses(obj, "cup") is None  # too few to say
    assert _evidence(30, 2).refuses(obj, "cup") is not None
    loose = dataclasses.replace(ev, options=EvidenceOptions(min_keypoints=30, min_share=0.05))
    assert loose.refuses(obj, "cup") is None
    ids = KeypointEvidence.from_matches(K, SHAPE, ev.keypoints_xy, np.r_[np.full(3, 7),
        np.full(37, -1), np.full(30, 7)], {7: "cup"})  # fmt: skip
    assert list(ids.votes) == list(ev.votes)
    assert ids.refuses(obj, "cup") == ev.refuses(obj, "cup")
