"""The pair-order check's ratio-test matcher (``plausibility._ratio_matches``, NumPy) gives
OpenCV's ``BFMatcher(NORM_L2).knnMatch(k=2)`` pairs bit for bit: on SIFT features of a rendered
pair, and on synthetic descriptors made to be hard (whole numbers at 0 and 255, exact
duplicates, ties for the best and the second best, ratios exactly at the threshold, one or
two right descriptors, more rows than one block)."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from scenespeak.perception.features import detect, to_gray
from scenespeak.perception.plausibility import _RATIO_BLOCK, _ratio_matches
from scenespeak.tools.fuzz.corpus import card_pair


def _opencv(left: np.ndarray, right: np.ndarray, ratio: float) -> list[tuple[int, int]]:  # type: ignore[type-arg]
    """The check's matcher before issue 16 session 8 (OpenCV's brute force)."""
    knn = cv2.BFMatcher(cv2.NORM_L2).knnMatch(
        left.astype(np.float32), right.astype(np.float32), k=2
    )
    return [
        (m[0].queryIdx, m[0].trainIdx)
        for m in knn
        if len(m) == 2 and m[0].distance < ratio * m[1].distance
    ]


def _numpy(left: np.ndarray, right: np.ndarray, ratio: float) -> list[tuple[int, int]]:  # type: ignore[type-arg]
    li, ri = _ratio_matches(left, right, ratio)
    assert li.dtype == ri.dtype == np.intp
    return list(zip(li.tolist(), ri.tolist(), strict=True))


def test_sift_features_of_a_pair() -> None:
    left, right = (detect(to_gray(x), precise_upscale=False) for x in card_pair())
    assert len(left) > _RATIO_BLOCK and len(right) > 100
    for ratio in (0.7, 0.8, 1.0):
        want = _opencv(left.descriptors, right.descriptors, ratio)
        assert len(want) > 50
        assert _numpy(left.descriptors, right.descriptors, ratio) == want


@pytest.mark.parametrize("seed", range(6))
def test_hard_synthetic_descriptors(seed: int) -> None:
    rng = np.random.default_rng(seed)
    nl, nr = int(rng.integers(1, 3 * _RATIO_BLOCK)), int(rng.integers(2, 700))
    # few distinct values: many equal distances (ties for the best and the second best)
    levels = np.array([0, 1, 2, 127, 254, 255], np.uint8)
    right = levels[rng.integers(0, len(levels), (nr, 128))]
    right[: nr // 4] = rng.integers(0, 256, (nr // 4, 128))
    if nr >= 4:
        right[1] = right[0]  # an exact duplicate: a tie for the best of what is near it
    left = right[rng.integers(0, nr, nl)].copy()  # near copies of right descriptors
    noise = rng.integers(-3, 4, left.shape) * (rng.random(left.shape) < 0.05)
    left = np.clip(left.astype(int) + noise, 0, 255).astype(np.uint8)
    left[: nl // 5] = rng.integers(0, 256, (nl // 5, 128))
    left[0] = 255
    for ratio in (0.7, 0.5, 1.0):
        assert _numpy(left, right, ratio) == _opencv(left, right, ratio)


def test_a_ratio_exactly_at_the_threshold_is_refused() -> None:
    # distances 7 and 10: 7 < 0.7 * 10 is false in doubles as in OpenCV's float comparison
    right = np.zeros((2, 128), np.uint8)
    right[0, 0], right[1, 0] = 7, 10
    left = np.zeros((1, 128), np.uint8)
    assert _numpy(left, right, 0.7) == _opencv(left, right, 0.7)
    assert _numpy(left, right, 0.71) == _opencv(left, right, 0.71) == [(0, 0)]


def test_fewer_than_two_right_descriptors_match_nothing() -> None:
    d = np.arange(256, dtype=np.uint8).reshape(2, 128)
    assert _numpy(d, d[:1], 0.7) == _opencv(d, d[:1], 0.7) == []
    assert _numpy(d[:0], d, 0.7) == []


@pytest.mark.parametrize("n", [1, 2, 3, 4, 7, 10, 101, 1000])
def test_median_is_numpys(n: int) -> None:
    from scenespeak.perception.plausibility import _median

    rng = np.random.default_rng(n)
    for x in (
        rng.normal(0, 1e3, n),
        rng.integers(0, 3, n).astype(np.float64),  # ties
        np.r_[rng.normal(0, 1, n - 1), np.inf],
        np.r_[rng.normal(0, 1, n - 1), -np.inf],
        np.r_[rng.normal(0, 1, n - 1), np.nan],
        np.full(n, 1e308),  # the two middle ones' sum overflows, as in np.mean
    ):
        with np.errstate(over="ignore", invalid="ignore"):
            want = float(np.median(x))
            got = _median(x)
        assert got == want or (np.isnan(got) and np.isnan(want)), (x, got, want)
        assert np.float64(got).tobytes() == np.float64(want).tobytes() or np.isnan(want)
