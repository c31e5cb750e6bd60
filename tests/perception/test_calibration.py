"""Calibration: every file form loads to the same rig, rectification round-trips, bad files
give named errors, and the ground frame."""

from __future__ import annotations

import json
import math
from pathlib import Path

import cv2
import numpy as np
import pytest
import yaml
from hypothesis import given
from hypothesis import strategies as st

from scenespeak.errors import CalibrationError, ImageError
from scenespeak.perception.calibration import (
    CalibrationMismatchError,
    StereoRig,
    ground_basis,
    heights,
    load_rig,
    load_ros_rig,
    rectify,
    rig_from_short,
    to_ground,
)
from scenespeak.perception.stereo import triangulate

SIZE = (640, 480)


def _unrectified_rig() -> StereoRig:
    """A realistic unrectified rig: small rotation, distortion, different intrinsics."""
    R, _ = cv2.Rodrigues(np.array([0.01, -0.03, 0.004]))
    K1 = np.array([[560.0, 0.0, 322.0], [0.0, 558.0, 236.0], [0.0, 0.0, 1.0]])
    K2 = np.array([[565.0, 0.0, 316.0], [0.0, 563.0, 244.0], [0.0, 0.0, 1.0]])
    D1 = np.array([-0.08, 0.03, 0.001, -0.0005, 0.0])
    D2 = np.array([-0.07, 0.02, -0.0008, 0.0004, 0.0])
    return StereoRig(SIZE, K1, K2, D1, D2, R, np.array([-0.12, 0.002, 0.001]), source="test")


def _write_opencv_yaml(path: Path, rig: StereoRig, ext: str) -> Path:
    """Write the rig with OpenCV's own FileStorage (as stereo_calib.cpp does)."""
    p = path / f"stereo{ext}"
    fs = cv2.FileStorage(str(p), cv2.FILE_STORAGE_WRITE)
    fs.write("M1", rig.K_left)
    fs.write("D1", rig.dist_left.reshape(1, -1))
    fs.write("M2", rig.K_right)
    fs.write("D2", rig.dist_right.reshape(1, -1))
    fs.write("R", rig.R)
    fs.write("T", rig.T.reshape(3, 1))
    fs.write("image_width", rig.image_size[0])
    fs.write("image_height", rig.image_size[1])
    fs.release()
    return p


def _write_ros_pair(path: Path, rig: StereoRig) -> tuple[Path, Path]:
    """camera_info YAML files as ROS camera_calibration writes them."""
    R1, R2, P1, P2, *_ = cv2.stereoRectify(
        rig.K_left, rig.dist_left, rig.K_right, rig.dist_right, rig.image_size, rig.R,
        rig.T.reshape(3, 1), flags=cv2.CALIB_ZERO_DISPARITY, alpha=0,
    )  # fmt: skip
    out = []
    for name, K, D, Rr, P in (
        ("left", rig.K_left, rig.dist_left, R1, P1),
        ("right", rig.K_right, rig.dist_right, R2, P2),
    ):
        doc = {
            "image_width": rig.image_size[0],
            "image_height": rig.image_size[1],
            "camera_name": name,
            "camera_matrix": {"rows": 3, "cols": 3, "data": K.ravel().tolist()},
            "distortion_model": "plumb_bob",
            "distortion_coefficients": {"rows": 1, "cols": 5, "data": D.tolist()},
            "rectification_matrix": {"rows": 3, "cols": 3, "data": Rr.ravel().tolist()},
            "projection_matrix": {"rows": 3, "cols": 4, "data": P.ravel().tolist()},
        }
        p = path / f"{name}.yaml"
        p.write_text(yaml.safe_dump(doc))
        out.append(p)
    return out[0], out[1]


# ------------------------------------------------------------------------------------------
# forms


def test_short_form_numbers() -> None:
    rig = rig_from_short(0.12, 60.0, SIZE)
    f = 320.0 / math.tan(math.radians(30.0))
    assert rig.K_left[0, 0] == pytest.approx(f)
    assert rig.K_left[1, 1] == pytest.approx(f)
    assert rig.K_left[:2, 2].tolist() == [319.5, 239.5]
    assert rig.T.tolist() == [-0.12, 0.0, 0.0]
    assert rig.baseline == pytest.approx(0.12)
    assert rig.is_rectified
    assert rig.up.tolist() == [0.0, -1.0, 0.0]


def test_short_and_full_json_give_the_same_rig(tmp_path: Path) -> None:
    short = {"baseline": 0.12, "hfov_deg": 60, "image_size": [640, 480], "up": [0, -1, 0]}
    (tmp_path / "short.json").write_text(json.dumps(short))
    a = load_rig(tmp_path / "short.json")
    (tmp_path / "full.json").write_text(json.dumps(a.to_dict()))
    b = load_rig(tmp_path / "full.json")
    assert a.allclose(b)
    assert b.source.endswith("full.json")


def test_every_form_loads_to_the_same_rig(tmp_path: Path) -> None:
    rig = _unrectified_rig()
    (tmp_path / "full.json").write_text(json.dumps(rig.to_dict()))
    forms = {
        "json": load_rig(tmp_path / "full.json"),
        "opencv yml": load_rig(_write_opencv_yaml(tmp_path, rig, ".yml")),
        "opencv xml": load_rig(_write_opencv_yaml(tmp_path, rig, ".xml")),
        "ros pair": load_ros_rig(*_write_ros_pair(tmp_path, rig)),
    }
    for name, other in forms.items():
        assert other.allclose(rig, rtol=1e-6, atol=1e-7), name


def test_opencv_names_in_plain_json(tmp_path: Path) -> None:
    rig = _unrectified_rig()
    d = {
        "K1": rig.K_left.ravel().tolist(),  # flat lists are accepted too
        "D1": rig.dist_left.tolist(),
        "K2": {"rows": 3, "cols": 3, "data": rig.K_right.ravel().tolist()},
        "D2": rig.dist_right.tolist(),
        "R": rig.R.tolist(),
        "T": rig.T.tolist(),
        "imageSize": [640, 480],
    }
    (tmp_path / "c.json").write_text(json.dumps(d))
    assert load_rig(tmp_path / "c.json").allclose(rig)


def test_missing_image_size_can_be_supplied(tmp_path: Path) -> None:
    rig = _unrectified_rig()
    d = rig.to_dict()
    del d["image_size"]
    (tmp_path / "c.json").write_text(json.dumps(d))
    with pytest.raises(CalibrationError, match="image_size"):
        load_rig(tmp_path / "c.json")
    assert load_rig(tmp_path / "c.json", image_size=SIZE).allclose(rig)


def test_ros_rectified_pair_is_a_rectified_rig(tmp_path: Path) -> None:
    # camera_info of already rectified images: K = P[:3, :3], R = I, D = 0
    f, B = 500.0, 0.1
    for name, tx in (("l", 0.0), ("r", -f * B)):
        doc = {
            "width": 640,
            "height": 480,
            "K": [f, 0, 320, 0, f, 240, 0, 0, 1],
            "D": [],
            "R": [1, 0, 0, 0, 1, 0, 0, 0, 1],
            "P": [f, 0, 320, tx, 0, f, 240, 0, 0, 0, 1, 0],
        }
        (tmp_path / f"{name}.yaml").write_text(yaml.safe_dump(doc))
    rig = load_ros_rig(tmp_path / "l.yaml", tmp_path / "r.yaml")
    assert rig.is_rectified
    assert rig.T.tolist() == pytest.approx([-B, 0.0, 0.0])


# ------------------------------------------------------------------------------------------
# errors


def _full(**changes: object) -> dict[str, object]:
    d = rig_from_short(0.12, 60.0, SIZE).to_dict()
    d.update(changes)
    return d


@pytest.mark.parametrize(
    ("doc", "message"),
    [
        (_full(K_left=[[float("nan"), 0, 320], [0, 500, 240], [0, 0, 1]]), "NaN"),
        (_full(K_left=[[0, 0, 320], [0, 0, 240], [0, 0, 1]]), "singular"),
        (_full(K_right=[[500, 0, 320], [0, 500, 240]]), "shape"),
        (_full(R=[[1, 0, 0], [0, 1, 0], [0, 0, 2]]), "rotation"),
        (_full(R=[[1, 0, 0], [0, 1, 0], [0, 0, -1]]), "rotation"),
        (_full(T=[0, 0, 0]), "baseline is zero"),
        (_full(T=[-0.1, 0, float("inf")]), "NaN or infinite"),
        (_full(dist_left=[0.1, 0.2, 0.3]), "coefficients"),
        (_full(up=[0, 0, 0]), "up"),
        (_full(image_size=[640]), "image_size"),
        (_full(image_size=[640.5, 480]), "image_size"),
        ({"baseline": 0.12, "image_size": [640, 480]}, "hfov_deg"),
        ({"baseline": 0.0, "hfov_deg": 60, "image_size": [640, 480]}, "baseline"),
        ({"baseline": 0.1, "hfov_deg": 190, "image_size": [640, 480]}, "hfov_deg"),
        ({k: v for k, v in _full().items() if k != "R"}, 'missing key "R"'),
        ([1, 2, 3], "mapping"),
    ],
)
def test_bad_calibration_names_file_and_problem(tmp_path: Path, doc: object, message: str) -> None:
    p = tmp_path / "calib.json"
    p.write_text(json.dumps(doc))
    with pytest.raises(CalibrationError, match=message) as info:
        load_rig(p)
    assert str(p) in str(info.value)
    assert "\n" not in str(info.value)


def test_unreadable_calibration_files(tmp_path: Path) -> None:
    with pytest.raises(CalibrationError, match="no such file"):
        load_rig(tmp_path / "missing.json")
    (tmp_path / "empty.json").write_text("")
    with pytest.raises(CalibrationError, match="empty"):
        load_rig(tmp_path / "empty.json")
    (tmp_path / "bad.json").write_text('{"baseline": 0.1,,}')
    with pytest.raises(CalibrationError, match="not valid JSON"):
        load_rig(tmp_path / "bad.json")
    (tmp_path / "bad.yaml").write_text("K1: [1, 2\n  - x")
    with pytest.raises(CalibrationError, match="not valid YAML"):
        load_rig(tmp_path / "bad.yaml")
    (tmp_path / "bin.json").write_bytes(b"\xff\xfe\x00\x81")
    with pytest.raises(CalibrationError, match="not a text file"):
        load_rig(tmp_path / "bin.json")
    with pytest.raises(CalibrationError, match="folder"):
        load_rig(tmp_path)


def test_single_ros_file_is_explained(tmp_path: Path) -> None:
    left, _ = _write_ros_pair(tmp_path, _unrectified_rig())
    with pytest.raises(CalibrationError, match="ROS camera_info"):
        load_rig(left)


def test_ros_errors(tmp_path: Path) -> None:
    left, right = _write_ros_pair(tmp_path, _unrectified_rig())
    with pytest.raises(CalibrationError, match="not the right camera"):
        load_ros_rig(left, left)
    doc = yaml.safe_load(right.read_text())
    doc["projection_matrix"]["data"][0] = float("nan")
    right.write_text(yaml.safe_dump(doc))
    with pytest.raises(CalibrationError, match="NaN") as info:
        load_ros_rig(left, right)
    assert "right.yaml" in str(info.value)


def test_image_size_mismatch_is_both_calibration_and_image_error() -> None:
    rig = rig_from_short(0.12, 60.0, SIZE)
    rig.check_image_size(SIZE)
    with pytest.raises(CalibrationMismatchError, match=r"640x480.*left.png is 741x500"):
        rig.check_image_size((741, 500), "left.png")
    assert issubclass(CalibrationMismatchError, CalibrationError)
    assert issubclass(CalibrationMismatchError, ImageError)


def test_right_camera_on_the_left_is_refused() -> None:
    rig = _unrectified_rig()
    flipped = StereoRig(SIZE, rig.K_left, rig.K_right, None, None, rig.R, -rig.T, source="c.json")
    with pytest.raises(CalibrationError, match=r"c\.json: T = .*right camera must be to the right"):
        rectify(flipped)


# ------------------------------------------------------------------------------------------
# rectification


def test_rectified_rig_keeps_images_and_handles_doffs() -> None:
    f = 994.978
    K1 = [[f, 0, 311.193], [0, f, 254.877], [0, 0, 1]]
    K2 = [[f, 0, 311.193 + 31.086], [0, f, 254.877], [0, 0, 1]]
    rig = StereoRig((741, 500), K1, K2, None, None, np.eye(3), [-0.193001, 0, 0])
    rect = rectify(rig)
    assert not rect.needs_resampling
    assert rect.doffs == pytest.approx(31.086)
    assert rect.baseline == pytest.approx(0.193001)
    # Middlebury: Z = B f / (d + doffs)
    assert rect.depth_from_disparity(40.0) == pytest.approx(0.193001 * f / 71.086)
    img = np.zeros((500, 741), np.uint8)
    a, b = rect.rectify_images(img, img)
    assert a is img and b is img


def _project(rig: StereoRig, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    z = np.zeros(3)
    xl, _ = cv2.projectPoints(X, z, z, rig.K_left, rig.dist_left)
    rvec, _ = cv2.Rodrigues(rig.R)
    xr, _ = cv2.projectPoints(X, rvec, rig.T, rig.K_right, rig.dist_right)
    return xl.reshape(-1, 2), xr.reshape(-1, 2)


def test_unrectified_rig_round_trips_points() -> None:
    rig = _unrectified_rig()
    rect = rectify(rig)
    assert rect.needs_resampling
    rng = np.random.default_rng(3)
    X = np.column_stack(
        [rng.uniform(-0.5, 0.5, 200), rng.uniform(-0.3, 0.4, 200), rng.uniform(0.6, 3.0, 200)]
    )
    xl, xr = _project(rig, X)
    ql, qr = rect.rectify_points(xl, "left"), rect.rectify_points(xr, "right")
    # rectified: same rows
    assert np.max(np.abs(ql[:, 1] - qr[:, 1])) < 1e-3
    # input <-> rectified pixel maps are inverse
    assert np.max(np.abs(rect.unrectify_points(ql, "left") - xl)) < 1e-3
    assert np.max(np.abs(rect.unrectify_points(qr, "right") - xr)) < 1e-3
    # triangulation returns the points in the ORIGINAL left frame
    assert np.max(np.abs(triangulate(ql, qr, rect) - X)) < 1e-4
    # the remap tables agree with the point maps
    mx, my = rect.maps_left  # type: ignore[misc]
    c = np.rint(ql[:50]).astype(int)
    inside = (c[:, 0] >= 0) & (c[:, 0] < 640) & (c[:, 1] >= 0) & (c[:, 1] < 480)
    back = np.column_stack([mx[c[inside, 1], c[inside, 0]], my[c[inside, 1], c[inside, 0]]])
    assert np.max(np.abs(back - rect.unrectify_points(c[inside].astype(float)))) < 0.05


def test_rectify_images_resamples_unrectified_pairs() -> None:
    rig = _unrectified_rig()
    rect = rectify(rig)
    img = np.full((480, 640), 200, np.uint8)
    a, b = rect.rectify_images(img, img)
    assert a.shape == img.shape and b.shape == img.shape
    assert a is not img
    # alpha=1 keeps every input pixel: some black border appears
    assert (a == 0).any()


def test_rectify_images_of_a_window_are_the_whole_images_part() -> None:
    # cv2.remap computes each output pixel from its own map entries: the window's maps give
    # the window's pixels bit for bit (the dense map rectifies only its crop, issue 16)
    rig = _unrectified_rig()
    rect = rectify(rig)
    rng = np.random.default_rng(16)
    img = cv2.GaussianBlur(rng.integers(0, 256, (480, 640), dtype=np.uint8), (0, 0), 1.5)
    img2 = np.roll(img, 7, axis=1)
    whole = rect.rectify_images(img, img2)
    for window in ((0, 0, 640, 480), (13, 200, 611, 201), (0, 5, 1, 480), (300, 0, 640, 47)):
        x0, y0, x1, y1 = window
        part = rect.rectify_images(img, img2, window=window)
        for p, w in zip(part, whole, strict=True):
            assert p.shape == (y1 - y0, x1 - x0)
            np.testing.assert_array_equal(p, w[y0:y1, x0:x1])
    # an already rectified rig: views of the images
    plain = rectify(rig_from_short(0.12, 60.0, (640, 480)))
    a, b = plain.rectify_images(img, img2, window=(3, 4, 50, 60))
    assert np.shares_memory(a, img) and a.shape == (56, 47)
    np.testing.assert_array_equal(b, img2[4:60, 3:50])


# ------------------------------------------------------------------------------------------
# ground frame


def test_level_rig_ground_frame_is_x_z() -> None:
    E = ground_basis([0, -1, 0])
    np.testing.assert_allclose(E, [[1, 0, 0], [0, 0, 1]], atol=1e-12)
    pts = np.array([[0.2, 0.3, 1.5]])
    np.testing.assert_allclose(to_ground(pts), [[0.2, 1.5]])
    np.testing.assert_allclose(heights(pts), [-0.3])


def test_pitched_rig_ground_frame_matches_world() -> None:
    # camera pitched down by 25 degrees: world -> camera rotation about the camera x axis
    th = math.radians(25.0)
    c, s = math.cos(th), math.sin(th)
    Rwc = np.array([[1, 0, 0], [0, c, s], [0, -s, c]])  # world (x right, y down, z fwd) -> cam
    up_cam = Rwc @ np.array([0.0, -1.0, 0.0])
    world = np.array([[0.3, 0.5, 2.0], [-0.4, 0.5, 1.0], [0.0, -0.2, 1.5]])
    cam = world @ Rwc.T
    np.testing.assert_allclose(to_ground(cam, up_cam), world[:, [0, 2]], atol=1e-12)
    np.testing.assert_allclose(heights(cam, up_cam), -world[:, 1], atol=1e-12)


@given(
    st.tuples(
        st.floats(-1, 1, allow_nan=False),
        st.floats(-1, 1, allow_nan=False),
        st.floats(-1, 1, allow_nan=False),
    ).filter(lambda v: np.linalg.norm(v) > 1e-3)
)
def test_ground_basis_is_orthonormal_and_horizontal(up: tuple[float, float, float]) -> None:
    E = ground_basis(up)
    u = np.asarray(up) / np.linalg.norm(up)
    np.testing.assert_allclose(E @ E.T, np.eye(2), atol=1e-9)
    np.testing.assert_allclose(E @ u, [0.0, 0.0], atol=1e-9)
    # right-handed seen from above: x = y x up
    np.testing.assert_allclose(np.cross(E[1], u), E[0], atol=1e-9)
    # y follows the camera's forward direction where it has a horizontal part
    fwd_h = np.array([0.0, 0.0, 1.0]) - u[2] * u
    if np.linalg.norm(fwd_h) > 1e-3:
        assert E[1] @ fwd_h > 0


def test_ground_basis_rejects_nan() -> None:
    with pytest.raises(CalibrationError, match="up"):
        ground_basis([float("nan"), -1, 0])


def test_rotation_vector_is_accepted(tmp_path: Path) -> None:
    rig = _unrectified_rig()
    d = rig.to_dict()
    d["R"] = cv2.Rodrigues(rig.R)[0].ravel().tolist()
    (tmp_path / "c.json").write_text(json.dumps(d))
    assert load_rig(tmp_path / "c.json").allclose(rig, atol=1e-9)
