"""The layout table of the README and ``docs/language.md``, and the module's command line."""

from __future__ import annotations

import argparse
import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from scenespeak.errors import InputError
from scenespeak.spatial.language.relate import relate

__all__ = ["layout_table", "main", "update_doc_table"]


def _ascii(
    polys: Sequence[tuple[str, NDArray[np.float64]]], width: int = 30, max_rows: int = 10
) -> list[str]:
    """Draw polygons on a character grid, seen from above (top row = farthest).

    One row is two columns tall, so a character cell is square on screen; every object gets at
    least the cell of its centroid, so small ones never vanish.
    """
    from matplotlib.path import Path

    allp = np.vstack([p for _, p in polys])
    lo, hi = allp.min(axis=0), allp.max(axis=0)
    span = np.maximum(hi - lo, 1e-9)
    cell = max(span[0] / (width - 2), span[1] / (2.0 * (max_rows - 1)))  # x-size of a column
    cols = math.ceil(span[0] / cell) + 2
    rows = math.ceil(span[1] / (2.0 * cell)) + 1
    x0 = lo[0] + 0.5 * span[0] - 0.5 * cols * cell
    y1 = hi[1] - 0.5 * span[1] + 0.5 * rows * 2.0 * cell
    xs = x0 + (np.arange(cols) + 0.5) * cell
    ys = y1 - (np.arange(rows) + 0.5) * 2.0 * cell
    pts = np.stack(np.meshgrid(xs, ys), axis=-1).reshape(-1, 2)
    grid = np.full((rows, cols), ".", dtype="<U1")
    hits = np.zeros((rows, cols), dtype=int)
    for ch, p in polys:
        inside = Path(p).contains_points(pts).reshape(rows, cols)
        c = p.mean(axis=0)
        col = min(cols - 1, max(0, int((c[0] - x0) // cell)))
        row = min(rows - 1, max(0, int((y1 - c[1]) // (2.0 * cell))))
        inside[row, col] = True
        grid[inside & (hits == 0)] = ch
        grid[inside & (hits > 0)] = "#"
        hits += inside
    return ["".join(r) for r in grid]


def layout_table() -> str:
    """The README table: every example layout as an ASCII picture with the sentence produced.

    Pictures are seen from above with the camera below them (up = behind, down = in front);
    the argument and the referent are drawn with the capital first letter of their labels,
    other objects of the same scene in lower case, ``#`` where objects overlap. Run
    ``python -m scenespeak.spatial.language --table`` to print it; ``docs/language.md`` holds a copy
    that ``tests/spatial/test_language.py`` keeps true.
    """
    from scenespeak.spatial.layouts import LAYOUTS

    out = [
        "Seen from above, the camera below each picture (up = behind = farther, down = in "
        "front); argument and referent in capitals, other objects of the scene in lower case, "
        "`#` where objects overlap.",
        "",
    ]
    for lay in LAYOUTS:
        a_ch, b_ch = lay.argument[0].upper(), lay.referent[0].upper()
        if a_ch == b_ch:
            a_ch, b_ch = "A", "B"
        rel = relate(
            lay.a,
            lay.b,
            argument=lay.argument,
            referent=lay.referent,
            a_heights=lay.a_heights,
            b_heights=lay.b_heights,
        )
        extra = [(name[0].lower(), poly) for name, poly in lay.others]
        pic = _ascii([*extra, (a_ch, lay.a), (b_ch, lay.b)])
        out.append(f"**{lay.name}** — {lay.note}")
        out.append("")
        out.append("```text")
        mid = len(pic) // 2
        for i, row in enumerate(pic):
            out.append(row + ("   → " + rel.sentence if i == mid else ""))
        out.append("```")
        out.append("")
    return "\n".join(out)


_TABLE_START = "<!-- layout-table:start"
_TABLE_END = "<!-- layout-table:end -->"


def update_doc_table(text: str) -> str:
    """Replace the generated layout table between the markers of ``docs/language.md``."""
    i = text.find(_TABLE_START)
    j = text.find(_TABLE_END)
    if i < 0 or j < i:
        raise InputError("docs", f"has no '{_TABLE_START} ... {_TABLE_END}' markers")
    i = text.index("\n", i) + 1
    return text[:i] + layout_table() + "\n" + text[j:]


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m scenespeak.spatial.language --table``: print the layout table (Markdown).

    ``--update-doc docs/language.md`` rewrites the table inside that file instead.
    """
    parser = argparse.ArgumentParser(prog="python -m scenespeak.spatial.language")
    parser.add_argument("--table", action="store_true", help="print the layout table")
    parser.add_argument("--update-doc", metavar="MD", help="rewrite the table in this file")
    args = parser.parse_args(argv)
    import sys

    if args.update_doc:
        from pathlib import Path

        path = Path(args.update_doc)
        path.write_text(update_doc_table(path.read_text(encoding="utf-8")), encoding="utf-8")
        return 0
    if args.table:
        sys.stdout.write(layout_table() + "\n")
        return 0
    parser.print_help()
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
