"""Corpus family of dataset folders and their ``truth.json``."""

from __future__ import annotations

import functools
import json
from pathlib import Path

from scenespeak.tools.fuzz.calibrations import _HUGE_INT
from scenespeak.tools.fuzz.corpus import (
    Base,
    Case,
    Writer,
    make_symlink,
)


def datasets(w: Writer, base: Base) -> None:
    """``evaluate`` on datasets with broken indexes, truth files and escaping entries."""
    src = base.dataset / "scene_000"
    outside = w.path("dataset/outside/secret_scene")
    w.do(lambda: outside.mkdir(parents=True, exist_ok=True))
    index_variants: dict[str, str] = {
        "empty": "",
        "garbage": "{scenes: [",
        "deep": "[" * 50_000 + "]" * 50_000,
        "scenes-missing": json.dumps({"format": "scenespeak-scenes/1"}),
        "scenes-not-list": json.dumps({"scenes": "scene_000"}),
        "scenes-numbers": json.dumps({"scenes": [1, 2, 3]}),
        "scenes-null": json.dumps({"scenes": [None]}),
        "scenes-nested": json.dumps({"scenes": [["scene_000"]]}),
        "dotdot": json.dumps({"scenes": ["../outside/secret_scene"]}),
        "absolute": json.dumps({"scenes": [str(outside)]}),
        "absolute-etc": json.dumps({"scenes": ["/etc"]}),
        "dotdot-deep": json.dumps({"scenes": ["scene_000/../../outside/secret_scene"]}),
        "nul-byte": json.dumps({"scenes": ["scene\u0000000"]}),
        "escape-seq": json.dumps({"scenes": ["\u001b[2Jgone"]}),
        "million-missing": json.dumps({"scenes": [f"s{i}" for i in range(200_000)]}),
        "int400": '{"scenes": ["scene_000"], "seed": ' + _HUGE_INT + "}",
        "list-top": json.dumps(["scene_000"]),
    }
    for name, text in index_variants.items():
        root = w.path(f"dataset/idx-{name}")
        _copy_scene(w, src, root / "scene_000", base)
        w.text(f"dataset/idx-{name}/dataset.json", text)
        says = ("outside",) if name.startswith(("dotdot", "absolute")) else ()
        w.add(
            Case(
                f"dataset/index-{name}",
                "dataset",
                ("evaluate", str(root), "--db", str(base.db), "--workers", "1", "-q"),
                names="dataset.json",
                says=says,
            )
        )
    link = w.path("dataset/idx-symlink-out")
    _copy_scene(w, src, link / "scene_000", base)
    w.do(functools.partial(make_symlink, link / "escape", outside))
    w.json("dataset/idx-symlink-out/dataset.json", {"scenes": ["escape"]})
    w.add(
        Case(
            "dataset/index-symlink-out",
            "dataset",
            ("evaluate", str(link), "--db", str(base.db), "--workers", "1", "-q"),
            names="dataset.json",
            says=("outside",),
        )
    )
    truth_variants: dict[str, str] = {
        "empty": "",
        "garbage": "{objects: ",
        "deep": '{"objects": ' + "[" * 50_000 + "]" * 50_000 + "}",
        "objects-not-list": json.dumps({"objects": {"a": 1}}),
        "centroid-nan": '{"objects": [{"label": "astronaut", "centroid": [NaN, 0, 1]}]}',
        "centroid-text": json.dumps({"objects": [{"label": "a", "centroid": ["x", "y", "z"]}]}),
        "centroid-short": json.dumps({"objects": [{"label": "a", "centroid": [1]}]}),
        "centroid-1e300": json.dumps({"objects": [{"label": "a", "centroid": [1e300, 0, 1]}]}),
        "label-missing": json.dumps({"objects": [{"centroid": [0, 0, 1]}]}),
        "relations-wrong": json.dumps({"objects": [], "relations": [1, 2]}),
        "relations-not-list": json.dumps({"objects": [], "relations": 5}),
        "int400": '{"objects": [{"label": "a", "centroid": [' + _HUGE_INT + ", 0, 1]}]}",
        "binary": "\x00\x01\x02",
        "top-list": "[]",
    }
    for name, text in truth_variants.items():
        root = w.path(f"dataset/truth-{name}")
        _copy_scene(w, src, root / "scene_000", base)
        w.text(f"dataset/truth-{name}/scene_000/truth.json", text)
        w.json(f"dataset/truth-{name}/dataset.json", {"scenes": ["scene_000"]})
        w.add(
            Case(
                f"dataset/truth-{name}",
                "truth",
                ("evaluate", str(root), "--db", str(base.db), "--workers", "1", "-q"),
                names="truth.json",
            )
        )
    for name, target in {
        "not-a-folder": base.calib,
        "missing": w.root / "dataset" / "nothing-here",
        "empty-folder": w.path("dataset/empty-folder"),
    }.items():
        if name == "empty-folder":
            w.do(functools.partial(target.mkdir, parents=True, exist_ok=True))
        w.add(
            Case(
                f"dataset/{name}",
                "dataset",
                ("evaluate", str(target), "--db", str(base.db), "--workers", "1", "-q"),
                names=str(target),
            )
        )
    broken = w.path("dataset/scene-broken-image")
    _copy_scene(w, src, broken / "scene_000", base)
    w.bytes("dataset/scene-broken-image/scene_000/left.png", b"\x89PNG broken")
    w.json("dataset/scene-broken-image/dataset.json", {"scenes": ["scene_000"]})
    w.add(
        Case(
            "dataset/scene-broken-image",
            "dataset",
            ("evaluate", str(broken), "--db", str(base.db), "--workers", "1", "-q"),
            expect="either",
            names="left.png",
        )
    )


def _copy_scene(w: Writer, src: Path, dest: Path, base: Base) -> None:
    def copy() -> None:
        dest.mkdir(parents=True, exist_ok=True)
        for f in ("left.png", "right.png", "calib.json", "truth.json"):
            (dest / f).write_bytes((src / f).read_bytes())

    w.do(copy)


BUILDERS = (datasets,)
