"""``python -m scenespeak.tools.fuzz build|run|one ROOT [...]``."""

from __future__ import annotations

import argparse
import json
import os
import random
import sys
from pathlib import Path


def _build_in_child(root: Path) -> None:
    """Write the corpus files in a child process (the runner itself never starts OpenCV)."""
    pid = os.fork()
    if pid == 0:  # pragma: no cover - child
        code = 0
        try:
            from scenespeak.tools.fuzz.corpus import build

            build(root, write=True)
        except BaseException:
            import traceback

            traceback.print_exc()
            code = 1
        os._exit(code)
    _, status = os.waitpid(pid, 0)
    if os.waitstatus_to_exitcode(status) != 0:
        raise SystemExit("building the corpus failed")


def _preimport() -> None:
    """Import what the cases use once, here: every forked case shares it (no OpenCV threads
    start on import)."""
    import importlib

    for name in (
        "scenespeak.cli",
        "scenespeak.pipeline",
        "scenespeak.perception.calibration",
        "scenespeak.perception.database",
        "scenespeak.perception.stereo",
        "scenespeak.perception.features",
        "scenespeak.perception.objects",
        "scenespeak.spatial.forces",
        "scenespeak.spatial.language",
        "scenespeak.spatial.degrees",
        "scenespeak.tools.evaluation",
        "scenespeak.tools.scenes",
        "scenespeak.tools.figures",
        "scenespeak.tools.annotate",
        "scenespeak.live.service",
        "scenespeak.spatial.dialogue",
        "fastapi",
        "fastapi.testclient",
        "matplotlib.pyplot",
        "skimage.measure",
        "scipy.spatial",
    ):
        try:
            importlib.import_module(name)
        except ImportError:
            pass


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m scenespeak.tools.fuzz")
    parser.add_argument("action", choices=["build", "run", "one"])
    parser.add_argument("root", type=Path)
    parser.add_argument("case", nargs="?")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--sample", type=int, default=0, help="run this many random cases")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--match", default="", help="only cases whose id contains this")
    parser.add_argument("--ids", type=Path, help="only the cases listed in this file (one a line)")
    parser.add_argument("--mode", choices=["fork", "exec"], default="fork")
    parser.add_argument("--results", type=Path, help="write every outcome here (JSON lines)")
    parser.add_argument("--show", default="", help="print outcomes of these classes (comma list)")
    args = parser.parse_args(argv)
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    if args.action == "one":
        from scenespeak.tools.fuzz.runner import run_one_exec

        run_one_exec(args.root, args.case)
        return 0
    if not (args.root / "base" / "objects.db").exists() or args.action == "build":
        _build_in_child(args.root)
    if args.action == "build":
        return 0
    _preimport()
    from scenespeak.tools.fuzz.corpus import build
    from scenespeak.tools.fuzz.runner import run_cases, summarise, write_results

    cases = [c for c in build(args.root, write=False) if args.match in c.id]
    if args.ids:
        wanted = set(args.ids.read_text(encoding="utf-8").splitlines())
        cases = [c for c in cases if c.id in wanted]
    if args.sample:
        cases = random.Random(args.seed).sample(cases, min(args.sample, len(cases)))
    show = {s.strip() for s in args.show.split(",") if s.strip()}

    def progress(o: object) -> None:
        cls = getattr(o, "cls", "")
        if cls in show or "all" in show or ("all-bad" in show and cls != "clean"):
            print(f"{cls:15s} {getattr(o, 'id', '')}: {getattr(o, 'reason', '')}", flush=True)

    outcomes = run_cases(
        cases, root=args.root, workers=args.workers, mode=args.mode, progress=progress
    )
    if args.results:
        write_results(outcomes, args.results)
    print(json.dumps(summarise(outcomes), indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
