"""Tables by distance band, rig and object (private helpers of :mod:`scenespeak.tools.evaluation`).

Each :class:`~scenespeak.tools.evaluation.SceneScore` carries ``detail`` — per true learnt
object its label, distance, whether it was found and its centroid error — and the rig's pitch;
these functions group them.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

__all__ = ["BANDS", "breakdown", "breakdown_table", "found_by_label"]

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
