"""The figure files of a scene and the one-page report (PNG and a self-contained HTML page)."""

from __future__ import annotations

import base64
import contextlib
import html
import io
import os
from collections.abc import Callable
from os import PathLike
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure
from numpy.typing import NDArray

from scenespeak.errors import InputError
from scenespeak.tools.figures._style import label_colors
from scenespeak.tools.figures.plots import (
    plot_histograms,
    plot_hulls,
    plot_matches,
    plot_points_3d,
)
from scenespeak.tools.figures.view import _scene_view, _SceneView


def _save(fig: Figure, path: Path, dpi: float | None = None) -> Path:
    buf = io.BytesIO()
    _plain_text(fig).savefig(buf, format="png", dpi=dpi, facecolor="white")
    return _write_file(path, buf.getvalue())


def _plain_text(fig: Figure) -> Figure:
    """Labels come from files (a database someone else made): "$x$" stays text, not mathtext."""
    from matplotlib.text import Text

    for t in fig.findobj(Text):
        t.set_parse_math(False)
    return fig


def _write_file(path: Path, data: bytes) -> Path:
    """Write ``data`` to ``path`` without following a symlink planted there.

    The bytes go to a new file beside it (``O_EXCL | O_NOFOLLOW``), which then replaces
    ``path`` itself: a symlink at ``path`` is replaced, its target is never written.
    """
    if path.is_dir() and not path.is_symlink():
        raise InputError(path, "is a folder; cannot write the figure there (remove or rename it)")
    flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        fd = os.open(tmp, flags, 0o644)
        try:
            with os.fdopen(fd, "wb", closefd=False) as f:
                f.write(data)
        finally:
            os.close(fd)
        os.replace(tmp, path)
    except OSError as exc:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise InputError(path, f"cannot write the figure ({exc.strerror or exc})") from None
    return path


def _pick_relation(view: _SceneView, pair: tuple[str, str] | None) -> dict[str, Any] | None:
    usable = [r for r in view.relations if r["f0"] is not None and r["f2"] is not None]
    if pair is not None:
        for r in usable:
            if (r["argument"], r["referent"]) == tuple(pair):
                return r
        raise InputError("pair", f"no relation of {pair[0]!r} to {pair[1]!r} in this scene")
    return usable[0] if usable else None


def _scene_figures(
    view: _SceneView, pair: tuple[str, str] | None
) -> list[tuple[str, Callable[[], Figure]]]:
    """Names and builders of the figures this scene has the data for."""
    colors = label_colors([*(view.point_labels or []), *view.hulls, *view.plane_points])
    out: list[tuple[str, Callable[[], Figure]]] = []
    left, right, left_xy, right_xy = view.left, view.right, view.left_xy, view.right_xy
    if left is not None and right is not None and left_xy is not None and right_xy is not None:
        lbl = view.match_labels
        if lbl is not None and len(lbl) != len(left_xy):
            lbl = None
        out.append(
            (
                "matches",
                lambda: plot_matches(left, right, left_xy, right_xy, lbl, colors=colors),
            )
        )
    xyz = view.xyz
    if xyz is not None and len(xyz):
        out.append(
            (
                "points3d",
                lambda: plot_points_3d(xyz, view.point_labels, up=view.up, colors=colors),
            )
        )
    if view.hulls:
        out.append(
            (
                "hulls",
                lambda: plot_hulls(
                    view.hulls, view.plane_points, colors=colors, hfov_deg=view.hfov_deg
                ),
            )
        )
    rel = _pick_relation(view, pair)
    if rel is not None:
        out.append(
            (
                "histograms",
                lambda: plot_histograms(
                    rel["f0"], rel["f2"], title=f"{rel['argument']} relative to {rel['referent']}"
                ),
            )
        )
    return out


def write_figures(
    description: Any,
    out_dir: str | PathLike[str],
    *,
    pair: tuple[str, str] | None = None,
    report: bool = True,
    dpi: float = 100.0,
) -> list[Path]:
    """Write the pictures of every stage of one described scene as PNG files.

    Files (each only when the description holds the data for it): ``matches.png``,
    ``points3d.png``, ``hulls.png``, ``histograms.png`` (of ``pair``, by default the first
    described pair) and, with ``report=True``, ``report.png`` and ``report.html``
    (see :func:`write_report`).

    Parameters
    ----------
    description : SceneDescription or dict
        The result of :func:`scenespeak.pipeline.describe_scene`, or its ``to_dict()`` / the
        JSON of ``scenespeak describe --format json`` (hulls, histograms and sentences only).
    out_dir : path
        Folder to write into (created if missing).
    pair : (argument, referent), optional
        The pair whose histograms to draw.
    report : bool
        Also write the one-page report.
    dpi : float
        Resolution of the PNG files.

    Returns
    -------
    list of Path
        The files written, in the order above.
    """
    out = _figures_dir(out_dir)
    view = _scene_view(description)
    written = [
        _save(build(), out / f"{name}.png", dpi) for name, build in _scene_figures(view, pair)
    ]
    if report:
        written.extend(write_report(description, out, pair=pair, _view=view))
    return written


def _figures_dir(out_dir: str | PathLike[str]) -> Path:
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise InputError(out, "exists and is not a folder; --figures needs a folder")
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(out, f"cannot create the figures folder ({exc.strerror or exc})") from exc
    return out


def plot_report(
    description: Any, *, pair: tuple[str, str] | None = None, _view: _SceneView | None = None
) -> Figure:
    """One page (A4-ish landscape) with every stage's picture and the sentences beside them.

    Parameters
    ----------
    description : SceneDescription or dict
        As for :func:`write_figures`.
    pair : (argument, referent), optional
        The pair whose histograms to draw.

    Returns
    -------
    matplotlib.figure.Figure
    """
    view = _scene_view(description) if _view is None else _view
    images = {name: _render(build(), dpi=90.0) for name, build in _scene_figures(view, pair)}
    page_w, page_h, margin, gap, title_h = 16.0, 10.0, 0.25, 0.2, 0.6
    fig = Figure(figsize=(page_w, page_h), dpi=100)
    fig.suptitle("scenespeak: what the stereo pair shows", fontsize=14, y=1.0 - 0.15 / page_h)

    def aspect(name: str) -> float:
        h, w = images[name].shape[:2]
        return w / h

    def place(name: str, x: float, y: float, w: float, h: float) -> None:
        # (x, y) is the top-left corner in inches from the page's top-left
        ax = fig.add_axes((x / page_w, 1.0 - (y + h) / page_h, w / page_w, h / page_h))
        ax.imshow(images[name])
        ax.set_axis_off()

    # Left block: the matches across its width, the 3-D points and the hulls side by side
    # below, as large as the page allows with every picture at its own aspect ratio.
    top = title_h
    room = page_h - top - margin
    right_w = 4.6
    left_w = page_w - 2 * margin - gap - right_w
    below = [n for n in ("points3d", "hulls") if n in images]

    def left_height(w: float) -> float:
        h = w / aspect("matches") if "matches" in images else 0.0
        if below:
            h += max((w - gap) / len(below) / aspect(n) for n in below) + gap
        return h

    if left_height(left_w) > room:
        left_w *= room / left_height(left_w)
    y = top
    if "matches" in images:
        h = left_w / aspect("matches")
        place("matches", margin, y, left_w, h)
        y += h + gap
    cell = (left_w - gap) / max(len(below), 1)
    for k, name in enumerate(below):
        place(name, margin + k * (cell + gap), y, cell, cell / aspect(name))
    # Right column: the histograms at the bottom, the sentences above them.
    x_right = page_w - margin - right_w
    hist_h = 0.0
    if "histograms" in images:
        hist_h = right_w / aspect("histograms")
        place("histograms", x_right, page_h - margin - hist_h, right_w, hist_h)
    text = _report_text(view)
    text_h = room - hist_h - gap
    lines = text.count("\n") + 1
    size = max(6.0, min(10.0, 72.0 * text_h / (1.3 * lines)))  # shrink a long list to fit
    fig.text(
        x_right / page_w,
        1.0 - top / page_h,
        text,
        va="top",
        ha="left",
        fontsize=size,
        family="serif",
    )
    return fig


def _render(fig: Figure, dpi: float = 100.0) -> NDArray[np.uint8]:
    buf = io.BytesIO()
    # cropped to what is drawn, so that the page can lay each picture out at its real shape
    _plain_text(fig).savefig(
        buf, format="png", dpi=dpi, facecolor="white", bbox_inches="tight", pad_inches=0.05
    )
    buf.seek(0)
    from matplotlib.image import imread

    img = imread(buf, format="png")
    return (np.clip(img, 0, 1) * 255).astype(np.uint8)


def _wrap(text: str, width: int = 52) -> str:
    import textwrap

    return "\n".join(textwrap.wrap(text, width)) or text


def _report_text(view: _SceneView) -> str:
    lines = ["Description"]
    if view.summary:
        lines += [_wrap(view.summary), ""]
    for i, rel in enumerate(view.relations, 1):
        if rel["sentence"]:
            lines.append(_wrap(f"{i}. {rel['sentence']}"))
    if not view.relations:
        lines.append("(no pair of objects could be described)")
    if view.skipped:
        lines += ["", "Not described"]
        lines += [_wrap(f"- {lab}: {why}") for lab, why in view.skipped]
    return "\n".join(lines)


def write_report(
    description: Any,
    out_dir: str | PathLike[str],
    *,
    pair: tuple[str, str] | None = None,
    _view: _SceneView | None = None,
) -> list[Path]:
    """Write the one-page report: ``report.png`` and a self-contained ``report.html``.

    The HTML page embeds every picture as base64 PNG (no other file is needed to view or send
    it) and lists the sentences, the objects and the objects that could not be described.

    Parameters
    ----------
    description : SceneDescription or dict
        As for :func:`write_figures`.
    out_dir : path
        Folder to write into (created if missing).
    pair : (argument, referent), optional
        The pair whose histograms to draw.

    Returns
    -------
    list of Path
        ``[report.png, report.html]``.
    """
    out = _figures_dir(out_dir)
    view = _scene_view(description) if _view is None else _view
    png = _save(plot_report(description, pair=pair, _view=view), out / "report.png", 100.0)

    images = []
    for name, build in _scene_figures(view, pair):
        buf = io.BytesIO()
        _plain_text(build()).savefig(buf, format="png", dpi=90, facecolor="white")
        data = base64.b64encode(buf.getvalue()).decode("ascii")
        images.append(
            f'<figure><img alt="{html.escape(name)}" src="data:image/png;base64,{data}">'
            f"<figcaption>{html.escape(_CAPTIONS.get(name, name))}</figcaption></figure>"
        )
    sentences = "".join(
        f"<li>{html.escape(r['sentence'])}</li>" for r in view.relations if r["sentence"]
    )
    objects = "".join(
        f"<tr><td>{html.escape(lab)}</td><td>{len(view.plane_points.get(lab, []))}</td>"
        f"<td>{len(hull)}</td></tr>"
        for lab, hull in view.hulls.items()
    )
    skipped = "".join(
        f"<li><b>{html.escape(lab)}</b>: {html.escape(why)}</li>" for lab, why in view.skipped
    )
    summary = f"<p>{html.escape(view.summary)}</p>" if view.summary else ""
    page = _HTML.format(
        images="\n".join(images) or "<p>(no pictures: the description holds no stage data)</p>",
        summary=summary,
        sentences=f"<ol>{sentences}</ol>" if sentences else "<p>No pair could be described.</p>",
        objects=objects,
        skipped=f"<h2>Not described</h2><ul>{skipped}</ul>" if skipped else "",
    )
    page_path = _write_file(out / "report.html", page.encode("utf-8"))
    return [png, page_path]


_CAPTIONS = {
    "matches": "Stereo matches between the left and right images, coloured by object.",
    "points3d": "3-D keypoints with their horizontal (cyan) and vertical (red) projections.",
    "hulls": "Convex hulls of the objects in the horizontal plane; the camera is at the origin.",
    "histograms": "Histograms of forces F0 and F2 of one pair (0° right, 90° behind).",
}

_HTML = """<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8">
<title>scenespeak report</title>
<style>
body {{ font-family: sans-serif; margin: 1.5em; color: #222; }}
main {{ display: flex; gap: 2em; align-items: flex-start; }}
.pictures {{ flex: 3; display: flex; flex-wrap: wrap; gap: 1em; }}
.pictures figure {{ margin: 0; max-width: 48%; }}
.pictures img {{ max-width: 100%; border: 1px solid #ddd; }}
figcaption {{ font-size: 0.85em; color: #555; }}
aside {{ flex: 1; min-width: 18em; }}
table {{ border-collapse: collapse; }} td, th {{ border: 1px solid #ccc; padding: 0.2em 0.6em; }}
</style></head>
<body>
<h1>scenespeak: what the stereo pair shows</h1>
<main>
<section class="pictures">
{images}
</section>
<aside>
<h2>Description</h2>
{summary}
{sentences}
<h2>Objects</h2>
<table><tr><th>object</th><th>points</th><th>hull vertices</th></tr>{objects}</table>
{skipped}
</aside>
</main>
</body></html>
"""
