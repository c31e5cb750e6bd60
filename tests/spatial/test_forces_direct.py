"""The compiled one-call path of ``force_histograms`` for two polygons (``forces._direct``).

It must give the general path's histograms bit for bit, take the same decisions (convex or
not, degenerate, overlapping, touching, too large or too small, not simple) and, whenever it
declines, leave the general path to raise the same error with the same message.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.typing import NDArray

from scenespeak.errors import InputError
from scenespeak.spatial import forces
from scenespeak.spatial.forces import _jit, api, guards, regions

Array = NDArray[np.float64]

pytestmark = pytest.mark.skipif(not _jit.available(), reason="numba is not installed")


@pytest.fixture(autouse=True)
def _compiled_kernel(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(_jit.POLICY_ENV, "always")


def _general(a: Array, b: Array, r: tuple[float, ...], directions: int) -> Array | str:
    """``force_histograms`` through the general path (the direct one switched off)."""
    direct = api._direct
    api._direct = lambda *args: None  # type: ignore[assignment]
    try:
        return forces.force_histograms(a, b, r, directions)
    except InputError as exc:
        return f"InputError: {exc}"
    finally:
        api._direct = direct  # type: ignore[assignment]


def _either(a: Array, b: Array, r: tuple[float, ...], directions: int) -> Array | str:
    try:
        return forces.force_histograms(a, b, r, directions)
    except InputError as exc:
        return f"InputError: {exc}"


def _same(a: Array, b: Array, r: tuple[float, ...] = (0.0, 2.0), directions: int = 36) -> None:
    got = _either(a, b, r, directions)
    want = _general(a, b, r, directions)
    if isinstance(want, str) or isinstance(got, str):
        assert got == want
    else:
        assert got.dtype == want.dtype and got.shape == want.shape
        assert np.array_equal(got, want), float(np.abs(got - want).max())


def _polygon(rng: np.random.Generator, kind: str, n: int, centre: Array, size: float) -> Array:
    ang = np.sort(rng.uniform(0, 2 * np.pi, n))
    if kind == "convex":
        rad = np.full(n, size)
    elif kind == "star":
        rad = rng.uniform(0.4 * size, size, n)
    else:  # a sliver: nearly collinear vertices
        rad = np.full(n, size)
        ang = np.linspace(0, np.pi, n) * 1e-9 + rng.uniform(0, 2 * np.pi)
    p = np.column_stack([centre[0] + rad * np.cos(ang), centre[1] + rad * np.sin(ang)])
    return p if rng.uniform() < 0.7 else p[::-1].copy()


EXPONENTS = [(0.0, 2.0), (0.0,), (2.0,), (0.5, 1.5), (3.0,), (0.0, 1.0, 2.0)]


@settings(max_examples=150, deadline=None)
@given(
    seed=st.integers(0, 2**31),
    kinds=st.tuples(*[st.sampled_from(["convex", "star", "sliver"])] * 2),
    sizes=st.tuples(st.integers(3, 40), st.integers(3, 40)),
    gap=st.sampled_from([0.0, 1.0, 1.999999, 2.0, 2.5, 6.0]),
    scale=st.sampled_from([1.0, 1e-7, 1e-3, 1e5, 1e7]),
    r=st.sampled_from(EXPONENTS),
    directions=st.sampled_from([36, 37, 180]),
)
def test_direct_path_is_the_general_path(
    seed: int,
    kinds: tuple[str, str],
    sizes: tuple[int, int],
    gap: float,
    scale: float,
    r: tuple[float, ...],
    directions: int,
) -> None:
    rng = np.random.default_rng(seed)
    angle = rng.uniform(0, 2 * np.pi)
    centre = gap * np.array([np.cos(angle), np.sin(angle)])
    a = _polygon(rng, kinds[0], sizes[0], np.zeros(2), 1.0) * scale
    b = _polygon(rng, kinds[1], sizes[1], centre, 1.0) * scale
    _same(a, b, r, directions)


SQUARE = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])


@pytest.mark.parametrize(
    ("a", "b"),
    [
        (SQUARE, SQUARE + np.array([3.0, 0.0])),  # apart
        (SQUARE, SQUARE + np.array([1.0, 0.0])),  # touching along an edge
        (SQUARE, SQUARE + np.array([0.5, 0.5])),  # overlapping
        (SQUARE, SQUARE * 0.25 + np.array([0.3, 0.3])),  # one inside the other
        (SQUARE, np.array([[3.0, 0.0], [4.0, 1.0], [4.0, 0.0], [3.0, 1.0]])),  # a bow tie
        (SQUARE, np.array([[3.0, 0.0], [4.0, 0.0], [5.0, 0.0]])),  # collinear
        (SQUARE, np.array([[3.0, 0.0], [4.0, 0.0], [4.0, 0.0], [4.0, 1.0]])),  # repeated
        (SQUARE, np.array([[3.0, 0.0], [4.0, 0.0], [3.5, 0.0], [3.5, 1.0]])),  # a fold
        (SQUARE, np.array([[3.0, 0.0], [4.0, 0.0], [np.nan, 1.0]])),  # not finite
        (SQUARE, np.array([[3.0, 0.0], [4.0, 0.0]])),  # too few vertices
        (SQUARE * 1e-160, SQUARE * 1e-160 + np.array([3e-160, 0.0])),  # tiny: normalised
        (SQUARE * 1e150, SQUARE * 1e150 + np.array([3e150, 0.0])),  # huge: normalised
        (SQUARE + 1e13, SQUARE + np.array([1e13 + 3.0, 1e13])),  # far from the origin
        (SQUARE, SQUARE * 1e-9 + np.array([1e3, 0.0])),  # zero histogram in float64
        (
            np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [1.0, 0.5], [0.0, 2.0]]),
            SQUARE + np.array([5.0, 0.0]),
        ),  # not convex, simple
        (
            np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [1.0, 0.0], [0.0, 2.0]]),
            SQUARE + np.array([5.0, 0.0]),
        ),  # touches itself
    ],
)
@pytest.mark.parametrize("r", [(0.0, 2.0), (0.0,), (2.0,)])
def test_direct_path_declines_what_the_general_path_must_decide(
    a: Array, b: Array, r: tuple[float, ...]
) -> None:
    with np.errstate(all="ignore"):
        _same(np.asarray(a, np.float64), np.asarray(b, np.float64), r)


def test_area_and_turn_thresholds_near_their_limits() -> None:
    """Polygons whose area or turn sits at the tolerance: the direct path must not decide
    differently from the general one (it declines within a margin)."""
    for k in range(-3, 4):
        h = regions._AREA_TOL * 2.0 * (1.0 + 0.5 * k)  # area about AREA_TOL * scale² * (..)
        tri = np.array([[0.0, 0.0], [1.0, 0.0], [0.5, h]])
        _same(tri, SQUARE + np.array([3.0, 0.0]))
        bent = np.array([[0.0, 0.0], [1.0, -h], [2.0, 0.0], [2.0, 1.0], [0.0, 1.0]])
        _same(bent, SQUARE + np.array([4.0, 0.0]))


def test_tolerances_are_the_general_paths() -> None:
    from scenespeak.spatial.forces import _direct

    assert _direct.LENGTH_TOL == regions._LENGTH_TOL
    assert _direct.AREA_TOL == regions._AREA_TOL
    assert (_direct.SCALE_LO, _direct.SCALE_HI) == guards._SCALE_RANGE


def test_direct_path_is_taken_for_plain_polygons() -> None:
    a = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    got = api._direct(a, a + np.array([3.0, 0.0]), [0.0, 2.0], 36, 0.25)
    assert got is not None and got.shape == (2, 36)
    # lists, integer arrays and masks take the general path
    assert api._direct(a.tolist(), a + 3.0, [0.0, 2.0], 36, 0.25) is None
    assert api._direct(a.astype(int), a + 3.0, [0.0, 2.0], 36, 0.25) is None
    assert api._direct(a, a + 3.0, [0.0, 2.0], 36, -1.0) is None  # the general path raises


def test_without_numba_the_general_path_runs(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(_jit.POLICY_ENV, "never")
    a = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    assert api._direct(a, a + np.array([3.0, 0.0]), [0.0, 2.0], 36, 0.25) is None
    assert forces.force_histograms(a, a + np.array([3.0, 0.0]), directions=36).shape == (2, 36)
