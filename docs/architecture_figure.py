"""Draw docs/architecture.png: the rooms of the package and the data flowing through them.

Run ``python docs/architecture_figure.py`` (matplotlib only; writes beside this file).
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
from matplotlib.patches import FancyArrowPatch, FancyBboxPatch

GEOMETRY = "geometry/  polygons (overlap, point inside) · frames (up, ground, heights) · DBSCAN"
PIPELINE = "pipeline.py  PipelineOptions (one options object per stage) → SceneDescription"
ROOMS = {
    # name: (x, y, w, h, colour, lines)
    "perception": (0.2, 3.0, 6.2, 2.6, "#dbe9f6", "perception/  pixels → 3-D objects"),
    "spatial": (7.0, 3.0, 5.8, 2.6, "#e3f1dc", "spatial/  regions → words"),
    "geometry": (
        0.2,
        0.3,
        12.6,
        1.1,
        "#f0e6d8",
        GEOMETRY,
    ),
    "contract": (5.35, 1.75, 2.7, 0.9, "#fff3bf", "contract.SpatialObject"),
    "pipeline": (
        0.2,
        6.1,
        12.6,
        0.8,
        "#eeeeee",
        PIPELINE,
    ),
    "tools": (
        0.2,
        7.2,
        6.0,
        0.8,
        "#f6e0e6",
        "tools/  generator · truth · evaluation · figures/",
    ),
    "live": (6.45, 7.2, 3.2, 0.8, "#dff3f3", "live/  tracker + memory"),
    "cli": (9.9, 7.2, 2.9, 0.8, "#e8e0f6", "cli/  the commands"),
}
STAGES = [
    # (x, y, text) inside the rooms, left to right = the order data flows; each stage's own
    # options dataclass under its result
    (0.4, 4.2, "calibration\nStereoRig"),
    (1.75, 4.2, "features\nSIFT"),
    (3.1, 4.2, "stereo\nStereoStage\n(StereoOptions)"),
    (4.45, 4.2, "recognition\nLabelling\n(LabelOptions)"),
    (3.9, 3.15, "scene_objects\nstrategy\n(StrategyOptions)"),
    (2.4, 3.15, "objects\nSceneObject\n(ObjectOptions)"),
    (7.3, 4.2, "forces\nF0, F2"),
    (8.8, 4.2, "degrees\nof truth"),
    (10.2, 4.2, "language\nRelation\n(RelationOptions)"),
    (10.2, 3.15, "summary,\nnaming"),
]
FLOW = [(0, 2), (1, 2), (1, 3), (2, 4), (3, 4), (4, 5), (6, 7), (7, 8), (8, 9)]


def main() -> Path:
    fig, ax = plt.subplots(figsize=(11, 6.6))
    for x, y, w, h, colour, text in ROOMS.values():
        ax.add_patch(
            FancyBboxPatch((x, y), w, h, boxstyle="round,pad=0.05", fc=colour, ec="#555555")
        )
        ty = y + h - 0.3 if h > 1.5 else y + h / 2
        ax.text(x + 0.15, ty, text, va="center", fontsize=9.5, weight="bold")
    boxes = []
    for x, y, text in STAGES:
        ax.add_patch(FancyBboxPatch((x, y), 1.2, 0.8, boxstyle="round,pad=0.04", fc="white"))
        ax.text(x + 0.6, y + 0.4, text, ha="center", va="center", fontsize=6.5)
        boxes.append((x + 0.6, y + 0.4))
    for a, b in FLOW:
        ax.add_patch(
            FancyArrowPatch(boxes[a], boxes[b], arrowstyle="-|>", mutation_scale=12,
                            shrinkA=22, shrinkB=22, color="#333333")
        )  # fmt: skip
    # the one crossing between the halves: SceneObject → SpatialObject → forces
    obj, forces = boxes[5], boxes[6]
    contract = (6.7, 2.2)
    for p, q in ((obj, contract), (contract, forces)):
        ax.add_patch(
            FancyArrowPatch(p, q, arrowstyle="-|>", mutation_scale=14, shrinkA=24, shrinkB=24,
                            color="#b8860b", lw=2)
        )  # fmt: skip
    ax.text(6.7, 2.85, "hull, heights, points,\nlabel, confidence", ha="center", fontsize=7.5)
    ax.text(
        6.5,
        -0.25,
        "imports point down only: spatial/ and geometry/ never import perception/; "
        "contract.py imports only NumPy (tests/architecture/test_layering.py)",
        ha="center",
        fontsize=8,
        style="italic",
    )
    ax.set_xlim(0, 13)
    ax.set_ylim(-0.5, 8.2)
    ax.axis("off")
    out = Path(__file__).with_name("architecture.png")
    fig.savefig(out, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return out


if __name__ == "__main__":
    print(main())
