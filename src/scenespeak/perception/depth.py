"""Depth images as cameras write them, read into metres with NaN for "no depth".

Three forms (``interfaces.md``, "Any perception in"):

- 16-bit PNG (or TIFF) of integer units, millimetres by default: the RealSense, Kinect, Azure
  and ROS ``16UC1`` convention; ``scale`` is metres per unit (0.001);
- 32-bit (or 64-bit) float TIFF in metres (the ROS ``32FC1`` convention; needs ``tifffile``,
  the ``rgbd`` extra);
- NumPy ``.npy`` of floats in metres (or of integers, read with ``scale``).

0, NaN, +-inf and negative values all mean "no depth" and come out as NaN. An 8-bit image, a
colour image, an image of another size than the colour image, or a depth image with no valid
pixel is refused with an :class:`~scenespeak.errors.InputError` that names the file.

>>> import numpy as np
>>> raw = np.array([[0, 1000], [1500, 2250]], dtype=np.uint16)
>>> depth_to_metres(raw, scale=0.001, source="d.png").round(3).tolist()
[[nan, 1.0], [1.5, 2.25]]
"""

from __future__ import annotations

from os import PathLike
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from scenespeak.errors import ImageError, InputError

__all__ = ["DEFAULT_DEPTH_SCALE", "check_depth_size", "depth_to_metres", "load_depth"]

#: Metres per unit of an integer depth image: millimetres.
DEFAULT_DEPTH_SCALE = 0.001


def depth_to_metres(
    raw: NDArray[np.generic], *, scale: float = DEFAULT_DEPTH_SCALE, source: str = "depth"
) -> NDArray[np.float32]:
    """A depth array in metres (float32), NaN where there is no depth.

    Parameters
    ----------
    raw : (H, W) array
        ``uint16`` / ``int32`` / ``uint32`` units (times ``scale``) or float metres (``scale``
        is not applied to floats).
    scale : float
        Metres per integer unit (0.001 for millimetres, 0.0001 for 0.1 mm).
    source : str
        The file, for messages.

    Raises
    ------
    ImageError
        For a colour or 8-bit image, a boolean array, a non-positive ``scale`` or no valid pixel.
    """
    a = np.asarray(raw)
    if not np.isfinite(scale) or scale <= 0:
        raise InputError("--depth-scale", f"must be a positive number of metres, got {scale}")
    if a.ndim == 3 and a.shape[2] == 1:
        a = a[:, :, 0]
    if a.ndim != 2:
        raise ImageError(
            source,
            f"is not a depth image: it has shape {a.shape} (a depth image has one channel; "
            "was the colour image given as --depth?)",
        )
    if a.dtype == np.bool_ or a.dtype in (np.uint8, np.int8):
        raise ImageError(
            source,
            f"holds {a.dtype} values: depth needs 16-bit integer units (PNG, millimetres with "
            "--depth-scale) or 32-bit float metres (TIFF or .npy)",
        )
    if np.issubdtype(a.dtype, np.integer):
        out = a.astype(np.float32) * np.float32(scale)
    elif np.issubdtype(a.dtype, np.floating):
        out = a.astype(np.float32, copy=True)
    else:
        raise ImageError(source, f"has values of type {a.dtype}, not numbers")
    with np.errstate(invalid="ignore"):
        out[~(np.isfinite(out) & (out > 0))] = np.nan
    if not np.isfinite(out).any():
        raise ImageError(source, "has no valid depth (every pixel is 0, NaN or inf)")
    return out


def _read_tiff(p: Path, data: bytes) -> NDArray[np.generic]:
    import io

    from scenespeak.safeio import check_image_header, decode_image

    check_image_header(data, p)  # the pixel count from the header, before decoding
    try:
        import tifffile
    except ImportError:  # pragma: no cover - the rgbd extra is installed in CI
        return np.asarray(decode_image(data, p))
    try:
        return np.asarray(tifffile.imread(io.BytesIO(data)))
    except Exception as exc:  # tifffile raises many kinds for a broken file
        raise ImageError(p, f"cannot be read as a TIFF ({exc})") from exc


def _read_npy(p: Path, data: bytes) -> NDArray[np.generic]:
    """A ``.npy`` array, its header (shape, dtype) checked before any allocation; no pickles."""
    import io

    from scenespeak import limits

    buf = io.BytesIO(data)
    try:
        fmt = np.lib.format
        version = fmt.read_magic(buf)
        read = fmt.read_array_header_1_0 if version == (1, 0) else fmt.read_array_header_2_0
        shape, _, dtype = read(buf)
    except (OSError, ValueError, SyntaxError, TypeError) as exc:
        raise ImageError(p, f"cannot be read as a NumPy .npy array ({exc})") from None
    pixels = int(np.prod(shape[:2], dtype=np.float64)) if len(shape) >= 2 else 0
    if pixels > limits.current().max_image_pixels or len(data) < pixels * dtype.itemsize:
        raise ImageError(
            p,
            f"its header says {shape} values of {dtype}, which is over max_image_pixels or more "
            "than the file holds (--limit max_image_pixels=N allows larger images)",
        )
    buf.seek(0)
    try:
        return np.asarray(np.load(buf, allow_pickle=False))
    except (OSError, ValueError) as exc:
        raise ImageError(p, f"cannot be read as a NumPy .npy array ({exc})") from None


def _read_raw(p: Path) -> NDArray[np.generic]:
    """The file's array: read as untrusted input (regular file, size and pixel limits, decoder
    noise said once) by :mod:`scenespeak.safeio`."""
    from scenespeak.safeio import decode_image, read_bytes

    data = read_bytes(p, error=ImageError, what="depth image")
    suffix = p.suffix.lower()
    if suffix == ".npy":
        return _read_npy(p, data)
    if suffix in (".tif", ".tiff"):
        return _read_tiff(p, data)
    try:
        return np.asarray(decode_image(data, p))
    except ImageError as exc:
        raise ImageError(
            p, f"{exc.problem}; a depth image is a 16-bit PNG, a float TIFF or .npy"
        ) from None


def load_depth(
    path: str | PathLike[str], *, scale: float = DEFAULT_DEPTH_SCALE
) -> NDArray[np.float32]:
    """Read a depth image file into metres (float32, NaN = no depth).

    Parameters
    ----------
    path : path
        ``.png`` (16-bit), ``.tif``/``.tiff`` (16-bit units or float metres) or ``.npy``.
    scale : float
        Metres per unit of an integer image (default millimetres).

    Raises
    ------
    ImageError
        Missing or unreadable file, or a depth of the wrong type (see :func:`depth_to_metres`).

    Examples
    --------
    >>> import tempfile, numpy as np, cv2
    >>> p = tempfile.mkdtemp() + "/d.png"
    >>> _ = cv2.imwrite(p, np.full((2, 3), 1234, np.uint16))
    >>> load_depth(p)[0, 0].round(4)
    np.float32(1.234)
    """
    p = Path(path)
    if not p.exists() and not p.is_symlink():
        raise ImageError(p, "no such depth file")
    depth = depth_to_metres(_read_raw(p), scale=scale, source=str(p))
    _check_plausible(depth, str(p), scale)
    return depth


def _check_plausible(depth: NDArray[np.float32], source: str, scale: float) -> None:
    """Refuse a depth image whose median depth no scene has (wrong units or a wrong file)."""
    from scenespeak import limits

    far = limits.current().max_scene_depth_m
    median = float(np.nanmedian(depth))
    if median > far:
        raise ImageError(
            source,
            f"its median depth is {median:.4g} m, over max_scene_depth_m ({far:g} m): wrong "
            f"units? (--depth-scale is {scale:g} m per unit of an integer image; float images "
            "are in metres)",
        )


def check_depth_size(
    depth: NDArray[np.generic],
    size: tuple[int, int],
    *,
    depth_name: str = "depth",
    other_name: str = "the colour image",
) -> None:
    """Refuse a depth image whose size is not ``size`` (width, height) of the image it belongs to.

    Raises
    ------
    ImageError
        Naming ``depth_name``, both sizes and what to do.

    Examples
    --------
    >>> import numpy as np
    >>> check_depth_size(np.zeros((480, 640)), (640, 480))
    >>> try:
    ...     check_depth_size(np.zeros((240, 320)), (640, 480), depth_name="d.png")
    ... except Exception as exc:
    ...     print(str(exc)[:50])
    d.png: is 320x240 but the colour image is 640x480:
    """
    h, w = np.asarray(depth).shape[:2]
    if (w, h) != tuple(size):
        raise ImageError(
            depth_name,
            f"is {w}x{h} but {other_name} is {size[0]}x{size[1]}: give a depth image "
            "registered to the colour image (same size)",
        )
