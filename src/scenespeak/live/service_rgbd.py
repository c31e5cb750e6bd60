"""RGB-D requests of the scene service: ``color`` + ``depth`` (+ ``masks`` + ``labels`` or
``boxes``, + ``intrinsics``) → the JSON of ``scenespeak describe`` for the same files.

The uploads are checked against the service's limits before anything is decoded (image sizes
from their PNG / JPEG headers, a ``.npy`` depth's shape from its header, the small files'
bytes), written into a temporary folder, and described through the CLI's own dispatch
(:func:`scenespeak.inputs.describe_inputs`), so the response is ``describe --format json``'s.
Without masks or boxes the server's object database names the objects. Fields:
``depth_scale`` (metres per unit of a 16-bit depth, 0.001), ``min_score`` (boxes),
``estimate_up`` (true: up from the support plane even when the intrinsics give it).
"""

from __future__ import annotations

import io
import math
import tempfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from scenespeak.errors import ScenespeakError
from scenespeak.live.service import RequestProblem, ServiceLimits, image_size_from_header

__all__ = ["rgbd_job"]

Files = Mapping[str, tuple[str, bytes]]


def _image_header(data: bytes, name: str, lim: ServiceLimits) -> str:
    """The format of an uploaded PNG / JPEG after the size checks (4xx otherwise)."""
    if not data:
        raise RequestProblem(400, f"{name}: the file is empty")
    try:
        fmt, w, h = image_size_from_header(data)
    except ValueError as exc:
        raise RequestProblem(415, f"{name}: {exc}") from None
    _check_size(name, w, h, lim)
    return fmt


def _check_size(name: str, w: int, h: int, lim: ServiceLimits) -> None:
    if w <= 0 or h <= 0:
        raise RequestProblem(400, f"{name}: the header says {w}x{h} pixels")
    if max(w, h) > lim.max_side or w * h > lim.max_pixels:
        raise RequestProblem(
            413,
            f"{name}: {w}x{h} pixels is too large (at most {lim.max_side} a side and "
            f"{lim.max_pixels} pixels)",
        )


def _depth_suffix(data: bytes, lim: ServiceLimits) -> str:
    """``.png`` (16-bit PNG) or ``.npy`` (its header's shape checked), else a 415."""
    if data[:6] == b"\x93NUMPY":
        try:
            f = io.BytesIO(data)
            version = np.lib.format.read_magic(f)
            read = (
                np.lib.format.read_array_header_1_0
                if version == (1, 0)
                else np.lib.format.read_array_header_2_0
            )
            shape, _, _ = read(f)
        except Exception as exc:  # numpy raises ValueError and kin for broken headers
            raise RequestProblem(400, f"depth: a broken .npy header ({exc})") from None
        if len(shape) != 2:
            raise RequestProblem(400, f"depth: a .npy of shape {shape}; one channel (H, W) needed")
        _check_size("depth", int(shape[1]), int(shape[0]), lim)
        return ".npy"
    if _image_header(data, "depth", lim) != "png":
        raise RequestProblem(415, "depth: send a 16-bit PNG (millimetres) or a .npy (metres)")
    return ".png"


def _small(files: Files, key: str, limit: int) -> bytes | None:
    item = files.get(key)
    if item is None:
        return None
    if not item[1]:
        raise RequestProblem(400, f"{key}: the file is empty")
    if len(item[1]) > limit:
        raise RequestProblem(413, f"{key}: over {limit} bytes")
    return item[1]


def _number(fields: Mapping[str, str], key: str, default: float) -> float:
    text = fields.get(key)
    if text is None or not text.strip():
        return default
    try:
        v = float(text)
    except ValueError:
        raise RequestProblem(400, f"{key} must be a number, not {text[:20]!r}") from None
    if not math.isfinite(v) or v < 0:
        raise RequestProblem(400, f"{key} must be a finite number >= 0, not {text[:20]!r}")
    return v


def _write(
    tmp: Path, files: Files, fields: Mapping[str, str], default_intrinsics: Path | None,
    lim: ServiceLimits,
) -> dict[str, Any]:  # fmt: skip
    """The uploads as files in ``tmp``: the keyword arguments of :class:`SceneInputs`."""
    for need in ("color", "depth"):
        if need not in files:
            raise RequestProblem(400, f"missing the file field `{need}` (send color and depth)")
    if "left" in files or "right" in files:
        raise RequestProblem(400, "send a stereo pair (left, right) or color + depth, not both")
    out: dict[str, Any] = {}
    color, depth = files["color"][1], files["depth"][1]
    out["color"] = tmp / ("color." + _image_header(color, "color", lim).replace("jpeg", "jpg"))
    out["color"].write_bytes(color)
    if not depth:
        raise RequestProblem(400, "depth: the file is empty")
    out["depth"] = tmp / ("depth" + _depth_suffix(depth, lim))
    out["depth"].write_bytes(depth)
    if "masks" in files:
        masks = files["masks"][1]
        if _image_header(masks, "masks", lim) != "png":
            raise RequestProblem(415, "masks: send an 8- or 16-bit PNG instance image")
        out["masks"] = tmp / "masks.png"
        out["masks"].write_bytes(masks)
    for key, limit in (("labels", lim.max_calib), ("boxes", 16 * lim.max_calib)):
        data = _small(files, key, limit)
        if data is not None:
            out[key] = tmp / f"{key}.json"
            out[key].write_bytes(data)
    data = _small(files, "intrinsics", lim.max_calib)
    if data is not None:
        suffix = Path(files["intrinsics"][0]).suffix.lower()
        out["intrinsics"] = tmp / (
            "intrinsics" + (suffix if suffix in (".yaml", ".yml") else ".json")
        )
        out["intrinsics"].write_bytes(data)
    elif default_intrinsics is not None:
        out["intrinsics"] = default_intrinsics
    else:
        raise RequestProblem(
            400, "no intrinsics: send a file `intrinsics` (the server has no --intrinsics)"
        )
    out["depth_scale"] = _number(fields, "depth_scale", 0.001) or 0.001
    out["min_score"] = _number(fields, "min_score", 0.0)
    out["estimate_up"] = str(fields.get("estimate_up", "")).strip().lower() in ("1", "true", "yes")
    return out


def rgbd_job(
    files: Files,
    fields: Mapping[str, str],
    db_path: Path,
    default_intrinsics: Path | None,
    lim: ServiceLimits,
) -> tuple[Any, dict[str, Any]]:
    """Describe one RGB-D request (in a worker thread): the description and its JSON.

    Raises
    ------
    RequestProblem
        4xx with one line naming the field, for anything wrong with the uploads.
    """
    from scenespeak.inputs import SceneInputs, describe_inputs

    with tempfile.TemporaryDirectory(prefix="scenespeak-serve-") as tmpdir:
        tmp = Path(tmpdir)
        kwargs = _write(tmp, files, fields, default_intrinsics, lim)
        if "masks" not in kwargs and "boxes" not in kwargs:
            kwargs["db"] = db_path
        try:
            description = describe_inputs(SceneInputs(**kwargs))
        except ScenespeakError as exc:
            message = str(exc)
            for key in ("color", "depth", "masks", "labels", "boxes", "intrinsics"):
                p = kwargs.get(key)
                if isinstance(p, Path) and p.parent == tmp:
                    message = message.replace(str(p), key)
            raise RequestProblem(400, message.replace(str(tmp) + "/", "")) from None
        return description, description.to_dict()
