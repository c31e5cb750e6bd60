"""Spatial-relation labels for a whole dataset: ``scenespeak annotate`` as a function.

:func:`annotate` describes every scene folder of a dataset (stereo or RGB-D,
:func:`scenespeak.scene_folder.describe_scene_folder`) on the Dask engine
(:mod:`scenespeak.tools.engine`) and writes one JSON line per ordered pair of objects
(``interfaces.md``, "Labels at dataset scale")::

    {"scene": "scene_000", "argument": "mug", "referent": "can", "primary": "left",
     "secondary": "behind", "sentence": "The mug is to the left of the can but slightly behind.",
     "degrees": {"left": 0.81, "right": 0.0, "front": 0.0, "behind": 0.19},
     "confidence": 0.77, "ambiguous": false}

``degrees`` are the degrees of truth of the four directions (the mean of F0's and F2's,
:mod:`scenespeak.spatial.degrees`), ``confidence`` the rule base's self-assessment and
``ambiguous`` (:func:`is_ambiguous`) says that no single direction is a fair label. Output,
scene log and resuming: :mod:`scenespeak.tools.output`. Running on a cluster:
``docs/annotate.md``.
"""

from __future__ import annotations

import json
import math
import tempfile
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from os import PathLike
from pathlib import Path
from typing import Any

from scenespeak.errors import InputError, ScenespeakError
from scenespeak.overrides import replace_fields
from scenespeak.tools.engine import DatabaseHandle, EngineOptions, run_batches
from scenespeak.tools.output import ResumableJsonl, SceneRecord, log_path, write_parquet

__all__ = [
    "AMBIGUOUS_DIAGONAL_DEG",
    "AnnotateOptions",
    "AnnotateSummary",
    "annotate",
    "annotate_batch",
    "is_ambiguous",
    "pair_record",
]

#: A label is ambiguous when the relation lies within this many degrees of a diagonal — the
#: same tolerance as the scene generator's ground truth (``scenes.DIAGONAL_TOLERANCE_DEG``).
AMBIGUOUS_DIAGONAL_DEG = 20.0

# Under the degree model of a single force direction δ off an axis (the primary gets 1 − δ/90,
# its neighbour δ/90; ``spatial.language.Thresholds``), "within 20° of the diagonal" is
# δ > 25°, i.e. a gap between the two best degrees below 1 − 2·25/90 = 4/9.
_AMBIGUOUS_GAP = 1.0 - 2.0 * (45.0 - AMBIGUOUS_DIAGONAL_DEG) / 90.0

_FOUR = ("left", "right", "front", "behind")
_ENCLOSING = ("surrounded", "partly surrounded", "surrounds", "partly surrounds")


def is_ambiguous(relation: Any) -> bool:
    """True when no single direction is a fair label for the pair.

    That is when the rule base said "front-left"-like (a compound), or that one object
    (partly) surrounds the other, or when the two best degrees of truth differ by less than
    4/9 — where a single force direction would lie within ``AMBIGUOUS_DIAGONAL_DEG`` of a
    diagonal. The same count as the generator's truth (diagonal ±20°, overlapping footprints),
    decided from the histograms instead of the true footprints.

    Parameters
    ----------
    relation : Relation
        A :class:`scenespeak.spatial.language.Relation` (``kind``, ``degrees``).

    Examples
    --------
    >>> import numpy as np
    >>> from scenespeak.language import describe_relation
    >>> h = np.zeros(180); h[90] = 1.0                 # straight to the left
    >>> is_ambiguous(describe_relation(h, h))
    False
    >>> h = np.zeros(180); h[70] = 1.0                 # 140°: 5° from the behind-left diagonal
    >>> is_ambiguous(describe_relation(h, h))
    True
    """
    if relation.kind == "compound" or relation.kind in _ENCLOSING:
        return True
    values = sorted((float(relation.degrees.get(d, 0.0)) for d in _FOUR), reverse=True)
    return values[0] - values[1] < _AMBIGUOUS_GAP


def _num(value: float) -> float:
    return round(float(value), 6) if math.isfinite(value) else 0.0


def pair_record(scene: str, relation: Any) -> dict[str, Any]:
    """The JSON line of one ordered pair (exactly the fields of ``interfaces.md``).

    ``relation`` is a :class:`~scenespeak.pipeline.PairRelation` or a ``Relation``.
    """
    rel = getattr(relation, "relation", relation)
    return {
        "scene": scene,
        "argument": rel.argument,
        "referent": rel.referent,
        "primary": rel.primary,
        "secondary": rel.secondary,
        "sentence": rel.sentence,
        "degrees": {d: _num(rel.degrees.get(d, 0.0)) for d in _FOUR},
        "confidence": _num(rel.confidence),
        "ambiguous": bool(is_ambiguous(rel)),
    }


def _one_line(exc: BaseException) -> str:
    text = str(exc) if isinstance(exc, ScenespeakError) else f"{type(exc).__name__}: {exc}"
    return " ".join(text.split()) or type(exc).__name__


def annotate_batch(folders: Sequence[str], database: DatabaseHandle) -> list[SceneRecord]:
    """Describe a batch of scene folders (the engine's task; runs on the workers).

    A scene that fails — bad files, no texture, or any other exception — becomes a record with
    its ``error`` and the batch goes on.
    """
    from scenespeak.scene_folder import describe_scene_folder

    records = []
    db = database.get()
    for folder in folders:
        name = Path(folder).name
        start = time.perf_counter()
        try:
            desc = describe_scene_folder(folder, db, summary=False, **database.scene_options())
            lines = tuple(
                json.dumps(pair_record(name, rel), ensure_ascii=False) for rel in desc.relations
            )
            records.append(
                SceneRecord(
                    name,
                    lines,
                    objects=len(desc.objects),
                    skipped=len(desc.skipped),
                    seconds=time.perf_counter() - start,
                )
            )
        except Exception as exc:  # recorded, never fatal: a long run meets broken scenes
            records.append(
                SceneRecord(name, seconds=time.perf_counter() - start, error=_one_line(exc))
            )
    return records


@dataclass(frozen=True)
class AnnotateOptions:
    """How :func:`annotate` treats an earlier run and what else it writes.

    Attributes
    ----------
    resume : bool
        Continue a previous run into the same ``out``: finished scenes are skipped.
    retry_failed : bool
        With ``resume``, run the scenes that failed before again.
    parquet : path, optional
        Also write the pairs (all of ``out``) as Parquet, same columns, at the end.
    """

    resume: bool = False
    retry_failed: bool = False
    parquet: str | PathLike[str] | None = None

    @classmethod
    def with_overrides(
        cls, options: AnnotateOptions | None, overrides: Mapping[str, object]
    ) -> AnnotateOptions:
        """``options`` (or the defaults) with single fields replaced (unknown names refused)."""
        return replace_fields(
            options if options is not None else cls(),
            overrides,
            lambda bad, _names: TypeError(f"annotate() got unexpected keyword argument(s) {bad}"),
        )


@dataclass(frozen=True)
class AnnotateSummary:
    """What a run did.

    Attributes
    ----------
    out, log : Path
        The pair lines and the scene log.
    scenes : int
        Scene folders in the dataset.
    skipped : int
        Scenes already finished by an earlier run (``resume``), not run again.
    described, failed : int
        Scenes of this run described, and failed (the log has their errors).
    pairs : int
        Pair lines in the output (all runs).
    seconds : float
        Wall-clock time of this run.
    parquet : Path or None
        The Parquet copy, when asked for.
    """

    out: Path
    log: Path
    scenes: int
    skipped: int
    described: int
    failed: int
    pairs: int
    seconds: float
    parquet: Path | None = None

    def to_text(self) -> str:
        """One line for people (the CLI prints it on stderr)."""
        ran = self.described + self.failed
        rate = ran / self.seconds if self.seconds > 0 else 0.0
        text = (
            f"annotate: {ran} scenes in {self.seconds:.1f} s ({rate:.2f} scenes/s): "
            f"{self.described} described, {self.failed} failed"
        )
        if self.skipped:
            text += f", {self.skipped} already done"
        text += f"; {self.pairs} pairs in {self.out}"
        if self.failed:
            text += f" (errors in {self.log})"
        if self.parquet is not None:
            text += f"; Parquet: {self.parquet}"
        return text


def _database_file(dataset: Path, db: str | PathLike[str] | None, tmp: str) -> Path | None:
    """The database to ship: ``db`` (checked), or one learnt from the dataset's views."""
    from scenespeak.perception.database import ObjectDatabase

    if db is not None:
        path = Path(db)
        with ObjectDatabase.open(path, readonly=True) as opened:  # a bad file fails here, once
            if len(opened) == 0:
                raise InputError(path, "the database holds no objects")
        return path
    if not (dataset / "objects").is_dir():
        return None
    from scenespeak.pipeline import database_from_dataset

    path = Path(tmp) / "objects.db"
    return path if database_from_dataset(dataset, path) else None


def annotate(
    dataset: str | PathLike[str],
    out: str | PathLike[str],
    *,
    db: str | PathLike[str] | None = None,
    engine: EngineOptions | None = None,
    options: AnnotateOptions | None = None,
    progress: Callable[[int, int], Any] | None = None,
    task: Callable[[Sequence[str], DatabaseHandle], list[SceneRecord]] = annotate_batch,
    **overrides: object,
) -> AnnotateSummary:
    """Label every ordered pair of every scene of ``dataset`` into ``out`` (JSON Lines).

    Parameters
    ----------
    dataset : path
        A folder of scene folders (:func:`scenespeak.scene_folder.find_scene_folders`).
    out : path
        The JSON Lines file; its scene log is written beside it
        (:func:`scenespeak.tools.output.log_path`).
    db : path, optional
        Object database. Without it, one is learnt from the dataset's training views
        (``DATASET/objects/<label>/view_NN.png``, as ``evaluate`` does); stereo scenes need
        one of the two.
    engine : EngineOptions, optional
        Local cluster size or scheduler address, batch size (default: 2 local workers).
    options : AnnotateOptions, optional
        ``resume``, ``retry_failed``, ``parquet`` (also accepted as single keywords,
        ``resume=True``, ...).
    progress : callable, optional
        ``progress(done, total)`` after each batch, counting scenes of this run.
    task : callable
        What runs on the workers per batch of scene folders (default :func:`annotate_batch`;
        the benchmarks put a stand-in here to measure the engine alone).

    Returns
    -------
    AnnotateSummary

    Raises
    ------
    InputError
        No such dataset or no scene in it, stereo scenes and no database to use, a bad
        database, an existing ``out`` without ``resume``, a log that cannot be resumed from.
    """
    from scenespeak.safetext import check_output
    from scenespeak.scene_folder import check_supported, find_scene_folders, scene_layout

    run = AnnotateOptions.with_overrides(options, overrides)
    resume, retry_failed, parquet = run.resume, run.retry_failed, run.parquet
    root = Path(dataset)
    scenes = find_scene_folders(root)
    if not scenes:
        raise InputError(root, "has no scene folders to annotate (its dataset.json lists none)")
    if parquet is not None:  # before the work, not after it
        check_output(parquet, what="Parquet file")
    names = [s.name for s in scenes]
    if len(set(names)) != len(names):
        raise InputError(root, "two scene folders have the same name; the output could not tell")
    check_supported(scenes)
    if not resume:
        ResumableJsonl.refuse_existing(out)
    engine_options = engine or EngineOptions()
    start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="scenespeak-annotate-") as tmp:
        db_file = _database_file(root, db, tmp)
        if db_file is None and any(scene_layout(s) == "stereo" for s in scenes):
            raise InputError(
                root,
                "stereo scenes need an object database: give --db, or put training views "
                "in objects/<label>/view_NN.png",
            )
        with ResumableJsonl.open(out, resume=resume, retry_failed=retry_failed) as sink:
            todo = [str(s) for s in scenes if s.name not in sink.finished]
            counts = _Counts(len(todo), progress)

            def take(records: list[SceneRecord]) -> None:
                sink.write(records)
                counts.add(records)

            def failed(folders: Sequence[str], error: str) -> None:
                take(
                    [SceneRecord(Path(f).name, error=f"the task failed: {error}") for f in folders]
                )

            if progress is not None:
                progress(0, len(todo))
            if todo:  # nothing left (a finished run resumed): no cluster to start
                run_batches(
                    task, todo, engine_options, on_results=take, on_failure=failed, database=db_file
                )
            pairs = sink.pairs
    parquet_path = None
    if parquet is not None:
        parquet_path = Path(parquet)
        write_parquet(out, parquet_path)
    return AnnotateSummary(
        out=Path(out),
        log=log_path(out),
        scenes=len(scenes),
        skipped=len(scenes) - len(todo),
        described=counts.described,
        failed=counts.failed,
        pairs=pairs,
        seconds=time.perf_counter() - start,
        parquet=parquet_path,
    )


class _Counts:
    def __init__(self, total: int, progress: Callable[[int, int], Any] | None) -> None:
        self.total = total
        self.progress = progress
        self.described = 0
        self.failed = 0

    def add(self, records: Sequence[SceneRecord]) -> None:
        for r in records:
            if r.error is None:
                self.described += 1
            else:
                self.failed += 1
        if self.progress is not None:
            self.progress(self.described + self.failed, self.total)
