"""The all-pairs path of the relations stage gives the same floats as the per-pair functions.

``language.relate_objects`` prepares each polygon once, sweeps the force histograms of all
pairs together (``forces._many_f0_f2``), computes the degrees of truth of all pairs in one
batch (``degrees.many_degrees``) and skips clipping for hulls an edge keeps apart. Each batch
helper is compared with the package's own per-pair function on random inputs (the batch is
designed to give the same floats). The geometry underneath (clipping, area, convexity) is
checked against independent references and properties to a tolerance: Green's theorem for the
clipped area, a triangle fan for the shoelace area, SciPy's hulls for convexity; no earlier
implementation is kept here as the specification.
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Iterator

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial import ConvexHull

from scenespeak.errors import InputError
from scenespeak.geometry.polygons import (
    _clip_convex,
    _clipped_away,
    _Ring,
    exact_intersection_area,
    intersection_area,
    is_convex,
    polygon_area,
)
from scenespeak.spatial import forces, language
from scenespeak.spatial.degrees import (
    _prefix_sums,
    direction_degree,
    four_degrees,
    many_degrees,
)
from scenespeak.spatial.language import rules

seeds = st.integers(min_value=0, max_value=2**32 - 1)


@contextlib.contextmanager
def _one_force_kernel() -> Iterator[None]:
    """Both paths of a comparison on the same force kernel: by default
    (``SCENESPEAK_NUMBA=auto``) a process switches from the NumPy reference to the compiled
    sweep once its work pays for loading Numba, which could happen between the two paths (the
    kernels agree to 1e-9, not bit for bit). The policy is read at every sweep."""
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("SCENESPEAK_NUMBA", "never")
        yield


def _convex(rng: np.random.Generator, spread: float = 2.0) -> np.ndarray:
    """A random convex hull (3 to 30 vertices, either orientation), sometimes on a 0.1 grid."""
    n = int(rng.integers(3, 31))
    centre = rng.uniform(-spread, spread, 2)
    pts = rng.normal(size=(n, 2)) * rng.uniform(0.02, 0.6, 2) + centre
    if rng.random() < 0.2:
        pts = np.round(pts, 1)
    try:
        hull = pts[ConvexHull(pts).vertices]
    except Exception:  # all points on a line: try again
        return _convex(rng, spread)
    if len(hull) < 3:
        return _convex(rng, spread)
    return hull[::-1].copy() if rng.random() < 0.3 else hull


def _star(rng: np.random.Generator, spread: float = 2.0) -> np.ndarray:
    """A random star-shaped (non-convex) polygon of 5 to 30 vertices."""
    n = int(rng.integers(5, 31))
    # One vertex per sector of 360/n degrees: gaps under 180°, so the polygon is simple.
    ang = (np.arange(n) + rng.uniform(0.0, 0.8, n)) * (2.0 * np.pi / n)
    rad = rng.uniform(0.3, 1.0, n) * rng.uniform(0.02, 0.6)
    centre = rng.uniform(-spread, spread, 2)
    return np.column_stack([centre[0] + rad * np.cos(ang), centre[1] + rad * np.sin(ang)])


def _scene(rng: np.random.Generator) -> list[np.ndarray]:
    """2-6 polygons, mostly convex hulls; some pairs touch (one translated onto the other),
    some overlap."""
    hulls = [
        (_star if rng.random() < 0.15 else _convex)(rng, spread=float(rng.choice([0.5, 2.0])))
        for _ in range(rng.integers(2, 7))
    ]
    if rng.random() < 0.4 and len(hulls) >= 2:
        d = rng.normal(size=2)
        d /= np.hypot(*d)
        gap = (hulls[0] @ d).max() - (hulls[1] @ d).min()
        hulls[1] = hulls[1] + gap * d  # touching (up to rounding)
    return hulls


def _assert_same_relation(a: language.Relation, b: language.Relation) -> None:
    assert a == b  # every field, the floats bit for bit


@settings(max_examples=40)
@given(seeds)
def test_relate_objects_matches_the_per_pair_functions(seed: int) -> None:
    with _one_force_kernel():
        rng = np.random.default_rng(seed)
        hulls = _scene(rng)
        names = [f"obj{k}" for k in range(len(hulls))]
        heights = [rng.uniform(0.0, 0.3, rng.integers(3, 20)) for _ in hulls]
        if rng.random() < 0.3:
            heights[0] = heights[0] + 0.4  # something above
        got = language.relate_objects(hulls, names=names, heights=heights)
        expected: dict[tuple[int, int], tuple[language.Relation, language.PairHistograms]] = {}
        for i in range(len(hulls)):
            for j in range(i + 1, len(hulls)):
                pair = language.pair_histograms(hulls[i], hulls[j], directions=180)
                ab, ba = language.relations_of_pair(
                    pair,
                    argument=names[i],
                    referent=names[j],
                    a_heights=heights[i],
                    b_heights=heights[j],
                )
                expected[i, j] = (ab, pair)
                expected[j, i] = (ba, pair.reversed())
        order = [(i, j) for i in range(len(hulls)) for j in range(len(hulls)) if i != j]
        assert len(got) == len(order)
        for (i, j), (rel, hist) in zip(order, got, strict=True):
            ref_rel, ref_hist = expected[i, j]
            _assert_same_relation(rel, ref_rel)
            assert (rel.argument, rel.referent) == (names[i], names[j])
            np.testing.assert_array_equal(hist.f0, ref_hist.f0)
            np.testing.assert_array_equal(hist.f2, ref_hist.f2)
            assert hist.hybrid == ref_hist.hybrid
            assert hist.intersection == ref_hist.intersection
            assert (hist.area_a, hist.area_b) == (ref_hist.area_a, ref_hist.area_b)


def test_relate_objects_without_heights_and_on_other_directions() -> None:
    with _one_force_kernel():
        rng = np.random.default_rng(7)
        hulls = [_convex(rng) for _ in range(4)]
        names = ["a", "b", "c", "d"]
        for directions in (8, 36, 360):
            got = language.relate_objects(hulls, names=names, directions=directions)
            order = [(i, j) for i in range(4) for j in range(4) if i != j]
            pair = language.pair_histograms(hulls[1], hulls[2], directions=directions)
            rel, hist = got[order.index((1, 2))]
            _assert_same_relation(rel, language.relation_of_pair(pair, argument="b", referent="c"))
            np.testing.assert_array_equal(hist.f2, pair.f2)
            rel, hist = got[order.index((2, 1))]  # the same sweep, turned by 180°
            back = pair.reversed()
            _assert_same_relation(rel, language.relation_of_pair(back, argument="c", referent="b"))
            np.testing.assert_array_equal(hist.f0, back.f0)


def test_relate_objects_refuses_bad_input() -> None:
    sq = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    with pytest.raises(InputError, match="one label per hull"):
        language.relate_objects([sq, sq + 3], names=["a"])
    with pytest.raises(InputError, match="one array per hull"):
        language.relate_objects([sq, sq + 3], names=["a", "b"], heights=[np.ones(3)])
    with pytest.raises(InputError, match="multiple of 4"):
        language.relate_objects([sq, sq + 3], names=["a", "b"], directions=30)
    with pytest.raises(InputError, match="zero area"):
        language.relate_objects([sq, sq[:3] * [1, 0]], names=["a", "b"])
    with pytest.raises(InputError):
        language.relate_objects([sq, sq + 3], names=["a", " "])
    assert language.relate_objects([sq], names=["a"]) == []


def test_relate_objects_on_a_non_simple_polygon_raises_like_pair_histograms() -> None:
    sq = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    bow = np.array([[0.0, 0.0], [1.0, 1.0], [1.0, 0.0], [0.0, 1.0], [0.5, 2.0]]) + np.array(
        [5.0, 0.0]
    )
    with pytest.raises(InputError) as per_pair:
        language.pair_histograms(sq, bow)
    with pytest.raises(InputError) as all_pairs:
        language.relate_objects([sq, bow], names=["a", "b"])
    assert per_pair.value.problem == all_pairs.value.problem


# -- degrees of truth ----------------------------------------------------------------------


@settings(max_examples=60)
@given(seeds, st.sampled_from([8, 12, 36, 180, 256, 360]))
def test_many_degrees_match_direction_degree_bit_for_bit(seed: int, nbins: int) -> None:
    rng = np.random.default_rng(seed)
    rows = int(rng.integers(1, 12))
    h = rng.exponential(size=(rows, nbins)) * 10.0 ** rng.integers(-6, 6, size=(rows, 1))
    h[rng.random(h.shape) < rng.random()] = 0.0
    if rng.random() < 0.3:  # a sector only, as for objects apart
        h[:, : nbins // 2] = 0.0
    index = rng.integers(0, nbins, rows)
    degree, deviation, effective, contrary = many_degrees(h, index)
    for r in range(rows):
        d = direction_degree(h[r], int(index[r]))
        assert (degree[r], deviation[r], effective[r], contrary[r]) == (
            d.degree,
            d.deviation,
            d.effective,
            d.contrary,
        )


def test_four_degrees_is_unchanged() -> None:
    h = np.random.default_rng(3).exponential(size=180)
    for k, d in enumerate(four_degrees(h).values()):
        assert d == direction_degree(h, 45 * k)


@settings(max_examples=60)
@given(seeds, st.integers(min_value=1, max_value=128))
def test_prefix_sums_match_numpy_bit_for_bit(seed: int, width: int) -> None:
    rng = np.random.default_rng(seed)
    x = rng.exponential(size=(7, width)) * 10.0 ** rng.integers(-8, 8, size=(7, width))
    length = rng.integers(0, width + 1, 7)
    got = _prefix_sums(x, length)
    assert got.tolist() == [float(x[r, : length[r]].sum()) for r in range(7)]


def test_prefix_sums_refuse_long_rows() -> None:
    with pytest.raises(ValueError):
        _prefix_sums(np.ones((1, 129)), np.array([3]))


# -- clipping --------------------------------------------------------------------------------


def _in_convex(points: np.ndarray, clip: np.ndarray, tol: float) -> bool:
    """Whether every point lies in the convex polygon ``clip`` (on its inner side of every edge,
    to ``tol``): the definition, written here independently."""
    c = clip if polygon_area(clip) >= 0 else clip[::-1]
    e = np.roll(c, -1, axis=0) - c
    rel = points[:, None, :] - c[None, :, :]
    cross = e[None, :, 0] * rel[:, :, 1] - e[None, :, 1] * rel[:, :, 0]
    length = np.hypot(e[:, 0], e[:, 1])[None, :]
    return bool(np.all(cross >= -tol * length))


@settings(max_examples=80)
@given(seeds)
def test_clipping_agrees_with_greens_theorem_and_stays_inside(seed: int) -> None:
    """Sutherland-Hodgman clipping against the exact area of Green's theorem (another
    algorithm: boundary pieces inside the other polygon), to a tolerance, and its properties:
    the clipped polygon lies in the clip polygon, its area is at most either area, and a pair
    said to be "clipped away" does not overlap."""
    rng = np.random.default_rng(seed)
    a, b = _scene(rng)[:2]
    for subject, clip in ((a, b), (b, a)):
        if not is_convex(clip):
            continue
        scale = float(np.ptp(np.concatenate([subject, clip]), axis=0).max())
        tol = 1e-9 * max(scale, 1.0) ** 2
        exact = exact_intersection_area(_Ring(subject), _Ring(clip))
        out = _clip_convex(subject, clip)
        got = abs(polygon_area(out)) if len(out) >= 3 else 0.0
        assert got == pytest.approx(exact, abs=tol)
        assert intersection_area(subject, clip) == pytest.approx(exact, abs=tol)
        assert got <= min(abs(polygon_area(subject)), abs(polygon_area(clip))) + tol
        if len(out):
            assert _in_convex(out, clip, 1e-9 * max(scale, 1.0))
        if _clipped_away(subject, clip):
            assert exact <= tol


def test_clipping_a_polygon_by_itself_or_a_box_around_it_keeps_it() -> None:
    rng = np.random.default_rng(12)
    for _ in range(100):
        p = _convex(rng)
        area = abs(polygon_area(p))
        assert abs(polygon_area(_clip_convex(p, p))) == pytest.approx(area, rel=1e-12)
        lo, hi = p.min(axis=0) - 1.0, p.max(axis=0) + 1.0
        box = np.array([lo, [hi[0], lo[1]], hi, [lo[0], hi[1]]])
        assert abs(polygon_area(_clip_convex(p, box))) == pytest.approx(area, rel=1e-12)
        assert intersection_area(p, p + (hi - lo) * 2.0) == 0.0


def test_polygon_area_against_a_triangle_fan_and_convexity_against_hulls() -> None:
    rng = np.random.default_rng(11)
    for _ in range(50):
        p = rng.normal(size=(int(rng.integers(3, 20)), 2))
        u, v = p[1:-1] - p[0], p[2:] - p[0]
        fan = math.fsum(0.5 * (u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]))
        assert polygon_area(p) == pytest.approx(fan, rel=1e-9, abs=1e-12)
        hull = p[ConvexHull(p).vertices]
        assert is_convex(hull) and is_convex(hull[::-1].copy())
    for _ in range(50):
        star = _star(rng)
        # push one vertex towards the centre: a reflex vertex, so not convex
        centre = star.mean(axis=0)
        dent = star.copy()
        dent[0] = centre + 0.05 * (star[0] - centre)
        assert not is_convex(dent)
        assert is_convex(dent[ConvexHull(dent).vertices])


# -- the force histograms of many pairs --------------------------------------------------------


def _regions(rng: np.random.Generator, count: int) -> list[tuple[forces._Region, forces._Region]]:
    out = []
    for _ in range(count):
        a, b = _scene(rng)[:2]
        out.append((forces._polygon_region(a, "a"), forces._polygon_region(b, "b")))
    return out


@settings(max_examples=40)
@given(seeds, st.sampled_from([8, 36, 90, 180, 181, 360]))
def test_many_f0_f2_matches_one_sweep_per_pair(seed: int, directions: int) -> None:
    rng = np.random.default_rng(seed)
    items = _regions(rng, int(rng.integers(1, 8)))
    got = forces._many_f0_f2(items, directions)
    kernels = [forces._Kernel(0.0), forces._Kernel(2.0)]
    for (a, b), h in zip(items, got, strict=True):
        with np.errstate(all="ignore"):
            ref = forces._edge_pair_histograms(a, b, kernels, directions)
        np.testing.assert_array_equal(h, ref)


@settings(max_examples=30)
@given(seeds)
def test_many_f0_and_f2_matches_the_public_functions(seed: int) -> None:
    rng = np.random.default_rng(seed)
    hulls = [_scene(rng)[:2] for _ in range(int(rng.integers(1, 6)))]
    items = [
        (forces._polygon_region(a, "argument"), forces._polygon_region(b, "referent"), True)
        for a, b in hulls
    ]
    for (a, b), (f0, f2, hybrid) in zip(hulls, forces._many_f0_and_f2(items, 180), strict=True):
        try:
            ref0, ref2 = forces.force_histograms(a, b, (0.0, 2.0), 180)
            ref_hybrid = not np.all(np.isfinite(ref2))
        except InputError:
            ref_hybrid = True
        if ref_hybrid:
            ref0 = forces.force_histogram(a, b, r=0.0)
            ref2 = forces.hybrid_histogram(a, b)
        assert hybrid == ref_hybrid
        np.testing.assert_array_equal(f0, ref0)
        np.testing.assert_array_equal(f2, ref2)


def test_f0_f2_pairs_of_objects_apart_are_the_masked_rows() -> None:
    """Where every pair is apart with a finite F2, ``f0_f2_pairs`` returns the sweep's rows
    as views; they are the rows the general path (some pair given F02 directly) copies, bit
    for bit, and index arrays give what index lists give."""
    rng = np.random.default_rng(3)
    sq = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    objs = [forces.prepare(sq * rng.uniform(0.5, 1.5) + [3.0 * k, k % 2], f"{k}") for k in range(5)]
    pairs = [(i, j) for i in range(5) for j in range(i + 1, 5)]
    fast = forces.f0_f2_pairs(objs, directions=36)
    assert not fast.hybrid.any() and not fast.f0.flags.c_contiguous  # the views
    general = forces.f0_f2_pairs(objs, pairs, 36, try_f2=[True] * (len(pairs) - 1) + [False])
    assert general.hybrid.tolist() == [False] * (len(pairs) - 1) + [True]
    assert fast.f0[:-1].tobytes() == general.f0[:-1].tobytes()
    assert fast.f2[:-1].tobytes() == general.f2[:-1].tobytes()
    as_arrays = forces.f0_f2_pairs(objs, np.array(pairs), 36, try_f2=np.ones(len(pairs), bool))
    assert as_arrays.f0.tobytes() == fast.f0.tobytes()
    assert as_arrays.f2.tobytes() == fast.f2.tobytes()


@settings(max_examples=40)
@given(seeds)
def test_pairs_keep_every_overlapping_edge_pair(seed: int) -> None:
    """Leaving out the directions where the objects' shadows are apart loses no edge pair."""
    rng = np.random.default_rng(seed)
    ((a, b),) = _regions(rng, 1)
    theta = 2.0 * np.pi * np.arange(90) / 180
    c, s = np.cos(theta), np.sin(theta)
    pairs = forces._pairs(a, b, c, s)
    found = set(
        zip(
            pairs.direction.tolist(),
            (pairs.a % (len(a.start) + len(b.start))).tolist(),
            (pairs.b % (len(a.start) + len(b.start)) - len(a.start)).tolist(),
            strict=True,
        )
    )
    for d in range(90):
        va = a.start @ [-s[d], c[d]]
        vb = b.start @ [-s[d], c[d]]
        for e in range(len(a.start)):
            lo_e, hi_e = sorted((va[e], va[a.nxt[e]]))
            for f in range(len(b.start)):
                lo_f, hi_f = sorted((vb[f], vb[b.nxt[f]]))
                if min(hi_e, hi_f) - max(lo_e, lo_f) > 1e-9:
                    assert (d, e, f) in found


def test_boxes_apart_is_contacts_first_test() -> None:
    rng = np.random.default_rng(5)
    for _ in range(300):
        a, b = _scene(rng)[:2]
        ra, rb = forces._polygon_region(a, "a"), forces._polygon_region(b, "b")
        lo_a, hi_a = ra.start.min(axis=0), ra.start.max(axis=0)
        lo_b, hi_b = rb.start.min(axis=0), rb.start.max(axis=0)
        scale = float((np.maximum(hi_a, hi_b) - np.minimum(lo_a, lo_b)).max())
        tol = 1e-10 * scale
        apart = bool((lo_a > hi_b + tol).any() or (lo_b > hi_a + tol).any())
        assert (
            forces._boxes_apart(lo_a.tolist(), hi_a.tolist(), lo_b.tolist(), hi_b.tolist()) == apart
        )
        if apart:
            assert forces._contact(ra, rb) == (0.0, False)


# -- the rule base's shared pieces -----------------------------------------------------------


def test_as_histograms_matches_as_histogram() -> None:
    rng = np.random.default_rng(2)
    hs = [rng.exponential(size=180) - 1e-13 for _ in range(6)]
    got = rules._as_histograms(hs, ("f0", "f2"))
    for h, g in zip(hs, got, strict=True):
        np.testing.assert_array_equal(g, rules._as_histogram(h, "f0"))
    bad = [h.copy() for h in hs]
    bad[3][7] = -1.0
    with pytest.raises(InputError) as err:
        rules._as_histograms(bad, ("f0", "f2"))
    assert err.value.source == "f2"
    bad[3][7] = np.nan
    with pytest.raises(InputError, match="non-finite"):
        rules._as_histograms(bad, ("f0", "f2"))


def test_coverage_is_the_same_turned_by_half_a_turn() -> None:
    rng = np.random.default_rng(4)
    t = language.DEFAULT_THRESHOLDS
    for _ in range(300):
        n = int(rng.choice([8, 36, 180, 360]))
        h = rng.exponential(size=n) * (rng.random(n) < rng.random())
        assert rules._coverage(h, t) == rules._coverage(np.roll(h, n // 2), t)


def test_reversed_pair_is_rolled_by_half() -> None:
    sq = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    pair = language.pair_histograms(sq, sq + np.array([2.5, 0.7]), directions=36)
    back = pair.reversed()
    np.testing.assert_array_equal(back.f0, np.roll(pair.f0, 18))
    np.testing.assert_array_equal(back.f2, np.roll(pair.f2, 18))
    assert (back.area_a, back.area_b) == (pair.area_b, pair.area_a)
