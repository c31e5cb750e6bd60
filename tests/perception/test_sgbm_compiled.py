"""The compiled 3-way SGBM (``perception/stereo/sgbm.py``) gives OpenCV's map bit for bit.

Random images, sizes, search ranges, block sizes and uniqueness ratios (hypothesis,
derandomised) and the real pairs (the stage's crops at 640×480, skipped without the data
folder) against ``cv2.StereoSGBM`` in ``MODE_SGBM_3WAY`` with the same parameters; then the
choice in ``dense.py`` (``SCENESPEAK_SGBM``) and the refusals.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from scenespeak.perception import calibration, stereo
from scenespeak.perception.features import to_gray
from scenespeak.perception.rectification import rectify
from scenespeak.perception.stage_options import StereoOptions
from scenespeak.perception.stereo import dense, sgbm

pytestmark = pytest.mark.skipif(not sgbm.available(), reason="numba is not installed")

LAYOUTS = (("view1.png", "view5.png"), ("imL.png", "imR.png"), ("im2.ppm", "im6.ppm"))


def _opencv(left: np.ndarray, right: np.ndarray, mn: int, nd: int, bs: int, u: int) -> np.ndarray:
    m = cv2.StereoSGBM_create(  # type: ignore[attr-defined]
        minDisparity=mn,
        numDisparities=nd,
        blockSize=bs,
        P1=8 * bs * bs,
        P2=32 * bs * bs,
        disp12MaxDiff=1,
        uniquenessRatio=u,
        speckleWindowSize=100,
        speckleRange=2,
        mode=cv2.STEREO_SGBM_MODE_SGBM_3WAY,
    )
    return np.asarray(m.compute(left, right))


def _params(mn: int, nd: int, bs: int, u: int) -> sgbm.SgbmParams:
    return sgbm.SgbmParams(mn, nd, bs, 8 * bs * bs, 32 * bs * bs, u, 1, 100, 2)


def _compiled(
    left: np.ndarray, right: np.ndarray, mn: int, nd: int, bs: int, u: int, **kw: int
) -> np.ndarray:
    return sgbm.sgbm3way(left, right, _params(mn, nd, bs, u), **kw)


def _pair(seed: int, h: int, w: int, shift: int, texture: int) -> tuple[np.ndarray, np.ndarray]:
    """A textured left image and a right one shifted by ``shift`` px, with noise: a pair with
    a true disparity (flat random images would leave every pixel to the ties)."""
    rng = np.random.default_rng(seed)
    base = rng.integers(0, 256, (h // texture + 2, (w + shift) // texture + 2)).astype(np.uint8)
    big = cv2.resize(base, ((w + shift) // texture * texture + 2 * texture, h + 2 * texture))
    big = big[:h, : w + shift]
    left = big[:, shift : shift + w].copy()
    right = big[:, :w].copy()
    noise = rng.integers(-3, 4, right.shape)
    right = np.clip(right.astype(int) + noise, 0, 255).astype(np.uint8)
    return np.ascontiguousarray(left), np.ascontiguousarray(right)


@settings(max_examples=40)
@given(
    seed=st.integers(0, 10_000),
    h=st.integers(24, 90),
    w=st.integers(40, 200),
    mn=st.integers(-20, 30),
    nd16=st.integers(1, 5),
    bs=st.sampled_from([1, 3, 5, 7]),
    u=st.sampled_from([0, 1, 5, 10, 15, 30]),
    shift=st.integers(0, 40),
    texture=st.integers(1, 6),
)
def test_random_pairs_give_opencvs_map_bit_for_bit(
    seed: int, h: int, w: int, mn: int, nd16: int, bs: int, u: int, shift: int, texture: int
) -> None:
    nd = 16 * nd16
    left, right = _pair(seed, h, w, shift, texture)
    if not sgbm.supported(left.shape, mn, nd, bs, 32 * bs * bs, u):
        with pytest.raises(ValueError):
            _compiled(left, right, mn, nd, bs, u)
        return
    want = _opencv(left, right, mn, nd, bs, u)
    got = _compiled(left, right, mn, nd, bs, u)
    assert got.dtype == np.int16 and got.shape == want.shape
    assert np.array_equal(got, want), f"{int((got != want).sum())} pixels differ"


def test_ties_are_broken_as_opencvs_8_lanes_break_them() -> None:
    """Without the uniqueness test (ratio 0) a pattern of period 3 ties disparities 3 apart;
    OpenCV's vector loop takes the last d of each of its 8 lanes, then the smallest of those:
    the copy does the same, and 16 or 32 lanes (or a plain first minimum) would not."""
    row = ((np.arange(160) % 3) * 66).astype(np.uint8)
    img = np.ascontiguousarray(np.tile(row, (40, 1)))
    want = _opencv(img, img, 0, 32, 3, 0)
    assert np.array_equal(_compiled(img, img, 0, 32, 3, 0), want)
    for lanes in (16, 32):
        other = _compiled(img, img, 0, 32, 3, 0, lanes=lanes)
        assert not np.array_equal(other, want)


def test_threads_do_not_change_the_map() -> None:
    left, right = _pair(11, 80, 180, 12, 3)
    one = _compiled(left, right, 0, 32, 3, 10, threads=1)
    two = _compiled(left, right, 0, 32, 3, 10, threads=2)
    assert np.array_equal(one, two)


def test_refusals_say_what_is_wrong() -> None:
    g = np.zeros((60, 100), np.uint8)
    with pytest.raises(ValueError, match="multiple of 16"):
        _compiled(g, g, 0, 24, 3, 10)
    with pytest.raises(ValueError, match="saturate"):
        _compiled(g, g, 0, 16, 11, 10)
    with pytest.raises(ValueError, match="too few"):
        _compiled(np.zeros((8, 100), np.uint8), np.zeros((8, 100), np.uint8), 0, 16, 3, 10)
    with pytest.raises(ValueError, match="one size"):
        _compiled(g, np.zeros((60, 90), np.uint8), 0, 16, 3, 10)
    assert not sgbm.fits_int16(11, 32 * 121, 10) and sgbm.fits_int16(7, 32 * 49, 10)


def test_no_matched_column_is_refused_as_opencv_fails() -> None:
    g = np.zeros((60, 40), np.uint8)
    with pytest.raises(cv2.error):
        _opencv(g, g, 0, 48, 3, 10)
    with pytest.raises(ValueError, match="no column"):
        _compiled(g, g, 0, 48, 3, 10)


def _stage_inputs(gl: np.ndarray, gr: np.ndarray, size: tuple[int, int]) -> list[tuple]:
    seen: list[tuple] = []
    real = dense.sgbm_map

    def spy(cl: np.ndarray, cr: np.ndarray, mn: int, num: int, bs: int, u: int) -> np.ndarray:
        seen.append((cl, cr, mn, num, bs, u))
        return real(cl, cr, mn, num, bs, u)

    rig = calibration.rig_from_short(0.16, 60.0, size)
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(dense, "sgbm_map", spy)
        stereo.stereo_points(gl, gr, rig, **StereoOptions().keywords())
    return seen


def test_real_pairs_stage_crops_at_640x480(real_data: Path) -> None:
    """Every real pair (Middlebury, KITTI) resized to 640×480: the stage's SGBM input, both
    ways, the same int16 map."""
    size = (640, 480)
    n = 0
    for sub in ("middeval2", "kitti2012"):
        for d in sorted((real_data / "stereo" / sub).iterdir()):
            names = next(((a, b) for a, b in LAYOUTS if (d / a).exists()), None)
            if names is None:
                continue
            imgs = [cv2.imread(str(d / f)) for f in names]
            gl, gr = (to_gray(cv2.resize(i, size, interpolation=cv2.INTER_AREA)) for i in imgs)
            for cl, cr, mn, num, bs, u in _stage_inputs(gl, gr, size):
                want = _opencv(cl, cr, mn, num, bs, u)
                assert np.array_equal(_compiled(cl, cr, mn, num, bs, u), want), d.name
                n += 1
    assert n >= 30


def test_dense_map_is_the_same_with_either_sgbm(monkeypatch: pytest.MonkeyPatch) -> None:
    left, right = _pair(3, 120, 260, 20, 3)
    rect = rectify(calibration.rig_from_short(0.16, 60.0, (260, 120)))
    maps = []
    for which in ("opencv", "numba"):
        monkeypatch.setenv(dense.SGBM_ENV, which)
        maps.append(dense.dense_disparity(left, right, rect, min_disparity=0, num_disparities=48))
    assert np.array_equal(maps[0].disparity, maps[1].disparity, equal_nan=True)


def test_the_choice(monkeypatch: pytest.MonkeyPatch) -> None:
    big, small = (1080, 2117), (480, 737)
    monkeypatch.setenv(dense.SGBM_ENV, "numba")
    assert dense.use_compiled(small, 26, 96, 3, 10)
    assert not dense.use_compiled(small, 26, 96, 11, 10)  # would saturate: OpenCV
    monkeypatch.setenv(dense.SGBM_ENV, "opencv")
    assert not dense.use_compiled(big, 21, 304, 3, 10)
    monkeypatch.setenv(dense.SGBM_ENV, "auto")
    import numba  # noqa: F401 - auto uses the compiled SGBM only once Numba is loaded

    assert dense.use_compiled(big, 21, 304, 3, 10)
    assert not dense.use_compiled(small, 26, 96, 3, 10)
    monkeypatch.setenv("SCENESPEAK_NO_NUMBA", "1")
    assert not dense.use_compiled(big, 21, 304, 3, 10)
    monkeypatch.delenv("SCENESPEAK_NO_NUMBA")
    monkeypatch.setenv(dense.SGBM_ENV, "fast")
    with pytest.raises(ValueError, match="SCENESPEAK_SGBM"):
        dense.use_compiled(big, 21, 304, 3, 10)
