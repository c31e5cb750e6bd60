"""The fuzzing corpus of issue 12: every bad input gets one line naming the file, exit 2.

The corpus (``scenespeak.tools.fuzz``, more than 1,000 generated inputs) is built once per
session in a forked child. The default run takes a fixed stratified sample (every family, a
fixed seed) through the forking runner and a few through the real ``python -m scenespeak``
entry point; the whole corpus runs under ``-m slow`` (and ``benchmarks/fuzz_corpus.py``).
A failure lists each case's class and reason.
"""

from __future__ import annotations

import json
import os
import random
import subprocess
import sys
from collections import defaultdict
from pathlib import Path

import pytest

from scenespeak.tools.fuzz.corpus import Case, build
from scenespeak.tools.fuzz.runner import CLASSES, Outcome, summarise

BAD = [c for c in CLASSES if c != "clean"]

#: The whole corpus takes minutes: run it with SCENESPEAK_LONG_TESTS=1 (CI runs the sample).
LONG = pytest.mark.skipif(
    not os.environ.get("SCENESPEAK_LONG_TESTS"),
    reason="the whole corpus takes minutes; set SCENESPEAK_LONG_TESTS=1 (or run "
    "benchmarks/fuzz_corpus.py)",
)


@pytest.fixture(scope="session")
def corpus(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, list[Case]]:
    root = tmp_path_factory.mktemp("fuzz")
    pid = os.fork()
    if pid == 0:  # pragma: no cover - child: OpenCV's threads start here, not in the runner
        code = 0
        try:
            build(root, write=True)
        except BaseException:
            import traceback

            traceback.print_exc()
            code = 1
        os._exit(code)
    _, status = os.waitpid(pid, 0)
    assert os.waitstatus_to_exitcode(status) == 0, "building the corpus failed"
    return root, build(root, write=False)


def sample(
    cases: list[Case], per_family: int, seed: int = 0, *, errors_only: bool = True
) -> list[Case]:
    """A fixed stratified sample: ``per_family`` cases of each family."""
    groups: dict[str, list[Case]] = defaultdict(list)
    for c in cases:
        if not errors_only or (c.expect == "error" and c.timeout <= 30 and "fifo" not in c.id):
            groups[c.family].append(c)
    rng = random.Random(seed)
    out: list[Case] = []
    for family in sorted(groups):
        items = groups[family]
        out.extend(rng.sample(items, min(per_family, len(items))))
    return out


def run_cases(
    cases: list[Case], *, root: Path, mode: str = "fork", workers: int = 2
) -> list[Outcome]:
    """Run cases with the corpus runner in a fresh process (never forked from pytest's, which
    may have OpenCV threads running), and read back its outcomes."""
    ids = root / f"ids-{os.getpid()}.txt"
    results = root / f"results-{os.getpid()}.jsonl"
    ids.write_text("\n".join(c.id for c in cases), encoding="utf-8")
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "scenespeak.tools.fuzz",
            "run",
            str(root),
            "--ids",
            str(ids),
            "--results",
            str(results),
            "--mode",
            mode,
            "--workers",
            str(workers),
        ],
        capture_output=True,
        text=True,
        timeout=3600,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    lines = results.read_text(encoding="utf-8").splitlines()
    return [Outcome(**json.loads(line)) for line in lines]


def _report(outcomes: list[Outcome]) -> str:
    bad = [o for o in outcomes if o.cls != "clean"]
    lines = [f"{o.cls:15s} {o.id}: {o.reason}" for o in bad[:40]]
    return "\n".join([str(summarise(outcomes)["classes"]), *lines])


def test_corpus_is_large_and_covers_every_family(corpus: tuple[Path, list[Case]]) -> None:
    _, cases = corpus
    assert len(cases) >= 1000
    families = {c.family for c in cases}
    assert {
        "images",
        "masks",
        "calibration",
        "database",
        "db commands",
        "dataset",
        "truth",
        "options",
        "api",
        "rgbd",
        "watch",
        "annotate",
        "ask",
        "serve",
    } <= families
    assert len({c.id for c in cases}) == len(cases)


def test_corpus_sample_is_clean(corpus: tuple[Path, list[Case]]) -> None:
    root, cases = corpus
    picked = sample(cases, per_family=4, seed=12)  # 14 families: 56 cases
    outcomes = run_cases(picked, root=root, workers=2)
    assert all(o.cls == "clean" for o in outcomes), _report(outcomes)
    assert max(o.rss_mb for o in outcomes) < 2048


def test_corpus_sample_through_the_real_entry_point(corpus: tuple[Path, list[Case]]) -> None:
    root, cases = corpus
    cli = [c for c in cases if c.argv is not None]
    picked = sample(cli, per_family=1, seed=3)
    outcomes = run_cases(picked, root=root, workers=2, mode="exec")
    assert all(o.cls == "clean" for o in outcomes), _report(outcomes)


def test_non_regular_files_never_block(corpus: tuple[Path, list[Case]]) -> None:
    root, cases = corpus
    picked = [c for c in cases if "fifo" in c.id or "dev-zero" in c.id][:8]
    assert picked
    outcomes = run_cases(picked, root=root, workers=2)
    assert all(o.cls == "clean" and o.seconds < 10 for o in outcomes), _report(outcomes)


def test_a_hang_is_classified_as_a_hang(corpus: tuple[Path, list[Case]]) -> None:
    """The runner itself: a case that blocks is killed at its timeout and called a hang."""
    root, _ = corpus
    import time

    from scenespeak.tools.fuzz.runner import run_cases as run_here

    case = Case("selftest/sleep", "selftest", api=lambda: time.sleep(60), timeout=1.0)
    (outcome,) = run_here([case], root=root)
    assert outcome.cls == "hang"


@pytest.mark.slow
@LONG
def test_whole_corpus_is_clean(corpus: tuple[Path, list[Case]]) -> None:
    root, cases = corpus
    outcomes = run_cases(cases, root=root, workers=2)
    counts = summarise(outcomes)["classes"]
    assert isinstance(counts, dict)
    assert all(counts[c] == 0 for c in BAD), _report(outcomes)
    assert max(o.rss_mb for o in outcomes) < 2048
    assert max(o.seconds for o in outcomes) < 30
