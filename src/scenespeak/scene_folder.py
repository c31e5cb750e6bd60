"""One scene folder in, its description out: the unit of work of ``annotate`` and ``evaluate``.

A scene folder holds one of two layouts (``interfaces.md``, "Labels at dataset scale"):

- **stereo** — ``left.png``, ``right.png``, ``calib.json`` (the scene generator's layout;
  ``truth.json`` optional), described by :func:`scenespeak.pipeline.describe_scene` with an
  object database;
- **RGB-D** — ``color.png``, ``depth.png``, ``intrinsics.json`` (optional ``masks.png`` +
  ``labels.json``), described by the RGB-D path of ``scenespeak.perception`` when this version
  has it.

:func:`describe_scene_folder` picks the layout; :func:`find_scene_folders` lists the scenes of
a dataset.

>>> import tempfile
>>> from pathlib import Path
>>> with tempfile.TemporaryDirectory() as tmp:
...     scene = Path(tmp) / "scene_000"
...     scene.mkdir()
...     for name in ("left.png", "right.png", "calib.json"):
...         _ = (scene / name).write_bytes(b"")
...     scene_layout(scene), [p.name for p in find_scene_folders(tmp)]
('stereo', ['scene_000'])
"""

from __future__ import annotations

import json
import os
from os import PathLike
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

from scenespeak.errors import InputError

if TYPE_CHECKING:  # pragma: no cover
    from scenespeak.perception.database import ObjectDatabase
    from scenespeak.pipeline import SceneDescription

__all__ = [
    "RGBD_FILES",
    "STEREO_FILES",
    "check_supported",
    "describe_scene_folder",
    "find_scene_folders",
    "rgbd_supported",
    "scene_layout",
]

#: The files of a stereo scene folder.
STEREO_FILES = ("left.png", "right.png", "calib.json")
#: The files of an RGB-D scene folder (``masks.png`` + ``labels.json`` optional).
RGBD_FILES = ("color.png", "depth.png", "intrinsics.json")

Layout = Literal["stereo", "rgbd"]

_COLOR_NAMES = ("color.png", "color.jpg", "left.png")
_DEPTH_NAMES = ("depth.png", "depth.tif", "depth.tiff", "depth.npy")


def _any(folder: Path, names: tuple[str, ...]) -> bool:
    return any((folder / n).is_file() for n in names)


def scene_layout(folder: str | PathLike[str]) -> Layout | None:
    """``"stereo"``, ``"rgbd"`` or None (not a scene folder) from the files present.

    Stereo wins when both are there (a generated scene folder also holds its left camera's
    depth). The RGB-D colour image may also be ``color.jpg`` or ``left.png``, the depth
    ``depth.tif``/``.tiff``/``.npy`` (the readers of ``perception.depth``).
    """
    p = Path(folder)
    if all((p / f).is_file() for f in STEREO_FILES):
        return "stereo"
    if _any(p, _COLOR_NAMES) and _any(p, _DEPTH_NAMES) and (p / "intrinsics.json").is_file():
        return "rgbd"
    return None


def _not_a_scene(folder: Path) -> InputError:
    return InputError(
        folder,
        "is not a scene folder: expected left.png, right.png and calib.json (stereo) or "
        "color.png, depth.png and intrinsics.json (RGB-D)",
    )


def find_scene_folders(dataset: str | PathLike[str]) -> list[Path]:
    """The scene folders of a dataset, in order.

    ``dataset.json``'s ``scenes`` list when there is one (the generator's index), otherwise
    every sub-folder (or link to one) in the stereo or RGB-D layout, sorted by name; a folder
    that is itself a scene is a dataset of one. ``truth.json`` is not needed.

    Raises
    ------
    InputError
        No such folder, an unreadable index or one naming missing folders, or no scene at all.
    """
    root = Path(dataset)
    if not root.is_dir():
        raise InputError(root, "not a folder; give a folder of scene folders")
    index = root / "dataset.json"
    if index.is_file():
        try:
            names = json.loads(index.read_text(encoding="utf-8"))["scenes"]
        except (OSError, ValueError, KeyError, TypeError) as exc:
            raise InputError(index, f'cannot read its "scenes" list ({exc})') from exc
        scenes = [root / str(n) for n in names]
        missing = [s.name for s in scenes if not s.is_dir()]
        if missing:
            raise InputError(index, f"lists scenes that are not there: {', '.join(missing[:5])}")
        return scenes
    if scene_layout(root) is not None:
        return [root]
    with os.scandir(root) as entries:
        names = sorted(e.name for e in entries if e.is_dir())
    scenes = [root / n for n in names if scene_layout(root / n) is not None]
    if not scenes:
        raise InputError(
            root,
            "holds no scene folder (sub-folders with left.png, right.png, calib.json, or with "
            "color.png, depth.png, intrinsics.json)",
        )
    return scenes


def describe_scene_folder(
    folder: str | PathLike[str],
    db: ObjectDatabase | str | PathLike[str] | None = None,
    **options: Any,
) -> SceneDescription:
    """Describe the scene in ``folder``, whichever layout it has.

    Parameters
    ----------
    folder : path
        A stereo or RGB-D scene folder (module docstring).
    db : ObjectDatabase or path, optional
        The object database (an open one, or its file). A stereo folder needs one.
    **options
        :class:`~scenespeak.pipeline.PipelineOptions` fields (``dense=False``, ...).

    Returns
    -------
    SceneDescription
        As :func:`scenespeak.pipeline.describe_files` gives for the same files.

    Raises
    ------
    InputError
        Not a scene folder, no database for a stereo folder, an RGB-D folder where this
        version has no RGB-D path, or any problem with the files (naming the file).
    """
    p = Path(folder)
    layout = scene_layout(p)
    if layout == "stereo":
        return _describe_stereo(p, db, options)
    if layout == "rgbd":
        return _describe_rgbd(p, db, options)
    raise _not_a_scene(p)


def _describe_stereo(
    folder: Path, db: ObjectDatabase | str | PathLike[str] | None, options: dict[str, Any]
) -> SceneDescription:
    from scenespeak.perception.calibration import load_rig
    from scenespeak.perception.database import ObjectDatabase
    from scenespeak.perception.features import load_image
    from scenespeak.pipeline import describe_scene

    if db is None:
        raise InputError(folder, "a stereo scene needs an object database (give --db)")
    rig = load_rig(folder / "calib.json")
    left = load_image(folder / "left.png", gray=False)
    right = load_image(folder / "right.png", gray=False)
    sources = {
        "left": str(folder / "left.png"),
        "right": str(folder / "right.png"),
        "calib": str(folder / "calib.json"),
    }
    if isinstance(db, ObjectDatabase):
        sources["db"] = str(db.path)
        return describe_scene(left, right, rig, db, sources=sources, **options)
    sources["db"] = str(db)
    with ObjectDatabase.open(db, readonly=True) as opened:
        return describe_scene(left, right, rig, opened, sources=sources, **options)


def rgbd_supported() -> bool:
    """Whether this version can describe RGB-D scene folders (the RGB-D path of issue 11,
    ``scenespeak.inputs``, is installed)."""
    import importlib.util

    return importlib.util.find_spec("scenespeak.inputs") is not None


def check_supported(folders: list[Path]) -> None:
    """Refuse, naming the folder, a dataset holding a layout this version cannot describe.

    Raises
    ------
    InputError
        An RGB-D scene folder while :func:`rgbd_supported` is False.
    """
    if rgbd_supported():
        return
    for folder in folders:
        if scene_layout(folder) == "rgbd":
            raise InputError(
                folder,
                "is an RGB-D scene (color.png, depth.png, intrinsics.json); this version "
                "describes stereo scene folders only",
            )


def _describe_rgbd(
    folder: Path, db: ObjectDatabase | str | PathLike[str] | None, options: dict[str, Any]
) -> Any:
    """The RGB-D layout: the RGB-D path's own folder reader (``scenespeak.inputs``, issue 11).

    With ``instances.png`` + ``labels.json`` in the folder no database is needed; otherwise
    the objects are recognised with ``db`` (its file: the RGB-D path opens it itself).
    """
    if not rgbd_supported():
        raise InputError(
            folder,
            "is an RGB-D scene (color.png, depth.png, intrinsics.json); this version "
            "describes stereo scene folders only",
        )
    from scenespeak.inputs import describe_scene_folder as describe_any  # type: ignore[import-not-found,unused-ignore]
    from scenespeak.perception.database import ObjectDatabase

    db_file = db.path if isinstance(db, ObjectDatabase) else db
    return describe_any(folder, db_file, layout="rgbd")
