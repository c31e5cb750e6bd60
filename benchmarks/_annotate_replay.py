"""A stand-in task for ``bench_annotate.py``: replays recorded scene results, no image work.

The workers import it by name (the benchmark puts ``benchmarks/`` on their PYTHONPATH). Each
worker reads the recorded lines once (``SCENESPEAK_REPLAY``: a JSON Lines file of a real
``annotate`` run) and answers every scene folder — a link to a real scene — with that scene's
lines renamed, so the client sees exactly the traffic of a real run at no cost.
"""

from __future__ import annotations

import json
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from scenespeak.tools.output import SceneRecord

_RECORDED: dict[str, list[dict[str, Any]]] = {}


def _recorded() -> dict[str, list[dict[str, Any]]]:
    if not _RECORDED:
        with open(os.environ["SCENESPEAK_REPLAY"], encoding="utf-8") as fh:
            for line in fh:
                d = json.loads(line)
                _RECORDED.setdefault(d["scene"], []).append(d)
    return _RECORDED


def replay_batch(folders: Sequence[str], database: Any) -> list[SceneRecord]:
    """The recorded lines of each folder's real scene, under the folder's own name."""
    if database is not None:
        database.get()  # the shipped database is opened as in a real run
    recorded = _recorded()
    out = []
    for folder in folders:
        name = Path(folder).name
        real = Path(os.path.realpath(folder)).name
        lines = tuple(json.dumps({**d, "scene": name}) for d in recorded.get(real, []))
        out.append(SceneRecord(name, lines, objects=3))
    return out
