"""Real chessboard stereo sets, every calibration form, depth on the board within 1 % (issue 12).

Three calibrations: OpenCV's own 13 pairs (9x6 corners; square size undocumented, 25 mm as in
OpenCV's sample), XIMEA's 25 pairs (6x9, 24 mm) calibrated here with OpenCV, and XIMEA's own
``intrinsics.yml`` / ``extrinsics.yml`` (millimetres, image names swapped: accepted with
``--units mm --swap``). Each calibration is written in every form scenespeak reads (JSON full
form, OpenCV YAML as ``cv2.FileStorage`` writes it, with ``imageSize`` as a matrix, OpenCV XML,
the stereo_calib intrinsics + extrinsics pair, a ROS camera_info pair), loaded back through the
same code as the CLI, and the board corners are triangulated: their depth must be within 1 %
of the board plane ``cv2.solvePnP`` finds in the left image (median over the corners of each
pair; every pair checked).
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import pytest

from scenespeak.perception import calibfiles, plausibility
from scenespeak.perception.calibration import StereoRig, rectify
from scenespeak.perception.stereo import triangulate

SETS = {
    # name: (folder, pattern (cols, rows), square in metres, (left prefix, right prefix))
    "opencv": ("opencv", (9, 6), 0.025, ("left", "right")),
    # XIMEA's files have left and right swapped (README): the camera named "right" is the left
    "ximea": ("ximea", (6, 9), 0.024, ("right", "left")),
}


def _corners(path: Path, pattern: tuple[int, int]) -> np.ndarray | None:
    gray = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
    found, corners = cv2.findChessboardCorners(gray, pattern)
    if not found:
        return None
    crit = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_MAX_ITER, 50, 1e-4)
    return cv2.cornerSubPix(gray, corners, (11, 11), (-1, -1), crit).reshape(-1, 2)


def _board(pattern: tuple[int, int], square: float) -> np.ndarray:
    cols, rows = pattern
    grid = np.mgrid[0:cols, 0:rows].T.reshape(-1, 2) * square
    return np.hstack([grid, np.zeros((len(grid), 1))]).astype(np.float32)


def _pairs(root: Path, name: str) -> tuple[list[tuple[np.ndarray, np.ndarray]], tuple[int, int]]:
    folder, pattern, _, (lp, rp) = SETS[name]
    base = root / "chess" / folder
    pairs = []
    size = (0, 0)
    for left in sorted(base.glob(f"{lp}*.jpg")):
        right = base / left.name.replace(lp, rp)
        cl, cr = _corners(left, pattern), _corners(right, pattern)
        if cl is None or cr is None:
            continue
        if np.linalg.norm(cl[0] - cr[0]) > np.linalg.norm(cl[0] - cr[-1]):
            cr = cr[::-1].copy()  # the detector started at the other end in one view
        pairs.append((cl, cr))
        h, w = cv2.imread(str(left), cv2.IMREAD_GRAYSCALE).shape
        size = (w, h)
    return pairs, size


@pytest.fixture(scope="module")
def chess(real_data: Path) -> dict[str, dict[str, Any]]:
    """Per set: the corner pairs, the image size and an OpenCV stereo calibration (metres)."""
    return calibrate_sets(real_data)


def calibrate_sets(real_data: Path) -> dict[str, dict[str, Any]]:
    """The calibration of each set (also used by ``benchmarks/real_calibration.py``)."""
    out: dict[str, dict[str, Any]] = {}
    for name, (_, pattern, square, _) in SETS.items():
        pairs, size = _pairs(real_data, name)
        assert len(pairs) >= 8, f"{name}: only {len(pairs)} pairs with the whole board"
        obj = [_board(pattern, square)] * len(pairs)
        left = [p[0].reshape(-1, 1, 2).astype(np.float32) for p in pairs]
        right = [p[1].reshape(-1, 1, 2).astype(np.float32) for p in pairs]
        _, k1, d1, _, _ = cv2.calibrateCamera(obj, left, size, None, None)
        _, k2, d2, _, _ = cv2.calibrateCamera(obj, right, size, None, None)
        rms, k1, d1, k2, d2, R, T, _, _ = cv2.stereoCalibrate(
            obj, left, right, k1, d1, k2, d2, size, flags=cv2.CALIB_FIX_INTRINSIC
        )
        out[name] = {
            "pairs": pairs,
            "size": size,
            "pattern": pattern,
            "square": square,
            "K1": k1,
            "D1": d1.ravel(),
            "K2": k2,
            "D2": d2.ravel(),
            "R": R,
            "T": T.ravel(),
            "rms": rms,
        }
    return out


def _write_forms(
    c: dict[str, Any], folder: Path
) -> dict[str, tuple[Path, Path | None, dict[str, Any]]]:
    """Every calibration form of one calibration: name -> (--calib, --calib-right, options)."""
    folder.mkdir(parents=True, exist_ok=True)
    w, h = c["size"]
    forms: dict[str, tuple[Path, Path | None, dict[str, Any]]] = {}
    full = {
        "image_size": [w, h],
        "K_left": c["K1"].tolist(),
        "K_right": c["K2"].tolist(),
        "dist_left": c["D1"].tolist(),
        "dist_right": c["D2"].tolist(),
        "R": c["R"].tolist(),
        "T": c["T"].tolist(),
    }
    (folder / "calib.json").write_text(json.dumps(full))
    forms["json"] = (folder / "calib.json", None, {})
    for ext in ("yml", "xml"):
        path = folder / f"calib.{ext}"
        fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
        fs.write("imageSize", np.array([w, h], np.int32))  # a matrix, as Python writes it
        for key in ("K1", "D1", "K2", "D2", "R"):
            fs.write(key.replace("K", "M"), np.asarray(c[key], np.float64))
        fs.write("T", np.asarray(c["T"], np.float64).reshape(3, 1))
        fs.release()
        forms[ext] = (path, None, {})
    R1, R2, P1, P2, Q, _, _ = cv2.stereoRectify(
        c["K1"], c["D1"], c["K2"], c["D2"], (w, h), c["R"], c["T"].reshape(3, 1), alpha=0
    )
    # OpenCV's stereo_calib sample: two files, translations in millimetres
    intr = cv2.FileStorage(str(folder / "intrinsics.yml"), cv2.FILE_STORAGE_WRITE)
    for key, value in (("M1", c["K1"]), ("D1", c["D1"]), ("M2", c["K2"]), ("D2", c["D2"])):
        intr.write(key, np.asarray(value, np.float64))
    intr.release()
    extr = cv2.FileStorage(str(folder / "extrinsics.yml"), cv2.FILE_STORAGE_WRITE)
    P2mm = P2.copy()
    P2mm[:, 3] *= 1000.0
    for key, value in (
        ("R", c["R"]),
        ("T", c["T"].reshape(3, 1) * 1000.0),
        ("R1", R1),
        ("R2", R2),
        ("P1", P1),
        ("P2", P2mm),
        ("Q", Q),
    ):
        extr.write(key, np.asarray(value, np.float64))
    extr.release()
    forms["stereo_calib pair (mm)"] = (
        folder / "intrinsics.yml",
        folder / "extrinsics.yml",
        {"image_size": (w, h), "units": "mm"},
    )
    for side, K, D, Rr, P in (
        ("left", c["K1"], c["D1"], R1, P1),
        ("right", c["K2"], c["D2"], R2, P2),
    ):

        def mat(a: np.ndarray) -> dict[str, Any]:
            a = np.atleast_2d(a)
            return {"rows": a.shape[0], "cols": a.shape[1], "data": a.ravel().tolist()}

        doc = {
            "image_width": w,
            "image_height": h,
            "camera_name": side,
            "camera_matrix": mat(K),
            "distortion_model": "plumb_bob",
            "distortion_coefficients": mat(np.asarray(D).ravel()[:5].reshape(1, -1)),
            "rectification_matrix": mat(Rr),
            "projection_matrix": mat(P),
        }
        import yaml

        (folder / f"ros_{side}.yaml").write_text(yaml.safe_dump(doc))
    forms["ros pair"] = (folder / "ros_left.yaml", folder / "ros_right.yaml", {})
    return forms


def _load(calib: Path, right: Path | None, options: dict[str, Any]) -> StereoRig:
    """Load as the CLI does (calibfiles, then --units / --swap, then the plausibility check)."""
    size = options.get("image_size")
    if right is None:
        rig = calibfiles.read_calibration(calib, image_size=size)
    else:
        rig = calibfiles.read_calibration_pair(calib, right, image_size=size)
    rig = plausibility.with_units(rig, options.get("units", "m"))
    if options.get("swap"):
        rig = plausibility.swapped(rig)
    return plausibility.check_rig(rig)


def _board_depth_errors(rig: StereoRig, c: dict[str, Any], swap: bool = False) -> list[float]:
    """Median |Z_triangulated − Z_solvePnP| / Z_solvePnP over the corners, per pair."""
    rect = rectify(rig)
    obj = _board(c["pattern"], c["square"])
    errors = []
    for cl, cr in c["pairs"]:
        if swap:
            cl, cr = cr, cl
        xyz = triangulate(rect.rectify_points(cl, "left"), rect.rectify_points(cr, "right"), rect)
        ok, rvec, tvec = cv2.solvePnP(obj, cl, rig.K_left, rig.dist_left)
        assert ok
        plane = (cv2.Rodrigues(rvec)[0] @ obj.T.astype(np.float64) + tvec).T
        errors.append(float(np.median(np.abs(xyz[:, 2] - plane[:, 2]) / plane[:, 2])))
    return errors


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(SETS))
def test_every_form_of_a_calibration_from_real_pairs(
    name: str, chess: dict[str, dict[str, Any]], tmp_path: Path
) -> None:
    c = chess[name]
    assert c["rms"] < 1.0, f"{name}: stereo calibration RMS {c['rms']:.2f} px"
    forms = _write_forms(c, tmp_path / name)
    reference = None
    for form, (calib, right, options) in forms.items():
        rig = _load(calib, right, options)
        if reference is None:
            reference = rig
        assert np.allclose(rig.T, reference.T, atol=1e-6), form
        errors = _board_depth_errors(rig, c)
        assert max(errors) < 0.01, f"{name} / {form}: depth error {max(errors):.2%} on the board"


@pytest.mark.slow
def test_ximea_own_stereo_calib_pair(chess: dict[str, dict[str, Any]], real_data: Path) -> None:
    """XIMEA's own files: millimetres and names swapped, both refused with the fix, then used."""
    from scenespeak.errors import CalibrationError

    folder = real_data / "chess" / "ximea"
    intr, extr = folder / "intrinsics.yml", folder / "extrinsics.yml"
    size = chess["ximea"]["size"]
    with pytest.raises(CalibrationError, match="looks like millimetres: pass --units mm"):
        _load(intr, extr, {"image_size": size})
    with pytest.raises(CalibrationError, match="--swap"):
        _load(intr, extr, {"image_size": size, "units": "mm"})
    rig = _load(intr, extr, {"image_size": size, "units": "mm", "swap": True})
    # their "left" files are camera 1 of their calibration; swapped, our left camera is their
    # camera 2, the "right" files, which the corner pairs already hold as left
    errors = _board_depth_errors(rig, chess["ximea"])
    assert max(errors) < 0.01, f"depth error {max(errors):.2%} on the board"


@pytest.mark.slow
def test_the_cli_takes_the_real_forms(
    chess: dict[str, dict[str, Any]], real_data: Path, tmp_path: Path
) -> None:
    """``scenespeak points`` accepts each form (exit 0) on a real pair."""
    c = chess["opencv"]
    forms = _write_forms(c, tmp_path / "cli")
    left = real_data / "chess" / "opencv" / "left01.jpg"
    right = real_data / "chess" / "opencv" / "right01.jpg"
    for form, (calib, second, options) in forms.items():
        args = ["points", "--calib", str(calib), str(left), str(right), "-q"]
        if second is not None:
            args += ["--calib-right", str(second)]
        if "image_size" in options:
            args += ["--image-size", "{}x{}".format(*options["image_size"])]
        if "units" in options:
            args += ["--units", options["units"]]
        proc = subprocess.run(
            [sys.executable, "-m", "scenespeak", *args],
            capture_output=True,
            text=True,
            timeout=300,
            check=False,
        )
        assert proc.returncode == 0, f"{form}: {proc.stderr.strip()}"
        assert json.loads(proc.stdout)["points"], form
