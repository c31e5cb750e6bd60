"""Run the whole fuzzing corpus (issue 12) and print its outcome classes.

    PYTHONPATH=src python3 benchmarks/fuzz_corpus.py [ROOT] [--workers 2] [--mode fork|exec]

Builds the corpus under ROOT (default: a temporary folder) in a child process, runs every case
through the CLI or the Python API in its own process (30 s and 2 GiB bounds), and prints the
counts per class and per family, the slowest case and the peak memory, plus every case that is
not clean. ``--results FILE`` keeps every outcome as JSON lines. The load of the machine is
printed first (``os.getloadavg``): the time per case depends on it, the classes do not.
"""

from __future__ import annotations

import os
import sys
import tempfile

from scenespeak.tools.fuzz.__main__ import main

if __name__ == "__main__":
    args = sys.argv[1:]
    if not args or args[0].startswith("-"):
        args = [tempfile.mkdtemp(prefix="fuzz-corpus-"), *args]
    print(f"load average: {os.getloadavg()}", flush=True)
    show = [] if "--show" in args else ["--show", "all-bad"]
    sys.exit(main(["run", *args, *show]))
