"""The command line starts light: ``--help`` and the CLI package import no heavy library.

Commands import NumPy, SciPy, OpenCV, matplotlib and rich inside their functions, when they
run; ``scenespeak --help`` (and every command's ``--help``) must not pay for them. Timing is
measured by ``benchmarks/bench_startup.py``; this pins what makes it possible.
"""

from __future__ import annotations

import os
import subprocess
import sys

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
