"""Corpus family: every command-line option with values it must refuse (or take)."""

from __future__ import annotations

from pathlib import Path
from typing import cast

from scenespeak.tools.fuzz.corpus import Base, Case, Checker, Expect, Writer


def _untouched(path: Path, content: bytes) -> Checker:
    def check(code: int, out: str, err: str) -> tuple[str, str] | None:
        try:
            now = path.read_bytes()
        except OSError:
            return ("data loss", f"{path} is gone")
        return None if now == content else ("security", f"wrote through a symlink into {path}")

    return check


def options(w: Writer, base: Base) -> None:
    """Bad values of every option of every command."""
    _points_options(w, base)
    _describe_options(w, base)
    _generate_options(w, base)
    _evaluate_options(w, base)
    _usage_options(w, base)
    _limit_options(w, base)
    _value_options(w, base)


def _commands(
    base: Base,
) -> tuple[tuple[str, str], tuple[str, str], tuple[str, ...], tuple[str, ...]]:
    """The stereo pair, the --calib option and the ``points`` and ``describe`` command lines."""
    pair = (str(base.left), str(base.right))
    calib = ("--calib", str(base.calib))
    points = ("points", *calib, *pair, "-q")
    describe = ("describe", "--db", str(base.db), *calib, *pair, "-q")
    return pair, calib, points, describe


def _points_options(w: Writer, base: Base) -> None:
    """``points``: --ratio, --format and --out."""
    _pair, _calib, points, _describe = _commands(base)
    for value, expect in (
        ("0", "error"),
        ("-1", "error"),
        ("nan", "error"),
        ("inf", "error"),
        ("-inf", "error"),
        ("1.5", "error"),
        ("1", "either"),
        ("abc", "error"),
        ("1e400", "error"),
        ("", "error"),
        ("0.6", "ok"),
        ("0.999", "ok"),
        ("1e-300", "error"),
    ):
        w.add(
            Case(
                f"option/points--ratio={value or 'empty'}",
                "options",
                (*points, f"--ratio={value}"),
                expect=cast(Expect, expect),
                names="--ratio",
            )
        )
    for value in ("xml", "", "JSON ", "ply\n"):
        w.add(
            Case(
                f"option/points--format={value.strip() or 'empty'}{len(value)}",
                "options",
                (*points, f"--format={value}"),
                names="--format",
            )
        )
    out_dir = w.path("options/out-is-a-folder")
    w.do(lambda: out_dir.mkdir(parents=True, exist_ok=True))
    for name, out, expect in (
        ("folder", out_dir, "error"),
        ("missing-dir", w.root / "options" / "nope" / "p.json", "error"),
        ("dev-full", Path("/dev/full"), "error"),
        ("name-300", w.root / "options" / ("o" * 300 + ".json"), "error"),
    ):
        w.add(
            Case(
                f"option/points--out-{name}",
                "options",
                (*points, "--out", str(out)),
                expect=cast(Expect, expect),
                names=str(out),
            )
        )
    w.add(Case("option/points-ply-no-out", "options", (*points, "--format", "ply"), names="--out"))
    w.add(
        Case(
            "option/points-ply-out-folder",
            "options",
            (*points, "--format", "ply", "--out", str(out_dir)),
            names=str(out_dir),
        )
    )


def _describe_options(w: Writer, base: Base) -> None:
    """``describe``: --format and --figures (a file, planted symlinks, a folder in the way)."""
    _pair, _calib, _points, describe = _commands(base)
    w.add(
        Case(
            "option/describe--format=xml",
            "options",
            (*describe, "--format", "xml"),
            names="--format",
        )
    )
    figfile = w.bytes("options/figures-is-a-file", b"x")
    w.add(
        Case(
            "option/describe--figures-file",
            "options",
            (*describe, "--figures", str(figfile)),
            names=str(figfile),
        )
    )
    planted = w.path("options/fig-symlink")
    victim = w.path("options/victim.txt")
    victim_bytes = b"do not overwrite me\n"

    def plant() -> None:
        planted.mkdir(parents=True, exist_ok=True)
        victim.write_bytes(victim_bytes)
        for name in (
            "matches.png",
            "hulls.png",
            "points3d.png",
            "histograms.png",
            "report.png",
            "report.html",
        ):
            link = planted / name
            if link.is_symlink() or link.exists():
                link.unlink()
            link.symlink_to(victim)

    w.add(
        Case(
            "option/describe--figures-symlinks",
            "options",
            (*describe, "--figures", str(planted)),
            expect="either",
            names=str(planted),
            setup=plant,
            check=_untouched(victim, victim_bytes),
            timeout=60.0,
        )
    )
    folder_fig = w.path("options/fig-folder")

    def folders() -> None:
        (folder_fig / "matches.png").mkdir(parents=True, exist_ok=True)

    w.add(
        Case(
            "option/describe--figures-matches-is-folder",
            "options",
            (*describe, "--figures", str(folder_fig)),
            names="matches.png",
            setup=folders,
            timeout=60.0,
        )
    )


def _generate_options(w: Writer, base: Base) -> None:
    """``scenes generate`` and ``demo``: --seed, --n and an output that is a file."""
    for value, expect in (
        ("-1", "error"),
        ("abc", "error"),
        (str(2**64), "error"),
        ("1.5", "error"),
    ):
        out = w.root / "options" / f"gen-seed-{value[:5]}"
        w.add(
            Case(
                f"option/scenes-generate--seed={value[:8]}",
                "options",
                ("scenes", "generate", str(out), "--seed", value, "-q"),
                expect=cast(Expect, expect),
                names="--seed",
            )
        )
        w.add(
            Case(
                f"option/demo--seed={value[:8]}",
                "options",
                ("demo", str(out), "--seed", value, "-q"),
                expect=cast(Expect, expect),
                names="--seed",
            )
        )
    for value in ("0", "-1", "abc", str(10**9), str(2**70)):
        out = w.root / "options" / f"gen-n-{value[:5]}"
        w.add(
            Case(
                f"option/scenes-generate--n={value[:8]}",
                "options",
                ("scenes", "generate", str(out), "--n", value, "-q"),
                names="--n",
            )
        )
    genfile = w.bytes("options/generate-into-a-file", b"x")
    w.add(
        Case(
            "option/scenes-generate-into-file",
            "options",
            ("scenes", "generate", str(genfile), "--n", "1", "-q"),
            names=str(genfile),
        )
    )
    w.add(
        Case("option/demo-into-file", "options", ("demo", str(genfile), "-q"), names=str(genfile))
    )


def _evaluate_options(w: Writer, base: Base) -> None:
    """``evaluate``: --workers and a missing --db."""
    ev = ("evaluate", str(base.dataset), "--db", str(base.db), "-q")
    for value in ("0", "-1", "abc", str(10**6), str(2**70)):
        w.add(
            Case(
                f"option/evaluate--workers={value[:8]}",
                "options",
                (*ev, "--workers", value),
                names="--workers",
            )
        )
    w.add(
        Case(
            "option/evaluate--db-missing",
            "options",
            (
                "evaluate",
                str(base.dataset),
                "--db",
                str(w.root / "nope.db"),
                "--workers",
                "1",
                "-q",
            ),
            names="nope.db",
        )
    )


def _usage_options(w: Writer, base: Base) -> None:
    """Usage errors: missing arguments and options, unknown commands and options."""
    pair, calib, _points, _describe = _commands(base)
    for argv, names in (
        (("describe", *pair), "--db"),
        (("describe", "--db", str(base.db), *calib, str(base.left)), "right"),
        (("points", *pair), "--calib"),
        (("db", "add", "--db", str(base.db), str(base.left)), "--label"),
        (("db", "add", "--label", "x", str(base.left)), "--db"),
        (("db", "frobnicate"), "frobnicate"),
        (("describe", "--no-such-option", *pair), "--no-such-option"),
        (("describe", "--db"), "--db"),
        (("no-such-command",), "no-such-command"),
        (("points", *calib, *pair, "--ratio"), "--ratio"),
        (("points", "--calib-right", str(base.calib), *pair), "--calib"),
    ):
        w.add(
            Case(
                f"option/usage-{'-'.join(a.strip('-') for a in argv[:2])}-{names.strip('-')}",
                "options",
                argv,
                names=names,
            )
        )


def _limit_options(w: Writer, base: Base) -> None:
    """The global --limit option."""
    pair, _calib, points, _describe = _commands(base)
    for value, says in (
        ("nonsense=5", "NAME=VALUE"),
        ("max_nesting=-1", "positive"),
        ("max_nesting=abc", "number"),
        ("max_nesting", "NAME=VALUE"),
        ("max_nesting=inf", "finite"),
        ("max_nesting=1e300", ""),
    ):
        w.add(
            Case(
                f"option/--limit-{value[:20]}",
                "options",
                ("--limit", value, *points),
                names="--limit",
                says=(says,) if says else (),
            )
        )
    tiny = ("--limit", "max_image_pixels=1000", *points)
    w.add(
        Case(
            "option/--limit-pixels-refuses",
            "options",
            tiny,
            names=str(base.left),
            says=("max_image_pixels",),
        )
    )
    raised = (
        "--limit",
        "max_nesting=200000",
        "points",
        "--calib",
        str(w.root / "calib" / "deep-list.json"),
        *pair,
        "-q",
    )
    w.add(
        Case(
            "option/--limit-nesting-raised",
            "options",
            raised,
            expect="either",
            names="deep-list.json",
        )
    )


def _value_options(w: Writer, base: Base) -> None:
    """--image-size, --units and --up of ``points``, --pitch of ``describe``."""
    _pair, _calib, points, describe = _commands(base)
    for name in ("image-size-bad", "image-size-zero", "image-size-huge"):
        value = {
            "image-size-bad": "abc",
            "image-size-zero": "0x0",
            "image-size-huge": "100000x100000",
        }[name]
        w.add(
            Case(
                f"option/points--{name}",
                "options",
                (*points, "--image-size", value),
                names="--image-size",
            )
        )
    for value in ("cm", "", "MM", "furlongs"):
        unit_expect: Expect = "either" if value in ("cm", "MM") else "error"
        w.add(
            Case(
                f"option/points--units={value or 'empty'}",
                "options",
                (*points, "--units", value),
                expect=unit_expect,
                names="--units",
            )
        )
    for value in ("0,0,0", "a,b,c", "1,2", "nan,1,0"):
        w.add(Case(f"option/points--up={value}", "options", (*points, "--up", value), names="--up"))
    for value in ("nan", "100", "-91", "abc"):
        w.add(
            Case(
                f"option/describe--pitch={value}",
                "options",
                (*describe, "--pitch", value),
                names="--pitch",
            )
        )


BUILDERS = (options,)
