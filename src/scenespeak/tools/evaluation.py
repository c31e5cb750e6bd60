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
from scenespeak.tools.evaluation_match import (
    MATCH_GATE_M,
    is_known,
    match_objects,
    object_detail,
    tally_relations,
    translate_relations,
    unmatched,
)
from scenespeak.tools.evaluation_tables import BANDS, breakdown, breakdown_table, found_by_label
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
    "PredictedScene",
    "SceneScore",
    "SceneTruth",
    "TruthObject",
    "TruthRelation",
    "evaluate",
    "find_scenes",
    "format_table",
    "load_scene_truth",
    "match_objects",
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
    false_known : int
        Described objects with a known label placed where no instance of that label is
        (farther than :data:`MATCH_GATE_M` from every one; a distractor named as a learnt
        object counts here).
    surrounded_apart : int
        Described pairs said "surrounded" whose true footprints do not overlap.
    detail : tuple of (label, distance, found, error)
        Per true (learnt) object: its label, metres from the camera, whether it was found and
        its centroid error (NaN when missed), for the tables by distance and by object.
    pitch_deg : float
        The rig's pitch (0 = level).
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
    #: The centroid-vector rule on the same pairs: clear right, ambiguous right, and per tag
    #: of ``centroid_rule.TAGS`` ``[forces right, centroid rule right, pairs]`` (clear pairs).
    centroid_clear_correct: int = 0
    centroid_ambiguous_correct: int = 0
    by_tag: Mapping[str, list[int]] = field(default_factory=dict)

    false_known: int = 0
    surrounded_apart: int = 0
    detail: tuple[tuple[str, float, bool, float], ...] = ()
    pitch_deg: float = 0.0


def _centroid_scores(
    pred: PredictedScene, truth: SceneTruth
) -> tuple[int, int, dict[str, list[int]]]:
    clear = ambiguous = 0
    by_tag: dict[str, list[int]] = {}
    for rel in truth.relations:
        key = (rel.argument, rel.referent)
        if key not in pred.relations or key not in pred.centroid_relations:
            continue
        right = int(pred.centroid_relations[key] == rel.primary)
        if rel.ambiguous:
            ambiguous += right
            continue
        clear += right
        for tag in (*rel.tags, "all"):
            t = by_tag.setdefault(tag, [0, 0, 0])
            t[0] += int(pred.relations[key] == rel.primary)
            t[1] += right
            t[2] += 1
    return clear, ambiguous, by_tag


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
    known = [o for o in truth.objects if not o.distractor]
    names = [o.key for o in known]
    matched = match_objects(pred, truth)  # predicted name -> true name
    to_pred = {t: p for p, t in matched.items()}
    detail = object_detail(pred, known, to_pred)
    errors = tuple(e for _lab, _d, ok, e in detail if ok)  # metres, 3-D
    said = translate_relations(pred, matched)
    pairs = [(a, b) for a in names for b in names if a != b]
    described = [p for p in pairs if p in said]
    clear, ambiguous, apart = tally_relations(said, truth.relations)
    found = len(errors)
    usable = pred.error is None and found == len(names) and len(described) == len(pairs)
    false_known = [n for n in unmatched(pred, matched) if is_known(pred.label_of(n))]
    cen_clear, cen_ambiguous, by_tag = _centroid_scores(pred, truth)
    return SceneScore(
        name=truth.name,
        usable=usable,
        n_objects=len(names),
        n_found=found,
        n_extra=len(pred.objects) - len(matched),
        pairs_total=len(pairs),
        pairs_described=len(described),
        clear_correct=clear[0],
        clear_total=clear[1],
        ambiguous_correct=ambiguous[0],
        ambiguous_total=ambiguous[1],
        centroid_errors=errors,
        seconds=float(pred.seconds),
        error=pred.error,
        labels=tuple(o.label for o in known),
        missing=tuple(o.key for o in known if o.key not in to_pred),
        false_known=len(false_known),
        surrounded_apart=apart,
        detail=detail,
        pitch_deg=truth.pitch_deg,
        centroid_clear_correct=cen_clear,
        centroid_ambiguous_correct=cen_ambiguous,
        by_tag=by_tag,
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
    def false_known(self) -> int:
        """Known objects reported where no instance of them is."""
        return sum(s.false_known for s in self.scenes)

    @property
    def surrounded_apart(self) -> int:
        """ "Surrounded" said of pairs whose footprints are apart."""
        return sum(s.surrounded_apart for s in self.scenes)

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

    def centroid_rule(self) -> dict[str, Any]:
        """The centroid-vector rule beside the forces: clear and ambiguous pairs right, and
        per tag (``elongated``, ``close``, ``partly hidden``, ``all``; clear pairs)
        ``{"forces", "centroid", "pairs"}``."""
        tags: dict[str, list[int]] = {}
        for s in self.scenes:
            for tag, (f, c, n) in s.by_tag.items():
                t = tags.setdefault(tag, [0, 0, 0])
                t[0], t[1], t[2] = t[0] + f, t[1] + c, t[2] + n
        return {
            "clear_correct": sum(s.centroid_clear_correct for s in self.scenes),
            "ambiguous_correct": sum(s.centroid_ambiguous_correct for s in self.scenes),
            "by_tag": {
                k: {"forces": f, "centroid": c, "pairs": n} for k, (f, c, n) in tags.items()
            },
        }

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
                        "detail": tuple(
                            (str(a), float(b), bool(c), float("nan") if e is None else float(e))
                            for a, b, c, e in s.get("detail", ())
                        ),
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
            "false_known": self.false_known,
            "surrounded_apart": self.surrounded_apart,
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
            "centroid_rule": self.centroid_rule(),
            "per_scene": [
                {
                    **asdict(s),
                    "centroid_errors": list(s.centroid_errors),
                    "labels": list(s.labels),
                    "missing": list(s.missing),
                    "detail": [
                        [a, b, c, None if math.isnan(e) else round(e, 6)] for a, b, c, e in s.detail
                    ],
                }
                for s in self.scenes
            ],
            "by_band": breakdown(self.scenes, "band"),
            "by_label": breakdown(self.scenes, "label"),
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
    p90 = "–" if ce["p90"] is None else f"{100 * ce['p90']:.1f} cm"
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
        ("centroid error, 90th percentile", p90, "–"),
        ("known objects reported where they are not", str(result.false_known), "–"),
        ("\"surrounded\" between objects whose footprints are apart",
         str(result.surrounded_apart), "–"),
        ("time per scene, median / mean", secs, "–"),
        ("scenes that failed outright", str(result.n_failed), "–"),
        ("centroid-vector rule instead: clear pairs",
         _frac(d["centroid_rule"]["clear_correct"], ct), "–"),
        ("centroid-vector rule instead: ambiguous pairs",
         _frac(d["centroid_rule"]["ambiguous_correct"], at), "–"),
    ]  # fmt: skip
    head = (
        f"scenespeak evaluate {result.dataset or '(scenes)'}: {result.n_scenes} scenes, "
        f"{result.workers} worker(s), {result.wall_seconds:.1f} s wall clock"
    )
    lines = [head, "", "| measure | scenespeak | paper (Luke et al. 2005) |", "| --- | --- | --- |"]
    lines += [f"| {a} | {b} | {c} |" for a, b, c in rows]
    tags = d["centroid_rule"]["by_tag"]
    if tags:
        lines += ["", "| clear pairs | pairs | forces right | centroid rule right |",
                  "| --- | --- | --- | --- |"]  # fmt: skip
        for tag in ("elongated", "close", "partly hidden", "all"):
            if tag in tags:
                t = tags[tag]
                lines.append(
                    f"| {tag} | {t['pairs']} | {_frac(t['forces'], t['pairs'])} | "
                    f"{_frac(t['centroid'], t['pairs'])} |"
                )
    found = found_by_label(result.scenes)
    if found:
        by_label = ", ".join(f"{lab} {f}/{n}" for lab, (f, n) in sorted(found.items()))
        lines += ["", f"Objects found by label: {by_label}."]
    lines += breakdown_table(result.scenes)
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


def evaluate_scene(scene_dir: str, db_path: str) -> SceneScore:
    """Describe one scene folder and score it (pure apart from reading files; picklable).

    A scene the chain cannot use (a :class:`~scenespeak.errors.ScenespeakError`) is scored as
    not usable with the error kept; a broken ``truth.json`` raises.
    """
    from scenespeak.perception.database import ObjectDatabase

    with ObjectDatabase.open(db_path, readonly=True) as db:
        return _evaluate_one(scene_dir, db)


def _evaluate_one(scene_dir: str, db: Any, options: dict[str, Any] | None = None) -> SceneScore:
    from scenespeak.scene_folder import describe_scene_folder

    scene = Path(scene_dir)
    truth = load_scene_truth(scene)
    start = time.perf_counter()
    try:
        desc = describe_scene_folder(scene, db, **(options or {}))
        pred = predicted_from_description(desc, scene.name, time.perf_counter() - start)
    except ScenespeakError as exc:
        pred = PredictedScene(scene.name, {}, {}, time.perf_counter() - start, str(exc))
    return score_scene(pred, truth)


def evaluate_batch(scene_dirs: Sequence[str], database: Any) -> list[SceneScore]:
    """Score a batch of scene folders: the task the engine (:mod:`scenespeak.tools.engine`)
    runs on its workers, with the database its worker opened once (``database.get()``)."""
    db = database.get()
    options = database.scene_options() if hasattr(database, "scene_options") else {}
    return [_evaluate_one(scene, db, options) for scene in scene_dirs]


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
