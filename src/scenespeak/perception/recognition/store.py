"""The object database: a SQLite file of labelled SIFT descriptors (one transaction per write)."""

from __future__ import annotations

import contextlib
import functools
import sqlite3
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import Executor
from os import PathLike
from pathlib import Path
from types import TracebackType
from typing import Any

import numpy as np
from numpy.typing import NDArray

from scenespeak.cleantext import check_label
from scenespeak.errors import DatabaseError, InputError
from scenespeak.perception import dbfiles
from scenespeak.perception.features import Features
from scenespeak.perception.recognition.colour import ColourModel
from scenespeak.perception.recognition.index import (
    DescriptorIndex,
    IndexKind,
)
from scenespeak.perception.recognition.label import LabelOptions, _Loaded, label_features
from scenespeak.perception.recognition.loading import (
    index_of,
    read_colour_models,
    read_views,
    synthetic_of,
)
from scenespeak.perception.recognition.results import Labelling, ObjectInfo, TrainingView
from scenespeak.perception.recognition.schema import (
    _SCHEMA,
    APPLICATION,
    APPLICATION_ID,
    SCHEMA_VERSION,
    _check_magic,
    _check_schema,
    _duplicate,
    _now,
    migrate,
)
from scenespeak.perception.recognition.views import (
    ImageLike,
    MaskLike,
    extract_views,
    forget_raised,
    insert_view,
    record_raised,
)
from scenespeak.safeio import as_path

__all__ = ["ObjectDatabase"]


Progress = Callable[[str, int, int], None]


# --------------------------------------------------------------------------------------------
# The database
# --------------------------------------------------------------------------------------------


class ObjectDatabase:
    """A SQLite file of labelled SIFT descriptors learnt from training images.

    Open with :meth:`open` (or :meth:`create`); use as a context manager, which closes the
    file. Do not call the constructor directly.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from skimage import data
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "objects.db"
    >>> with ObjectDatabase.create(path) as db:
    ...     _ = db.add_object("cat", [data.chelsea()])
    ...     db.labels()
    ['cat']
    >>> with ObjectDatabase.open(path) as db:
    ...     [(o.label, o.views) for o in db.list_objects()]
    [('cat', 1)]
    """

    def __init__(
        self, path: Path, conn: sqlite3.Connection, *, readonly: bool, index_kind: IndexKind
    ) -> None:
        self.path = path
        self._conn: sqlite3.Connection | None = conn
        self.readonly = readonly
        self.index_kind: IndexKind = index_kind
        self._loaded: _Loaded | None = None
        self._colours: tuple[int, dict[str, ColourModel]] | None = None  # (generation, models)

    # -- opening -------------------------------------------------------------------------

    @classmethod
    def create(cls, path: str | PathLike[str], *, index: IndexKind = "auto") -> ObjectDatabase:
        """Create a new, empty database file (atomically: never a 0-byte or half-made file).

        Raises
        ------
        DatabaseError
            If the file already exists or cannot be written.
        """
        p = as_path(path, error=DatabaseError)
        if dbfiles.check_file(p, must_exist=False) or not dbfiles.create_empty(p):
            raise DatabaseError(p, "already exists; open it instead, or choose another name")
        return cls._connect(p, readonly=False, index=index)

    @classmethod
    def _new_file(cls, p: Path) -> None:
        """Write the schema into a new file ``p`` (:func:`dbfiles.create_empty` publishes it)."""
        try:
            conn = sqlite3.connect(p, isolation_level=None)
            try:
                conn.execute("BEGIN IMMEDIATE")
                for stmt in _SCHEMA.strip().split(";"):
                    if stmt.strip():
                        conn.execute(stmt)
                now = _now()
                conn.executemany(
                    "INSERT INTO meta(key, value) VALUES (?, ?)",
                    [
                        ("application", APPLICATION),
                        ("schema_version", str(SCHEMA_VERSION)),
                        ("descriptor", "sift-128-uint8 (OpenCV)"),
                        ("created", now),
                        ("generation", "0"),
                    ],
                )
                conn.execute("COMMIT")
                conn.execute(f"PRAGMA application_id = {APPLICATION_ID}")
            finally:
                conn.close()
        except sqlite3.Error as exc:
            raise DatabaseError(p, f"cannot create the database: {exc}") from None

    @classmethod
    def open(
        cls,
        path: str | PathLike[str],
        *,
        create: bool = False,
        readonly: bool = False,
        index: IndexKind = "auto",
    ) -> ObjectDatabase:
        """Open a database file (or create it, if ``create`` and it does not exist).

        The file gets the same checks as on the command line (:mod:`~scenespeak.perception.
        dbfiles`): no FIFO, device or folder, a bounded wait for other writers, and every row
        validated ("database is damaged: view 3 of 'mug': …") before anything is used.

        Parameters
        ----------
        path : str or path-like
        create : bool
            Create the file when it is missing.
        readonly : bool
            Open read-only (writes raise :class:`DatabaseError`).
        index : {"auto", "exact", "ivf", "faiss"}
            Nearest-neighbour index built on the first :meth:`label` (see :func:`build_index`).

        Raises
        ------
        DatabaseError
            Missing file, a folder, an empty file, a file that is not SQLite, an SQLite file
            that is not ours, another schema version, a damaged row or a corrupt file.
        """
        p = as_path(path, error=DatabaseError)
        if not dbfiles.check_file(p, must_exist=not create or readonly):
            dbfiles.create_empty(p)  # False: another process created it first; open that
        _check_magic(p)
        dbfiles.validate(p)
        return cls._connect(p, readonly=readonly, index=index)

    @classmethod
    def _connect(cls, p: Path, *, readonly: bool, index: IndexKind) -> ObjectDatabase:
        """Connect to an existing regular file and check that it is ours (this schema)."""
        _check_magic(p)
        conn = dbfiles.connect(p, readonly=readonly)
        try:
            _check_schema(p, conn)
            if not readonly:
                migrate(conn)
        except sqlite3.Error as exc:
            conn.close()
            raise DatabaseError(p, f"cannot upgrade the schema: {exc}") from None
        except BaseException:
            conn.close()
            raise
        return cls(p, conn, readonly=readonly, index_kind=index)

    def close(self) -> None:
        """Close the file (idempotent)."""
        if self._conn is not None:
            self._conn.close()
            self._conn = None
        self._loaded = None

    def __enter__(self) -> ObjectDatabase:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"ObjectDatabase({str(self.path)!r})"

    @property
    def conn(self) -> sqlite3.Connection:
        if self._conn is None:
            raise DatabaseError(self.path, "the database is closed")
        return self._conn

    def _query(self, sql: str, args: Sequence[Any] = ()) -> list[tuple[Any, ...]]:
        try:
            return self.conn.execute(sql, args).fetchall()
        except sqlite3.DatabaseError as exc:
            raise DatabaseError(self.path, f"cannot be read (corrupt?): {exc}") from None

    # -- reading -------------------------------------------------------------------------

    def labels(self) -> list[str]:
        """Labels of all objects, sorted."""
        return [r[0] for r in self._query("SELECT label FROM objects ORDER BY label")]

    def __len__(self) -> int:
        return int(self._query("SELECT COUNT(*) FROM objects")[0][0])

    def __contains__(self, label: object) -> bool:
        return bool(self._query("SELECT 1 FROM objects WHERE label = ?", (label,)))

    def list_objects(self) -> list[ObjectInfo]:
        """Every object with its number of views and descriptors and when it was added."""
        rows = self._query(
            "SELECT o.id, o.label, COUNT(v.id), COALESCE(SUM(v.n), 0), o.added "
            "FROM objects o LEFT JOIN views v ON v.object_id = o.id "
            "GROUP BY o.id ORDER BY o.label"
        )
        return [ObjectInfo(int(a), str(b), int(c), int(d), str(e)) for a, b, c, d, e in rows]

    info = list_objects

    def views(self, label: str | None = None) -> list[TrainingView]:
        """Training views (image size and outline, no descriptors), of one object or all."""
        sql = (
            "SELECT v.id, o.label, v.source, v.width, v.height, v.outline, v.has_mask, v.n "
            "FROM views v JOIN objects o ON o.id = v.object_id"
        )
        args: tuple[Any, ...] = ()
        if label is not None:
            sql += " WHERE o.label = ?"
            args = (label,)
        rows = self._query(sql + " ORDER BY v.id", args)
        return [
            TrainingView(
                int(i),
                str(lab),
                str(src),
                int(w),
                int(h),
                np.frombuffer(out, np.float32).reshape(-1, 2).copy(),
                bool(hm),
                int(n),
            )
            for i, lab, src, w, h, out, hm, n in rows
        ]

    def generation(self) -> int:
        """A counter bumped by every write (for caches)."""
        return int(self._query("SELECT value FROM meta WHERE key = 'generation'")[0][0])

    # -- writing -------------------------------------------------------------------------

    def add_object(
        self,
        label: str,
        images: Sequence[ImageLike],
        masks: Sequence[MaskLike] | None = None,
        *,
        replace: bool = False,
        max_features: int = 0,
        contrast_threshold: float = 0.02,
        progress: Progress | None = None,
        raise_cylinders: bool = True,
    ) -> ObjectInfo:
        """Learn an object from training images and store it, in one transaction.

        Parameters
        ----------
        label : str
            The object's name (non-empty; unique in the database).
        images : sequence of path or array
            Training images (files OpenCV reads, or gray/RGB/RGBA arrays).
        masks : sequence of (path, array or None), optional
            One per image: non-zero where the object is. Keypoints are taken only inside it,
            and its largest contour becomes the view's outline. Without a mask the whole image
            is the object.
        replace : bool
            Replace an object with the same label instead of failing.
        max_features : int
            Keep at most this many of the strongest keypoints per image (0: all).
        contrast_threshold : float
            SIFT's contrast threshold for the training images (see
            :func:`scenespeak.perception.features.detect`). 0.02, half OpenCV's default: a
            photo of a small object holds few keypoints, and a far view of it in a scene
            matches only what the training view kept (on the tuning set, with the finer
            search, 37 instead of 33 of 57 objects found; about 40 % more descriptors).
        progress : callable, optional
            Called as ``progress(stage, done, total)`` with stage ``"extract"`` (per image,
            before anything is written) and ``"store"`` (per view written).
        raise_cylinders : bool
            True — a cylinder also gets views from 18° and 32° higher (``docs/database.md``).

        Returns
        -------
        ObjectInfo

        Raises
        ------
        DatabaseError
            Duplicate label without ``replace``, an empty label, a read-only database.
        ImageError
            An image (or mask) that cannot be read, or has no keypoints; the database is left
            as it was.
        """
        try:  # the command line's rules: printable text, no escapes, not empty, bounded
            label = check_label(label, "label").strip()
        except InputError as exc:
            raise DatabaseError(self.path, f"label: {exc.problem}") from None
        self._check_writable()
        images = list(images)
        if not images:
            raise DatabaseError(self.path, f"no training images given for {label!r}")
        mask_list = self._one_mask_per_image(label, images, masks)
        if not replace and label in self:
            raise DatabaseError(self.path, _duplicate(label))
        done = None if progress is None else functools.partial(progress, "extract")
        sift = (max_features, contrast_threshold)
        views = extract_views(images, mask_list, sift, done, raise_cylinders=raise_cylinders)
        with self._transaction() as conn:
            self._delete(conn, label, missing_ok=replace)
            now = _now()
            cur = conn.execute("INSERT INTO objects(label, added) VALUES (?, ?)", (label, now))
            oid = int(cur.lastrowid or 0)
            ids = []
            for i, v in enumerate(views):
                ids.append(insert_view(conn, oid, v))
                if progress is not None:
                    progress("store", i + 1, len(views))
            record_raised(conn, views, ids)
        self._loaded = None
        return ObjectInfo(oid, label, len(views), sum(len(v.features) for v in views), now)

    def remove(self, label: str) -> None:
        """Remove an object and its views (one transaction).

        Raises
        ------
        DatabaseError
            If there is no object with that label.
        """
        self._check_writable()
        with self._transaction() as conn:
            if not self._delete(conn, label, missing_ok=True):
                known = ", ".join(self.labels()) or "none"
                raise DatabaseError(
                    self.path, f"has no object labelled {label!r} (labels: {known})"
                )
        self._loaded = None

    def _one_mask_per_image(
        self, label: str, images: Sequence[ImageLike], masks: Sequence[MaskLike] | None
    ) -> list[MaskLike]:
        mask_list: list[MaskLike] = [None] * len(images) if masks is None else list(masks)
        if len(mask_list) != len(images):
            raise DatabaseError(
                self.path,
                f"{len(mask_list)} masks for {len(images)} images of {label!r}; "
                "give one mask per image (or none)",
            )
        return mask_list

    @contextlib.contextmanager
    def _transaction(self) -> Iterator[sqlite3.Connection]:
        """One write: BEGIN IMMEDIATE, the block, the generation bumped, COMMIT — or ROLLBACK
        on any exception (Ctrl-C included), leaving the file as it was."""
        conn = self.conn
        try:
            conn.execute("BEGIN IMMEDIATE")
            try:
                yield conn
                self._bump_generation()
                conn.execute("COMMIT")
            except BaseException:
                conn.execute("ROLLBACK")
                raise
        except sqlite3.Error as exc:
            raise DatabaseError(self.path, f"cannot write: {exc}") from None

    def _delete(self, conn: sqlite3.Connection, label: str, *, missing_ok: bool) -> bool:
        """Delete the object ``label`` and its views; False if there was none. With
        ``missing_ok`` False an existing object is an error (a duplicate label)."""
        old = conn.execute("SELECT id FROM objects WHERE label = ?", (label,)).fetchall()
        if old and not missing_ok:
            raise DatabaseError(self.path, _duplicate(label))
        for (oid,) in old:
            forget_raised(conn, oid)
            conn.execute(
                "DELETE FROM view_colours WHERE view_id IN "
                "(SELECT id FROM views WHERE object_id = ?)",
                (oid,),
            )
            conn.execute("DELETE FROM views WHERE object_id = ?", (oid,))
            conn.execute("DELETE FROM objects WHERE id = ?", (oid,))
        return bool(old)

    def _check_writable(self) -> None:
        if self.readonly:
            raise DatabaseError(self.path, "was opened read-only")

    def _bump_generation(self) -> None:
        self.conn.execute(
            "UPDATE meta SET value = CAST(CAST(value AS INTEGER) + 1 AS TEXT) "
            "WHERE key = 'generation'"
        )

    # -- index and labelling -------------------------------------------------------------

    def load(self, *, nprobe: int = 4, seed: int = 0) -> None:
        """Load every descriptor and build the nearest-neighbour index (done lazily).

        The inverted file's trained quantiser and cell assignment are cached in the file's
        ``index_cache`` table (written when the database is writable), so that only the first
        load after a change trains it.

        Parameters
        ----------
        nprobe : int
            Inverted-file cells visited per query descriptor.
        seed : int
            Seed of the quantiser's training.

        Raises
        ------
        DatabaseError
            If the database has no objects, or a view is corrupt.
        """
        gen = self.generation()
        if self._loaded is not None and self._loaded.generation == gen:
            self._set_nprobe(nprobe)
            return
        self._loaded = None
        counts = self._query("SELECT COUNT(*), COALESCE(SUM(n), 0) FROM views")[0]
        if int(counts[0]) == 0:
            raise DatabaseError(
                self.path,
                "has no objects to match against; add some with "
                "`scenespeak db add --db FILE --label NAME IMAGE`",
            )
        total = int(counts[1])
        kp, object_of, view_of, sizes, labels, outlines = read_views(self, total)
        index = index_of(self, gen, total, sizes, nprobe, seed)
        syn, view_of = synthetic_of(self, view_of)
        self._loaded = _Loaded(
            gen, index, object_of, view_of, kp[:, :2], kp[:, 2], kp[:, 3], labels, outlines, syn
        )

    def _set_nprobe(self, nprobe: int) -> None:
        if self._loaded is not None and hasattr(self._loaded.index, "nprobe"):
            self._loaded.index.nprobe = nprobe

    def colour_models(self) -> dict[str, ColourModel]:
        """Each object's colour signatures and chromatic-box aspects, by label
        (:mod:`~scenespeak.perception.recognition.colour`); objects learnt without masks, from
        gray images or into a version-1 file opened read-only have none.

        Examples
        --------
        >>> import pathlib, tempfile
        >>> from skimage import data
        >>> mask = np.zeros((512, 512), bool); mask[50:400, 100:300] = True
        >>> path = pathlib.Path(tempfile.mkdtemp()) / "objects.db"
        >>> with ObjectDatabase.create(path) as db:
        ...     _ = db.add_object("astronaut", [data.astronaut()], masks=[mask])
        ...     _ = db.add_object("cat", [data.chelsea()])  # no mask: no colour
        ...     {k: m.signatures.shape for k, m in db.colour_models().items()}
        {'astronaut': (1, 28)}
        """
        gen = self.generation()
        if self._colours is None or self._colours[0] != gen:
            self._colours = (gen, read_colour_models(self))
        return dict(self._colours[1])

    @property
    def index(self) -> DescriptorIndex:
        """The nearest-neighbour index (built on first use)."""
        self.load()
        assert self._loaded is not None
        return self._loaded.index

    def label(
        self,
        features: Features,
        options: LabelOptions | None = None,
        *,
        image: NDArray[np.generic] | None = None,
        executor: Executor | None = None,
        **overrides: float,
    ) -> Labelling:
        """Label query keypoints (of the scene's left image) with the database's objects.

        Parameters
        ----------
        features : Features
            SIFT features of the scene image (``scenespeak.perception.features.detect``).
        options : LabelOptions, optional
            The knobs (ratio test, RANSAC, small objects; defaults documented there).
        image : ndarray, optional
            The image ``features`` come from: with it, a finer search (enlarged boxes round
            the matches that explain no detection, ``LabelOptions.finer_*``) also finds
            small and far objects (:func:`~scenespeak.perception.recognition.finer.finer_search`).
        executor : Executor, optional
            With ``image``: a thread to share the finer search's boxes with (same result).
        **overrides
            Single fields of :class:`LabelOptions` (``min_inliers=5``, ``small_area=0``, ...).

        Returns
        -------
        Labelling

        Raises
        ------
        DatabaseError
            If the database is empty.
        InputError
            For a keyword that is not a field of :class:`LabelOptions`.
        """
        opts = LabelOptions.with_overrides(options, overrides)
        self.load(nprobe=opts.nprobe)
        assert self._loaded is not None
        labelling = label_features(self._loaded, features, opts)
        if image is None:
            return labelling
        return self.look_closer(features, labelling, image, opts, executor=executor)

    def look_closer(
        self,
        features: Features,
        labelling: Labelling,
        image: NDArray[np.generic],
        options: LabelOptions | None = None,
        *,
        executor: Executor | None = None,
    ) -> Labelling:
        """:meth:`label`'s finer search alone, on ``labelling = label(features, options)``:
        ``label(features, options, image=image)`` in two steps, so that work needing only the
        first labelling can start in between (the pipeline's). Returns ``labelling`` itself
        (the same object) when the finer search adds nothing."""
        opts = options if options is not None else LabelOptions()
        self.load(nprobe=opts.nprobe)
        assert self._loaded is not None
        from scenespeak.perception.recognition.finer import finer_search

        return finer_search(self._loaded, image, features, labelling, opts, executor)

    def labeller(self, options: LabelOptions | None = None) -> Callable[[Features], Labelling]:
        """``label(features, options)`` as a function of the features alone, loaded now: it
        reads no SQLite, so another thread may call it (the closer look, ``recognition.closer``)."""
        opts = options if options is not None else LabelOptions()
        self.load(nprobe=opts.nprobe)
        assert self._loaded is not None
        return functools.partial(label_features, self._loaded, o=opts)
