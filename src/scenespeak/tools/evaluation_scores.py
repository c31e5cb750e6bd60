"""Scoring one scene against its ground truth, and the result of a whole evaluation (pure).

:func:`score_scene` gives a :class:`SceneScore`; :func:`summarize` gathers them into an
:class:`EvaluationResult` whose :meth:`~EvaluationResult.to_dict` is ``scenespeak evaluate
--json``. :mod:`scenespeak.tools.evaluation` runs the chain and re-exports these.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import asdict, dataclass, field, replace
from typing import Any

import numpy as np

from scenespeak.errors import InputError
from scenespeak.tools.centroid_rule import score_point_pairs
from scenespeak.tools.evaluation_match import (
    match_objects,
    object_detail,
    tally_relations,
    translate_relations,
)
from scenespeak.tools.evaluation_split import FALSE_KNOWN_KINDS, false_known_kinds
from scenespeak.tools.evaluation_tables import PAPER, breakdown
from scenespeak.tools.evaluation_truth import PredictedScene, SceneTruth

__all__ = ["DIRECTIONS", "EvaluationResult", "SceneScore", "score_scene", "summarize"]

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
    false_known_detail : tuple of (name, kind, near)
        Per false known object: its described name, where it was put (one of
        :data:`~scenespeak.tools.evaluation_split.FALSE_KNOWN_KINDS`: on an ``unlearnt``
        object, a ``duplicate`` of a found one, on a ``neighbour`` of another label, on the
        ``background``) and the nearest true object within the gate ("" for background).
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
    #: The same against the second truth, the point pairs of the true footprints
    #: (``centroid_rule.score_point_pairs``): per tag ``[forces right, centroid right, pairs]``.
    by_tag_point_pairs: Mapping[str, list[int]] = field(default_factory=dict)

    false_known: int = 0
    surrounded_apart: int = 0
    detail: tuple[tuple[str, float, bool, float], ...] = ()
    pitch_deg: float = 0.0
    false_known_detail: tuple[tuple[str, str, str], ...] = ()


def _centroid_scores(
    said: Mapping[tuple[str, str], str],
    by_centroid: Mapping[tuple[str, str], str],
    truth: SceneTruth,
) -> tuple[int, int, dict[str, list[int]]]:
    """The centroid rule's right answers (clear, ambiguous) and per tag ``[forces right,
    centroid right, pairs]``; ``said`` and ``by_centroid`` are keyed by the TRUE names (the
    matched objects', as ``translate_relations`` gives them)."""
    clear = ambiguous = 0
    by_tag: dict[str, list[int]] = {}
    for rel in truth.relations:
        key = (rel.argument, rel.referent)
        if key not in said or key not in by_centroid:
            continue
        right = int(by_centroid[key] == rel.primary)
        if rel.ambiguous:
            ambiguous += right
            continue
        clear += right
        for tag in (*rel.tags, "all"):
            t = by_tag.setdefault(tag, [0, 0, 0])
            t[0] += int(said[key] == rel.primary)
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
    n_pairs, n_described = _pair_counts(names, said)
    clear, ambiguous, apart = tally_relations(said, truth.relations)
    found = len(errors)
    usable = pred.error is None and found == len(names) and n_described == n_pairs
    by_centroid = translate_relations(_CentroidView(pred.centroid_relations), matched)
    cen_clear, cen_ambiguous, by_tag = _centroid_scores(said, by_centroid, truth)
    false_known = false_known_kinds(pred, truth, matched)
    return SceneScore(
        name=truth.name,
        usable=usable,
        n_objects=len(names),
        n_found=found,
        n_extra=len(pred.objects) - len(matched),
        pairs_total=n_pairs,
        pairs_described=n_described,
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
        false_known_detail=false_known,
        surrounded_apart=apart,
        detail=detail,
        pitch_deg=truth.pitch_deg,
        centroid_clear_correct=cen_clear,
        centroid_ambiguous_correct=cen_ambiguous,
        by_tag=by_tag,
        by_tag_point_pairs=score_point_pairs(said, by_centroid, truth.relations),
    )


@dataclass(frozen=True)
class _CentroidView:
    """The centroid rule's relations where ``translate_relations`` reads ``relations``."""

    relations: Mapping[tuple[str, str], str]


def _pair_counts(names: Sequence[str], said: Mapping[tuple[str, str], Any]) -> tuple[int, int]:
    """(ordered pairs of the true objects, those that got a relation)."""
    pairs = [(a, b) for a in names for b in names if a != b]
    return len(pairs), sum(1 for p in pairs if p in said)


def _tag_totals(per_scene: Iterable[Mapping[str, Sequence[int]]]) -> dict[str, dict[str, int]]:
    """Sum per-scene ``tag -> [forces right, centroid right, pairs]`` into
    ``tag -> {"forces", "centroid", "pairs"}``."""
    tags: dict[str, list[int]] = {}
    for by_tag in per_scene:
        for tag, (f, c, n) in by_tag.items():
            t = tags.setdefault(tag, [0, 0, 0])
            t[0], t[1], t[2] = t[0] + f, t[1] + c, t[2] + n
    return {k: {"forces": f, "centroid": c, "pairs": n} for k, (f, c, n) in tags.items()}


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

    def false_known_by_kind(self) -> dict[str, int]:
        """False known objects counted by where they were put (``FALSE_KNOWN_KINDS``)."""
        kinds = [k for s in self.scenes for _n, k, _o in s.false_known_detail]
        return {k: kinds.count(k) for k in FALSE_KNOWN_KINDS}

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
        ``{"forces", "centroid", "pairs"}`` against the generator's truth (``by_tag``) and
        against the point pairs of the true footprints (``by_tag_point_pairs``)."""
        return {
            "clear_correct": sum(s.centroid_clear_correct for s in self.scenes),
            "ambiguous_correct": sum(s.centroid_ambiguous_correct for s in self.scenes),
            "by_tag": _tag_totals(s.by_tag for s in self.scenes),
            "by_tag_point_pairs": _tag_totals(s.by_tag_point_pairs for s in self.scenes),
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
                        "false_known_detail": tuple(
                            (str(n), str(k), str(o)) for n, k, o in s.get("false_known_detail", ())
                        ),
                    }
                )
                for s in data["per_scene"]
            ]
            result = summarize(
                scenes,
                dataset=str(data.get("dataset", "")),
                workers=int(data.get("workers", 1)),
                wall_seconds=float(data.get("wall_seconds", 0.0)),
            )
            kept = {k: data[k] for k in ("learnt", "unlearnt", "split") if k in data}
            return replace(result, extra=kept) if kept else result
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

        by_kind = self.false_known_by_kind()
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
            "false_known_unlearnt": by_kind["unlearnt"],
            "false_known_elsewhere": self.false_known - by_kind["unlearnt"],
            "false_known_by_kind": by_kind,
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
                    "false_known_detail": [list(f) for f in s.false_known_detail],
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
