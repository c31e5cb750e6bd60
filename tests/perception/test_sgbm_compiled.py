"""The compiled 3-way SGBMs (``perception/stereo/sgbm.py``: the C extension ``_sgbm_c`` and
the Numba loops ``_sgbm3way``) give OpenCV's map bit for bit.

Random images, sizes, search ranges, block sizes and uniqueness ratios (hypothesis,
derandomised) and the real pairs (the stage's crops at 640×480, and for the C kernel at
1280×960 and 1920×1080 too; skipped without the data folder) against ``cv2.StereoSGBM`` in
``MODE_SGBM_3WAY`` with the same parameters, each kernel skipped with the reason when it is
not there (Numba not installed; the extension not built); then every instruction-set copy of
the C kernel's loops, the choice in ``dense.py`` (``SCENESPEAK_SGBM``) and the refusals.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

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

NEEDS_NUMBA = pytest.mark.skipif(not sgbm.available(), reason="numba is not installed")
NEEDS_C = pytest.mark.skipif(
    not sgbm.c_available(),
    reason="the C extension _sgbm_c is not built (pip install -e . with a C compiler)",
)
KERNELS = [pytest.param("c", marks=NEEDS_C), pytest.param("numba", marks=NEEDS_NUMBA)]

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
    left: np.ndarray, right: np.ndarray, mn: int, nd: int, bs: int, u: int, **kw: Any
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


@pytest.mark.parametrize("kernel", KERNELS)
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
    kernel: str,
    seed: int,
    h: int,
    w: int,
    mn: int,
    nd16: int,
    bs: int,
    u: int,
    shift: int,
    texture: int,
) -> None:
    nd = 16 * nd16
    left, right = _pair(seed, h, w, shift, texture)
    if not sgbm.supported(left.shape, mn, nd, bs, 32 * bs * bs, u):
        with pytest.raises(ValueError):
            _compiled(left, right, mn, nd, bs, u, kernel=kernel)
        return
    want = _opencv(left, right, mn, nd, bs, u)
    got = _compiled(left, right, mn, nd, bs, u, kernel=kernel)
    assert got.dtype == np.int16 and got.shape == want.shape
    assert np.array_equal(got, want), f"{int((got != want).sum())} pixels differ"


@pytest.mark.parametrize("kernel", KERNELS)
def test_ties_are_broken_as_opencvs_8_lanes_break_them(kernel: str) -> None:
    """Without the uniqueness test (ratio 0) a pattern of period 3 ties disparities 3 apart;
    OpenCV's vector loop takes the last d of each of its 8 lanes, then the smallest of those:
    the copy does the same, and 16 or 32 lanes (or a plain first minimum) would not."""
    row = ((np.arange(160) % 3) * 66).astype(np.uint8)
    img = np.ascontiguousarray(np.tile(row, (40, 1)))
    want = _opencv(img, img, 0, 32, 3, 0)
    assert np.array_equal(_compiled(img, img, 0, 32, 3, 0, kernel=kernel), want)
    for lanes in (16, 32):
        other = _compiled(img, img, 0, 32, 3, 0, lanes=lanes, kernel=kernel)
        assert not np.array_equal(other, want)


@pytest.mark.parametrize("kernel", KERNELS)
@pytest.mark.parametrize("u", [0, 10])
def test_flat_images_tie_everywhere_as_in_opencv(kernel: str, u: int) -> None:
    """Flat images, a ramp and a step: every summed cost ties or nearly ties, the uniqueness
    test and the lane tie-breaking decide every pixel (and the edge columns' 15)."""
    flat = np.full((48, 120), 90, np.uint8)
    ramp = np.ascontiguousarray(np.tile(np.arange(120, dtype=np.uint8) * 2, (48, 1)))
    step = flat.copy()
    step[:, 60:] = 200
    for left, right in ((flat, flat), (ramp, ramp), (step, flat), (ramp, step)):
        want = _opencv(left, right, 0, 48, 3, u)
        assert np.array_equal(_compiled(left, right, 0, 48, 3, u, kernel=kernel), want)


@pytest.mark.parametrize("kernel", KERNELS)
def test_threads_do_not_change_the_map(kernel: str) -> None:
    left, right = _pair(11, 80, 180, 12, 3)
    one = _compiled(left, right, 0, 32, 3, 10, threads=1, kernel=kernel)
    two = _compiled(left, right, 0, 32, 3, 10, threads=2, kernel=kernel)
    four = _compiled(left, right, 0, 32, 3, 10, threads=4, kernel=kernel)
    assert np.array_equal(one, two) and np.array_equal(one, four)


@NEEDS_C
@pytest.mark.parametrize("bs", [1, 3, 5, 7])
def test_every_instruction_set_copy_of_the_c_loops_gives_the_same_raw_map(bs: int) -> None:
    """The C loops are compiled once per instruction set (x86-64-v4, -v3, the baseline) and
    the widest the CPU runs is taken: each copy this CPU can run gives the same raw map, and
    through OpenCV's filters OpenCV's map (D 304: a 16-lane tail after the 32-lane vectors,
    the pixel costs' rounding up to 64)."""
    from scenespeak.perception.stereo import _sgbm_c

    left, right = _pair(5, 70, 420, 30, 2)
    p = _params(-5, 304, bs, 10)
    h, w = left.shape
    maps = []
    for isa in range(_sgbm_c.isa() + 1):
        raw = np.empty((h, w), np.int16)
        _sgbm_c.raw(left, right, raw, h, w, -5, 304, bs, p.p1, p.p2, 10, 1, 8, 2, isa)
        maps.append(raw)
    assert all(np.array_equal(m, maps[0]) for m in maps[1:])
    assert np.array_equal(_compiled(left, right, -5, 304, bs, 10, kernel="c"),
                          _opencv(left, right, -5, 304, bs, 10))  # fmt: skip


@NEEDS_C
def test_the_c_kernel_refuses_what_it_cannot_compute() -> None:
    from scenespeak.perception.stereo import _sgbm_c

    g = np.zeros((60, 100), np.uint8)
    raw = np.empty((60, 100), np.int16)
    with pytest.raises(ValueError, match=r"SgbmParams\.check"):
        _sgbm_c.raw(g, g, raw, 60, 100, 0, 16, 4, 72, 288, 10, 1, 8, 2)  # even block
    with pytest.raises(ValueError, match="wrong size"):
        _sgbm_c.raw(g, g, raw[:50], 60, 100, 0, 16, 3, 72, 288, 10, 1, 8, 2)
    with pytest.raises(ValueError, match="kernel 'fortran'"):
        _compiled(g, g, 0, 16, 3, 10, kernel="fortran")


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


def _real_crops_agree(real_data: Path, size: tuple[int, int], kernel: str, every: int) -> int:
    """The stage's SGBM inputs of every ``every``-th real pair resized to ``size``: OpenCV's
    and the kernel's maps are the same; returns how many inputs were compared."""
    n = 0
    dirs = [
        d
        for sub in ("middeval2", "kitti2012")
        for d in sorted((real_data / "stereo" / sub).iterdir())
        if any((d / a).exists() for a, _ in LAYOUTS)
    ]
    for d in dirs[::every]:
        names = next((a, b) for a, b in LAYOUTS if (d / a).exists())
        imgs = [cv2.imread(str(d / f)) for f in names]
        interp = cv2.INTER_AREA if size[0] < imgs[0].shape[1] else cv2.INTER_LINEAR
        gl, gr = (to_gray(cv2.resize(i, size, interpolation=interp)) for i in imgs)
        for cl, cr, mn, num, bs, u in _stage_inputs(gl, gr, size):
            want = _opencv(cl, cr, mn, num, bs, u)
            got = _compiled(cl, cr, mn, num, bs, u, kernel=kernel)
            assert np.array_equal(got, want), f"{d.name} at {size}: {(got != want).sum()} px"
            n += 1
    return n


@pytest.mark.parametrize("kernel", KERNELS)
def test_real_pairs_stage_crops_at_640x480(real_data: Path, kernel: str) -> None:
    """Every real pair (Middlebury, KITTI) resized to 640×480: the stage's SGBM input, both
    ways, the same int16 map."""
    assert _real_crops_agree(real_data, (640, 480), kernel, 1) >= 30


@NEEDS_C
@pytest.mark.slow
@pytest.mark.parametrize("size", [(1280, 960), (1920, 1080)])
def test_real_pairs_stage_crops_at_the_large_sizes(real_data: Path, size: tuple[int, int]) -> None:
    """Every third real pair at 1280×960 and 1920×1080 (the sizes of bench_points.py: wide
    search ranges, D up to about 300): the C kernel's map is OpenCV's."""
    assert _real_crops_agree(real_data, size, "c", 3) >= 10


def test_dense_map_is_the_same_with_any_sgbm(monkeypatch: pytest.MonkeyPatch) -> None:
    left, right = _pair(3, 120, 260, 20, 3)
    rect = rectify(calibration.rig_from_short(0.16, 60.0, (260, 120)))
    kernels = ["opencv"] + [
        k for k, ok in (("c", sgbm.c_available()), ("numba", sgbm.available())) if ok
    ]
    maps = []
    for which in kernels:
        monkeypatch.setenv(dense.SGBM_ENV, which)
        assert dense.sgbm_kernel((120, 260), 0, 48, 3, 10) == which
        maps.append(dense.dense_disparity(left, right, rect, min_disparity=0, num_disparities=48))
    assert all(np.array_equal(maps[0].disparity, m.disparity, equal_nan=True) for m in maps)


@NEEDS_NUMBA
def test_the_choice_without_the_c_kernel(monkeypatch: pytest.MonkeyPatch) -> None:
    """``numba`` forces the Numba loops; ``auto`` without the C extension takes them only
    for a large cost volume once Numba is loaded (session 8's rule)."""
    big, small = (1080, 2117), (480, 737)
    monkeypatch.setattr(sgbm, "c_available", lambda: False)
    monkeypatch.setenv(dense.SGBM_ENV, "numba")
    assert dense.use_compiled(small, 26, 96, 3, 10)
    assert not dense.use_compiled(small, 26, 96, 11, 10)  # would saturate: OpenCV
    monkeypatch.setenv(dense.SGBM_ENV, "opencv")
    assert not dense.use_compiled(big, 21, 304, 3, 10)
    monkeypatch.setenv(dense.SGBM_ENV, "c")  # asked for, not built: OpenCV
    assert dense.sgbm_kernel(big, 21, 304, 3, 10) == "opencv"
    monkeypatch.setenv(dense.SGBM_ENV, "auto")
    import numba  # noqa: F401 - auto uses the Numba loops only once Numba is loaded

    assert dense.sgbm_kernel(big, 21, 304, 3, 10) == "numba"
    assert dense.sgbm_kernel(small, 26, 96, 3, 10) == "opencv"
    monkeypatch.setenv("SCENESPEAK_NO_NUMBA", "1")
    assert not dense.use_compiled(big, 21, 304, 3, 10)
    monkeypatch.delenv("SCENESPEAK_NO_NUMBA")
    monkeypatch.setenv(dense.SGBM_ENV, "fast")
    with pytest.raises(ValueError, match="SCENESPEAK_SGBM"):
        dense.use_compiled(big, 21, 304, 3, 10)


@NEEDS_C
def test_the_choice_with_the_c_kernel(monkeypatch: pytest.MonkeyPatch) -> None:
    """``auto`` (and ``c``) take the C extension at every size where it can compute the call,
    with or without Numba; OpenCV where it cannot (saturation) or when asked."""
    big, small = (1080, 2117), (480, 737)
    for value in ("auto", "c"):
        monkeypatch.setenv(dense.SGBM_ENV, value)
        assert dense.sgbm_kernel(big, 21, 304, 3, 10) == "c"
        assert dense.sgbm_kernel(small, 26, 96, 3, 10) == "c"
        assert dense.sgbm_kernel(small, 26, 96, 11, 10) == "opencv"  # would saturate
    monkeypatch.delenv(dense.SGBM_ENV)
    assert dense.sgbm_kernel(small, 26, 96, 3, 10) == "c"  # auto is the default
    monkeypatch.setenv(dense.SGBM_ENV, "opencv")
    assert dense.sgbm_kernel(small, 26, 96, 3, 10) == "opencv"
    monkeypatch.setenv(dense.SGBM_ENV, "numba")
    if sgbm.available():
        assert dense.sgbm_kernel(small, 26, 96, 3, 10) == "numba"
