"""Generator configurations: which objects, textures, rigs and layouts a dataset is made of.

``default`` is the generator's original catalogue (7 objects textured with scikit-image photos,
training views with masks, 3-5 distinct objects per scene). ``tuning`` and ``validation`` are
the two configurations of issue 10 (perception that holds on objects it was never tuned to):
12 objects each, learnt **without masks**, 5 training views each, 2-5 objects per scene with
repeated instances of one object and unknown *distractor* objects (never learnt), more
occlusion, level and pitched (20-30°) rigs, 0.5-2 m.

The two pools of textures are disjoint from each other and from the default catalogue:

- ``tuning``: scikit-image photographs the default catalogue does not use;
- ``validation``: the sample photos of Debian's ``opencv-doc`` package
  (``/usr/share/doc/opencv-doc/examples/data``) and matplotlib's ``mpl-data/sample_data``.
  The validation set is frozen before any tuning and reported as it comes out
  (``docs/evaluation.md``); nobody tunes on it.

Textures are named ``skimage:NAME`` (or a bare scikit-image name), ``opencv-doc:FILE``,
``mpl:FILE`` or ``solid:R,G,B``; :func:`texture_image` finds them at run time and raises an
:class:`~scenespeak.errors.InputError` saying what to install when one is missing. No image is
copied into the repository.

>>> CONFIGS["validation"].masks, len(CONFIGS["validation"].catalogue)
(False, 12)
>>> texture_image("solid:10,20,30")[0, 0].tolist()
[10, 20, 30]
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Literal

import numpy as np
from numpy.typing import NDArray

from scenespeak.errors import InputError

if TYPE_CHECKING:
    from scenespeak.tools.scenes import CatalogueObject

__all__ = [
    "CONFIGS",
    "FIVE_CYLINDER_VIEW_YAWS",
    "FIVE_VIEW_YAWS",
    "OPENCV_DOC_DIRS",
    "GeneratorConfig",
    "Item",
    "as_objects",
    "config_catalogue",
    "config_choice",
    "config_yaws",
    "instance_names",
    "texture_image",
]

#: Where Debian's ``opencv-doc`` puts its sample images (``OPENCV_SAMPLES_DATA_PATH`` first).
OPENCV_DOC_DIRS: tuple[str, ...] = (
    "/usr/share/doc/opencv-doc/examples/data",
    "/usr/share/opencv4/samples/data",
)

#: (label, shape, (w, d, h) metres, texture) of one catalogue entry.
Item = tuple[str, str, tuple[float, float, float], str]


@dataclass(frozen=True)
class GeneratorConfig:
    """What a dataset is made of (``generate_dataset(config=...)``).

    Attributes
    ----------
    name : str
        ``"default"``, ``"tuning"`` or ``"validation"``.
    catalogue : tuple of Item
        The objects that are learnt (training views are rendered for them).
    distractors : tuple of Item
        Objects that appear in scenes but are never learnt (truth marks them ``distractor``).
    n_objects : (int, int)
        Objects per scene, inclusive range (distractors and repeated instances included).
    repeat_rate : float
        Probability that a scene holds a second instance of one of its learnt objects.
    distractor_rate : float
        Probability that a scene holds one distractor (a second one with half of it).
    min_visible : float
        Least unoccluded fraction of each object (lower: more occlusion).
    pitched : bool or "mixed"
        The rig, unless the caller gives one.
    pitch_range : (float, float)
        Downward pitch of a pitched rig, degrees, drawn per scene.
    views : int or None
        Training views per object (``None``: 4 for boxes and cards, 8 for cylinders).
    masks : bool
        Write ``view_NN_mask.png`` next to the training views (False: learnt without masks).
    """

    name: str
    catalogue: tuple[Item, ...]
    distractors: tuple[Item, ...] = ()
    n_objects: tuple[int, int] = (3, 5)
    repeat_rate: float = 0.0
    distractor_rate: float = 0.0
    min_visible: float = 0.6
    pitched: bool | Literal["mixed"] = False
    pitch_range: tuple[float, float] = (25.0, 25.0)
    views: int | None = None
    masks: bool = True


_TUNING = (
    ("cereal", "box", (0.19, 0.07, 0.27), "rocket"),
    ("tea", "box", (0.12, 0.07, 0.18), "skimage:stereo_motorcycle"),
    ("novel", "box", (0.15, 0.025, 0.22), "retina"),
    ("frame", "card", (0.15, 0.012, 0.20), "colorwheel"),
    ("postcard", "card", (0.16, 0.01, 0.11), "clock"),
    ("soup", "cylinder", (0.075, 0.075, 0.10), "hubble_deep_field"),
    ("jar", "cylinder", (0.09, 0.09, 0.14), "cell"),
    ("bottle", "cylinder", (0.065, 0.065, 0.22), "text"),
    ("cup", "cylinder", (0.08, 0.08, 0.09), "logo"),
    ("crate", "box", (0.30, 0.20, 0.12), "brick"),
    ("cube", "box", (0.12, 0.12, 0.12), "moon"),
    ("carton", "box", (0.09, 0.06, 0.20), "cat"),
)
_TUNING_DISTRACTORS = (
    ("vase", "cylinder", (0.10, 0.10, 0.18), "gravel"),
    ("parcel", "box", (0.20, 0.10, 0.15), "grass"),
    ("block", "box", (0.15, 0.10, 0.10), "solid:190,70,60"),
)
_VALIDATION = (
    ("cereal", "box", (0.19, 0.07, 0.27), "opencv-doc:baboon.jpg"),
    ("tea", "box", (0.12, 0.07, 0.18), "opencv-doc:fruits.jpg"),
    ("novel", "box", (0.15, 0.025, 0.22), "opencv-doc:building.jpg"),
    ("frame", "card", (0.15, 0.012, 0.20), "mpl:grace_hopper.jpg"),
    ("postcard", "card", (0.16, 0.01, 0.11), "opencv-doc:butterfly.jpg"),
    ("soup", "cylinder", (0.075, 0.075, 0.10), "opencv-doc:HappyFish.jpg"),
    ("jar", "cylinder", (0.09, 0.09, 0.14), "opencv-doc:starry_night.jpg"),
    ("bottle", "cylinder", (0.065, 0.065, 0.22), "opencv-doc:messi5.jpg"),
    ("cup", "cylinder", (0.08, 0.08, 0.09), "mpl:Minduka_Present_Blue_Pack.png"),
    ("crate", "box", (0.30, 0.20, 0.12), "opencv-doc:home.jpg"),
    ("cube", "box", (0.12, 0.12, 0.12), "opencv-doc:graf1.png"),
    ("carton", "box", (0.09, 0.06, 0.20), "opencv-doc:leuvenA.jpg"),
)
_VALIDATION_DISTRACTORS = (
    ("vase", "cylinder", (0.10, 0.10, 0.18), "opencv-doc:orange.jpg"),
    ("parcel", "box", (0.20, 0.10, 0.15), "opencv-doc:aero1.jpg"),
    ("block", "box", (0.15, 0.10, 0.10), "solid:60,90,170"),
)

_DEFAULT = (
    ("box", "box", (0.19, 0.07, 0.27), "page"),  # cereal box, printed text
    ("book", "box", (0.16, 0.03, 0.23), "coffee"),  # upright book
    ("card", "card", (0.18, 0.012, 0.13), "chelsea"),  # photo card / frame
    ("can", "cylinder", (0.066, 0.066, 0.122), "astronaut"),  # drink can
    ("mug", "cylinder", (0.085, 0.085, 0.095), "immunohistochemistry"),
    ("tin", "cylinder", (0.10, 0.10, 0.16), "coins"),  # coin tin
    ("shoebox", "box", (0.32, 0.19, 0.11), "camera"),
)

_HARD = {
    "n_objects": (2, 5),
    "repeat_rate": 0.35,
    "distractor_rate": 0.5,
    "min_visible": 0.45,
    "pitched": "mixed",
    "pitch_range": (20.0, 30.0),
    "views": 5,
    "masks": False,
}

#: The generator's configurations by name (``scenespeak scenes generate --config NAME``).
CONFIGS: dict[str, GeneratorConfig] = {
    "default": GeneratorConfig("default", _DEFAULT),
    "tuning": GeneratorConfig("tuning", _TUNING, _TUNING_DISTRACTORS, **_HARD),  # type: ignore[arg-type]
    "validation": GeneratorConfig(
        "validation",
        _VALIDATION,
        _VALIDATION_DISTRACTORS,
        **_HARD,  # type: ignore[arg-type]
    ),
}


def _opencv_doc(name: str) -> Path:
    dirs = [os.environ.get("OPENCV_SAMPLES_DATA_PATH", ""), *OPENCV_DOC_DIRS]
    for d in dirs:
        if d and (Path(d) / name).is_file():
            return Path(d) / name
    raise InputError(
        f"texture opencv-doc:{name}",
        f"not found in {', '.join(OPENCV_DOC_DIRS)}; install Debian's sample images with "
        "`apt-get install opencv-doc` (or set OPENCV_SAMPLES_DATA_PATH to a folder holding them)",
    )


def _mpl_sample(name: str) -> Path:
    try:
        import matplotlib
    except ImportError as exc:  # pragma: no cover - matplotlib is a dependency
        raise InputError(
            f"texture mpl:{name}", "needs matplotlib (pip install matplotlib)"
        ) from exc
    path = Path(matplotlib.get_data_path()) / "sample_data" / name
    if not path.is_file():
        raise InputError(
            f"texture mpl:{name}",
            f"not found at {path}; reinstall matplotlib with its sample data",
        )
    return path


def _read(path: Path, source: str) -> NDArray[np.uint8]:
    import cv2

    img = cv2.imread(str(path), cv2.IMREAD_COLOR)
    if img is None:
        raise InputError(source, f"{path} cannot be read as an image")
    return np.ascontiguousarray(img[:, :, ::-1])


def _skimage(name: str) -> NDArray[np.generic]:
    from skimage import data

    loader = getattr(data, name, None)
    if loader is None:
        raise InputError(f"texture {name}", "is not a scikit-image sample (skimage.data)")
    try:
        img = loader()
    except Exception as exc:  # pooch-backed samples need a download we do not do
        raise InputError(f"texture {name}", f"scikit-image cannot load it ({exc})") from exc
    if isinstance(img, tuple):  # stereo_motorcycle: (left, right, disparity)
        img = img[0]
    return np.asarray(img)


def texture_image(name: str) -> NDArray[np.uint8]:
    """The RGB ``uint8`` photograph a texture name stands for (see the module docstring).

    Raises
    ------
    InputError
        The package that holds it is not installed, or the name is unknown.
    """
    kind, _, rest = name.partition(":")
    if not rest:
        kind, rest = "skimage", name
    if kind == "solid":
        rgb = [int(v) for v in rest.split(",")]
        return np.tile(np.array(rgb, np.uint8), (64, 64, 1))
    if kind == "opencv-doc":
        return _read(_opencv_doc(rest), name)
    if kind == "mpl":
        return _read(_mpl_sample(rest), name)
    if kind != "skimage":
        raise InputError(f"texture {name}", "unknown kind (skimage:, opencv-doc:, mpl:, solid:)")
    img = _skimage(rest)
    if img.dtype == bool:
        img = img.astype(np.uint8) * 255
    elif img.dtype != np.uint8:
        img = np.clip(np.asarray(img, np.float64) * 255.0, 0, 255).astype(np.uint8)
    if img.ndim == 2:
        img = np.repeat(img[:, :, None], 3, axis=2)
    return np.ascontiguousarray(img[:, :, :3]).astype(np.uint8)


# --------------------------------------------------------------------------------------------
# scenes of a configuration


def as_objects(items: Sequence[Item], distractor: bool = False) -> list[CatalogueObject]:
    """Catalogue entries as :class:`~scenespeak.tools.scenes.CatalogueObject` values."""
    from scenespeak.tools.scenes import CatalogueObject

    return [CatalogueObject(a, b, tuple(c), d, distractor) for a, b, c, d in items]  # type: ignore[arg-type]


def config_catalogue(config: GeneratorConfig) -> tuple[CatalogueObject, ...]:
    """A configuration's learnt objects, then its distractors."""
    return tuple(as_objects(config.catalogue) + as_objects(config.distractors, True))


def config_choice(
    rng: np.random.Generator, config: GeneratorConfig, catalogue: Sequence[CatalogueObject], n: int
) -> list[CatalogueObject]:
    """``n`` objects of a configuration: some distractors, maybe a repeated learnt object."""
    known = [o for o in catalogue if not o.distractor]
    extra = [o for o in catalogue if o.distractor]
    n_dis = 0
    if extra and n >= 2 and rng.random() < config.distractor_rate:
        n_dis = 2 if n >= 4 and rng.random() < 0.5 else 1
    n_known = n - n_dis
    repeat = n_known >= 2 and rng.random() < config.repeat_rate
    distinct = n_known - 1 if repeat else n_known
    picked = [known[i] for i in rng.choice(len(known), distinct, replace=False)]
    if repeat:
        picked.append(picked[int(rng.integers(len(picked)))])
    picked += [extra[i] for i in rng.choice(len(extra), n_dis, replace=False)]
    return picked


def instance_names(labels: Sequence[str]) -> list[str]:
    """Unique names: the label, then "label 2", "label 3" for repeated instances.

    >>> instance_names(["mug", "can", "mug"])
    ['mug', 'can', 'mug 2']
    """
    seen: dict[str, int] = {}
    out = []
    for lab in labels:
        seen[lab] = seen.get(lab, 0) + 1
        out.append(lab if seen[lab] == 1 else f"{lab} {seen[lab]}")
    return out


#: Five training views (the ``tuning`` and ``validation`` configurations): boxes and cards
#: front, ±30°, one side and the back; cylinders every 72°.
FIVE_VIEW_YAWS = (0.0, 30.0, -30.0, 90.0, 180.0)
FIVE_CYLINDER_VIEW_YAWS = (0.0, 72.0, 144.0, -144.0, -72.0)


def config_yaws(obj: CatalogueObject, config: GeneratorConfig) -> tuple[float, ...]:
    """Training-view yaws (degrees) of ``obj`` in ``config``."""
    if config.views is None:
        from scenespeak.tools.scenes import view_yaws

        return view_yaws(obj)
    yaws: tuple[float, ...] = FIVE_CYLINDER_VIEW_YAWS if obj.shape == "cylinder" else FIVE_VIEW_YAWS
    if config.views != len(yaws):
        step = 360.0 / config.views
        yaws = tuple(float(k * step) for k in range(config.views))
    return yaws
