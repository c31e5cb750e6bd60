"""The package's layering (docs/architecture.md), read from the source's import statements.

Data flows one way: ``geometry`` underneath; ``perception`` (pixels → 3-D objects) and
``spatial`` (regions → words) on top, joined by ``contract.SpatialObject``; ``pipeline``
composes the stages; ``tools`` and ``cli`` sit above. Every ``import`` counts, also those
inside functions (lazy imports are still dependencies).
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[2] / "src" / "scenespeak"

#: Leaf modules every room may use: errors, safe reading and text cleaning, size limits.
BASE = {"errors", "cleantext", "safeio", "safetext", "limits", "overrides"}
#: The composition layer: the pipelines and the input readers that feed them.
COMPOSE = {
    "pipeline",
    "pipeline_threads",
    "description",
    "pipeline_rgbd",
    "rgbd_description",
    "rgbd_regions",
    "inputs",
    "scene_folder",
}
_BELOW_COMPOSE = BASE | {"geometry", "contract", "perception", "spatial"}
#: room → the rooms of scenespeak it may import (itself always).
ALLOWED: dict[str, set[str]] = {
    **{leaf: BASE - {leaf} for leaf in BASE},
    "contract": {"errors"},
    "geometry": set(BASE),
    "spatial": BASE | {"geometry", "contract"},
    "perception": BASE | {"geometry", "contract"},
    **{name: _BELOW_COMPOSE | COMPOSE for name in COMPOSE},
    "live": _BELOW_COMPOSE | COMPOSE,
    "tools": _BELOW_COMPOSE | COMPOSE | {"live"},
    "cli": _BELOW_COMPOSE | COMPOSE | {"live", "tools"},
}
#: Known breaches of the layering, landed by other issues during this session (to fix: tools
#: should not call the CLI).
BREACHES = {
    ("tools/fuzz/runner.py", "cli"),
    ("tools/rgbd_eval.py", "cli"),
}
#: Modules outside the rooms: the package's root and its compatibility aliases.
ROOT_MODULES = {"__init__", "__main__", "forces", "language"}


def _room(path: Path) -> str:
    rel = path.relative_to(SRC)
    return rel.parts[0] if len(rel.parts) > 1 else rel.stem


def _imports(path: Path) -> set[str]:
    """Every ``scenespeak.*`` module named by an import in the file (absolute or relative)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    pkg = ".".join(("scenespeak", *path.relative_to(SRC).parent.parts))
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = pkg.rsplit(".", node.level - 1)[0] if node.level > 1 else pkg
                name = f"{base}.{node.module}" if node.module else base
            else:
                name = node.module or ""
            found.add(name)
            found |= {f"{name}.{a.name}" for a in node.names}
    return {m for m in found if m == "scenespeak" or m.startswith("scenespeak.")}


def _target_room(module: str) -> str | None:
    parts = module.split(".")
    if len(parts) < 2:
        return None
    head = parts[1]
    if head in ALLOWED:
        return head
    return None  # names imported from a module (``from scenespeak.x import name``)


MODULES = sorted(p for p in SRC.rglob("*.py") if _room(p) not in ROOT_MODULES)


@pytest.mark.parametrize("path", MODULES, ids=lambda p: p.relative_to(SRC).as_posix())
def test_each_room_imports_only_the_rooms_below(path: Path) -> None:
    room = _room(path)
    assert room in ALLOWED, f"{path}: a module outside the rooms of docs/architecture.md"
    bad = sorted(
        m
        for m in _imports(path)
        if (r := _target_room(m)) is not None
        and r != room
        and r not in ALLOWED[room]
        and (path.relative_to(SRC).as_posix(), r) not in BREACHES
    )
    assert not bad, f"{room} may import only {sorted(ALLOWED[room])}; {path.name} imports {bad}"


def test_the_contract_imports_only_numpy_and_the_errors() -> None:
    tree = ast.parse((SRC / "contract.py").read_text(encoding="utf-8"))
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names |= {a.name.split(".")[0] for a in node.names}
        elif isinstance(node, ast.ImportFrom) and not node.level:
            names.add((node.module or "").split(".")[0])
    stdlib = set(sys.stdlib_module_names) | {"__future__"}
    # numpy, and the package's error types (a leaf module that imports nothing of scenespeak)
    assert names - stdlib <= {"numpy", "scenespeak"}, names - stdlib
    inside = {
        n.module
        for n in ast.walk(tree)
        if isinstance(n, ast.ImportFrom) and (n.module or "").startswith("scenespeak")
    }
    assert inside <= {"scenespeak.errors"}, inside


def test_the_spatial_half_runs_without_perception() -> None:
    """Importing the spatial half loads nothing of perception (checked in a fresh process)."""
    import subprocess

    code = (
        "import sys, scenespeak.spatial.language, scenespeak.spatial.forces, "
        "scenespeak.geometry.polygons, scenespeak.contract; "
        "print(sorted(m for m in sys.modules if m.startswith('scenespeak.perception')))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout
    assert out.strip() == "[]"
