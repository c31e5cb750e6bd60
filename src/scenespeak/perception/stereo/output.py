"""Writing stereo points: the ``scenespeak points`` JSON object and ASCII PLY."""

from __future__ import annotations

from os import PathLike
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from scenespeak.errors import ImageError
from scenespeak.perception.stereo.results import Points3D

__all__ = ["points_to_json", "write_ply"]


def points_to_json(points: Points3D, *, decimals: int = 6) -> dict[str, Any]:
    """The ``scenespeak points --format json`` object of ``docs/interfaces.md``.

    >>> points_to_json(Points3D.empty())
    {'points': []}
    """
    out = []
    for lxy, rxy, xyz in zip(points.left_xy, points.right_xy, points.xyz, strict=True):
        out.append(
            {
                "left": [round(float(v), 3) for v in lxy],
                "right": [round(float(v), 3) for v in rxy],
                "xyz": [round(float(v), decimals) for v in xyz],
            }
        )
    return {"points": out}


def write_ply(
    points: Points3D,
    path: str | PathLike[str],
    *,
    colors: NDArray[np.uint8] | None = None,
) -> None:
    """Write the points as an ASCII PLY point cloud (x, y, z in metres; optional RGB).

    Parameters
    ----------
    points : Points3D
    path : str or path-like
    colors : (N, 3) uint8, optional
        A colour per point (e.g. sampled from the left image at ``points.left_xy``).
    """
    p = Path(path)
    n = len(points)
    has_c = colors is not None
    if has_c:
        colors = np.asarray(colors, dtype=np.uint8).reshape(n, 3)
    header = [
        "ply",
        "format ascii 1.0",
        "comment scenespeak stereo points, left camera OpenCV frame (X right, Y down, Z forward)",
        f"element vertex {n}",
        "property float x",
        "property float y",
        "property float z",
    ]
    if has_c:
        header += ["property uchar red", "property uchar green", "property uchar blue"]
    header.append("end_header")
    lines = []
    for i in range(n):
        x, y, z = points.xyz[i]
        row = f"{x:.6f} {y:.6f} {z:.6f}"
        if has_c and colors is not None:
            r, g, b = colors[i]
            row += f" {r} {g} {b}"
        lines.append(row)
    try:
        p.write_text("\n".join([*header, *lines]) + "\n", encoding="ascii")
    except OSError as exc:
        raise ImageError(p, f"cannot write the PLY file: {exc.strerror or exc}") from None
