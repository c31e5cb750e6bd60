"""Reading calibration files as untrusted input, in every form real tools write.

:func:`read_calibration` reads one file, :func:`read_calibration_pair` two: a ROS
``camera_info`` pair (left, right), or OpenCV's stereo_calib pair ``intrinsics.yml``
(``M1 D1 M2 D2``) + ``extrinsics.yml`` (``R T R1 R2 P1 P2 Q``). Files are read with
:mod:`scenespeak.safeio` (size, FIFO and device checks before reading; JSON and YAML with bounded
nesting, numbers and aliases; no YAML python tags; XML without DOCTYPE or entities) and then
built into a :class:`~scenespeak.perception.calibration.StereoRig` by
:func:`~scenespeak.perception.calibration.rig_from_mapping` /
:func:`~scenespeak.perception.calibration.load_ros_rig`.

Accepted on top of the short and full JSON forms: ``imageSize`` written as a matrix (what
Python's ``cv2.FileStorage.write`` gives), ``width``/``height`` pairs, and an ``up:`` key in a
ROS file (honoured, not ignored).

>>> import json, pathlib, tempfile
>>> p = pathlib.Path(tempfile.mkdtemp()) / "calib.json"
>>> _ = p.write_text(json.dumps({"baseline": 0.12, "hfov_deg": 60, "image_size": [640, 480]}))
>>> read_calibration(p).baseline
0.12
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from os import PathLike
from pathlib import Path
from typing import Any

import numpy as np

from scenespeak import safeio
from scenespeak.errors import CalibrationError
from scenespeak.perception.calibration import StereoRig, load_ros_rig, rig_from_mapping
from scenespeak.perception.rig_readers import _opencv_yaml_loader

__all__ = ["parse_calibration", "read_calibration", "read_calibration_pair"]

_MAX_MATRIX = 10_000  # elements of one calibration matrix (the largest real one has 14)


def _check_matrices(data: Any, source: Path) -> None:
    """Refuse ``{rows, cols, data}`` entries that claim more elements than they could hold."""
    if not isinstance(data, Mapping):
        return
    for key, value in data.items():
        if isinstance(value, Mapping) and "data" in value:
            _check_matrix(key, value, source)


def _rows_cols(value: Mapping[str, Any]) -> tuple[Any, Any]:
    """The rows and columns a matrix entry claims (``sizes`` of an opencv-nd-matrix first)."""
    sizes = value.get("sizes")
    if isinstance(sizes, list) and sizes:  # opencv-nd-matrix (OpenCV 5 writes 1-D so)
        return sizes[0], int(np.prod(sizes[1:])) if len(sizes) > 1 else 1
    return value.get("rows", 1), value.get("cols", 1)


def _check_matrix(key: Any, value: Mapping[str, Any], source: Path) -> None:
    """One ``{rows, cols, data}`` entry: whole, bounded sizes and as many numbers as claimed."""
    rows, cols = _rows_cols(value)
    if not all(isinstance(v, int) and not isinstance(v, bool) for v in (rows, cols)):
        raise CalibrationError(source, f"{key}: rows and cols must be whole numbers")
    if rows < 1 or cols < 1 or rows * cols > _MAX_MATRIX:
        raise CalibrationError(
            source, f"{key}: a {rows} x {cols} matrix is not a calibration matrix"
        )
    items = value["data"]
    if not isinstance(items, list) or len(items) != rows * cols:
        n = len(items) if isinstance(items, list) else "no list of"
        raise CalibrationError(
            source, f"{key}: rows x cols = {rows * cols} but data has {n} numbers"
        )


_CAMERA_KEYS = (
    "M1", "K1", "cameraMatrix1", "K_left", "camera_matrix_left", "left_K",
    "M2", "K2", "cameraMatrix2", "K_right", "camera_matrix_right", "right_K",
)  # fmt: skip


_NUMERIC = {
    "baseline", "hfov_deg", "image_size", "imageSize", "size", "image_width", "image_height",
    "width", "height", "R", "T", "up", "P", "K", "D",
    *_CAMERA_KEYS, "dist_left", "dist_right", "D1", "D2", "distCoeffs1", "distCoeffs2",
    "camera_matrix", "distortion_coefficients", "rectification_matrix", "projection_matrix",
}  # fmt: skip


def _has_bool(value: Any) -> bool:
    stack = [value]
    while stack:
        x = stack.pop()
        if isinstance(x, bool):
            return True
        if isinstance(x, Mapping):
            stack.extend(v for k, v in x.items() if k in ("data", "rows", "cols"))
        elif isinstance(x, list | tuple):
            stack.extend(x)
    return False


def _normalise(data: Any, source: Path) -> Any:
    """``imageSize`` as a matrix → ``[w, h]``; true/false where numbers belong refused."""
    if not isinstance(data, Mapping):
        return data
    for key in _NUMERIC & set(data):
        if _has_bool(data[key]):
            raise CalibrationError(source, f"{key}: expected numbers, got true/false")
    out = dict(data)
    for key in ("imageSize", "image_size", "size"):
        value = out.get(key)
        if isinstance(value, Mapping) and "data" in value:
            out[key] = value["data"]
    return out


def _xml_mapping(data: bytes, source: Path) -> dict[str, Any]:
    """An OpenCV FileStorage XML file (checked by :func:`safeio.check_xml`) as a mapping."""
    import cv2

    safeio.check_xml(data, source, error=CalibrationError)
    for m in re.finditer(rb"<rows>\s*(\d+)\s*</rows>\s*<cols>\s*(\d+)\s*</cols>", data):
        if int(m.group(1)[:12]) * int(m.group(2)[:12]) > _MAX_MATRIX:
            raise CalibrationError(
                source,
                f"a {int(m.group(1)[:12])} x {int(m.group(2)[:12])} matrix is not a "
                "calibration matrix",
            )
    safeio.quiet_opencv()
    try:
        fs = cv2.FileStorage(
            data.decode("utf-8", "replace"), cv2.FILE_STORAGE_READ | cv2.FILE_STORAGE_MEMORY
        )
    except Exception:  # cv2.error, or SystemError from its Python binding
        raise CalibrationError(source, "is not a valid OpenCV FileStorage XML file") from None
    try:
        if not fs.isOpened():
            raise CalibrationError(source, "is not a valid OpenCV FileStorage XML file")
        out: dict[str, Any] = {}
        root = fs.root()
        for key in root.keys():
            node = fs.getNode(key)
            if node.isSeq():
                out[key] = [node.at(i).real() for i in range(min(node.size(), _MAX_MATRIX))]
            elif node.isInt() or node.isReal():
                out[key] = node.real()
            elif node.isString():
                out[key] = node.string()
            elif node.isMap() and node.mat() is not None:
                out[key] = node.mat()
        return out
    except Exception as exc:
        if isinstance(exc, CalibrationError):
            raise
        raise CalibrationError(source, "is not a valid OpenCV FileStorage XML file") from None
    finally:
        fs.release()


def parse_calibration(path: str | PathLike[str]) -> dict[str, Any]:
    """Read and parse one calibration file into a mapping (nothing is validated yet).

    Raises
    ------
    CalibrationError
        Not a regular file, too large, not UTF-8, a syntax error, nesting or numbers over the
        limits, YAML tags that are not allowed, XML entities, not a mapping at the top.
    """
    p = Path(path)
    suffix = p.suffix.lower()
    from scenespeak import limits

    data_bytes = safeio.read_bytes(
        p,
        error=CalibrationError,
        max_bytes=limits.current().max_text_bytes,
        what="calibration file",
    )
    if suffix == ".xml" or data_bytes.lstrip()[:5] in (b"<?xml", b"<open"):
        return _xml_mapping(data_bytes, p)
    try:
        text = data_bytes.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise CalibrationError(p, "is not a text file (expected JSON, YAML or XML)") from None
    if not text.strip():
        raise CalibrationError(p, "the file is empty (only white space)")
    if "\x00" in text:
        raise CalibrationError(p, "is not a text file (it contains NUL bytes)")
    if suffix == ".json" or (suffix not in (".yml", ".yaml") and text.lstrip()[:1] == "{"):
        data = safeio.load_json(text, p, error=CalibrationError)
    else:
        data = safeio.load_yaml(text, p, loader=_opencv_yaml_loader(), error=CalibrationError)
    if not isinstance(data, Mapping):
        raise CalibrationError(p, "expected a mapping of calibration keys at the top level")
    _check_matrices(data, p)
    return _normalise(data, p)


def _is_ros(d: Mapping[str, Any]) -> bool:
    return "camera_matrix" in d or "projection_matrix" in d or ("K" in d and "P" in d)


def _is_intrinsics(d: Mapping[str, Any]) -> bool:
    """OpenCV stereo_calib's intrinsics.yml: camera matrices, no R and T."""
    return any(k in d for k in _CAMERA_KEYS) and "T" not in d and "R" not in d


def _is_extrinsics(d: Mapping[str, Any]) -> bool:
    """OpenCV stereo_calib's extrinsics.yml: R and T, no camera matrix."""
    return "T" in d and not any(k in d for k in _CAMERA_KEYS)


def read_calibration(
    path: str | PathLike[str], *, image_size: tuple[int, int] | None = None
) -> StereoRig:
    """One calibration file (JSON short/full form, OpenCV YAML/XML/JSON) as a rig."""
    p = Path(path)
    data = parse_calibration(p)
    if _is_ros(data):
        raise CalibrationError(
            p,
            "is one camera's ROS camera_info file: give the right camera's file too with "
            "--calib-right RIGHT.yaml (API: read_calibration_pair(left, right))",
        )
    if _is_intrinsics(data):
        raise CalibrationError(
            p,
            "holds only intrinsics (M1 D1 M2 D2, OpenCV's stereo_calib intrinsics.yml): give "
            "its extrinsics.yml (R, T) too with --calib-right extrinsics.yml",
        )
    if _is_extrinsics(data):
        raise CalibrationError(
            p,
            "holds only extrinsics (R, T, OpenCV's stereo_calib extrinsics.yml): give "
            "intrinsics.yml as --calib and this file as --calib-right",
        )
    return rig_from_mapping(data, str(p), image_size=image_size)


def read_calibration_pair(
    first: str | PathLike[str],
    second: str | PathLike[str],
    *,
    image_size: tuple[int, int] | None = None,
) -> StereoRig:
    """Two calibration files: a ROS camera_info pair, or intrinsics.yml + extrinsics.yml.

    A ROS pair's ``up:`` (in the left file, or the right one) is honoured. For the OpenCV pair
    either order is accepted; ``image_size`` is used when neither file has one.
    """
    a, b = Path(first), Path(second)
    da, db = parse_calibration(a), parse_calibration(b)
    if _is_ros(da) and _is_ros(db):
        up = da.get("up", db.get("up"))
        rig = load_ros_rig(a, b, up=None)
        if up is not None:
            rig = rig_from_mapping({**_rig_mapping(rig), "up": up}, rig.source)
        return rig
    if _is_ros(da) or _is_ros(db):
        raise CalibrationError(
            b if _is_ros(da) else a,
            "is not a ROS camera_info file like the other one: give two camera_info files",
        )
    if _is_extrinsics(da) and _is_intrinsics(db):
        da, db, a, b = db, da, b, a
    if not (_is_intrinsics(da) and _is_extrinsics(db)):
        raise CalibrationError(
            f"{a} + {b}",
            "a pair must be two ROS camera_info files (left, right) or OpenCV's stereo_calib "
            "intrinsics.yml (M1 D1 M2 D2) + extrinsics.yml (R T)",
        )
    merged = {**db, **da}
    return rig_from_mapping(merged, f"{a} + {b}", image_size=image_size)


def _rig_mapping(rig: StereoRig) -> dict[str, Any]:
    return {
        "image_size": list(rig.image_size),
        "K_left": np.asarray(rig.K_left).tolist(),
        "K_right": np.asarray(rig.K_right).tolist(),
        "dist_left": np.asarray(rig.dist_left).tolist(),
        "dist_right": np.asarray(rig.dist_right).tolist(),
        "R": np.asarray(rig.R).tolist(),
        "T": np.asarray(rig.T).tolist(),
    }
