"""Learnt cylinders looked for as seen from where the camera is: views from higher up.

A learnt cylinder's training views are photographed from a little above (about 17° on the
generated sets); a rig 0.3-0.45 m above the support sees objects 0.5-1.2 m away from 25-45°
above, where the label's lines bend and it is foreshortened, and SIFT matches little: a grey
tin 0.59 m away, 37° below the camera, passed the ratio test with 5 of 66 keypoints against its
training views, with 44 against views rendered from 40° (session 9, ``docs/database.md``).
Views synthesised from higher up and *added to the index* did not help: their descriptors,
near copies of their source view's, split the few matches between views and fill the ratio
test's k neighbours with one object (session 9).

So they are kept out of the index. At ``db add`` (:func:`add_elevated_views`), each view of a
cylinder (:func:`~scenespeak.perception.recognition.cylinder_views.cylinder_of`) is remapped
(:func:`~scenespeak.perception.recognition.cylinder_views.view_from`) to be seen from each
elevation of :data:`ELEVATIONS` that is at least :data:`MIN_RAISE` above its own, and its SIFT
features are stored in a side table (``elevated_views``) that the label index never loads.
In a scene, the closer look (:mod:`~scenespeak.perception.recognition.closer`) asks
:class:`ElevatedLook` about an unknown segment that it could not name:

1. geometry gives the elevation the segment is seen from (:func:`seen_from`: its points, the
   support plane and the camera centre) and its standing proportion;
2. the candidates are the learnt objects with views stored at the elevation nearest it (within
   :data:`BUCKET_REACH`) whose training views' aspects the proportion fits
   (:meth:`~scenespeak.perception.recognition.shape_guard.ShapeGuard.fits`);
3. the segment's keypoints are matched against those views with Lowe's ratio test, whose
   second neighbour is the nearest descriptor of *another* object: of another candidate's
   views here, or of another object in the whole database's index (Lowe 2004, sec. 7.1), so a
   keypoint that is as close to some other learnt object does not count;
4. each candidate's views are verified as in the label index (RANSAC homography or
   similarity, :func:`~scenespeak.perception.recognition.label._detect_object`); the closer
   look's own rules (area, share of matches, coverage, veto) then decide as for its first
   look.
"""

from __future__ import annotations

import dataclasses
import sqlite3
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from scenespeak.perception.features import Features, detect
from scenespeak.perception.objects import SceneObject
from scenespeak.perception.recognition.cylinder_views import Cylinder, cylinder_of, view_from
from scenespeak.perception.recognition.index import ExactIndex
from scenespeak.perception.recognition.label import _Candidates, _detect_object, _Loaded
from scenespeak.perception.recognition.options import LabelOptions
from scenespeak.perception.recognition.results import Labelling
from scenespeak.perception.recognition.shape_guard import ShapeGuard
from scenespeak.perception.recognition.views import outline_from_mask, read_grey_views

__all__ = [
    "ELEVATIONS",
    "ElevatedLook",
    "add_elevated_views",
    "cylinder_views_of",
    "elevated_features",
    "seen_from",
]

#: The elevations (degrees above the support) the side table's views are seen from.
ELEVATIONS = (26.0, 34.0, 42.0, 50.0)
#: A view is synthesised at an elevation at least this many degrees above its own.
MIN_RAISE = 5.0
#: A segment is looked for at the stored elevation nearest its own, if within this (degrees).
BUCKET_REACH = 6.0

_TABLE = (
    "CREATE TABLE IF NOT EXISTS elevated_views (id INTEGER PRIMARY KEY, "
    "label TEXT NOT NULL, view_id INTEGER NOT NULL, source_n INTEGER NOT NULL, "
    "elevation REAL NOT NULL, n INTEGER NOT NULL, descriptors BLOB NOT NULL, "
    "keypoints BLOB NOT NULL, outline BLOB NOT NULL)"
)


def _elevation_of(cyl: Cylinder) -> float:
    """The elevation (degrees) a view sees its cylinder's middle from."""
    return float(np.degrees(np.arcsin((cyl.sin_bottom + cyl.sin_top) / 2.0)))


def cylinder_views_of(
    masks: Sequence[NDArray[np.bool_] | None], *, width_spread: float = 0.05
) -> list[Cylinder | None]:
    """Each masked view's cylinder when the object is one (as
    :func:`~scenespeak.perception.recognition.cylinder_views.elevated_views` decides: at least
    3 and 60 % of the views are a cylinder's silhouette, of one width within ``width_spread``),
    else all None.

    >>> box = np.zeros((100, 100), bool); box[20:80, 30:70] = True
    >>> cylinder_views_of([box, box, box])
    [None, None, None]
    """
    cyls = [None if m is None else cylinder_of(np.asarray(m, bool)) for m in masks]
    good = [c for c in cyls if c is not None]
    none: list[Cylinder | None] = [None] * len(cyls)
    if len(good) < max(3, 0.6 * len(cyls)):
        return none
    widths = np.array([c.r for c in good])
    if float(widths.max() / widths.min()) > 1.0 + width_spread:
        return none
    return cyls


def _detect_inside(
    image: NDArray[np.generic], mask: NDArray[np.bool_], sift: tuple[int, float], pad: int = 16
) -> Features:
    """SIFT features inside ``mask``, found in the box round it grown by ``pad`` pixels (the
    same keypoints as in the whole image but for the box's edge, at a fraction of the cost),
    in the whole image's pixels."""
    rows, cols = np.nonzero(mask)
    if not len(rows):
        return detect(image, mask=mask, max_features=sift[0], contrast_threshold=sift[1])
    h, w = mask.shape
    y0, y1 = max(int(rows.min()) - pad, 0), min(int(rows.max()) + pad + 1, h)
    x0, x1 = max(int(cols.min()) - pad, 0), min(int(cols.max()) + pad + 1, w)
    f = detect(
        image[y0:y1, x0:x1],
        mask=mask[y0:y1, x0:x1],
        max_features=sift[0],
        contrast_threshold=sift[1],
    )
    return dataclasses.replace(f, xy=f.xy + np.array([x0, y0], np.float64))


def elevated_features(
    images: Sequence[Any], masks: Sequence[Any], sift: tuple[int, float]
) -> list[tuple[int, float, Features, NDArray[np.float32]]]:
    """``(view index, elevation, features, outline)`` of every view of a cylinder seen from
    each elevation of :data:`ELEVATIONS` at least :data:`MIN_RAISE` above its own (``sift =
    (max_features, contrast_threshold)``, as the training views); [] for other objects."""
    grays, ms = read_grey_views(images, masks)
    out = []
    for i, cyl in enumerate(cylinder_views_of(ms)):
        if cyl is None:
            continue
        own = _elevation_of(cyl)
        for elev in ELEVATIONS:
            if elev - own < MIN_RAISE:
                continue
            view, vmask = view_from(grays[i], cyl, elev - own)
            feats = _detect_inside(view, vmask, sift)
            if len(feats):
                out.append((i, elev, feats, outline_from_mask(vmask)))
    return out


def add_elevated_views(
    db: Any,
    label: str,
    images: Sequence[Any],
    masks: Sequence[Any] | None,
    sift: tuple[int, float] = (0, 0.02),
) -> int:
    """Store the views of the learnt object ``label`` (just added to the
    :class:`~scenespeak.perception.recognition.ObjectDatabase` ``db`` from ``images`` and
    ``masks``) from higher up in the side table (module docstring), replacing its earlier
    rows; returns how many (0 for an object that is not a cylinder or has no masks)."""
    conn: sqlite3.Connection = db.conn
    conn.execute(_TABLE)
    with conn:
        conn.execute("DELETE FROM elevated_views WHERE label = ?", (label,))
    if masks is None:
        return 0
    sources = [(v.id, v.keypoints) for v in db.views(label)]
    rows = elevated_features(images, masks, sift)
    with conn:
        for i, elev, f, outline in rows:
            kp = np.column_stack([f.xy, f.size, f.angle]).astype(np.float32)
            conn.execute(
                "INSERT INTO elevated_views(label, view_id, source_n, elevation, n, "
                "descriptors, keypoints, outline) VALUES (?, ?, ?, ?, ?, ?, ?, ?)",
                (
                    label,
                    sources[i][0],
                    sources[i][1],
                    elev,
                    len(f),
                    np.ascontiguousarray(f.descriptors, np.uint8).tobytes(),
                    kp.tobytes(),
                    np.ascontiguousarray(outline, np.float32).tobytes(),
                ),
            )
    return len(rows)


def seen_from(
    xyz: NDArray[np.floating], normal: NDArray[np.floating], level: float
) -> float | None:
    """The elevation (degrees) the camera at the origin sees the middle of the points ``xyz``
    standing on the plane ``{p : p·normal = level}`` (``normal`` up) from: the angle above the
    plane of the line from the middle of their height above their footprint's centre to the
    camera. None for fewer than 3 points or a camera not above the plane.

    >>> n = np.array([0.0, -1.0, 0.0])  # up is -y; the plane 0.4 m below the camera
    >>> pts = np.array([[0.0, 0.4 - h, 0.6] for h in np.linspace(0.0, 0.1, 20)])
    >>> round(seen_from(pts, n, -0.4), 1)  # atan(0.35 / 0.6)
    30.3
    """
    p = np.asarray(xyz, np.float64).reshape(-1, 3)
    n = np.asarray(normal, np.float64)
    if len(p) < 3 or -float(level) <= 0:
        return None
    heights = p @ n - float(level)
    top = float(np.percentile(heights, 98))
    foot = p.mean(axis=0) - (float(p.mean(axis=0) @ n) - float(level)) * n
    mid = foot + 0.5 * max(top, 0.0) * n
    up = -float(mid @ n)
    dist = float(np.linalg.norm(mid))
    if dist <= 0 or up <= 0:
        return None
    return float(np.degrees(np.arcsin(min(up / dist, 1.0))))


@dataclass(frozen=True)
class _Side:
    """The side table's views of some objects at one elevation, stacked."""

    descriptors: NDArray[np.uint8]
    object_of: NDArray[np.int32]
    view_of: NDArray[np.int32]
    keypoints: NDArray[np.float32]
    labels: dict[int, str]
    outlines: dict[int, NDArray[np.float32]]


def _read_only(path: str) -> sqlite3.Connection:
    """A read-only connection of its own to the database file ``path``."""
    return sqlite3.connect(f"{Path(path).absolute().as_uri()}?mode=ro", uri=True)


def _read_side(path: str, labels: Sequence[str], elevations: Sequence[float]) -> _Side:
    """The stored views of ``labels`` at ``elevations`` whose source views are still the
    ones they were made from, each known by its own row id (a fresh read-only connection: the
    closer look may run in another thread than the one that opened the database)."""
    conn = _read_only(path)
    try:
        marks = ",".join("?" * len(labels))
        rows = conn.execute(
            "SELECT e.label, e.id, e.n, e.descriptors, e.keypoints, e.outline "
            "FROM elevated_views e JOIN views v ON v.id = e.view_id AND v.n = e.source_n "
            "JOIN objects o ON o.id = v.object_id AND o.label = e.label "
            f"WHERE e.elevation IN ({','.join('?' * len(elevations))}) "
            f"AND e.label IN ({marks}) ORDER BY e.id",
            (*elevations, *labels),
        ).fetchall()
    finally:
        conn.close()
    order = {lab: i for i, lab in enumerate(labels)}
    descs, objs, vids, kps, outlines = [], [], [], [], {}
    for lab, vid, n, d, k, out in rows:
        descs.append(np.frombuffer(d, np.uint8).reshape(-1, 128))
        kps.append(np.frombuffer(k, np.float32).reshape(-1, 4))
        objs.append(np.full(int(n), order[lab], np.int32))
        vids.append(np.full(int(n), int(vid), np.int32))
        outlines[int(vid)] = np.frombuffer(out, np.float32).reshape(-1, 2)
    if not rows:
        return _Side(
            np.zeros((0, 128), np.uint8),
            np.zeros(0, np.int32),
            np.zeros(0, np.int32),
            np.zeros((0, 4), np.float32),
            {},
            {},
        )
    return _Side(
        np.concatenate(descs),
        np.concatenate(objs),
        np.concatenate(vids),
        np.concatenate(kps),
        dict(enumerate(labels)),
        outlines,
    )


def stored_elevations(path: str) -> dict[str, tuple[float, ...]]:
    """The side table's elevations per label ({} without the table)."""
    conn = _read_only(path)
    try:
        have = conn.execute(
            "SELECT 1 FROM sqlite_master WHERE type = 'table' AND name = 'elevated_views'"
        ).fetchone()
        if have is None:
            return {}
        rows = conn.execute("SELECT DISTINCT label, elevation FROM elevated_views").fetchall()
    finally:
        conn.close()
    out: dict[str, list[float]] = {}
    for lab, elev in rows:
        out.setdefault(str(lab), []).append(float(elev))
    return {lab: tuple(sorted(v)) for lab, v in out.items()}


def _other_distance(
    dist: NDArray[np.float32],
    objs: NDArray[np.int64],
    valid: NDArray[np.bool_],
    first: NDArray[np.int64],
) -> NDArray[np.float32]:
    """Per query row: the nearest valid distance whose object differs from ``first`` (inf:
    none)."""
    other = (objs != first[:, None]) & valid
    has = other.any(axis=1)
    j = np.argmax(other, axis=1)
    return np.where(has, dist[np.arange(len(dist)), j], np.inf).astype(np.float32)


@dataclass(frozen=True, eq=False)
class ElevatedLook:
    """The closer look's second try on an unknown segment (module docstring).

    Attributes
    ----------
    path : str
        The database file (its side table is read here, lazily).
    have : mapping
        The side table's elevations per label (:func:`stored_elevations`).
    main : _Loaded
        The loaded label index: the ratio test's other objects.
    aspects : mapping
        Each label's training views' standing aspects (the colour models' ``aspects``).
    guard : ShapeGuard
        The support plane and the proportion bounds.
    options : LabelOptions
        The labelling's knobs (ratio, RANSAC, small-object rule).
    """

    path: str
    have: Mapping[str, tuple[float, ...]]
    main: _Loaded
    aspects: Mapping[str, NDArray[np.floating] | None]
    guard: ShapeGuard
    options: LabelOptions = field(default_factory=LabelOptions)
    _cache: dict[tuple[tuple[str, ...], tuple[float, ...]], _Side] = field(default_factory=dict)

    def candidates(self, obj: SceneObject) -> tuple[tuple[float, ...], tuple[str, ...]] | None:
        """The stored elevations within :data:`BUCKET_REACH` of the segment's (one or two)
        and the labels it could be there."""
        e = seen_from(obj.xyz, self.guard.normal, self.guard.level)
        if e is None:
            return None
        near = tuple(
            sorted({x for v in self.have.values() for x in v if abs(x - e) <= BUCKET_REACH})
        )
        if not near:
            return None
        prop = self.guard.proportion(obj.xyz)
        labels = tuple(
            sorted(
                lab
                for lab, elevs in self.have.items()
                if set(near) & set(elevs) and self.guard.fits(prop, self.aspects.get(lab))
            )
        )
        return (near, labels) if labels else None

    def _side(self, labels: tuple[str, ...], elevations: tuple[float, ...]) -> _Side:
        key = (labels, elevations)
        if key not in self._cache:
            self._cache[key] = _read_side(self.path, labels, elevations)
        return self._cache[key]

    def __call__(self, obj: SceneObject, features: Features) -> Labelling | None:
        """The detections of the segment's candidates in ``features`` (its keypoints), or
        None when it has none."""
        found = self.candidates(obj)
        if found is None or not len(features):
            return None
        side = self._side(found[1], found[0])
        if not len(side.descriptors):
            return None
        # the small-object rule wherever it stands (a near cylinder's region is large, but
        # the half of it one view from above shows holds few of its matches)
        o = dataclasses.replace(self.options, small_area=np.inf)
        return _label_side(side, self.main, features, o)


def _label_side(side: _Side, main: _Loaded, features: Features, o: LabelOptions) -> Labelling:
    """Label ``features`` against the side views (module docstring, steps 3-4)."""
    nq = len(features)
    index = ExactIndex(side.descriptors)
    kk = max(2, min(o.k, index.ntotal))
    dist, ids = index.search(features.descriptors, kk)
    first = side.object_of[ids[:, 0]].astype(np.int64)
    obj = side.object_of[np.maximum(ids, 0)].astype(np.int64)
    d2 = _other_distance(dist, obj, ids >= 0, first)
    # the whole database: the nearest descriptor of an object other than the candidate
    mk = max(2, min(o.k, main.index.ntotal))
    mdist, mids = main.index.search(features.descriptors, mk)
    lut = np.full(max(main.labels, default=0) + 1, -1, np.int64)
    code = {lab: i for i, lab in side.labels.items()}
    for oid, lab in main.labels.items():
        lut[oid] = code.get(lab, len(code) + int(oid))
    mobj = lut[main.object_of[np.maximum(mids, 0)]]
    md2 = _other_distance(mdist, mobj, mids >= 0, first)
    md2 = np.where(np.isinf(md2), mdist[:, -1], md2)
    limit = (o.ratio * o.ratio) * np.minimum(d2, md2)
    passed = (ids[:, 0] >= 0) & (dist[:, 0] < limit)
    cand = passed[:, None] & (obj == first[:, None]) & (ids >= 0) & (dist < limit[:, None])
    rows, cols = np.nonzero(cand)
    t_all = ids[rows, cols]
    v_all = side.view_of[t_all].astype(np.int64)
    key = rows.astype(np.int64) * (int(side.view_of.max()) + 1) + v_all
    _, first_at = np.unique(key, return_index=True)
    q_idx = rows[first_at].astype(np.intp)
    t_idx = t_all[first_at]
    c = _Candidates(q_idx, t_idx, side.view_of[t_idx], first.astype(np.int32), passed, ids[:, 0])
    kp = side.keypoints
    small = _Loaded(
        0,
        index,
        side.object_of,
        side.view_of,
        kp[:, :2],
        kp[:, 2],
        kp[:, 3],
        side.labels,
        side.outlines,
    )
    need = min(o.min_inliers, o.min_inliers_small) if o.small_area > 0 else o.min_inliers
    found = []
    for oid in np.unique(first[q_idx]).tolist():
        found.extend(_detect_object(small, features, c, int(oid), need, o))
    found.sort(key=lambda d: -d.score)
    labels = np.full(nq, -1, np.int32)
    for i, det in enumerate(found):
        labels[det.inliers] = i
    matched = np.where(passed, first, -1).astype(np.int32)
    return Labelling(labels, tuple(found), matched)


def elevated_look(db: Any, options: LabelOptions, geometry: bool = True) -> Any:
    """A maker of :class:`ElevatedLook` for the database ``db`` (``make(guard)`` once the
    scene's support plane is known), or None when the closer look is off
    (``options.closer``, or no ``geometry``) or the side table holds no views. Reads the
    database now (the look itself reads only the side table, with a connection of its own)."""
    path = str(getattr(db, "path", ""))
    if not (options.closer and geometry and path and hasattr(db, "colour_models")):
        return None
    have = stored_elevations(path)
    if not have:
        return None
    db.load(nprobe=options.nprobe)
    main = db._loaded
    aspects = {
        lab: m.grey_aspects if m.grey_aspects is not None else m.aspects
        for lab, m in db.colour_models().items()
    }

    def make(guard: ShapeGuard) -> ElevatedLook:
        return ElevatedLook(path, have, main, aspects, guard, options)

    return make
