"""``scenespeak evaluate``: the paper's experiment over a generated dataset."""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from scenespeak.cli._app import (
    QuietOpt,
    _echo,
    _progress,
    app,
)
from scenespeak.cli._options import takes_options

if TYPE_CHECKING:
    from scenespeak.tools.evaluation import EvaluationResult


@dataclass(frozen=True, kw_only=True)
class EvaluateCommand:
    """The command line of ``scenespeak evaluate`` (see :mod:`scenespeak.cli._options`)."""

    dataset: Annotated[Path, typer.Argument(help="A generated dataset folder.")]
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON.")] = False
    workers: Annotated[
        int,
        typer.Option(
            "--workers", min=1, max=256, help="Local Dask worker processes (1: this one; <= 256)."
        ),
    ] = 2
    scheduler: Annotated[
        str | None,
        typer.Option("--scheduler", help="An existing Dask scheduler, tcp://HOST:PORT."),
    ] = None
    db: Annotated[Path | None, typer.Option("--db", help="Object database (default: learnt).")] = (
        None
    )
    learn: Annotated[
        str | None,
        typer.Option(
            "--learn",
            metavar="LABEL,...",
            help="Learn only these objects; the others are scored as distractors.",
        ),
    ] = None
    learn_only: Annotated[
        float | None,
        typer.Option(
            "--learn-only",
            help="Learn only this share of the objects (e.g. 0.5), drawn with --split-seed.",
        ),
    ] = None
    split_seed: Annotated[
        int, typer.Option("--split-seed", help="Seed of the --learn-only draw.")
    ] = 0
    other_part: Annotated[
        bool,
        typer.Option("--other-part", help="Learn the objects --learn/--learn-only leave out."),
    ] = False
    quiet: QuietOpt = False


@app.command("evaluate")
@takes_options(EvaluateCommand)
def evaluate_cmd(o: EvaluateCommand) -> None:
    """Describe every scene of a dataset and score it against the ground truth."""
    from scenespeak.tools.evaluation import LearnSplit, evaluate, format_table

    split = LearnSplit(
        learn=tuple(x.strip() for x in (o.learn or "").split(",") if x.strip()),
        fraction=o.learn_only,
        seed=o.split_seed,
        other=o.other_part,
    )
    if o.db is not None:
        from scenespeak.perception import dbfiles

        dbfiles.check_file(o.db)
        dbfiles.validate(o.db)

    def run(progress: Callable[[int, int], Any] | None) -> EvaluationResult:
        return evaluate(
            o.dataset,
            db=o.db,
            workers=o.workers,
            progress=progress,
            scheduler=o.scheduler,
            learn=split,
        )

    bar = _progress(0, "evaluating", o.quiet)
    if bar is None:
        result = run(None)
    else:
        with bar:
            task = bar.add_task("describing scenes", total=None)

            def advance(done: int, total: int) -> None:
                bar.update(task, completed=done, total=total)

            result = run(advance)
    _echo(json.dumps(result.to_dict()) if o.as_json else format_table(result))
