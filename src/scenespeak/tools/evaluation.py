"""The seed paper's experiment as a function: describe every labelled scene, score it.

The paper took 100 stereo pairs of a hat, a mug and a can; 76 "resulted in having suitable
convex hulls for linguistic description" and their descriptions were judged right.
:func:`evaluate` runs the whole chain over a folder of labelled scenes (the scene generator's
format, ``docs/scenes.md``; ``docs/evaluation.md`` says how to label your own) and measures:

- **scenes usable** — like the paper: every object of the scene got a hull and every ordered
  pair of them a description;
- **objects found** — objects of the ground truth that got a hull;
- **primary-direction accuracy** — the predicted primary direction (left / right / front /
  behind) equals the true one, over the pairs that were described; pairs the ground truth marks
  as *ambiguous* (near a diagonal) are counted apart;
- **centroid error** — distance between the described and the true centroid, metres;
- **time per scene** — wall-clock seconds of the chain per scene (load, match, describe);
- **known objects reported where they are not** — and where they were put
  (:mod:`scenespeak.tools.evaluation_split`); with ``learn=LearnSplit(...)`` the database learns
  only part of the objects and the others are distractors (leave-part-out).

The scoring is pure (:func:`score_scene`, :func:`summarize`), so it can be checked by hand:

>>> truth = SceneTruth(
...     "s",
...     (TruthObject("hat", (0.0, 0.0, 1.0)), TruthObject("mug", (0.3, 0.0, 1.0))),
...     (TruthRelation("hat", "mug", "left"), TruthRelation("mug", "hat", "right")),
... )
>>> pred = PredictedScene(
...     "s",
...     {"hat": (0.0, 0.0, 1.1), "mug": (0.3, 0.0, 1.0)},
...     {("hat", "mug"): "left", ("mug", "hat"): "behind"},
...     seconds=2.0,
... )
>>> s = score_scene(pred, truth)
>>> s.usable, s.n_found, s.clear_correct, s.clear_total
(True, 2, 1, 2)
"""

from __future__ import annotations

import functools
import tempfile
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import replace
from os import PathLike
from pathlib import Path
from typing import Any

from scenespeak.errors import InputError, ScenespeakError
from scenespeak.tools.evaluation_match import (
    MATCH_GATE_M,
    match_objects,
)
from scenespeak.tools.evaluation_scores import (
    EvaluationResult,
    SceneScore,
    score_scene,
    summarize,
)
from scenespeak.tools.evaluation_split import LearnSplit, choose_learnt, with_unlearnt
from scenespeak.tools.evaluation_tables import BANDS, PAPER, format_table
from scenespeak.tools.evaluation_truth import (
    PredictedScene,
    SceneTruth,
    TruthObject,
    TruthRelation,
    load_scene_truth,
    predicted_from_description,
)

__all__ = [
    "BANDS",
    "MATCH_GATE_M",
    "PAPER",
    "EvaluationResult",
    "LearnSplit",
    "PredictedScene",
    "SceneScore",
    "SceneTruth",
    "TruthObject",
    "TruthRelation",
    "choose_learnt",
    "evaluate",
    "find_scenes",
    "format_table",
    "load_scene_truth",
    "match_objects",
    "predicted_from_description",
    "score_scene",
    "summarize",
]


# --------------------------------------------------------------------------------------------
# Running the chain over a dataset


def find_scenes(dataset_dir: str | PathLike[str]) -> list[Path]:
    """The scene folders of a dataset, in order.

    ``dataset.json``'s ``scenes`` list when present, otherwise every sub-folder holding
    ``left.png``, ``right.png``, ``calib.json`` and ``truth.json``; a folder that is itself a
    scene is a dataset of one.

    Raises
    ------
    InputError
        If the folder does not exist, or holds no scene.
    """
    root = Path(dataset_dir)
    if not root.is_dir():
        raise InputError(root, "not a folder; give a dataset made by `scenespeak scenes generate`")
    index = root / "dataset.json"
    if index.is_file():
        return _indexed_scenes(root, index)

    def is_scene(p: Path) -> bool:
        return all((p / f).is_file() for f in ("left.png", "right.png", "calib.json", "truth.json"))

    if is_scene(root):
        return [root]
    scenes = sorted(p for p in root.iterdir() if p.is_dir() and is_scene(p))
    if not scenes:
        raise InputError(
            root, "holds no scene (folders with left.png, right.png, calib.json, truth.json)"
        )
    return scenes


def _indexed_scenes(root: Path, index: Path) -> list[Path]:
    """The scenes ``dataset.json`` lists, each a folder inside the dataset (never outside)."""
    from scenespeak import limits
    from scenespeak.safeio import clean_text, load_json, read_text, within

    data = load_json(read_text(index, what="dataset.json file"), index)
    names = data.get("scenes") if isinstance(data, Mapping) else None
    if not isinstance(names, list):
        raise InputError(index, 'expected {"scenes": ["scene_000", ...], ...}')
    if len(names) > limits.current().max_scenes:
        raise InputError(index, limits.exceeded("max_scenes", f"{len(names)} scenes", 0))
    scenes = []
    for n in names:
        if not isinstance(n, str):
            raise InputError(
                index, f"a scene entry must be a folder name, got {clean_text(repr(n))[:60]}"
            )
        scenes.append(within(root, n, index))
    missing = [clean_text(s.name) for s in scenes if not s.is_dir()]
    if missing:
        raise InputError(index, f"lists scenes that are not there: {', '.join(missing[:5])}")
    return scenes


def evaluate_scene(scene_dir: str, db_path: str, learnt: Sequence[str] | None = None) -> SceneScore:
    """Describe one scene folder and score it (pure apart from reading files; picklable).

    A scene the chain cannot use (a :class:`~scenespeak.errors.ScenespeakError`) is scored as
    not usable with the error kept; a broken ``truth.json`` raises. ``learnt``: the labels the
    database learnt when it learnt only part of them (the others are scored as distractors).
    """
    from scenespeak.perception.database import ObjectDatabase

    with ObjectDatabase.open(db_path, readonly=True) as db:
        return _evaluate_one(scene_dir, db, learnt=learnt)


def _evaluate_one(
    scene_dir: str,
    db: Any,
    options: dict[str, Any] | None = None,
    learnt: Sequence[str] | None = None,
) -> SceneScore:
    from scenespeak.scene_folder import describe_scene_folder

    scene = Path(scene_dir)
    truth = load_scene_truth(scene)
    if learnt is not None:
        truth = with_unlearnt(truth, learnt)
    start = time.perf_counter()
    try:
        desc = describe_scene_folder(scene, db, **(options or {}))
        pred = predicted_from_description(desc, scene.name, time.perf_counter() - start)
    except ScenespeakError as exc:
        pred = PredictedScene(scene.name, {}, {}, time.perf_counter() - start, str(exc))
    return score_scene(pred, truth)


def evaluate_batch(
    scene_dirs: Sequence[str], database: Any, learnt: Sequence[str] | None = None
) -> list[SceneScore]:
    """Score a batch of scene folders: the task the engine (:mod:`scenespeak.tools.engine`)
    runs on its workers, with the database its worker opened once (``database.get()``);
    ``learnt`` as in :func:`evaluate_scene`."""
    db = database.get()
    options = database.scene_options() if hasattr(database, "scene_options") else {}
    return [_evaluate_one(scene, db, options, learnt) for scene in scene_dirs]


def evaluate(
    dataset_dir: str | PathLike[str],
    *,
    db: str | PathLike[str] | Any | None = None,
    workers: int = 2,
    progress: Callable[[int, int], Any] | None = None,
    scheduler: str | None = None,
    learn: LearnSplit | None = None,
) -> EvaluationResult:
    """Run the whole chain over a folder of labelled scenes and score it: the paper's experiment.

    Parameters
    ----------
    dataset_dir : path
        A dataset folder (``dataset.json``, ``objects/``, ``scene_NNN/``; see
        ``docs/evaluation.md``), or one scene folder (then give ``db``).
    db : path or ObjectDatabase, optional
        The object database to label with. By default one is learnt from the dataset's
        ``objects/<label>/view_NN.png`` training views into a temporary file.
    workers : int
        Worker processes of a local Dask cluster (:mod:`scenespeak.tools.engine`, one
        OpenCV/BLAS thread each); 1 runs in this process.
    progress : callable, optional
        Called as ``progress(done, total)`` as scenes finish.
    scheduler : str, optional
        Run on an existing Dask cluster (``tcp://HOST:PORT``) instead; ``workers`` is ignored.
    learn : LearnSplit, optional
        Learn only part of the dataset's objects (leave-part-out): the others become
        distractors in every scene, so every known object named away from a true instance of
        its label is false. The result's ``extra`` (and ``--json``) then names the ``learnt``
        and ``unlearnt`` labels and the ``split``. Needs the dataset's training views (not
        ``db``).

    Returns
    -------
    EvaluationResult

    Raises
    ------
    InputError
        No such folder, no scene in it, no training views and no ``db``, a broken truth file,
        ``learn`` with ``db`` or naming labels the dataset does not have.
    """
    from scenespeak.tools.engine import EngineOptions

    if workers < 1:
        raise InputError("workers", f"must be at least 1, got {workers}")
    engine = EngineOptions(workers=workers, scheduler=scheduler)
    root = Path(dataset_dir)
    scenes = find_scenes(root)
    split = learn if learn is not None and learn.active else None
    if split is not None and db is not None:
        raise InputError("--learn", "learns from the dataset's training views; drop --db")
    learnt: tuple[str, ...] | None = None
    start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="scenespeak-eval-") as tmp:
        if db is None:
            from scenespeak.pipeline import database_from_dataset, dataset_labels

            db_path = Path(tmp) / "objects.db"
            available = dataset_labels(root)
            learnt = split.labels(available) if split is not None else None
            if not database_from_dataset(root, db_path, labels=learnt):
                raise InputError(root / "objects", "holds no training views to learn from")
        elif isinstance(db, str | PathLike):
            db_path = Path(db)
            if not db_path.is_file():
                raise InputError(db_path, "no such object database")
        else:
            db_path = Path(db.path)
        scores = _run(scenes, db_path, engine, progress, learnt)
    result = summarize(
        scores, dataset=str(root), workers=workers, wall_seconds=time.perf_counter() - start
    )
    if split is None or learnt is None:
        return result
    extra = {
        "learnt": list(learnt),
        "unlearnt": [x for x in available if x not in learnt],
        "split": split.to_dict(),
    }
    return replace(result, extra=extra)


def _run(
    scenes: Sequence[Path],
    db_path: Path,
    engine: Any,
    progress: Callable[[int, int], Any] | None,
    learnt: Sequence[str] | None = None,
) -> list[SceneScore]:
    from scenespeak.tools.engine import run_batches

    total = len(scenes)
    scores: list[SceneScore] = []

    def take(batch: list[SceneScore]) -> None:
        scores.extend(batch)
        if progress is not None:
            progress(len(scores), total)

    task = evaluate_batch if learnt is None else functools.partial(evaluate_batch, learnt=learnt)
    run_batches(task, [str(s) for s in scenes], engine, on_results=take, database=db_path)
    return scores
