"""The Histogram of Forces beside the centroid rule on shapes that can part them.

The generator's scenes (``scenespeak evaluate``) hold compact objects a few centimetres apart,
where the centroid vector and the objects' extent agree (docs/evaluation.md: both rules are right
on every clear pair). This benchmark draws, with fixed seeds, the configurations where they can
part — the cases spatial-VQA label generators get wrong — and scores both rules on each ordered
pair against the **point-pairs truth** (``tools.centroid_rule.point_pairs_direction``: the
direction a strict majority of point pairs of the two footprints agree on; pairs no direction
wins are left out):

``elongated``
    a long object (a shelf, a bench, a table edge: 0.5–1.2 m × 4–12 cm, any heading) and a small
    one (3–8 cm) 3–40 cm from it, anywhere around it;
``close``
    two compact objects of very different sizes (5 and 20–40 cm across) 1–8 cm apart;
``L-shaped``
    a non-convex L (a corner unit, arms 30–60 cm) and a small object in or near its corner.

Both rules read the same footprints: the **true** ones, and **estimated** ones as a stereo
chain would give them (the convex hull of 40 points drawn inside the visible footprint with 1 cm
of noise — the hull of an L is no longer an L). The forces' answer is the rule base's primary
direction (``language.relate_objects``), the centroid rule's the nearest axis to the centroid
vector (``tools.centroid_rule.centroid_primary``).

Honest reading: the point-pairs truth is the "all point pairs" definition of a directional
relation (Freeman 1975; Miyajima & Ralescu 1994) with every pair counted alike; it is the
continuous form of the F0 (constant-force) histogram only. The rule base reads F0 *and* F2, the
gravitational histogram, which weights near parts of an object far more than far ones — so on a
long object next to a small one the forces speak of the part that is near ("mostly in front"),
where the majority of point pairs, and the centroid, speak of the whole ("to the left"). Which
of the two a person would say is not settled by this truth (no human judgements are available
here); the table shows where the rules part and how often, not which one people prefer.

Run::

    python benchmarks/bench_rules.py              # 300 configurations per family
    python benchmarks/bench_rules.py --n 1000 --seed 7
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import NDArray

from scenespeak.spatial.language import relate_objects
from scenespeak.tools.centroid_rule import (
    CLEAR_SHARE,
    centroid_primary,
    point_pairs_direction,
)

Poly = NDArray[np.float64]


def _rect(w: float, h: float, heading: float, centre: tuple[float, float]) -> Poly:
    c, s = math.cos(heading), math.sin(heading)
    pts = np.array([[-w / 2, -h / 2], [w / 2, -h / 2], [w / 2, h / 2], [-w / 2, h / 2]])
    return pts @ np.array([[c, s], [-s, c]]) + np.asarray(centre)


def _disc(r: float, centre: tuple[float, float], n: int = 20) -> Poly:
    t = np.linspace(0.0, 2 * math.pi, n, endpoint=False)
    return np.column_stack([np.cos(t), np.sin(t)]) * r + np.asarray(centre)


def _ell(
    arm_a: float, arm_b: float, width: float, heading: float, corner: tuple[float, float]
) -> Poly:
    pts = np.array(
        [[0, 0], [arm_a, 0], [arm_a, width], [width, width], [width, arm_b], [0, arm_b]], float
    )
    c, s = math.cos(heading), math.sin(heading)
    return pts @ np.array([[c, s], [-s, c]]) + np.asarray(corner)


def _gap(a: Poly, b: Poly) -> float:
    """Smallest distance between the two polygons' vertices and edges (metres, approximate)."""
    d = np.linalg.norm(a[:, None, :] - b[None, :, :], axis=2)
    return float(d.min())


def _elongated(rng: np.random.Generator) -> tuple[Poly, Poly]:
    long = _rect(
        rng.uniform(0.5, 1.2), rng.uniform(0.04, 0.12), rng.uniform(0, math.pi), (0.0, 1.2)
    )
    r = rng.uniform(0.015, 0.04)
    while True:
        ang, dist = rng.uniform(0, 2 * math.pi), rng.uniform(0.05, 0.7)
        small = _disc(r, (dist * math.cos(ang), 1.2 + dist * math.sin(ang)))
        g = _gap(long, small)
        if 0.03 <= g <= 0.4 and not _inside_any(small, long):
            return long, small


def _close(rng: np.random.Generator) -> tuple[Poly, Poly]:
    big = _rect(rng.uniform(0.2, 0.4), rng.uniform(0.2, 0.4), rng.uniform(0, math.pi), (0.0, 1.2))
    r = 0.025
    while True:
        ang, dist = rng.uniform(0, 2 * math.pi), rng.uniform(0.1, 0.35)
        small = _disc(r, (dist * math.cos(ang), 1.2 + dist * math.sin(ang)))
        g = _gap(big, small)
        if 0.01 <= g <= 0.08 and not _inside_any(small, big):
            return big, small


def _l_shaped(rng: np.random.Generator) -> tuple[Poly, Poly]:
    width = rng.uniform(0.06, 0.12)
    ell = _ell(
        rng.uniform(0.3, 0.6), rng.uniform(0.3, 0.6), width, rng.uniform(0, 2 * math.pi), (0.0, 1.2)
    )
    r = rng.uniform(0.02, 0.04)
    lo, hi = ell.min(axis=0), ell.max(axis=0)
    while True:
        c = rng.uniform(lo - 0.1, hi + 0.1)
        small = _disc(r, (float(c[0]), float(c[1])))
        g = _gap(ell, small)
        if 0.03 <= g <= 0.25 and not _inside_any(small, ell):
            return ell, small


def _inside_any(small: Poly, big: Poly) -> bool:
    """Whether the small disc's centre lies inside ``big`` (even-odd rule)."""
    px, py = small.mean(axis=0)
    x, y = big[:, 0], big[:, 1]
    xn, yn = np.roll(x, -1), np.roll(y, -1)
    inside = False
    for x0, y0, x1, y1 in zip(x, y, xn, yn, strict=True):
        if (y0 > py) != (y1 > py) and px < x0 + (py - y0) * (x1 - x0) / (y1 - y0):
            inside = not inside
    return inside


def _estimated(poly: Poly, rng: np.random.Generator, points: int = 40) -> Poly:
    """The convex hull of ``points`` noisy points inside ``poly``: what a stereo chain gives."""
    from scipy.spatial import ConvexHull

    lo, hi = poly.min(axis=0), poly.max(axis=0)
    got: list[NDArray[np.float64]] = []
    while sum(len(g) for g in got) < points:
        cand = rng.uniform(lo, hi, size=(4 * points, 2))
        keep = [p for p in cand if _inside_any(np.asarray([p]), poly)]
        if keep:
            got.append(np.asarray(keep))
    pts = np.concatenate(got)[:points] + rng.normal(0.0, 0.01, size=(points, 2))
    hull = ConvexHull(pts)
    return pts[hull.vertices]


def _centroid(poly: Poly) -> tuple[float, float]:
    x, y = poly[:, 0], poly[:, 1]
    xn, yn = np.roll(x, -1), np.roll(y, -1)
    cross = x * yn - xn * y
    area = cross.sum() / 2
    return float(((x + xn) * cross).sum() / (6 * area)), float(
        ((y + yn) * cross).sum() / (6 * area)
    )


FAMILIES: dict[str, Callable[[np.random.Generator], tuple[Poly, Poly]]] = {
    "elongated": _elongated,
    "close": _close,
    "L-shaped": _l_shaped,
}


def score(family: str, n: int, seed: int, estimated: bool) -> dict[str, int]:
    """Counts of clear ordered pairs and each rule's right answers on ``n`` configurations."""
    rng = np.random.default_rng([seed, list(FAMILIES).index(family), int(estimated)])
    out = {"pairs": 0, "forces": 0, "centroid": 0, "forces only": 0, "centroid only": 0}
    for _ in range(n):
        true = FAMILIES[family](rng)
        seen = tuple(_estimated(p, rng) for p in true) if estimated else true
        rels = relate_objects(list(seen), names=["big", "small"])
        for rel, _hist in rels:
            a, b = (true[0], true[1]) if rel.argument == "big" else (true[1], true[0])
            sa, sb = (seen[0], seen[1]) if rel.argument == "big" else (seen[1], seen[0])
            direction, share = point_pairs_direction(a.tolist(), b.tolist())
            if share <= CLEAR_SHARE:
                continue
            forces_ok = rel.primary == direction
            cent_ok = centroid_primary(_centroid(sa), _centroid(sb)) == direction
            out["pairs"] += 1
            out["forces"] += forces_ok
            out["centroid"] += cent_ok
            out["forces only"] += forces_ok and not cent_ok
            out["centroid only"] += cent_ok and not forces_ok
    return out


def _pct(k: int, n: int) -> str:
    return f"{k} / {n} ({100.0 * k / n:.1f} %)" if n else "–"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=300, help="configurations per family")
    ap.add_argument("--seed", type=int, default=2026)
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    print(f"configurations per family: {args.n}, seed {args.seed}")
    print(
        "\n| footprints | family | clear pairs (point-pairs truth) | forces right | centroid rule "
        "right | only the forces | only the centroid |"
    )
    print("| --- | --- | --- | --- | --- | --- | --- |")
    rows: list[dict[str, Any]] = []
    for estimated in (False, True):
        for family in FAMILIES:
            s = score(family, args.n, args.seed, estimated)
            rows.append(s)
            print(
                f"| {'estimated' if estimated else 'true'} | {family} | {s['pairs']} | "
                f"{_pct(s['forces'], s['pairs'])} | {_pct(s['centroid'], s['pairs'])} | "
                f"{s['forces only']} | {s['centroid only']} |"
            )
    print(f"\n{time.perf_counter() - t0:.1f} s", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
