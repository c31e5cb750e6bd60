"""``scenespeak points`` runs the pipeline's stereo stage (threaded SIFT, the dense check
cropped to the matches plus ``stage_options.DENSE_MARGIN``, issue 16) and must give the
points ``describe`` finds, bit for bit: ``describe_scene(...).points``, and the stage's call
``stereo_points(..., **StereoOptions().keywords())`` on the images read in colour as
``describe`` reads them: rendered card pairs, scenes of the generator, and the real
Middlebury and KITTI pairs (resized to the benchmark's sizes). The default run takes a
sample; with ``SCENESPEAK_LONG_TESTS=1`` every real pair at 640×480, 1280×960 and 1920×1080
(minutes)."""

from __future__ import annotations

import json
import os
from pathlib import Path

import cv2
import numpy as np
import pytest

from cardscene import BASELINE, HFOV, H, W, card_pair, write_rgb
from scenespeak.cli import main
from scenespeak.perception import calibration, stereo
from scenespeak.perception.calibfiles import read_calibration
from scenespeak.perception.features import load_image
from scenespeak.perception.recognition import ObjectDatabase
from scenespeak.perception.stage_options import StereoOptions
from scenespeak.pipeline import describe_scene

CARDS = {"astronaut": (-0.5, 1.6, 0.5), "coffee": (0.45, 2.2, 0.6)}
SIZES = ((640, 480), (1280, 960), (1920, 1080))
#: A sample of the real pairs for the default run (hard ones: thin structures, repeated
#: texture, depth edges — the README's hardest — and a wide KITTI frame).
SAMPLE = ("middeval2/Art", "middeval2/Laundry", "middeval2/Cones", "kitti2012/000000_10")


def _points(left: Path, right: Path, calib: Path, capsys: pytest.CaptureFixture[str]) -> dict:
    assert main(["points", "--calib", str(calib), str(left), str(right)]) == 0
    return json.loads(capsys.readouterr().out)


def _reference(left: Path, right: Path, rig: calibration.StereoRig) -> dict:
    """The pipeline's stereo stage (its options: the cropped dense check), on the images as
    describe reads them."""
    ref = stereo.stereo_points(
        load_image(left, gray=False),
        load_image(right, gray=False),
        rig,
        **StereoOptions().keywords(),
    )
    return stereo.points_to_json(ref.points)


def _described(left: Path, right: Path, rig: calibration.StereoRig, db_path: Path) -> dict:
    """The points of ``describe_scene`` itself (the whole pipeline, threads and all)."""
    with ObjectDatabase.open(db_path, readonly=True) as db:
        desc = describe_scene(
            load_image(left, gray=False), load_image(right, gray=False), rig, db, unknown=False
        )
    return stereo.points_to_json(desc.points)


@pytest.fixture(scope="module")
def card_db(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from cardscene import photo

    path = tmp_path_factory.mktemp("cards") / "objects.db"
    with ObjectDatabase.create(path) as db:
        for name in CARDS:
            db.add_object(name, [photo(name, (240, 240))])
    return path


def _write_pair(
    left: np.ndarray, right: np.ndarray, size: tuple[int, int], root: Path
) -> tuple[Path, Path, Path, calibration.StereoRig]:
    if left.shape[1::-1] != size:
        interp = cv2.INTER_AREA if size[0] < left.shape[1] else cv2.INTER_LINEAR
        left = cv2.resize(left, size, interpolation=interp)
        right = cv2.resize(right, size, interpolation=interp)
    lp, rp = write_rgb(root / "l.png", left), write_rgb(root / "r.png", right)
    calib = root / "calib.json"
    calib.write_text(json.dumps({"baseline": BASELINE, "hfov_deg": HFOV, "image_size": list(size)}))
    return lp, rp, calib, calibration.rig_from_short(BASELINE, HFOV, size)


@pytest.mark.parametrize("size", [(W, H), (2 * W, 2 * H)])
def test_points_are_those_of_the_pipelines_stereo_stage(
    size: tuple[int, int], tmp_path: Path, capsys: pytest.CaptureFixture[str], card_db: Path
) -> None:
    lp, rp, calib, rig = _write_pair(*card_pair(CARDS), size, tmp_path)
    ref = _reference(lp, rp, rig)
    assert len(ref["points"]) > 100
    got = _points(lp, rp, calib, capsys)
    assert got == ref
    assert got == _described(lp, rp, rig, card_db)
    if size == (W, H):
        # One path: the command's points are describe's (colour images), which for this pair
        # differ from those of the files read as gray (libpng's conversion rounds otherwise).
        gray = stereo.stereo_points(load_image(lp), load_image(rp), rig).points
        assert got != stereo.points_to_json(gray)


@pytest.fixture(scope="module")
def rendered(tmp_path_factory: pytest.TempPathFactory) -> list[Path]:
    from scenespeak.tools.scenes import generate_dataset

    root = generate_dataset(tmp_path_factory.mktemp("rendered") / "ds", 2, seed=41)
    return sorted(p for p in Path(root).iterdir() if (p / "left.png").exists())


def test_points_on_generated_scenes(
    rendered: list[Path], capsys: pytest.CaptureFixture[str]
) -> None:
    assert rendered
    for folder in rendered:
        left, right, calib = folder / "left.png", folder / "right.png", folder / "calib.json"
        ref = _reference(left, right, read_calibration(calib))
        assert len(ref["points"]) > 20, folder
        assert _points(left, right, calib, capsys) == ref, folder


def _real_pair(real_data: Path, name: str) -> tuple[np.ndarray, np.ndarray]:
    folder = real_data / "stereo" / name
    for lname, rname in (
        ("view1.png", "view5.png"),
        ("imL.png", "imR.png"),
        ("left.png", "right.png"),
    ):
        if (folder / lname).exists():
            return load_image(folder / lname, gray=False), load_image(folder / rname, gray=False)
    pytest.skip(f"{folder}: no pair of the expected names")


def _check_real(
    real_data: Path,
    name: str,
    size: tuple[int, int],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    lp, rp, calib, rig = _write_pair(*_real_pair(real_data, name), size, tmp_path)
    ref = _reference(lp, rp, rig)
    assert _points(lp, rp, calib, capsys) == ref, (name, size, len(ref["points"]))


def test_points_are_describes_on_a_generated_and_a_real_scene(
    rendered: list[Path],
    real_data: Path,
    card_db: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """The whole of ``describe_scene`` (its threads, BLAS single-threaded) finds the points of
    the command: on a scene of the generator and on the real Art pair (640×480)."""
    folder = rendered[0]
    left, right, calib = folder / "left.png", folder / "right.png", folder / "calib.json"
    got = _points(left, right, calib, capsys)
    assert len(got["points"]) > 20
    assert got == _described(left, right, read_calibration(calib), card_db)
    lp, rp, calib, rig = _write_pair(*_real_pair(real_data, "middeval2/Art"), (640, 480), tmp_path)
    got = _points(lp, rp, calib, capsys)
    assert len(got["points"]) > 100
    assert got == _described(lp, rp, rig, card_db)


@pytest.mark.parametrize("name", SAMPLE)
def test_points_on_real_pairs(
    real_data: Path, name: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    _check_real(real_data, name, (640, 480), tmp_path, capsys)


def _all_real() -> list[str]:
    from conftest import real_data_root

    root = real_data_root()
    if root is None:
        return ["(real data absent)"]
    return [f"{d.parent.name}/{d.name}" for sub in ("middeval2", "kitti2012")
            for d in sorted((root / "stereo" / sub).iterdir()) if d.is_dir()]  # fmt: skip


@pytest.mark.slow
@pytest.mark.skipif(
    not os.environ.get("SCENESPEAK_LONG_TESTS"),
    reason="every real pair at three sizes takes minutes; set SCENESPEAK_LONG_TESTS=1",
)
@pytest.mark.parametrize("size", SIZES, ids=lambda s: f"{s[0]}x{s[1]}")
@pytest.mark.parametrize("name", _all_real())
def test_points_on_every_real_pair(
    real_data: Path,
    name: str,
    size: tuple[int, int],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    _check_real(real_data, name, size, tmp_path, capsys)


@pytest.mark.parametrize(
    ("case", "message"),
    [
        ("swapped", r"calib\.json: .*negative disparity.*look swapped"),
        # without the check the stage finds a few points here, and the command would go on
        ("left twice", r"shows the same view as"),
        # the stage alone raises too ("only 0 stereo matches"): the check's refusal comes first
        ("noise", r"the two images do not show the same scene"),
    ],
)
def test_the_pair_checks_come_first(
    case: str, message: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The pair-order check runs on the stage's features, beside the stage; a pair it refuses
    is named as it names it, in one line, exit 2."""
    import re

    left, right = card_pair(CARDS)
    if case == "noise":
        right = np.random.default_rng(1).integers(0, 255, right.shape, dtype=np.uint8)
    lp, rp, calib, _ = _write_pair(left, right, (W, H), tmp_path)
    first, second = {"swapped": (rp, lp), "left twice": (lp, lp), "noise": (lp, rp)}[case]
    assert main(["points", "--calib", str(calib), str(first), str(second)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and re.search(message, err), err


@pytest.mark.parametrize(
    ("case", "message"),
    [
        ("swapped", r"calib\.json: .*negative disparity.*look swapped"),
        ("left twice", r"shows the same view as"),
        ("noise", r"the two images do not show the same scene"),
    ],
)
def test_describe_refuses_the_same_pairs_on_its_stages_features(
    case: str, message: str, tmp_path: Path, capsys: pytest.CaptureFixture[str], card_db: Path
) -> None:
    """``describe`` runs the pair-order check inside the stereo stage on that stage's SIFT
    features (``StereoOptions.check_order``; it used to run SIFT on both images once more):
    the pairs ``points`` refuses, it refuses with the same one line, exit 2."""
    import re

    left, right = card_pair(CARDS)
    if case == "noise":
        right = np.random.default_rng(1).integers(0, 255, right.shape, dtype=np.uint8)
    lp, rp, calib, _ = _write_pair(left, right, (W, H), tmp_path)
    first, second = {"swapped": (rp, lp), "left twice": (lp, lp), "noise": (lp, rp)}[case]
    argv = ["describe", "--calib", str(calib), "--db", str(card_db), str(first), str(second)]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and re.search(message, err), err


def test_describe_with_the_check_in_the_stage_describes_a_good_pair(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], card_db: Path
) -> None:
    """The check in the stage passes a good pair, and what ``describe --json`` prints is
    ``describe_scene`` without the check (the check decides only whether to go on)."""
    lp, rp, calib, rig = _write_pair(*card_pair(CARDS), (W, H), tmp_path)
    argv = [
        "describe",
        "--calib",
        str(calib),
        "--db",
        str(card_db),
        str(lp),
        str(rp),
        "--format",
        "json",
    ]
    assert main(argv) == 0
    got = json.loads(capsys.readouterr().out)
    with ObjectDatabase.open(card_db, readonly=True) as db:
        ref = describe_scene(load_image(lp, gray=False), load_image(rp, gray=False), rig, db)
    assert got["objects"] == ref.to_dict()["objects"]
    assert got["relations"] == ref.to_dict()["relations"]
