"""The compiled force kernel against the NumPy reference, and its fallbacks.

The reference (``scenespeak.spatial.forces.reference``) is the specification; the kernel must
give the same histograms to 1e-9 relative to each histogram's largest bin (bins far below the
peak are sums of terms of both signs, so their rounding error is relative to the peak, not to
themselves). Without Numba the package must run the reference, and a cache directory that
cannot be written must not stop it.
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.typing import NDArray
from skimage.draw import polygon as raster_polygon

from scenespeak.errors import InputError
from scenespeak.spatial import forces
from scenespeak.spatial.forces import _jit, kernel
from scenespeak.spatial.forces.reference import _edge_pair_histograms, _Kernel

Array = NDArray[np.float64]

pytestmark = pytest.mark.skipif(not _jit.available(), reason="numba is not installed")


@pytest.fixture(autouse=True)
def _compiled_kernel(monkeypatch: pytest.MonkeyPatch) -> None:
    """Every sweep of these tests runs compiled (the default policy would run small ones in
    the reference until the process has done enough work to pay for loading Numba)."""
    monkeypatch.setenv(_jit.POLICY_ENV, "always")


KERNELS = [
    (kernel.KernelSpec(0.0), _Kernel(0.0)),
    (kernel.KernelSpec(2.0), _Kernel(2.0)),
    (kernel.KernelSpec(0.5), _Kernel(0.5)),
    (kernel.KernelSpec(1.0), _Kernel(1.0)),
    (kernel.KernelSpec(3.0), _Kernel(3.0)),
    (kernel.KernelSpec(1.5), _Kernel(1.5)),
]


def star(rng: np.random.Generator, n: int, centre: Array, radius: float) -> Array:
    # Jittered regular angles: every gap below pi, so the polygon is simple (star-shaped).
    n = max(n, 4)
    ang = 2 * np.pi * (np.arange(n) + 0.9 * rng.uniform(0, 1, n)) / n
    rad = rng.uniform(0.4 * radius, radius, n)
    return np.column_stack([centre[0] + rad * np.cos(ang), centre[1] + rad * np.sin(ang)])


def assert_close(got: Array, ref: Array, rel: float = 1e-9) -> None:
    scale = np.abs(ref).max(axis=-1, keepdims=True)
    err = np.abs(got - ref) / np.where(scale > 0, scale, 1.0)
    assert float(err.max(initial=0.0)) <= rel, float(err.max())


@settings(max_examples=60, deadline=None)
@given(
    seed=st.integers(0, 2**31),
    n=st.integers(3, 40),
    m=st.integers(3, 40),
    directions=st.sampled_from([36, 90, 180, 181, 45, 37]),
)
def test_kernel_matches_reference_on_disjoint_stars(
    seed: int, n: int, m: int, directions: int
) -> None:
    rng = np.random.default_rng(seed)
    a = forces.prepare(star(rng, n, np.zeros(2), 1.0), "a")
    gap = rng.uniform(2.2, 6.0)
    angle = rng.uniform(0, 2 * np.pi)
    b = forces.prepare(star(rng, m, gap * np.array([np.cos(angle), np.sin(angle)]), 1.0), "b")
    specs = [k for k, _ in KERNELS]
    got = kernel.sweep_pairs([a, b], [(0, 1)], specs, directions)[0]
    with np.errstate(all="ignore"):
        ref = _edge_pair_histograms(a, b, [r for _, r in KERNELS], directions)
    assert_close(got, ref)


@settings(max_examples=60, deadline=None)
@given(
    seed=st.integers(0, 2**31),
    shift=st.tuples(st.floats(-1.2, 1.2), st.floats(-1.2, 1.2)),
    directions=st.sampled_from([36, 180, 37]),
)
def test_kernel_matches_reference_on_overlapping_objects(
    seed: int, shift: tuple[float, float], directions: int
) -> None:
    """Overlapping objects: F0, r = 0.5 and the hybrid F02 (defined there)."""
    rng = np.random.default_rng(seed)
    a = forces.prepare(star(rng, int(rng.integers(3, 30)), np.zeros(2), 1.0), "a")
    b = forces.prepare(star(rng, int(rng.integers(3, 30)), np.array(shift), 1.0), "b")
    y0 = float(rng.uniform(0.01, 0.5))
    specs = [kernel.KernelSpec(0.0), kernel.KernelSpec(0.5), kernel.KernelSpec(2.0, hybrid=True)]
    got = kernel.sweep_pairs([a, b], [(0, 1)], specs, directions, [y0])[0]
    with np.errstate(all="ignore"):
        kernels = [_Kernel(0.0), _Kernel(0.5), _Kernel(2.0, y0)]
        ref = _edge_pair_histograms(a, b, kernels, directions)
    assert_close(got, ref)


def convex_polygon(rng: np.random.Generator, n: int, centre: Array, radius: float) -> Array:
    """Vertices on an ellipse at sorted random angles (convex), either orientation."""
    ang = np.sort(rng.uniform(0, 2 * np.pi, n))
    if np.diff(np.concatenate([ang, ang[:1] + 2 * np.pi])).max() >= np.pi:
        ang = 2 * np.pi * (np.arange(n) + 0.5 * rng.uniform(0, 1, n)) / n
    p = np.column_stack([centre[0] + radius * np.cos(ang), centre[1] + 0.6 * radius * np.sin(ang)])
    return p if rng.uniform() < 0.5 else p[::-1].copy()


@settings(max_examples=60, deadline=None)
@given(
    seed=st.integers(0, 2**31),
    n=st.integers(3, 40),
    m=st.integers(3, 40),
    directions=st.sampled_from([36, 90, 180, 181, 45]),
)
def test_convex_chain_walk_matches_reference(seed: int, n: int, m: int, directions: int) -> None:
    """Two convex regions take the chain merge of ``_convex`` for F0 + F2: against the
    reference, also with a region in the same call that needs the edge tables."""
    rng = np.random.default_rng(seed)
    a = forces.prepare(convex_polygon(rng, n, np.zeros(2), 1.0), "a")
    angle = rng.uniform(0, 2 * np.pi)
    gap = rng.uniform(2.1, 6.0)
    b = forces.prepare(
        convex_polygon(rng, m, gap * np.array([np.cos(angle), np.sin(angle)]), 1.0), "b"
    )
    c = forces.prepare(star(rng, 12, -gap * np.array([np.cos(angle), np.sin(angle)]), 1.0), "c")
    assert a.convex and b.convex
    specs = [kernel.KernelSpec(0.0), kernel.KernelSpec(2.0)]
    got = kernel.sweep_pairs([a, b, c], [(0, 1), (1, 0), (0, 2)], specs, directions)
    with np.errstate(all="ignore"):
        for k, (x, y) in enumerate([(a, b), (b, a), (a, c)]):
            ref = _edge_pair_histograms(x, y, [_Kernel(0.0), _Kernel(2.0)], directions)
            assert_close(got[k], ref)


@pytest.mark.parametrize("start", range(8))
def test_convex_chain_walk_with_level_runs_of_vertices(start: int) -> None:
    """Collinear vertices parallel to the lines (a rectangle with its edges' midpoints), the
    ring starting anywhere: the lowest and highest vertex are found in every direction."""
    ring = np.array(
        [
            [0.0, 0.0],
            [1.0, 0.0],
            [2.0, 0.0],
            [2.0, 0.5],
            [2.0, 1.0],
            [1.0, 1.0],
            [0.0, 1.0],
            [0.0, 0.5],
        ]
    )
    a = forces.prepare(np.roll(ring, start, axis=0), "a")
    b = forces.prepare(np.roll(ring, -start, axis=0) * 0.5 + np.array([3.0, 0.25]), "b")
    assert a.convex and b.convex
    got = kernel.sweep_pairs(
        [a, b], [(0, 1), (1, 0)], [kernel.KernelSpec(0.0), kernel.KernelSpec(2.0)], 8
    )
    for k, (x, y) in enumerate([(a, b), (b, a)]):
        with np.errstate(all="ignore"):
            ref = _edge_pair_histograms(x, y, [_Kernel(0.0), _Kernel(2.0)], 8)
        assert_close(got[k], ref)


F0_F2 = [kernel.KernelSpec(0.0), kernel.KernelSpec(2.0)]


@pytest.mark.parametrize(("n", "m", "directions"), [(150, 320, 180), (200, 200, 36), (400, 120, 8)])
def test_f0_f2_of_large_stars_match_reference(n: int, m: int, directions: int) -> None:
    """Regions of more than ``_table.BUCKET_SORT_FROM`` edges, F0 + F2 (the batched walk of
    ``_batch``): more pairs in a direction than the first buffers hold (they grow), and at 8
    directions so many inversions from one direction to the next that ``_order`` switches to
    the bucket sort."""
    rng = np.random.default_rng(n + m + directions)
    a = forces.prepare(star(rng, n, np.zeros(2), 1.0), "a")
    b = forces.prepare(star(rng, m, np.array([2.4, -0.9]), 1.3), "b")
    got = kernel.sweep_pairs([a, b], [(0, 1), (1, 0)], F0_F2, directions)
    with np.errstate(all="ignore"):
        for k, (x, y) in enumerate([(a, b), (b, a)]):
            assert_close(
                got[k], _edge_pair_histograms(x, y, [_Kernel(0.0), _Kernel(2.0)], directions)
            )


@settings(max_examples=40, deadline=None)
@given(
    seed=st.integers(0, 2**31),
    shift=st.tuples(st.floats(-1.2, 1.2), st.floats(-1.2, 1.2)),
    directions=st.sampled_from([36, 180, 37]),
)
def test_f0_f2_of_overlapping_stars_match_reference(
    seed: int, shift: tuple[float, float], directions: int
) -> None:
    """F0 + F2 of overlapping regions: the edge pairs that cross leave the vectorised loops of
    ``_batch`` and are integrated one at a time, split at the crossing."""
    rng = np.random.default_rng(seed)
    a = forces.prepare(star(rng, int(rng.integers(3, 40)), np.zeros(2), 1.0), "a")
    b = forces.prepare(star(rng, int(rng.integers(3, 40)), np.array(shift), 1.0), "b")
    got = kernel.sweep_pairs([a, b], [(0, 1)], F0_F2, directions)[0]
    with np.errstate(all="ignore"):
        ref = _edge_pair_histograms(a, b, [_Kernel(0.0), _Kernel(2.0)], directions)
    assert np.all(np.isfinite(ref))
    assert_close(got, ref)


def test_edge_pair_buffers_say_how_many_pairs_they_need() -> None:
    """``collect_pairs`` into buffers too small returns minus the pairs needed; grown buffers
    take them all, and the same pairs whatever the first size."""
    from scenespeak.spatial.forces import _batch, _table

    rng = np.random.default_rng(5)
    a = forces.prepare(star(rng, 120, np.zeros(2), 1.0), "a")
    b = forces.prepare(star(rng, 110, np.array([2.2, 0.7]), 1.0), "b")
    pts, nxt, region_start, origin, _ = kernel._packed([a, b])
    size = pts.shape[0]
    srt = np.empty((size, 5))
    scratch = (np.empty((size, 5)), np.arange(size), np.empty((2, 2)), srt, np.empty(size))
    moves = np.full(2, -1, dtype=np.int64)
    _table._tables(1.0, 0.0, pts, nxt, region_start, True, (*scratch, moves), np.ones(2, bool))
    ranges = (0, int(region_start[1]), int(region_start[1]), size)
    shift = (float(origin[1, 1] - origin[0, 1]), float(origin[1, 0] - origin[0, 0]))
    small = _batch.scratch(8)
    needed = _batch.collect_pairs(srt, ranges, shift, small)
    assert needed < -8
    big = _batch.grown(small, -needed)
    n = _batch.collect_pairs(srt, ranges, shift, big)
    assert n == -needed
    roomy = _batch.scratch(10 * n)
    assert _batch.collect_pairs(srt, ranges, shift, roomy) == n
    np.testing.assert_array_equal(big[:, :n], roomy[:, :n])


def test_bitcasts_read_and_make_a_double_from_its_bits() -> None:
    """``_jit.bitcasts`` (compiled: LLVM bitcasts) against NumPy's views."""
    import numba

    from scenespeak.spatial.forces import _batch

    as_int = numba.njit(lambda x: _batch.as_int(x))
    as_float = numba.njit(lambda b: _batch.as_float(b))
    xs = np.array([1.0, 1.5, 2.0**-1022, 3.0e300, 0.1, 7.25])
    bits = xs.view(np.int64)
    assert [as_int(float(x)) for x in xs] == [int(b) for b in bits]
    assert [as_float(int(b)) for b in bits] == [float(x) for x in xs]
    # fdlibm's reduction: x = 2**k (1 + f), 1 + f in [sqrt(2)/2, sqrt(2))
    for x in xs:
        f, k = _batch._reduce(float(x))
        assert math.sqrt(0.5) <= 1.0 + f < math.sqrt(2.0)
        assert (1.0 + f) * 2.0**k == x


def test_bucket_and_insertion_sort_give_the_same_order() -> None:
    """``_order``'s two ways (bucket sort first, or insertion sort alone) leave the same order:
    the stable sort of the previous one, ties included."""
    from scenespeak.spatial.forces import _table

    rng = np.random.default_rng(2)
    n = 300
    tab = np.zeros((n, 5))
    tab[:, 0] = np.round(rng.uniform(0, 4, n), 1)  # many equal keys
    previous = rng.permutation(n)
    orders = []
    for last_moves in (0, 10 * n):  # insertion alone; bucket sort first
        perm = previous.copy()
        moves = np.array([last_moves], dtype=np.int64)
        _table._order(tab, perm, np.empty(n), (0, n), False, moves, 0)
        orders.append(perm)
    np.testing.assert_array_equal(orders[0], orders[1])
    np.testing.assert_array_equal(orders[0], previous[np.argsort(tab[previous, 0], kind="stable")])


def test_kernel_matches_reference_on_masks() -> None:
    shape = (256, 256)
    rng = np.random.default_rng(3)
    masks = []
    for centre in ((70.0, -80.0), (180.0, -170.0)):
        p = star(rng, 60, np.array(centre), 60.0)
        mask = np.zeros(shape, bool)
        rr, cc = raster_polygon(-p[:, 1], p[:, 0], shape)
        mask[rr, cc] = True
        masks.append(mask)
    a, b = (forces.prepare(m, name) for m, name in zip(masks, "ab", strict=True))
    specs = [kernel.KernelSpec(0.0), kernel.KernelSpec(2.0)]
    got = kernel.sweep_pairs([a, b], [(0, 1)], specs, 180)
    ref = _edge_pair_histograms(a, b, [_Kernel(0.0), _Kernel(2.0)], 180)
    assert_close(got[0], ref)


def test_all_pairs_in_one_call_equal_each_pair_alone() -> None:
    """A pair's histograms do not depend on which other pairs share the call."""
    rng = np.random.default_rng(8)
    regions = [
        forces.prepare(star(rng, int(rng.integers(3, 25)), rng.uniform(-6, 6, 2), 1.0), f"o{k}")
        for k in range(7)
    ]
    pairs = [(i, j) for i in range(7) for j in range(7) if i != j]
    specs = [kernel.KernelSpec(0.0), kernel.KernelSpec(0.5)]
    together = kernel.sweep_pairs(regions, pairs, specs, 36)
    for k, (i, j) in enumerate(pairs):
        alone = kernel.sweep_pairs([regions[i], regions[j]], [(0, 1)], specs, 36)[0]
        np.testing.assert_array_equal(together[k], alone)


def test_f0_f2_pairs_match_the_public_functions() -> None:
    rng = np.random.default_rng(11)
    polys = [star(rng, int(rng.integers(3, 20)), rng.uniform(-3, 3, 2), 1.0) for _ in range(6)]
    regions = [forces.prepare(p, f"o{k}") for k, p in enumerate(polys)]
    got = forces.f0_f2_pairs(regions, directions=36)
    pairs = [(i, j) for i in range(6) for j in range(i + 1, 6)]
    assert got.f0.shape == (len(pairs), 36)
    for k, (i, j) in enumerate(pairs):
        try:
            f0, f2 = forces.force_histograms(polys[i], polys[j], directions=36)
            hybrid = not np.all(np.isfinite(f2))
        except InputError:
            hybrid = True
        if hybrid:
            f0 = forces.force_histogram(polys[i], polys[j], r=0.0, directions=36)
            f2 = forces.hybrid_histogram(polys[i], polys[j], directions=36)
        assert bool(got.hybrid[k]) == hybrid
        np.testing.assert_array_equal(got.f0[k], f0)
        np.testing.assert_array_equal(got.f2[k], f2)


def test_without_numba_the_reference_runs(monkeypatch: pytest.MonkeyPatch) -> None:
    rng = np.random.default_rng(5)
    a, b = star(rng, 12, np.zeros(2), 1.0), star(rng, 9, np.array([3.0, 1.0]), 1.0)
    compiled = forces.force_histograms(a, b, directions=90)
    bow = np.array([[0.0, 0.0], [2.0, 0.0], [0.0, 1.0], [2.0, 1.0], [1.0, 3.0]])
    with pytest.raises(InputError, match="cross or touch") as err:
        forces.prepare(bow, "bow")
    message = str(err.value)
    monkeypatch.setenv(_jit.POLICY_ENV, "never")
    assert not forces.compiled()
    plain = forces.force_histograms(a, b, directions=90)
    ra, rb = forces.prepare(a, "a"), forces.prepare(b, "b")
    ref = _edge_pair_histograms(ra, rb, [_Kernel(0.0), _Kernel(2.0)], 90)
    np.testing.assert_array_equal(plain, ref)
    assert_close(compiled, ref)
    # the simplicity check has a NumPy path too, with the same message
    with pytest.raises(InputError) as err:
        forces.prepare(bow, "bow")
    assert str(err.value) == message


def _run(code: str, env: dict[str, str]) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-c", textwrap.dedent(code)],
        env={**os.environ, **env},
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )


def test_numba_disabled_process_never_imports_it() -> None:
    out = _run(
        """
        import sys
        import numpy as np
        from scenespeak.spatial.forces import force_histograms, compiled
        sq = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
        h = force_histograms(sq + [3.0, 0.0], sq, directions=8)
        print(compiled(), "numba" in sys.modules, round(float(h[0, 0]), 12))
        """,
        {_jit.DISABLE_ENV: "1"},
    )
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["False", "False", "1.0"]


def test_importing_the_package_does_not_import_numba() -> None:
    out = _run(
        "import sys, scenespeak.spatial.forces, scenespeak.forces; print('numba' in sys.modules)",
        {},
    )
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "False"


@pytest.mark.slow
def test_unwritable_cache_directory_does_not_crash(tmp_path: os.PathLike[str]) -> None:
    """A cache path that cannot be created (here: below a regular file) is not an error."""
    blocker = os.path.join(tmp_path, "file")
    with open(blocker, "w") as f:
        f.write("not a directory")
    out = _run(
        """
        import numpy as np
        from scenespeak.spatial.forces import force_histograms, compiled
        sq = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
        h = force_histograms(sq + [3.0, 0.0], sq, directions=8)
        print(compiled(), round(float(h[0, 0]), 12))
        """,
        {"NUMBA_CACHE_DIR": os.path.join(blocker, "cache"), _jit.POLICY_ENV: "always"},
    )
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["True", "1.0"]


def test_auto_policy_loads_numba_only_when_the_work_pays_for_it() -> None:
    """A short process stays on the reference; a big sweep loads Numba (``_jit.wanted``)."""
    out = _run(
        """
        import sys
        import numpy as np
        from scenespeak.spatial import forces
        sq = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
        forces.force_histograms(sq + [3.0, 0.0], sq)
        small = "numba" in sys.modules
        objs = [forces.prepare(sq + [3.0 * k, 0.0], f"o{k}") for k in range(90)]
        forces.f0_f2_pairs(objs, directions=180)  # 4005 pairs: about 1.6 s of reference
        print(small, "numba" in sys.modules)
        """,
        {_jit.POLICY_ENV: "auto"},
    )
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["False", "True"]


def test_auto_policy_depends_on_the_call_alone(monkeypatch: pytest.MonkeyPatch) -> None:
    # the same sweep gets the same kernel whatever the process did before (so a service and a
    # one-shot command give the same floats): many small calls never switch, a big one is compiled
    monkeypatch.setenv(_jit.POLICY_ENV, "auto")
    monkeypatch.setattr(_jit, "_numba", lambda: object())  # stands for the module: no import
    per_call = _jit.reference_seconds(1, 60 * 180)
    calls = math.ceil(_jit.LOAD_SECONDS / per_call) + 5  # together more than the load
    assert not any(_jit.wanted(1, 60 * 180) for _ in range(calls))
    assert _jit.wanted(10**4, 10**10)
    assert not _jit.wanted(1, 60 * 180)  # still the reference after a big call
    monkeypatch.setenv(_jit.POLICY_ENV, "never")
    assert not _jit.wanted(10**6, 10**12)


def _random_masks(seed: int, count: int) -> list[NDArray[np.bool_]]:
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(count):
        shape = (int(rng.integers(3, 40)), int(rng.integers(3, 40)))
        out.append(np.pad(rng.random(shape) < rng.uniform(0.2, 0.8), 1))
    return out


def _canonical(rings: list[Array]) -> list[tuple[tuple[float, float], ...]]:
    """Rings as tuples of points starting at their smallest (row, col), sorted."""
    out = []
    for c in rings:
        first = int(np.lexsort((c[:, 1], c[:, 0]))[0])
        out.append(tuple(map(tuple, np.roll(c, -first, axis=0).tolist())))
    return sorted(out)


def test_traced_rings_are_scikit_images_contours(monkeypatch: pytest.MonkeyPatch) -> None:
    """The marching-squares tracer gives find_contours' rings (8-connected objects, the same
    orientation), compiled and in NumPy alike, on random masks with holes and saddles."""
    from skimage.measure import find_contours

    from scenespeak.spatial.forces import _trace

    for padded in _random_masks(0, 150):
        ref = []
        for c in find_contours(
            padded.astype(float), 0.5, fully_connected="high", positive_orientation="high"
        ):
            ref.append(c[:-1] if np.array_equal(c[0], c[-1]) else c)
        monkeypatch.setenv(_jit.POLICY_ENV, "always")
        forces.force_histograms(np.eye(2, dtype=bool), np.eye(2, dtype=bool)[::-1], (0.0,), 4)
        compiled_rings = _trace.rings(padded)
        monkeypatch.setenv(_jit.POLICY_ENV, "never")
        numpy_rings = _trace.rings(padded)
        assert _canonical(compiled_rings) == _canonical(ref)
        assert len(compiled_rings) == len(numpy_rings)
        for x, y in zip(compiled_rings, numpy_rings, strict=True):
            np.testing.assert_array_equal(x, y)
