"""``scenespeak db add | list | remove``: the object database."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

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

    check_label(label)
    masks = list(mask) if mask else None
    if masks is not None and len(masks) != len(images):
        raise InputError("--mask", f"{len(masks)} masks for {len(images)} images; give one each")
    with (
        _status(f"learning {label!r} from {len(images)} image(s)", quiet),
        ObjectDatabase.open(db, create=True) as database,
    ):
        info = database.add_object(label, images, masks=masks, replace=replace)
    _echo(f"added {info.label!r}: {info.views} view(s), {info.descriptors} descriptors")


@db_app.command("list")
def db_list(
    db: DbOpt,
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON.")] = False,
) -> None:
    """List the objects in the database."""
    from scenespeak.perception.recognition import ObjectDatabase

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
    from scenespeak.perception.recognition import ObjectDatabase

    with ObjectDatabase.open(db) as database:
        remove_many = getattr(database, "remove_many", None)
        if remove_many is not None:
            remove_many(labels)
        else:
            missing = [lab for lab in labels if lab not in database]
            if missing:
                raise InputError(db, f"no object labelled {missing[0]!r}; nothing was removed")
            for lab in dict.fromkeys(labels):
                database.remove(lab)
    _echo("removed " + ", ".join(repr(lab) for lab in dict.fromkeys(labels)))
