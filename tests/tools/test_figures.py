"""Every figure rendered to a file and checked for real content (size, variance, colours).

Data: the Middlebury motorcycle pair shipped with scikit-image (matches and 3-D points from its
ground-truth disparity and calibration), hand-made polygons and histograms, and a real
:class:`~scenespeak.pipeline.SceneDescription` of photo cards before a textured wall.
"""

from __future__ import annotations

import base64
import re
from pathlib import Path

import numpy as np
import pytest
from matplotlib.colors import to_rgba
from matplotlib.figure import Figure
from matplotlib.image import imread
from scipy.spatial import ConvexHull
from skimage import data

from cardscene import BASELINE as CARD_BASELINE
from cardscene import HFOV, H, W, card_pair, photo
from scenespeak.errors import InputError
from scenespeak.tools.figures import (
    UNLABELLED_COLOR,
    label_colors,
    plot_histograms,
    plot_hulls,
    plot_matches,
    plot_points_3d,
    write_figures,
    write_report,
)

# Middlebury 2014 motorcycle, down-sampled (the real-data README describes it).
FOCAL, CX, CY, DOFFS, BASELINE = 994.978, 311.193, 254.877, 31.086, 0.193001


@pytest.fixture(scope="module")
def motorcycle() -> dict[str, object]:
    left, right, disp = data.stereo_motorcycle()
    rng = np.random.default_rng(0)
    rows, cols = np.nonzero(np.isfinite(disp))
    pick = rng.choice(len(rows), 600, replace=False)
    r, c = rows[pick].astype(float), cols[pick].astype(float)
    d = disp[rows[pick], cols[pick]]
    z = BASELINE * FOCAL / (d + DOFFS)
    xyz = np.c_[(c - CX) * z / FOCAL, (r - CY) * z / FOCAL, z]
    labels = np.where(z < 2.6, "near", np.where(z < 3.5, "middle", "far")).tolist()
    return {
        "left": left,
        "right": right,
        "left_xy": np.c_[c, r],
        "right_xy": np.c_[c - d, r],
        "xyz": xyz,
        "labels": labels,
    }


def _pixels(path: Path) -> np.ndarray:
    img = imread(path)
    assert img.dtype == np.float32 and img.ndim == 3
    return (img[..., :3] * 255).round().astype(np.int16)


def _nontrivial(path: Path, size: tuple[int, int], min_colours: int = 50) -> np.ndarray:
    """Assert a PNG has the expected (width, height), is not blank, and has many colours."""
    assert path.is_file() and path.stat().st_size > 5_000
    px = _pixels(path)
    assert (px.shape[1], px.shape[0]) == size
    assert px.std() > 10.0
    assert len(np.unique(px.reshape(-1, 3), axis=0)) >= min_colours
    return px


def _count_colour(px: np.ndarray, colour: object, tol: int = 12) -> int:
    rgb = (np.array(to_rgba(colour)[:3]) * 255).round()
    return int((np.abs(px - rgb).max(axis=2) <= tol).sum())


def _save(fig: Figure, path: Path) -> Path:
    assert isinstance(fig, Figure)
    fig.savefig(path)
    return path


def test_label_colours_are_stable_and_skip_unlabelled() -> None:
    a = label_colors(["mug", None, "hat", "", "mug"])
    b = label_colors(["hat", "mug"])
    assert a == b and set(a) == {"hat", "mug"}
    assert a["hat"] != a["mug"] and UNLABELLED_COLOR not in a.values()


def test_matches_on_the_motorcycle_are_coloured_by_object(
    motorcycle: dict[str, object], tmp_path: Path
) -> None:
    m = motorcycle
    fig = plot_matches(m["left"], m["right"], m["left_xy"], m["right_xy"], m["labels"])
    px = _nontrivial(_save(fig, tmp_path / "m.png"), (1000, 400), min_colours=5000)
    colours = label_colors(m["labels"])
    for label in ("near", "middle", "far"):
        assert _count_colour(px, colours[label], tol=6) > 150, label
    assert "600 matches (400 drawn)" in fig.axes[0].get_title()


def test_matches_without_labels_are_grey(motorcycle: dict[str, object], tmp_path: Path) -> None:
    m = motorcycle
    gray_left = (m["left"].mean(axis=2) / 255.0).astype(np.float32)  # floats, gray: accepted
    gray_right = (m["right"].mean(axis=2) / 255.0).astype(np.float32)
    fig = plot_matches(gray_left, gray_right, m["left_xy"], m["right_xy"], max_lines=50)
    px = _nontrivial(_save(fig, tmp_path / "g.png"), (1000, 400))
    assert _count_colour(px, label_colors(["near"])["near"], tol=6) == 0
    assert _count_colour(px, UNLABELLED_COLOR, tol=3) > 50


def test_matches_reject_inconsistent_input(motorcycle: dict[str, object]) -> None:
    m = motorcycle
    with pytest.raises(InputError, match="left points"):
        plot_matches(m["left"], m["right"], m["left_xy"], m["right_xy"][:-1])
    with pytest.raises(InputError, match="one label per point"):
        plot_matches(m["left"], m["right"], m["left_xy"], m["right_xy"], ["a"])
    with pytest.raises(InputError, match=r"\(N, 2\)"):
        plot_matches(m["left"], m["right"], m["xyz"], m["xyz"])


def test_points_3d_show_both_projections(motorcycle: dict[str, object], tmp_path: Path) -> None:
    fig = plot_points_3d(motorcycle["xyz"], motorcycle["labels"], dpi=80)
    px = _nontrivial(_save(fig, tmp_path / "p.png"), (520, 440))
    colours = label_colors(motorcycle["labels"])
    assert _count_colour(px, colours["far"], tol=6) > 200
    # floor shadows are cyan, back-wall shadows red (alpha-blended on the pane: look for hue)
    r, g, b = px[..., 0], px[..., 1], px[..., 2]
    assert ((g > 170) & (b > 170) & (r < 150)).sum() > 100
    assert ((r > 200) & (g < 190) & (b < 190) & (r - g > 40)).sum() > 100
    # the axes are the horizontal plane's frame: depth runs over the motorcycle's 2-5 m
    ylo, yhi = fig.axes[0].get_ylim()
    assert ylo <= 0.0 and 4.5 < yhi < 6.5


def test_points_3d_follow_the_up_direction(motorcycle: dict[str, object]) -> None:
    level = plot_points_3d(motorcycle["xyz"]).axes[0].get_zlim()
    upside = plot_points_3d(motorcycle["xyz"], up=(0, 1, 0)).axes[0].get_zlim()
    assert level[0] == pytest.approx(-upside[1]) and level[1] == pytest.approx(-upside[0])


def test_hulls_of_the_motorcycle_depth_bands(motorcycle: dict[str, object], tmp_path: Path) -> None:
    labels = np.array(motorcycle["labels"])
    plane = motorcycle["xyz"][:, [0, 2]]
    points = {lab: plane[labels == lab] for lab in ("near", "middle", "far")}
    hulls = {lab: p[ConvexHull(p).vertices] for lab, p in points.items()}
    fig = plot_hulls(hulls, points, hfov_deg=40.0)
    px = _nontrivial(_save(fig, tmp_path / "h.png"), (550, 550))
    colours = label_colors(list(hulls))
    for lab in hulls:  # every hull's edge is drawn in its colour
        assert _count_colour(px, colours[lab], tol=6) > 200, lab
    assert {t.get_text() for t in fig.axes[0].texts} >= {"near", "middle", "far", "camera"}


def test_hulls_by_hand_with_truth_and_degenerate_hulls(tmp_path: Path) -> None:
    hat = [[-0.3, 1.0], [-0.1, 1.0], [-0.1, 1.2], [-0.3, 1.2]]
    mug = [[0.2, 1.5], [0.3, 1.5], [0.25, 1.6]]
    can = [[0.0, 2.0], [0.1, 2.0]]  # two points: drawn as a segment, not rejected
    fig = plot_hulls({"hat": hat, "mug": mug, "can": can}, truth={"hat": np.add(hat, 0.02)})
    px = _nontrivial(_save(fig, tmp_path / "hand.png"), (550, 550), min_colours=30)
    assert _count_colour(px, label_colors(["can", "hat", "mug"])["mug"], tol=6) > 30
    with pytest.raises(InputError, match="hull of hat"):
        plot_hulls({"hat": [1.0, 2.0, 3.0]})


def test_histograms_polar_and_linear(tmp_path: Path) -> None:
    theta = np.linspace(0, 2 * np.pi, 180, endpoint=False)
    f0 = np.maximum(np.cos(theta - np.pi), 0.0)  # argument to the left
    f2 = 0.01 * np.maximum(np.cos(theta - 0.9 * np.pi), 0.0) ** 4
    fig = plot_histograms(f0, f2, title="hat relative to mug")
    px = _nontrivial(_save(fig, tmp_path / "f.png"), (900, 380))
    assert _count_colour(px, "#1f77b4", tol=6) > 300 and _count_colour(px, "#d62728", 6) > 300
    polar, linear = fig.axes
    assert polar.name == "polar"
    # scaled to their maxima; the line's peak is where the argument lies (180° = left)
    blue = linear.lines[0]
    assert blue.get_ydata().max() == pytest.approx(1.0)
    assert blue.get_xdata()[np.argmax(blue.get_ydata())] == pytest.approx(180.0)
    with pytest.raises(InputError, match="F0 has 180 values and F2 90"):
        plot_histograms(f0, f2[:90])


# --- a real SceneDescription: photo cards before a textured wall ------------------------------

CARDS = {"astronaut": (-0.25, 1.2, 0.2), "chelsea": (0.22, 1.0, 0.2), "coffee": (0.0, 1.8, 0.25)}


@pytest.fixture(scope="module")
def description(tmp_path_factory: pytest.TempPathFactory) -> object:
    from scenespeak.perception.calibration import rig_from_short
    from scenespeak.perception.recognition import ObjectDatabase
    from scenespeak.pipeline import describe_scene

    left, right = card_pair(CARDS)
    path = tmp_path_factory.mktemp("cards") / "objects.db"
    with ObjectDatabase.create(path) as db:
        for name in CARDS:
            db.add_object(name, [photo(name, 240)])
    rig = rig_from_short(CARD_BASELINE, HFOV, (W, H))
    with ObjectDatabase.open(path, readonly=True) as db:
        return describe_scene(left, right, rig, db, unknown=False)


def test_write_figures_of_a_described_scene(description: object, tmp_path: Path) -> None:
    files = write_figures(description, tmp_path / "figs")
    names = [p.name for p in files]
    assert names == [
        "matches.png",
        "points3d.png",
        "hulls.png",
        "histograms.png",
        "report.png",
        "report.html",
    ]
    sizes = {
        "matches.png": (1000, 400),
        "points3d.png": (650, 550),
        "hulls.png": (550, 550),
        "histograms.png": (900, 380),
        "report.png": (1600, 1000),
    }
    colours = label_colors(list(CARDS))
    for path in files[:-1]:
        px = _nontrivial(path, sizes[path.name])
        if path.name in ("matches.png", "hulls.png", "report.png"):
            for label in CARDS:  # every object appears in its own colour
                assert _count_colour(px, colours[label], tol=8) > 20, (path.name, label)


def test_report_html_is_self_contained(description: object, tmp_path: Path) -> None:
    png, page = write_report(description, tmp_path, pair=("coffee", "chelsea"))
    assert png.name == "report.png" and page.name == "report.html"
    text = page.read_text(encoding="utf-8")
    images = re.findall(r'src="data:image/png;base64,([A-Za-z0-9+/=]+)"', text)
    assert len(images) == 4
    assert all(base64.b64decode(img)[:8] == b"\x89PNG\r\n\x1a\n" for img in images)
    assert 'src="http' not in text and "<link" not in text  # nothing outside the page
    for rel in description.relations:
        assert rel.sentence.replace("'", "&#x27;") in text


def test_report_of_the_json_form_and_unknown_pair(description: object, tmp_path: Path) -> None:
    as_json = description.to_dict()
    files = write_figures(as_json, tmp_path)
    assert [p.name for p in files] == ["hulls.png", "histograms.png", "report.png", "report.html"]
    _nontrivial(files[0], (550, 550))
    with pytest.raises(InputError, match="no relation of 'mug' to 'hat'"):
        write_figures(as_json, tmp_path, pair=("mug", "hat"))


def test_write_figures_into_an_unusable_folder(description: object, tmp_path: Path) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    with pytest.raises(InputError, match="cannot create the figures folder"):
        write_figures(description, blocker / "figs")
