"""A synthetic stereo scene for tests: photo cards (scikit-image's photos) standing upright
before a random-texture wall 4 m away, seen by a parallel 640×480, 60°, 12 cm rig.

Shared by the pipeline, CLI, evaluation and figure tests (imported as ``cardscene``; pytest puts
``tests/`` on the path).
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
from skimage import data, transform

W, H, BASELINE, HFOV = 640, 480, 0.12, 60.0
FOCAL = (W / 2) / np.tan(np.radians(HFOV / 2))


def photo(name: str, size: int | tuple[int, int]) -> np.ndarray:
    """scikit-image's photo ``name`` as RGB uint8, resized to ``size`` (rows, cols)."""
    img = getattr(data, name)()
    img = np.stack([img] * 3, -1) if img.ndim == 2 else img[..., :3]
    shape = (size, size) if isinstance(size, int) else size
    return (transform.resize(img, shape, anti_aliasing=True) * 255).astype(np.uint8)


def write_rgb(path: Path, rgb: np.ndarray) -> Path:
    """Write an RGB image with OpenCV; return the path."""
    assert cv2.imwrite(str(path), cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))
    return path


def card_pair(
    cards: dict[str, tuple[float, float, float]], seed: int = 0
) -> tuple[np.ndarray, np.ndarray]:
    """Left/right images of photo cards ``label → (x, Z, width)`` (metres) before the wall.

    Cards are square, centred on the image row of the horizon, pasted far to near so that
    nearer cards hide farther ones; disparities are exact whole pixels of ``FOCAL·BASELINE/Z``.
    """
    rng = np.random.default_rng(seed)
    wall = cv2.resize(
        rng.integers(0, 255, (H // 8, (W + 200) // 8, 3)).astype(np.uint8),
        (W + 200, H),
        interpolation=cv2.INTER_LINEAR,
    )
    d_wall = round(FOCAL * BASELINE / 4.0)
    left = wall[:, 100 : 100 + W].copy()
    right = wall[:, 100 + d_wall : 100 + d_wall + W].copy()
    for name, (x, z, width) in sorted(cards.items(), key=lambda kv: -kv[1][1]):
        wpx = round(FOCAL * width / z)
        u = round(W / 2 + FOCAL * x / z - wpx / 2)
        v = H // 2 - wpx // 2
        d = round(FOCAL * BASELINE / z)
        card = photo(name, (wpx, wpx))
        left[v : v + wpx, u : u + wpx] = card
        right[v : v + wpx, u - d : u - d + wpx] = card
    return left, right
