"""The scene as the dialogue sees it: plain Python values read from ``describe --format json``.

A :class:`DialogueScene` holds each object's name, label, footprint, centre and heights and
each ordered pair's relation (primary, secondary, degrees of truth, sentence), read from the
dict of a saved ``scenespeak describe --format json`` output or from a
:class:`~scenespeak.pipeline.SceneDescription` (through its ``to_dict()``, so both give the
same answers). This module imports only the standard library: answering a question about a
saved scene needs no NumPy, OpenCV or SciPy (``benchmarks/bench_ask.py``).

>>> scene = scene_from_dict({
...     "objects": [{"label": "mug", "centroid": [0.1, 0.1, 1.0], "hull": [[0, 1], [0.1, 1],
...                  [0.1, 1.1], [0, 1.1]]}],
...     "relations": [],
... })
>>> scene.objects[0].name, round(scene.objects[0].distance, 3)
('mug', 1.01)
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from os import PathLike
from typing import Any

from scenespeak.errors import InputError

__all__ = [
    "DialogueObject",
    "DialogueRelation",
    "DialogueScene",
    "Point2",
    "load_scene",
    "scene_from",
    "scene_from_dict",
]

Point2 = tuple[float, float]

#: Focal length (pixels) and baseline (metres) assumed when a scene does not say: the
#: generator's rig (640 px wide, 60° field of view, 12 cm baseline).
DEFAULT_FOCAL_PX = 554.256
DEFAULT_BASELINE_M = 0.12


@dataclass(frozen=True)
class DialogueObject:
    """One described object.

    Attributes
    ----------
    name : str
        Unique in the scene; what sentences call it ("mug", "left mug", "unknown object 2").
    label : str
        What it is; several instances may share it. ``"unknown"`` for unknown objects.
    hull : tuple of (x, y)
        Footprint on the horizontal plane (metres; x = camera right, y = depth).
    centroid : (X, Y, Z) or None
        Centre in the left camera's frame (metres).
    heights : (low, high) or None
        Range of the object's heights along up (metres).
    points : int
        Points it was built from.
    confidence : float
        How sure perception is of what it is, in [0, 1].
    colour : (r, g, b) or None
        Mean colour, 0-255, when the scene has colour.
    """

    name: str
    label: str
    hull: tuple[Point2, ...]
    centroid: tuple[float, float, float] | None = None
    heights: tuple[float, float] | None = None
    points: int = 0
    confidence: float = 1.0
    colour: tuple[float, float, float] | None = None

    @property
    def known(self) -> bool:
        """True when the object has a real label (not an unknown cluster)."""
        return not self.label.startswith("unknown")

    @property
    def plane_centroid(self) -> Point2:
        """The mean of the hull's vertices on the horizontal plane."""
        n = len(self.hull)
        return (sum(p[0] for p in self.hull) / n, sum(p[1] for p in self.hull) / n)

    @property
    def distance(self) -> float:
        """Metres from the camera to the object's centre (plane centre when no centroid)."""
        if self.centroid is not None:
            return math.sqrt(sum(v * v for v in self.centroid))
        return math.hypot(*self.plane_centroid)

    @property
    def depth(self) -> float:
        """Depth Z of the centre along the camera's axis (metres)."""
        return self.centroid[2] if self.centroid is not None else self.plane_centroid[1]

    @property
    def extent(self) -> tuple[float, float]:
        """Width (x) and depth (y) of the footprint's bounding box (metres)."""
        xs = [p[0] for p in self.hull]
        ys = [p[1] for p in self.hull]
        return (max(xs) - min(xs), max(ys) - min(ys))

    @property
    def height(self) -> float | None:
        """Height of the object (metres) from its heights along up, when known."""
        return None if self.heights is None else self.heights[1] - self.heights[0]

    @property
    def area(self) -> float:
        """Footprint area (m²), shoelace formula."""
        h = self.hull
        s = sum(h[i][0] * h[i - 1][1] - h[i - 1][0] * h[i][1] for i in range(len(h)))
        return abs(s) / 2.0


@dataclass(frozen=True)
class DialogueRelation:
    """The relation of one ordered pair as ``describe`` gave it (see ``interfaces.md``)."""

    argument: str
    referent: str
    primary: str
    secondary: str | None
    sentence: str
    degrees: Mapping[str, float] = field(default_factory=dict)
    confidence: float = 0.0
    vertical: str | None = None
    kind: str = "direction"
    hedge: str | None = None
    secondary_hedge: str | None = None
    deviation_deg: float = 0.0

    def degree(self, direction: str) -> float:
        """Degree of truth of ``direction`` (0 when unknown)."""
        return float(self.degrees.get(direction, 0.0))


@dataclass(frozen=True)
class DialogueScene:
    """Objects, relations and camera of one scene.

    Attributes
    ----------
    objects : tuple of DialogueObject
    relations : dict of (argument, referent) to DialogueRelation
    viewer : dict of name to dict
        Saved ``viewer`` entries (``describe --viewer``), when present.
    focal_px, baseline_m : float
        The stereo rig, for the depth error Z²·σ/(f·B).
    frame : str
        ``"horizontal"`` or ``"image"``.
    summary : str
        The saved summary, if any.
    """

    objects: tuple[DialogueObject, ...]
    relations: Mapping[tuple[str, str], DialogueRelation]
    viewer: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)
    focal_px: float = DEFAULT_FOCAL_PX
    baseline_m: float = DEFAULT_BASELINE_M
    frame: str = "horizontal"
    summary: str = ""

    def object(self, name: str) -> DialogueObject:
        """The object called ``name`` (KeyError when there is none)."""
        for o in self.objects:
            if o.name == name:
                return o
        raise KeyError(name)

    def relation(self, argument: str, referent: str) -> DialogueRelation | None:
        """The relation of ``argument`` to ``referent``, if it was described."""
        return self.relations.get((argument, referent))

    @property
    def names(self) -> tuple[str, ...]:
        """Every object's name, in the scene's order."""
        return tuple(o.name for o in self.objects)


def _floats(value: Any, n: int, where: str) -> tuple[float, ...]:
    try:
        out = tuple(float(v) for v in value)
    except (TypeError, ValueError) as exc:
        raise InputError(where, f"expected {n} numbers, got {value!r:.60}") from exc
    if len(out) != n or not all(math.isfinite(v) for v in out):
        raise InputError(where, f"expected {n} finite numbers, got {value!r:.60}")
    return out


def _object(d: Any, k: int, source: str) -> DialogueObject:
    if not isinstance(d, Mapping) or "label" not in d or "hull" not in d:
        raise InputError(source, f"objects[{k}] needs a 'label' and a 'hull'")
    where = f"{source}: objects[{k}]"
    from scenespeak.cleantext import check_label  # printable text, as every label

    for key in ("label", "name"):
        if d.get(key) is not None:
            check_label(d[key], f"{where}.{key}")
    if not isinstance(d["hull"], list | tuple):
        raise InputError(where, f"the hull must be a list of [x, z] points, got {d['hull']!r:.40}")
    hull = tuple(_floats(p, 2, f"{where}.hull") for p in d["hull"])
    if len(hull) < 3:
        raise InputError(where, f"a hull needs at least 3 vertices, got {len(hull)}")
    centroid = d.get("centroid")
    heights = d.get("height_range")
    colour = d.get("color", d.get("colour"))
    return DialogueObject(
        name=str(d.get("name") or d["label"]),
        label=str(d["label"]),
        hull=tuple((p[0], p[1]) for p in hull),
        centroid=None if centroid is None else _floats(centroid, 3, f"{where}.centroid"),  # type: ignore[arg-type]
        heights=None if heights is None else _floats(heights, 2, f"{where}.height_range"),  # type: ignore[arg-type]
        points=int(d.get("points", 0) or 0),
        confidence=float(d.get("confidence", 1.0)),
        colour=None if colour is None else _floats(colour, 3, f"{where}.color"),  # type: ignore[arg-type]
    )


def _relation(d: Any, k: int, source: str) -> DialogueRelation:
    try:
        return DialogueRelation(
            argument=str(d["argument"]),
            referent=str(d["referent"]),
            primary=str(d["primary"]),
            secondary=None if d.get("secondary") is None else str(d["secondary"]),
            sentence=str(d.get("sentence", "")),
            degrees={str(a): float(v) for a, v in (d.get("degrees") or {}).items()},
            confidence=float(d.get("confidence", 0.0)),
            vertical=d.get("vertical"),
            kind=str(d.get("kind", "direction")),
            hedge=d.get("hedge"),
            secondary_hedge=d.get("secondary_hedge"),
            deviation_deg=float(d.get("deviation_deg", 0.0)),
        )
    except (KeyError, TypeError, ValueError, AttributeError) as exc:
        raise InputError(source, f"relations[{k}] is not a describe relation ({exc})") from exc


def scene_from_dict(data: Mapping[str, Any], source: str = "scene") -> DialogueScene:
    """Read the dict of a ``describe --format json`` output.

    Parameters
    ----------
    data : mapping
        ``{"objects": [...], "relations": [...], ...}`` as ``interfaces.md`` has it; extras
        ``name``, ``height_range``, ``color``, ``viewer``, ``camera`` and ``frame`` are used
        when present.
    source : str
        Where it came from, for error messages.

    Raises
    ------
    InputError
        When ``objects`` or ``relations`` are missing or malformed, or a relation names an
        object that is not in ``objects``.
    """
    if not isinstance(data, Mapping) or not isinstance(data.get("objects"), list):
        raise InputError(source, 'not a describe --format json output: no "objects" list')
    objects = tuple(_object(d, k, source) for k, d in enumerate(data["objects"]))
    names = {o.name for o in objects}
    if len(names) != len(objects):
        raise InputError(source, "two objects share a name; give each a distinct 'name'")
    relations: dict[tuple[str, str], DialogueRelation] = {}
    for k, d in enumerate(data.get("relations") or []):
        rel = _relation(d, k, source)
        if rel.argument not in names or rel.referent not in names:
            raise InputError(
                source, f"relations[{k}] names an object not in 'objects' ({rel.argument!r})"
            )
        relations[rel.argument, rel.referent] = rel
    viewer = {
        str(v["object"]): v
        for v in data.get("viewer") or []
        if isinstance(v, Mapping) and "object" in v
    }
    cam = data.get("camera")
    camera: Mapping[str, Any] = cam if isinstance(cam, Mapping) else {}
    return DialogueScene(
        objects=objects,
        relations=relations,
        viewer=viewer,
        focal_px=float(camera.get("focal_px", DEFAULT_FOCAL_PX)),
        baseline_m=float(camera.get("baseline_m", DEFAULT_BASELINE_M)),
        frame=str(data.get("frame", "horizontal")),
        summary=str(data.get("summary", "")),
    )


def load_scene(path: str | PathLike[str]) -> DialogueScene:
    """Read a saved ``scenespeak describe --format json`` file.

    Read as untrusted input (:mod:`scenespeak.safetext`, the standard library only): a regular
    file under ``max_text_bytes`` (a FIFO never blocks), UTF-8, nesting and numbers bounded.

    Raises
    ------
    InputError
        When the file is missing, not a regular file, too large, not UTF-8, not JSON, nested
        too deeply, or not a describe output.
    """
    from scenespeak.safetext import as_path, load_json, read_text

    p = as_path(path)
    if not p.exists() and not p.is_symlink():
        raise InputError(p, "no such file (save one with `describe --format json`)")
    text = read_text(p, what="JSON file (a describe output)")
    try:
        data = load_json(text, p)
    except InputError as exc:
        raise InputError(p, f"cannot be read as JSON: {exc.problem}") from None
    return scene_from_dict(data, str(p))


def scene_from(scene: Any) -> DialogueScene:
    """A :class:`DialogueScene` from a scene, a describe dict, a ``SceneDescription`` or a path.

    Anything with a ``to_dict()`` method (a :class:`~scenespeak.pipeline.SceneDescription`) is
    read through it, so a live description and its saved JSON answer alike.
    """
    if isinstance(scene, DialogueScene):
        return scene
    if isinstance(scene, Mapping):
        return scene_from_dict(scene)
    if isinstance(scene, str | PathLike):
        return load_scene(scene)
    to_dict = getattr(scene, "to_dict", None)
    if callable(to_dict):
        return scene_from_dict(to_dict(), "scene description")
    raise InputError("scene", f"expected a SceneDescription or a describe dict, got {scene!r:.60}")


def hull_gap(a: Sequence[Point2], b: Sequence[Point2]) -> float:
    """Smallest distance between two convex footprints (0 when they touch or overlap).

    >>> sq = ((0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0))
    >>> hull_gap(sq, tuple((x + 3.0, y) for x, y in sq))
    2.0
    """
    if _overlap(a, b):
        return 0.0
    best = math.inf
    for p in a:
        best = min(best, _point_polygon(p, b))
    for p in b:
        best = min(best, _point_polygon(p, a))
    return best


def _point_segment(p: Point2, a: Point2, b: Point2) -> float:
    dx, dy = b[0] - a[0], b[1] - a[1]
    den = dx * dx + dy * dy
    t = 0.0 if den == 0 else max(0.0, min(1.0, ((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / den))
    return math.hypot(p[0] - a[0] - t * dx, p[1] - a[1] - t * dy)


def _point_polygon(p: Point2, poly: Sequence[Point2]) -> float:
    return min(_point_segment(p, poly[i - 1], poly[i]) for i in range(len(poly)))


def _overlap(a: Sequence[Point2], b: Sequence[Point2]) -> bool:
    """Separating-axis test of two convex polygons."""
    for poly in (a, b):
        for i in range(len(poly)):
            ex, ey = poly[i][0] - poly[i - 1][0], poly[i][1] - poly[i - 1][1]
            nx, ny = ey, -ex
            pa = [q[0] * nx + q[1] * ny for q in a]
            pb = [q[0] * nx + q[1] * ny for q in b]
            if max(pa) < min(pb) or max(pb) < min(pa):
                return False
    return True
