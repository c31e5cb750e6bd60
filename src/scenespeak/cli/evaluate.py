"""``scenespeak evaluate``: the paper's experiment over a generated dataset."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer

from scenespeak.cli._app import (
    QuietOpt,
    _echo,
    _progress,
    app,
)


@app.command("evaluate")
def evaluate_cmd(
    dataset: Annotated[Path, typer.Argument(help="A generated dataset folder.")],
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON.")] = False,
    workers: Annotated[
        int,
        typer.Option(
            "--workers", min=1, max=256, help="Local Dask worker processes (1: this one; <= 256)."
        ),
    ] = 2,
    scheduler: Annotated[
        str | None,
        typer.Option("--scheduler", help="An existing Dask scheduler, tcp://HOST:PORT."),
    ] = None,
    db: Annotated[
        Path | None, typer.Option("--db", help="Object database (default: learnt).")
    ] = None,
    quiet: QuietOpt = False,
) -> None:
    """Describe every scene of a dataset and score it against the ground truth."""
    from scenespeak.tools.evaluation import evaluate, format_table

    if db is not None:
        from scenespeak.perception import dbfiles

        dbfiles.check_file(db)
        dbfiles.validate(db)

    progress = _progress(0, "evaluating", quiet)
    if progress is None:
        result = evaluate(dataset, db=db, workers=workers, progress=None, scheduler=scheduler)
    else:
        with progress:
            task = progress.add_task("describing scenes", total=None)

            def advance(done: int, total: int) -> None:
                progress.update(task, completed=done, total=total)

            result = evaluate(
                dataset, db=db, workers=workers, progress=advance, scheduler=scheduler
            )
    _echo(json.dumps(result.to_dict()) if as_json else format_table(result))
