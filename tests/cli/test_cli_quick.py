"""The quick ``ask --scene`` path (``cli/_quick.py``) against the full Typer command line.

Issue 16: ``ask --scene`` as a whole process in <= 0.3 s, so :func:`scenespeak.cli.main`
answers ``ask QUESTION --scene FILE`` without importing Typer. Here both paths run on the same
command lines — generated scenes saved with and without ``viewer``, a matrix of questions and of
bad inputs — and must print the same stdout and stderr and return the same exit status; the
quick path must really be taken (else the comparison would be vacuous) and must import no NumPy,
Typer, click or pydantic. Timing: ``benchmarks/bench_startup.py --scene``.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from scenespeak.cli import _full, _quick, main
from scenespeak.spatial.dialogue import scene_from_dict, viewer_entries
from scenespeak.tools.dialogue_eval import layout_scene

HEAVY = ("numpy", "scipy", "cv2", "typer", "click", "pydantic", "rich", "numba")

QUESTIONS = (
    "where is the {a}?",
    "Where is the {b}",
    "is the {a} to the left of the {b}?",
    "is the {a} behind the {b}?",
    "Can you tell me whether the {b} is in front of the {a}?",
    "is the {a} near the {b}?",
    "is the {a} between the {b} and the {c}?",
    "what is to the right of the {b}?",
    "what is near the {a}?",
    "which object is closest to me?",
    "which is the leftmost object?",
    "what do you see?",
    "where is the cup?",
    "is the cup left of the {a}?",
    "how tall is the moon",
    "",
    "   ",
    "where is the \x1b[31m{a}?",
    "où est le {a} ?",
)


@pytest.fixture(scope="module")
def saved(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path | list[str]]:
    """A generated scene saved as ``describe --format json`` would, with and without viewer."""
    root = tmp_path_factory.mktemp("quick")
    description = dict(layout_scene(3).description)
    plain = root / "plain.json"
    plain.write_text(json.dumps(description))
    description["viewer"] = viewer_entries(scene_from_dict(description))
    viewer = root / "viewer.json"
    viewer.write_text(json.dumps(description))
    names = [o.get("name", o["label"]) for o in description["objects"]]
    bad = {
        "not_json": "{objects: ",
        "not_a_scene": "[1, 2, 3]",
        "no_objects": '{"relations": []}',
        "bad_hull": '{"objects": [{"label": "mug", "hull": "square"}], "relations": []}',
        "deep": "[" * 100_000 + "]" * 100_000,
    }
    for name, text in bad.items():
        (root / f"{name}.json").write_text(text)
    (root / "latin1.json").write_bytes(b'{"objects": "\xe9"}')
    (root / "folder.json").mkdir()
    return {"plain": plain, "viewer": viewer, "root": root, "names": names}


def _both(args: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[tuple[int, str, str], ...]:
    quick = _quick.run(args)
    q_out, q_err = capsys.readouterr()
    assert quick is not None, f"the quick path did not take {args!r}"
    full = _full.main(args)
    f_out, f_err = capsys.readouterr()
    return (quick, q_out, q_err), (full, f_out, f_err)


@pytest.mark.parametrize("kind", ["plain", "viewer"])
@pytest.mark.parametrize("fmt", [[], ["--format", "json"], ["--format=text"], ["-q"]])
def test_quick_and_full_answer_alike(
    saved: dict[str, object], kind: str, fmt: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    a, b, *_, c = saved["names"]  # type: ignore[misc]
    for template in QUESTIONS:
        question = template.format(a=a, b=b, c=c)
        args = ["ask", question, "--scene", str(saved[kind]), *fmt]
        quick, full = _both(args, capsys)
        assert quick == full, args
        assert quick[0] == 0 and quick[1].strip() and not quick[2], args
    # Options before the question, and --scene=FILE.
    quick, full = _both(["ask", "--scene=" + str(saved[kind]), *fmt, f"where is the {a}?"], capsys)
    assert quick == full and quick[0] == 0


@pytest.mark.parametrize(
    "name",
    ["missing", "not_json", "not_a_scene", "no_objects", "bad_hull", "deep", "latin1", "folder"],
)
@pytest.mark.parametrize("fmt", ["text", "json"])
def test_bad_scene_files_give_the_same_one_line(
    saved: dict[str, Path], name: str, fmt: str, capsys: pytest.CaptureFixture[str]
) -> None:
    path = saved["root"] / f"{name}.json"
    quick, full = _both(["ask", "where is the mug?", "--scene", str(path), "--format", fmt], capsys)
    assert quick == full
    code, out, err = quick
    assert code == 2 and not out and len(err.splitlines()) == 1, quick
    assert err.startswith("scenespeak: error: ") and f"{name}.json" in err
    assert "Traceback" not in err


@pytest.mark.parametrize(
    "args",
    [
        ["ask", "where is the mug?"],  # no --scene: describe's inputs, or a usage error
        ["ask", "--scene", "s.json"],  # no question
        ["ask", "where?", "why?", "--scene", "s.json"],  # two questions
        ["ask", "where?", "--scene", "s.json", "--format", "xml"],
        ["ask", "where?", "--scene", "s.json", "--scene", "t.json"],
        ["ask", "where?", "--scene"],
        ["ask", "where?", "--scene", "--format", "json"],
        ["ask", "where?", "--scene", "s.json", "--db", "objects.db"],
        ["ask", "where?", "--scene", "s.json", "--help"],
        ["ask", "--help"],
        ["ask", "-where?", "--scene", "s.json"],
        ["ask", "where?", "--scene", "s.json", "--"],
        ["ask", "where?", "--scene", "s.json", "-qq"],
        ["--limit", "max_json_bytes=10", "ask", "where?", "--scene", "s.json"],
        ["describe", "--help"],
        ["--help"],
        [],
    ],
)
def test_anything_else_goes_to_the_full_command_line(args: list[str]) -> None:
    assert _quick.parse_ask(args) is None


@pytest.mark.parametrize(
    "args",
    [
        ["ask", "where?", "--scene", "s.json", "--format", "xml"],
        ["ask", "--scene", "s.json"],
        ["ask", "where?", "--scene", "s.json", "--frmat", "json"],
    ],
)
def test_usage_errors_are_the_full_command_lines(
    args: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    code = main(args)
    out, err = capsys.readouterr()
    assert code == 2 and not out and len(err.splitlines()) == 1
    assert "(see: scenespeak ask --help)" in err


def _modules_after(args: list[str]) -> tuple[int, str, list[str]]:
    probe = (
        "import sys\n"
        "from scenespeak.cli import main\n"
        f"status = main({args!r})\n"
        f"print(' '.join(m for m in {HEAVY!r} if m in sys.modules), file=sys.stderr)\n"
        "sys.exit(status)\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", probe], capture_output=True, text=True, timeout=120,
        check=False, env=dict(os.environ),
    )  # fmt: skip
    *_, loaded = out.stderr.splitlines() or [""]
    return out.returncode, out.stdout, loaded.split()


@pytest.mark.parametrize("kind", ["plain", "viewer"])
def test_the_quick_path_imports_no_heavy_library(saved: dict[str, Path], kind: str) -> None:
    code, out, loaded = _modules_after(
        ["ask", "where is the mug?", "--scene", str(saved[kind]), "--format", "json"]
    )
    assert code == 0 and json.loads(out)["kind"] in {"where", "unknown"}
    assert loaded == []
    code, _, loaded = _modules_after(["ask", "where is the mug?", "--scene", "/nonexistent.json"])
    assert code == 2 and loaded == []
    # The probe can see them: the full command line does import Typer.
    _, _, loaded = _modules_after(["ask", "--scene", "/nonexistent.json"])
    assert "typer" in loaded
