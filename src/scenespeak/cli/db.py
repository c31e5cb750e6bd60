"""``scenespeak db add | list | remove``: the object database."""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Annotated, Any

import typer

from scenespeak.cli._app import (
    DbOpt,
    QuietOpt,
    _echo,
    _status,
    db_app,
)
from scenespeak.errors import InputError


@db_app.command("add")
def db_add(
    images: Annotated[list[Path], typer.Argument(help="Training images of the object.")],
    db: DbOpt,
    label: Annotated[str, typer.Option("--label", help="The object's name.")],
    mask: Annotated[
        list[Path] | None,
        typer.Option(
            "--mask",
            help="A mask per image (white = object), in the same order; repeat the option.",
        ),
    ] = None,
    replace: Annotated[
        bool, typer.Option("--replace", help="Replace an object with the same label.")
    ] = False,
    quiet: QuietOpt = False,
) -> None:
    """Learn an object from training images (a transaction: all or nothing)."""
    from scenespeak.cleantext import check_label
    from scenespeak.perception.recognition import ObjectDatabase
    from scenespeak.perception.recognition.elevated import add_elevated_views
    from scenespeak.perception.segmentation import training_mask

    check_label(label)
    masks: list[Any] | None = list(mask) if mask else None
    if masks is not None and len(masks) != len(images):
        raise InputError("--mask", f"{len(masks)} masks for {len(images)} images; give one each")
    _ready_to_write(db, create=True)
    with (
        _status(f"learning {label!r} from {len(images)} image(s)", quiet),
        ObjectDatabase.open(db) as database,
    ):
        if masks is None:  # the object on its plain background, as `evaluate` learns it
            masks = [training_mask(p) for p in images]
        info = database.add_object(label, images, masks=masks, replace=replace)
        add_elevated_views(database, info.label, images, masks)
    _echo(f"added {info.label!r}: {info.views} view(s), {info.descriptors} descriptors")


@db_app.command("list")
def db_list(
    db: DbOpt,
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON.")] = False,
) -> None:
    """List the objects in the database."""
    from scenespeak.perception import dbfiles
    from scenespeak.perception.recognition import ObjectDatabase

    dbfiles.check_file(db)
    dbfiles.validate(db)
    with ObjectDatabase.open(db, readonly=True) as database:
        rows = [
            {"label": o.label, "views": o.views, "descriptors": o.descriptors, "added": o.added}
            for o in database.list_objects()
        ]
    if as_json:
        _echo(json.dumps({"objects": rows}))
        return
    if not rows:
        _echo("(no objects)")
    for row in rows:
        _echo(f"{row['label']}\t{row['views']} view(s)\t{row['descriptors']} descriptors")


@db_app.command("remove")
def db_remove(
    labels: Annotated[
        list[str],
        typer.Argument(
            help="Labels to remove (all in one transaction). Put -- before a label that "
            "starts with a dash: db remove --db objects.db -- --help"
        ),
    ],
    db: DbOpt,
) -> None:
    """Remove objects from the database (all or none)."""
    from scenespeak.perception import dbfiles

    _ready_to_write(db, create=False)
    removed = dbfiles.remove_labels(db, list(labels), waiting=_say_waiting)
    _echo("removed " + ", ".join(repr(lab) for lab in removed))


def _say_waiting(message: str) -> None:
    sys.stderr.write(f"scenespeak: {message}\n")
    sys.stderr.flush()


def _ready_to_write(db: Path, *, create: bool) -> None:
    """The database file checked row by row (or created atomically), no other writer in it."""
    from scenespeak.perception import dbfiles

    if not dbfiles.check_file(db, must_exist=not create):
        dbfiles.create_empty(db)
    dbfiles.validate(db)
    dbfiles.wait_for_writers(db, waiting=_say_waiting)
