"""A user's own segmentation: instance images with a labels file, or detector boxes.

- An **instance image** (PNG, 8- or 16-bit, one channel): 0 = background, ``k > 0`` = instance
  ``k``. Its **labels** file is JSON ``{"1": "mug", "2": "can"}`` (a value may also be
  ``{"label": "mug"}``); several instances may share a label. An instance the labels do not
  name is kept as ``"unknown"``.
- **Boxes**: COCO detection results, ``[{"bbox": [x, y, w, h], "label": "mug", "score": 0.9}]``
  (``"category_name"`` or ``"category_id"`` instead of ``"label"``; a labels file then maps
  category ids to names). A box is not an object: :mod:`scenespeak.perception.rgbd` keeps the
  pixels of its nearest coherent surface.

Everything a user can get wrong is refused with one :class:`~scenespeak.errors.InputError`
naming the file: an instance image of another size than the colour image, a colour image given
as masks, an empty instance image, labels naming instances that are not in the image, boxes
outside the image or of no area.

>>> import numpy as np
>>> inst = np.zeros((4, 6), np.uint16); inst[1:3, 1:3] = 1; inst[1:3, 4:6] = 2
>>> m = instances_from_array(inst, {1: "mug", 2: "mug"}, source="i.png")
>>> m.ids, m.labels, m.boxes
((1, 2), ('mug', 'mug'), ((1, 1, 3, 3), (4, 1, 6, 3)))
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from os import PathLike
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from scenespeak.cleantext import clean_text
from scenespeak.errors import ImageError, InputError

__all__ = [
    "Box",
    "InstanceMasks",
    "boxes_from_list",
    "instances_from_array",
    "load_boxes",
    "load_instances",
    "load_labels",
]

#: Label of an instance the labels file does not name.
UNKNOWN = "unknown"


@dataclass(frozen=True, eq=False)
class InstanceMasks:
    """An instance image and what each instance is.

    Attributes
    ----------
    image : (H, W) int32
        0 = background, ``k`` = instance ``k``.
    ids : tuple of int
        The instances present, ascending.
    labels : tuple of str
        The label of each id (``"unknown"`` when the labels file does not name it).
    boxes : tuple of (x0, y0, x1, y1)
        Each instance's bounding box in pixels (``x1``, ``y1`` exclusive).
    source : str
        The instance image's file name, for messages.
    """

    image: NDArray[np.int32]
    ids: tuple[int, ...]
    labels: tuple[str, ...]
    boxes: tuple[tuple[int, int, int, int], ...]
    source: str = "masks"

    @property
    def size(self) -> tuple[int, int]:
        """(width, height)."""
        return (int(self.image.shape[1]), int(self.image.shape[0]))

    def mask(self, k: int) -> tuple[NDArray[np.bool_], tuple[int, int]]:
        """Instance number ``k`` of :attr:`ids` (0-based) as a cropped mask and its (x0, y0)."""
        x0, y0, x1, y1 = self.boxes[k]
        return self.image[y0:y1, x0:x1] == self.ids[k], (x0, y0)

    def full_mask(self, k: int) -> NDArray[np.bool_]:
        """Instance number ``k`` of :attr:`ids` as a mask of the whole image."""
        return self.image == self.ids[k]


@dataclass(frozen=True)
class Box:
    """One detection: ``label``, the box ``(x, y, w, h)`` in pixels (COCO), ``score``."""

    label: str
    x: float
    y: float
    w: float
    h: float
    score: float = 1.0

    def pixel_box(self, size: tuple[int, int]) -> tuple[int, int, int, int]:
        """(x0, y0, x1, y1) of the pixels whose centres lie in the box, clipped to ``size``."""
        width, height = size
        x0 = max(0, int(np.ceil(self.x - 0.5)))
        y0 = max(0, int(np.ceil(self.y - 0.5)))
        x1 = min(width, int(np.ceil(self.x + self.w - 0.5)))
        y1 = min(height, int(np.ceil(self.y + self.h - 0.5)))
        return x0, y0, x1, y1


def _read_json(path: Path, what: str) -> Any:
    """Bounded, as every reader (:mod:`scenespeak.safetext`: regular file, size, nesting)."""
    from scenespeak.safetext import load_json, read_text

    if not path.exists() and not path.is_symlink():
        raise InputError(path, f"no such {what} file")
    return load_json(read_text(path, what=f"JSON {what} file"), path)


def _label_value(v: Any, key: str, src: str) -> str:
    if isinstance(v, Mapping):
        v = v.get("label", v.get("name"))
    if not isinstance(v, str) or not v.strip():
        raise InputError(src, f'instance "{key}" needs a non-empty label, got {v!r:.40}')
    from scenespeak.cleantext import check_label  # the labels' rules everywhere: printable

    try:
        return check_label(v, src).strip()
    except InputError as exc:
        raise InputError(src, f'instance "{clean_text(key)[:20]}": {exc.problem}') from None


def labels_from_mapping(d: Any, source: str = "labels") -> dict[int, str]:
    """``{"1": "mug"}`` (or ``{"1": {"label": "mug"}}``) to ``{1: "mug"}``.

    Raises
    ------
    InputError
        A key that is not a positive integer or an empty label.
    """
    if not isinstance(d, Mapping):
        raise InputError(source, 'expected a JSON object {"1": "mug", "2": "can"}')
    out: dict[int, str] = {}
    for key, v in d.items():
        try:
            k = int(key)
        except (TypeError, ValueError):
            raise InputError(source, f"key {key!r} is not an instance number") from None
        if k <= 0:
            raise InputError(source, f"instance numbers start at 1 (0 is background), got {k}")
        out[k] = _label_value(v, str(key), source)
    return out


def load_labels(path: str | PathLike[str]) -> dict[int, str]:
    """Read a labels JSON file into ``{instance number: label}``."""
    p = Path(path)
    return labels_from_mapping(_read_json(p, "labels"), str(p))


def load_instances(path: str | PathLike[str]) -> NDArray[np.int32]:
    """Read an instance image (PNG/TIFF, 8- or 16-bit, one channel) as int32.

    A three-channel image whose channels are equal is read as one channel; any other colour
    image is refused (an instance image holds numbers, not colours).
    """
    from scenespeak.safeio import decode_image, read_bytes

    p = Path(path)
    if not p.exists() and not p.is_symlink():
        raise ImageError(p, "no such instance image")
    try:  # bounded: regular file, size, pixels from the header; decoder noise said once
        img = decode_image(read_bytes(p, error=ImageError, what="instance image"), p)
    except ImageError as exc:
        raise ImageError(p, f"{exc.problem} (give an 8- or 16-bit PNG)") from None
    a = np.asarray(img)
    if a.ndim == 3:
        if (
            a.shape[2] >= 3
            and np.array_equal(a[:, :, 0], a[:, :, 1])
            and np.array_equal(a[:, :, 0], a[:, :, 2])
        ):
            a = a[:, :, 0]
        else:
            raise ImageError(
                p,
                "is a colour image: give an instance image with one channel "
                "(0 = background, k = instance k), 8- or 16-bit",
            )
    if not np.issubdtype(a.dtype, np.integer):
        raise ImageError(p, f"holds {a.dtype} values: instance numbers must be integers")
    return a.astype(np.int32)


def instances_from_array(
    image: NDArray[np.integer[Any]],
    labels: Mapping[int, str] | None = None,
    *,
    size: tuple[int, int] | None = None,
    source: str = "masks",
    labels_source: str = "labels",
    other_name: str = "the colour image",
) -> InstanceMasks:
    """Check an instance image against its labels and the colour image's ``size``.

    Parameters
    ----------
    image : (H, W) integer array
        0 = background, k = instance k.
    labels : mapping of int to str, optional
        The label of each instance; instances it does not name are ``"unknown"``.
    size : (width, height), optional
        The colour image's size the masks must have.
    source, labels_source, other_name : str
        Names for the messages.

    Raises
    ------
    ImageError
        Another size than ``size``, negative values, or no instance at all.
    InputError
        Labels naming instances that are not in the image.
    """
    from scipy import ndimage

    a = _checked_image(image, size, source, other_name)
    found = ndimage.find_objects(a)
    ids = tuple(k + 1 for k, sl in enumerate(found) if sl is not None)
    if not ids:
        raise ImageError(source, "is empty: no pixel belongs to an instance (all 0)")
    names = dict(labels or {})
    _check_labels(names, ids, source, labels_source)
    boxes = []
    for k in ids:
        sl = found[k - 1]
        assert sl is not None
        boxes.append((int(sl[1].start), int(sl[0].start), int(sl[1].stop), int(sl[0].stop)))
    return InstanceMasks(
        image=a,
        ids=ids,
        labels=tuple(names.get(k, UNKNOWN) for k in ids),
        boxes=tuple(boxes),
        source=source,
    )


def _checked_image(
    image: NDArray[np.integer[Any]], size: tuple[int, int] | None, source: str, other_name: str
) -> NDArray[np.int32]:
    """The instance image as int32: one channel, of ``size`` (width, height), no negatives."""
    a = np.asarray(image)
    if a.ndim != 2:
        raise ImageError(source, f"must have one channel, got shape {a.shape}")
    h, w = a.shape
    if size is not None and (w, h) != tuple(size):
        raise ImageError(
            source, f"is {w}x{h} but {other_name} is {size[0]}x{size[1]}: masks must be of its size"
        )
    a = a.astype(np.int32, copy=False)
    if a.min(initial=0) < 0:
        raise ImageError(
            source, "holds negative values; instance numbers are 0 (background) or more"
        )
    return a


def _check_labels(
    names: Mapping[int, str], ids: tuple[int, ...], source: str, labels_source: str
) -> None:
    """Labels may only name instances that are in the image (``ids``)."""
    missing = sorted(set(names) - set(ids))
    if not missing:
        return
    shown = ", ".join(str(k) for k in missing[:8]) + (" ..." if len(missing) > 8 else "")
    raise InputError(
        labels_source,
        f"names instance{'s' if len(missing) > 1 else ''} {shown} that "
        f"{'are' if len(missing) > 1 else 'is'} not in {source} (it holds "
        f"{', '.join(str(k) for k in ids[:8])}{' ...' if len(ids) > 8 else ''})",
    )


def _box_label(d: Mapping[str, Any], names: Mapping[int, str] | None, src: str, i: int) -> str:
    for key in ("label", "category_name", "class", "name"):
        v = d.get(key)
        if isinstance(v, str) and v.strip():
            return v.strip()
    cat = d.get("category_id")
    if cat is not None:
        try:
            c = int(cat)
        except (TypeError, ValueError):
            raise InputError(src, f"detection {i}: category_id {cat!r} is not an integer") from None
        if names is not None and c in names:
            return names[c]
        return f"category {c}"
    raise InputError(src, f'detection {i} has no "label" (or "category_name", "category_id")')


def _one_box(
    d: Any, i: int, names: Mapping[int, str] | None, source: str, size: tuple[int, int] | None
) -> Box:
    """Detection ``i`` of a COCO list as a :class:`Box` (one line naming it when malformed)."""
    if not isinstance(d, Mapping):
        raise InputError(source, f"detection {i} is not a JSON object")
    bbox = d.get("bbox")
    try:
        x, y, w, h = (float(v) for v in bbox)  # type: ignore[union-attr]
    except (TypeError, ValueError):
        raise InputError(
            source, f"detection {i}: bbox must be [x, y, w, h], got {bbox!r}"
        ) from None
    if not all(np.isfinite([x, y, w, h])) or w <= 0 or h <= 0:
        raise InputError(source, f"detection {i}: bbox {bbox} has no area (w and h must be > 0)")
    score = d.get("score", 1.0)
    try:
        s = float(score)
    except (TypeError, ValueError):
        raise InputError(source, f"detection {i}: score {score!r} is not a number") from None
    box = Box(_box_label(d, names, source, i), x, y, w, h, s)
    if size is not None:
        x0, y0, x1, y1 = box.pixel_box(size)
        if x1 <= x0 or y1 <= y0:
            raise InputError(
                source, f"detection {i}: bbox {bbox} lies outside the {size[0]}x{size[1]} image"
            )
    return box


def boxes_from_list(
    data: Any,
    *,
    size: tuple[int, int] | None = None,
    names: Mapping[int, str] | None = None,
    min_score: float = 0.0,
    source: str = "boxes",
) -> list[Box]:
    """COCO detection results to :class:`Box` values (those with ``score >= min_score``).

    Raises
    ------
    InputError
        Not a list, a malformed entry, a box of no area or wholly outside the image, or no box.

    Examples
    --------
    >>> boxes_from_list([{"bbox": [10, 20, 30, 40], "label": "mug", "score": 0.9}])
    [Box(label='mug', x=10.0, y=20.0, w=30.0, h=40.0, score=0.9)]
    """
    if isinstance(data, Mapping) and "annotations" in data:
        data = data["annotations"]  # a COCO ground-truth file
    if not isinstance(data, list):
        raise InputError(source, 'expected a JSON list of detections [{"bbox": [x, y, w, h], ...}]')
    out: list[Box] = []
    for i, d in enumerate(data):
        box = _one_box(d, i, names, source, size)
        if box.score >= min_score:
            out.append(box)
    if not out:
        raise InputError(
            source, "holds no detection" + (f" with score >= {min_score}" if min_score else "")
        )
    return out


def load_boxes(
    path: str | PathLike[str],
    *,
    size: tuple[int, int] | None = None,
    names: Mapping[int, str] | None = None,
    min_score: float = 0.0,
) -> list[Box]:
    """Read COCO detection results (JSON) into :class:`Box` values (see :func:`boxes_from_list`)."""
    p = Path(path)
    return boxes_from_list(
        _read_json(p, "boxes"), size=size, names=names, min_score=min_score, source=str(p)
    )
