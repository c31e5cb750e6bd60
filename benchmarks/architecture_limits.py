"""The architecture limits of issue 9, measured: complexity, module size, signature width.

For every module under ``src/scenespeak`` (or ``--src``): its lines; every function with a
cyclomatic complexity above 15 (radon's count: 1 + branches, boolean operators, comprehension
conditions, ...); every signature with more than 8 parameters (``self``/``cls`` not counted;
``*args``/``**kwargs`` count one each) that is not an options object. Prints the offenders
and the totals; ``tests/architecture/test_limits.py`` keeps them at zero outside the scene
generator and the listed exceptions.

Run::

    python benchmarks/architecture_limits.py
    python benchmarks/architecture_limits.py --src /some/checkout/src/scenespeak
"""

from __future__ import annotations

import argparse
import ast
from dataclasses import dataclass
from pathlib import Path

MAX_COMPLEXITY = 15
MAX_LINES = 600
MAX_PARAMETERS = 8
#: The scene generator may be as complex as the scenes it builds (issue 9).
GENERATOR = (
    "tools/scenes.py",
    "tools/scene_layout.py",
    "tools/scene_model.py",
    "tools/render.py",
)


@dataclass(frozen=True)
class Finding:
    module: str
    name: str
    value: int


def parameters(node: ast.FunctionDef | ast.AsyncFunctionDef) -> int:
    a = node.args
    names = [p.arg for p in (*a.posonlyargs, *a.args, *a.kwonlyargs)]
    n = len(names) - (1 if names and names[0] in ("self", "cls") else 0)
    return n + (a.vararg is not None) + (a.kwarg is not None)


def complexity(source: str) -> list[tuple[str, int]]:
    """(qualified name, cyclomatic complexity) of every function, by radon."""
    from radon.complexity import cc_visit

    out: dict[str, int] = {}
    for block in cc_visit(source):
        kind = type(block).__name__
        if kind == "Function":
            name = f"{block.classname}.{block.name}" if block.classname else block.name
            out[name] = max(out.get(name, 0), block.complexity)
        elif kind == "Class":
            for m in block.methods:
                name = f"{block.name}.{m.name}"
                out[name] = max(out.get(name, 0), m.complexity)
    return sorted(out.items())


def measure(src: Path) -> dict[str, list[Finding]]:
    found: dict[str, list[Finding]] = {"complexity": [], "lines": [], "parameters": []}
    for path in sorted(src.rglob("*.py")):
        rel = path.relative_to(src).as_posix()
        text = path.read_text(encoding="utf-8")
        lines = text.count("\n")
        if lines > MAX_LINES:
            found["lines"].append(Finding(rel, "", lines))
        for name, cc in complexity(text):
            if cc > MAX_COMPLEXITY and rel not in GENERATOR:
                found["complexity"].append(Finding(rel, name, cc))
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                n = parameters(node)
                if n > MAX_PARAMETERS:
                    found["parameters"].append(Finding(rel, node.name, n))
    return found


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    default = Path(__file__).resolve().parents[1] / "src" / "scenespeak"
    ap.add_argument("--src", type=Path, default=default)
    args = ap.parse_args(argv)
    found = measure(args.src)
    limits = {"complexity": MAX_COMPLEXITY, "lines": MAX_LINES, "parameters": MAX_PARAMETERS}
    for what, items in found.items():
        print(f"== {what} above {limits[what]}: {len(items)}")
        for f in sorted(items, key=lambda f: -f.value):
            print(f"  {f.value:5d}  {f.module}  {f.name}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
