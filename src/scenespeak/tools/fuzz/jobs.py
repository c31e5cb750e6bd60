"""Corpus families: ``annotate`` (bad datasets, outputs that cannot be written, ``--resume`` on
a foreign or corrupt output) and ``ask`` (bad scene JSON: deep, huge, wrong types, not UTF-8;
questions of 1 MB and with control characters). Everything generated here, fixed seeds.
"""

from __future__ import annotations

import functools
import json
from pathlib import Path
from typing import Any, cast

from scenespeak.tools.fuzz.corpus import Base, Case, Checker, Expect, Writer, make_fifo
from scenespeak.tools.fuzz.streams import _no_escapes

# --------------------------------------------------------------------------------------------
# annotate


def _lines_intact(path: Path, before: bytes) -> Checker:
    """A check: a refused ``--resume`` left its output as it was."""

    def check(code: int, out: str, err: str) -> tuple[str, str] | None:
        if code == 0:
            return None
        try:
            now = path.read_bytes()
        except OSError:
            return ("data loss", f"{path.name} is gone")
        return None if now == before else ("data loss", f"{path.name} was changed by a refused run")

    return check


def _fresh_outputs(argv: tuple[str, ...], then: object) -> None:
    """Remove what an earlier run of the case wrote (``--out`` / ``--parquet`` files and the
    ``.scenes.jsonl`` log, never anything else), so that the corpus can be run again; then
    the case's own set-up."""
    import stat

    if "--resume" not in argv:
        for opt in ("--out", "--parquet"):
            if opt in argv:
                p = Path(argv[argv.index(opt) + 1])
                for q in (p, p.with_name(p.stem + ".scenes.jsonl")):
                    try:
                        if stat.S_ISREG(q.lstat().st_mode) and "annotate" in q.parts:
                            q.unlink()
                    except OSError:
                        pass
    if callable(then):
        then()


def _copy_to(src: Path, dest: Path, data: bytes) -> None:
    dest.parent.mkdir(parents=True, exist_ok=True)
    dest.write_bytes(data)


def annotate(w: Writer, base: Base) -> None:
    """``annotate`` with bad datasets, outputs that cannot be written and bad ``--resume``."""
    run = ("annotate", str(base.dataset), "--db", str(base.db), "--workers", "1", "-q")
    out_dir = w.path("annotate/out")
    w.do(lambda: out_dir.mkdir(parents=True, exist_ok=True))
    folder = w.path("annotate/out/a-folder.jsonl")
    w.do(lambda: folder.mkdir(parents=True, exist_ok=True))
    # A private device node (never /dev itself: a rename over it would replace the device).
    device = w.path("annotate/out/full-device")
    fifo = w.path("annotate/out/a-fifo")
    make_device = functools.partial(_make_full_device, device)
    make_pipe = functools.partial(make_fifo, fifo)
    cases: list[tuple[str, tuple[str, ...], Expect, str | None, Checker | None, object]] = [
        (
            "out-missing-folder",
            ("--out", str(w.root / "annotate/nope/pairs.jsonl")),
            "error",
            "nope",
            None,
            None,
        ),
        ("out-is-folder", ("--out", str(folder)), "error", str(folder), None, None),
        ("out-device", ("--out", str(device)), "error", str(device), None, make_device),
        ("out-fifo", ("--out", str(fifo)), "error", str(fifo), None, make_pipe),
        (
            "parquet-device",
            ("--out", str(out_dir / "p1.jsonl"), "--parquet", str(device)),
            "error",
            str(device),
            None,
            make_device,
        ),
        (
            "parquet-fifo",
            ("--out", str(out_dir / "p2.jsonl"), "--parquet", str(fifo)),
            "error",
            str(fifo),
            None,
            make_pipe,
        ),
        (
            "batch-0",
            ("--out", str(out_dir / "b0.jsonl"), "--batch", "0"),
            "error",
            "--batch",
            None,
            None,
        ),
        (
            "workers-0",
            ("--out", str(out_dir / "w0.jsonl"), "--workers", "0"),
            "error",
            "--workers",
            None,
            None,
        ),
        (
            "retry-without-resume",
            ("--out", str(out_dir / "r.jsonl"), "--retry-failed"),
            "error",
            "--resume",
            None,
            None,
        ),
        (
            "scheduler-nobody",
            (
                "--workers-default",
                "--out",
                str(out_dir / "s.jsonl"),
                "--scheduler",
                "tcp://127.0.0.1:9",
            ),
            "error",
            "127.0.0.1:9",
            None,
            None,
        ),
        (
            "scheduler-not-url",
            (
                "--workers-default",
                "--out",
                str(out_dir / "s2.jsonl"),
                "--scheduler",
                "\x1b[2Jnot a url",
            ),
            "error",
            "--scheduler",
            _no_escapes,
            None,
        ),
    ]
    resumes: dict[str, tuple[bytes, Expect]] = {
        "foreign-png": (b"\x89PNG\r\n\x1a\n" + b"\x00" * 100, "error"),
        "binary-garbage": (bytes(range(256)) * 8, "error"),
        "not-json-lines": (b"hello\nworld\n", "error"),
        "json-but-not-pairs": (b'{"a": 1}\n[1, 2]\n', "error"),
        "truncated-last-line": (b'{"scene": "scene_000", "argument": "astr', "either"),
        "other-dataset": (
            json.dumps({"scene": "scene_999", "argument": "a", "referent": "b"}).encode() + b"\n",
            "either",
        ),
        "deep-line": (b"[" * 50_000 + b"]" * 50_000 + b"\n", "error"),
        "escape-in-scene": (
            json.dumps({"scene": "\x1b[2J", "argument": "a", "referent": "b"}).encode() + b"\n",
            "either",
        ),
    }
    for name, (data, expect) in resumes.items():
        out = w.path(f"annotate/resume/{name}.jsonl")
        check = _lines_intact(out, data)
        cases.append(
            (
                f"resume-{name}",
                ("--out", str(out), "--resume"),
                expect,
                str(out),
                check,
                functools.partial(_copy_to, out, out, data),
            )
        )
    for name, args, expect, names, extra, setup in cases:
        if args[0] == "--workers-default":  # --scheduler: without --workers
            argv = (*run[:4], "-q", *args[1:])
        else:
            argv = (*run, *args)
        w.add(
            Case(
                f"annotate/{name}",
                "annotate",
                argv,
                expect=expect,
                names=names,
                check=_both(extra, _no_escapes),
                setup=functools.partial(_fresh_outputs, argv, setup),
            )
        )
    _annotate_datasets(w, base)


def _make_full_device(path: Path) -> None:
    """A character device like /dev/full at ``path`` (a FIFO when not allowed to make one)."""
    import os
    import stat

    if path.exists() or path.is_symlink():
        return
    try:
        os.mknod(path, 0o666 | stat.S_IFCHR, os.makedev(1, 7))
    except OSError:
        os.mkfifo(path)


def _both(a: Checker | None, b: Checker) -> Checker:
    def check(code: int, out: str, err: str) -> tuple[str, str] | None:
        return (a(code, out, err) if a is not None else None) or b(code, out, err)

    return check


def _annotate_datasets(w: Writer, base: Base) -> None:
    out = w.path("annotate/out/datasets.jsonl")
    afile = w.bytes("annotate/a-file", b"x")
    no_index = w.path("annotate/no-index")
    w.do(lambda: no_index.mkdir(parents=True, exist_ok=True))
    no_objects = w.path("annotate/no-objects")
    w.json("annotate/no-objects/dataset.json", {"format": "scenespeak-scenes/1", "scenes": []})
    for name, root, expect in (
        ("missing", w.root / "annotate/nope", "error"),
        ("a-file", afile, "error"),
        ("no-index", no_index, "error"),
        ("no-db-no-objects", no_objects, "error"),
    ):
        args = ("annotate", str(root), "--out", str(out), "--workers", "1", "-q")
        w.add(Case(f"annotate/dataset-{name}", "annotate", args, expect=expect, names=str(root)))  # type: ignore[arg-type]


# --------------------------------------------------------------------------------------------
# ask


def _scene_json() -> dict[str, object]:
    hull = [[-0.25, 0.9], [-0.05, 0.9], [-0.05, 1.1], [-0.25, 1.1]]
    return {
        "objects": [
            {"label": "astronaut", "hull": hull, "centroid": [-0.15, 0.0, 1.0]},
            {
                "label": "coffee",
                "hull": [[x + 0.33, y + 0.3] for x, y in hull],
                "centroid": [0.18, 0.0, 1.3],
            },
        ],
        "relations": [],
    }


def ask(w: Writer, base: Base) -> None:
    """``ask QUESTION --scene FILE`` with bad scene files and hostile questions."""
    good = w.json("ask/scene.json", _scene_json())
    obj = cast("list[dict[str, Any]]", _scene_json()["objects"])
    scenes: dict[str, tuple[str | bytes, Expect]] = {
        "deep.json": ("[" * 100_000 + "]" * 100_000, "error"),
        "deep-in-objects.json": ('{"objects": ' + "[" * 5_000 + "]" * 5_000 + "}", "error"),
        "huge-17MB.json": ("", "error"),
        "objects-number.json": (json.dumps({"objects": 5}), "error"),
        "objects-of-numbers.json": (json.dumps({"objects": [5, 6]}), "error"),
        "label-number.json": (json.dumps({"objects": [{**obj[0], "label": 5}]}), "error"),
        "hull-text.json": (json.dumps({"objects": [{**obj[0], "hull": "square"}]}), "error"),
        "hull-nan.json": (
            json.dumps({"objects": [{**obj[0], "hull": [[0, 0], [1, 0], [1, 1]]}]}).replace(
                "1]", "NaN]", 1
            ),
            "error",
        ),
        "centroid-1e300.json": (
            json.dumps({"objects": [{**obj[0], "centroid": [1e300, 0, 1e300]}]}),
            "either",
        ),
        "label-escape.json": (
            json.dumps({"objects": [{**obj[0], "label": "\x1b[2Jmug"}]}),
            "either",
        ),
        "non-utf8.json": (b'{"objects": [{"label": "\xff\xfe"}]}', "error"),
        "null.json": ("null", "error"),
        "empty.json": ("", "error"),
        "int400.json": ('{"objects": [], "n": ' + "9" * 400 + "}", "error"),
        "many-objects.json": (
            json.dumps({"objects": [{**obj[0], "label": f"o{i}"} for i in range(20_000)]}),
            "either",
        ),
    }
    for name, (data, expect) in scenes.items():
        if name.startswith("huge"):
            p = w.bytes(
                f"ask/{name}", lambda: b'{"objects": [], "pad": "' + b"x" * (17 << 20) + b'"}'
            )
        elif isinstance(data, bytes):
            p = w.bytes(f"ask/{name}", data)
        else:
            p = w.text(f"ask/{name}", data)
        w.add(
            Case(
                f"ask/scene-{name}",
                "ask",
                ("ask", "where is the coffee?", "--scene", str(p)),
                expect=expect,
                names=str(p),
                check=_no_escapes,
            )
        )
    fifo = w.path("ask/fifo.json")
    folder = w.path("ask/folder.json")
    w.do(lambda: folder.mkdir(parents=True, exist_ok=True))
    for name, p, setup in (
        ("fifo", fifo, functools.partial(make_fifo, fifo)),
        ("folder", folder, None),
    ):
        w.add(
            Case(
                f"ask/scene-{name}",
                "ask",
                ("ask", "where is the coffee?", "--scene", str(p)),
                names=str(p),
                setup=setup,
            )
        )
    questions: dict[str, str] = {
        "one-megabyte": "where is the coffee? " * 50_000,
        "control-chars": "where is the \x1b[31mcoffee\x1b[0m?\x07",
        "nul": "where is\x00 the coffee?",
        "surrogate": "where is the \udcff?",
        "bidi": "where is the \u202ecoffee?",
        "empty": "",
        "only-spaces": "   ",
        "newlines": "where\nis\nthe\ncoffee?",
    }
    for name, q in questions.items():
        for fmt in ("text", "json"):
            w.add(
                Case(
                    f"ask/question-{name}-{fmt}",
                    "ask",
                    ("ask", q, "--scene", str(good), "--format", fmt),
                    expect="either",
                    check=_no_escapes,
                )
            )


BUILDERS = (annotate, ask)
