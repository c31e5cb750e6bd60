"""Hand-made layouts on the horizontal plane (private): the seed paper's scenes and one layout
per sentence pattern. Used by the tests and by :func:`scenespeak.spatial.language.layout_table`.

Coordinates are the horizontal plane's 2-D frame of ``docs/interfaces.md`` in metres: x = the
camera's right, y = depth (larger y = farther = "behind"). The camera is at the origin.
The seed's scenes (Fig. 8–11) are rebuilt from the figures' captions and sentences: the hulls
in the paper are not given numerically, so these are layouts that match each description.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray


def disc(cx: float, cy: float, r: float, n: int = 24) -> NDArray[np.float64]:
    """A regular ``n``-gon of circumradius ``r`` (a round object's hull)."""
    t = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    return np.column_stack([cx + r * np.cos(t), cy + r * np.sin(t)])


def rect(x0: float, y0: float, x1: float, y1: float) -> NDArray[np.float64]:
    """An axis-aligned rectangle, counter-clockwise."""
    return np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]], dtype=np.float64)


def polar(r: float, deg: float, centre: tuple[float, float] = (0.0, 1.0)) -> tuple[float, float]:
    """The point at distance ``r`` and angle ``deg`` (0 = right, 90 = behind) from ``centre``."""
    return (
        centre[0] + r * math.cos(math.radians(deg)),
        centre[1] + r * math.sin(math.radians(deg)),
    )


# -- The seed paper's scenes ------------------------------------------------------------------
#: Fig. 8: "a hat between, but slightly behind a mug and a can" (left to right: can, hat, mug).
FIG8: dict[str, NDArray[np.float64]] = {
    "mug": disc(0.45, 0.9, 0.045),
    "hat": disc(0.45 - 0.80, 0.9 + 0.60, 0.09),
    "can": disc(0.45 - 0.915, 0.9 + 0.486, 0.04),
}
#: Fig. 9: "the hat rotated with its bill up": an odd hull reaching back past the can.
FIG9: dict[str, NDArray[np.float64]] = {
    "can": disc(0.25, 1.2, 0.1),
    "hat": np.array(
        [[-0.4, -0.1], [-0.15, -0.1], [-0.12, 0.1], [0.05, 0.35], [-0.1, 0.4], [-0.4, 0.1]]
    )
    + np.array([0.25 - 0.03, 1.2]),
}
#: Fig. 10: "a hat partially obscuring the view of a can" (mug, hat in front, can).
FIG10: dict[str, NDArray[np.float64]] = {
    "mug": disc(-0.35, 1.0, 0.045),
    "hat": disc(-0.014, 0.782, 0.1),
    "can": disc(0.573, 1.163, 0.06),
}
#: Fig. 11: "a mug above a can as well as a hat": the mug stands on the can.
FIG11: dict[str, NDArray[np.float64]] = {
    "mug": disc(0.0, 1.0, 0.04),
    "can": disc(0.005, 1.0, 0.05, 32),
    "hat": disc(*polar(0.3, 302.0), 0.09),
}
#: Fig. 11's heights along up (metres above the table): a 12 cm can, a 10 cm mug on it, a
#: 9 cm hat on the table.
FIG11_HEIGHTS: dict[str, NDArray[np.float64]] = {
    "can": np.linspace(0.0, 0.12, 25),
    "mug": np.linspace(0.125, 0.22, 20),
    "hat": np.linspace(0.0, 0.09, 20),
}


@dataclass(frozen=True, eq=False)
class Layout:
    """One argument/referent pair drawn in the README table."""

    name: str
    note: str
    argument: str
    referent: str
    a: NDArray[np.float64]
    b: NDArray[np.float64]
    a_heights: NDArray[np.float64] | None = None
    b_heights: NDArray[np.float64] | None = None
    others: tuple[tuple[str, NDArray[np.float64]], ...] = ()


def _pair(name: str, note: str, scene: dict[str, NDArray[np.float64]], a: str, b: str) -> Layout:
    rest = tuple((k, v) for k, v in scene.items() if k not in (a, b))
    return Layout(name, note, a, b, scene[a], scene[b], others=rest)


_B = disc(0.0, 1.0, 0.05)


def _at(deg: float, r: float = 0.3, size: float = 0.05) -> NDArray[np.float64]:
    return disc(*polar(r, deg), size)


#: Every layout of the README table, in order.
LAYOUTS: tuple[Layout, ...] = (
    _pair("Fig. 8 (1)", "seed: hat between, slightly behind", FIG8, "hat", "mug"),
    _pair("Fig. 8 (2)", "seed", FIG8, "mug", "can"),
    _pair("Fig. 8 (3)", "seed: compound", FIG8, "can", "hat"),
    _pair("Fig. 9 (1)", "seed: the hat's odd hull reaches back", FIG9, "hat", "can"),
    _pair("Fig. 10 (2)", "seed", FIG10, "mug", "can"),
    _pair("Fig. 11 (2)", "seed", FIG11, "hat", "mug"),
    _pair("Fig. 11 (1)", "seed: mug on the can, no heights", FIG11, "mug", "can"),
    Layout(
        "Fig. 11 with heights",
        "the vertical plane takes precedence",
        "mug",
        "can",
        FIG11["mug"],
        FIG11["can"],
        FIG11_HEIGHTS["mug"],
        FIG11_HEIGHTS["can"],
        others=(("hat", FIG11["hat"]),),
    ),
    Layout("right", "0° off", "cup", "box", _at(0.0), _B),
    Layout("behind", "0° off", "cup", "box", _at(90.0), _B),
    Layout("left", "0° off", "cup", "box", _at(180.0), _B),
    Layout("front", "0° off", "cup", "box", _at(270.0), _B),
    Layout("no hedge", "12° off", "cup", "box", _at(168.0), _B),
    Layout("mostly, slightly", "22° off", "cup", "box", _at(158.0), _B),
    Layout("mostly, somewhat", "33° off", "cup", "box", _at(147.0), _B),
    Layout(
        "loosely",
        "a bracket wrapped round the box's left side",
        "bracket",
        "box",
        np.array(
            [
                [-0.12, 0.85],
                [0.05, 0.85],
                [0.05, 0.92],
                [-0.07, 0.92],
                [-0.07, 1.08],
                [0.05, 1.08],
                [0.05, 1.15],
                [-0.12, 1.15],
            ]
        ),
        _B,
    ),
    Layout("compound", "45° off", "cup", "box", _at(225.0), _B),
    Layout(
        "extends",
        "a long bar to the left reaching back",
        "bar",
        "box",
        rect(-0.3, 0.95, -0.15, 1.5),
        _B,
    ),
    Layout(
        "surrounded",
        "inside",
        "coin",
        "tray",
        disc(0.02, 1.0, 0.04),
        disc(0.0, 1.0, 0.15, 48),
    ),
    Layout(
        "partly surrounded",
        "mostly inside, poking out",
        "coin",
        "tray",
        disc(-0.12, 1.0, 0.05, 32),
        disc(0.0, 1.0, 0.15, 48),
    ),
    Layout(
        "surrounds",
        "the converse",
        "tray",
        "coin",
        disc(0.0, 1.0, 0.15, 48),
        disc(0.02, 1.0, 0.04),
    ),
    Layout(
        "above",
        "a lamp hanging 30 cm over the table's box",
        "lamp",
        "box",
        disc(0.0, 1.0, 0.06),
        rect(-0.1, 0.9, 0.1, 1.1),
        np.linspace(0.5, 0.6, 10),
        np.linspace(0.0, 0.2, 10),
    ),
)
