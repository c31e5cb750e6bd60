"""Issue 10, session 10: a grey name whose lead is short, corroborated by the keypoints' votes
(recognition/grey.py ``corroborated``, known_evidence ``KeypointEvidence.votes_in``)."""

from __future__ import annotations

import dataclasses

import numpy as np

from scenespeak.perception.known_evidence import KeypointEvidence
from scenespeak.perception.objects import SceneObject, make_object
from scenespeak.perception.recognition.colour import ColourModel, _object_pixels, colour_signature
from scenespeak.perception.recognition.colour import name_unknown_objects as name_unknown
from scenespeak.perception.recognition.grey import (
    GreyOptions,
    corroborated,
    grey_pixels,
    hellinger,
    view_grey,
)

FLOOR = 145
K = np.array([[500.0, 0.0, 160.0], [0.0, 500.0, 120.0], [0.0, 0.0, 1.0]])
UP = np.array([0.0, -1.0, 0.0])


def _stars(h: int, w: int, every: int, seed: int) -> np.ndarray:
    """Nearly black with a bright speck at one pixel in ``every`` (a star-field texture)."""
    rng = np.random.default_rng(seed)
    g = np.full((h, w), 9, np.uint8)
    n = h * w // every
    g[rng.integers(0, h, n), rng.integers(0, w, n)] = 200
    return g


def _model(gray: np.ndarray) -> ColourModel:
    mask = np.ones(gray.shape, bool)
    sig, _ = view_grey(gray, mask)
    colours = colour_signature(np.repeat(gray.reshape(-1, 1), 3, 1))
    one = np.ones(1, np.float32)
    return ColourModel(colours[None], one, sig[None], np.array([1.5], np.float32))


def _smooth(level: int) -> np.ndarray:
    rng = np.random.default_rng(level)
    return np.clip(level + rng.normal(0, 2, (60, 40)), 0, 255).astype(np.uint8)


def _models(rival_every: int) -> dict[str, ColourModel]:
    """A tin (specks at one pixel in 8) and a soup (one in ``rival_every``), both star fields
    like the segment's (one in 12), and two plain greys."""
    return {
        "tin": _model(_stars(60, 40, 8, seed=1)),
        "soup": _model(_stars(60, 40, rival_every, seed=2)),
        "jar": _model(_smooth(50)),
        "cube": _model(_smooth(85)),
    }


def _segment() -> tuple[np.ndarray, SceneObject]:
    gray = np.full((240, 320), FLOOR, np.uint8)
    gray[60:120, 100:140] = _stars(60, 40, 12, seed=9)
    u, v = np.meshgrid(np.arange(100, 140, 1.0), np.arange(60, 112, 1.0))
    uv1 = np.column_stack([u.ravel(), v.ravel(), np.ones(u.size)])
    xyz = uv1 @ np.linalg.inv(K).T
    xyz[:, 2] += np.linspace(0, 0.02, len(xyz))
    obj = make_object("unknown object 1", xyz, up=UP, source="segment")
    assert isinstance(obj, SceneObject)
    return np.repeat(gray[..., None], 3, axis=2), dataclasses.replace(obj, name="unknown object 1")


@dataclasses.dataclass(frozen=True)
class _Votes:
    """What the keypoints say (``colour.Keypoints``): no veto, these votes in any region."""

    votes: dict[str, int]

    def refuses(self, obj: SceneObject, label: str) -> str | None:
        return None

    def votes_in(self, obj: SceneObject) -> dict[str, int]:
        return self.votes


def _lead(image: np.ndarray, seg: SceneObject, models: dict[str, ColourModel]) -> float:
    """The grey cue's lead on ``seg``'s pixels: the second nearest label over the nearest."""
    _rgb, uv, _ = _object_pixels(seg, image, K)
    got = grey_pixels((uv.astype(np.intp), np.zeros(len(uv), bool)), image[..., 0], GreyOptions())
    assert got is not None
    d = sorted(float(hellinger(got[0], m.greys).min()) for m in models.values())  # type: ignore[arg-type]
    return d[1] / d[0]


def test_a_short_grey_lead_is_named_only_when_the_keypoints_vote_for_the_same_label() -> None:
    image, seg = _segment()
    models = _models(18)
    lead = _lead(image, seg, models)
    assert GreyOptions().weak_lead <= lead < GreyOptions().lead  # short, not hopeless
    # the grey levels alone: the tin leads the soup by too little to name it
    assert name_unknown([seg], image, K, models)[0].label == "unknown object 1"
    assert name_unknown([seg], image, K, models, veto=_Votes({}))[0].label.startswith("unknown")
    # 3 keypoints in its region voted for the tin, none for anything else: the tin
    (named,) = name_unknown([seg], image, K, models, veto=_Votes({"tin": 3}))
    assert named.label == "tin"
    assert "3 keypoints voted for it" in named.notes[-1]
    # one vote is no evidence; votes split with the soup, or for the soup, neither
    for votes in ({"tin": 1}, {"tin": 3, "soup": 2}, {"soup": 3}):
        (left,) = name_unknown([seg], image, K, models, veto=_Votes(votes))
        assert left.label == "unknown object 1", votes


def test_votes_do_not_make_up_for_grey_levels_that_tie() -> None:
    image, seg = _segment()
    models = _models(14)  # the soup's specks as near the segment's as the tin's
    assert _lead(image, seg, models) < GreyOptions().weak_lead
    (left,) = name_unknown([seg], image, K, models, veto=_Votes({"tin": 9}))
    assert left.label == "unknown object 1"


def test_corroboration_needs_the_lead_the_votes_and_their_lead() -> None:
    o = GreyOptions()
    d1 = 0.2
    d2 = o.weak_lead * d1 * 1.01
    assert corroborated("tin", d1, d2, {"tin": o.min_votes}, o)
    assert not corroborated("tin", d1, d2, None, o)
    assert not corroborated("tin", d1, d1 * 1.01, {"tin": 50}, o)
    assert not corroborated("tin", d1, d2, {"tin": o.min_votes - 1}, o)
    assert not corroborated("tin", d1, d2, {"tin": 4, "jar": 3}, o)


def test_the_votes_in_an_objects_region_are_counted_per_label() -> None:
    _, seg = _segment()
    xy = np.array([[110.0, 70.0], [120.0, 80.0], [130.0, 90.0], [10.0, 10.0], [115.0, 75.0]])
    ev = KeypointEvidence(K, (240, 320), xy, ["tin", "tin", "jar", "tin", None])
    assert ev.votes_in(seg) == {"tin": 2, "jar": 1}  # the 4th is outside the region
