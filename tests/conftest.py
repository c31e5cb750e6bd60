"""Shared test settings and fixtures.

Hypothesis runs derandomised (a fixed seed), without deadlines (the machine is shared and
noisy), so CI results are reproducible.

Test modules live in folders that mirror the package (``perception/``, ``spatial/``, ``tools/``,
``cli/`` …); their file names stay unique, and helpers shared by several folders (such as
``cardscene.py``) sit here, in ``tests/``, which is put on ``sys.path``.

The real photographs (``../shared/data/real`` beside the project, read its README) are reached
through the ``real_data`` fixture, which skips with the reason when the folder is absent.
``SCENESPEAK_REAL_DATA`` points elsewhere.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import pytest
from hypothesis import HealthCheck, settings

TESTS = Path(__file__).resolve().parent
ROOT = TESTS.parent
if str(TESTS) not in sys.path:
    sys.path.insert(0, str(TESTS))

settings.register_profile(
    "scenespeak",
    derandomize=True,
    deadline=None,
    max_examples=60,
    suppress_health_check=[HealthCheck.too_slow],
)
settings.load_profile("scenespeak")


def real_data_root() -> Path | None:
    """The folder of real data (``../shared/data/real``), or None when it is absent."""
    env = os.environ.get("SCENESPEAK_REAL_DATA")
    candidates = [Path(env)] if env else []
    candidates.append(ROOT.parent / "shared" / "data" / "real")
    for path in candidates:
        if path.is_dir():
            return path
    return None


@pytest.fixture(scope="session")
def real_data() -> Path:
    """The real-data folder; the test is skipped with the reason when it is absent."""
    root = real_data_root()
    if root is None:
        pytest.skip("real data folder ../shared/data/real is absent (set SCENESPEAK_REAL_DATA)")
    return root


# The rendered sequence and database of the live tests (tests/live, tests/cli/test_watch.py).
from livedata import live_data  # noqa: E402, F401
