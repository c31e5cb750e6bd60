"""An imitation of a structured-light / active-stereo depth camera's errors, for the generator.

Real RGB-D sensors (RealSense D4xx, Kinect v1, OAK-D, ZED) triangulate: depth is
``Z = f b / d`` for a disparity ``d`` measured to a fraction of a pixel, so

- **noise grows with Z²**: a disparity error ``sigma_d`` gives ``sigma_Z = Z^2 sigma_d / (f b)``
  (Khoshelham & Elberink 2012, *Sensors* 12(2), eq. 9);
- **quantisation**: ``d`` comes in steps of 1/8 (RealSense) to 1/32 px, so depth comes in
  steps that also grow with Z²; and the image is written in whole millimetres;
- **holes at depth edges** (the projector's or the second camera's shadow, and invalidated
  mixed matches) and **flying pixels** (a depth between the foreground's and the
  background's) along depth discontinuities;
- random **dropouts** and no depth beyond the working range.

:func:`imitate_depth_camera` applies all of these, seeded, to a true depth image.

>>> import numpy as np
>>> z = np.full((40, 60), 2.0, np.float32); z[10:30, 20:40] = 1.0
>>> noisy = imitate_depth_camera(z, fx=550.0, seed=0)
>>> bool(np.isnan(noisy).any()), bool(abs(np.nanmedian(noisy[15:25, 25:35]) - 1.0) < 0.01)
(True, True)
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray

__all__ = ["DepthNoise", "imitate_depth_camera"]


@dataclass(frozen=True)
class DepthNoise:
    """Parameters of the imitation (defaults: a RealSense-D415-like camera).

    Attributes
    ----------
    baseline : float
        Projector/second-camera baseline (metres).
    sigma_disparity : float
        Disparity noise (pixels, standard deviation).
    subpixel : float
        Disparity step (pixels).
    edge_jump : float
        A pixel is at a depth edge when its 3×3 neighbourhood's depth range exceeds this
        fraction of its depth.
    edge_hole : float
        Probability that an edge pixel has no depth.
    flying : float
        Probability that a remaining edge pixel takes a depth between the neighbourhood's
        nearest and farthest (a flying pixel).
    dropout : float
        Probability of a random hole anywhere.
    max_range : float
        No depth beyond this (metres).
    """

    baseline: float = 0.055
    sigma_disparity: float = 0.08
    subpixel: float = 0.125
    edge_jump: float = 0.04
    edge_hole: float = 0.5
    flying: float = 0.4
    dropout: float = 0.01
    max_range: float = 6.0


def imitate_depth_camera(
    depth: NDArray[np.floating],
    *,
    fx: float,
    noise: DepthNoise | None = None,
    seed: int = 0,
) -> NDArray[np.float32]:
    """A true depth image (metres, NaN = none) as a triangulating depth camera would give it.

    Parameters
    ----------
    depth : (H, W) float
        True depth in metres.
    fx : float
        Focal length in pixels.
    noise : DepthNoise, optional
    seed : int

    Returns
    -------
    (H, W) float32
        Metres rounded to millimetres, NaN where the camera gives no depth.
    """
    p = noise or DepthNoise()
    rng = np.random.default_rng(seed)
    z = np.asarray(depth, np.float64)
    valid = np.isfinite(z) & (z > 0)
    filled = np.where(valid, z, 0.0).astype(np.float32)
    big = np.where(valid, z, 1e6).astype(np.float32)
    kernel = np.ones((3, 3), np.uint8)
    zmax = cv2.dilate(filled, kernel).astype(np.float64)
    zmin = cv2.erode(big, kernel).astype(np.float64)
    edge = valid & ((zmax - zmin) > p.edge_jump * np.where(valid, z, 1.0))
    fb = fx * p.baseline
    d = fb / np.where(valid, z, 1.0)
    d = d + rng.normal(0.0, p.sigma_disparity, size=d.shape)
    d = np.round(d / p.subpixel) * p.subpixel
    out = np.where(valid & (d > 0), fb / np.maximum(d, 1e-9), np.nan)
    u = rng.random(z.shape)
    hole = edge & (u < p.edge_hole)
    fly = edge & ~hole & (u < p.edge_hole + (1 - p.edge_hole) * p.flying)
    t = rng.random(z.shape)
    lo, hi = np.minimum(zmin, zmax), zmax
    out = np.where(fly, lo + t * (hi - lo), out)
    out[hole] = np.nan
    out[rng.random(z.shape) < p.dropout] = np.nan
    out[out > p.max_range] = np.nan
    return (np.round(out * 1000.0) / 1000.0).astype(np.float32)
