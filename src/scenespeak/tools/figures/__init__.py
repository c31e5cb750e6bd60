"""Pictures of every stage, and a one-page report.

The package's rooms: :mod:`._style` (one colour per label, input checks), :mod:`.plots` (the
stage pictures on plain arrays), :mod:`.view` (what the figures need of a scene description)
and :mod:`.report` (the PNG files and the one-page report).

The plotting functions take plain arrays, so they work on any data (yours, or the pipeline's);
each returns a :class:`matplotlib.figure.Figure` built without :mod:`matplotlib.pyplot`, so no
display, no global state, and no backend switch are needed (``Figure.savefig`` renders with
Agg). :func:`write_figures` and :func:`write_report` adapt a whole
:class:`~scenespeak.pipeline.SceneDescription` (or the dictionary of
``scenespeak describe --format json``) and write PNG files (and one self-contained HTML page).

Like the seed paper's figures:

- :func:`plot_matches` — the left and right images side by side, one line per stereo match,
  coloured by object (paper Fig. 4);
- :func:`plot_points_3d` — the 3-D keypoints with their projections onto the horizontal and the
  vertical plane (paper Fig. 5 b);
- :func:`plot_hulls` — the convex hulls in the horizontal plane, camera at the origin, with
  labels (paper Figs. 6, 8 e);
- :func:`plot_histograms` — F0 and F2 of one pair, polar and linear (paper Fig. 7).

>>> import numpy as np
>>> from scenespeak.tools.figures import plot_histograms
>>> theta = np.linspace(0, 2 * np.pi, 180, endpoint=False)
>>> f0 = np.maximum(np.cos(theta - np.pi), 0)       # the argument lies to the left
>>> fig = plot_histograms(f0, f0**2, title="hat / mug")
>>> len(fig.axes)
2
"""

from scenespeak.tools.figures._style import UNLABELLED_COLOR, FigureStyle, label_colors
from scenespeak.tools.figures.plots import (
    plot_histograms,
    plot_hulls,
    plot_matches,
    plot_points_3d,
)
from scenespeak.tools.figures.report import plot_report, write_figures, write_report

__all__ = [
    "UNLABELLED_COLOR",
    "FigureStyle",
    "label_colors",
    "plot_histograms",
    "plot_hulls",
    "plot_matches",
    "plot_points_3d",
    "plot_report",
    "write_figures",
    "write_report",
]
