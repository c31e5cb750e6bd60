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
    learn: Annotated[
        str | None,
        typer.Option(
            "--learn",
            metavar="LABEL,...",
            help="Learn only these objects; the others are scored as distractors.",
        ),
    ] = None,
    learn_only: Annotated[
        float | None,
        typer.Option(
            "--learn-only",
            help="Learn only this share of the objects (e.g. 0.5), drawn with --split-seed.",
        ),
    ] = None,
    split_seed: Annotated[
        int, typer.Option("--split-seed", help="Seed of the --learn-only draw.")
    ] = 0,
    other_part: Annotated[
        bool,
        typer.Option("--other-part", help="Learn the objects --learn/--learn-only leave out."),
    ] = False,
    quiet: QuietOpt = False,
) -> None:
    """Describe every scene of a dataset and score it against the ground truth."""
    from scenespeak.tools.evaluation import LearnSplit, evaluate, format_table

    split = LearnSplit(
        learn=tuple(x.strip() for x in (learn or "").split(",") if x.strip()),
        fraction=learn_only,
        seed=split_seed,
        other=other_part,
    )

    if db is not None:
        from scenespeak.perception import dbfiles

        dbfiles.check_file(db)
        dbfiles.validate(db)

    progress = _progress(0, "evaluating", quiet)
    if progress is None:
        result = evaluate(
            dataset, db=db, workers=workers, progress=None, scheduler=scheduler, learn=split
        )
    else:
        with progress:
            task = progress.add_task("describing scenes", total=None)

            def advance(done: int, total: int) -> None:
                progress.update(task, completed=done, total=total)

            result = evaluate(
                dataset, db=db, workers=workers, progress=advance, scheduler=scheduler, learn=split
            )
    _echo(json.dumps(result.to_dict()) if as_json else format_table(result))
