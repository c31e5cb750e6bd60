"""Checks of a stereo pair's images: one size, the calibration's size; reading a pair."""

from __future__ import annotations

from os import PathLike

import numpy as np
from numpy.typing import NDArray

from scenespeak.errors import ImageError
from scenespeak.perception.calibration import StereoRig
from scenespeak.perception.features import load_image

__all__ = ["check_pair", "load_pair"]


def check_pair(
    left: NDArray[np.generic],
    right: NDArray[np.generic],
    rig: StereoRig | None = None,
    *,
    left_name: str = "left image",
    right_name: str = "right image",
) -> None:
    """Check that a pair of images fits together and fits the rig.

    Raises
    ------
    ImageError
        Empty images or images of different sizes.
    CalibrationMismatchError
        (an ImageError and a CalibrationError) if the size is not the calibration's.
    """
    for img, name in ((left, left_name), (right, right_name)):
        a = np.asarray(img)
        if a.ndim not in (2, 3) or a.size == 0:
            raise ImageError(name, f"is not an image (array of shape {a.shape})")
    lh, lw = np.asarray(left).shape[:2]
    rh, rw = np.asarray(right).shape[:2]
    if (lh, lw) != (rh, rw):
        raise ImageError(
            f"{left_name}, {right_name}",
            f"the left image is {lw}x{lh} but the right image is {rw}x{rh}; a stereo pair must "
            "have one size",
        )
    if rig is not None:
        rig.check_image_size((lw, lh), left_name)


def load_pair(
    left_path: str | PathLike[str],
    right_path: str | PathLike[str],
    rig: StereoRig | None = None,
) -> tuple[NDArray[np.uint8], NDArray[np.uint8]]:
    """Read a stereo pair (gray) and check it with :func:`check_pair`, naming the files."""
    left = load_image(left_path)
    right = load_image(right_path)
    check_pair(left, right, rig, left_name=str(left_path), right_name=str(right_path))
    return left, right
