"""Stage 1: images and SIFT features (through OpenCV; SIFT is not re-implemented here).

>>> import numpy as np
>>> from skimage import data
>>> from scenespeak.perception.features import detect, to_gray
>>> feats = detect(to_gray(data.camera()))
>>> feats.descriptors.dtype, feats.descriptors.shape[1]
(dtype('uint8'), 128)
>>> len(feats) > 500
True
"""

from __future__ import annotations

from dataclasses import dataclass
from os import PathLike

import cv2
import numpy as np
from numpy.typing import NDArray

from scenespeak.errors import ImageError

__all__ = ["Features", "detect", "load_image", "to_gray"]

# OpenCV's classic SIFT (without enable_precise_upscale) reports positions +0.25 px too far right
# and down; measured on skimage's camera image: median 0.248, 0.249 px at every octave.
_CLASSIC_UPSCALE_OFFSET = 0.25


@dataclass(frozen=True)
class Features:
    """SIFT keypoints of one image.

    Attributes
    ----------
    xy : (N, 2) float64
        Keypoint positions in pixels (column, row) of the image as given.
    size : (N,) float32
        Keypoint diameters in pixels (OpenCV's ``KeyPoint.size``).
    angle : (N,) float32
        Keypoint orientations in degrees (OpenCV's ``KeyPoint.angle``).
    response : (N,) float32
        Detector responses.
    octave : (N,) int32
        OpenCV's packed octave field.
    descriptors : (N, 128) uint8
        SIFT descriptors. OpenCV's values are whole numbers in 0..255, so uint8 loses nothing.
    """

    xy: NDArray[np.float64]
    size: NDArray[np.float32]
    angle: NDArray[np.float32]
    response: NDArray[np.float32]
    octave: NDArray[np.int32]
    descriptors: NDArray[np.uint8]

    def __len__(self) -> int:
        return int(self.xy.shape[0])

    def subset(self, index: NDArray[np.intp] | NDArray[np.bool_]) -> Features:
        """Return the features selected by an index or boolean mask."""
        return Features(
            xy=self.xy[index],
            size=self.size[index],
            angle=self.angle[index],
            response=self.response[index],
            octave=self.octave[index],
            descriptors=self.descriptors[index],
        )

    @staticmethod
    def empty() -> Features:
        """Features of an image with no keypoints."""
        return Features(
            xy=np.zeros((0, 2)),
            size=np.zeros(0, np.float32),
            angle=np.zeros(0, np.float32),
            response=np.zeros(0, np.float32),
            octave=np.zeros(0, np.int32),
            descriptors=np.zeros((0, 128), np.uint8),
        )


def _check_pixels(height: int, width: int) -> None:
    from scenespeak import limits

    lim = limits.current()
    if height * width > lim.max_image_pixels:
        raise ImageError(
            None,
            limits.exceeded(
                "max_image_pixels",
                f"the image is {width} x {height} = {width * height} pixels, which",
                0,
            ),
        )


def to_gray(image: NDArray[np.generic]) -> NDArray[np.uint8]:
    """Convert an image array (gray, RGB or RGBA; uint8 or float in [0, 1]) to gray uint8.

    Raises
    ------
    ImageError
        If the array is not a 2-D or 3-D image with 1, 3 or 4 channels, or is empty.
    """
    arr = np.asarray(image)
    if arr.ndim not in (2, 3) or arr.size == 0 or (arr.ndim == 3 and arr.shape[2] not in (1, 3, 4)):
        raise ImageError(
            None, f"expected a gray, RGB or RGBA image, got an array of shape {arr.shape}"
        )
    if arr.dtype.kind not in "buif":
        raise ImageError(
            None, f"expected an image of real numbers (uint8 or float), got dtype {arr.dtype}"
        )
    _check_pixels(arr.shape[0], arr.shape[1])
    if arr.dtype == np.bool_:
        arr = arr.astype(np.uint8) * 255
    if arr.dtype != np.uint8:
        if np.issubdtype(arr.dtype, np.floating):
            if not np.all(np.isfinite(arr)):
                raise ImageError(None, "the image contains NaN or infinite values")
            scale = 255.0 if arr.max(initial=0.0) <= 1.0 else 1.0
            arr = np.clip(np.rint(arr * scale), 0, 255).astype(np.uint8)
        else:
            arr = np.clip(arr, 0, 255).astype(np.uint8)
    if arr.ndim == 3:
        if arr.shape[2] == 1:
            arr = arr[:, :, 0]
        elif arr.shape[2] == 4:
            arr = cv2.cvtColor(arr, cv2.COLOR_RGBA2GRAY)
        else:
            arr = cv2.cvtColor(arr, cv2.COLOR_RGB2GRAY)
    return np.ascontiguousarray(arr)


def load_image(path: str | PathLike[str], *, gray: bool = True) -> NDArray[np.uint8]:
    """Read an image file.

    Parameters
    ----------
    path : str or path-like
        Any format OpenCV reads (PNG, JPEG, TIFF, ...).
    gray : bool
        Return a 2-D gray image (default) or an RGB ``(H, W, 3)`` image.

    Raises
    ------
    ImageError
        If the file is missing, empty, not a regular file (a folder, a FIFO, a device), over
        :attr:`~scenespeak.limits.Limits.max_file_bytes`, declares more pixels in its header
        than :attr:`~scenespeak.limits.Limits.max_image_pixels` (checked before decoding), or
        is not a readable image (truncated, corrupt: said once, without the decoder's own
        warnings).
    """
    from scenespeak.safeio import as_path, decode_image, read_bytes

    p = as_path(path, error=ImageError)
    data = read_bytes(p, error=ImageError, what="image file")
    flag = cv2.IMREAD_GRAYSCALE if gray else cv2.IMREAD_COLOR
    image = decode_image(data, p, flags=flag)
    if image.ndim < 2 or min(image.shape[:2]) < 1:
        raise ImageError(p, f"the image has no pixels (shape {image.shape})")
    if not gray:
        image = cv2.cvtColor(np.asarray(image, dtype=np.uint8), cv2.COLOR_BGR2RGB)
    return np.ascontiguousarray(image, dtype=np.uint8)


def as_mask(mask: object, source: str | None = "mask") -> NDArray[np.bool_]:
    """A 2-D boolean mask (non-zero = inside), or :class:`ImageError` saying why not.

    Numbers and booleans are accepted; complex, text, object arrays and anything that is not
    2-D are refused (a complex mask is never "non-zero" in a sense anyone means).

    >>> as_mask([[0, 2], [0, 0]]).tolist()
    [[False, True], [False, False]]
    >>> as_mask(np.ones((2, 2), complex))
    Traceback (most recent call last):
    ...
    scenespeak.errors.ImageError: mask: a mask must be booleans or numbers, got complex128
    """
    m = np.asarray(mask)
    if m.dtype.kind not in "biuf":
        raise ImageError(source, f"a mask must be booleans or numbers, got {m.dtype}")
    if m.ndim != 2 or 0 in m.shape:
        raise ImageError(source, f"a mask must be a 2-D (height, width) array, got shape {m.shape}")
    if m.dtype.kind == "f" and not np.isfinite(m).all():
        raise ImageError(source, "the mask has NaN or infinite values")
    return np.asarray(m != 0)


def detect(
    image: NDArray[np.generic],
    *,
    mask: NDArray[np.bool_] | None = None,
    max_features: int = 0,
    contrast_threshold: float = 0.04,
    precise_upscale: bool = True,
) -> Features:
    """Detect SIFT keypoints and compute their descriptors with OpenCV.

    Parameters
    ----------
    image : ndarray
        Gray or colour image (see :func:`to_gray`).
    mask : ndarray of bool, optional
        Only detect where the mask is true (same height and width as the image).
    max_features : int
        Keep at most this many of the strongest keypoints (0: all).
    contrast_threshold : float
        OpenCV's ``contrastThreshold``; lower finds more keypoints in low-contrast images.
    precise_upscale : bool
        Use OpenCV's ``enable_precise_upscale``. Without it OpenCV's positions carry a +0.25 px
        offset in x and y (from the first octave's upscaling), which is subtracted here, so
        positions mean the same in both modes. The classic mode finds a few % more keypoints
        (the stereo stage uses it).

    Returns
    -------
    Features
    """
    gray = to_gray(image)
    cv_mask = None
    if mask is not None:
        m = as_mask(mask)
        if m.shape != gray.shape:
            raise ImageError(None, f"mask shape {m.shape} differs from image shape {gray.shape}")
        cv_mask = m.astype(np.uint8) * 255
    precise = precise_upscale
    try:
        sift = cv2.SIFT_create(  # type: ignore[attr-defined]
            nfeatures=max_features,
            contrastThreshold=contrast_threshold,
            enable_precise_upscale=precise_upscale,
        )
    except TypeError:  # older OpenCV without enable_precise_upscale
        sift = cv2.SIFT_create(  # type: ignore[attr-defined]
            nfeatures=max_features, contrastThreshold=contrast_threshold
        )
        precise = False
    keypoints, descriptors = sift.detectAndCompute(gray, cv_mask)
    if not keypoints or descriptors is None:
        return Features.empty()
    xy = np.array([k.pt for k in keypoints], dtype=np.float64)
    if not precise:
        xy -= _CLASSIC_UPSCALE_OFFSET
    return Features(
        xy=xy,
        size=np.array([k.size for k in keypoints], dtype=np.float32),
        angle=np.array([k.angle for k in keypoints], dtype=np.float32),
        response=np.array([k.response for k in keypoints], dtype=np.float32),
        octave=np.array([k.octave for k in keypoints], dtype=np.int32),
        descriptors=np.clip(np.rint(descriptors), 0, 255).astype(np.uint8),
    )
