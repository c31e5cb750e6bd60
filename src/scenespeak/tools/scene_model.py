"""What the scene generator builds scenes of: the catalogue of objects, the rig, placements.

Part of :mod:`scenespeak.tools.scenes` (which re-exports every public name here); the folder
format and the ground-truth rule are in ``docs/scenes.md``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Literal, TypeVar

import numpy as np
from numpy.typing import NDArray

from scenespeak.overrides import replace_fields
from scenespeak.tools.render import (
    Camera,
    MeshSpec,
    cylinder_outline,
)

FORMAT = "scenespeak-scenes/1"
SUPERSAMPLE = 2
DIAGONAL_TOLERANCE_DEG = 20.0
HIDDEN_THRESHOLD = 0.5
CLEARANCE = 0.03
VIEW_YAWS = (0.0, 30.0, -30.0, 180.0)
#: Training-view yaws of cylinders: every 45° (a cylinder stands at any yaw in the scenes, and
#: its wrapped photo is recognised only near the middle of a view, where it faces the camera).
CYLINDER_VIEW_YAWS = (0.0, 45.0, -45.0, 90.0, -90.0, 135.0, -135.0, 180.0)


@dataclass(frozen=True)
class CatalogueObject:
    """A catalogue object: label, shape (``box``, ``cylinder``, ``card``), size (w, d, h) in
    metres (width along its front, depth, height) and a scikit-image photograph name."""

    label: str
    shape: str
    size: tuple[float, float, float]
    texture: str
    #: Never learnt: appears in scenes of the ``tuning``/``validation`` configurations only.
    distractor: bool = False


#: The fixed catalogue: sizes of real household objects.
CATALOGUE: tuple[CatalogueObject, ...] = (
    CatalogueObject("box", "box", (0.19, 0.07, 0.27), "page"),  # cereal box, printed text
    CatalogueObject("book", "box", (0.16, 0.03, 0.23), "coffee"),  # upright book
    CatalogueObject("card", "card", (0.18, 0.012, 0.13), "chelsea"),  # photo card / frame
    CatalogueObject("can", "cylinder", (0.066, 0.066, 0.122), "astronaut"),  # drink can
    CatalogueObject("mug", "cylinder", (0.085, 0.085, 0.095), "immunohistochemistry"),
    CatalogueObject("tin", "cylinder", (0.10, 0.10, 0.16), "coins"),  # coin tin
    CatalogueObject("shoebox", "box", (0.32, 0.19, 0.11), "camera"),
)


@dataclass(frozen=True)
class Rig:
    """A parallel stereo rig in the world (Z up, floor z = 0), looking along world +Y.

    ``height`` is the left camera's height above the floor, ``pitch_deg`` the downward pitch.
    """

    pitch_deg: float = 0.0
    height: float = 0.25
    baseline: float = 0.12
    hfov_deg: float = 60.0
    image_size: tuple[int, int] = (640, 480)

    def camera(self, which: Literal["left", "right"] = "left") -> Camera:
        """The left or right camera (right = left shifted by the baseline along its X axis)."""
        a = np.radians(self.pitch_deg)
        right = np.array([1.0, 0.0, 0.0])
        forward = np.array([0.0, np.cos(a), -np.sin(a)])
        down = np.array([0.0, -np.sin(a), -np.cos(a)])
        eye = np.array([0.0, 0.0, self.height])
        if which == "right":
            eye = eye + self.baseline * right
        return Camera(
            tuple(eye), tuple(right), tuple(down), tuple(forward), self.image_size, self.hfov_deg
        )

    @property
    def up(self) -> NDArray[np.float64]:
        """World up in the left camera's OpenCV frame."""
        return self.camera().rotation @ np.array([0.0, 0.0, 1.0])

    def calibration(self) -> dict[str, Any]:
        """The calibration JSON: short form for a level rig, full form for a pitched one."""
        up = [round(float(v), 12) + 0.0 for v in self.up]
        if self.pitch_deg == 0:
            return {
                "baseline": self.baseline,
                "hfov_deg": self.hfov_deg,
                "image_size": list(self.image_size),
                "up": up,
            }
        k = self.camera().intrinsics(SUPERSAMPLE).tolist()
        return {
            "image_size": list(self.image_size),
            "K_left": k,
            "K_right": k,
            "dist_left": [0.0] * 5,
            "dist_right": [0.0] * 5,
            "R": np.eye(3).tolist(),
            "T": [-self.baseline, 0.0, 0.0],
            "up": up,
        }


def make_rig(
    pitched: bool,
    *,
    image_size: tuple[int, int] = (640, 480),
    hfov_deg: float = 60.0,
    baseline: float = 0.12,
    pitch_deg: float = 25.0,
) -> Rig:
    """The level rig (0.25 m high) or the pitched rig (0.45 m high, ``pitch_deg`` down)."""
    if pitched:
        return Rig(pitch_deg, 0.45, baseline, hfov_deg, _size(image_size))
    return Rig(0.0, 0.25, baseline, hfov_deg, _size(image_size))


@dataclass(frozen=True)
class Placement:
    """A catalogue object placed in the world: base centre ``position`` (x, y, z) and yaw."""

    obj: CatalogueObject
    position: tuple[float, float, float]
    yaw_deg: float
    on: str | None = None

    def footprint_world(self) -> NDArray[np.float64]:
        """Outline of the base in world (x, y), counter-clockwise."""
        w, d, _ = self.obj.size
        if self.obj.shape == "cylinder":
            local = cylinder_outline(w / 2)
        else:
            local = np.array([[-w / 2, -d / 2], [w / 2, -d / 2], [w / 2, d / 2], [-w / 2, d / 2]])
        a = np.radians(self.yaw_deg)
        rot = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
        return local @ rot.T + np.asarray(self.position[:2])

    def corners_world(self) -> NDArray[np.float64]:
        """Vertices of the object's (prism) hull in the world, ``(2n, 3)``."""
        fp = self.footprint_world()
        z0 = self.position[2]
        z1 = z0 + self.obj.size[2]
        return np.vstack([np.c_[fp, np.full(len(fp), z0)], np.c_[fp, np.full(len(fp), z1)]])

    def centroid_world(self) -> NDArray[np.float64]:
        """Centre of the object's volume."""
        x, y, z = self.position
        return np.array([x, y, z + self.obj.size[2] / 2])

    def mesh(self) -> MeshSpec:
        shape = "cylinder" if self.obj.shape == "cylinder" else "box"
        return MeshSpec(shape, self.obj.size, self.obj.texture, self.position, self.yaw_deg)


def _size(image_size: Sequence[int]) -> tuple[int, int]:
    w, h = image_size
    return int(w), int(h)


@dataclass(frozen=True)
class SceneOptions:
    """Knobs of one generated scene (:func:`scenespeak.tools.scenes.generate_scene`).

    Attributes
    ----------
    pitched : bool
        False — a level rig; True: pitched ``pitch_deg`` down.
    image_size : (w, h)
        (640, 480) pixels.
    hfov_deg, baseline : float
        60° horizontal field of view, 0.12 m baseline.
    pitch_deg : float
        25° — the pitched rig's angle (a configuration's ``pitch_range`` draws it per scene).
    n_objects : int or None
        Objects in the scene (None: 3–5 at random).
    stacked : bool
        Put one object on another where one fits (the paper's mug on a can).
    catalogue : sequence of CatalogueObject
        The objects to choose from (:data:`CATALOGUE`).
    depth_noise : bool
        Also write ``depth_noisy.png``, the depth as a depth camera would give it.
    """

    pitched: bool = False
    image_size: tuple[int, int] = (640, 480)
    hfov_deg: float = 60.0
    baseline: float = 0.12
    pitch_deg: float = 25.0
    n_objects: int | None = None
    stacked: bool = False
    catalogue: Sequence[CatalogueObject] = CATALOGUE
    depth_noise: bool = False


@dataclass(frozen=True)
class DatasetOptions:
    """Knobs of a generated dataset (:func:`scenespeak.tools.scenes.generate_dataset`).

    Attributes
    ----------
    pitched : bool or "mixed"
        Level rig, rig pitched 25° down, or both alternately (odd scenes pitched).
    image_size, hfov_deg, baseline
        As in :class:`SceneOptions`.
    stacked : bool
        Put one object on another in every scene where one fits.
    views : bool
        True — render the training views into ``objects/<label>/``.
    overwrite : bool
        Replace a dataset made with other settings instead of refusing.
    depth_noise : bool
        Also write each scene's ``depth_noisy.png``.
    config : str
        ``"default"``, ``"tuning"`` or ``"validation"`` (``scene_configs.CONFIGS``; docs/scenes.md).
    """

    pitched: bool | Literal["mixed"] = False
    image_size: tuple[int, int] = (640, 480)
    hfov_deg: float = 60.0
    baseline: float = 0.12
    stacked: bool = False
    views: bool = True
    overwrite: bool = False
    depth_noise: bool = False
    config: str = "default"


_Options = TypeVar("_Options", SceneOptions, DatasetOptions)


def with_overrides(options: _Options, overrides: dict[str, object], what: str) -> _Options:
    """``options`` with single fields replaced; an unknown name is refused like a keyword."""
    return replace_fields(
        options,
        overrides,
        lambda bad, _names: TypeError(f"{what}() got unexpected keyword argument(s) {bad}"),
    )
