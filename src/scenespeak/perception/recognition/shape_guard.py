"""A shape guard on the names given by the colour and grey cues.

The colour and grey cues (:mod:`~scenespeak.perception.recognition.colour`,
:mod:`~scenespeak.perception.recognition.grey`) name an unknown segment by what its pixels look
like. A never-learnt object of the same colours or grey texture is then named after a learnt
one (in leave-half-out runs on the tuning sets a grey cube and a grey parcel came out "crate",
a brown carton "tea"). What the database knows of each learnt object's *shape* is the height
over width of its object region in each training view (found at ``db add``): a flat crate's
views are 0.5–0.8, a cube's about 1.

The segment's own box in the image is a poor measure of its shape: the dense map often
leaves out its lower part (dark faces, a plain floor), so it comes out too flat. The guard
completes it with the support plane: each of the segment's points is also dropped onto the
plane (its foot, ``p − (p·n − level) n``), and the box round the points and their feet, in
the image, is the silhouette the object has down to the floor it stands on. A name whose
learnt views are all more than ``factor`` flatter or taller than that silhouette is refused.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

__all__ = ["ShapeGuard", "standing_proportion"]


def standing_proportion(
    xyz: NDArray[np.floating], normal: NDArray[np.floating], level: float
) -> float:
    """Height over length of the points ``xyz`` standing on the plane ``{p : p·normal =
    level}`` (``normal`` up): the 98th percentile of their heights above it over the longer
    side of their footprint (the 2–98 % extent along its two principal axes); 0 when there are
    fewer than 3 points or no footprint.

    >>> n = np.array([0.0, -1.0, 0.0])  # up is -y: the plane 0.5 m below the camera
    >>> g = np.linspace(-0.1, 0.1, 11)
    >>> box = np.array([[x, y, 2.0 + z] for x in g for z in g[:6] for y in (0.5, 0.4)])
    >>> round(standing_proportion(box, n, -0.5), 2)  # 10 cm tall, 20 cm long
    0.5
    """
    p = np.asarray(xyz, np.float64)
    if len(p) < 3:
        return 0.0
    n = np.asarray(normal, np.float64)
    height = float(np.percentile(p @ n - float(level), 98))
    flat = p - (p @ n)[:, None] * n[None, :]
    flat -= flat.mean(axis=0)
    axes = np.linalg.svd(flat, full_matrices=False)[2][:2]
    along = flat @ axes.T
    length = float(np.max(np.percentile(along, 98, axis=0) - np.percentile(along, 2, axis=0)))
    return height / length if length > 0 and height > 0 else 0.0


@dataclass(frozen=True)
class ShapeGuard:
    """Refuses a cue's name when the segment's standing silhouette fits none of the name's
    training views (:func:`standing_aspect`).

    Attributes
    ----------
    normal, level
        The support plane (``p·normal = level``; ``normal`` is up).
    factor : float
        The silhouette's height / width must lie within this factor of a view's.
    flat_factor : float
        0.6 — ... and be at least this share of the flattest view's. A segment flatter than
        every view of the name is another, longer object: with only a cube, a novel and a tea
        learnt (stress60 leave-part-out, 3 of 12), never-learnt brick crates were named "cube"
        by grey levels at 0.44-0.48 of the cube's flattest view; every right colour or grey
        naming on tuning-40 and stress60 stood at 0.73 or more.
    """

    normal: NDArray[np.float64]
    level: float
    factor: float = 1.3
    flat_factor: float = 0.6

    def refuses(self, xyz: NDArray[np.floating], views: NDArray[np.floating]) -> str | None:
        """Why points ``xyz`` cannot be an object whose views' aspects are ``views`` (None:
        they may be, or nothing is known)."""
        v = np.asarray(views, np.float64)
        v = v[v > 0]
        a = standing_proportion(xyz, self.normal, self.level)
        if not len(v) or not a > 0:
            return None
        f, least = self.factor, float(v.min())
        if a < self.flat_factor * least:
            return (
                f"it stands {a:.2f} times as tall as long on the support plane, less than "
                f"{self.flat_factor:g} times its flattest view ({least:.2f}): a longer object"
            )
        if a <= f * least:
            return None
        return (
            f"it stands {a:.2f} times as tall as long on the support plane, more than {f:g} "
            f"times its flattest view ({least:.2f})"
        )
