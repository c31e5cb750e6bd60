"""Tables by distance band, rig and object (private helpers of :mod:`scenespeak.tools.evaluation`).

Each :class:`~scenespeak.tools.evaluation.SceneScore` carries ``detail`` — per true learnt
object its label, distance, whether it was found and its centroid error — and the rig's pitch;
these functions group them.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from scenespeak.tools.evaluation_scores import EvaluationResult

__all__ = ["BANDS", "PAPER", "breakdown", "breakdown_table", "format_table", "found_by_label"]

#: The seed paper's own result (Luke, Blisard, Keller, Skubic, RO-MAN 2005, section V).
PAPER: Mapping[str, Any] = {
    "scenes": 100,
    "usable": 76,
    "note": "descriptions judged accurate by eye; no counts, errors or times reported",
}

#: Distance bands (metres from the left camera) of the tables by distance.
BANDS: tuple[tuple[float, float], ...] = ((0.0, 1.0), (1.0, 1.5), (1.5, float("inf")))


def _frac(num: int, den: int) -> str:
    return "–" if den == 0 else f"{num} / {den} ({100.0 * num / den:.0f} %)"


def found_by_label(scenes: Sequence[Any]) -> dict[str, list[int]]:
    """label -> [found, total] over all scenes (from ``detail`` where present)."""
    found: dict[str, list[int]] = {}
    for s in scenes:
        if s.detail:
            for lab, _d, ok, _e in s.detail:
                found.setdefault(lab, [0, 0])[1] += 1
                found[lab][0] += int(ok)
            continue
        for lab in s.labels:
            found.setdefault(lab, [0, 0])[1] += 1
            found[lab][0] += lab not in s.missing
    return found


def _band(distance: float) -> str:
    for lo, hi in BANDS:
        if lo <= distance < hi:
            return f"{lo:.1f}–{hi:.1f} m" if math.isfinite(hi) else f"≥ {lo:.1f} m"
    return "?"


def breakdown(scenes: Sequence[Any], by: str) -> dict[str, dict[str, Any]]:
    """Found / total and centroid errors per distance band, label or rig."""
    groups: dict[str, list[tuple[bool, float]]] = {}
    for s in scenes:
        for lab, dist, ok, err in s.detail:
            key = {"band": _band(dist), "label": lab}.get(by)
            if key is None:
                key = "pitched" if s.pitch_deg else "level"
            groups.setdefault(key, []).append((ok, err))
    out: dict[str, dict[str, Any]] = {}
    for key in sorted(groups):
        items = groups[key]
        errs = np.array([e for ok, e in items if ok], dtype=np.float64)
        out[key] = {
            "found": sum(ok for ok, _ in items),
            "total": len(items),
            "median_error_m": None if errs.size == 0 else round(float(np.median(errs)), 6),
            "p90_error_m": None if errs.size == 0 else round(float(np.percentile(errs, 90)), 6),
        }
    return out


def breakdown_table(scenes: Sequence[Any]) -> list[str]:
    """Markdown tables of objects found and centroid errors by distance, rig and object
    (preceded by an empty line; none without per-object detail)."""
    if not any(s.detail for s in scenes):
        return []
    lines: list[str] = [""]
    usable = {"level": [0, 0], "pitched": [0, 0]}
    for s in scenes:
        k = "pitched" if s.pitch_deg else "level"
        usable[k][0] += int(s.usable)
        usable[k][1] += 1
    for by, title in (("band", "distance"), ("rig", "rig"), ("label", "object")):
        table = breakdown(scenes, by)
        lines += [
            f"| {title} | objects found | centroid error median / p90 |"
            + (" scenes usable |" if by == "rig" else ""),
            "| --- | --- | --- |" + (" --- |" if by == "rig" else ""),
        ]
        for key, row in table.items():
            med, p90 = row["median_error_m"], row["p90_error_m"]
            err = "–" if med is None else f"{100 * med:.1f} / {100 * p90:.1f} cm"
            extra = f" {_frac(*usable[key])} |" if by == "rig" else ""
            lines.append(f"| {key} | {_frac(row['found'], row['total'])} | {err} |{extra}")
        lines.append("")
    return lines[:-1]


def format_table(result: EvaluationResult) -> str:
    """The paper's table, filled in, beside the paper's own result (Markdown).

    Examples
    --------
    >>> from scenespeak.tools.evaluation import summarize
    >>> print(format_table(summarize([])).splitlines()[2])
    | measure | scenespeak | paper (Luke et al. 2005) |
    """
    d = result.to_dict()
    head = (
        f"scenespeak evaluate {result.dataset or '(scenes)'}: {result.n_scenes} scenes, "
        f"{result.workers} worker(s), {result.wall_seconds:.1f} s wall clock"
    )
    lines = [head, "", "| measure | scenespeak | paper (Luke et al. 2005) |", "| --- | --- | --- |"]
    lines += [f"| {a} | {b} | {c} |" for a, b, c in _summary_rows(result, d)]
    lines += _tag_lines(d["centroid_rule"])
    found = found_by_label(result.scenes)
    if found:
        by_label = ", ".join(f"{lab} {f}/{n}" for lab, (f, n) in sorted(found.items()))
        lines += ["", f"Objects found by label: {by_label}."]
    lines += breakdown_table(result.scenes)
    if d.get("learnt") is not None:
        lines += ["", f"Learnt: {', '.join(d['learnt'])}; not learnt (distractors): "
                  f"{', '.join(d['unlearnt']) or '–'}."]  # fmt: skip
    lines += _failed_lines(result)
    return "\n".join(lines)


def _summary_rows(result: EvaluationResult, d: Mapping[str, Any]) -> list[tuple[str, str, str]]:
    """The rows of the main table: measure, scenespeak's figure, the paper's."""
    ce, sp = d["centroid_error_m"], d["seconds_per_scene"]
    cc, ct = result.clear
    ac, at = result.ambiguous
    uc, ut = result.usable_clear
    cent = "–" if ce["median"] is None else f"{100 * ce['median']:.1f} / {100 * ce['mean']:.1f} cm"
    secs = "–" if sp["median"] is None else f"{sp['median']:.2f} / {sp['mean']:.2f} s"
    p90 = "–" if ce["p90"] is None else f"{100 * ce['p90']:.1f} cm"
    return [
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
        ("… on an unlearnt object / elsewhere (duplicate, neighbour, background)",
         _false_known_split(d), "–"),
        ("\"surrounded\" between objects whose footprints are apart",
         str(result.surrounded_apart), "–"),
        ("time per scene, median / mean", secs, "–"),
        ("scenes that failed outright", str(result.n_failed), "–"),
        ("centroid-vector rule instead: clear pairs",
         _frac(d["centroid_rule"]["clear_correct"], ct), "–"),
        ("centroid-vector rule instead: ambiguous pairs",
         _frac(d["centroid_rule"]["ambiguous_correct"], at), "–"),
    ]  # fmt: skip


def _false_known_split(d: Mapping[str, Any]) -> str:
    """``unlearnt / elsewhere (duplicate, neighbour, background)`` of ``to_dict()``."""
    k = d["false_known_by_kind"]
    return (
        f"{d['false_known_unlearnt']} / {d['false_known_elsewhere']} "
        f"({k['duplicate']}, {k['neighbour']}, {k['background']})"
    )


_TAG_TABLES = (
    ("by_tag", "clear pairs (truth: centroid direction of the true footprints)"),
    ("by_tag_point_pairs", "clear pairs (truth: point pairs of the true footprints)"),
)


def _tag_lines(rule: Mapping[str, Any]) -> list[str]:
    """The forces against the centroid-vector rule, per tag of the clear pairs, against the
    generator's truth and against the point pairs of the true footprints."""
    lines: list[str] = []
    for key, title in _TAG_TABLES:
        tags = rule.get(key) or {}
        if tags:
            lines += ["", f"| {title} | pairs | forces right | centroid rule right |",
                      "| --- | --- | --- | --- |"]  # fmt: skip
        for tag in ("elongated", "close", "partly hidden", "all"):
            if tag in tags:
                t = tags[tag]
                lines.append(
                    f"| {tag} | {t['pairs']} | {_frac(t['forces'], t['pairs'])} | "
                    f"{_frac(t['centroid'], t['pairs'])} |"
                )
    return lines


def _failed_lines(result: EvaluationResult) -> list[str]:
    """The first ten failed scenes with their errors."""
    failed = [s for s in result.scenes if s.error]
    if not failed:
        return []
    lines = ["", "Failed scenes:"]
    lines += [f"- {s.name}: {s.error}" for s in failed[:10]]
    if len(failed) > 10:
        lines.append(f"- ... and {len(failed) - 10} more")
    return lines
