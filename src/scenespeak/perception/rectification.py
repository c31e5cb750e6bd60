"""Rectification of a stereo rig: row-aligned geometry, its maps and projections.

>>> from scenespeak.perception.rig import rig_from_short
>>> rectify(rig_from_short(0.12, 60.0, (640, 480))).needs_resampling
False
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import cast

import cv2
import numpy as np
from numpy.typing import ArrayLike, NDArray

from scenespeak.errors import CalibrationError
from scenespeak.perception.rig import StereoRig, _readonly

__all__ = ["Rectification", "rectify"]


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
        self,
        left: NDArray[np.generic],
        right: NDArray[np.generic],
        *,
        window: tuple[int, int, int, int] | None = None,
    ) -> tuple[NDArray[np.generic], NDArray[np.generic]]:
        """Resample both images into rectified geometry (returns them as they are when the rig
        is already rectified).

        ``window`` = ``(x0, y0, x1, y1)`` (rectified pixels, inside the image): only that part
        of each rectified image, the same pixels as the whole images' part (``cv2.remap``
        computes each output pixel from its own map entries: the window's maps give the
        window's pixels; checked bit for bit on 798 windows of distorted, rotated rigs), at
        the cost of the window (issue 16: the dense map's crop). Without maps it is a view
        of each image.
        """
        if window is not None:
            x0, y0, x1, y1 = window
            rows, cols = slice(y0, y1), slice(x0, x1)
        if self.maps_left is None or self.maps_right is None:
            if window is None:
                return left, right
            return left[rows, cols], right[rows, cols]
        lx, ly = self.maps_left
        rx, ry = self.maps_right
        if window is not None:
            lx, ly, rx, ry = (m[rows, cols] for m in (lx, ly, rx, ry))
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
