"""The command line starts light: ``--help`` and the CLI package import no heavy library.

Commands import NumPy, SciPy, OpenCV, matplotlib and rich inside their functions, when they
run; ``scenespeak --help`` (and every command's ``--help``) must not pay for them. Timing is
measured by ``benchmarks/bench_startup.py``; this pins what makes it possible.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

HEAVY = ("numpy", "scipy", "cv2", "matplotlib", "rich", "numba", "skimage")


def _loaded_after(code: str) -> list[str]:
    probe = "\n".join(
        ["import sys", code, f"print(' '.join(m for m in {HEAVY!r} if m in sys.modules))"]
    )
    out = subprocess.run(
        [sys.executable, "-c", probe],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
        env=dict(os.environ),
    )
    assert out.returncode == 0, out.stderr
    return out.stdout.split()


def test_importing_the_cli_loads_no_heavy_library() -> None:
    assert _loaded_after("import scenespeak.cli, scenespeak.cli._app") == []


@pytest.mark.parametrize("args", [["--help"], ["describe", "--help"], ["db", "--help"]])
def test_help_loads_no_heavy_library(args: list[str]) -> None:
    code = (
        "from scenespeak.cli import main\n"
        "import contextlib, io\n"
        "with contextlib.redirect_stdout(io.StringIO()):\n"
        f"    status = main({args!r})\n"
        "assert status == 0, status"
    )
    assert _loaded_after(code) == []


def test_help_does_not_load_a_second_click() -> None:
    """Typer >= 0.2x runs on its own copy of click; the real one would be loaded for nothing."""
    typer = pytest.importorskip("typer")
    if getattr(typer, "_click", None) is None:
        pytest.skip("this Typer runs on click itself")
    code = (
        "import sys, contextlib, io\n"
        "from scenespeak.cli import main\n"
        "with contextlib.redirect_stdout(io.StringIO()):\n"
        "    assert main(['--help']) == 0\n"
        "print('click' in sys.modules)"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=True
    )
    assert out.stdout.strip() == "False"


def _help_run(env: dict[str, str]) -> tuple[str, list[str]]:
    code = (
        "import sys\n"
        "from scenespeak.cli import main\n"
        "status = main(['--help'])\n"
        "print(' '.join(m for m in ('typer', 'click') if m in sys.modules), file=sys.stderr)\n"
        "sys.exit(status)\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=True,
        env={**os.environ, **env},
    )  # fmt: skip
    return out.stdout, out.stderr.split()


def test_top_level_help_is_cached_and_the_same(tmp_path: Path) -> None:
    """`scenespeak --help` renders once per version of the CLI, Typer and terminal width, then
    prints the cached text without importing Typer; the text is the one Typer renders."""
    env = {"XDG_CACHE_HOME": str(tmp_path), "COLUMNS": "100"}
    first, loaded = _help_run(env)
    assert "typer" in loaded and first.startswith("Usage: scenespeak")
    cached = list((tmp_path / "scenespeak").glob("help-*.txt"))
    assert len(cached) == 1 and cached[0].read_text(encoding="utf-8") == first
    again, loaded = _help_run(env)
    assert again == first and loaded == []
    fresh, loaded = _help_run({**env, "SCENESPEAK_NO_HELP_CACHE": "1"})
    assert fresh == first and "typer" in loaded
    narrow, _ = _help_run({**env, "COLUMNS": "60"})
    assert narrow != first and len(list((tmp_path / "scenespeak").glob("help-*.txt"))) == 2


def test_help_cache_that_cannot_be_written_is_no_error(tmp_path: Path) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    text, loaded = _help_run({"XDG_CACHE_HOME": str(blocker)})
    assert text.startswith("Usage: scenespeak") and "typer" in loaded
