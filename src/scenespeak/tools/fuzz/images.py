"""Corpus families of image files: the stereo images (broken, huge, truncated, special files) and
the masks."""

from __future__ import annotations

import functools
import struct
import zlib
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
    keeps_labels,
    make_fifo,
    make_symlink,
    png_bytes,
)


def _png_chunk(kind: bytes, body: bytes) -> bytes:
    return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))


def png_header_only(width: int, height: int, *, idat: bool = True) -> bytes:
    """A PNG whose header declares ``width`` x ``height`` with (almost) no pixel data."""
    ihdr = struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)
    out = b"\x89PNG\r\n\x1a\n" + _png_chunk(b"IHDR", ihdr)
    if idat:
        out += _png_chunk(b"IDAT", zlib.compress(b"\x00" * 64))
    return out + _png_chunk(b"IEND", b"")


def _jpeg_huge() -> bytes:
    sof = b"\xff\xc0" + struct.pack(">HBHHB", 11, 8, 65000, 65000, 1) + b"\x01\x11\x00"
    return b"\xff\xd8" + sof + b"\xff\xd9"


def _tiff_huge() -> bytes:
    entries = [(256, 4, 1, 60000), (257, 4, 1, 60000), (258, 3, 1, 8), (277, 3, 1, 1)]
    body = struct.pack("<H", len(entries))
    for tag, typ, count, value in entries:
        body += struct.pack("<HHII", tag, typ, count, value)
    return b"II*\x00" + struct.pack("<I", 8) + body + b"\x00\x00\x00\x00"


def _bmp_huge() -> bytes:
    header = struct.pack("<2sIHHI", b"BM", 0, 0, 0, 54)
    info = struct.pack("<IiiHHIIiiII", 40, 70000, 70000, 1, 24, 0, 0, 0, 0, 0, 0)
    return header + info + b"\x00" * 64


def _image_variants(w: Writer, base: Base) -> list[tuple[str, Path, Expect]]:
    """(name, path, expect) of every broken image."""
    pair = card_pair() if w.write else (np.zeros((H, W, 3), np.uint8),) * 2
    good = png_bytes(pair[0]) if w.write else b""
    rng = np.random.default_rng(1)
    out: list[tuple[str, Path, Expect]] = []

    def add(name: str, data: bytes | Callable[[], bytes], expect: Expect = "error") -> None:
        out.append((name, w.bytes(f"images/{name}", data), expect))

    add("empty.png", b"")
    add("one-byte.png", b"\x89")
    add("text.png", b"this is not an image\n")
    add("html.png", b"<html><body>404</body></html>")
    for k, size in enumerate((16, 1000, 50_000)):
        add(f"random-{k}.png", functools.partial(rng.bytes, size))
    add("signature-only.png", b"\x89PNG\r\n\x1a\n")
    add("header-only.png", lambda: png_header_only(W, H, idat=False))
    for frac in (0.05, 0.2, 0.4, 0.6, 0.8, 0.95, 0.999):
        add(f"truncated-{int(frac * 1000)}.png", good[: int(len(good) * frac)])
    for k, offset in enumerate((20, 29, 40, 100, 1000, -20)):

        def flip(offset: int = offset) -> bytes:
            b = bytearray(good)
            b[offset] ^= 0x5A
            return bytes(b)

        add(f"bitflip-{k}.png", flip)
    add("claims-50000x50000.png", lambda: png_header_only(50_000, 50_000))
    add("claims-100000x1.png", lambda: png_header_only(100_000, 1))
    add("claims-0x0.png", lambda: png_header_only(0, 0))
    add("claims-2G.png", lambda: png_header_only(2**31 - 1, 2**31 - 1))
    add("claims-65000.jpg", _jpeg_huge)
    add("claims-60000.tif", _tiff_huge)
    add("claims-70000.bmp", _bmp_huge)
    add("claims-100000.pgm", b"P5\n100000 100000\n255\n" + b"\x00" * 100)
    add("truncated.pgm", b"P5\n320 240\n255\n" + b"\x00" * 100)
    add("garbage.webp", b"RIFF\x00\x00\x00\x00WEBPVP8 " + b"\x00" * 40)
    add("ok.jpg", lambda: png_bytes(pair[0], ".jpg"), "either")
    add("truncated.jpg", lambda: png_bytes(pair[0], ".jpg")[:3000])
    add("corrupt.jpg", lambda: png_bytes(pair[0], ".jpg")[:600] + rng.bytes(4000))
    add("tiny-1x1.png", lambda: png_bytes(np.zeros((1, 1), np.uint8)))
    add("tiny-2x3.png", lambda: png_bytes(np.zeros((2, 3, 3), np.uint8)))
    add("tiny-8x8.png", lambda: png_bytes(np.full((8, 8), 128, np.uint8)))
    add("black.png", lambda: png_bytes(np.zeros((H, W), np.uint8)))
    add("white.png", lambda: png_bytes(np.full((H, W, 3), 255, np.uint8)))
    add("noise.png", lambda: png_bytes(rng.integers(0, 255, (H, W), dtype=np.uint8)), "either")
    add("sixteen-bit.png", lambda: png_bytes(pair[0][..., 0].astype(np.uint16) * 257), "either")
    add(
        "rgba.png",
        lambda: png_bytes(np.dstack([pair[0], np.full((H, W), 255, np.uint8)])),
        "either",
    )
    add("gray.png", lambda: png_bytes(pair[0].mean(axis=2).astype(np.uint8)), "either")
    add("wrong-size-640x480.png", lambda: png_bytes(np.zeros((480, 640, 3), np.uint8)))
    add("transposed-240x320.png", lambda: png_bytes(np.zeros((W, H, 3), np.uint8)))
    add("huge-10000x10000.png", lambda: png_bytes(np.zeros((10_000, 10_000), np.uint8)))
    add("strip-20000x1.png", lambda: png_bytes(np.zeros((1, 20_000), np.uint8)))
    add(
        "float-nan.tiff",
        lambda: png_bytes(np.full((H, W), np.nan, np.float32), ".tiff"),
    )
    add("looks-like-png.jpg", good, "either")
    # not regular files
    folder = w.path("images/folder.png")
    w.do(lambda: folder.mkdir(exist_ok=True))
    out.append(("folder.png", folder, "error"))
    fifo = w.path("images/fifo.png")
    w.do(functools.partial(make_fifo, fifo))
    out.append(("fifo.png", fifo, "error"))
    zero = w.path("images/zero.png")
    w.do(functools.partial(make_symlink, zero, "/dev/zero"))
    out.append(("dev-zero.png", zero, "error"))
    loop = w.path("images/loop.png")
    w.do(functools.partial(make_symlink, loop, loop))
    out.append(("symlink-loop.png", loop, "error"))
    out.append(("missing.png", w.root / "images" / "no-such-file.png", "error"))
    out.append(("name-300-bytes.png", w.root / "images" / ("x" * 300 + ".png"), "error"))
    out.append(("escape-in-name.png", w.bytes("images/esc\x1b[31mred.png", b"junk"), "error"))
    out.append(("newline-in-name.png", w.bytes("images/new\nline.png", b"junk"), "error"))
    return out


def images(w: Writer, base: Base) -> None:
    """Every broken image as a left image, right image, training image and mask."""
    db = str(base.db)
    for name, path, expect in _image_variants(w, base):
        p = str(path)
        q = "-q"
        w.add(
            Case(
                f"image/{name}/describe-left",
                "images",
                ("describe", "--db", db, "--calib", str(base.calib), p, str(base.right), q),
                expect=expect,
                names=p,
            )
        )
        w.add(
            Case(
                f"image/{name}/describe-right",
                "images",
                ("describe", "--db", db, "--calib", str(base.calib), str(base.left), p, q),
                expect=expect,
                names=p,
            )
        )
        w.add(
            Case(
                f"image/{name}/points-left",
                "images",
                ("points", "--calib", str(base.calib), p, str(base.right), q),
                expect=expect,
                names=p,
            )
        )
        copy = base.fresh_db(f"img-{name}")
        copy_mask = base.fresh_db(f"img-mask-{name}")
        add_expect: Expect = "either" if expect != "error" else "error"
        if name in ("black.png", "white.png", "wrong-size-640x480.png", "transposed-240x320.png"):
            add_expect = "either"  # a training image may have any size; a blank one has no features
        w.add(
            Case(
                f"image/{name}/db-add",
                "images",
                ("db", "add", "--db", str(copy), "--label", "new", p, q),
                expect=add_expect,
                names=p,
                setup=functools.partial(base.copy_db, copy),
                check=keeps_labels(copy, ("astronaut", "coffee")),
            )
        )
        w.add(
            Case(
                f"image/{name}/db-add-mask",
                "masks",
                (
                    "db",
                    "add",
                    "--db",
                    str(copy_mask),
                    "--label",
                    "new",
                    str(base.train["astronaut"]),
                    "--mask",
                    p,
                    q,
                ),
                expect="either" if name in ("white.png", "gray.png", "noise.png") else "error",
                names=p,
                setup=functools.partial(base.copy_db, copy_mask),
                check=keeps_labels(copy_mask, ("astronaut", "coffee")),
            )
        )


def masks(w: Writer, base: Base) -> None:
    """Masks that are images but wrong as masks."""
    variants: dict[str, Callable[[], bytes]] = {
        "one-pixel.png": lambda: png_bytes(
            np.pad(np.full((1, 1), 255, np.uint8), ((99, 100),) * 2)
        ),
        "all-black.png": lambda: png_bytes(np.zeros((200, 200), np.uint8)),
        "other-size.png": lambda: png_bytes(np.full((50, 70), 255, np.uint8)),
        "line.png": lambda: png_bytes(
            np.pad(np.full((1, 150), 255, np.uint8), ((100, 99), (25, 25)))
        ),
        "checker.png": lambda: png_bytes(
            ((np.indices((200, 200)).sum(0) % 2) * 255).astype(np.uint8)
        ),
        "gray-127.png": lambda: png_bytes(np.full((200, 200), 127, np.uint8)),
    }
    for name, make in variants.items():
        p = w.bytes(f"masks/{name}", make)
        copy = base.fresh_db(f"mask-{name}")
        w.add(
            Case(
                f"mask/{name}",
                "masks",
                (
                    "db",
                    "add",
                    "--db",
                    str(copy),
                    "--label",
                    "new",
                    str(base.train["astronaut"]),
                    "--mask",
                    str(p),
                    "-q",
                ),
                expect="either" if name in ("checker.png", "gray-127.png", "line.png") else "error",
                names=str(p),
                setup=functools.partial(base.copy_db, copy),
                check=keeps_labels(copy, ("astronaut", "coffee")),
            )
        )
    copy = base.fresh_db("mask-count")
    w.add(
        Case(
            "mask/two-masks-one-image",
            "masks",
            (
                "db",
                "add",
                "--db",
                str(copy),
                "--label",
                "new",
                str(base.train["astronaut"]),
                "--mask",
                str(base.mask),
                "--mask",
                str(base.mask),
                "-q",
            ),
            names="--mask",
            setup=lambda: base.copy_db(copy),
            check=keeps_labels(copy, ("astronaut", "coffee")),
        )
    )


BUILDERS = (images, masks)
