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

The bound is two-sided (issue 10, session 9): a segment far *flatter* than the name's flattest
view (under ``flat_factor`` times it) is not that object either — a 6.5 cm bottle 22 cm tall stands
3.4 times as tall as wide in every view, and a 10 cm soup tin beside it 1.4. Labels whose
views the segment does not fit are no *competitors* of a cue's name either
(:meth:`ShapeGuard.allowed`): on a tall, narrow grey segment a flat postcard or a short soup
tin whose grey levels look alike is not a rival to the bottle. A rival is ruled out only when
the segment fits none of its views, its tallest included (a cube-shaped segment still has the
flat crate, whose side view is 0.78, as a rival: ruled out by its flattest view, 0.48, the
crate let a never-learnt grey cube be named "postcard" in a leave-half-out run), and never
because the segment is too *flat* for it (flat never-learnt boxes then lost the taller grey
cylinders as rivals and came out "cube" in leave-half-out runs of the cylinder stress set). The
cues' lead and margin are then measured against the learnt objects the segment could be.
"""

from __future__ import annotations

from collections.abc import Mapping
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
        1.3 — the standing proportion may be at most this many times the flattest view's.
    flat_factor : float
        0.6 — ... and at least this share of it (0 turns the lower bound off). A segment
        flatter than every view of the name is another, longer object: with only a cube, a
        novel and a tea learnt (stress60 leave-part-out, 3 of 12), never-learnt brick crates
        were named "cube" by grey levels at 0.44-0.48 of the cube's flattest view; right
        colour and grey names on the tuning sets and the cylinder stress set stood at
        0.66-1.08 (developers cyl and falsek of session 9 found the same bound apart).
    """

    normal: NDArray[np.float64]
    level: float
    factor: float = 1.3
    flat_factor: float = 0.6

    def proportion(self, xyz: NDArray[np.floating]) -> float:
        """:func:`standing_proportion` of ``xyz`` on this guard's plane."""
        return standing_proportion(xyz, self.normal, self.level)

    def fits(self, proportion: float, views: NDArray[np.floating] | None) -> bool:
        """Whether a segment of standing ``proportion`` may be an object whose views' aspects
        are ``views`` (True when either is unknown).

        >>> g = ShapeGuard(np.array([0.0, -1.0, 0.0]), 0.0)
        >>> [g.fits(p, np.array([3.4, 3.5])) for p in (1.4, 3.0, 5.0)]
        [False, True, False]
        """
        v = np.asarray(views if views is not None else (), np.float64)
        v = v[v > 0]
        if not len(v) or not proportion > 0:
            return True
        least = float(v.min())
        return self.flat_factor * least <= proportion <= self.factor * least

    def could_be(self, proportion: float, views: NDArray[np.floating] | None) -> bool:
        """Whether a segment of standing ``proportion`` could be an object whose views'
        aspects are ``views``, as far as a *rival* goes: at most ``factor`` times its tallest
        view (True when either is unknown). Only a segment too tall for every view rules a
        rival out: a flatter one is what a floor smeared into the segment, a merged neighbour
        or a dark top left out of it make of any object.

        >>> g = ShapeGuard(np.array([0.0, -1.0, 0.0]), 0.0)
        >>> crate = np.array([0.48, 0.78])  # a flat crate's front and side views
        >>> g.fits(0.75, crate), g.could_be(0.75, crate), g.could_be(1.4, crate)
        (False, True, False)
        >>> g.could_be(0.3, crate)  # far flatter: still a rival
        True
        """
        v = np.asarray(views if views is not None else (), np.float64)
        v = v[v > 0]
        if not len(v) or not proportion > 0:
            return True
        return proportion <= self.factor * float(v.max())

    def allowed(
        self, xyz: NDArray[np.floating], views: Mapping[str, NDArray[np.floating] | None]
    ) -> frozenset[str]:
        """The labels (keys of ``views``: each label's views' aspects) that the points
        ``xyz`` standing on the plane could be (:meth:`could_be`): the rivals of a cue's name."""
        a = self.proportion(xyz)
        return frozenset(lab for lab, v in views.items() if self.could_be(a, v))

    def refuses(self, xyz: NDArray[np.floating], views: NDArray[np.floating]) -> str | None:
        """Why points ``xyz`` cannot be an object whose views' aspects are ``views`` (None:
        they may be, or nothing is known)."""
        v = np.asarray(views, np.float64)
        v = v[v > 0]
        a = standing_proportion(xyz, self.normal, self.level)
        if self.fits(a, v):
            return None
        least = float(v.min())
        if a > self.factor * least:
            return (
                f"it stands {a:.2f} times as tall as long on the support plane, more than "
                f"{self.factor:g} times its flattest view ({least:.2f})"
            )
        return (
            f"it stands {a:.2f} times as tall as long on the support plane, less than "
            f"{self.flat_factor:g} times its flattest view ({least:.2f}): a longer object"
        )
