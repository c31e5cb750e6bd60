"""Corpus families for the inputs that came after the first corpus: RGB-D input (``describe
COLOR --depth --intrinsics --masks``) and ``watch`` (``annotate`` and ``ask`` are in
:mod:`~scenespeak.tools.fuzz.jobs`).

Each case is a command line; what must happen is as everywhere in the corpus (one line naming
the file, exit 2; or, for ``"either"``, no traceback, hang or memory blow-up). Stream cases
(``watch``) may skip a broken frame with a ``scenespeak: warning:`` line or refuse it; both are
fine, a traceback or a silent wrong answer is not. All files are generated here, fixed seeds.
The HTTP service (``serve``) has its own family in :mod:`~scenespeak.tools.fuzz.service`.
"""

from __future__ import annotations

import functools
import json
import os
from collections.abc import Callable
from pathlib import Path

import numpy as np

from scenespeak.tools.fuzz.corpus import (
    Base,
    Case,
    Expect,
    H,
    W,
    Writer,
    card_pair,
    make_fifo,
    png_bytes,
)

FX = 277.1281292110204
#: instance k of the RGB-D frame: (label, x0, y0, size, depth in metres)
CARDS = ((1, "astronaut", 70, 90, 60, 1.0), (2, "coffee", 200, 100, 45, 1.3))


def _no_escapes(code: int, out: str, err: str) -> tuple[str, str] | None:
    """A check: nothing printed carries a raw terminal escape."""
    if "\x1b" in out or "\x1b" in err:
        return ("security", "a raw escape sequence was printed")
    return None


# --------------------------------------------------------------------------------------------
# a valid RGB-D frame, then each file broken in one way


def rgbd_arrays() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Colour (the stereo pair's left image), 16-bit depth in mm, 8-bit instance image."""
    color = card_pair()[0]
    depth = np.full((H, W), 4000, np.uint16)
    masks = np.zeros((H, W), np.uint8)
    for k, _, x, y, s, z in CARDS:
        depth[y : y + s, x : x + s] = int(z * 1000)
        masks[y : y + s, x : x + s] = k
    return color, depth, masks


def _intrinsics(**changes: object) -> dict[str, object]:
    d: dict[str, object] = {
        "fx": FX,
        "fy": FX,
        "cx": (W - 1) / 2,
        "cy": (H - 1) / 2,
        "width": W,
        "height": H,
    }
    d.update(changes)
    return d


def _npy(arr: np.ndarray) -> bytes:
    import io

    buf = io.BytesIO()
    np.save(buf, arr, allow_pickle=True)
    return buf.getvalue()


def _rgbd_base(w: Writer) -> dict[str, Path]:
    arrays = functools.cache(rgbd_arrays)
    return {
        "color": w.bytes("rgbd/color.png", lambda: png_bytes(arrays()[0])),
        "depth": w.bytes("rgbd/depth.png", lambda: png_bytes(arrays()[1])),
        "masks": w.bytes("rgbd/masks.png", lambda: png_bytes(arrays()[2])),
        "labels": w.json("rgbd/labels.json", {str(k): label for k, label, *_ in CARDS}),
        "intrinsics": w.json("rgbd/intrinsics.json", _intrinsics()),
    }


def _depth_variants(w: Writer) -> dict[str, tuple[Path, Expect]]:
    def arr() -> np.ndarray:
        return rgbd_arrays()[1]

    out: dict[str, tuple[Path, Expect]] = {}

    def add(name: str, data: object, expect: Expect = "error") -> None:
        out[name] = (w.bytes(f"rgbd/depth/{name}", data), expect)  # type: ignore[arg-type]

    add("eight-bit.jpg", lambda: png_bytes((arr() // 16).astype(np.uint8), ".jpg"), "either")
    add("rgb.png", lambda: png_bytes(np.dstack([(arr() // 16).astype(np.uint8)] * 3)), "either")
    add("text.png", b"this is not a depth image\n")
    add("empty.png", b"")
    add("truncated.png", lambda: png_bytes(arr())[:500])
    add("all-zero.png", lambda: png_bytes(np.zeros((H, W), np.uint16)))
    add("wrong-size-640x480.png", lambda: png_bytes(np.full((480, 640), 1000, np.uint16)))
    add("transposed.png", lambda: png_bytes(np.ascontiguousarray(arr().T)))
    add("claims-50000.png", lambda: _header_only(50_000, 50_000))
    add("complex.npy", lambda: _npy(arr().astype(np.complex128)))
    add("object.npy", lambda: _npy(np.array([[None, {"a": 1}]], dtype=object)))
    add("three-d.npy", lambda: _npy(np.ones((2, H, W), np.float32)))
    add("strings.npy", lambda: _npy(np.array([["1.0"] * W] * H)))
    add("negative.npy", lambda: _npy(-np.ones((H, W), np.float32)))
    add("all-nan.npy", lambda: _npy(np.full((H, W), np.nan, np.float32)))
    add("huge-1e30.npy", lambda: _npy(np.full((H, W), 1e30, np.float32)))
    add("npy-garbage.npy", b"\x93NUMPY\x01\x00garbage")
    add("npy-claims-huge.npy", _npy_claims_huge)
    add("float.tif", lambda: png_bytes(arr().astype(np.float32) / 1000, ".tiff"), "either")
    return out


def _header_only(width: int, height: int) -> bytes:
    from scenespeak.tools.fuzz.images import png_header_only

    return png_header_only(width, height)


def _npy_claims_huge() -> bytes:
    header = "{'descr': '<f8', 'fortran_order': False, 'shape': (100000, 100000), }"
    header = header + " " * (117 - len(header)) + "\n"
    return b"\x93NUMPY\x01\x00" + len(header).to_bytes(2, "little") + header.encode() + b"\0" * 64


def rgbd(w: Writer, base: Base) -> None:
    """``describe COLOR --depth D --intrinsics I --masks M --labels L`` with one file broken."""
    ok = _rgbd_base(w)

    def argv(**files: Path | str) -> tuple[str, ...]:
        f = {**ok, **files}
        args = ["describe", str(f["color"]), "--depth", str(f["depth"])]
        args += ["--intrinsics", str(f["intrinsics"]), "--masks", str(f["masks"])]
        args += ["--labels", str(f["labels"]), "-q"]
        return tuple(args)

    w.add(Case("rgbd/valid", "rgbd", argv(), expect="ok"))
    for name, (path, expect) in _depth_variants(w).items():
        w.add(Case(f"rgbd/depth-{name}", "rgbd", argv(depth=path), expect=expect, names=str(path)))
    fifo = w.path("rgbd/depth/fifo.png")
    w.add(
        Case(
            "rgbd/depth-fifo",
            "rgbd",
            argv(depth=fifo),
            names=str(fifo),
            setup=functools.partial(make_fifo, fifo),
        )
    )
    _mask_and_label_cases(w, ok, argv)
    _intrinsics_cases(w, argv)
    for scale, expect in (("0", "error"), ("-1", "error"), ("nan", "error"), ("1e300", "error")):
        w.add(
            Case(
                f"rgbd/depth-scale={scale}",
                "rgbd",
                (*argv(), "--depth-scale", scale),
                expect=expect,
            )
        )


def _mask_and_label_cases(
    w: Writer, ok: dict[str, Path], argv: Callable[..., tuple[str, ...]]
) -> None:
    make = argv  # a callable(**files) -> argv
    masks: dict[str, tuple[object, Expect]] = {
        "other-size.png": (lambda: png_bytes(np.ones((100, 100), np.uint8)), "error"),
        "empty-all-zero.png": (lambda: png_bytes(np.zeros((H, W), np.uint8)), "error"),
        "rgb.png": (lambda: png_bytes(np.dstack([rgbd_arrays()[2]] * 3)), "either"),
        "many-instances.png": (
            lambda: png_bytes(np.arange(H * W, dtype=np.uint32).reshape(H, W).astype(np.uint16)),
            "either",
        ),
        "garbage.png": (b"\x89PNG\r\n\x1a\n" + os.urandom(0) + b"\x00" * 64, "error"),
    }
    for name, (data, expect) in masks.items():
        p = w.bytes(f"rgbd/masks/{name}", data)  # type: ignore[arg-type]
        w.add(Case(f"rgbd/masks-{name}", "rgbd", make(masks=p), expect=expect, names=str(p)))
    labels: dict[str, tuple[str, Expect]] = {
        "missing-instance.json": (
            json.dumps({"1": "astronaut", "2": "coffee", "7": "x"}),
            "either",
        ),
        "only-one.json": (json.dumps({"1": "astronaut"}), "either"),
        "not-a-mapping.json": (json.dumps(["astronaut", "coffee"]), "either"),
        "numbers.json": (json.dumps({"1": 5, "2": 6}), "error"),
        "escape.json": (json.dumps({"1": "\x1b[2Jmug", "2": "coffee"}), "error"),
        "empty-label.json": (json.dumps({"1": "", "2": "coffee"}), "error"),
        "key-not-number.json": (json.dumps({"one": "astronaut"}), "error"),
        "key-negative.json": (json.dumps({"-1": "astronaut"}), "error"),
        "key-huge.json": (json.dumps({str(2**70): "astronaut"}), "error"),
        "deep.json": ("[" * 50_000 + "]" * 50_000, "error"),
        "garbage.json": ("{1: astronaut", "error"),
        "non-utf8.json": ("", "error"),
        "long-label.json": (json.dumps({"1": "m" * 100_000}), "error"),
    }
    for name, (text, expect) in labels.items():
        if name == "non-utf8.json":
            p = w.bytes(f"rgbd/labels/{name}", b'{"1": "\xff\xfe"}')
        else:
            p = w.text(f"rgbd/labels/{name}", text)
        w.add(
            Case(
                f"rgbd/labels-{name}",
                "rgbd",
                make(labels=p),
                expect=expect,
                names=str(p),
                check=_no_escapes,
            )
        )


def _intrinsics_cases(w: Writer, argv: Callable[..., tuple[str, ...]]) -> None:
    from scenespeak.tools.fuzz.calibrations import _billion_laughs

    make = argv
    variants: dict[str, tuple[str, Expect]] = {
        "deep.json": ('{"fx": ' + "[" * 50_000 + "]" * 50_000 + "}", "error"),
        "billion-laughs.yml": (_billion_laughs(), "error"),
        "fx-1e300.json": (json.dumps(_intrinsics(fx=1e300, fy=1e300)), "error"),
        "fx-negative.json": (json.dumps(_intrinsics(fx=-FX)), "error"),
        "fx-zero.json": (json.dumps(_intrinsics(fx=0)), "error"),
        "fx-nan-literal.json": (json.dumps(_intrinsics()).replace(str(FX), "NaN", 1), "error"),
        "fx-text.json": (json.dumps(_intrinsics(fx="277")), "error"),
        "fx-bool.json": (json.dumps(_intrinsics(fx=True)), "error"),
        "width-1e9.json": (json.dumps(_intrinsics(width=10**9, height=10**9)), "error"),
        "other-size.json": (json.dumps(_intrinsics(width=640, height=480)), "error"),
        "int400.json": (json.dumps(_intrinsics()).replace(str(FX), "9" * 400, 1), "error"),
        "missing-fx.json": (
            json.dumps({k: v for k, v in _intrinsics().items() if k != "fx"}),
            "error",
        ),
        "up-zero.json": (json.dumps(_intrinsics(up=[0, 0, 0])), "error"),
        "up-complex-text.json": (json.dumps(_intrinsics(up=["1j", 0, 0])), "error"),
        "python-tag.yml": ("fx: !!python/object/apply:os.system ['true']\n", "error"),
        "list-top.json": (json.dumps([FX, FX]), "error"),
    }
    for name, (text, expect) in variants.items():
        p = w.text(f"rgbd/intrinsics/{name}", text)
        w.add(
            Case(f"rgbd/intrinsics-{name}", "rgbd", make(intrinsics=p), expect=expect, names=str(p))
        )


# --------------------------------------------------------------------------------------------
# watch


def _frames_folder(w: Writer, name: str, frames: int, broken: dict[str, object]) -> Path:
    """``watch/NAME/NNNN/{left,right}.png``: the base pair ``frames`` times, with the files in
    ``broken`` (``"0001/right.png"`` → bytes or a callable) replaced."""
    pair = functools.cache(card_pair)
    root = w.path(f"watch/{name}")
    for k in range(frames):
        for side, idx in (("left", 0), ("right", 1)):
            rel = f"{k:04d}/{side}.png"
            data = broken.get(rel, functools.partial(lambda i: png_bytes(pair()[i]), idx))
            if data is not None:
                w.bytes(f"watch/{name}/{rel}", data)  # type: ignore[arg-type]
    return root


def watch(w: Writer, base: Base) -> None:
    """``watch`` on broken folders, frames, bags and videos."""
    run = ("watch", "--db", str(base.db), "--calib", str(base.calib), "-q")
    empty = w.path("watch/empty")
    w.do(lambda: empty.mkdir(parents=True, exist_ok=True))
    afile = w.bytes("watch/a-file.png", b"not a folder")
    garbage = functools.partial(os.urandom, 2000)
    cases: dict[str, tuple[tuple[str, ...], Expect, str | None]] = {
        "frames-missing": (("--frames", str(w.root / "watch/nope")), "error", "nope"),
        "frames-a-file": (("--frames", str(afile)), "error", str(afile)),
        "frames-empty": (("--frames", str(empty)), "error", str(empty)),
    }
    folders: dict[str, tuple[int, dict[str, object], Expect, str | None]] = {
        "ok": (2, {}, "ok", None),
        "right-missing": (2, {"0001/right.png": None}, "either", "0001"),
        "right-other-size": (
            2,
            {"0001/right.png": lambda: png_bytes(np.zeros((480, 640, 3), np.uint8))},
            "either",
            "0001",
        ),
        "left-corrupt": (2, {"0001/left.png": garbage}, "either", "0001"),
        "left-truncated": (
            2,
            {"0000/left.png": lambda: png_bytes(card_pair()[0])[:700]},
            "either",
            "0000",
        ),
        "left-empty": (2, {"0000/left.png": b""}, "either", "0000"),
        "left-claims-50000": (
            2,
            {"0000/left.png": lambda: _header_only(50_000, 50_000)},
            "either",
            "0000",
        ),
        "left-huge-10000": (
            1,
            {"0000/left.png": lambda: png_bytes(np.zeros((10_000, 10_000), np.uint8))},
            "either",
            "0000",
        ),
        "sizes-change": (
            2,
            {
                "0001/left.png": lambda: png_bytes(np.zeros((480, 640, 3), np.uint8)),
                "0001/right.png": lambda: png_bytes(np.zeros((480, 640, 3), np.uint8)),
            },
            "either",
            "0001",
        ),
    }
    for name, (n, broken, expect, names) in folders.items():
        root = _frames_folder(w, name, n, broken)
        cases[f"frames-{name}"] = (("--frames", str(root)), expect, names)
    odd = w.path("watch/odd-names")
    for rel in ("left_abc.png", "right_abc.png", "left_0001.png"):
        w.bytes(f"watch/odd-names/{rel}", lambda: png_bytes(card_pair()[0]))
    cases["frames-odd-names"] = (("--frames", str(odd)), "either", None)
    bag_file = w.bytes("watch/garbage.bag", garbage)
    bag_dir = w.path("watch/bag-dir")
    w.text("watch/bag-dir/metadata.yaml", "rosbag2_bagfile_information: [")
    w.bytes("watch/bag-dir/bag_0.db3", b"SQLite format 3\x00" + b"\x00" * 200)
    empty_bag = w.path("watch/empty-bag")
    w.do(lambda: empty_bag.mkdir(parents=True, exist_ok=True))
    video = w.bytes("watch/garbage.mp4", garbage)
    for name, args, names in (
        ("rosbag-garbage", ("--rosbag", str(bag_file)), str(bag_file)),
        ("rosbag-bad-metadata", ("--rosbag", str(bag_dir)), str(bag_dir)),
        ("rosbag-empty-folder", ("--rosbag", str(empty_bag)), str(empty_bag)),
        ("rosbag-missing", ("--rosbag", str(w.root / "watch/nope.bag")), "nope.bag"),
        ("sbs-garbage", ("--sbs", str(video)), str(video)),
        ("videos-garbage", ("--left-video", str(video), "--right-video", str(video)), str(video)),
        (
            "videos-missing",
            ("--left-video", str(w.root / "watch/no.mp4"), "--right-video", str(video)),
            "no.mp4",
        ),
    ):
        cases[name] = (args, "error", names)
    rgbd_dir = w.path("watch/rgbd-bad")
    arrays = functools.cache(rgbd_arrays)
    w.bytes("watch/rgbd-bad/0000/color.png", lambda: png_bytes(arrays()[0]))
    w.bytes(
        "watch/rgbd-bad/0000/depth.png", lambda: png_bytes(np.full((480, 640), 1000, np.uint16))
    )
    w.bytes("watch/rgbd-bad/0000/masks.png", lambda: png_bytes(arrays()[2]))
    intr = w.json("watch/intrinsics.json", _intrinsics())
    cases["rgbd-depth-other-size"] = (
        ("--rgbd", str(rgbd_dir), "--intrinsics", str(intr)),
        "either",
        "0000",
    )
    for name, (extra, expect, names) in cases.items():
        w.add(Case(f"watch/{name}", "watch", (*run, *extra), expect=expect, names=names))


BUILDERS = (rgbd, watch)
