"""Reading a stereo calibration: the JSON short and full forms, OpenCV FileStorage, ROS pairs.

:func:`rig_from_mapping` builds a :class:`~scenespeak.perception.rig.StereoRig` from a parsed
file (accepting OpenCV's and other tools' key names), :func:`load_rig` reads one file and
:func:`load_ros_rig` a pair of ROS ``camera_info`` files; every one raises
:class:`~scenespeak.errors.CalibrationError` naming the file and the problem.

>>> rig_from_mapping({"baseline": 0.12, "hfov_deg": 60, "image_size": [640, 480]}).baseline
0.12
"""

from __future__ import annotations

import functools
import json
from collections.abc import Mapping, Sequence
from os import PathLike
from pathlib import Path
from typing import TYPE_CHECKING, Any

import cv2
import numpy as np
from numpy.typing import ArrayLike, NDArray

from scenespeak.errors import CalibrationError
from scenespeak.geometry.frames import DEFAULT_UP
from scenespeak.perception.rig import (
    StereoRig,
    _as_dist,
    _as_matrix,
    _as_size,
    _as_up,
    _check_K,
    _short_rig,
)
from scenespeak.safeio import as_path

if TYPE_CHECKING:  # PyYAML is imported when a YAML file is read
    import yaml

__all__ = ["load_rig", "load_ros_rig", "rig_from_mapping"]


_ALIASES: dict[str, tuple[str, ...]] = {
    "K_left": ("K_left", "K1", "M1", "cameraMatrix1", "camera_matrix_left", "left_K"),
    "K_right": ("K_right", "K2", "M2", "cameraMatrix2", "camera_matrix_right", "right_K"),
    "dist_left": ("dist_left", "D1", "distCoeffs1", "dist_coeffs_left", "left_D"),
    "dist_right": ("dist_right", "D2", "distCoeffs2", "dist_coeffs_right", "right_D"),
    "R": ("R",),
    "T": ("T",),
    "up": ("up",),
}


def _pick(d: Mapping[str, Any], names: Sequence[str]) -> Any:
    for n in names:
        if n in d and d[n] is not None:
            return d[n]
    return None


def _size_from_mapping(
    d: Mapping[str, Any], source: str, image_size: tuple[int, int] | None
) -> tuple[int, int]:
    size = _pick(d, ("image_size", "imageSize", "size"))
    if size is not None:
        return _as_size(size, source)
    for wk, hk in (("image_width", "image_height"), ("width", "height")):
        if wk in d and hk in d:
            return _as_size([d[wk], d[hk]], source)
    if image_size is not None:
        return _as_size(image_size, source)
    raise CalibrationError(
        source, 'missing key "image_size" ([width, height] of the images the rig was calibrated on)'
    )


def rig_from_mapping(
    d: Mapping[str, Any],
    source: str = "calibration",
    *,
    image_size: tuple[int, int] | None = None,
) -> StereoRig:
    """Build a rig from a parsed calibration (JSON short or full form, or OpenCV names).

    Parameters
    ----------
    d : mapping
        Either the short form (``baseline``, ``hfov_deg``, ``image_size``, optional ``up``) or
        the full form (``K_left``/``K1``/``M1``, ``K_right``/``K2``/``M2``, ``dist_left``/``D1``,
        ``dist_right``/``D2``, ``R``, ``T``, image size, optional ``up``). Matrices may be nested
        lists, flat lists or ``{rows, cols, data}`` mappings; ``R`` may also be a rotation
        vector (3 numbers, OpenCV's Rodrigues form).
    source : str
        Name used in error messages.
    image_size : (w, h), optional
        Used only when the mapping has no image size (OpenCV's samples do not write one).
    """
    if not isinstance(d, Mapping):
        raise CalibrationError(source, "expected a mapping of calibration keys at the top level")
    if "baseline" in d or "hfov_deg" in d:
        for key in ("baseline", "hfov_deg"):
            if key not in d:
                raise CalibrationError(source, f'short form: missing key "{key}"')
        return _short_rig(
            d["baseline"],
            d["hfov_deg"],
            _size_from_mapping(d, source, image_size),
            d.get("up"),
            source=source,
        )
    values: dict[str, Any] = {}
    for key, names in _ALIASES.items():
        values[key] = _pick(d, names)
    for key in ("K_left", "K_right", "R", "T"):
        if values[key] is None:
            alias = " / ".join(_ALIASES[key])
            raise CalibrationError(source, f'missing key "{key}" (accepted names: {alias})')
    size = _size_from_mapping(d, source, image_size)
    r_value = values["R"]
    if isinstance(r_value, Mapping) and "data" in r_value:
        r_value = r_value["data"]
    if np.size(np.asarray(r_value, dtype=object)) == 3:  # a rotation vector (Rodrigues)
        rvec = _as_matrix(r_value, (3,), "R", source)
        r_value = cv2.Rodrigues(rvec)[0]
    return StereoRig(
        size,
        _as_matrix(values["K_left"], (3, 3), "K_left", source),
        _as_matrix(values["K_right"], (3, 3), "K_right", source),
        _as_dist(values["dist_left"], "dist_left", source),
        _as_dist(values["dist_right"], "dist_right", source),
        _as_matrix(r_value, (3, 3), "R", source),
        _as_matrix(values["T"], (3,), "T", source),
        _as_up(values["up"], source),
        source,
    )


@functools.cache
def _opencv_yaml_loader() -> type[yaml.SafeLoader]:
    """PyYAML loader that understands OpenCV FileStorage's ``!!opencv-matrix`` tags (made on
    first use: PyYAML is imported only for a YAML file, not for every command that reads a
    JSON calibration, about 20 ms of start-up, issue 16)."""
    import yaml

    class _OpenCVYamlLoader(yaml.SafeLoader):
        pass

    def _construct_opencv_matrix(loader: yaml.SafeLoader, node: yaml.Node) -> dict[str, Any]:
        return dict(loader.construct_mapping(node, deep=True))

    for tag in ("tag:yaml.org,2002:opencv-matrix", "tag:yaml.org,2002:opencv-nd-matrix"):
        _OpenCVYamlLoader.add_constructor(tag, _construct_opencv_matrix)
    return _OpenCVYamlLoader


def _read_text(p: Path) -> str:
    """The file's text, read as untrusted input (a FIFO never blocks, size bounded)."""
    from scenespeak.safetext import read_bytes

    data = read_bytes(p, error=CalibrationError, what="calibration file")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        raise CalibrationError(p, "is not a text file (expected JSON or YAML)") from None
    if not text.strip():
        raise CalibrationError(p, "the file is empty")
    return text


def _parse_yaml(text: str, p: Path) -> Any:
    lines = text.splitlines()
    if lines and lines[0].startswith("%YAML"):
        lines = lines[1:]  # OpenCV writes "%YAML:1.0", which PyYAML rejects
    import yaml

    try:
        return yaml.load("\n".join(lines), Loader=_opencv_yaml_loader())
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" at line {mark.line + 1}" if mark is not None else ""
        raise CalibrationError(p, f"is not valid YAML{where}") from None


def load_rig(path: str | PathLike[str], *, image_size: tuple[int, int] | None = None) -> StereoRig:
    """Load a stereo calibration file.

    Parameters
    ----------
    path : str or path-like
        ``.json`` (short or full form of ``docs/interfaces.md``, or OpenCV names),
        ``.yml``/``.yaml``
        (OpenCV FileStorage with ``!!opencv-matrix``, or plain YAML with the same keys) or
        ``.xml`` (OpenCV FileStorage).
    image_size : (w, h), optional
        Image size to assume when the file has none (OpenCV's samples write none).

    Returns
    -------
    StereoRig

    Raises
    ------
    CalibrationError
        Missing/unreadable file, syntax error, missing key, wrong shape, NaN/inf, singular
        matrix, R not a rotation, zero baseline, ...
    """
    p = as_path(path, error=CalibrationError)
    source = str(p)
    suffix = p.suffix.lower()
    if suffix == ".xml":  # bounded: regular file, no DOCTYPE/entities, parsed from memory
        from scenespeak.perception.calibfiles import parse_calibration

        data: Any = parse_calibration(p)
    else:
        text = _read_text(p)
        if suffix == ".json" or (suffix not in (".yml", ".yaml") and text.lstrip()[:1] == "{"):
            try:
                data = json.loads(text)
            except json.JSONDecodeError as exc:
                raise CalibrationError(
                    p, f"is not valid JSON (line {exc.lineno}, column {exc.colno}: {exc.msg})"
                ) from None
        else:
            data = _parse_yaml(text, p)
    if not isinstance(data, Mapping):
        raise CalibrationError(p, "expected a mapping of calibration keys at the top level")
    if "camera_matrix" in data or ("K" in data and "P" in data):
        raise CalibrationError(
            p,
            "is a single ROS camera_info file; give both: load_ros_rig(left.yaml, right.yaml) "
            "(CLI: --calib left.yaml --calib-right right.yaml)",
        )
    return rig_from_mapping(data, source, image_size=image_size)


def _ros_camera(path: str | PathLike[str]) -> dict[str, Any]:
    p = as_path(path, error=CalibrationError)
    data = _parse_yaml(_read_text(p), p)
    if not isinstance(data, Mapping):
        raise CalibrationError(p, "expected a ROS camera_info mapping at the top level")
    src = str(p)

    def get(names: Sequence[str], shape: tuple[int, ...], what: str) -> NDArray[np.float64]:
        v = _pick(data, names)
        if v is None:
            raise CalibrationError(src, f'missing key "{names[0]}" ({what})')
        return _as_matrix(v, shape, names[0], src)

    K = get(("camera_matrix", "K", "k"), (3, 3), "camera matrix")
    Rr = get(("rectification_matrix", "R", "r"), (3, 3), "rectification rotation")
    P = get(("projection_matrix", "P", "p"), (3, 4), "projection matrix")
    D = _as_dist(_pick(data, ("distortion_coefficients", "D", "d")), "D", src)
    model = str(_pick(data, ("distortion_model",)) or "plumb_bob")
    if model not in ("plumb_bob", "rational_polynomial", ""):
        raise CalibrationError(
            src, f"distortion_model {model!r} is not supported (plumb_bob, rational_polynomial)"
        )
    size = _size_from_mapping(data, src, None)
    _check_K(K, "K", src)
    if not np.allclose(Rr.T @ Rr, np.eye(3), atol=1e-4) or np.linalg.det(Rr) < 0.999:
        raise CalibrationError(src, "the rectification matrix R is not a rotation")
    return {"K": K, "D": D, "R": Rr, "P": P, "size": size, "source": src}


def load_ros_rig(
    left_yaml: str | PathLike[str],
    right_yaml: str | PathLike[str],
    *,
    up: ArrayLike | None = None,
) -> StereoRig:
    """Load a rig from a pair of ROS ``camera_info`` YAML files.

    Both the ``camera_calibration`` file layout (``camera_matrix: {rows, cols, data}``,
    ``distortion_coefficients``, ``rectification_matrix``, ``projection_matrix``,
    ``image_width``, ``image_height``) and the message layout (``K``, ``D``, ``R``, ``P``,
    ``width``, ``height``) are read. The baseline comes from the right projection matrix:
    ``P_right[0, 3] = −fx' · B``. The extrinsics follow from the rectifying rotations:
    ``R = R_right^T R_left`` and ``T = R_right^T [−B, 0, 0]``.
    """
    left = _ros_camera(left_yaml)
    right = _ros_camera(right_yaml)
    src = f"{left['source']} + {right['source']}"
    if left["size"] != right["size"]:
        raise CalibrationError(
            src,
            f"left and right camera_info have different sizes {left['size']} and {right['size']}",
        )
    P2 = right["P"]
    if P2[0, 0] <= 0:
        raise CalibrationError(right["source"], "projection matrix P has fx' <= 0")
    tx = P2[0, 3] / P2[0, 0]  # = -B
    ty = P2[1, 3] / P2[1, 1] if P2[1, 1] > 0 else 0.0
    if abs(tx) < 1e-12 and abs(ty) < 1e-12:
        raise CalibrationError(
            right["source"],
            "P[0, 3] is 0: this is not the right camera of a stereo pair (P[0,3] = -fx * B)",
        )
    t_rect = np.array([tx, ty, 0.0])
    R = right["R"].T @ left["R"]
    T = right["R"].T @ t_rect
    return StereoRig(
        left["size"],
        left["K"],
        right["K"],
        left["D"],
        right["D"],
        R,
        T,
        np.array(DEFAULT_UP) if up is None else np.asarray(up, dtype=np.float64),
        src,
    )
