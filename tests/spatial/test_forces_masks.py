"""Mask outlines (spatial/forces/masks.py): the measured simplification rule and its bounds.

The rule (``masks.RULE``) was chosen on the tuning seed of ``tools/mask_set`` and is
reported on the validation seed (``benchmarks/bench_masks.py``); these tests use a third seed
of the same generator, so they look at neither.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from scenespeak.spatial import forces
from scenespeak.spatial.forces import masks
from scenespeak.spatial.forces.reference import _edge_pair_histograms, _Kernel
from scenespeak.tools.mask_set import mask_pairs

#: The bound the rule was chosen for (docs/forces.md): max |F - F_exact| / max F_exact, for F0
#: and F2 at 180 directions, against the unsimplified traced outline.
BOUND = 0.01
TEST_SEED = 3827


def peak_error(h: np.ndarray, g: np.ndarray) -> float:
    return float(np.abs(h - g).max() / np.abs(g).max())


@pytest.mark.parametrize("size", [128, 256])
def test_the_rule_stays_within_its_bound_against_the_exact_outline(size: int) -> None:
    for pair in mask_pairs(TEST_SEED, sizes=(size,), per_kind=1):
        exact = forces.force_histograms(pair.a, pair.b, mask_tolerance=0.0)
        ruled = forces.force_histograms(pair.a, pair.b)  # the default: the rule
        for k in (0, 1):
            assert peak_error(ruled[k], exact[k]) <= BOUND, (pair.name, k)


def test_the_offset_chords_beat_plain_douglas_peucker(monkeypatch: pytest.MonkeyPatch) -> None:
    """Moving the chords back (area of each run kept) is closer to the exact outline than
    Douglas-Peucker's chords, and moves no vertex by more than the tolerance."""
    yy, xx = np.mgrid[:400, :400]
    disc = np.hypot(yy - 200.3, xx - 199.6) <= 150.0
    exact = forces.prepare(disc, "disc", mask_tolerance=0.0)
    ring = np.column_stack([-exact.start[:, 1], exact.start[:, 0]])  # (row, col), as traced
    idx = masks._kept_indices(ring, 1.0)
    assert idx is not None
    moved = masks._offset_vertices(ring, idx, 1.0)
    assert 0.0 < np.hypot(*(moved - ring[idx]).T).max() <= 1.0 + 1e-12

    pairs = mask_pairs(TEST_SEED, sizes=(256,), per_kind=1)
    worst = {}
    for name, offset in (("offset", masks._offset_vertices), ("plain", None)):
        if offset is None:
            monkeypatch.setattr(masks, "_offset_vertices", lambda ring, idx, tol: ring[idx])
        errors = []
        for pair in pairs:
            exact_h = forces.force_histograms(pair.a, pair.b, mask_tolerance=0.0)
            got = forces.force_histograms(pair.a, pair.b, mask_tolerance=0.75)
            errors += [peak_error(got[k], exact_h[k]) for k in (0, 1)]
        worst[name] = max(errors)
    assert worst["offset"] < 0.5 * worst["plain"], worst


def test_rule_rows_and_thin_rings() -> None:
    r = 100.0
    assert masks.outline_tolerance(math.pi * r * r, 2 * math.pi * r) == 1.0
    assert masks.outline_tolerance(10_000.0, 20_002.0) == forces.regions.MASK_TOLERANCE
    # a 1-pixel-wide line, however long, keeps every corner
    line = np.zeros((40, 2000), bool)
    line[20, 5:1995] = True
    got = forces.prepare(line, "line")
    assert got.area == pytest.approx(line.sum() - 0.5)


def test_the_default_is_deterministic_and_the_same_through_prepare() -> None:
    pair = mask_pairs(TEST_SEED, sizes=(256,), per_kind=1)[2]
    one = forces.force_histograms(pair.a, pair.b)
    two = forces.force_histograms(pair.a, pair.b)
    np.testing.assert_array_equal(one, two)
    regions = [forces.prepare(pair.a, "a"), forces.prepare(pair.b, "b")]
    got = forces.f0_f2_pairs(regions, [(0, 1)], 180)
    np.testing.assert_array_equal(got.f0[0], one[0])
    np.testing.assert_array_equal(got.f2[0], one[1])


def test_unsimplified_outline_matches_the_reference() -> None:
    """``mask_tolerance=0``: the traced outline itself, kernel against reference to 1e-9."""
    pair = mask_pairs(TEST_SEED, sizes=(128,), per_kind=1)[3]  # a field: holes, islands
    a = forces.prepare(pair.a, "a", mask_tolerance=0.0)
    b = forces.prepare(pair.b, "b", mask_tolerance=0.0)
    got = forces.force_histograms(pair.a, pair.b, mask_tolerance=0.0)
    ref = _edge_pair_histograms(a, b, [_Kernel(0.0), _Kernel(2.0)], 180)
    for k in (0, 1):
        assert peak_error(got[k], ref[k]) <= 1e-9
