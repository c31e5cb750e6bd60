"""A single camera's intrinsics (pinhole, the colour camera of an RGB-D sensor).

Read from three forms (``interfaces.md``, "Any perception in"):

- JSON ``{"fx", "fy", "cx", "cy", "width", "height", "up"?}`` (also ``"K"`` as a 3×3 matrix,
  ``"image_size"``, and ``"camera_pose_cam_to_world"``, a 4×4 pose of a world with z up, from
  which ``up`` follows);
- a ROS ``sensor_msgs/CameraInfo`` YAML (``image_width``, ``image_height``, ``camera_matrix``
  or ``K``/``k``);
- an OpenCV FileStorage YAML with a ``camera_matrix`` (or ``K``, ``M1``, ``cameraMatrix``)
  ``!!opencv-matrix`` and ``image_width``/``image_height`` (or ``image_size``).

Frames are those of the stereo case: the camera's OpenCV frame (X right, Y down, Z forward);
``up`` is the world's up in that frame, None when the file does not say (then the pipeline
estimates it from the dominant support plane, or uses ``[0, -1, 0]``).

>>> cam = Intrinsics(fx=500.0, fy=500.0, cx=320.0, cy=240.0, width=640, height=480)
>>> cam.K.tolist()
[[500.0, 0.0, 320.0], [0.0, 500.0, 240.0], [0.0, 0.0, 1.0]]
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace
from os import PathLike
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from scenespeak.errors import CalibrationError

__all__ = ["Intrinsics", "intrinsics_from_mapping", "load_intrinsics"]


@dataclass(frozen=True)
class Intrinsics:
    """Pinhole intrinsics of one camera, the image size and (if known) the world's up.

    Attributes
    ----------
    fx, fy, cx, cy : float
        Focal lengths and principal point in pixels (OpenCV convention: pixel (u, v) sees
        ``X = (u - cx) Z / fx``, ``Y = (v - cy) Z / fy``).
    width, height : int
        The image size the intrinsics belong to.
    up : (3,) tuple of float or None
        The world's up direction in the camera frame (unit length), None when unknown.
    source : str
        Where the intrinsics came from (a file name), for messages.
    """

    fx: float
    fy: float
    cx: float
    cy: float
    width: int
    height: int
    up: tuple[float, float, float] | None = None
    source: str = "intrinsics"

    def __post_init__(self) -> None:
        for name in ("fx", "fy", "cx", "cy"):
            v = getattr(self, name)
            if not np.isfinite(v):
                raise CalibrationError(self.source, f"{name} must be a finite number, got {v}")
        if self.fx <= 0 or self.fy <= 0:
            raise CalibrationError(
                self.source, f"focal lengths must be positive, got fx={self.fx}, fy={self.fy}"
            )
        if self.width <= 0 or self.height <= 0:
            raise CalibrationError(
                self.source, f"image size must be positive, got {self.width}x{self.height}"
            )
        if self.up is not None:
            u = np.asarray(self.up, dtype=np.float64)
            n = float(np.linalg.norm(u)) if u.shape == (3,) else 0.0
            if u.shape != (3,) or not np.all(np.isfinite(u)) or n < 1e-9:
                raise CalibrationError(
                    self.source, f'"up" must be 3 finite numbers, not zero: {self.up}'
                )
            object.__setattr__(self, "up", tuple(float(v) for v in u / n))

    @property
    def K(self) -> NDArray[np.float64]:
        """The 3×3 camera matrix."""
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])

    @property
    def size(self) -> tuple[int, int]:
        """(width, height)."""
        return (self.width, self.height)

    def with_up(self, up: ArrayLike | None) -> Intrinsics:
        """A copy with another ``up`` (None: unknown)."""
        return replace(self, up=None if up is None else tuple(np.asarray(up, float).tolist()))

    def to_dict(self) -> dict[str, Any]:
        """The JSON form (the file format of :func:`load_intrinsics`)."""
        out: dict[str, Any] = {
            "fx": self.fx,
            "fy": self.fy,
            "cx": self.cx,
            "cy": self.cy,
            "width": self.width,
            "height": self.height,
        }
        if self.up is not None:
            out["up"] = list(self.up)
        return out


def _number(d: Mapping[str, Any], key: str, src: str) -> float:
    v = d.get(key)
    if v is None:
        raise CalibrationError(
            src, f'missing "{key}" (intrinsics need fx, fy, cx, cy, width, height)'
        )
    if isinstance(v, bool | str | bytes):  # "277" or true: a number written wrong
        raise CalibrationError(src, f'"{key}" must be a number, got {v!r:.40}')
    try:
        return float(v)
    except (TypeError, ValueError):
        raise CalibrationError(src, f'"{key}" must be a number, got {v!r:.40}') from None


def _matrix(v: Any, shape: tuple[int, int], name: str, src: str) -> NDArray[np.float64]:
    if isinstance(v, Mapping) and "data" in v:  # OpenCV / ROS {rows, cols, data}
        v = v["data"]
    try:
        a = np.asarray(v, dtype=np.float64)
    except (TypeError, ValueError):
        raise CalibrationError(src, f'"{name}" must be numbers') from None
    if a.size != shape[0] * shape[1]:
        raise CalibrationError(
            src, f'"{name}" must have {shape[0]}x{shape[1]} numbers, got {a.size}'
        )
    a = a.reshape(shape)
    if not np.all(np.isfinite(a)):
        raise CalibrationError(src, f'"{name}" holds NaN or infinite values')
    return a


def _pick(d: Mapping[str, Any], names: tuple[str, ...]) -> Any:
    for n in names:
        if n in d:
            return d[n]
    return None


def _size(d: Mapping[str, Any], src: str) -> tuple[int, int]:
    size = _pick(d, ("image_size", "imageSize", "resolution"))
    if size is not None:
        if isinstance(size, Mapping) and "data" in size:
            size = size["data"]
        try:
            w, h = (int(v) for v in size)
        except (TypeError, ValueError):
            raise CalibrationError(
                src, f'"image_size" must be [width, height], got {size!r}'
            ) from None
        return w, h
    w = _pick(d, ("width", "image_width", "imageWidth"))
    h = _pick(d, ("height", "image_height", "imageHeight"))
    if w is None or h is None:
        raise CalibrationError(src, 'missing the image size ("width" and "height")')
    try:
        return int(w), int(h)
    except (TypeError, ValueError):
        raise CalibrationError(
            src, f"width and height must be integers, got {w!r}, {h!r}"
        ) from None


def _up(d: Mapping[str, Any], src: str) -> tuple[float, float, float] | None:
    up = d.get("up")
    if up is not None:
        u = _matrix(up, (1, 3), "up", src).reshape(3)
        return (float(u[0]), float(u[1]), float(u[2]))
    pose = d.get("camera_pose_cam_to_world")
    if pose is not None:
        # a camera-to-world pose of a world with z up: up in the camera frame is R^T e_z, the
        # third row of R
        T = _matrix(pose, (4, 4), "camera_pose_cam_to_world", src)
        R = T[:3, :3]
        if not np.allclose(R @ R.T, np.eye(3), atol=1e-3):
            raise CalibrationError(src, '"camera_pose_cam_to_world" does not hold a rotation')
        return (float(R[2, 0]), float(R[2, 1]), float(R[2, 2]))
    return None


def intrinsics_from_mapping(d: Mapping[str, Any], source: str = "intrinsics") -> Intrinsics:
    """:class:`Intrinsics` from a parsed JSON / YAML mapping (any of the three forms).

    Raises
    ------
    CalibrationError
        Missing or malformed values, naming ``source``.

    Examples
    --------
    >>> d = {"image_width": 640, "image_height": 480,
    ...      "camera_matrix": {"rows": 3, "cols": 3, "data": [600, 0, 320, 0, 600, 240, 0, 0, 1]}}
    >>> intrinsics_from_mapping(d).fx
    600.0
    """
    if not isinstance(d, Mapping):
        raise CalibrationError(source, "expected a mapping (JSON object / YAML map) at the top")
    K = _pick(d, ("camera_matrix", "K", "k", "M1", "cameraMatrix", "intrinsic_matrix"))
    if K is not None:
        m = _matrix(K, (3, 3), "camera_matrix", source)
        fx, fy, cx, cy = m[0, 0], m[1, 1], m[0, 2], m[1, 2]
    else:
        fx, fy = _number(d, "fx", source), _number(d, "fy", source)
        cx, cy = _number(d, "cx", source), _number(d, "cy", source)
    w, h = _size(d, source)
    return Intrinsics(float(fx), float(fy), float(cx), float(cy), w, h, _up(d, source), source)


def load_intrinsics(path: str | PathLike[str]) -> Intrinsics:
    """Read a camera's intrinsics from JSON, a ROS camera_info YAML or an OpenCV YAML.

    Raises
    ------
    CalibrationError
        Missing, unreadable or malformed file, naming it.

    Examples
    --------
    >>> import json, tempfile
    >>> p = tempfile.mkdtemp() + "/cam.json"
    >>> _ = open(p, "w").write(json.dumps(
    ...     {"fx": 600, "fy": 600, "cx": 320, "cy": 240, "width": 640, "height": 480}))
    >>> load_intrinsics(p).size, load_intrinsics(p).up
    ((640, 480), None)
    """
    from scenespeak.perception.calibfiles import parse_calibration

    p = Path(path)
    if not p.exists() and not p.is_symlink():
        raise CalibrationError(p, "no such intrinsics file")
    # The calibration readers' bounded parsing (docs/trust.md): regular files only, size,
    # nesting, numbers and YAML aliases bounded, OpenCV's matrix tags, no python tags.
    return intrinsics_from_mapping(parse_calibration(p), str(p))
