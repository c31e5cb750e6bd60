"""The stereo rig: both cameras' intrinsics and distortion, the extrinsics, the image size, up.

:class:`StereoRig` and the paper's short form (:func:`rig_from_short`), with the checks every
loader shares (matrix shapes, distortion lengths, camera matrices, the up vector, the image size).
The readers of each file form are in :mod:`scenespeak.perception.rig_readers`, the rectification
in :mod:`scenespeak.perception.rectification`; :mod:`scenespeak.perception.calibration` exports
all of them.

>>> rig = rig_from_short(0.12, 60.0, (640, 480))
>>> round(rig.baseline, 3), round(float(rig.K_left[0, 0]), 1)
(0.12, 554.3)
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from scenespeak import limits as _limits
from scenespeak.errors import CalibrationError, ImageError
from scenespeak.geometry.frames import DEFAULT_UP

__all__ = ["CalibrationMismatchError", "StereoRig", "rig_from_short"]


_VALID_DIST_LENGTHS = (4, 5, 8, 12, 14)


class CalibrationMismatchError(CalibrationError, ImageError):
    """The images do not fit the calibration (e.g. a different size).

    Both a :class:`~scenespeak.errors.CalibrationError` and an
    :class:`~scenespeak.errors.ImageError`, so a caller catching either sees it.
    """


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
