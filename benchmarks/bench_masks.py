"""Mask-outline simplification: histogram error and speed on the frozen mask set (issue 16).

For every pair of :func:`scenespeak.tools.mask_set.mask_pairs` (tuning or validation seed),
F0 and F2 at 180 directions through ``force_histograms`` on the masks:

* with the unsimplified marching-squares outline (``mask_tolerance=0``, the exact histogram of
  the traced outline), the reference of the simplification error;
* with each tolerance asked for, and with the library's rule (``mask_tolerance=None``);
* for the kinds rasterised from a polygon, on the polygon itself (what the mask stands for).

The error of a histogram ``h`` against a reference ``g`` is ``max|h - g| / max g`` (relative to
the peak, over the 180 directions). Times are CPU ms of one ``force_histograms`` call (F0 + F2,
tracing included), median of ``--repeat`` runs, compiled kernel (``SCENESPEAK_NUMBA=always``).

Run::

    python benchmarks/bench_masks.py --set tuning --tolerances 0.25,0.5,1,2
    python benchmarks/bench_masks.py --set validation --rule        # the figures in the docs
    python benchmarks/bench_masks.py --figure docs/img/mask_outline_rule.png   # the picture
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from scenespeak.tools.mask_set import TUNING_SEED, VALIDATION_SEED, MaskPair, mask_pairs

Array = NDArray[np.float64]
RULE = "rule"


@dataclass
class Row:
    """One pair under one setting: errors (F0, F2) and CPU ms."""

    pair: str
    kind: str
    size: int
    gap: float
    setting: str
    vertices: int
    err_exact: tuple[float, float]
    err_polygon: tuple[float, float] | None
    ms: float
    ms_exact: float
    extra: dict[str, float] = field(default_factory=dict)


def cpu_ms(fn: Callable[[], object], repeat: int) -> float:
    fn()
    times = []
    for _ in range(repeat):
        t0 = time.process_time()
        fn()
        times.append(1e3 * (time.process_time() - t0))
    return statistics.median(times)


def peak_error(h: Array, g: Array) -> float:
    """``max|h - g| / max g``."""
    return float(np.abs(h - g).max() / np.abs(g).max())


def _hist(a: object, b: object, tol: float | None) -> tuple[Array, Array]:
    from scenespeak.spatial.forces import force_histograms

    f0, f2 = force_histograms(a, b, r=(0.0, 2.0), directions=180, mask_tolerance=tol)
    return f0, f2


def _vertices(pair: MaskPair, tol: float | None) -> int:
    from scenespeak.spatial.forces import prepare

    return len(prepare(pair.a, "a", mask_tolerance=tol).start) + len(
        prepare(pair.b, "b", mask_tolerance=tol).start
    )


def evaluate(pair: MaskPair, settings: list[str], repeat: int) -> list[Row]:
    """Every setting on one pair, against the exact outline and the polygon."""
    exact = _hist(pair.a, pair.b, 0.0)
    poly = None
    if pair.polygon_a is not None and pair.polygon_b is not None:
        poly = _hist(pair.polygon_a, pair.polygon_b, None)
    ms_exact = cpu_ms(lambda: _hist(pair.a, pair.b, 0.0), repeat)
    rows = []
    for setting in ["0", *settings]:
        tol = None if setting == RULE else float(setting)
        got = _hist(pair.a, pair.b, tol)
        err_e = (peak_error(got[0], exact[0]), peak_error(got[1], exact[1]))
        err_p = None
        if poly is not None:
            err_p = (peak_error(got[0], poly[0]), peak_error(got[1], poly[1]))
        ms = ms_exact if setting == "0" else cpu_ms(lambda t=tol: _hist(pair.a, pair.b, t), repeat)
        rows.append(
            Row(
                pair.name,
                pair.kind,
                pair.size,
                pair.gap,
                setting,
                _vertices(pair, tol),
                err_e,
                err_p,
                ms,
                ms_exact,
            )
        )
    return rows


def _fmt(x: float) -> str:
    return f"{100 * x:.3f} %"


def summary(rows: list[Row], settings: list[str]) -> None:
    """Per setting and image size: the max errors and the median speed-up over ``0``."""
    print(
        "| setting | size | pairs | max err F0 / F2 vs exact outline | "
        "max err F0 / F2 vs polygon (0 → setting) | vertices | speed-up (median) |"
    )
    print("| --- | ---: | ---: | ---: | ---: | ---: | ---: |")
    sizes = sorted({r.size for r in rows})
    for setting in settings:
        for size in [*sizes, 0]:
            sel = [r for r in rows if r.setting == setting and (size == 0 or r.size == size)]
            base = {r.pair: r for r in rows if r.setting == "0"}
            e0 = max(r.err_exact[0] for r in sel)
            e2 = max(r.err_exact[1] for r in sel)
            pol = [r for r in sel if r.err_polygon is not None]
            p_txt = "–"
            if pol:
                b0 = max(base[r.pair].err_polygon[0] for r in pol)  # type: ignore[index]
                b2 = max(base[r.pair].err_polygon[1] for r in pol)  # type: ignore[index]
                p0 = max(r.err_polygon[0] for r in pol)  # type: ignore[index]
                p2 = max(r.err_polygon[1] for r in pol)  # type: ignore[index]
                p_txt = f"{_fmt(b0)} → {_fmt(p0)} / {_fmt(b2)} → {_fmt(p2)}"
            verts = sum(r.vertices for r in sel) / max(1, sum(base[r.pair].vertices for r in sel))
            speed = statistics.median(r.ms_exact / r.ms for r in sel)
            label = "all" if size == 0 else f"{size}²"
            print(
                f"| {setting} | {label} | {len(sel)} | {_fmt(e0)} / {_fmt(e2)} | {p_txt} | "
                f"{100 * verts:.0f} % | {speed:.2f}× |"
            )


def figure(path: str) -> None:
    """The picture of docs/forces.md: a tuning-set pair, its traced and simplified outlines,
    and F2 with either outline (the rule's error as a curve)."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    from scenespeak.spatial.forces import prepare

    pair = next(p for p in mask_pairs(TUNING_SEED, sizes=(512,)) if p.name == "field-512-0")
    fig = Figure(figsize=(11, 4.2), dpi=110)
    ax_mask, ax_zoom, ax_hist = fig.subplots(1, 3, width_ratios=[1, 1, 1.5])
    outlines = {
        (name, tol): prepare(mask, name, mask_tolerance=tol)
        for mask, name in ((pair.a, "A"), (pair.b, "B"))
        for tol in (0.0, None)
    }
    styles = {0.0: {"color": "C0", "lw": 2.2}, None: {"color": "C3", "lw": 1.0}}
    for ax in (ax_mask, ax_zoom):
        ax.imshow(pair.a | pair.b, cmap="Greys", vmin=0, vmax=2.5, interpolation="nearest")
        for (_, tol), region in outlines.items():
            x = np.column_stack([region.start[:, 0], region.end[:, 0]]).T
            y = -np.column_stack([region.start[:, 1], region.end[:, 1]]).T
            ax.plot(x, y, **styles[tol])  # type: ignore[arg-type]
        ax.set_xticks([])
        ax.set_yticks([])
    for name, mask in (("A", pair.a), ("B", pair.b)):
        rows, cols = np.nonzero(mask)
        ax_mask.text(cols.mean(), rows.mean(), name, fontsize=12, ha="center", va="center")
    ruled = outlines[("A", None)].start
    ax_zoom.plot(ruled[:, 0], -ruled[:, 1], "o", color="C3", ms=3)
    # zoom on A's outline where it comes nearest B (what F2 weighs most)
    rows_b, cols_b = np.nonzero(pair.b)
    near = ruled[np.argmin(np.hypot(ruled[:, 0] - cols_b.mean(), -ruled[:, 1] - rows_b.mean()))]
    ax_zoom.set_xlim(near[0] - 20, near[0] + 20)
    ax_zoom.set_ylim(-near[1] + 20, -near[1] - 20)
    n_exact = _vertices(pair, 0.0)
    n_rule = _vertices(pair, None)
    ax_mask.set_title(
        f"traced outline ({n_exact} vertices, blue)\nthe rule's ({n_rule} vertices, red)",
        fontsize=9,
    )
    ax_zoom.set_title("A where it comes nearest B (40 × 40 px)", fontsize=9)
    exact = _hist(pair.a, pair.b, 0.0)[1]
    rule = _hist(pair.a, pair.b, None)[1]
    deg = np.arange(180) * 2.0
    ax_hist.plot(deg, exact / exact.max(), color="0.3", lw=2.5, label="F2, traced outline")
    ax_hist.plot(deg, rule / exact.max(), color="C3", lw=1.0, label="F2, rule")
    err = peak_error(rule, exact)
    ax_hist.plot(
        deg, 20 * (rule - exact) / exact.max(), color="C0", lw=0.8, label="difference × 20"
    )
    ax_hist.set_xlabel("direction (degrees)")
    ax_hist.set_title(
        f"F2 of A with respect to B: max difference {100 * err:.2f} % of the peak",
        fontsize=9,
    )
    ax_hist.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path)
    print(f"wrote {path}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--set", choices=("tuning", "validation"), default="validation")
    parser.add_argument("--tolerances", default="", help="comma-separated pixels, e.g. 0.5,1")
    parser.add_argument("--rule", action="store_true", help="the library's rule (None)")
    parser.add_argument("--sizes", default="64,128,256,512,1024")
    parser.add_argument("--per-kind", type=int, default=3)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--json", help="write every row to this file")
    parser.add_argument("--figure", help="only draw the picture of docs/forces.md to this file")
    args = parser.parse_args()
    os.environ.setdefault("SCENESPEAK_NUMBA", "always")
    if args.figure:
        figure(args.figure)
        return
    settings = [s for s in args.tolerances.split(",") if s] + ([RULE] if args.rule else [])
    seed = TUNING_SEED if args.set == "tuning" else VALIDATION_SEED
    sizes = tuple(int(s) for s in args.sizes.split(","))
    print(f"load average before: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    pairs = mask_pairs(seed, sizes=sizes, per_kind=args.per_kind)
    print(f"{args.set} set (seed {seed}): {len(pairs)} pairs, sizes {sizes}\n")
    rows: list[Row] = []
    for pair in pairs:
        rows.extend(evaluate(pair, settings, args.repeat))
    summary(rows, settings)
    if args.json:
        with open(args.json, "w") as fh:
            json.dump([r.__dict__ for r in rows], fh)
    print(f"\nload average after: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")


if __name__ == "__main__":
    main()
