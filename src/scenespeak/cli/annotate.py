"""``scenespeak annotate``: spatial-relation labels for a whole dataset, on Dask."""

from __future__ import annotations

import sys
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any

import typer

from scenespeak.cli._app import QuietOpt, _stderr_console, app
from scenespeak.cli._options import takes_options

#: Without a terminal (a batch job's log), a progress line at most this often (seconds).
_PLAIN_EVERY_S = 30.0


def _eta(seconds: float) -> str:
    whole = round(seconds)
    h, rest = divmod(whole, 3600)
    return f"{h}:{rest // 60:02d}:{rest % 60:02d}" if h else f"{rest // 60}:{rest % 60:02d}"


@contextmanager
def scene_progress(quiet: bool = False) -> Iterator[Callable[[int, int], None] | None]:
    """A progress callback ``(done, total)`` on stderr: scenes done, scenes/s, time left.

    A rich bar on a terminal; otherwise one plain line every 30 s (a batch job's log).
    """
    if quiet:
        yield None
        return
    if not sys.stderr.isatty():
        start, last = time.perf_counter(), [0.0]

        def plain(done: int, total: int) -> None:
            now = time.perf_counter() - start
            if done and (now - last[0] >= _PLAIN_EVERY_S or done == total):
                last[0] = now
                rate = done / now if now > 0 else 0.0
                left = (total - done) / rate if rate > 0 else 0.0
                sys.stderr.write(
                    f"annotate: {done}/{total} scenes, {rate:.2f} scenes/s, {_eta(left)} left\n"
                )
                sys.stderr.flush()

        yield plain
        return
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TaskProgressColumn,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    columns = (
        TextColumn("[progress.description]{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TextColumn("scenes"),
        TaskProgressColumn(),
        TextColumn("{task.fields[rate]} scenes/s"),
        TimeElapsedColumn(),
        TextColumn("left"),
        TimeRemainingColumn(),
    )
    with Progress(*columns, console=_stderr_console(), transient=False) as bar:
        task = bar.add_task("annotating", total=None, rate="–")
        start = time.perf_counter()

        def update(done: int, total: int) -> None:
            elapsed = time.perf_counter() - start
            rate = f"{done / elapsed:.2f}" if done and elapsed > 0 else "–"
            bar.update(task, completed=done, total=total, rate=rate)

        yield update


@dataclass(frozen=True, kw_only=True)
class AnnotateCommand:
    """The command line of ``scenespeak annotate`` (see :mod:`scenespeak.cli._options`)."""

    dataset: Annotated[Path, typer.Argument(help="A folder of scene folders.")]
    out: Annotated[
        Path, typer.Option("--out", help="JSON Lines output, one line per ordered pair.")
    ]
    db: Annotated[
        Path | None,
        typer.Option(
            "--db",
            help="Object database (default: learnt from DATASET/objects/ training views).",
        ),
    ] = None
    workers: Annotated[
        int, typer.Option("--workers", min=1, help="Local worker processes (1: this process).")
    ] = 2
    scheduler: Annotated[
        str | None,
        typer.Option("--scheduler", help="An existing Dask scheduler, tcp://HOST:PORT."),
    ] = None
    resume: Annotated[
        bool, typer.Option("--resume", help="Continue a killed run: skip finished scenes.")
    ] = False
    retry_failed: Annotated[
        bool, typer.Option("--retry-failed", help="With --resume: run failed scenes again.")
    ] = False
    parquet: Annotated[
        Path | None, typer.Option("--parquet", help="Also write the pairs as Parquet.")
    ] = None
    batch: Annotated[int, typer.Option("--batch", min=1, help="Scenes per task.")] = 2
    quiet: QuietOpt = False


@app.command("annotate")
@takes_options(AnnotateCommand)
def annotate_cmd(o: AnnotateCommand) -> None:
    """Label every ordered pair of objects of every scene: JSON Lines (and Parquet)."""
    from scenespeak.errors import InputError
    from scenespeak.tools.annotate import annotate
    from scenespeak.tools.engine import EngineOptions

    if o.retry_failed and not o.resume:
        raise InputError("--retry-failed", "only makes sense with --resume")
    if o.scheduler is not None and o.workers != 2:
        raise InputError("--workers", "give either --workers or --scheduler, not both")
    engine = EngineOptions(workers=o.workers, scheduler=o.scheduler, batch=o.batch)
    summary: Any
    with scene_progress(o.quiet) as progress:
        summary = annotate(
            o.dataset,
            o.out,
            db=o.db,
            engine=engine,
            resume=o.resume,
            retry_failed=o.retry_failed,
            parquet=o.parquet,
            progress=progress,
        )
    if not o.quiet:
        sys.stderr.write(summary.to_text() + "\n")
