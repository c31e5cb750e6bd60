"""The ``scenespeak`` command: every command once, and every bad input of issue 4.

The scene is a real stereo pair of photographs: crops of scikit-image's photos pasted as
fronto-parallel cards at known depths (the exact disparity ``f·B/Z`` apart in the right image)
in front of a textured wall. Bad input must give one line on stderr naming the file and the
problem, exit status 2, and never a traceback.
"""

from __future__ import annotations

import json
import sqlite3
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

from cardscene import BASELINE, FOCAL, HFOV, H, W, card_pair, photo, write_rgb
from scenespeak.cli import main

#: label → (x, Z, width) in metres: a card of that photo at that place.
CARDS = {"astronaut": (-0.25, 1.2, 0.22), "coffee": (0.22, 1.0, 0.2)}

_photo, _write = photo, write_rgb


@pytest.fixture(scope="module")
def scene(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """Files of one synthetic stereo scene, its calibration, training images and a database."""
    root = tmp_path_factory.mktemp("cli_scene")
    left, right = card_pair(CARDS)
    files = {
        "left": _write(root / "left.png", left),
        "right": _write(root / "right.png", right),
        "calib": root / "calib.json",
    }
    files["calib"].write_text(
        json.dumps({"baseline": BASELINE, "hfov_deg": HFOV, "image_size": [W, H]})
    )
    for name in CARDS:
        files[f"train_{name}"] = _write(root / f"{name}.png", _photo(name, (240, 240)))
    db = root / "objects.db"
    for name in CARDS:
        assert (
            main(["db", "add", "--db", str(db), "--label", name, str(files[f"train_{name}"])]) == 0
        )
    files["db"] = db
    return files


def _run(args: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


def _assert_one_line_error(code: int, err: str, *needles: str) -> None:
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("scenespeak: error: ")
    assert "Traceback" not in err
    for needle in needles:
        assert needle in lines[0], (needle, lines[0])


def _describe(scene: dict[str, Path], **repl: Path) -> list[str]:
    f = {**scene, **repl}
    return ["describe", "--db", f["db"], "--calib", f["calib"], f["left"], f["right"]]


# --------------------------------------------------------------------------------------------
# the commands


def test_db_list_and_remove(scene: dict[str, Path], capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = _run(["db", "list", "--db", scene["db"], "--json"], capsys)
    assert code == 0
    rows = json.loads(out)["objects"]
    assert sorted(r["label"] for r in rows) == sorted(CARDS)
    assert all(r["descriptors"] > 50 for r in rows)
    copy = scene["db"].with_name("copy.db")
    copy.write_bytes(scene["db"].read_bytes())
    code, out, _ = _run(["db", "remove", "--db", copy, "coffee"], capsys)
    assert code == 0
    code, out, _ = _run(["db", "list", "--db", copy], capsys)
    assert out.split()[0] == "astronaut" and "coffee" not in out
    code, _, err = _run(["db", "remove", "--db", copy, "coffee"], capsys)
    _assert_one_line_error(code, err, "coffee")


def test_describe_json_follows_the_interface(
    scene: dict[str, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    code, out, err = _run([*_describe(scene), "--format", "json", "--no-unknown"], capsys)
    assert code == 0, err
    doc = json.loads(out)  # stdout is exactly one JSON object
    labels = {o["label"] for o in doc["objects"]}
    assert labels == set(CARDS)
    for o in doc["objects"]:
        assert set(o) >= {"label", "points", "centroid", "hull"}
        assert len(o["centroid"]) == 3 and len(o["hull"]) >= 3
    assert len(doc["relations"]) == 2  # every ordered pair
    for r in doc["relations"]:
        assert set(r) >= {"argument", "referent", "primary", "secondary", "sentence", "f0", "f2"}
        assert len(r["f0"]) == len(r["f2"]) == 180
    rel = {(r["argument"], r["referent"]): r for r in doc["relations"]}
    # the astronaut card is 25 cm left and 20 cm behind the coffee card
    assert rel[("astronaut", "coffee")]["primary"] == "left"
    assert rel[("coffee", "astronaut")]["primary"] == "right"
    assert doc["skipped"] == []


def test_describe_text_and_figures(
    scene: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    figures = tmp_path / "figures"
    code, out, _ = _run([*_describe(scene), "--figures", figures], capsys)
    assert code == 0
    assert "The astronaut is" in out and "of the coffee" in out
    pngs = sorted(p.name for p in figures.glob("*.png"))
    assert {"hulls.png", "histograms.png", "matches.png"} <= set(pngs)


def test_points_json_and_ply(
    scene: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    args = ["points", "--calib", scene["calib"], scene["left"], scene["right"]]
    code, out, _ = _run(args, capsys)
    assert code == 0
    pts = json.loads(out)["points"]
    assert len(pts) > 100
    p = pts[0]
    # the right-image column is the left one minus the disparity f·B/Z
    disparity = p["left"][0] - p["right"][0]
    assert disparity == pytest.approx(FOCAL * BASELINE / p["xyz"][2], abs=0.5)
    ply = tmp_path / "points.ply"
    code, _, _ = _run([*args, "--format", "ply", "--out", ply], capsys)
    assert code == 0
    text = ply.read_text()
    assert text.startswith("ply\n") and f"element vertex {len(pts)}" in text


def test_python_dash_m_runs_the_same_command(scene: dict[str, Path]) -> None:
    proc = subprocess.run(
        [sys.executable, "-m", "scenespeak", "db", "list", "--db", str(scene["db"])],
        capture_output=True,
        text=True,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr
    assert "astronaut" in proc.stdout


def test_usage_error_is_not_a_traceback(capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = _run(["describe", "--format", "xml"], capsys)
    assert code == 2
    assert "Traceback" not in err


# --------------------------------------------------------------------------------------------
# bad input: one line naming the file, exit 2


def _missing_image(scene: dict[str, Path], tmp: Path) -> dict[str, Path]:
    return {"left": scene["left"].with_name("nope.png")}


def _corrupt_image(scene: dict[str, Path], tmp: Path) -> dict[str, Path]:
    bad = tmp / "corrupt.png"
    bad.write_bytes(b"\x89PNG\r\n\x1a\n" + bytes(range(256)) * 4)
    return {"right": bad}


def _empty_image(scene: dict[str, Path], tmp: Path) -> dict[str, Path]:
    empty = tmp / "empty.png"
    empty.write_bytes(b"")
    return {"left": empty}


def _sizes_differ(scene: dict[str, Path], tmp: Path) -> dict[str, Path]:
    small = cv2.resize(cv2.imread(str(scene["right"])), (320, 240))
    path = tmp / "small_right.png"
    cv2.imwrite(str(path), small)
    return {"right": path}


def _calib_nan(scene: dict[str, Path], tmp: Path) -> dict[str, Path]:
    calib = tmp / "nan.json"
    calib.write_text('{"baseline": NaN, "hfov_deg": 60, "image_size": [640, 480]}')
    return {"calib": calib}


def _calib_singular(scene: dict[str, Path], tmp: Path) -> dict[str, Path]:
    k = [[554.0, 0, 320], [0, 554.0, 240], [0, 0, 1]]
    full = {
        "image_size": [W, H],
        "K_left": [[554.0, 0, 320], [0, 0, 240], [0, 0, 1]],  # fy = 0: singular
        "K_right": k,
        "dist_left": [0, 0, 0, 0, 0],
        "dist_right": [0, 0, 0, 0, 0],
        "R": np.eye(3).tolist(),
        "T": [-0.12, 0, 0],
    }
    calib = tmp / "singular.json"
    calib.write_text(json.dumps(full))
    return {"calib": calib}


def _calib_other_size(scene: dict[str, Path], tmp: Path) -> dict[str, Path]:
    calib = tmp / "small.json"
    calib.write_text(json.dumps({"baseline": 0.12, "hfov_deg": 60, "image_size": [320, 240]}))
    return {"calib": calib}


def _db_text_file(scene: dict[str, Path], tmp: Path) -> dict[str, Path]:
    text = tmp / "notes.db"
    text.write_text("these are my notes, not a database\n")
    return {"db": text}


def _db_someone_elses(scene: dict[str, Path], tmp: Path) -> dict[str, Path]:
    other = tmp / "other.db"
    with sqlite3.connect(other) as conn:
        conn.execute("CREATE TABLE songs(title TEXT)")
    return {"db": other}


def _db_empty(scene: dict[str, Path], tmp: Path) -> dict[str, Path]:
    from scenespeak.perception.recognition import ObjectDatabase

    empty = tmp / "empty.db"
    ObjectDatabase.create(empty).close()
    return {"db": empty}


def _textureless(scene: dict[str, Path], tmp: Path) -> dict[str, Path]:
    gray = np.full((H, W, 3), 128, np.uint8)
    return {
        "left": _write(tmp / "blank_left.png", gray),
        "right": _write(tmp / "blank_right.png", gray),
    }


BAD_INPUT = {
    # case: (what to put in place of the good file(s), words the one-line error must hold)
    "missing image": (_missing_image, ("nope.png", "no such file")),
    "corrupt image": (_corrupt_image, ("corrupt.png", "cannot be read")),
    "empty image": (_empty_image, ("empty.png", "empty")),
    "left and right of different sizes": (_sizes_differ, ("small_right.png", "320x240")),
    "calibration with NaN": (_calib_nan, ("nan.json",)),
    "calibration with a singular matrix": (_calib_singular, ("singular.json", "K_left")),
    "calibration for another image size": (_calib_other_size, ("small.json", "320x240")),
    "database that is a text file": (
        _db_text_file,
        ("notes.db", "not a scenespeak object database"),
    ),
    "database of another program": (_db_someone_elses, ("other.db",)),
    "empty database": (_db_empty, ("empty.db", "no objects")),
    "textureless scene": (_textureless, ("blank_left.png", "texture")),
}


@pytest.mark.parametrize("case", list(BAD_INPUT))
def test_bad_input_is_one_line_naming_the_file(
    case: str, scene: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    make, needles = BAD_INPUT[case]
    code, _, err = _run(_describe(scene, **make(scene, tmp_path)), capsys)
    _assert_one_line_error(code, err, *needles)


def test_missing_training_image_leaves_the_database_as_it_was(
    scene: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    db = tmp_path / "copy.db"
    db.write_bytes(scene["db"].read_bytes())
    before = db.read_bytes()
    args = ["db", "add", "--db", db, "--label", "cat", scene["train_coffee"], tmp_path / "x.png"]
    code, _, err = _run(args, capsys)
    _assert_one_line_error(code, err, "x.png")
    assert db.read_bytes() == before


# --------------------------------------------------------------------------------------------
# rendered scenes (need scenespeak.tools.scenes and pybullet)


@pytest.mark.slow
def test_demo_prints_sentences(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    pytest.importorskip("scenespeak.tools.scenes")
    code, out, err = _run(["demo", tmp_path / "demo", "--quiet"], capsys)
    assert code == 0, err
    assert (tmp_path / "demo" / "scene_000" / "left.png").exists()
    assert (tmp_path / "demo" / "objects.db").exists()
    sentences = [line for line in out.splitlines() if line.startswith("The ")]
    assert sentences, out
    assert all(s.endswith(".") for s in sentences)
    meta = json.loads((tmp_path / "demo" / "dataset.json").read_text())
    labels = [o["label"] for o in meta["objects"]]
    assert any(label in out for label in labels)
