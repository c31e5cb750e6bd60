"""Run corpus cases in child processes and classify what happened.

Each case runs in its own process: forked from a runner that has imported scenespeak (fast:
tens of milliseconds a case) or, with ``mode="exec"``, as a fresh ``python -m scenespeak``
(the real entry point). The child gets an address-space limit (``RLIMIT_AS``), its stdout and
stderr go to files (so whatever a C library prints is seen too), and it is killed with its whole
process group when it overruns the timeout. The outcome classes:

``clean``           refused with exactly one line ``scenespeak: error: <file>: …`` naming the
                    file (and saying what the case requires), or accepted where it should be
``traceback``       a Python traceback, or exit status 1
``hang``            still running after the timeout
``memory``          peak RSS over the memory bound, or a ``MemoryError`` / allocation failure
``crash``           killed by a signal (segfault, abort)
``not one line``    refused, but with more than one line (library noise, a usage box) or
                    not in the ``scenespeak: error:`` form
``unclear message`` one line that does not name the file, miss a required hint, or names an
                    option that does not exist
``silently wrong``  accepted (exit 0) what must be refused, or a check found a wrong answer
``data loss``       a database lost objects it had
``security``        code ran from a file, a symlink was written through, raw escapes printed
``refused valid``   refused an input that must be accepted
"""

from __future__ import annotations

import json
import os
import re
import resource
import signal
import subprocess
import sys
import tempfile
import time
import traceback
from collections import Counter
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from scenespeak.tools.fuzz.corpus import Case

__all__ = ["CLASSES", "Outcome", "classify", "run_cases", "summarise"]

CLASSES = (
    "clean",
    "traceback",
    "hang",
    "memory",
    "crash",
    "not one line",
    "unclear message",
    "silently wrong",
    "data loss",
    "security",
    "refused valid",
)
MEMORY_BOUND = 2 * 1024**3
_EXIT_WRONG = 4
_EXIT_MEMORY = 3


@dataclass(frozen=True)
class Outcome:
    """What one case did."""

    id: str
    family: str
    cls: str
    reason: str
    code: int | None
    seconds: float
    rss_mb: float
    stderr: str


def _known_options() -> set[str]:
    import typer

    from scenespeak.cli import app

    names: set[str] = {"--help"}

    def walk(cmd: Any) -> None:  # click's or typer's vendored click: duck-typed
        for p in getattr(cmd, "params", ()):
            names.update(o for o in (*p.opts, *p.secondary_opts) if o.startswith("--"))
        for sub in getattr(cmd, "commands", {}).values():
            walk(sub)

    walk(typer.main.get_command(app))
    return names


_OPTION = re.compile(r"(?<![\w-])--[a-z][a-z0-9-]+")


def classify(
    case: Case,
    code: int | None,
    out: str,
    err: str,
    *,
    rss: int,
    timed_out: bool,
    options: set[str],
) -> tuple[str, str]:
    """The outcome class and a reason (see the module docstring)."""
    if timed_out:
        return "hang", f"still running after {case.timeout:g} s"
    if code is None or code < 0:
        return "crash", f"killed by signal {-(code or 0)}"
    found = _failed(code, out, err, rss)
    if found is None and case.check is not None:
        found = case.check(code, out, err)
    if found is not None:
        return found
    if code == 0:
        return _accepted(case, err)
    return _classify_error(case, code, err, options)


def _failed(code: int, out: str, err: str, rss: int) -> tuple[str, str] | None:
    """Memory, a traceback or a wrong answer the case itself reported (else None)."""
    if rss > MEMORY_BOUND:
        return "memory", f"peak RSS {rss / 2**20:.0f} MiB"
    if code == _EXIT_MEMORY or re.search(r"MemoryError|Insufficient memory|bad_alloc", err):
        return "memory", "allocation failed: " + _first(err)
    if "Traceback (most recent call last)" in err or code == 1:
        return "traceback", _last(err)
    if code == _EXIT_WRONG:
        return "silently wrong", _first(out)
    return None


def _accepted(case: Case, err: str) -> tuple[str, str]:
    """The class of an exit 0: clean unless the input had to be refused or stderr is noisy."""
    if case.expect == "error":
        return "silently wrong", "accepted (exit 0) an input that must be refused"
    noise = [
        ln
        for ln in err.splitlines()
        if ln.strip() and not ln.startswith(("scenespeak: waiting", "scenespeak: warning"))
    ]
    if noise and case.argv is not None:
        return "not one line", "succeeded but printed on stderr: " + noise[0][:120]
    return "clean", "accepted"


def _classify_error(case: Case, code: int, err: str, options: set[str]) -> tuple[str, str]:
    """The class of a non-zero exit: one clean ``scenespeak: error:`` line, or what is wrong."""
    lines = [ln for ln in err.splitlines() if ln.strip()]
    if code != 2:
        return "traceback", f"exit status {code}: " + _first(err)
    if case.expect == "ok":
        return "refused valid", _first(err)
    if len(lines) != 1 or not lines[0].startswith("scenespeak: error: "):
        return "not one line", f"{len(lines)} lines: " + " | ".join(x[:80] for x in lines[:3])
    return _message_problem(case, lines[0], options) or ("clean", lines[0][:200])


def _message_problem(case: Case, line: str, options: set[str]) -> tuple[str, str] | None:
    """What is wrong with a one-line refusal (else None): the file, the words, the options."""
    from scenespeak.safeio import clean_text

    if case.names and case.names not in line and clean_text(case.names) not in line:
        return "unclear message", f"does not name {case.names!r}: {line[:160]}"
    for needle in case.says:
        if needle.lower() not in line.lower():
            return "unclear message", f"does not say {needle!r}: {line[:160]}"
    bogus = [o for o in _OPTION.findall(line) if o not in options and o not in (case.argv or ())]
    if bogus:
        return "unclear message", f"names an option that does not exist ({bogus[0]}): {line[:120]}"
    if "\x1b" in line:
        return "security", "a raw escape sequence in the message"
    return None


def _first(text: str) -> str:
    lines = [ln for ln in text.splitlines() if ln.strip()]
    return lines[0][:200] if lines else ""


def _last(text: str) -> str:
    lines = [ln for ln in text.splitlines() if ln.strip()]
    return lines[-1][:200] if lines else ""


# --------------------------------------------------------------------------------------------
# the child


def _child(case: Case, memory: int) -> int:
    from scenespeak.errors import ScenespeakError
    from scenespeak.safeio import clean_text
    from scenespeak.tools.fuzz.apicases import WrongAnswer

    try:
        resource.setrlimit(resource.RLIMIT_AS, (memory, memory))
        if case.setup is not None:
            case.setup()
        if case.argv is not None:
            from scenespeak.cli import main

            return main(list(case.argv))
        assert case.api is not None
        value = case.api()
        sys.stdout.write(f"returned {type(value).__name__}\n")
        return 0
    except ScenespeakError as exc:
        sys.stderr.write("scenespeak: error: " + clean_text(str(exc)) + "\n")
        return 2
    except WrongAnswer as exc:
        sys.stdout.write(f"{exc}\n")
        return _EXIT_WRONG
    except MemoryError:
        sys.stderr.write("MemoryError\n")
        return _EXIT_MEMORY
    except BaseException:
        traceback.print_exc()
        return 1


def _fork(case: Case, out: int, err: int, memory: int) -> int:
    pid = os.fork()
    if pid == 0:  # pragma: no cover - runs in the child
        code = 1
        try:
            os.setsid()
            os.dup2(out, 1)
            os.dup2(err, 2)
            sys.stdout = open(1, "w", encoding="utf-8", errors="backslashreplace", closefd=False)
            sys.stderr = open(2, "w", encoding="utf-8", errors="backslashreplace", closefd=False)
            code = _child(case, memory)
        finally:
            try:
                sys.stdout.flush()
                sys.stderr.flush()
            finally:
                os._exit(code)
    return pid


def _exec(case: Case, root: Path, out: int, err: int, memory: int) -> subprocess.Popen[bytes]:
    def limit() -> None:  # pragma: no cover - runs in the child
        os.setsid()
        resource.setrlimit(resource.RLIMIT_AS, (memory, memory))

    proc = subprocess.Popen(
        [sys.executable, "-m", "scenespeak.tools.fuzz", "one", str(root), case.id],
        stdout=out,
        stderr=err,
        stdin=subprocess.DEVNULL,
        preexec_fn=limit,
    )
    # The caller keeps the Popen alive until it has reaped the child itself: a Popen that is
    # garbage collected while its child runs is reaped by subprocess's own clean-up on the next
    # Popen, and os.wait4 then fails with ECHILD.
    return proc


def run_one_exec(root: Path, case_id: str) -> None:
    """``python -m scenespeak.tools.fuzz one ROOT ID``: set the case up, then exec the CLI."""
    from scenespeak.tools.fuzz.corpus import build

    case = next(c for c in build(root, write=False) if c.id == case_id)
    if case.setup is not None:
        case.setup()
    if case.argv is not None:
        os.execv(sys.executable, [sys.executable, "-m", "scenespeak", *case.argv])
    sys.exit(_child(case, MEMORY_BOUND * 2))


def run_cases(
    cases: Sequence[Case],
    *,
    root: Path,
    workers: int = 2,
    memory: int = 3 * 1024**3,
    mode: str = "fork",
    progress: Callable[[Outcome], None] | None = None,
) -> list[Outcome]:
    """Run ``cases`` with ``workers`` at a time; return their outcomes in order."""
    options = _known_options()
    pending = list(enumerate(cases))[::-1]
    running: dict[int, tuple[int, Case, float, int, int]] = {}
    procs: dict[int, subprocess.Popen[bytes]] = {}  # exec mode: kept alive until reaped
    results: dict[int, Outcome] = {}
    tmp = Path(tempfile.mkdtemp(prefix="fuzz-io-"))
    while pending or running:
        while pending and len(running) < workers:
            k, case = pending.pop()
            out = os.open(tmp / f"{k}.out", os.O_RDWR | os.O_CREAT | os.O_TRUNC, 0o600)
            err = os.open(tmp / f"{k}.err", os.O_RDWR | os.O_CREAT | os.O_TRUNC, 0o600)
            if mode == "fork":
                pid = _fork(case, out, err, memory)
            else:
                proc = _exec(case, root, out, err, memory)
                pid = proc.pid
                procs[pid] = proc
            running[pid] = (k, case, time.monotonic(), out, err)
        time.sleep(0.005)
        for pid, (k, case, start, out, err) in list(running.items()):
            elapsed = time.monotonic() - start
            done, status, usage = os.wait4(pid, os.WNOHANG)
            timed_out = False
            if done == 0:
                if elapsed < case.timeout:
                    continue
                _kill_group(pid)
                done, status, usage = os.wait4(pid, 0)
                timed_out = True
            _kill_group(pid)
            del running[pid]
            if pid in procs:  # reaped above, not by Popen: tell it so
                procs.pop(pid).returncode = os.waitstatus_to_exitcode(status)
            outcome = _outcome(case, status, usage, elapsed, out, err, timed_out, options)
            results[k] = outcome
            if progress is not None:
                progress(outcome)
    return [results[k] for k in range(len(cases))]


def _kill_group(pid: int) -> None:
    try:
        os.killpg(pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):
        pass


def _read(fd: int) -> str:
    os.lseek(fd, 0, 0)
    data = os.read(fd, 1 << 16)
    os.close(fd)
    return data.decode("utf-8", "backslashreplace")


def _outcome(
    case: Case,
    status: int,
    usage: resource.struct_rusage,
    elapsed: float,
    out: int,
    err: int,
    timed_out: bool,
    options: set[str],
) -> Outcome:
    code: int | None = None
    if os.WIFEXITED(status):
        code = os.WEXITSTATUS(status)
    elif os.WIFSIGNALED(status):
        code = -os.WTERMSIG(status)
    out_text, err_text = _read(out), _read(err)
    rss = int(usage.ru_maxrss) * 1024
    try:
        cls, reason = classify(
            case, code, out_text, err_text, rss=rss, timed_out=timed_out, options=options
        )
    except Exception as exc:  # a check that itself failed
        cls, reason = "traceback", f"the case's check failed: {exc!r}"
    return Outcome(
        case.id, case.family, cls, reason, code, round(elapsed, 3), rss / 2**20, err_text[:2000]
    )


def summarise(outcomes: Sequence[Outcome]) -> dict[str, object]:
    """Counts per class, per family and class, the slowest case and the peak memory."""
    by_class = Counter(o.cls for o in outcomes)
    by_family: dict[str, dict[str, int]] = {}
    for o in outcomes:
        by_family.setdefault(o.family, {}).setdefault(o.cls, 0)
        by_family[o.family][o.cls] += 1
    slowest = max(outcomes, key=lambda o: o.seconds, default=None)
    biggest = max(outcomes, key=lambda o: o.rss_mb, default=None)
    return {
        "cases": len(outcomes),
        "classes": {c: by_class.get(c, 0) for c in CLASSES},
        "families": by_family,
        "slowest": None if slowest is None else [slowest.id, slowest.seconds],
        "peak_rss_mb": None if biggest is None else [biggest.id, round(biggest.rss_mb)],
    }


def write_results(outcomes: Sequence[Outcome], path: Path) -> None:
    """All outcomes as JSON lines."""
    with path.open("w", encoding="utf-8") as f:
        for o in outcomes:
            f.write(json.dumps(asdict(o)) + "\n")
