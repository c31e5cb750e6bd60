"""The generated data of the live benchmarks: a 640×480 database of the sequence objects and
rendered sequences, made by the repository's generator into a cache folder and reused.

Seeds: 100 and 101 are the *tuning* sequences (looked at while the tracker and the memory were
tuned); 200 and 201 are the *frozen evaluation* set, generated before any tuning and reported
as they come out (``docs/live.md``).
"""

from __future__ import annotations

import tempfile
from pathlib import Path

from scenespeak.tools.sequences import SCRIPTS, generate_sequence_set, sequence_database

TUNING_SEEDS = (100, 101)
FROZEN_SEEDS = (200, 201)
DEFAULT_CACHE = Path(tempfile.gettempdir()) / "scenespeak-live-bench"


def database(cache: Path) -> Path:
    """``cache/objects.db`` (rendered and learnt when missing)."""
    from scenespeak.pipeline import database_from_dataset

    db = cache / "objects.db"
    if not db.exists():
        sequence_database(cache / "train")
        database_from_dataset(cache / "train", db)
    return db


def sequences(cache: Path, seeds: tuple[int, ...], n_frames: int = 24, scripts=SCRIPTS) -> list:
    """Every script with every seed in ``cache/seq`` (rendered when missing)."""
    return generate_sequence_set(
        cache / "seq", seeds, scripts=scripts, n_frames=n_frames, progress=lambda n: None
    )
