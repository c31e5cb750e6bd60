"""Frames: the world's up, the horizontal plane's 2-D frame, heights along up.

One definition for both halves (perception projects points with it; the 2-D frame is the one
``docs/interfaces.md`` fixes): points are in the left camera's OpenCV frame (X right, Y down,
Z forward, metres) and ``up`` is the world's up direction in that frame. The horizontal plane's
x is the camera's right direction projected onto the plane, y its forward direction projected
(depth); a level rig (``up = [0, -1, 0]``) gives (X, Z).

>>> project_to_plane([[0.1, 0.2, 1.5]]).tolist()
[[0.1, 1.5]]
>>> heights_along([[0.0, 0.3, 1.0]]).tolist()  # 30 cm below a level camera
[-0.3]
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from scenespeak.errors import CalibrationError

__all__ = [
    "DEFAULT_UP",
    "ground_basis",
    "heights",
    "heights_along",
    "plane_basis",
    "project_to_plane",
    "to_ground",
    "unit_vector",
]

#: The world's up direction of a level rig in the left camera's OpenCV frame (Y points down).
DEFAULT_UP: tuple[float, float, float] = (0.0, -1.0, 0.0)


def unit_vector(v: ArrayLike, name: str = "up") -> NDArray[np.float64]:
    """``v`` as a unit 3-vector.

    Raises
    ------
    CalibrationError
        Not three finite numbers, or the zero vector (``name`` says which input).

    Examples
    --------
    >>> unit_vector([0, -2, 0]).tolist()
    [0.0, -1.0, 0.0]
    """
    a = np.asarray(v, dtype=np.float64).reshape(-1)
    if a.shape != (3,) or not np.all(np.isfinite(a)):
        raise CalibrationError(name, f"must be 3 finite numbers, got {np.asarray(v).tolist()!r}")
    n = float(np.linalg.norm(a))
    if n < 1e-12:
        raise CalibrationError(name, "must not be the zero vector")
    return a / n


def ground_basis(up: ArrayLike = DEFAULT_UP) -> NDArray[np.float64]:
    """Orthonormal basis ``E`` (2, 3) of the horizontal plane: 2-D coordinates are ``E @ X``.

    Row 0 (x) is the camera's right direction projected on the plane, row 1 (y) the camera's
    forward direction projected on the plane; they are made exactly orthogonal keeping y
    (depth) as projected, and ``x = y × up`` so the frame is right-handed seen from above.
    When the camera looks straight along up (or down), y is taken as ``up × x``.

    Examples
    --------
    >>> ground_basis([0, -1, 0]).round(6).tolist()
    [[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]
    """
    u = np.asarray(up, dtype=np.float64).reshape(3)
    n = float(np.linalg.norm(u))
    if not np.all(np.isfinite(u)) or n < 1e-12:
        raise CalibrationError("up", f"up must be a finite non-zero 3-vector, got {u.tolist()}")
    u = u / n
    fwd = np.array([0.0, 0.0, 1.0])
    y = fwd - (fwd @ u) * u
    if np.linalg.norm(y) < 1e-6:
        right = np.array([1.0, 0.0, 0.0])
        x = right - (right @ u) * u
        x /= np.linalg.norm(x)
        y = np.cross(u, x)
    else:
        y /= np.linalg.norm(y)
        x = np.cross(y, u)
    x /= np.linalg.norm(x)
    y /= np.linalg.norm(y)
    return np.vstack([x, y]) + 0.0  # + 0.0 turns -0.0 into 0.0


def to_ground(xyz: ArrayLike, up: ArrayLike = DEFAULT_UP) -> NDArray[np.float64]:
    """Project 3-D points (N, 3) of the left camera frame onto the horizontal plane (N, 2)."""
    return np.asarray(xyz, dtype=np.float64).reshape(-1, 3) @ ground_basis(up).T


def heights(xyz: ArrayLike, up: ArrayLike = DEFAULT_UP) -> NDArray[np.float64]:
    """Height of 3-D points along ``up`` (relative to the left camera centre), shape (N,)."""
    u = np.asarray(up, dtype=np.float64).reshape(3)
    u = u / np.linalg.norm(u)
    return np.asarray(xyz, dtype=np.float64).reshape(-1, 3) @ u


def plane_basis(up: ArrayLike = DEFAULT_UP) -> NDArray[np.float64]:
    """Orthonormal axes of the horizontal plane and up, as the rows of a 3×3 matrix.

    Rows 0 and 1 are :func:`ground_basis` (x = the camera's right direction projected onto the
    plane, y = its forward direction projected, so depth); row 2 is the unit ``up``.

    Raises
    ------
    CalibrationError
        If ``up`` is not three finite numbers or is the zero vector.

    Examples
    --------
    >>> (plane_basis([0, -1, 0]).round(3) + 0.0).tolist()
    [[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]]
    """
    u = unit_vector(up)
    return np.vstack([ground_basis(u), u])


def project_to_plane(xyz: ArrayLike, up: ArrayLike = DEFAULT_UP) -> NDArray[np.float64]:
    """Project 3-D points onto the horizontal plane's 2-D frame.

    Parameters
    ----------
    xyz : (N, 3) array_like
        Points in the left camera's OpenCV frame.
    up : (3,) array_like
        The world's up direction in that frame (need not be unit length).

    Returns
    -------
    (N, 2) float64

    Examples
    --------
    >>> project_to_plane([[0.1, 0.2, 1.5]]).tolist()
    [[0.1, 1.5]]
    """
    p = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
    return p @ ground_basis(unit_vector(up)).T


def heights_along(xyz: ArrayLike, up: ArrayLike = DEFAULT_UP) -> NDArray[np.float64]:
    """Heights of 3-D points along ``up`` (metres, relative to the camera centre).

    Raises
    ------
    CalibrationError
        If ``up`` is not three finite numbers or is the zero vector.

    Examples
    --------
    >>> heights_along([[0.0, 0.3, 1.0]]).tolist()  # 30 cm below a level camera
    [-0.3]
    """
    p = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
    return p @ unit_vector(up)
