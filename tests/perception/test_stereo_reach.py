"""The segmentation map's reach (perception/stereo/reach.py): a card nearer than every matched
keypoint gets its depth from a coarse look at the whole range, while the stereo stage's own map
(the one its points are checked against) keeps the keypoints' range."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from scenespeak.perception.calibration import rectify, rig_from_short
from scenespeak.perception.stereo import dense_disparity
from scenespeak.perception.stereo.reach import ReachOptions, widened

BACK, CARD = 20, 52  # disparities of the wall and of the card in front of it (pixels)
X0, X1, Y0, Y1 = 260, 380, 180, 300  # the card in the left image


def _texture(seed: int, shape: tuple[int, int]) -> np.ndarray:
    """Blurred noise: texture at every scale down to a quarter."""
    noise = np.random.default_rng(seed).uniform(0, 255, shape).astype(np.float32)
    return np.clip(cv2.GaussianBlur(noise, (0, 0), 4.0) * 6.0 - 640, 0, 255).astype(np.uint8)


def _pair() -> tuple[np.ndarray, np.ndarray]:
    """A textured wall at disparity 20 and a card (another texture) at disparity 52 in front
    of it: the right image is each layer shifted by its disparity, the card drawn last."""
    wall = _texture(1, (480, 760))
    card = _texture(2, (Y1 - Y0, X1 - X0))
    left = wall[:, 60:700].copy()
    right = wall[:, 60 + BACK : 700 + BACK].copy()
    left[Y0:Y1, X0:X1] = card
    right[Y0:Y1, X0 - CARD : X1 - CARD] = card
    return np.ascontiguousarray(left), np.ascontiguousarray(right)


def test_a_card_outside_the_keypoints_range_gets_its_depth() -> None:
    left, right = _pair()
    rect = rectify(rig_from_short(0.12, 60.0, (640, 480)))
    # the stage's map over the wall's range (as if every matched keypoint lay on the wall)
    fine = dense_disparity(
        left, right, rect, min_disparity=BACK - 8, num_disparities=32, roi=(100, 100, 540, 380)
    )
    inner = (slice(Y0 + 8, Y1 - 8), slice(X0 + 8, X1 - 8))
    card_fine = fine.disparity[inner]
    with np.errstate(invalid="ignore"):
        assert np.mean(np.abs(card_fine - CARD) < 1.0) < 0.05  # it cannot search 52
    wide = widened(left, right, fine)
    assert wide is not fine
    card = wide.disparity[inner]
    assert np.mean(np.abs(card - CARD) < 1.0) > 0.8
    wall = (slice(120, 170), slice(120, 240))
    ok = np.isfinite(fine.disparity[wall])
    # the wall keeps the stage's own values, and the stage's map is left as it was
    np.testing.assert_array_equal(wide.disparity[wall][ok], fine.disparity[wall][ok])
    assert fine.min_disparity == BACK - 8 and fine.num_disparities == 32
    assert wide.min_disparity <= CARD < wide.min_disparity + wide.num_disparities


@pytest.mark.parametrize("reach", [None, ReachOptions(min_pixels=10**9)])
def test_a_map_whose_range_covers_the_scene_is_left_alone(reach: ReachOptions | None) -> None:
    """Searched over both layers' range the map needs nothing more (the coarse look only);
    nor does the card when fewer pixels than ``min_pixels`` are missed."""
    left, right = _pair()
    rect = rectify(rig_from_short(0.12, 60.0, (640, 480)))
    full = dense_disparity(left, right, rect, min_disparity=8, num_disparities=64)
    assert widened(left, right, full, reach) is full
    if reach is not None:
        part = dense_disparity(left, right, rect, min_disparity=12, num_disparities=32)
        assert widened(left, right, part, reach) is part
