"""Labelling's fast paths against small independent references and properties.

* The inverted file's search (every path: the small-table scan, cell by cell, one or two
  threads) against brute force in float64: with every cell probed it is exact search; with
  fewer cells every answer is a true distance, sorted, and never nearer than exact search.
* The geometric check (``verify``): a homography is recovered from exact correspondences with
  outliers; the Jacobians are those of finite differences; implausible maps are refused.
* ``label`` stops trying an object's views once no view left can beat the best: the same
  detections as a plain loop that fits every one of the ``max_views`` views.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.typing import NDArray
from skimage import data

from scenespeak.perception import blas
from scenespeak.perception.features import Features, detect, to_gray
from scenespeak.perception.recognition import IVFIndex, LabelOptions, ObjectDatabase, verify
from scenespeak.perception.recognition import index as index_mod
from scenespeak.perception.recognition import label as label_mod

# --------------------------------------------------------------------------------------------
# The inverted file's search
# --------------------------------------------------------------------------------------------


def _brute(base: NDArray[np.uint8], query: NDArray[np.uint8]) -> NDArray[np.float64]:
    """All squared distances, float64 (exact for uint8 descriptors)."""
    b = base.astype(np.float64)
    q = query.astype(np.float64)
    return ((q[:, None, :] - b[None, :, :]) ** 2).sum(axis=2)


def _all_paths(index: IVFIndex, query: NDArray[np.uint8], k: int):  # type: ignore[no-untyped-def]
    """The search by every internal path; they must agree with each other bit for bit."""
    results = []
    for table_limit, threads in ((1 << 40, 1), (0, 1), (1 << 40, 2), (0, 2)):
        index.table_limit, index.threads = table_limit, threads
        d, i = index.search(query, k)
        assert d.dtype == np.float32 and i.dtype == np.int64
        results.append((d, i))
    for d, i in results[1:]:
        np.testing.assert_array_equal(d, results[0][0])
        np.testing.assert_array_equal(i, results[0][1])
    return results[0]


def _check_against_brute(
    base: NDArray[np.uint8], query: NDArray[np.uint8], k: int, d: NDArray, i: NDArray, exact: bool
) -> None:
    true = _brute(base, query)
    exact_k = np.sort(true, axis=1)[:, :k]
    for row in range(query.shape[0]):
        found = i[row] >= 0
        ids = i[row][found]
        assert len(set(ids.tolist())) == ids.size  # no neighbour twice
        # every answer is a true distance, nearest first
        np.testing.assert_allclose(d[row][found], true[row, ids], rtol=1e-6, atol=0.5)
        assert np.all(np.diff(d[row][found]) >= 0)
        assert np.all(np.isinf(d[row][~found]))
        # never nearer than exact search; equal to it when every cell is probed
        np.testing.assert_array_less(exact_k[row, : ids.size] - 0.5, d[row][found])
        if exact:
            assert ids.size == min(k, base.shape[0])
            np.testing.assert_allclose(d[row][found], exact_k[row, : ids.size], atol=0.5)


@given(
    n=st.integers(1, 300),
    pool=st.integers(1, 40),
    nlist=st.integers(1, 16),
    nprobe=st.integers(1, 20),
    nq=st.integers(0, 30),
    k=st.integers(1, 20),
    extreme=st.booleans(),
    seed=st.integers(0, 2**16),
)
@settings(max_examples=60, deadline=None)
def test_ivf_search_against_brute_force(
    n: int, pool: int, nlist: int, nprobe: int, nq: int, k: int, extreme: bool, seed: int
) -> None:
    rng = np.random.default_rng(seed)
    # Rows drawn from a small pool: duplicate descriptors, so tied distances everywhere.
    # ``extreme``: values near 0 and 255, the largest sums float32 must hold exactly.
    lo, hi = (200, 256) if extreme else (0, 40)
    rows = rng.integers(lo, hi, (pool, 128), dtype=np.uint8)
    base = rows[rng.integers(0, pool, n)]
    if extreme:
        base[rng.random(base.shape) < 0.5] = 0
    query = np.vstack([rows, rng.integers(0, 256, (pool, 128), dtype=np.uint8)])
    query = query[rng.integers(0, len(query), nq)]
    index = IVFIndex(base, nlist=nlist, nprobe=nprobe, seed=seed, iters=3)
    d, i = _all_paths(index, query, k)
    _check_against_brute(base, query, k, d, i, exact=nprobe >= index.nlist)


def test_ivf_search_on_real_descriptors() -> None:
    feats = [detect(to_gray(img)) for img in (data.astronaut(), data.coffee())]
    base = np.vstack([f.descriptors for f in feats] * 2)  # every descriptor twice
    query = detect(to_gray(data.astronaut())[::2, ::2]).descriptors[:60]
    for nprobe in (4, 32):
        index = IVFIndex(base, nlist=32, nprobe=nprobe, seed=0)
        for q in (query, query[:3]):  # a few queries: cells converted one by one
            d, i = _all_paths(index, q, 16)
            _check_against_brute(base, q, 16, d, i, exact=nprobe >= 32)


@given(st.lists(st.integers(0, 3), max_size=30))
def test_runs_of_equal_values(values: list[int]) -> None:
    starts, ends = index_mod._runs(values)
    assert [v for i, j in zip(starts, ends, strict=True) for v in values[i:j]] == values
    for i, j in zip(starts, ends, strict=True):
        assert j > i and len(set(values[i:j])) == 1
    assert all(values[j - 1] != values[j] for j in ends[:-1])


# --------------------------------------------------------------------------------------------
# The geometric check
# --------------------------------------------------------------------------------------------


def _random_homography(rng: np.random.Generator, perspective: float) -> NDArray[np.float64]:
    s, deg = rng.uniform(0.4, 2.5), rng.uniform(-180, 180)
    c, si = s * math.cos(math.radians(deg)), s * math.sin(math.radians(deg))
    h = np.array([[c, -si, rng.uniform(0, 300)], [si, c, rng.uniform(0, 300)], [0, 0, 1.0]])
    h[:2, :2] += rng.normal(0, 0.05 * s, (2, 2))
    h[2, :2] = rng.normal(0, perspective, 2)
    return h


def _apply(h: NDArray[np.float64], xy: NDArray[np.float64]) -> NDArray[np.float64]:
    p = np.c_[xy, np.ones(len(xy))] @ h.T
    return p[:, :2] / p[:, 2:3]


@given(
    n=st.integers(20, 60),
    outliers=st.floats(0.0, 0.3),
    perspective=st.sampled_from([0.0, 1e-4, 5e-4]),
    seed=st.integers(0, 2**16),
)
@settings(deadline=None)
def test_fit_view_recovers_a_homography(
    n: int, outliers: float, perspective: float, seed: int
) -> None:
    rng = np.random.default_rng(seed)
    h = _random_homography(rng, perspective)
    t_xy = rng.uniform(0, 200, (n, 2))
    q_xy = _apply(h, t_xy)
    bad = rng.random(n) < outliers
    q_xy[bad] += rng.uniform(30, 80, (int(bad.sum()), 2)) * rng.choice([-1, 1], (int(bad.sum()), 2))
    t_size = rng.uniform(1, 10, n).astype(np.float32)
    (j00, j01, j10, j11), _ = verify._local_jacobians(h, t_xy)
    q_size = (t_size * np.sqrt(np.abs(j00 * j11 - j01 * j10))).astype(np.float32)
    t_angle = rng.uniform(0, 360, n).astype(np.float32)
    rot = np.degrees(np.arctan2(j10 - j01, j00 + j11))
    q_angle = ((t_angle + rot) % 360).astype(np.float32)
    outline = np.array([[0, 0], [200, 0], [200, 200], [0, 200]], np.float32)
    fit = verify._fit_view(
        verify._Keys(t_xy, t_size, t_angle),
        verify._Keys(q_xy, q_size, q_angle),
        outline,
        LabelOptions(),
    )
    assert fit is not None
    assert np.all(fit.inliers[~bad])  # every true correspondence is an inlier
    assert fit.inliers[bad].sum() <= 1  # an outlier 30+ px off agrees only by chance
    corners = outline.astype(np.float64)
    np.testing.assert_allclose(verify._apply_h(fit.h, corners), _apply(h, corners), atol=0.05)


def test_local_jacobians_are_the_derivatives() -> None:
    rng = np.random.default_rng(3)
    for _ in range(50):
        h = _random_homography(rng, 1e-3)
        pts = rng.uniform(0, 200, (10, 2))
        (j00, j01, j10, j11), w = verify._local_jacobians(h, pts)
        np.testing.assert_allclose(w, verify._w_of(h, pts))
        eps = 1e-4
        ex, ey = np.array([eps, 0.0]), np.array([0.0, eps])
        dx = (_apply(h, pts + ex) - _apply(h, pts - ex)) / (2 * eps)
        dy = (_apply(h, pts + ey) - _apply(h, pts - ey)) / (2 * eps)
        np.testing.assert_allclose(np.c_[j00, j10], dx, rtol=1e-5, atol=1e-7)
        np.testing.assert_allclose(np.c_[j01, j11], dy, rtol=1e-5, atol=1e-7)


def test_implausible_maps_are_refused() -> None:
    outline = np.array([[0, 0], [200, 0], [200, 150], [0, 150]], np.float32)
    t_xy = np.random.default_rng(0).uniform(0, 150, (30, 2))
    assert verify._plausible(np.eye(3), outline, t_xy)
    assert verify._plausible(np.diag([2.0, 2.0, 1.0]), outline, t_xy)
    assert not verify._plausible(np.diag([-1.0, 1.0, 1.0]), outline, t_xy)  # mirror
    assert not verify._plausible(np.diag([100.0, 100.0, 1.0]), outline, t_xy)  # zoom
    assert not verify._plausible(np.diag([1 / 100, 1 / 100, 1.0]), outline, t_xy)
    assert not verify._plausible(np.diag([9.0, 1.0, 1.0]), outline, t_xy)  # anisotropy
    folded = np.array([[1.0, 0, 0], [0, 1, 0], [-0.01, 0, 1]])  # w < 0 beyond x = 100
    assert not verify._plausible(folded, outline, t_xy)
    assert not verify._plausible(np.full((3, 3), np.nan), outline, t_xy)


def test_consistent_checks_position_scale_and_angle() -> None:
    rng = np.random.default_rng(5)
    t_xy = rng.uniform(0, 100, (4, 2))
    h = np.diag([2.0, 2.0, 1.0])
    keys = verify._Keys(t_xy, np.full(4, 3.0, np.float32), np.full(4, 10.0, np.float32))
    q_xy = 2.0 * t_xy
    q_xy[1] += 5.0  # 7 px off: beyond the 4 px tolerance
    q_size = np.array([6.0, 6.0, 13.0, 6.0], np.float32)  # [2]: 4.3x the scale of 2x the view
    q_angle = np.array([10.0, 10.0, 10.0, 50.0], np.float32)  # [3]: turned by 40 degrees
    ok = verify._consistent(h, keys, verify._Keys(q_xy, q_size, q_angle), LabelOptions())
    assert ok.tolist() == [True, False, False, False]


def test_blas_limit_is_reused_and_restores() -> None:
    threadpoolctl = pytest.importorskip("threadpoolctl")

    def blas_threads() -> list[int]:
        return [
            i["num_threads"] for i in threadpoolctl.threadpool_info() if i["user_api"] == "blas"
        ]

    before = blas_threads()
    with blas.single_threaded_blas():
        assert all(n == 1 for n in blas_threads())
    assert blas_threads() == before
    assert blas._blas_controller(len(sys.modules)) is blas._blas_controller(len(sys.modules))


# --------------------------------------------------------------------------------------------
# Labelling: an object's views
# --------------------------------------------------------------------------------------------


def _every_view(db: ObjectDatabase, features: Features, o: LabelOptions) -> list[tuple]:
    """The detections when each object's ``max_views`` most matched views are all fitted.

    A plain loop: fit every view (needing ``need`` inliers), keep the one with the most
    inliers (the first on ties), then sort the objects by their inliers.
    """
    db.load()
    loaded = db._loaded
    assert loaded is not None
    need = min(o.min_inliers, o.min_inliers_small) if o.small_area > 0 else o.min_inliers
    c = label_mod._ratio_candidates(loaded, features, o)
    out = []
    for oid in np.unique(c.first_obj[c.q_idx]).tolist():
        sel_o = c.first_obj[c.q_idx] == oid
        vids, counts = np.unique(c.view[sel_o], return_counts=True)
        dets = []
        for vid in vids[np.argsort(-counts, kind="stable")][: o.max_views].tolist():
            sel = sel_o & (c.view == vid)
            det = label_mod._detect_in_view(
                loaded, features, c.q_idx[sel], c.t_idx[sel], (oid, vid), o, need - 1
            )
            if det is not None:
                dets.append(det)
        if dets:
            best = max(dets, key=lambda d: d.score)  # max keeps the first of equal scores
            out.append(best)
    out.sort(key=lambda d: -d.score)
    return [(d.label, d.view_id, d.model, d.score, d.inliers, d.outline_in_scene) for d in out]


def _views_of(img: NDArray[np.uint8]) -> list[NDArray[np.uint8]]:
    """The image and near-copies (rotated, scaled, cropped): matches split over views."""
    h, w = img.shape
    out = [img]
    for angle, scale in ((4.0, 1.0), (-3.0, 0.9), (0.0, 1.1)):
        m = cv2.getRotationMatrix2D((w / 2, h / 2), angle, scale)
        out.append(cv2.warpAffine(img, m, (w, h), borderMode=cv2.BORDER_REFLECT))
    out.append(img[10:, 15:])
    return out


_PHOTOS = {
    "astronaut": (lambda: to_gray(data.astronaut())[30:330, 100:400], 0.7),
    "coffee": (lambda: to_gray(data.coffee())[50:350, 150:450], 0.35),
    "cat": (lambda: to_gray(data.chelsea())[20:280, 80:380], 0.2),
}


@pytest.fixture(scope="module")
def many_views(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("views") / "objects.db"
    with ObjectDatabase.create(path) as db:
        for name, (img, _) in _PHOTOS.items():
            db.add_object(name, _views_of(img()), max_features=300)
    return path


def _scenes() -> list[Features]:
    background = cv2.resize(to_gray(data.gravel()), (900, 700))
    rng = np.random.default_rng(11)
    scenes = []
    for trial in range(2):
        image = background.copy()
        for j, (img, s) in enumerate(_PHOTOS.values()):
            c, si = s * math.cos(rng.uniform(-0.3, 0.3)), s * math.sin(rng.uniform(-0.3, 0.3))
            h = np.array([[c, -si, 40 + 280 * j], [si, c, rng.uniform(50, 400)], [0, 0, 1.0]])
            h[2, :2] = rng.normal(0, 1e-4 * trial, 2)
            size = (image.shape[1], image.shape[0])
            warped = cv2.warpPerspective(img(), h, size)
            mask = cv2.warpPerspective(np.full_like(img(), 255), h, size) > 0
            image[mask] = warped[mask]
        scenes.append(detect(image))
    # Training keypoints themselves carried into the background by similarities: every match
    # to the first view is right, so its inliers reach the next views' match counts.
    feats = detect(background)
    for j, (img, s) in enumerate(_PHOTOS.values()):
        donor = detect(img(), max_features=300)
        c, si = s * math.cos(0.2 * j), s * math.sin(0.2 * j)
        xy = donor.xy @ np.array([[c, si], [-si, c]]) + [40 + 280 * j, 200]
        feats = Features(
            xy=np.vstack([feats.xy, xy]),
            size=np.concatenate([feats.size, donor.size * np.float32(s)]),
            angle=np.concatenate(
                [feats.angle, (donor.angle + np.float32(math.degrees(0.2 * j))) % 360]
            ),
            response=np.concatenate([feats.response, donor.response]),
            octave=np.concatenate([feats.octave, donor.octave]),
            descriptors=np.vstack([feats.descriptors, donor.descriptors]),
        )
    scenes.append(feats)
    return scenes


@pytest.mark.parametrize("kind", ["exact", "ivf"])
def test_label_skips_views_with_the_same_result(
    many_views: Path, kind: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    fits: list[int] = []
    original = label_mod._fit_view

    def counting(*args, **kwargs):  # type: ignore[no-untyped-def]
        fits.append(1)
        return original(*args, **kwargs)

    monkeypatch.setattr(label_mod, "_fit_view", counting)
    found = set()
    every, skipping = 0, 0
    with ObjectDatabase.open(many_views, readonly=True, index=kind) as db:  # type: ignore[arg-type]
        for feats in _scenes():
            for max_views, min_inliers in ((3, 8), (5, 30)):
                # one instance per label, as the every-view reference looks for
                o = LabelOptions(max_views=max_views, min_inliers=min_inliers, max_instances=1)
                fits.clear()
                want = _every_view(db, feats, o)
                every += len(fits)
                fits.clear()
                got = db.label(feats, o)
                skipping += len(fits)
                assert len(got.detections) == len(want)
                for det, (lab, vid, model, score, inliers, outline) in zip(
                    got.detections, want, strict=True
                ):
                    assert (det.label, det.view_id, det.model, det.score) == (
                        lab,
                        vid,
                        model,
                        score,
                    )
                    np.testing.assert_array_equal(det.inliers, inliers)
                    np.testing.assert_allclose(det.outline_in_scene, outline)
                    found.add(lab)
    assert 0 < skipping < every  # views were skipped
    assert found == {"astronaut", "coffee", "cat"}


def test_label_options_refuse_unknown_keywords(many_views: Path) -> None:
    from scenespeak.errors import InputError

    with ObjectDatabase.open(many_views, readonly=True) as db:
        with pytest.raises(InputError, match="min_inlier"):
            db.label(_scenes()[0], min_inlier=5)
