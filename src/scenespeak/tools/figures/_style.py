"""Colours of the figures (one per object label, the same in every figure) and input checks."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from matplotlib.colors import to_rgba
from numpy.typing import ArrayLike, NDArray

from scenespeak.errors import InputError
from scenespeak.overrides import replace_fields

#: Colour of points that belong to no known object.
UNLABELLED_COLOR: tuple[float, float, float, float] = (0.55, 0.55, 0.55, 1.0)

# Ten well-separated colours (matplotlib's "tab10"), listed so that the order is ours.
_PALETTE: tuple[str, ...] = (
    "#1f77b4",
    "#d62728",
    "#2ca02c",
    "#ff7f0e",
    "#9467bd",
    "#17becf",
    "#e377c2",
    "#8c564b",
    "#bcbd22",
    "#7f7f7f",
)

Color = tuple[float, float, float, float]


def _is_unlabelled(label: object) -> bool:
    return label is None or (isinstance(label, str) and label.strip() in {"", "?"})


def label_colors(labels: Sequence[str | None] | NDArray[Any]) -> dict[str, Color]:
    """Give every object label one colour, the same in every figure of a scene.

    Labels are sorted so that the colours do not depend on the order the points come in.
    ``None`` and the empty string mean "no object" and get no entry (they are drawn in
    :data:`UNLABELLED_COLOR`).

    Parameters
    ----------
    labels : sequence of str or None
        Labels, repeated or not.

    Returns
    -------
    dict
        ``label -> RGBA`` tuple.

    Examples
    --------
    >>> colors = label_colors(["mug", "hat", "mug", None])
    >>> sorted(colors)
    ['hat', 'mug']
    """
    unique = sorted({str(lab) for lab in labels if not _is_unlabelled(lab)})
    return {lab: to_rgba(_PALETTE[i % len(_PALETTE)]) for i, lab in enumerate(unique)}


def _color_of(label: object, colors: Mapping[str, Color]) -> Color:
    if _is_unlabelled(label):
        return UNLABELLED_COLOR
    return colors.get(str(label), UNLABELLED_COLOR)


def _as_points(values: ArrayLike, dims: int, name: str) -> NDArray[np.float64]:
    arr = np.asarray(values, dtype=np.float64)
    if arr.size == 0:
        return np.zeros((0, dims))
    if arr.ndim != 2 or arr.shape[1] != dims:
        raise InputError(name, f"expected an (N, {dims}) array of points, got shape {arr.shape}")
    return arr


def _as_labels(labels: Sequence[str | None] | NDArray[Any] | None, n: int, name: str) -> list[Any]:
    if labels is None:
        return [None] * n
    out = list(labels)
    if len(out) != n:
        raise InputError(name, f"{len(out)} labels for {n} points; give one label per point")
    return out


def _as_image(image: ArrayLike, name: str) -> NDArray[Any]:
    arr = np.asarray(image)
    if arr.ndim not in (2, 3) or arr.size == 0:
        raise InputError(name, f"expected an image (H, W) or (H, W, C), got shape {arr.shape}")
    if arr.ndim == 3 and arr.shape[2] == 1:
        arr = arr[:, :, 0]
    if arr.dtype != np.uint8:
        # Floats in [0, 1] (or anything else) are shown as they are, scaled to 8 bits.
        f = arr.astype(np.float64)
        hi = float(np.nanmax(f)) if np.isfinite(f).any() else 1.0
        scale = 255.0 if hi <= 1.0 else 255.0 / max(hi, 1e-12)
        arr = np.clip(np.nan_to_num(f) * scale, 0, 255).astype(np.uint8)
    if arr.ndim == 2:
        arr = np.repeat(arr[:, :, None], 3, axis=2)
    return arr[:, :, :3]


def _spread(n: int, limit: int) -> NDArray[np.intp]:
    """Indices of at most ``limit`` items spread evenly over ``n`` (deterministic)."""
    if n <= limit:
        return np.arange(n)
    return np.unique(np.linspace(0, n - 1, limit).round().astype(np.intp))


def _legend_for(ax: Any, colors: Mapping[str, Color], used: Sequence[Any], **kw: Any) -> None:
    from matplotlib.lines import Line2D

    names = sorted({str(u) for u in used if not _is_unlabelled(u)})
    handles = [Line2D([], [], color=colors.get(n, UNLABELLED_COLOR), lw=3) for n in names]
    if any(_is_unlabelled(u) for u in used):
        handles.append(Line2D([], [], color=UNLABELLED_COLOR, lw=3))
        names.append("unlabelled")
    if handles:
        ax.legend(handles, names, fontsize="small", framealpha=0.85, **kw)


# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class FigureStyle:
    """Colours, title, size and resolution of one figure (``plot_matches``, ``plot_points_3d``).

    Attributes
    ----------
    colors : mapping, optional
        ``label -> colour``; by default :func:`label_colors` of the labels drawn.
    title : str, optional
        Figure title.
    figsize : (width, height) inches, optional
        None: the figure's own default size.
    dpi : float
        100 — resolution.
    """

    colors: Mapping[str, Color] | None = None
    title: str | None = None
    figsize: tuple[float, float] | None = None
    dpi: float = 100.0

    @classmethod
    def with_overrides(
        cls, style: FigureStyle | None, overrides: Mapping[str, object], what: str
    ) -> FigureStyle:
        """``style`` (or the defaults) with single fields replaced (unknown names refused)."""
        return replace_fields(
            style if style is not None else cls(),
            overrides,
            lambda bad, _names: TypeError(f"{what}() got unexpected keyword argument(s) {bad}"),
        )
