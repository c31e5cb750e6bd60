"""Stage 0: the stereo rig — calibration files, rectification, the up vector, the ground frame.

A :class:`StereoRig` holds both cameras' intrinsics and distortion, the extrinsics in OpenCV's
``stereoCalibrate`` convention (a point ``X`` in the left camera frame is ``R @ X + T`` in the
right camera frame, so a right camera 12 cm to the right has ``T = [-0.12, 0, 0]``), the image
size and the world's ``up`` direction in the left camera frame.

Calibrations load from

* the JSON short form ``{"baseline", "hfov_deg", "image_size", "up"?}`` (:func:`rig_from_short`),
* the JSON full form (``K_left``, ``K_right``, ``dist_left``, ``dist_right``, ``R``, ``T``, ...),
* OpenCV FileStorage YAML/XML/JSON with the names OpenCV's stereo samples use
  (``K1``/``M1``, ``D1``, ``K2``/``M2``, ``D2``, ``R``, ``T``, image size),
* a pair of ROS ``camera_info`` YAML files (:func:`load_ros_rig`).

Every loader validates and raises :class:`~scenespeak.errors.CalibrationError` naming the file
and the problem.

>>> from scenespeak.perception.calibration import rig_from_short, rectify, ground_basis
>>> rig = rig_from_short(0.12, 60.0, (640, 480))
>>> round(rig.baseline, 3), round(float(rig.K_left[0, 0]), 1)
(0.12, 554.3)
>>> rectify(rig).needs_resampling
False
>>> ground_basis([0, -1, 0]).tolist()
[[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from os import PathLike
from pathlib import Path
from typing import Any, cast

import cv2
import numpy as np
import yaml
from numpy.typing import ArrayLike, NDArray

from scenespeak import limits as _limits
from scenespeak.errors import CalibrationError, ImageError
from scenespeak.geometry.frames import DEFAULT_UP, ground_basis, heights, to_ground
from scenespeak.safeio import as_path

__all__ = [
    "DEFAULT_UP",
    "CalibrationMismatchError",
    "Rectification",
    "StereoRig",
    "ground_basis",
    "heights",
    "load_rig",
    "load_ros_rig",
    "rectify",
    "rig_from_mapping",
    "rig_from_short",
    "to_ground",
]


_VALID_DIST_LENGTHS = (4, 5, 8, 12, 14)


class CalibrationMismatchError(CalibrationError, ImageError):
    """The images do not fit the calibration (e.g. a different size).

    Both a :class:`~scenespeak.errors.CalibrationError` and an
    :class:`~scenespeak.errors.ImageError`, so a caller catching either sees it.
    """


# --------------------------------------------------------------------------------------------
# the rig


def _readonly(a: NDArray[np.float64]) -> NDArray[np.float64]:
    a = np.array(a, dtype=np.float64, copy=True)
    a.setflags(write=False)
    return a


def _as_matrix(value: Any, shape: tuple[int, ...], name: str, source: str) -> NDArray[np.float64]:
    """Coerce ``value`` (nested lists, flat list, ``{rows, cols, data}``) to a float array."""
    if isinstance(value, Mapping) and "data" in value:
        value = value["data"]
    if np.iscomplexobj(value):
        raise CalibrationError(source, f"{name} must be real numbers, got complex ones")
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise CalibrationError(
            source, f"{name} must be numbers of shape {shape}, got {value!r:.80}"
        ) from None
    size = int(np.prod(shape))
    if arr.shape != shape:
        if arr.size == size:
            arr = arr.reshape(shape)
        else:
            raise CalibrationError(source, f"{name} must have shape {shape}, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise CalibrationError(source, f"{name} contains NaN or infinite values")
    return arr


def _as_dist(value: Any, name: str, source: str) -> NDArray[np.float64]:
    if value is None:
        return np.zeros(5)
    if isinstance(value, Mapping) and "data" in value:
        value = value["data"]
    try:
        arr = np.asarray(value, dtype=np.float64).ravel()
    except (TypeError, ValueError):
        raise CalibrationError(source, f"{name} must be a list of numbers") from None
    if arr.size == 0:
        return np.zeros(5)
    if arr.size not in _VALID_DIST_LENGTHS:
        raise CalibrationError(
            source,
            f"{name} must have 4, 5, 8, 12 or 14 coefficients (OpenCV order k1, k2, p1, p2, k3, "
            f"...), got {arr.size}",
        )
    if not np.all(np.isfinite(arr)):
        raise CalibrationError(source, f"{name} contains NaN or infinite values")
    if arr.size < 5:
        arr = np.concatenate([arr, np.zeros(5 - arr.size)])
    return arr


def _check_K(K: NDArray[np.float64], name: str, source: str) -> None:
    if not (K[0, 0] > 0 and K[1, 1] > 0):
        raise CalibrationError(
            source,
            f"{name} is singular or invalid: focal lengths must be > 0, got "
            f"fx={K[0, 0]:g}, fy={K[1, 1]:g}",
        )
    if not np.allclose(K[2], [0.0, 0.0, 1.0]) or abs(K[1, 0]) > 1e-9:
        raise CalibrationError(
            source, f"{name} must be [[fx, s, cx], [0, fy, cy], [0, 0, 1]], got {K.tolist()}"
        )
    if abs(np.linalg.det(K)) < 1e-12:
        raise CalibrationError(source, f"{name} is singular")


def _as_up(value: Any, source: str) -> NDArray[np.float64]:
    if value is None:
        return np.array(DEFAULT_UP)
    up = _as_matrix(value, (3,), "up", source)
    n = float(np.linalg.norm(up))
    if n < 1e-9:
        raise CalibrationError(source, "up must be a non-zero 3-vector, e.g. [0, -1, 0]")
    return up / n


def _as_size(value: Any, source: str) -> tuple[int, int]:
    items = list(value) if isinstance(value, list | tuple) else None
    if items is not None and any(isinstance(v, bool | np.bool_ | str | bytes) for v in items):
        raise CalibrationError(
            source, f"image_size must be two whole numbers [width, height], got {value!r:.80}"
        )
    try:
        w, h = (float(v) for v in np.asarray(value, dtype=np.float64).ravel())
    except (TypeError, ValueError):
        raise CalibrationError(
            source, f"image_size must be [width, height], got {value!r:.80}"
        ) from None
    if not (math.isfinite(w) and math.isfinite(h)) or w != int(w) or h != int(h) or w < 1 or h < 1:
        raise CalibrationError(
            source, f"image_size must be two positive whole numbers [width, height], got {value!r}"
        )
    return int(w), int(h)


@dataclass(frozen=True, eq=False)
class StereoRig:
    """A calibrated stereo pair of cameras.

    Arrays are converted to read-only float64 and the whole rig is validated on construction.

    Attributes
    ----------
    image_size : (int, int)
        Width and height in pixels of the images the calibration is for.
    K_left, K_right : (3, 3) ndarray
        Camera matrices ``[[fx, s, cx], [0, fy, cy], [0, 0, 1]]``.
    dist_left, dist_right : (n,) ndarray
        OpenCV distortion coefficients (k1, k2, p1, p2, k3, ...); n is 5, 8, 12 or 14.
    R : (3, 3) ndarray
        Rotation from the left camera frame to the right camera frame.
    T : (3,) ndarray
        Translation in metres: ``X_right = R @ X_left + T``.
    up : (3,) ndarray
        Unit vector of the world's up direction in the left camera's OpenCV frame.
    source : str
        Where the calibration came from (a file name), used in error messages.

    Raises
    ------
    CalibrationError
        Wrong shapes, NaN/inf, singular K, R not a rotation, zero baseline, bad image size.
    """

    image_size: tuple[int, int]
    K_left: NDArray[np.float64]
    K_right: NDArray[np.float64]
    dist_left: NDArray[np.float64]
    dist_right: NDArray[np.float64]
    R: NDArray[np.float64]
    T: NDArray[np.float64]
    up: NDArray[np.float64] = field(default_factory=lambda: np.array(DEFAULT_UP))
    source: str = "calibration"

    def __post_init__(self) -> None:
        src = self.source
        object.__setattr__(self, "image_size", _as_size(self.image_size, src))
        K1 = _as_matrix(self.K_left, (3, 3), "K_left", src)
        K2 = _as_matrix(self.K_right, (3, 3), "K_right", src)
        _check_K(K1, "K_left", src)
        _check_K(K2, "K_right", src)
        D1 = _as_dist(self.dist_left, "dist_left", src)
        D2 = _as_dist(self.dist_right, "dist_right", src)
        R = _as_matrix(self.R, (3, 3), "R", src)
        if not np.allclose(R.T @ R, np.eye(3), atol=1e-4) or np.linalg.det(R) < 0.999:
            raise CalibrationError(
                src, f"R is not a rotation matrix (R^T R != I or det(R) != 1): {R.tolist()}"
            )
        T = _as_matrix(self.T, (3,), "T", src)
        if np.linalg.norm(T) < 1e-9:
            raise CalibrationError(src, "the baseline is zero (T = [0, 0, 0]); T is in metres")
        up = _as_up(self.up, src)
        for name, arr in (
            ("K_left", K1),
            ("K_right", K2),
            ("dist_left", D1),
            ("dist_right", D2),
            ("R", R),
            ("T", T),
            ("up", up),
        ):
            object.__setattr__(self, name, _readonly(arr))

    @property
    def baseline(self) -> float:
        """Distance between the camera centres in metres."""
        return float(np.linalg.norm(self.T))

    @property
    def is_rectified(self) -> bool:
        """Whether the images can be matched row to row without resampling.

        True when R is the identity, T lies along −x, there is no distortion and both cameras
        share fx, fy and cy (cx may differ, like Middlebury's ``doffs``).
        """
        K1, K2 = self.K_left, self.K_right
        tol = 1e-6
        return bool(
            np.allclose(self.R, np.eye(3), atol=tol)
            and self.T[0] < 0
            and abs(self.T[1]) <= tol * self.baseline
            and abs(self.T[2]) <= tol * self.baseline
            and not np.any(self.dist_left)
            and not np.any(self.dist_right)
            and abs(K1[0, 0] - K2[0, 0]) <= tol * K1[0, 0]
            and abs(K1[1, 1] - K2[1, 1]) <= tol * K1[1, 1]
            and abs(K1[1, 2] - K2[1, 2]) <= tol * K1[1, 1]
            and abs(K1[0, 1]) <= tol
            and abs(K2[0, 1]) <= tol
        )

    def with_up(self, up: ArrayLike) -> StereoRig:
        """Return a copy of the rig with another up vector."""
        return StereoRig(
            self.image_size,
            self.K_left,
            self.K_right,
            self.dist_left,
            self.dist_right,
            self.R,
            self.T,
            np.asarray(up, dtype=np.float64),
            self.source,
        )

    def check_image_size(self, size: tuple[int, int], image: str = "the images") -> None:
        """Raise :class:`CalibrationMismatchError` if ``size`` (w, h) is not the rig's size."""
        w, h = int(size[0]), int(size[1])
        if (w, h) != self.image_size:
            cw, ch = self.image_size
            raise CalibrationMismatchError(
                self.source,
                f"the calibration is for {cw}x{ch} images but {image} is {w}x{h}; "
                "use the calibration made for these images (or resize them)",
            )

    def to_dict(self) -> dict[str, Any]:
        """The JSON full form of the rig (see ``docs/interfaces.md``)."""
        return {
            "image_size": list(self.image_size),
            "K_left": self.K_left.tolist(),
            "K_right": self.K_right.tolist(),
            "dist_left": self.dist_left.tolist(),
            "dist_right": self.dist_right.tolist(),
            "R": self.R.tolist(),
            "T": self.T.tolist(),
            "up": self.up.tolist(),
        }

    def allclose(self, other: StereoRig, *, rtol: float = 1e-6, atol: float = 1e-9) -> bool:
        """Whether two rigs describe the same cameras (``source`` is ignored)."""
        if self.image_size != other.image_size:
            return False
        pairs = [
            (self.K_left, other.K_left),
            (self.K_right, other.K_right),
            (self.R, other.R),
            (self.T, other.T),
            (self.up, other.up),
        ]
        for a, b in [(self.dist_left, other.dist_left), (self.dist_right, other.dist_right)]:
            n = max(a.size, b.size)
            pairs.append((np.pad(a, (0, n - a.size)), np.pad(b, (0, n - b.size))))
        return all(np.allclose(a, b, rtol=rtol, atol=atol) for a, b in pairs)


def rig_from_short(
    baseline: float,
    hfov_deg: float,
    image_size: Sequence[int] | tuple[int, int],
    up: ArrayLike | None = None,
    *,
    source: str = "calibration",
    units: str = "m",
) -> StereoRig:
    """A parallel, rectified rig from the paper's three numbers.

    ``fx = fy = (w / 2) / tan(hfov / 2)``; the principal point is the image centre
    ``((w − 1) / 2, (h − 1) / 2)`` in OpenCV's pixel-centre convention; no distortion; the right
    camera ``baseline`` metres to the right (``T = [−baseline, 0, 0]``).

    ``units`` (``"m"``, ``"cm"`` or ``"mm"``) is the unit ``baseline`` is given in. A baseline
    over :attr:`~scenespeak.limits.Limits.max_baseline_m` once in metres is refused with the
    fix (``units="mm"``): a 120 m stereo rig is a 120 mm one written in the wrong unit.

    Examples
    --------
    >>> rig = rig_from_short(0.12, 60.0, (640, 480))
    >>> rig.T.tolist(), rig.K_left[:2, 2].tolist()
    ([-0.12, 0.0, 0.0], [319.5, 239.5])
    >>> rig_from_short(120.0, 60.0, (640, 480), units="mm").baseline
    0.12
    >>> rig_from_short(120.0, 60.0, (640, 480))  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    scenespeak.errors.CalibrationError: calibration: the baseline is 120 m, ... units='mm' ...
    """
    scale = {"m": 1.0, "cm": 0.01, "mm": 0.001}.get(units) if isinstance(units, str) else None
    if scale is None:
        raise CalibrationError(source, f"unknown unit {units!r}; use one of 'm', 'cm', 'mm'")
    rig = _short_rig(baseline, hfov_deg, image_size, up, source=source, scale=scale)
    lim = _limits.current()
    b = rig.baseline
    if b > lim.max_baseline_m:
        unit, name = ("mm", "millimetres") if b >= 20 else ("cm", "centimetres")
        raise CalibrationError(
            source,
            f"the baseline is {b:g} m, which looks like {name}: pass units={unit!r} (CLI: "
            f"--units {unit}) or metres (--limit max_baseline_m=N allows larger rigs)",
        )
    return rig


def _number(value: object, name: str, source: str) -> float:
    if isinstance(value, bool | np.bool_ | str | bytes):
        raise CalibrationError(source, f"{name} must be a number, got {value!r:.40}")
    try:
        return float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise CalibrationError(source, f"{name} must be a number, got {value!r:.40}") from None


def _short_rig(
    baseline: object,
    hfov_deg: object,
    image_size: object,
    up: object,
    *,
    source: str,
    scale: float = 1.0,
) -> StereoRig:
    """:func:`rig_from_short` without the plausibility check (a file's units come later)."""
    b = _number(baseline, "baseline", source) * scale
    hfov = _number(hfov_deg, "hfov_deg", source)
    if not math.isfinite(b) or b <= 0:
        raise CalibrationError(source, f"baseline must be a positive number of metres, got {b}")
    if not math.isfinite(hfov) or not 0 < hfov < 180:
        raise CalibrationError(source, f"hfov_deg must be between 0 and 180 degrees, got {hfov}")
    w, h = _as_size(image_size, source)
    f = (w / 2.0) / math.tan(math.radians(hfov) / 2.0)
    K = np.array([[f, 0.0, (w - 1) / 2.0], [0.0, f, (h - 1) / 2.0], [0.0, 0.0, 1.0]])
    return StereoRig(
        (w, h),
        K,
        K,
        np.zeros(5),
        np.zeros(5),
        np.eye(3),
        np.array([-b, 0.0, 0.0]),
        np.array(DEFAULT_UP) if up is None else up,  # type: ignore[arg-type]
        source,
    )


# --------------------------------------------------------------------------------------------
# loading


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


class _OpenCVYamlLoader(yaml.SafeLoader):
    """PyYAML loader that understands OpenCV FileStorage's ``!!opencv-matrix`` tags."""


def _construct_opencv_matrix(loader: yaml.SafeLoader, node: yaml.Node) -> dict[str, Any]:
    m = loader.construct_mapping(node, deep=True)
    return dict(m)


for _tag in ("tag:yaml.org,2002:opencv-matrix", "tag:yaml.org,2002:opencv-nd-matrix"):
    _OpenCVYamlLoader.add_constructor(_tag, _construct_opencv_matrix)


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
    try:
        return yaml.load("\n".join(lines), Loader=_OpenCVYamlLoader)
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


# --------------------------------------------------------------------------------------------
# rectification


@dataclass(frozen=True, eq=False)
class Rectification:
    """How to bring a rig's images into row-aligned (rectified) geometry.

    In rectified coordinates a scene point appears on the same row in both images, and
    ``Z = f · B / (x_left − x_right − (cx_left − cx_right))`` in the rectified left frame.

    Attributes
    ----------
    rig : StereoRig
        The rig this rectification belongs to.
    R1, R2 : (3, 3) ndarray
        Rotations from each original camera frame to its rectified frame (identity when the rig
        is already rectified). A point ``X`` of the original left frame is ``R1 @ X`` in the
        rectified left frame.
    P1, P2 : (3, 4) ndarray
        Projection matrices of the rectified cameras (in the rectified left frame).
    maps_left, maps_right : (map_x, map_y) or None
        ``cv2.remap`` maps from rectified pixels to input pixels (float32, shape (h, w)); None
        when the rig is already rectified: the images are used as they are, and a differing cx
        (Middlebury's ``doffs``) is handled in triangulation, not by resampling.
    """

    rig: StereoRig
    R1: NDArray[np.float64]
    R2: NDArray[np.float64]
    P1: NDArray[np.float64]
    P2: NDArray[np.float64]
    maps_left: tuple[NDArray[np.float32], NDArray[np.float32]] | None
    maps_right: tuple[NDArray[np.float32], NDArray[np.float32]] | None

    @property
    def needs_resampling(self) -> bool:
        """Whether images must be remapped (False for an already rectified rig)."""
        return self.maps_left is not None

    @property
    def focal(self) -> float:
        """Rectified focal length in pixels."""
        return float(self.P1[0, 0])

    @property
    def baseline(self) -> float:
        """Rectified baseline in metres (positive)."""
        return float(-self.P2[0, 3] / self.P2[0, 0])

    @property
    def doffs(self) -> float:
        """``cx_right − cx_left`` of the rectified cameras (0 after OpenCV rectification)."""
        return float(self.P2[0, 2] - self.P1[0, 2])

    def depth_from_disparity(self, disparity: ArrayLike) -> NDArray[np.float64]:
        """Depth Z (rectified left frame) of rectified disparities ``x_left − x_right``."""
        d = np.asarray(disparity, dtype=np.float64) + self.doffs
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(d > 0, self.focal * self.baseline / d, np.inf)

    def _camera(
        self, side: str
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """K, distortion, rectifying rotation and projection matrix of one camera."""
        rig = self.rig
        if side == "left":
            return rig.K_left, rig.dist_left, self.R1, self.P1
        return rig.K_right, rig.dist_right, self.R2, self.P2

    def rectify_points(self, xy: ArrayLike, side: str = "left") -> NDArray[np.float64]:
        """Map pixel coordinates of an input image to the rectified image.

        Parameters
        ----------
        xy : (N, 2) array
            Pixel coordinates (column, row) in the input image.
        side : {"left", "right"}
        """
        pts = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        if not self.needs_resampling or len(pts) == 0:
            return pts.copy()
        K, D, Rr, P = self._camera(side)
        out = cv2.undistortPoints(
            pts.reshape(-1, 1, 2),
            K,
            D,
            R=Rr,
            P=P,
            criteria=(cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 50, 1e-12),
        )
        return np.asarray(out, dtype=np.float64).reshape(-1, 2)

    def unrectify_points(self, xy: ArrayLike, side: str = "left") -> NDArray[np.float64]:
        """Map rectified pixel coordinates back to the input image (inverse of
        :meth:`rectify_points`)."""
        pts = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        if not self.needs_resampling or len(pts) == 0:
            return pts.copy()
        K, D, Rr, P = self._camera(side)
        rays = np.column_stack([pts, np.ones(len(pts))]) @ np.linalg.inv(P[:, :3]).T
        rays = rays @ Rr  # Rr.T @ ray for each row: back to the original camera frame
        img, _ = cv2.projectPoints(rays.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), K, D)
        return np.asarray(img, dtype=np.float64).reshape(-1, 2)

    def rectify_images(
        self, left: NDArray[np.generic], right: NDArray[np.generic]
    ) -> tuple[NDArray[np.generic], NDArray[np.generic]]:
        """Resample both images into rectified geometry (returns them as they are when the rig
        is already rectified)."""
        if self.maps_left is None or self.maps_right is None:
            return left, right
        lx, ly = self.maps_left
        rx, ry = self.maps_right
        return (
            cv2.remap(_cv(left), lx, ly, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT),
            cv2.remap(_cv(right), rx, ry, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT),
        )

    def to_original(self, xyz_rect: ArrayLike) -> NDArray[np.float64]:
        """Points of the rectified left frame in the original left camera frame."""
        return np.asarray(xyz_rect, dtype=np.float64).reshape(-1, 3) @ self.R1


def rectify(rig: StereoRig, *, alpha: float = 1.0) -> Rectification:
    """Compute the rectification of a rig.

    Parameters
    ----------
    rig : StereoRig
    alpha : float
        OpenCV's free scaling for unrectified rigs: 1 keeps every input pixel in the rectified
        image (with black borders), 0 keeps only valid pixels.

    Returns
    -------
    Rectification
        Without maps when :attr:`StereoRig.is_rectified`.

    Raises
    ------
    CalibrationError
        If the right camera is not to the right of the left one (after rectification the
        baseline would not be horizontal with the right camera at +x).
    """
    K1, K2 = rig.K_left, rig.K_right
    if rig.is_rectified:
        f = float(K1[0, 0])
        fy = float(K1[1, 1])
        cy = float(K1[1, 2])
        B = rig.baseline
        P1 = np.array([[f, K1[0, 1], K1[0, 2], 0.0], [0.0, fy, cy, 0.0], [0.0, 0.0, 1.0, 0.0]])
        P2 = np.array([[f, K2[0, 1], K2[0, 2], -f * B], [0.0, fy, cy, 0.0], [0.0, 0.0, 1.0, 0.0]])
        eye = np.eye(3)
        return Rectification(
            rig, _readonly(eye), _readonly(eye), _readonly(P1), _readonly(P2), None, None
        )
    t = rig.T
    if abs(t[0]) < max(abs(t[1]), abs(t[2])) or t[0] >= 0:
        raise CalibrationError(
            rig.source,
            f"T = {t.tolist()}: the right camera must be to the right of the left one "
            "(OpenCV convention: T = [-baseline, 0, 0] for a side-by-side rig); check the sign "
            "of T or swap the left and right images",
        )
    size = rig.image_size
    try:
        R1, R2, P1, P2, _Q, _roi1, _roi2 = cv2.stereoRectify(
            K1,
            rig.dist_left,
            K2,
            rig.dist_right,
            size,
            rig.R,
            rig.T.reshape(3, 1),
            flags=cv2.CALIB_ZERO_DISPARITY,
            alpha=alpha,
        )
    except cv2.error as exc:  # pragma: no cover - validated input should not fail
        raise CalibrationError(rig.source, f"OpenCV cannot rectify this rig: {exc.err}") from None
    if not (np.all(np.isfinite(P1)) and np.all(np.isfinite(P2))) or P2[0, 3] >= 0:
        raise CalibrationError(rig.source, "OpenCV could not rectify this rig (degenerate)")
    m1 = cv2.initUndistortRectifyMap(K1, rig.dist_left, R1, P1, size, cv2.CV_32FC1)
    m2 = cv2.initUndistortRectifyMap(K2, rig.dist_right, R2, P2, size, cv2.CV_32FC1)
    # OpenCV returns float64 matrices and float32 maps: np.asarray gives the same arrays, typed.
    return Rectification(
        rig,
        _readonly(np.asarray(R1, np.float64)),
        _readonly(np.asarray(R2, np.float64)),
        _readonly(np.asarray(P1, np.float64)),
        _readonly(np.asarray(P2, np.float64)),
        (np.asarray(m1[0], np.float32), np.asarray(m1[1], np.float32)),
        (np.asarray(m2[0], np.float32), np.asarray(m2[1], np.float32)),
    )


def _cv(image: NDArray[np.generic]) -> NDArray[np.uint8 | np.float32]:
    """An image as OpenCV's stubs want it typed (the same array)."""
    return cast("NDArray[np.uint8 | np.float32]", image)
