"""Issue 9's limits, kept true: complexity <= 15 (radon), modules <= ~600 lines, <= 8 parameters.

``benchmarks/architecture_limits.py`` measures them; this test fails when a function, module or
signature goes over a limit that is not in ``KNOWN`` below, or when a known one grows. The
known ones are what is left to split (docs/architecture.md says which); remove an entry once
it is within the limit (the test says so).
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "benchmarks"))
limits = pytest.importorskip("architecture_limits", reason="benchmarks/ not beside the tests")
pytest.importorskip("radon", reason="radon measures the complexity (pip install radon)")

#: How much a known exception may still grow: none.
SLACK = {"lines": 0, "complexity": 0, "parameters": 0}
#: (kind, module, name) → the value measured when it was listed.
KNOWN: dict[tuple[str, str, str], int] = {
    # Empty: nothing is over a limit. (The Typer commands with many options take one options
    # object each, a frozen dataclass whose fields declare the flags: cli/_options.py.)
}


def test_limits() -> None:
    found = limits.measure(ROOT / "src" / "scenespeak")
    over = []
    for kind, items in found.items():
        for f in items:
            allowed = KNOWN.get((kind, f.module, f.name))
            if allowed is not None:
                allowed += SLACK[kind]
            if allowed is None or f.value > allowed:
                over.append(f"{kind}: {f.module} {f.name} = {f.value} (allowed {allowed})")
    assert not over, "over the limits of issue 9:\n" + "\n".join(over)


def test_known_exceptions_are_still_needed() -> None:
    found = limits.measure(ROOT / "src" / "scenespeak")
    present = {(kind, f.module, f.name) for kind, items in found.items() for f in items}
    # An exception whose module is gone or now within the limit should be deleted from KNOWN;
    # modules of other issues may be mid-change, so only say which.
    stale = sorted(k for k in KNOWN if k not in present)
    if stale:
        pytest.skip(f"within the limits now, remove from KNOWN: {stale}")
