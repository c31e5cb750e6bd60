"""``describe --summary/--viewer/--about`` and ``scenespeak ask`` (issue 13) on a real stereo
pair of rendered photo cards (``cardscene``): the astronaut card left of and behind the coffee
card, both in front of the camera."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from cardscene import BASELINE, HFOV, H, W, card_pair, photo, write_rgb
from scenespeak.cli import main

CARDS = {"astronaut": (-0.25, 1.2, 0.22), "coffee": (0.22, 1.0, 0.2)}


@pytest.fixture(scope="module")
def scene(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    root = tmp_path_factory.mktemp("ask_scene")
    left, right = card_pair(CARDS)
    files = {
        "left": write_rgb(root / "left.png", left),
        "right": write_rgb(root / "right.png", right),
        "calib": root / "calib.json",
        "db": root / "objects.db",
    }
    files["calib"].write_text(
        json.dumps({"baseline": BASELINE, "hfov_deg": HFOV, "image_size": [W, H]})
    )
    for name in CARDS:
        img = write_rgb(root / f"{name}.png", photo(name, (240, 240)))
        assert main(["db", "add", "--db", str(files["db"]), "--label", name, str(img)]) == 0
    saved = root / "described.json"
    code = main(
        [*_inputs(files), "--format", "json", "--no-unknown", "--viewer"],
    )
    assert code == 0
    files["saved"] = saved
    return files


def _inputs(f: dict[str, Path]) -> list[str]:
    return ["describe", "--db", str(f["db"]), "--calib", str(f["calib"]), str(f["left"]),
            str(f["right"])]  # fmt: skip


def _run(args: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture(scope="module")
def described(scene: dict[str, Path]) -> Path:
    out = subprocess.run(
        [sys.executable, "-m", "scenespeak", *_inputs(scene), "--format", "json", "--no-unknown",
         "--viewer", "--summary"],
        capture_output=True, text=True, check=True,
    )  # fmt: skip
    scene["saved"].write_text(out.stdout)
    return scene["saved"]


def test_describe_json_adds_viewer_and_summary(described: Path) -> None:
    d = json.loads(described.read_text())
    assert {"objects", "relations", "skipped", "viewer", "summary"} <= set(d)
    names = {o["label"] for o in d["objects"]}
    assert names == set(CARDS)
    entries = {v["object"]: v for v in d["viewer"]}
    assert set(entries) == names
    for v in entries.values():
        assert {"object", "sentence", "primary", "distance_m"} <= set(v)
        assert "me" in v["sentence"]
    assert entries["astronaut"]["secondary"] == "left" or entries["astronaut"]["primary"] == "left"
    assert entries["coffee"]["secondary"] == "right" or entries["coffee"]["primary"] == "right"
    assert entries["astronaut"]["distance_m"] == pytest.approx(1.2, abs=0.15)
    assert "the astronaut" in d["summary"] and "the coffee" in d["summary"]
    assert d["camera"]["baseline_m"] == pytest.approx(BASELINE)


def test_describe_text_views(scene: dict[str, Path], capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = _run([*_inputs(scene), "--no-unknown", "--summary"], capsys)
    assert code == 0
    lines = out.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("From left to right I see the astronaut")
    code, out, _ = _run([*_inputs(scene), "--no-unknown", "--viewer"], capsys)
    assert code == 0 and len(out.strip().splitlines()) == 2
    assert "The astronaut is" in out and "me" in out
    code, out, _ = _run([*_inputs(scene), "--no-unknown", "--about", "coffee", "--format", "json"],
                        capsys)  # fmt: skip
    d = json.loads(out)
    assert code == 0 and d["about"] == "coffee"
    assert d["relations"] and all(r["argument"] == "coffee" for r in d["relations"])
    code, _, err = _run([*_inputs(scene), "--no-unknown", "--about", "cup"], capsys)
    assert code == 2 and "cup" in err and "Traceback" not in err


def test_ask_on_a_saved_scene(described: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = _run(
        ["ask", "Is the astronaut to the left of the coffee?", "--scene", described,
         "--format", "json"], capsys,
    )  # fmt: skip
    d = json.loads(out)
    assert code == 0 and d["kind"] == "yes-no" and d["objects"] == ["astronaut", "coffee"]
    assert d["answer"].startswith(("Yes", "Mostly")) and 0.5 <= d["degree"] <= 1.0
    code, out, _ = _run(["ask", "where is the coffee?", "--scene", described], capsys)
    assert code == 0 and out.startswith("The coffee is")
    code, out, _ = _run(["ask", "where is the cup?", "--scene", described, "--format", "json"],
                        capsys)  # fmt: skip
    assert code == 0 and json.loads(out)["answer"] == "I don't see a cup."
    assert json.loads(out)["kind"] == "unknown"


def test_ask_from_images_equals_ask_on_the_saved_scene(
    scene: dict[str, Path], described: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    q = "which object is closest to me?"
    _, saved, _ = _run(["ask", q, "--scene", described, "--format", "json"], capsys)
    args = ["ask", q, *_inputs(scene)[1:], "--no-unknown", "--format", "json"]
    code, live, _ = _run(args, capsys)
    assert code == 0 and json.loads(live) == json.loads(saved)
    assert json.loads(live)["objects"] == ["coffee"]


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["ask", "where is the mug?"], "--scene"),
        (["ask", "where is the mug?", "--scene", "/nonexistent/scene.json"], "no such file"),
    ],
)
def test_ask_bad_input_is_one_line(
    args: list[str], needle: str, capsys: pytest.CaptureFixture[str]
) -> None:
    code, _, err = _run(args, capsys)
    assert code == 2 and len(err.strip().splitlines()) == 1 and needle in err


def test_ask_bad_scene_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / "bad.json"
    bad.write_text('{"relations": []}')
    code, _, err = _run(["ask", "where is the mug?", "--scene", bad], capsys)
    assert code == 2 and "bad.json" in err and "objects" in err
