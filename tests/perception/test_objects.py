"""Objects stage: projection, outlier removal, unknown clustering, convex hull, degenerate sets."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from scenespeak.errors import CalibrationError
from scenespeak.perception.objects import (
    SLIVER_WIDTH,
    SceneObject,
    Skipped,
    build_objects,
    cluster_unknown,
    convex_hull,
    dbscan,
    heights_along,
    main_cluster,
    make_object,
    plane_basis,
    project_to_plane,
    radius_inliers,
)


def _pitch_up(deg: float) -> np.ndarray:
    """Up in the frame of a camera pitched down by ``deg`` degrees."""
    a = np.radians(deg)
    # A camera looking down by a sees the world's up tilted towards its forward axis (-Y, +Z).
    return np.array([0.0, -np.cos(a), np.sin(a)])


def _signed_area(poly: np.ndarray) -> float:
    x, y = poly[:, 0], poly[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def test_level_rig_plane_is_x_and_z() -> None:
    pts = np.array([[0.1, 0.2, 1.5], [-0.3, -0.1, 0.7]])
    assert np.allclose(project_to_plane(pts), pts[:, [0, 2]])
    assert np.allclose(heights_along(pts), -pts[:, 1])


def test_pitched_rig_floor_has_one_height_and_depth_grows() -> None:
    up = _pitch_up(20.0)
    basis = plane_basis(up)
    assert np.allclose(basis @ basis.T, np.eye(3), atol=1e-12)
    # A floor 0.4 m below the camera: points p with p·up = -0.4, spread along right and forward.
    x_axis, y_axis = basis[0], basis[1]
    floor = np.array(
        [a * x_axis + b * y_axis - 0.4 * basis[2] for a in (-0.2, 0.2) for b in (1, 2)]
    )
    assert np.allclose(heights_along(floor, up), -0.4)
    xy = project_to_plane(floor, up)
    assert np.allclose(xy, [[-0.2, 1], [-0.2, 2], [0.2, 1], [0.2, 2]])
    # Scaling up does not change anything.
    assert np.allclose(project_to_plane(floor, 5 * up), xy)


@pytest.mark.parametrize("bad", [[0, 0, 0], [np.nan, -1, 0], [1, 2]])
def test_bad_up_is_a_calibration_error(bad: list[float]) -> None:
    with pytest.raises(CalibrationError, match="up"):
        project_to_plane([[0, 0, 1]], bad)


def test_radius_inliers_is_the_papers_median_filter() -> None:
    rng = np.random.default_rng(3)
    cluster = rng.normal([0.0, 1.0], 0.02, (50, 2))
    far = np.array([[0.8, 1.0], [0.0, 2.5]])
    keep = radius_inliers(np.vstack([cluster, far]), radius=0.3)
    assert keep[:50].all()
    assert not keep[50:].any()


def test_main_cluster_keeps_the_biggest_group() -> None:
    rng = np.random.default_rng(4)
    big = rng.normal([0.0, 1.0], 0.01, (40, 2))
    small = rng.normal([0.3, 1.0], 0.01, (10, 2))
    keep = main_cluster(np.vstack([small, big]), eps=0.03, min_samples=3)
    assert keep[10:].all() and not keep[:10].any()


def test_main_cluster_all_noise_keeps_everything() -> None:
    keep = main_cluster([[0, 0], [1, 1], [2, 2]], eps=0.01, min_samples=3)
    assert keep.all()


def test_convex_hull_of_a_square_with_inner_points() -> None:
    pts = np.array([[0, 0], [1, 0], [1, 1], [0, 1], [0.5, 0.5], [0.2, 0.7]], float)
    h = convex_hull(pts)
    assert h.degenerate is None
    assert {tuple(v) for v in h.polygon} == {(0, 0), (1, 0), (1, 1), (0, 1)}
    assert _signed_area(h.polygon) == pytest.approx(1.0)  # counter-clockwise


@pytest.mark.parametrize(
    ("pts", "kind", "length"),
    [
        ([[0.2, 1.0]], "point", SLIVER_WIDTH),
        ([[0.2, 1.0], [0.2, 1.0], [0.2, 1.0]], "point", SLIVER_WIDTH),
        ([[0.0, 1.0], [0.1, 1.1]], "two points", np.hypot(0.1, 0.1)),
        ([[0.0, 1.0], [0.05, 1.0], [0.3, 1.0]], "collinear", 0.3),
        ([[0.0, 1.0], [0.0, 1.2], [0.0, 1.1], [0.0, 1.05]], "collinear", 0.2),
    ],
)
def test_degenerate_hulls_become_slivers(pts: list[list[float]], kind: str, length: float) -> None:
    h = convex_hull(pts)
    assert h.degenerate == kind
    assert h.polygon.shape == (4, 2)
    area = _signed_area(h.polygon)
    assert area == pytest.approx(length * SLIVER_WIDTH, rel=1e-6)
    # The sliver is centred on the middle of the points' extent.
    p = np.asarray(pts, float)
    mid = (p.min(axis=0) + p.max(axis=0)) / 2
    assert np.allclose(h.polygon.mean(axis=0), mid, atol=1e-9)


def test_convex_hull_rejects_empty_and_nan() -> None:
    with pytest.raises(ValueError, match="at least one"):
        convex_hull(np.zeros((0, 2)))
    with pytest.raises(ValueError, match="NaN"):
        convex_hull([[0, 0], [np.nan, 1], [1, 1]])


@given(
    arrays(
        np.float64,
        st.tuples(st.integers(1, 30), st.just(2)),
        elements=st.floats(-5, 5, allow_nan=False, width=32),
    )
)
def test_hull_property_contains_all_points_and_is_ccw(pts: np.ndarray) -> None:
    h = convex_hull(pts)
    poly = h.polygon
    assert poly.shape[0] >= 3
    assert _signed_area(poly) > 0
    # Every input point is inside (or on) the polygon: all edge cross products >= -tol.
    a = poly
    b = np.roll(poly, -1, axis=0)
    for p in pts:
        cross = (b[:, 0] - a[:, 0]) * (p[1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (p[0] - a[:, 0])
        assert np.all(cross >= -1e-7 * (1 + np.abs(pts).max()) ** 2)


def test_make_object_keeps_the_cluster_and_reports_outliers() -> None:
    rng = np.random.default_rng(5)
    mug = rng.normal([0.1, 0.0, 1.0], 0.015, (60, 3))
    stray = np.array([[0.9, 0.0, 2.5], [0.1, 0.0, 1.4]])
    obj = make_object("mug", np.vstack([mug, stray]))
    assert isinstance(obj, SceneObject)
    assert obj.n_points == 60
    assert any("2 outlier points removed" in n for n in obj.notes)
    assert np.allclose(obj.centroid, mug.mean(axis=0))
    assert np.allclose(obj.plane_centroid, mug[:, [0, 2]].mean(axis=0))
    assert obj.heights.shape == (60,)


def test_make_object_with_too_few_points_is_skipped_with_a_reason() -> None:
    res = make_object("can", [[0.1, 0, 1.0], [0.11, 0, 1.0]])
    assert res == Skipped("can", "only 2 points (at least 3 needed for a hull)")
    res = make_object("can", [[0.1, 0, 1.0], [0.11, 0, 1.0], [2.0, 0, 3.0]], radius=0.3)
    assert isinstance(res, Skipped)
    assert res.reason.startswith("only 2 points left after outlier removal")
    assert make_object("can", np.zeros((0, 3))) == Skipped("can", "no 3-D points")
    assert make_object("can", [[np.nan, 0, 1]]) == Skipped("can", "no 3-D points")


def test_make_object_collinear_points_are_reported() -> None:
    pts = [[0.0, 0.0, 1.0], [0.05, 0.0, 1.0], [0.1, 0.0, 1.0]]
    obj = make_object("card", pts)
    assert isinstance(obj, SceneObject)
    assert any("degenerate hull (collinear)" in n for n in obj.notes)
    two = make_object("card", pts[:2], min_points=2)
    assert isinstance(two, SceneObject)
    assert any("two points" in n for n in two.notes)


def test_make_object_subsamples_dense_points() -> None:
    rng = np.random.default_rng(6)
    pts = rng.normal([0, 0, 1.5], 0.02, (10_000, 3))
    obj = make_object("box", pts, source="dense", max_points=1000)
    assert isinstance(obj, SceneObject)
    assert obj.source == "dense"
    assert obj.n_points <= 1000
    assert "1000 of 10000 points used" in obj.notes


def test_cluster_unknown_drops_noise_and_wide_surfaces() -> None:
    rng = np.random.default_rng(7)
    box = rng.normal([0.2, 0.0, 1.0], 0.01, (30, 3))
    book = rng.normal([-0.2, 0.0, 1.2], 0.01, (30, 3))
    noise = rng.uniform([-1, 0, 0.5], [1, 0, 3], (5, 3))
    gx, gz = np.meshgrid(np.linspace(-1, 1, 40), np.linspace(0.5, 3, 40))
    floor = np.column_stack([gx.ravel(), np.full(gx.size, 0.4), gz.ravel()])
    labels = cluster_unknown(np.vstack([box, book, noise, floor]))
    assert set(labels[:30]) == {1}  # the box is on the right: numbered after the book
    assert set(labels[30:60]) == {0}
    assert (labels[60:] == -1).mean() > 0.95


def test_build_objects_known_and_unknown() -> None:
    rng = np.random.default_rng(8)
    hat = rng.normal([-0.2, 0.0, 1.2], 0.02, (40, 3))
    mug = rng.normal([0.2, 0.0, 1.0], 0.02, (40, 3))
    thing = rng.normal([0.0, 0.0, 1.6], 0.01, (20, 3))
    can = np.array([[0.5, 0.0, 1.5], [0.51, 0.0, 1.5]])
    xyz = np.vstack([hat, mug, thing, can])
    labels: list[str | None] = ["hat"] * 40 + ["mug"] * 40 + [None] * 20 + ["can"] * 2
    objects, skipped = build_objects(xyz, labels)
    assert [o.label for o in objects] == ["hat", "mug", "unknown object 1"]
    assert objects[2].source == "clustered"
    assert skipped == [Skipped("can", "only 2 points (at least 3 needed for a hull)")]
    objects, _ = build_objects(xyz, labels, unknown=False)
    assert [o.label for o in objects] == ["hat", "mug"]
    with pytest.raises(ValueError, match="labels"):
        build_objects(xyz, labels[:-1])


@given(
    arrays(
        np.float64,
        st.tuples(st.integers(1, 60), st.just(2)),
        elements=st.floats(0, 1, allow_nan=False, width=32),
    ),
    st.floats(0.02, 0.3),
    st.integers(1, 5),
)
def test_dbscan_matches_scikit_learn(pts: np.ndarray, eps: float, min_samples: int) -> None:
    from sklearn.cluster import DBSCAN

    ours = dbscan(pts, eps=eps, min_samples=min_samples)
    model = DBSCAN(eps=eps, min_samples=min_samples).fit(pts)
    ref = model.labels_
    # Noise is the same set, and core points are grouped the same way (a border point may go
    # to either neighbouring cluster in scikit-learn, depending on its visiting order).
    assert np.array_equal(ours == -1, ref == -1)
    core = np.zeros(len(pts), bool)
    core[model.core_sample_indices_] = True
    a, b = ours[core], ref[core]
    assert np.array_equal(a[:, None] == a[None, :], b[:, None] == b[None, :])


@pytest.mark.parametrize("n", [300, 1300])
def test_dbscan_small_and_large_paths_agree_with_scikit_learn(n: int) -> None:
    # up to 1,200 points dbscan works on the distance matrix, beyond on a k-d tree
    from sklearn.cluster import DBSCAN

    rng = np.random.default_rng(n)
    centres = rng.uniform(0, 1, (4, 2))
    pts = np.vstack([rng.normal(c, 0.02, (n // 5, 2)) for c in centres])
    pts = np.vstack([pts, rng.uniform(0, 1, (n - len(pts), 2))])  # and scattered noise
    ours = dbscan(pts, eps=0.02, min_samples=4)
    model = DBSCAN(eps=0.02, min_samples=4).fit(pts)
    assert np.array_equal(ours == -1, model.labels_ == -1)
    core = np.zeros(n, bool)
    core[model.core_sample_indices_] = True
    a, b = ours[core], model.labels_[core]
    assert np.array_equal(a[:, None] == a[None, :], b[:, None] == b[None, :])
    # clusters are numbered by their first core point
    firsts = [int(np.flatnonzero(core & (ours == k))[0]) for k in range(ours.max() + 1)]
    assert firsts == sorted(firsts)
