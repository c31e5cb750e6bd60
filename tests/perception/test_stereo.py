"""Stereo matching and triangulation: the Middlebury motorcycle pair with ground truth,
synthetic rigs with known points, dense regions, bad pairs, JSON and PLY output."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest
from skimage import data

from scenespeak.errors import CalibrationError, ImageError
from scenespeak.perception.calibration import (
    CalibrationMismatchError,
    StereoRig,
    rectify,
    rig_from_short,
)
from scenespeak.perception.features import Features
from scenespeak.perception.stereo import (
    Points3D,
    StereoResult,
    check_pair,
    dense_disparity,
    load_pair,
    match_stereo,
    points_to_json,
    region_points,
    stereo_points,
    triangulate,
    write_ply,
)

# Middlebury 2014 motorcycle, as scikit-image ships it (calibration from its docstring)
F, CX, CY, DOFFS, B = 994.978, 311.193, 254.877, 31.086, 0.193001


def motorcycle_rig() -> StereoRig:
    K1 = [[F, 0, CX], [0, F, CY], [0, 0, 1]]
    K2 = [[F, 0, CX + DOFFS], [0, F, CY], [0, 0, 1]]
    return StereoRig((741, 500), K1, K2, None, None, np.eye(3), [-B, 0, 0], source="middlebury")


@pytest.fixture(scope="module")
def motorcycle() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    left, right, disp = data.stereo_motorcycle()
    return left, right, disp


@pytest.fixture(scope="module")
def moto_result(motorcycle: tuple[np.ndarray, np.ndarray, np.ndarray]) -> StereoResult:
    left, right, _ = motorcycle
    return stereo_points(left, right, motorcycle_rig())


def _gt_errors(points: Points3D, disp: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """|disparity error| in px and |depth error| in m where the ground truth is known."""
    d = points.left_xy[:, 0] - points.right_xy[:, 0]
    c = np.rint(points.left_xy).astype(int)
    g = disp[c[:, 1], c[:, 0]]
    known = np.isfinite(g)  # unknown ground truth is +inf
    z_gt = F * B / (g[known] + DOFFS)
    return np.abs(d[known] - g[known]), np.abs(points.xyz[known, 2] - z_gt)


def test_motorcycle_accuracy_floor(
    moto_result: StereoResult, motorcycle: tuple[np.ndarray, np.ndarray, np.ndarray]
) -> None:
    # plain SIFT + ratio 0.6 + band: 751 matches, 93.1 % within 1 px, median depth error 6.1 mm
    pts = moto_result.points
    err_px, err_z = _gt_errors(pts, motorcycle[2])
    assert len(pts) >= 750
    assert np.mean(err_px <= 1.0) >= 0.97
    assert np.median(err_z) < 0.0065
    # depths of the scene: about 2.1-4.9 m
    assert np.all((pts.xyz[:, 2] > 1.5) & (pts.xyz[:, 2] < 6.0))


def test_motorcycle_result_is_consistent(moto_result: StereoResult) -> None:
    r = moto_result
    pts = r.points
    assert pts.descriptors.dtype == np.uint8 and pts.descriptors.shape == (len(pts), 128)
    np.testing.assert_array_equal(pts.descriptors, r.features_left.descriptors[pts.left_index])
    np.testing.assert_allclose(pts.left_xy, r.features_left.xy[pts.left_index])
    np.testing.assert_allclose(pts.right_xy, r.features_right.xy[pts.right_index])
    # rectified rig: rows agree within the band, disparity is x_l - x_r
    assert np.all(np.abs(pts.left_xy[:, 1] - pts.right_xy[:, 1]) <= 1.5)
    np.testing.assert_allclose(pts.disparity, pts.left_xy[:, 0] - pts.right_xy[:, 0])
    # Z = f B / (d + doffs)
    np.testing.assert_allclose(pts.xyz[:, 2], F * B / (pts.disparity + DOFFS), rtol=1e-9)
    # every left keypoint is used at most once
    assert len(np.unique(pts.left_index)) == len(pts)
    assert r.dense is not None and r.dense.valid_fraction() > 0.5


def test_plain_matching_on_motorcycle(
    moto_result: StereoResult, motorcycle: tuple[np.ndarray, np.ndarray, np.ndarray]
) -> None:
    # the paper's matching (no dense check), reusing the features: close to the plain figures
    m = match_stereo(moto_result.features_left, moto_result.features_right, moto_result.rect)
    assert 700 <= len(m) <= 800
    lx = moto_result.features_left.xy[m.left_index]
    rx = moto_result.features_right.xy[m.right_index]
    g = motorcycle[2][np.rint(lx[:, 1]).astype(int), np.rint(lx[:, 0]).astype(int)]
    known = np.isfinite(g)
    frac = np.mean(np.abs(lx[known, 0] - rx[known, 0] - g[known]) <= 1)
    assert 0.90 <= frac < 0.97  # the dense check is what lifts it


def test_dense_region_on_motorcycle(
    moto_result: StereoResult, motorcycle: tuple[np.ndarray, np.ndarray, np.ndarray]
) -> None:
    dense = moto_result.dense
    assert dense is not None
    disp = motorcycle[2]
    mask = np.zeros(disp.shape, bool)
    mask[300:380, 420:520] = True  # the engine
    xyz, left_xy = region_points(dense, mask, max_points=None)
    assert len(xyz) > 0.5 * mask.sum()
    c = np.rint(left_xy).astype(int)
    assert mask[c[:, 1], c[:, 0]].all()
    g = disp[c[:, 1], c[:, 0]]
    known = np.isfinite(g)
    z_gt = F * B / (g[known] + DOFFS)
    assert np.median(np.abs(xyz[known, 2] - z_gt)) < 0.02
    sub, _ = region_points(dense, mask, max_points=100)
    assert len(sub) <= 100


# ------------------------------------------------------------------------------------------
# synthetic rigs with known answers


def _synthetic_features(rig: StereoRig, X: np.ndarray, seed: int = 0) -> tuple[Features, Features]:
    """Project known points through a rig; give both views the same random descriptor."""
    z = np.zeros(3)
    xl, _ = cv2.projectPoints(X, z, z, rig.K_left, rig.dist_left)
    rvec, _ = cv2.Rodrigues(rig.R)
    xr, _ = cv2.projectPoints(X, rvec, rig.T, rig.K_right, rig.dist_right)
    n = len(X)
    rng = np.random.default_rng(seed)
    desc = rng.integers(0, 256, (n, 128), dtype=np.uint8)
    ones = np.ones(n, np.float32)

    def feats(xy: np.ndarray, order: np.ndarray) -> Features:
        return Features(
            xy.reshape(-1, 2)[order].astype(np.float64),
            ones * 4,
            ones * 0,
            ones,
            np.zeros(n, np.int32),
            desc[order],
        )

    perm = rng.permutation(n)  # the right features come in another order
    return feats(xl, np.arange(n)), feats(xr, perm)


def _points(n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.column_stack(
        [rng.uniform(-0.6, 0.6, n), rng.uniform(-0.4, 0.4, n), rng.uniform(0.5, 2.5, n)]
    )


@pytest.mark.parametrize("kind", ["rectified", "unrectified"])
def test_synthetic_rig_matches_and_triangulates(kind: str) -> None:
    if kind == "rectified":
        rig = rig_from_short(0.12, 60.0, (640, 480))
    else:
        R, _ = cv2.Rodrigues(np.array([0.02, -0.04, 0.01]))
        K1 = np.array([[560.0, 0, 322], [0, 558, 236], [0, 0, 1]])
        K2 = np.array([[565.0, 0, 316], [0, 563, 244], [0, 0, 1]])
        rig = StereoRig(
            (640, 480), K1, K2, [-0.08, 0.03, 0.001, -0.0005, 0], [-0.07, 0.02, 0, 0, 0], R,
            [-0.12, 0.003, 0.002],
        )  # fmt: skip
    X = _points(300, 1)
    fl, fr = _synthetic_features(rig, X)
    rect = rectify(rig)
    m = match_stereo(fl, fr, rect)
    assert len(m) == len(X)
    np.testing.assert_array_equal(np.sort(m.left_index), np.arange(len(X)))
    xyz = triangulate(m.left_rect, m.right_rect, rect)
    np.testing.assert_allclose(xyz, X[m.left_index], atol=1e-4)


def test_epipolar_band_and_positive_disparity_reject_wrong_pairs() -> None:
    rig = rig_from_short(0.12, 60.0, (640, 480))
    X = _points(50, 2)
    fl, fr = _synthetic_features(rig, X)
    # move every other right keypoint 5 rows down: out of the band
    xy = fr.xy.copy()
    xy[::2, 1] += 5.0
    moved = Features(xy, fr.size, fr.angle, fr.response, fr.octave, fr.descriptors)
    m = match_stereo(fl, moved, rectify(rig))
    assert len(m) == 25
    # a right keypoint to the right of its left one (negative disparity) is refused
    right_of = Features(
        fl.xy + np.array([5.0, 0.0]), fl.size, fl.angle, fl.response, fl.octave, fl.descriptors
    )
    assert len(match_stereo(fl, right_of, rectify(rig))) == 0
    assert len(match_stereo(right_of, fl, rectify(rig))) == 50


def test_ratio_test_ignores_duplicate_keypoints_but_not_rivals() -> None:
    rig = rig_from_short(0.12, 60.0, (640, 480))
    X = _points(40, 3)
    fl, fr = _synthetic_features(rig, X)
    rect = rectify(rig)
    # a duplicate of right keypoint 0 at the same place (another orientation): still matched
    dup = Features(
        np.vstack([fr.xy, fr.xy[:1]]),
        np.r_[fr.size, fr.size[:1]],
        np.r_[fr.angle, fr.angle[:1] + 90],
        np.r_[fr.response, fr.response[:1]],
        np.r_[fr.octave, fr.octave[:1]],
        np.vstack([fr.descriptors, fr.descriptors[:1]]),
    )
    assert len(match_stereo(fl, dup, rect)) == 40
    # the same descriptor somewhere else in the image: ambiguous, refused
    rival = Features(
        np.vstack([fr.xy, fr.xy[:1] + np.array([-100.0, 0.0])]),
        dup.size,
        dup.angle,
        dup.response,
        dup.octave,
        dup.descriptors,
    )
    assert len(match_stereo(fl, rival, rect)) == 39


# ------------------------------------------------------------------------------------------
# dense stereo on a textured plane at a known depth


def _plane_pair(d: int = 40) -> tuple[np.ndarray, np.ndarray, StereoRig, float]:
    """A fronto-parallel textured plane: the right image is the left shifted by d pixels."""
    rig = rig_from_short(0.12, 60.0, (640, 480))
    g = data.astronaut()[:, :, 1]
    tex = np.hstack([g, g[:, ::-1]])  # 512 x 1024
    left = np.ascontiguousarray(tex[:480, 100:740])
    right = np.ascontiguousarray(tex[:480, 100 + d : 740 + d])
    z = rig.K_left[0, 0] * 0.12 / d
    return left, right, rig, z


def test_dense_disparity_and_region_points_on_a_plane() -> None:
    left, right, rig, z = _plane_pair()
    rect = rectify(rig)
    dense = dense_disparity(left, right, rect, min_disparity=0, num_disparities=64)
    mask = np.zeros((480, 640), bool)
    mask[200:260, 300:380] = True
    xyz, left_xy = region_points(dense, mask, max_points=None)
    assert len(xyz) > 0.9 * mask.sum()
    assert np.median(xyz[:, 2]) == pytest.approx(z, rel=0.005)
    # the X of a pixel is (x - cx) Z / f
    i = np.argmin(np.abs(left_xy[:, 0] - 340))
    assert xyz[i, 0] == pytest.approx((left_xy[i, 0] - 319.5) * xyz[i, 2] / rig.K_left[0, 0])
    # a crop (roi) gives the same values where computed, NaN elsewhere
    crop = dense_disparity(
        left, right, rect, min_disparity=0, num_disparities=64, roi=(280, 180, 400, 280)
    )
    assert np.isnan(crop.disparity[0, 0])
    both = np.isfinite(crop.disparity[200:260, 300:380]) & np.isfinite(
        dense.disparity[200:260, 300:380]
    )
    assert both.mean() > 0.9
    diff = crop.disparity[200:260, 300:380][both] - dense.disparity[200:260, 300:380][both]
    assert np.median(np.abs(diff)) < 0.1


def test_stereo_points_on_a_plane_uses_keypoint_range() -> None:
    left, right, rig, z = _plane_pair()
    res = stereo_points(left, right, rig)
    assert len(res.points) > 100
    np.testing.assert_allclose(np.median(res.points.xyz[:, 2]), z, rtol=0.005)
    assert res.dense is not None
    assert res.dense.min_disparity <= 40 < res.dense.min_disparity + res.dense.num_disparities


# ------------------------------------------------------------------------------------------
# bad pairs


def test_textureless_pair_gives_empty_result_or_named_error() -> None:
    rig = rig_from_short(0.12, 60.0, (640, 480))
    flat = np.full((480, 640), 128, np.uint8)
    res = stereo_points(flat, flat, rig)
    assert len(res.points) == 0 and len(res.features_left) == 0
    assert points_to_json(res.points) == {"points": []}
    with pytest.raises(ImageError, match=r"l.png, r.png: only 0 stereo matches.*textureless"):
        stereo_points(flat, flat, rig, min_points=3, left_name="l.png", right_name="r.png")


def test_pairs_of_different_sizes_are_refused() -> None:
    a = np.zeros((480, 640), np.uint8)
    b = np.zeros((480, 600), np.uint8)
    with pytest.raises(ImageError, match=r"l.png, r.png: the left image is 640x480 but the right"):
        check_pair(a, b, left_name="l.png", right_name="r.png")
    with pytest.raises(ImageError, match="left image, right image"):
        stereo_points(a, b, rig_from_short(0.12, 60.0, (640, 480)))


def test_pair_not_matching_the_calibration() -> None:
    rig = rig_from_short(0.12, 60.0, (640, 480), source="calib.json")
    a = np.zeros((500, 741, 3), np.uint8)
    with pytest.raises(CalibrationMismatchError, match=r"calib.json: .* l.png is 741x500") as info:
        check_pair(a, a, rig, left_name="l.png")
    assert isinstance(info.value, ImageError) and isinstance(info.value, CalibrationError)


def test_load_pair_names_the_files(tmp_path: Path) -> None:
    img = data.camera()
    cv2.imwrite(str(tmp_path / "l.png"), img)
    cv2.imwrite(str(tmp_path / "small.png"), img[:100, :100])
    (tmp_path / "empty.png").write_bytes(b"")
    (tmp_path / "corrupt.png").write_bytes(b"\x89PNG\r\n\x1a\nnot really")
    left, _right = load_pair(tmp_path / "l.png", tmp_path / "l.png")
    assert left.shape == img.shape
    with pytest.raises(ImageError, match=r"small.png"):
        load_pair(tmp_path / "l.png", tmp_path / "small.png")
    for name, problem in (
        ("missing.png", "no such file"),
        ("empty.png", "empty"),
        ("corrupt.png", "cannot be read"),
    ):
        with pytest.raises(ImageError, match=problem) as info:
            load_pair(tmp_path / "l.png", tmp_path / name)
        assert name in str(info.value)


# ------------------------------------------------------------------------------------------
# output


def test_points_json_and_ply(moto_result: StereoResult, tmp_path: Path) -> None:
    pts = moto_result.points.subset(np.arange(20))
    doc = json.loads(json.dumps(points_to_json(pts)))
    assert len(doc["points"]) == 20
    first = doc["points"][0]
    assert set(first) == {"left", "right", "xyz"}
    assert first["left"] == pytest.approx(pts.left_xy[0].tolist(), abs=1e-3)
    assert first["right"] == pytest.approx(pts.right_xy[0].tolist(), abs=1e-3)
    assert first["xyz"] == pytest.approx(pts.xyz[0].tolist(), abs=1e-6)
    out = tmp_path / "p.ply"
    colors = np.tile(np.array([[255, 0, 10]], np.uint8), (20, 1))
    write_ply(pts, out, colors=colors)
    lines = out.read_text().splitlines()
    assert lines[0] == "ply" and "element vertex 20" in lines
    body = lines[lines.index("end_header") + 1 :]
    assert len(body) == 20
    vals = np.array([list(map(float, line.split())) for line in body])
    np.testing.assert_allclose(vals[:, :3], pts.xyz, atol=1e-6)
    assert vals[0, 3:].tolist() == [255, 0, 10]
    with pytest.raises(ImageError, match="cannot write"):
        write_ply(pts, tmp_path / "no" / "such" / "dir.ply")


def test_unrectified_rig_end_to_end_on_a_plane() -> None:
    """Render an unrectified pair of a plane (via the rectification maps, inverted) and check
    that sparse points and a dense region both land on the plane, in the ORIGINAL left frame."""
    R, _ = cv2.Rodrigues(np.array([0.01, -0.03, 0.005]))
    K1 = np.array([[560.0, 0, 322], [0, 558, 236], [0, 0, 1]])
    K2 = np.array([[565.0, 0, 316], [0, 563, 244], [0, 0, 1]])
    rig = StereoRig(
        (640, 480), K1, K2, [-0.06, 0.02, 0.0, 0.0, 0], [-0.05, 0.01, 0, 0, 0], R,
        [-0.12, 0.002, 0.001],
    )  # fmt: skip
    rect = rectify(rig)
    d = 36.0
    z0 = rect.focal * rect.baseline / d  # the plane Z = z0 of the rectified left frame
    g = data.astronaut()[:, :, 1]
    tex = np.hstack([g, g[:, ::-1]]).astype(np.float32)
    ys, xs = np.mgrid[0:480, 0:640].astype(np.float64)
    pix = np.column_stack([xs.ravel(), ys.ravel()])
    images = []
    for side, shift in (("left", 0.0), ("right", d)):
        q = rect.rectify_points(pix, side).reshape(480, 640, 2)
        # rectified texture: left at x, right at x - d sees the same texture point
        mx = (q[:, :, 0] + 150.0 + shift).astype(np.float32)
        my = (q[:, :, 1] + 10.0).astype(np.float32)
        images.append(cv2.remap(tex, mx, my, cv2.INTER_LINEAR).astype(np.uint8))
    res = stereo_points(images[0], images[1], rig)
    assert len(res.points) > 100
    z_rect = (res.points.xyz @ rect.R1.T)[:, 2]
    assert np.median(np.abs(z_rect - z0)) < 0.005 * z0
    assert res.dense is not None
    mask = np.zeros((480, 640), bool)
    mask[180:300, 250:400] = True
    xyz, left_xy = region_points(res.dense, mask, max_points=None)
    assert len(xyz) > 0.8 * mask.sum()
    c = np.rint(left_xy).astype(int)
    assert mask[np.clip(c[:, 1], 0, 479), np.clip(c[:, 0], 0, 639)].mean() > 0.99
    assert np.median(np.abs((xyz @ rect.R1.T)[:, 2] - z0)) < 0.005 * z0


def test_match_stereo_with_dense_reproduces_stereo_points(moto_result: StereoResult) -> None:
    r = moto_result
    m = match_stereo(r.features_left, r.features_right, r.rect, dense=r.dense)
    np.testing.assert_array_equal(m.left_index, r.points.left_index)
    np.testing.assert_array_equal(m.right_index, r.points.right_index)
    # the band search alone finds more (and worse) matches; the dense check thins them
    band = match_stereo(r.features_left, r.features_right, r.rect, search="band", ratio=0.8)
    assert len(band) > len(m) + 100


def test_dense_crop_on_motorcycle_keeps_the_accuracy(
    motorcycle: tuple[np.ndarray, np.ndarray, np.ndarray], moto_result: StereoResult
) -> None:
    # SGBM over the bounding box of the keypoints to verify (and a given region) only
    left, right, disp = motorcycle
    roi = (300, 200, 400, 260)
    res = stereo_points(left, right, motorcycle_rig(), dense_crop=True, dense_roi=roi)
    err_px, _ = _gt_errors(res.points, disp)
    assert len(res.points) >= 750
    assert np.mean(err_px <= 1.0) >= 0.97
    assert res.dense is not None
    known = np.isfinite(res.dense.disparity)
    ys, xs = np.nonzero(known)
    assert res.dense.roi is not None
    x0, y0, x1, y1 = res.dense.roi  # nothing is known outside the computed region
    assert xs.min() >= x0 and ys.min() >= y0 and xs.max() < x1 and ys.max() < y1
    assert known[200:260, 300:400].mean() > 0.5  # the given region is covered
    assert known[:, :40].mean() > 0.3  # the left edge too (OpenCV alone leaves it empty)
    # a pair whose keypoints sit in one corner: the map stops near them
    h, w = left.shape[:2]
    small = stereo_points(
        left[: h // 2, : w // 2], right[: h // 2, : w // 2], _half_rig(), dense_crop=True
    )
    assert small.dense is not None and len(small.points) > 50


def _half_rig() -> StereoRig:
    K1 = [[F, 0, CX], [0, F, CY], [0, 0, 1]]
    K2 = [[F, 0, CX + DOFFS], [0, F, CY], [0, 0, 1]]
    return StereoRig((370, 250), K1, K2, None, None, np.eye(3), [-B, 0, 0])


def test_dense_crop_covers_the_matches_plus_margin_and_the_given_region() -> None:
    # the cropped dense map: the matches' bounding box plus dense_margin pixels, and a region
    # the caller asks for (e.g. recognised outlines)
    from cardscene import BASELINE, HFOV, H, W, card_pair
    from scenespeak.perception.calibration import rig_from_short

    left, right = card_pair({"astronaut": (-0.1, 1.2, 0.2), "chelsea": (0.15, 1.0, 0.2)})
    # no texture, so no keypoints, along the top and the left edge
    left[:100] = right[:100] = left[:, :100] = right[:, :100] = 128
    rig = rig_from_short(BASELINE, HFOV, (W, H))
    plain = stereo_points(left, right, rig, dense_crop=True)  # dense_margin=5
    wide = stereo_points(left, right, rig, dense_crop=True, dense_margin=17)
    asked = stereo_points(left, right, rig, dense_crop=True, dense_roi=(5.0, 3.0, 20.0, 15.0))
    rois = [r.dense.roi if r.dense is not None else None for r in (plain, wide, asked)]
    assert all(roi is not None for roi in rois)
    (px0, py0, px1, py1), (wx0, wy0, wx1, wy1), (ax0, ay0, _, _) = rois  # type: ignore[misc]
    assert px0 > 20 and py0 > 20  # the keypoints do not reach the top-left corner
    assert (wx0, wy0) == (px0 - 12, py0 - 12)
    assert (wx1, wy1) == (min(W, px1 + 12), min(H, py1 + 12))
    assert ax0 <= 5 and ay0 <= 3


def test_options_objects_are_the_old_keywords() -> None:
    # each function takes its options object or the old single keywords (they replace the
    # object's fields); an unknown keyword is refused naming the fields
    from scenespeak.perception.stereo import DenseOptions, MatchOptions, PointsOptions

    rig = rig_from_short(0.12, 60.0, (640, 480))
    fl, fr = _synthetic_features(rig, _points(50, 2))
    xy = fr.xy.copy()
    xy[::2, 1] += 5.0  # every other right keypoint 5 rows down: inside a 6 px band only
    moved = Features(xy, fr.size, fr.angle, fr.response, fr.octave, fr.descriptors)
    rect = rectify(rig)
    by_kw = match_stereo(fl, moved, rect, band_px=6.0)
    by_opt = match_stereo(fl, moved, rect, options=MatchOptions(band_px=6.0))
    assert len(by_kw) == len(by_opt) == 50
    assert np.array_equal(by_kw.right_index, by_opt.right_index)
    # a keyword overrides the object's field
    assert len(match_stereo(fl, moved, rect, options=MatchOptions(band_px=6.0), band_px=1.5)) == 25
    with pytest.raises(TypeError, match=r"band_pixels.*the fields are"):
        match_stereo(fl, moved, rect, band_pixels=6.0)

    left, right, rig, _ = _plane_pair()
    kw = dense_disparity(left, right, rect, min_disparity=0, num_disparities=64, block_size=5)
    opt = DenseOptions(min_disparity=0, num_disparities=64, block_size=5)
    assert np.array_equal(
        kw.disparity, dense_disparity(left, right, rect, options=opt).disparity, equal_nan=True
    )
    with pytest.raises(TypeError, match="DenseOptions"):
        dense_disparity(left, right, rect, blocksize=5)

    a = stereo_points(left, right, rig, verify=False, ratio=0.7)
    b = stereo_points(left, right, rig, options=PointsOptions(verify=False, ratio=0.7))
    assert len(a.points) > 0 and np.array_equal(a.points.xyz, b.points.xyz)
    with pytest.raises(TypeError, match="PointsOptions"):
        stereo_points(left, right, rig, dense_crops=True)


def test_plain_dense_margin_is_not_the_pipelines() -> None:
    # a plain stereo_points call keeps its 5 px margin (plain callers with dense_crop=True and
    # no margin exist); the pipeline's stage sets its own 16 px
    from scenespeak.perception.stage_options import DENSE_MARGIN, StereoOptions
    from scenespeak.perception.stereo import PLAIN_DENSE_MARGIN, PointsOptions

    assert PointsOptions().dense_margin == PLAIN_DENSE_MARGIN == 5
    assert not PointsOptions().dense_crop
    staged = PointsOptions.with_overrides(None, StereoOptions().keywords())
    assert staged.dense_crop and staged.dense_margin == DENSE_MARGIN == 16


def _brute_band_pairs(
    dl: np.ndarray, dr: np.ndarray, lrect: np.ndarray, rrect: np.ndarray, band: float, lo: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every in-band pair with positive disparity, by the full integer distance matrix, in
    the order (left row rank, right row rank), distances as float32 of the exact value."""
    rank_l = np.argsort(np.argsort(lrect[:, 1], kind="stable"), kind="stable")
    rank_r = np.argsort(np.argsort(rrect[:, 1], kind="stable"), kind="stable")
    ii, jj = np.nonzero(
        (np.abs(lrect[:, 1, None] - rrect[None, :, 1]) <= band)
        & (lrect[:, 0, None] - rrect[None, :, 0] > lo)
    )
    order = np.lexsort((rank_r[jj], rank_l[ii]))
    ii, jj = ii[order], jj[order]
    diff = dl[ii].astype(np.int64) - dr[jj].astype(np.int64)
    sq = (diff * diff).sum(1)
    return ii, jj, np.sqrt(sq.astype(np.float32))


@pytest.mark.parametrize("chunk", [256, 5])
def test_band_pairs_are_every_in_band_pair_with_its_exact_distance(chunk: int) -> None:
    from scenespeak.perception.stereo.matching import _band_pairs

    rng = np.random.default_rng(16)
    dl = rng.integers(0, 256, (300, 128)).astype(np.uint8)
    dr = rng.integers(0, 256, (280, 128)).astype(np.uint8)
    dr[:40] = dl[:40]  # equal descriptors: distance 0
    dr[40:60] = dr[60:80]  # ties: two right keypoints at the same distance of every left one
    lrect = np.c_[rng.uniform(0, 80, 300), np.round(rng.uniform(0, 40, 300) * 4) / 4]
    rrect = np.c_[rng.uniform(0, 80, 280), np.round(rng.uniform(0, 40, 280) * 4) / 4]
    got = _band_pairs(dl, dr, lrect, rrect, 1.5, 0.0, None, chunk)
    want = _brute_band_pairs(dl, dr, lrect, rrect, 1.5, 0.0)
    assert len(want[0]) > 1000  # rows on quarter pixels: many pairs exactly 1.5 rows apart
    for g, w in zip(got, want, strict=True):
        assert g.dtype == w.dtype or g.dtype.kind == w.dtype.kind == "i"
        np.testing.assert_array_equal(g, w)


def _lexsort_group_best(
    ii: np.ndarray, jj: np.ndarray, dd: np.ndarray, n: int, rxy: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``matching._group_best`` as it was before issue 16 session 8 (a two-key lexsort)."""
    best = np.full(n, -1, np.intp)
    d1 = np.full(n, np.inf, np.float32)
    d2 = np.full(n, np.inf, np.float32)
    o = np.lexsort((dd, ii))
    ii, jj, dd = ii[o], jj[o], dd[o]
    first = np.flatnonzero(np.r_[True, ii[1:] != ii[:-1]])
    best[ii[first]] = jj[first]
    d1[ii[first]] = dd[first]
    far = np.linalg.norm(rxy[jj] - rxy[best[ii]], axis=1) > 2.0
    fi = np.flatnonzero(far)
    grp = ii[fi]
    f2 = fi[np.r_[True, grp[1:] != grp[:-1]]]
    d2[ii[f2]] = dd[f2]
    return best, d1, d2


@pytest.mark.parametrize("seed", range(4))
def test_group_best_keeps_the_lexsort_order_of_ties(seed: int) -> None:
    # few distinct distances (many exact ties, zeros among them) and right keypoints on a
    # coarse grid (many at the same place): which of two equally near ones is best matters
    from scenespeak.perception.stereo.matching import _group_best

    rng = np.random.default_rng(seed)
    n, m, pairs = 300, 200, 6000
    ii = rng.integers(0, n, pairs).astype(np.intp)
    jj = rng.integers(0, m, pairs).astype(np.intp)
    dd = np.sqrt(rng.integers(0, 40, pairs).astype(np.float32))
    rxy = rng.integers(0, 6, (m, 2)).astype(np.float64) * 1.5
    got = _group_best(ii, jj, dd, n + 5, rxy)
    want = _lexsort_group_best(ii, jj, dd, n + 5, rxy)
    for g, w in zip(got, want, strict=True):
        assert g.dtype == w.dtype
        np.testing.assert_array_equal(g, w)
    assert np.sum(got[0] >= 0) > 250 and np.isfinite(got[2]).sum() > 100


def test_dense_map_of_an_unrectified_rig_rectifies_only_its_crop() -> None:
    # dense_disparity resamples only the crop it hands to SGBM (issue 16); the map is the one
    # of the whole images rectified first (the same Rectification without its maps: it then
    # takes the images as they are), for crops inside, at the edges and the whole image
    from dataclasses import replace

    import cv2

    from cardscene import card_pair
    from scenespeak.perception.calibration import StereoRig

    left, right = card_pair({"astronaut": (-0.1, 1.2, 0.2), "chelsea": (0.15, 1.0, 0.2)})
    h, w = left.shape[:2]
    R, _ = cv2.Rodrigues(np.array([0.004, -0.01, 0.002]))
    K1 = np.array([[0.9 * w, 0.0, w / 2 + 3], [0.0, 0.9 * w, h / 2 - 2], [0.0, 0.0, 1.0]])
    K2 = K1 + np.array([[2.0, 0, -4], [0, 2.0, 3], [0, 0, 0]])
    D1, D2 = np.array([-0.05, 0.01, 0, 0, 0]), np.array([-0.04, 0.01, 0, 0, 0])
    rig = StereoRig((w, h), K1, K2, D1, D2, R, np.array([-0.1, 0.001, 0.0]))
    rect = rectify(rig)
    assert rect.needs_resampling
    from scenespeak.perception.features import to_gray

    whole = rect.rectify_images(to_gray(left), to_gray(right))
    flat = replace(rect, maps_left=None, maps_right=None)
    kd = np.array([20.0, 21.0, 22.0, 40.0, 41.0, 41.5])
    for roi in (None, (40, 30, 200, 150), (0, 0, 60, h), (w - 50, h - 40, w, h)):
        got = dense_disparity(left, right, rect, keypoint_disparities=kd, roi=roi, pad=16)
        want = dense_disparity(*whole, flat, keypoint_disparities=kd, roi=roi, pad=16)
        assert np.isfinite(got.disparity).sum() > 100
        assert (got.min_disparity, got.num_disparities, got.roi) == (
            want.min_disparity,
            want.num_disparities,
            want.roi,
        )
        np.testing.assert_array_equal(got.disparity, want.disparity)
