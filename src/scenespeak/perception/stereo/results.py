"""The stereo stage's results: matches, 3-D points, the dense disparity map, all of a pair."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from scenespeak.perception.calibration import Rectification
from scenespeak.perception.features import Features

__all__ = ["DenseDisparity", "Points3D", "StereoMatches", "StereoResult"]


@dataclass(frozen=True, eq=False)
class StereoMatches:
    """Accepted left/right keypoint matches.

    Attributes
    ----------
    left_index, right_index : (N,) intp
        Indices into the left and right :class:`~scenespeak.perception.features.Features`.
    left_rect, right_rect : (N, 2) float64
        Keypoint positions in rectified coordinates.
    distance : (N,) float32
        Descriptor distance of each match.
    ratio : (N,) float32
        Best / second-best distance (the ratio test's value; 0 when there was no second).
    """

    left_index: NDArray[np.intp]
    right_index: NDArray[np.intp]
    left_rect: NDArray[np.float64]
    right_rect: NDArray[np.float64]
    distance: NDArray[np.float32]
    ratio: NDArray[np.float32]

    def __len__(self) -> int:
        return int(self.left_index.shape[0])

    @property
    def disparity(self) -> NDArray[np.float64]:
        """Rectified disparities ``x_left − x_right`` in pixels."""
        return self.left_rect[:, 0] - self.right_rect[:, 0]

    def subset(self, index: NDArray[np.intp] | NDArray[np.bool_]) -> StereoMatches:
        """The matches selected by an index or a boolean mask."""
        return StereoMatches(
            self.left_index[index],
            self.right_index[index],
            self.left_rect[index],
            self.right_rect[index],
            self.distance[index],
            self.ratio[index],
        )


@dataclass(frozen=True, eq=False)
class Points3D:
    """Triangulated stereo points.

    Attributes
    ----------
    xyz : (N, 3) float64
        Points in metres in the ORIGINAL left camera's OpenCV frame (X right, Y down, Z forward).
    left_xy, right_xy : (N, 2) float64
        Pixel positions (column, row) in the input images as given.
    descriptors : (N, 128) uint8
        SIFT descriptors of the left keypoints.
    left_index, right_index : (N,) intp
        Indices into the left / right :class:`~scenespeak.perception.features.Features`.
    disparity : (N,) float64
        Rectified disparity ``x_left − x_right`` in pixels. Depth in the rectified frame is
        ``f · B / (disparity + doffs)`` (see
        :class:`~scenespeak.perception.calibration.Rectification`).
    """

    xyz: NDArray[np.float64]
    left_xy: NDArray[np.float64]
    right_xy: NDArray[np.float64]
    descriptors: NDArray[np.uint8]
    left_index: NDArray[np.intp]
    right_index: NDArray[np.intp]
    disparity: NDArray[np.float64]

    def __len__(self) -> int:
        return int(self.xyz.shape[0])

    def subset(self, index: NDArray[np.intp] | NDArray[np.bool_]) -> Points3D:
        """The points selected by an index or a boolean mask."""
        return Points3D(
            self.xyz[index],
            self.left_xy[index],
            self.right_xy[index],
            self.descriptors[index],
            self.left_index[index],
            self.right_index[index],
            self.disparity[index],
        )

    @staticmethod
    def empty() -> Points3D:
        """No points (e.g. a textureless pair)."""
        return Points3D(
            np.zeros((0, 3)),
            np.zeros((0, 2)),
            np.zeros((0, 2)),
            np.zeros((0, 128), np.uint8),
            np.zeros(0, np.intp),
            np.zeros(0, np.intp),
            np.zeros(0),
        )


@dataclass(frozen=True, eq=False)
class DenseDisparity:
    """A dense disparity map of the rectified left image.

    Attributes
    ----------
    disparity : (h, w) float32
        Rectified disparity ``x_left − x_right`` per rectified left pixel; NaN where unknown
        (failed the left-right check or uniqueness test, occluded, or outside the computed
        region).
    rect : Rectification
        The rectification the map belongs to.
    min_disparity, num_disparities : int
        The disparity search range used.
    roi : (x0, y0, x1, y1) or None
        The part of the rectified left image that was computed (None: all of it).
    """

    disparity: NDArray[np.float32]
    rect: Rectification
    min_disparity: int
    num_disparities: int
    roi: tuple[int, int, int, int] | None = None

    def valid_fraction(self) -> float:
        """Fraction of pixels with a disparity."""
        return float(np.mean(np.isfinite(self.disparity)))


@dataclass(frozen=True, eq=False)
class StereoResult:
    """Everything :func:`stereo_points` computed, so later stages never recompute it.

    Attributes
    ----------
    points : Points3D
    features_left, features_right : Features
        SIFT features of the input images (SIFT runs exactly once per image).
    rect : Rectification
    dense : DenseDisparity or None
        The dense disparity map used to verify matches (reuse it for :func:`region_points`).
    matches : StereoMatches
    """

    points: Points3D
    features_left: Features
    features_right: Features
    rect: Rectification
    dense: DenseDisparity | None
    matches: StereoMatches
