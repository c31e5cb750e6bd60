"""The one contract between the two halves: an object as the spatial half sees it.

Perception (stereo + database, RGB-D, a user's masks or boxes) produces
:class:`SpatialObject` values; the spatial half (:mod:`scenespeak.spatial`) reads nothing else.
This module imports only NumPy, so any segmenter can feed the spatial half.

>>> import numpy as np
>>> mug = SpatialObject(
...     name="mug", label="mug", hull=np.array([[0.0, 1.0], [0.1, 1.0], [0.1, 1.1], [0.0, 1.1]])
... )
>>> mug.frame, mug.confidence
('horizontal', 1.0)
>>> mug.footprint_centroid.round(3).tolist()
[0.05, 1.05]
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray

__all__ = ["Frame", "SpatialObject"]

#: Where a hull lives: ``"horizontal"`` = the horizontal plane's 2-D frame of ``docs/interfaces.md``
#: (metres; x = the camera's right, y = its forward direction); ``"image"`` = the image plane
#: (x = column, y = image up, pixels), used when there is no depth.
Frame = Literal["horizontal", "image"]


@dataclass(frozen=True, eq=False)
class SpatialObject:
    """One object of a scene, as the spatial half needs it.

    Attributes
    ----------
    name : str
        Unique within the scene; used in the sentences ("the left mug", "unknown object 2").
    label : str
        What the object is (the database label, the segmenter's class), shared by several
        instances; ``"unknown"`` for an object nothing named.
    hull : (M, 2) float64
        The object's footprint: a simple polygon, counter-clockwise, in ``frame``.
    frame : {"horizontal", "image"}
        The 2-D frame of ``hull``.
    heights : (K,) float64 or None
        Heights of the object's points along up (metres, larger = higher), for the vertical
        relations ("on top of"); None when unknown (e.g. the image plane).
    points : (N, 3) float64 or None
        The object's 3-D points in the camera's OpenCV frame (metres), when there are any.
    centroid : (3,) float64 or None
        The object's centre in the camera frame (metres), when known.
    confidence : float
        How sure perception is of the object's identity, in [0, 1].
    mask : (H, W) bool or None
        The object's pixels in the image, where a mask exists.
    """

    name: str
    label: str
    hull: NDArray[np.float64]
    frame: Frame = "horizontal"
    heights: NDArray[np.float64] | None = None
    points: NDArray[np.float64] | None = None
    centroid: NDArray[np.float64] | None = None
    confidence: float = 1.0
    mask: NDArray[np.bool_] | None = None

    def __post_init__(self) -> None:
        from scenespeak.errors import InputError

        try:
            hull = np.asarray(self.hull)
        except (TypeError, ValueError) as exc:
            raise InputError(self.name, f"hull cannot be read as vertices ({exc})") from None
        if hull.dtype.kind not in "iuf" or hull.ndim != 2 or hull.shape[1:] != (2,):
            raise InputError(
                self.name, f"hull must be real (M, 2) vertices, got {hull.dtype} {hull.shape}"
            )
        if len(hull) < 3 or not np.isfinite(hull).all():
            raise InputError(self.name, "hull needs at least 3 finite vertices")

    @property
    def footprint_centroid(self) -> NDArray[np.float64]:
        """The mean of the hull's vertices (a cheap "where" on the plane)."""
        return np.asarray(self.hull, dtype=np.float64).mean(axis=0)
