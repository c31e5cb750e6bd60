"""The sped-up paths of labelling give the same answers as the code they replaced.

* The inverted file's search: the small-table path (``IVFIndex._scan_table``) and the
  cell-by-cell path (``IVFIndex._scan_each``) against the previous search, verbatim, on
  databases full of duplicate descriptors (ties everywhere), bit for bit: distances, ids and
  the order of tied neighbours.
* ``_fit_view`` skips the similarity when it cannot win; ``_plausible`` computes the Jacobian
  at the centre in Python floats: against the previous versions, verbatim.
* ``ObjectDatabase.label`` stops trying an object's views once no view left can beat the best:
  against the previous loop over every view (``max_views`` of them).
"""

from __future__ import annotations

import math
from pathlib import Path

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.typing import NDArray
from skimage import data

from scenespeak.perception import database
from scenespeak.perception.database import IVFIndex, ObjectDatabase, _topk_rows
from scenespeak.perception.features import Features, detect, to_gray

# --------------------------------------------------------------------------------------------
# The inverted file's search
# --------------------------------------------------------------------------------------------


def _reference_search(
    index: IVFIndex, query: NDArray[np.uint8], k: int
) -> tuple[NDArray[np.float32], NDArray[np.int64]]:
    """``IVFIndex._search`` before the small-table path (one thread), verbatim."""
    q = np.ascontiguousarray(query, np.float32)
    nq = q.shape[0]
    nprobe = min(index.nprobe, index.nlist)
    if nq == 0:
        return np.full((0, k), np.inf, np.float32), np.full((0, k), -1, np.int64)
    qn = np.einsum("ij,ij->i", q, q)
    qm2 = q * np.float32(-2.0)
    cd = qm2 @ index.centroids.T
    cd += np.einsum("ij,ij->i", index.centroids, index.centroids)[None, :]
    if nprobe >= index.nlist:
        probes = np.tile(np.arange(index.nlist), (nq, 1))
    elif nprobe <= 8:
        probes = np.empty((nq, nprobe), np.intp)
        rows = np.arange(nq)
        for j in range(nprobe):
            probes[:, j] = np.argmin(cd, axis=1)
            cd[rows, probes[:, j]] = np.inf
    else:
        probes = np.argpartition(cd, nprobe - 1, axis=1)[:, :nprobe]
    flat = probes.ravel()
    order = np.argsort(flat, kind="stable")
    lists = flat[order]
    qidx = order // nprobe
    pair_d = np.full((flat.size, k), np.inf, np.float32)
    pair_i = np.full((flat.size, k), -1, np.int64)
    bounds = np.flatnonzero(np.diff(lists)) + 1
    starts = np.concatenate([[0], bounds])
    ends = np.concatenate([bounds, [lists.size]])
    for a, b in zip(starts.tolist(), ends.tolist(), strict=True):
        cell = int(lists[a])
        lo, hi = int(index._offsets[cell]), int(index._offsets[cell + 1])
        if hi == lo:
            continue
        d = qm2[qidx[a:b]] @ index._data[lo:hi].astype(np.float32).T
        d += index._norms[lo:hi][None, :]
        kk = min(k, hi - lo)
        if kk < hi - lo:
            cols = np.argpartition(d, kk - 1, axis=1)[:, :kk]
            pair_d[a:b, :kk] = d[np.arange(b - a)[:, None], cols]
        else:
            cols = np.broadcast_to(np.arange(hi - lo), d.shape)
            pair_d[a:b, :kk] = d
        pair_i[a:b, :kk] = index._ids[lo + cols]
    back = np.empty_like(order)
    back[order] = np.arange(order.size)
    cand_d = pair_d[back].reshape(nq, nprobe * k)
    cand_i = pair_i[back].reshape(nq, nprobe * k)
    sel = _topk_rows(cand_d, k)
    out_d = np.take_along_axis(cand_d, sel, axis=1)
    out_i = np.take_along_axis(cand_i, sel, axis=1)
    out_d += qn[:, None]
    np.maximum(out_d, 0.0, out=out_d)
    return out_d, out_i


def _assert_same_search(index: IVFIndex, query: NDArray[np.uint8], k: int) -> None:
    want_d, want_i = _reference_search(index, query, k)
    for table_limit, threads in ((1 << 40, 1), (0, 1), (1 << 40, 2), (0, 2)):
        index.table_limit, index.threads = table_limit, threads
        got_d, got_i = index.search(query, k)
        np.testing.assert_array_equal(got_d, want_d)
        np.testing.assert_array_equal(got_i, want_i)
        assert got_d.dtype == np.float32 and got_i.dtype == np.int64


@given(
    n=st.integers(1, 400),
    pool=st.integers(1, 60),
    nlist=st.integers(1, 24),
    nprobe=st.integers(1, 30),
    nq=st.integers(0, 40),
    k=st.integers(1, 20),
    extreme=st.booleans(),
    seed=st.integers(0, 2**16),
)
@settings(max_examples=80)
def test_ivf_search_paths_match_the_reference(
    n: int, pool: int, nlist: int, nprobe: int, nq: int, k: int, extreme: bool, seed: int
) -> None:
    rng = np.random.default_rng(seed)
    # Rows drawn from a small pool: duplicate descriptors, so tied distances everywhere (the
    # order of tied neighbours must be the reference's too). ``extreme``: values near 0 and
    # 255, the largest sums the float32 arithmetic must hold exactly.
    lo, hi = (200, 256) if extreme else (0, 40)
    rows = rng.integers(lo, hi, (pool, 128), dtype=np.uint8)
    base = rows[rng.integers(0, pool, n)]
    if extreme:
        base[rng.random(base.shape) < 0.5] = 0
    query = np.vstack([rows, rng.integers(0, 256, (pool, 128), dtype=np.uint8)])
    query = query[rng.integers(0, len(query), nq)]
    index = IVFIndex(base, nlist=nlist, nprobe=nprobe, seed=seed, iters=3)
    _assert_same_search(index, query, k)


def test_ivf_search_paths_match_on_real_descriptors() -> None:
    feats = [detect(to_gray(img)) for img in (data.astronaut(), data.coffee(), data.chelsea())]
    base = np.vstack([f.descriptors for f in feats] * 2)  # every descriptor twice
    query = detect(to_gray(data.astronaut())[::2, ::2]).descriptors
    index = IVFIndex(base, nlist=32, nprobe=4, seed=0)
    for k in (2, 16):
        _assert_same_search(index, query, k)
        # A few queries visit few cells: those are converted one by one, not all at once.
        _assert_same_search(index, query[:3], k)


@given(st.lists(st.integers(0, 3), max_size=30))
def test_runs_of_equal_values(values: list[int]) -> None:
    starts, ends = database._runs(values)
    assert [v for i, j in zip(starts, ends, strict=True) for v in values[i:j]] == values
    for i, j in zip(starts, ends, strict=True):
        assert j > i and len(set(values[i:j])) == 1
    assert all(values[j - 1] != values[j] for j in ends[:-1])


# --------------------------------------------------------------------------------------------
# The geometric check
# --------------------------------------------------------------------------------------------


def _reference_local_jacobians(
    h: NDArray[np.float64], pts: NDArray[np.float64]
) -> tuple[tuple[NDArray[np.float64], ...], NDArray[np.float64]]:
    x, y = pts[:, 0], pts[:, 1]
    u = h[0, 0] * x + h[0, 1] * y + h[0, 2]
    v = h[1, 0] * x + h[1, 1] * y + h[1, 2]
    w = h[2, 0] * x + h[2, 1] * y + h[2, 2]
    w2 = w**2
    j00 = (h[0, 0] * w - u * h[2, 0]) / w2
    j01 = (h[0, 1] * w - u * h[2, 1]) / w2
    j10 = (h[1, 0] * w - v * h[2, 0]) / w2
    j11 = (h[1, 1] * w - v * h[2, 1]) / w2
    return (j00, j01, j10, j11), w


def _reference_plausible(
    h: NDArray[np.float64], outline: NDArray[np.float32], t_xy: NDArray[np.float64]
) -> bool:
    """``_plausible`` before (the Jacobian at the centre through NumPy), verbatim."""
    if not np.all(np.isfinite(h)):
        return False
    w_of = database._w_of
    if np.any(w_of(h, outline.astype(np.float64)) <= 0) or np.any(w_of(h, t_xy) <= 0):
        return False
    centre = t_xy.mean(axis=0, keepdims=True)
    jc, _ = _reference_local_jacobians(h, centre)
    a = np.array([[jc[0][0], jc[1][0]], [jc[2][0], jc[3][0]]])
    if np.linalg.det(a) <= 0:
        return False
    sv = np.linalg.svd(a, compute_uv=False)
    if sv[1] <= 0 or sv[0] / sv[1] > 8.0:
        return False
    scale = math.sqrt(sv[0] * sv[1])
    return 1.0 / 64.0 <= scale <= 64.0


_reference_fits = [0]  # calls of _reference_fit_view


def _reference_fit_view(
    t_xy: NDArray[np.float64],
    t_size: NDArray[np.float32],
    t_angle: NDArray[np.float32],
    q_xy: NDArray[np.float64],
    q_size: NDArray[np.float32],
    q_angle: NDArray[np.float32],
    outline: NDArray[np.float32],
    *,
    threshold: float,
    homography_min: int,
    max_scale_ratio: float,
    max_angle_deg: float,
) -> tuple[NDArray[np.float64], NDArray[np.bool_], str] | None:
    """``_fit_view`` before (the similarity always fitted), verbatim but for the result type."""
    _reference_fits[0] += 1
    n = t_xy.shape[0]
    best: tuple[NDArray[np.float64], NDArray[np.bool_], str] | None = None
    src = t_xy.astype(np.float32)
    dst = q_xy.astype(np.float32)

    def agree(h: NDArray[np.float64]) -> NDArray[np.bool_]:
        return database._consistent(
            h, t_xy, t_size, t_angle, q_xy, q_size, q_angle, threshold, max_scale_ratio,
            max_angle_deg,
        )  # fmt: skip

    if n >= homography_min:
        h, _ = cv2.findHomography(
            src, dst, cv2.RANSAC, ransacReprojThreshold=threshold, maxIters=2000, confidence=0.999
        )
        if h is not None and _reference_plausible(h, outline, t_xy):
            inl = agree(h)
            if inl.sum() >= 4:
                h2, _ = cv2.findHomography(src[inl], dst[inl], 0)
                if h2 is not None and _reference_plausible(h2, outline, t_xy[inl]):
                    inl2 = agree(h2)
                    if inl2.sum() >= inl.sum():
                        h, inl = h2, inl2
                best = (h / h[2, 2], inl, "homography")
    if n >= 2:
        a, _ = cv2.estimateAffinePartial2D(
            src, dst, method=cv2.RANSAC, ransacReprojThreshold=threshold, maxIters=2000
        )
        if a is not None:
            h = np.vstack([a, [0.0, 0.0, 1.0]])
            if _reference_plausible(h, outline, t_xy):
                inl = agree(h)
                if best is None or inl.sum() > 1.2 * best[1].sum():
                    best = (h, inl, "similarity")
    return best


def _random_homography(rng: np.random.Generator, perspective: float) -> NDArray[np.float64]:
    s, deg = rng.uniform(0.2, 3.0), rng.uniform(-180, 180)
    c, si = s * math.cos(math.radians(deg)), s * math.sin(math.radians(deg))
    h = np.array([[c, -si, rng.uniform(-50, 300)], [si, c, rng.uniform(-50, 300)], [0, 0, 1.0]])
    h[:2, :2] += rng.normal(0, 0.3 * s, (2, 2))  # shear, anisotropy, mirror now and then
    h[2, :2] = rng.normal(0, perspective, 2)
    return h


@given(
    n=st.integers(2, 40),
    inlier_share=st.floats(0.0, 1.0),
    perspective=st.sampled_from([0.0, 1e-4, 2e-3]),
    noise=st.sampled_from([0.0, 0.5, 3.0]),
    seed=st.integers(0, 2**16),
)
def test_fit_view_and_plausible_match_the_reference(
    n: int, inlier_share: float, perspective: float, noise: float, seed: int
) -> None:
    rng = np.random.default_rng(seed)
    h = _random_homography(rng, perspective)
    t_xy = rng.uniform(0, 200, (n, 2))
    q_xy = np.c_[t_xy, np.ones(n)] @ h.T
    q_xy = q_xy[:, :2] / q_xy[:, 2:3] + rng.normal(0, noise, (n, 2))
    out = rng.random(n) > inlier_share
    q_xy[out] = rng.uniform(-100, 400, (int(out.sum()), 2))
    t_size = rng.uniform(1, 10, n).astype(np.float32)
    scale = math.sqrt(abs(np.linalg.det(h[:2, :2])))
    q_size = (t_size * scale * rng.uniform(0.7, 1.4, n)).astype(np.float32)
    t_angle = rng.uniform(0, 360, n).astype(np.float32)
    rot = math.degrees(math.atan2(h[1, 0], h[0, 0]))
    q_angle = ((t_angle + rot + rng.normal(0, 10, n)) % 360).astype(np.float32)
    outline = np.array([[0, 0], [200, 0], [200, 200], [0, 200]], np.float32)
    for candidate in (h, np.eye(3), h * [[1, 1, 1], [1, 1, 1], [1, 1, 50]]):
        assert database._plausible(candidate, outline, t_xy) == _reference_plausible(
            candidate, outline, t_xy
        )
    opts = dict(threshold=4.0, homography_min=12, max_scale_ratio=2.0, max_angle_deg=30.0)
    args = (t_xy, t_size, t_angle, q_xy, q_size, q_angle, outline)
    got = database._fit_view(*args, **opts)  # type: ignore[arg-type]
    want = _reference_fit_view(*args, **opts)  # type: ignore[arg-type]
    if want is None:
        assert got is None
        return
    assert got is not None
    np.testing.assert_array_equal(got.h, want[0])
    np.testing.assert_array_equal(got.inliers, want[1])
    assert got.model == want[2]


# --------------------------------------------------------------------------------------------
# Labelling: an object's views
# --------------------------------------------------------------------------------------------


def _reference_label(
    db: ObjectDatabase, features: Features, *, min_inliers: int = 8, max_views: int = 3
) -> list[tuple[str, int, NDArray[np.float64], NDArray[np.intp], str, int]]:
    """The detections of ``label`` (default options) with every view up to ``max_views`` fitted.

    The loop over an object's views as it was; the matching before it as ``label`` does it.
    """
    db.load()
    loaded = db._loaded
    assert loaded is not None
    ratio, k, need = 0.8, 16, min(min_inliers, 6)
    dist, ids = loaded.index.search(features.descriptors, max(2, min(k, loaded.index.ntotal)))
    nq = len(features)
    valid = ids[:, 0] >= 0
    first_obj = np.where(valid, loaded.object_of[np.maximum(ids[:, 0], 0)], -1)
    obj = np.where(ids >= 0, loaded.object_of[np.maximum(ids, 0)], -1)
    other = (obj != first_obj[:, None]) & (ids >= 0)
    d2 = np.where(other.any(axis=1), dist[np.arange(nq), np.argmax(other, axis=1)], dist[:, -1])
    limit = (ratio * ratio) * d2
    passed = valid & (dist[:, 0] < limit)
    cand = passed[:, None] & (obj == first_obj[:, None]) & (ids >= 0) & (dist < limit[:, None])
    rows, cols = np.nonzero(cand)
    t_all = ids[rows, cols]
    key = rows.astype(np.int64) * (int(loaded.view_of.max()) + 1) + loaded.view_of[t_all]
    _, first = np.unique(key, return_index=True)
    q_idx, t_idx = rows[first].astype(np.intp), t_all[first]
    view = loaded.view_of[t_idx]
    out = []
    for oid in np.unique(first_obj[q_idx]).tolist():
        sel_o = first_obj[q_idx] == oid
        vids, counts = np.unique(view[sel_o], return_counts=True)
        if counts.max() < need:
            continue
        best = None
        for vid in vids[np.argsort(-counts, kind="stable")][:max_views].tolist():
            sel = sel_o & (view == vid)
            if sel.sum() < need:
                break
            qi, ti = q_idx[sel], t_idx[sel]
            outline = loaded.outlines[vid]
            fit = _reference_fit_view(
                loaded.xy[ti].astype(np.float64),
                loaded.size[ti],
                loaded.angle[ti],
                features.xy[qi],
                features.size[qi],
                features.angle[qi],
                outline,
                threshold=4.0,
                homography_min=12,
                max_scale_ratio=2.0,
                max_angle_deg=30.0,
            )
            if fit is None:
                continue
            n_in = int(fit[1].sum())
            if n_in < need or (best is not None and n_in <= best[0]):
                continue
            in_scene = database._apply_h(fit[0], outline.astype(np.float64))
            if n_in < min_inliers and not database._small_enough(
                in_scene, features.xy[qi[fit[1]]], 4000.0, 6
            ):
                continue
            best = (n_in, (loaded.labels[oid], vid, in_scene, np.sort(qi[fit[1]]), fit[2], n_in))
        if best is not None:
            out.append(best[1])
    out.sort(key=lambda d: -d[5])
    return out


def _views_of(img: NDArray[np.uint8]) -> list[NDArray[np.uint8]]:
    """The image and three near-copies (rotated, scaled, cropped): matches split over views."""
    h, w = img.shape
    out = [img]
    for angle, scale in ((4.0, 1.0), (-3.0, 0.9), (0.0, 1.1)):
        m = cv2.getRotationMatrix2D((w / 2, h / 2), angle, scale)
        out.append(cv2.warpAffine(img, m, (w, h), borderMode=cv2.BORDER_REFLECT))
    out.append(img[10:, 15:])
    return out


@pytest.fixture(scope="module")
def many_views(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("views") / "objects.db"
    objects = {
        "astronaut": to_gray(data.astronaut())[30:330, 100:400],
        "coffee": to_gray(data.coffee())[50:350, 150:450],
        "cat": to_gray(data.chelsea())[20:280, 80:380],
    }
    with ObjectDatabase.create(path) as db:
        for name, img in objects.items():
            db.add_object(name, _views_of(img), max_features=300)
    return path


@pytest.mark.parametrize("index", ["exact", "ivf"])
def test_label_tries_fewer_views_with_the_same_result(
    many_views: Path, index: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    background = cv2.resize(to_gray(data.gravel()), (900, 700))
    rng = np.random.default_rng(11)
    photos = {
        "astronaut": (to_gray(data.astronaut())[30:330, 100:400], 0.7),
        "coffee": (to_gray(data.coffee())[50:350, 150:450], 0.35),
        "cat": (to_gray(data.chelsea())[20:280, 80:380], 0.2),
    }
    scenes = []
    for trial in range(2):
        image = background.copy()
        for j, (img, s) in enumerate(photos.values()):
            c, si = s * math.cos(rng.uniform(-0.3, 0.3)), s * math.sin(rng.uniform(-0.3, 0.3))
            h = np.array([[c, -si, 40 + 280 * j], [si, c, rng.uniform(50, 400)], [0, 0, 1.0]])
            h[2, :2] = rng.normal(0, 1e-4 * trial, 2)
            size = (image.shape[1], image.shape[0])
            warped = cv2.warpPerspective(img, h, size)
            mask = cv2.warpPerspective(np.full_like(img, 255), h, size) > 0
            image[mask] = warped[mask]
        scenes.append(detect(image))
    # Training keypoints themselves carried into the background by similarities: every match
    # to the first view is right, so its inliers reach the next views' match counts.
    feats = detect(background)
    for j, (img, s) in enumerate(photos.values()):
        donor = detect(img, max_features=300)
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
    fits = []
    _reference_fits[0] = 0
    original = database._fit_view

    def counting(*args: object, **kwargs: object) -> object:
        fits.append(1)
        return original(*args, **kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr(database, "_fit_view", counting)
    found = set()
    with ObjectDatabase.open(many_views, readonly=True, index=index) as db:  # type: ignore[arg-type]
        for feats in scenes:
            for max_views, min_inliers in ((3, 8), (5, 30)):
                got = db.label(feats, max_views=max_views, min_inliers=min_inliers)
                want = _reference_label(db, feats, min_inliers=min_inliers, max_views=max_views)
                assert len(got.detections) == len(want)
                for det, (label, vid, outline, inliers, model, score) in zip(
                    got.detections, want, strict=True
                ):
                    assert (det.label, det.view_id, det.model, det.score) == (
                        label, vid, model, score,
                    )  # fmt: skip
                    np.testing.assert_array_equal(det.inliers, inliers)
                    np.testing.assert_array_equal(det.outline_in_scene, outline)
                    found.add(label)
    assert found == {"astronaut", "coffee", "cat"}
    assert 0 < len(fits) < _reference_fits[0]  # views were skipped
