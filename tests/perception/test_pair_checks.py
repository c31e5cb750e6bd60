"""plausibility.check_pair_order names what is wrong with a pair: an image that is not the other
half (noise, the left image twice) or a calibration that does not fit (wild R)."""

from __future__ import annotations

import numpy as np
import pytest

from scenespeak.errors import CalibrationError, ImageError
from scenespeak.perception.calibration import StereoRig, rig_from_short
from scenespeak.perception.plausibility import check_pair_order
from scenespeak.tools.fuzz.corpus import BASELINE, HFOV, H, W, card_pair


@pytest.fixture(scope="module")
def pair() -> tuple[np.ndarray, np.ndarray]:  # type: ignore[type-arg]
    return card_pair()


def _rig(**changes: object) -> StereoRig:
    rig = rig_from_short(BASELINE, HFOV, (W, H), source="calib.json")
    if not changes:
        return rig
    from dataclasses import replace

    return replace(rig, **changes)  # type: ignore[arg-type]


def test_a_good_pair_passes(pair: tuple[np.ndarray, np.ndarray]) -> None:  # type: ignore[type-arg]
    assert check_pair_order(*pair, _rig(), names=("l.png", "r.png")) < 0.5


def test_noise_as_one_image_names_both_images(pair: tuple[np.ndarray, np.ndarray]) -> None:  # type: ignore[type-arg]
    noise = np.random.default_rng(1).integers(0, 255, (H, W), dtype=np.uint8)
    with pytest.raises(ImageError, match=r"l\.png, noise\.png: the two images do not show"):
        check_pair_order(pair[0], noise, _rig(), names=("l.png", "noise.png"))


def test_the_left_image_twice(pair: tuple[np.ndarray, np.ndarray]) -> None:  # type: ignore[type-arg]
    with pytest.raises(ImageError, match="shows the same view as"):
        check_pair_order(pair[0], pair[0].copy(), _rig(), names=("l.png", "l2.png"))


def test_a_calibration_that_does_not_fit_is_named(pair: tuple[np.ndarray, np.ndarray]) -> None:  # type: ignore[type-arg]
    import cv2

    R, _ = cv2.Rodrigues(np.array([0.3, 0.0, 0.0]))  # 17 deg about x: rows no longer agree
    with pytest.raises(CalibrationError, match=r"calib\.json: .* same rectified row"):
        check_pair_order(*pair, _rig(R=R), names=("l.png", "r.png"))


def test_images_of_another_size_are_left_to_the_stereo_stage(
    pair: tuple[np.ndarray, np.ndarray],  # type: ignore[type-arg]
) -> None:
    assert check_pair_order(pair[0][:100], pair[1], _rig()) == 0.0
