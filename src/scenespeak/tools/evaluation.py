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
- **time per scene** — wall-clock seconds of the chain per scene (load, match, describe).

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

import json
import math
import tempfile
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, field
from os import PathLike
from pathlib import Path
from typing import Any

import numpy as np

from scenespeak.errors import InputError, ScenespeakError

__all__ = [
    "PAPER",
    "EvaluationResult",
    "PredictedScene",
    "SceneScore",
    "SceneTruth",
    "TruthObject",
    "TruthRelation",
    "evaluate",
    "find_scenes",
    "format_table",
    "load_scene_truth",
    "predicted_from_description",
    "score_scene",
    "summarize",
]

#: The seed paper's own result (Luke, Blisard, Keller, Skubic, RO-MAN 2005, section V).
PAPER: Mapping[str, Any] = {
    "scenes": 100,
    "usable": 76,
    "note": "descriptions judged accurate by eye; no counts, errors or times reported",
}

DIRECTIONS = ("left", "right", "front", "behind")


# --------------------------------------------------------------------------------------------
# Ground truth and predictions


@dataclass(frozen=True)
class TruthObject:
    """One object of the ground truth: its label and the centre of its volume (metres)."""

    label: str
    centroid: tuple[float, float, float]


@dataclass(frozen=True)
class TruthRelation:
    """The true primary direction of ``argument`` relative to ``referent``.

    ``ambiguous`` marks pairs whose true direction lies near a diagonal, where either
    neighbouring direction is a fair answer; they are counted apart.
    """

    argument: str
    referent: str
    primary: str
    ambiguous: bool = False


@dataclass(frozen=True)
class SceneTruth:
    """Everything the evaluation needs from one ``truth.json``."""

    name: str
    objects: tuple[TruthObject, ...]
    relations: tuple[TruthRelation, ...]


@dataclass(frozen=True)
class PredictedScene:
    """What the chain said about one scene, reduced to what is scored.

    Attributes
    ----------
    name : str
        Scene name.
    objects : mapping
        ``label -> centroid (X, Y, Z)`` of every described object (one with a hull).
    relations : mapping
        ``(argument, referent) -> primary`` of every described ordered pair.
    seconds : float
        Wall-clock time the chain took on this scene.
    error : str or None
        Why the scene could not be processed at all (then nothing was described).
    """

    name: str
    objects: Mapping[str, tuple[float, float, float]]
    relations: Mapping[tuple[str, str], str]
    seconds: float = 0.0
    error: str | None = None


def _vec3(value: Any, where: str) -> tuple[float, float, float]:
    arr = np.asarray(value, dtype=np.float64).ravel()
    if arr.shape != (3,) or not np.isfinite(arr).all():
        raise InputError(where, f"expected three finite numbers [X, Y, Z], got {value!r:.60}")
    return (float(arr[0]), float(arr[1]), float(arr[2]))


def load_scene_truth(scene_dir: str | PathLike[str]) -> SceneTruth:
    """Read ``scene_dir/truth.json`` (format: ``docs/evaluation.md``).

    Raises
    ------
    InputError
        If the file is missing, not JSON, or lacks ``objects`` with ``label`` and ``centroid``.
    """
    path = Path(scene_dir) / "truth.json"
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError as exc:
        raise InputError(path, "missing: every labelled scene needs a truth.json") from exc
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise InputError(path, f"cannot be read as JSON ({exc})") from exc
    if not isinstance(data, Mapping) or not isinstance(data.get("objects"), list):
        raise InputError(path, 'expected {"objects": [...], "relations": [...]}')
    try:
        objects = tuple(
            TruthObject(str(o["label"]), _vec3(o["centroid"], f"{path}: {o['label']}"))
            for o in data["objects"]
        )
        relations = tuple(
            TruthRelation(
                str(r["argument"]),
                str(r["referent"]),
                str(r["primary"]),
                bool(r.get("ambiguous", False)),
            )
            for r in data.get("relations", [])
        )
    except (KeyError, TypeError) as exc:
        raise InputError(path, f"an object or relation lacks the field {exc}") from exc
    return SceneTruth(Path(scene_dir).name, objects, relations)


def predicted_from_description(description: Any, name: str, seconds: float = 0.0) -> PredictedScene:
    """Reduce a :class:`~scenespeak.pipeline.SceneDescription` (or its ``to_dict()``)."""
    d = description if isinstance(description, Mapping) else description.to_dict()
    objects = {str(o["label"]): _vec3(o["centroid"], str(o["label"])) for o in d["objects"]}
    relations = {
        (str(r["argument"]), str(r["referent"])): str(r["primary"]) for r in d["relations"]
    }
    return PredictedScene(name, objects, relations, seconds)


# --------------------------------------------------------------------------------------------
# Scoring (pure)


@dataclass(frozen=True)
class SceneScore:
    """The score of one scene.

    Attributes
    ----------
    name : str
        Scene name.
    usable : bool
        Every true object was described and every ordered pair of them got a relation.
    n_objects, n_found : int
        True objects, and those that were described (got a hull).
    n_extra : int
        Described objects that are not in the ground truth (false detections, unknown clusters).
    pairs_total, pairs_described : int
        Ordered pairs of true objects, and those that got a relation.
    clear_correct, clear_total : int
        Described pairs with an unambiguous true direction: right answers, all.
    ambiguous_correct, ambiguous_total : int
        The same for pairs the truth marks ambiguous.
    centroid_errors : tuple of float
        Distance (metres) between described and true centroid, per found object.
    seconds : float
        Time the chain took on the scene.
    error : str or None
        Why the scene failed outright.
    labels, missing : tuple of str
        The true objects' labels, and those that were not described.
    """

    name: str
    usable: bool
    n_objects: int
    n_found: int
    n_extra: int
    pairs_total: int
    pairs_described: int
    clear_correct: int
    clear_total: int
    ambiguous_correct: int
    ambiguous_total: int
    centroid_errors: tuple[float, ...]
    seconds: float
    error: str | None = None
    labels: tuple[str, ...] = ()
    missing: tuple[str, ...] = ()


def score_scene(pred: PredictedScene, truth: SceneTruth) -> SceneScore:
    """Score one scene's description against its ground truth.

    Parameters
    ----------
    pred : PredictedScene
        What the chain described.
    truth : SceneTruth
        The ground truth.

    Returns
    -------
    SceneScore
    """
    labels = [o.label for o in truth.objects]
    found = [o for o in truth.objects if o.label in pred.objects]
    errors = tuple(
        float(math.dist(pred.objects[o.label], o.centroid)) for o in found
    )  # metres, 3-D
    pairs = [(a, b) for a in labels for b in labels if a != b]
    described = [p for p in pairs if p in pred.relations]
    clear = [0, 0]
    ambiguous = [0, 0]
    for rel in truth.relations:
        key = (rel.argument, rel.referent)
        if key not in pred.relations:
            continue
        tally = ambiguous if rel.ambiguous else clear
        tally[1] += 1
        tally[0] += int(pred.relations[key] == rel.primary)
    usable = pred.error is None and len(found) == len(labels) and len(described) == len(pairs)
    return SceneScore(
        name=truth.name,
        usable=usable,
        n_objects=len(labels),
        n_found=len(found),
        n_extra=len(set(pred.objects) - set(labels)),
        pairs_total=len(pairs),
        pairs_described=len(described),
        clear_correct=clear[0],
        clear_total=clear[1],
        ambiguous_correct=ambiguous[0],
        ambiguous_total=ambiguous[1],
        centroid_errors=errors,
        seconds=float(pred.seconds),
        error=pred.error,
        labels=tuple(labels),
        missing=tuple(lab for lab in labels if lab not in pred.objects),
    )


def _ratio(num: int, den: int) -> float | None:
    return None if den == 0 else num / den


@dataclass(frozen=True)
class EvaluationResult:
    """The scores of every scene and the table's figures.

    Use :func:`format_table` for people and :meth:`to_dict` for machines.
    """

    scenes: tuple[SceneScore, ...]
    dataset: str = ""
    workers: int = 1
    wall_seconds: float = 0.0
    extra: Mapping[str, Any] = field(default_factory=dict)

    @property
    def n_scenes(self) -> int:
        return len(self.scenes)

    @property
    def n_usable(self) -> int:
        return sum(s.usable for s in self.scenes)

    @property
    def n_failed(self) -> int:
        return sum(s.error is not None for s in self.scenes)

    @property
    def objects_found(self) -> int:
        return sum(s.n_found for s in self.scenes)

    @property
    def objects_total(self) -> int:
        return sum(s.n_objects for s in self.scenes)

    @property
    def objects_extra(self) -> int:
        return sum(s.n_extra for s in self.scenes)

    @property
    def pairs_described(self) -> int:
        return sum(s.pairs_described for s in self.scenes)

    @property
    def pairs_total(self) -> int:
        return sum(s.pairs_total for s in self.scenes)

    @property
    def clear(self) -> tuple[int, int]:
        """(right, described) over unambiguous pairs."""
        return (
            sum(s.clear_correct for s in self.scenes),
            sum(s.clear_total for s in self.scenes),
        )

    @property
    def ambiguous(self) -> tuple[int, int]:
        """(right, described) over ambiguous pairs."""
        return (
            sum(s.ambiguous_correct for s in self.scenes),
            sum(s.ambiguous_total for s in self.scenes),
        )

    @property
    def usable_clear(self) -> tuple[int, int]:
        """(right, described) over unambiguous pairs of usable scenes only (the paper's view)."""
        use = [s for s in self.scenes if s.usable]
        return (sum(s.clear_correct for s in use), sum(s.clear_total for s in use))

    @property
    def centroid_errors(self) -> tuple[float, ...]:
        return tuple(e for s in self.scenes for e in s.centroid_errors)

    @property
    def seconds(self) -> tuple[float, ...]:
        """Per-scene times of the scenes that ran (failed ones included)."""
        return tuple(s.seconds for s in self.scenes)

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> EvaluationResult:
        """Rebuild a result from :meth:`to_dict`'s output (e.g. a saved ``--json`` file).

        Examples
        --------
        >>> r = summarize([], dataset="x", workers=2)
        >>> EvaluationResult.from_dict(r.to_dict()) == r
        True
        """
        try:
            scenes = [
                SceneScore(
                    **{
                        **s,
                        "centroid_errors": tuple(s["centroid_errors"]),
                        "labels": tuple(s.get("labels", ())),
                        "missing": tuple(s.get("missing", ())),
                    }
                )
                for s in data["per_scene"]
            ]
            return summarize(
                scenes,
                dataset=str(data.get("dataset", "")),
                workers=int(data.get("workers", 1)),
                wall_seconds=float(data.get("wall_seconds", 0.0)),
            )
        except (KeyError, TypeError) as exc:
            raise InputError(
                "evaluation JSON", f"not the output of `evaluate --json` ({exc})"
            ) from exc

    def to_dict(self) -> dict[str, Any]:
        """A JSON-ready summary plus every scene's score (``scenespeak evaluate --json``)."""
        errs = np.asarray(self.centroid_errors, dtype=np.float64)
        secs = np.asarray(self.seconds, dtype=np.float64)

        def stat(a: np.ndarray, f: Callable[[np.ndarray], Any]) -> float | None:
            return None if a.size == 0 else round(float(f(a)), 6)

        cc, ct = self.clear
        ac, at = self.ambiguous
        uc, ut = self.usable_clear
        return {
            "dataset": self.dataset,
            "workers": self.workers,
            "wall_seconds": round(self.wall_seconds, 3),
            "scenes": self.n_scenes,
            "usable": self.n_usable,
            "usable_fraction": _ratio(self.n_usable, self.n_scenes),
            "failed": self.n_failed,
            "objects_found": self.objects_found,
            "objects_total": self.objects_total,
            "objects_extra": self.objects_extra,
            "pairs_described": self.pairs_described,
            "pairs_total": self.pairs_total,
            "primary_correct": cc,
            "primary_described": ct,
            "primary_accuracy": _ratio(cc, ct),
            "ambiguous_correct": ac,
            "ambiguous_described": at,
            "ambiguous_accuracy": _ratio(ac, at),
            "usable_primary_accuracy": _ratio(uc, ut),
            "centroid_error_m": {
                "median": stat(errs, np.median),
                "mean": stat(errs, np.mean),
                "p90": stat(errs, lambda a: np.percentile(a, 90)),
            },
            "seconds_per_scene": {"median": stat(secs, np.median), "mean": stat(secs, np.mean)},
            "paper": dict(PAPER),
            "per_scene": [
                {
                    **asdict(s),
                    "centroid_errors": list(s.centroid_errors),
                    "labels": list(s.labels),
                    "missing": list(s.missing),
                }
                for s in self.scenes
            ],
            **dict(self.extra),
        }


def summarize(
    scores: Sequence[SceneScore], *, dataset: str = "", workers: int = 1, wall_seconds: float = 0.0
) -> EvaluationResult:
    """Gather scene scores (sorted by scene name) into an :class:`EvaluationResult`."""
    return EvaluationResult(
        tuple(sorted(scores, key=lambda s: s.name)),
        dataset=dataset,
        workers=workers,
        wall_seconds=wall_seconds,
    )


def _frac(num: int, den: int) -> str:
    return "–" if den == 0 else f"{num} / {den} ({100.0 * num / den:.0f} %)"


def format_table(result: EvaluationResult) -> str:
    """The paper's table, filled in, beside the paper's own result (Markdown).

    Examples
    --------
    >>> print(format_table(summarize([])).splitlines()[2])
    | measure | scenespeak | paper (Luke et al. 2005) |
    """
    d = result.to_dict()
    ce, sp = d["centroid_error_m"], d["seconds_per_scene"]
    cc, ct = result.clear
    ac, at = result.ambiguous
    uc, ut = result.usable_clear
    cent = "–" if ce["median"] is None else f"{100 * ce['median']:.1f} / {100 * ce['mean']:.1f} cm"
    secs = "–" if sp["median"] is None else f"{sp['median']:.2f} / {sp['mean']:.2f} s"
    rows = [
        ("scenes usable (every object a hull, every pair a sentence)",
         _frac(result.n_usable, result.n_scenes), _frac(PAPER["usable"], PAPER["scenes"])),
        ("objects found (with a hull)",
         _frac(result.objects_found, result.objects_total), "–"),
        ("other objects reported (not in the truth)", str(result.objects_extra), "–"),
        ("ordered pairs described",
         _frac(result.pairs_described, result.pairs_total), "–"),
        ("primary direction right, clear pairs", _frac(cc, ct), "\"accurate\" (not counted)"),
        ("primary direction right, clear pairs of usable scenes", _frac(uc, ut), "–"),
        ("primary direction right, ambiguous pairs", _frac(ac, at), "–"),
        ("centroid error, median / mean", cent, "–"),
        ("time per scene, median / mean", secs, "–"),
        ("scenes that failed outright", str(result.n_failed), "–"),
    ]  # fmt: skip
    head = (
        f"scenespeak evaluate {result.dataset or '(scenes)'}: {result.n_scenes} scenes, "
        f"{result.workers} worker(s), {result.wall_seconds:.1f} s wall clock"
    )
    lines = [head, "", "| measure | scenespeak | paper (Luke et al. 2005) |", "| --- | --- | --- |"]
    lines += [f"| {a} | {b} | {c} |" for a, b, c in rows]
    found: dict[str, list[int]] = {}
    for s in result.scenes:
        for lab in s.labels:
            found.setdefault(lab, [0, 0])[1] += 1
            found[lab][0] += lab not in s.missing
    if found:
        by_label = ", ".join(f"{lab} {f}/{n}" for lab, (f, n) in sorted(found.items()))
        lines += ["", f"Objects found by label: {by_label}."]
    failed = [s for s in result.scenes if s.error]
    if failed:
        lines += ["", "Failed scenes:"]
        lines += [f"- {s.name}: {s.error}" for s in failed[:10]]
        if len(failed) > 10:
            lines.append(f"- ... and {len(failed) - 10} more")
    return "\n".join(lines)


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
        try:
            names = json.loads(index.read_text(encoding="utf-8"))["scenes"]
        except (OSError, ValueError, KeyError, TypeError) as exc:
            raise InputError(index, f'cannot read its "scenes" list ({exc})') from exc
        scenes = [root / str(n) for n in names]
        missing = [s.name for s in scenes if not s.is_dir()]
        if missing:
            raise InputError(index, f"lists scenes that are not there: {', '.join(missing[:5])}")
        return scenes

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


def evaluate_scene(scene_dir: str, db_path: str) -> SceneScore:
    """Describe one scene folder and score it (pure apart from reading files; picklable).

    A scene the chain cannot use (a :class:`~scenespeak.errors.ScenespeakError`) is scored as
    not usable with the error kept; a broken ``truth.json`` raises.
    """
    from scenespeak.perception.database import ObjectDatabase

    with ObjectDatabase.open(db_path, readonly=True) as db:
        return _evaluate_one(scene_dir, db)


def _evaluate_one(scene_dir: str, db: Any) -> SceneScore:
    from scenespeak.scene_folder import describe_scene_folder

    scene = Path(scene_dir)
    truth = load_scene_truth(scene)
    start = time.perf_counter()
    try:
        desc = describe_scene_folder(scene, db)
        pred = predicted_from_description(desc, scene.name, time.perf_counter() - start)
    except ScenespeakError as exc:
        pred = PredictedScene(scene.name, {}, {}, time.perf_counter() - start, str(exc))
    return score_scene(pred, truth)


def evaluate_batch(scene_dirs: Sequence[str], database: Any) -> list[SceneScore]:
    """Score a batch of scene folders: the task the engine (:mod:`scenespeak.tools.engine`)
    runs on its workers, with the database its worker opened once (``database.get()``)."""
    db = database.get()
    return [_evaluate_one(scene, db) for scene in scene_dirs]


def evaluate(
    dataset_dir: str | PathLike[str],
    *,
    db: str | PathLike[str] | Any | None = None,
    workers: int = 2,
    progress: Callable[[int, int], Any] | None = None,
    scheduler: str | None = None,
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

    Returns
    -------
    EvaluationResult

    Raises
    ------
    InputError
        No such folder, no scene in it, no training views and no ``db``, a broken truth file.
    """
    from scenespeak.tools.engine import EngineOptions

    if workers < 1:
        raise InputError("workers", f"must be at least 1, got {workers}")
    engine = EngineOptions(workers=workers, scheduler=scheduler)
    root = Path(dataset_dir)
    scenes = find_scenes(root)
    start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="scenespeak-eval-") as tmp:
        if db is None:
            from scenespeak.pipeline import database_from_dataset

            db_path = Path(tmp) / "objects.db"
            if not database_from_dataset(root, db_path):
                raise InputError(root / "objects", "holds no training views to learn from")
        elif isinstance(db, str | PathLike):
            db_path = Path(db)
            if not db_path.is_file():
                raise InputError(db_path, "no such object database")
        else:
            db_path = Path(db.path)
        scores = _run(scenes, db_path, engine, progress)
    return summarize(
        scores, dataset=str(root), workers=workers, wall_seconds=time.perf_counter() - start
    )


def _run(
    scenes: Sequence[Path],
    db_path: Path,
    engine: Any,
    progress: Callable[[int, int], Any] | None,
) -> list[SceneScore]:
    from scenespeak.tools.engine import run_batches

    total = len(scenes)
    scores: list[SceneScore] = []

    def take(batch: list[SceneScore]) -> None:
        scores.extend(batch)
        if progress is not None:
            progress(len(scores), total)

    run_batches(evaluate_batch, [str(s) for s in scenes], engine, on_results=take, database=db_path)
    return scores
