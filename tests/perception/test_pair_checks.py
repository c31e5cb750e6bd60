"""plausibility.check_pair_order names what is wrong with a pair: an image that is not the other
half (noise, the left image twice), swapped images, or a calibration that does not fit (wild R).

Every case runs twice: with the check's own SIFT, and with the stereo stage's features given
(``features=``, as ``scenespeak points`` calls it)."""

from __future__ import annotations

import numpy as np
import pytest

from scenespeak.errors import CalibrationError, ImageError
from scenespeak.perception.calibration import StereoRig, rig_from_short
from scenespeak.perception.features import detect, to_gray
from scenespeak.perception.plausibility import CHECK_FEATURES, _strongest
from scenespeak.perception.plausibility import check_pair_order as _check_pair_order
from scenespeak.tools.fuzz.corpus import BASELINE, HFOV, H, W, card_pair


@pytest.fixture(scope="module")
def pair() -> tuple[np.ndarray, np.ndarray]:  # type: ignore[type-arg]
    return card_pair()


@pytest.fixture(params=["own SIFT", "stage's features"], autouse=True)
def given(request: pytest.FixtureRequest) -> bool:
    return bool(request.param == "stage's features")


_GIVEN: list[bool] = []


@pytest.fixture(autouse=True)
def _mode(given: bool) -> object:
    _GIVEN.append(given)
    yield
    _GIVEN.pop()


def check_pair_order(left: np.ndarray, right: np.ndarray, rig: StereoRig, **kw: object) -> float:  # type: ignore[type-arg]
    """The check as called in this case's mode (features detected as the stereo stage does)."""
    if _GIVEN[-1]:
        kw["features"] = tuple(detect(to_gray(x), precise_upscale=False) for x in (left, right))
    return _check_pair_order(left, right, rig, **kw)  # type: ignore[arg-type]


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


def test_swapped_images_are_named(pair: tuple[np.ndarray, np.ndarray]) -> None:  # type: ignore[type-arg]
    with pytest.raises(CalibrationError, match=r"calib\.json: .*negative disparity.*look swapped"):
        check_pair_order(pair[1], pair[0], _rig(), names=("r.png", "l.png"))


def test_the_strongest_features_are_kept_with_ties() -> None:
    f = detect(to_gray(np.random.default_rng(2).integers(0, 255, (240, 320), dtype=np.uint8)))
    assert 100 < len(f) < CHECK_FEATURES
    n = len(f) // 2
    kept = _strongest(f, n)
    cut = np.sort(f.response)[::-1][n - 1]
    assert len(kept) == int((f.response >= cut).sum()) >= n
    assert np.array_equal(kept.xy, f.xy[f.response >= cut])  # their order
    assert _strongest(f, len(f)) is f
