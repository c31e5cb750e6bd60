"""Degrees of truth (``spatial.degrees``) against what they must be, with a tolerance.

Replaces a verbatim copy of an earlier ``direction_degree``: a single force spike ``δ`` degrees
off a direction scores ``1 − δ/90`` (the reading the rule base's thresholds rely on); the
degree of bin ``i`` is that of bin 0 of the histogram turned by ``i`` bins; a mirrored
histogram has the same degree and the opposite deviation; degrees lie in [0, 1]; a uniform
histogram favours no direction.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from scenespeak.spatial.degrees import direction_degree, four_degrees


@pytest.mark.parametrize("nbins", [8, 36, 180, 360])
def test_a_spike_scores_one_minus_its_angle_over_ninety(nbins: int) -> None:
    step = 360.0 / nbins
    for k in range(-(nbins // 4) + 1, nbins // 4):
        h = np.zeros(nbins)
        h[k % nbins] = 1.0
        d = direction_degree(h, 0)
        delta = abs(k) * step
        assert d.degree == pytest.approx(max(0.0, 1.0 - delta / 90.0), abs=1e-12)
        assert d.deviation == pytest.approx(math.radians(k * step), abs=1e-12)


histograms = st.tuples(
    st.sampled_from([8, 36, 180]), st.integers(0, 2**32 - 1), st.sampled_from(["dense", "sparse"])
)


def _histogram(nbins: int, seed: int, kind: str) -> np.ndarray:
    rng = np.random.default_rng(seed)
    if kind == "dense":
        return rng.random(nbins)
    h = np.zeros(nbins)
    h[rng.integers(0, nbins, 3)] = rng.random(3)
    return h


@settings(max_examples=150)
@given(histograms, st.integers(0, 359))
def test_degree_turns_with_the_histogram(spec: tuple[int, int, str], turn: int) -> None:
    h = _histogram(*spec)
    i = turn % h.size
    a = direction_degree(h, i)
    b = direction_degree(np.roll(h, -i), 0)
    assert a.degree == pytest.approx(b.degree, abs=1e-12)
    assert a.deviation == pytest.approx(b.deviation, abs=1e-12)
    assert 0.0 <= a.degree <= 1.0
    assert a.effective >= -1e-12 and a.contrary >= -1e-12


@settings(max_examples=150)
@given(histograms)
def test_a_mirrored_histogram_mirrors_the_deviation(spec: tuple[int, int, str]) -> None:
    h = _histogram(*spec)
    mirrored = h[(-np.arange(h.size)) % h.size]  # θ → −θ
    a, b = direction_degree(h, 0), direction_degree(mirrored, 0)
    assert a.degree == pytest.approx(b.degree, abs=1e-12)
    assert a.deviation == pytest.approx(-b.deviation, abs=1e-12)


def test_a_uniform_histogram_favours_no_direction() -> None:
    for nbins in (8, 180):
        assert all(abs(d.degree) < 1e-12 for d in four_degrees(np.ones(nbins)).values())


def test_float32_input_gives_the_float64_answer() -> None:
    h = np.exp(-(((np.arange(180) - 40) / 15.0) ** 2)).astype(np.float32)
    a, b = direction_degree(h, 45), direction_degree(h.astype(np.float64), 45)
    assert a.degree == pytest.approx(b.degree, abs=1e-12)
