"""Corpus family: the Python API with values a caller might pass by mistake.

Each case calls one public function. ``expect="error"``: it must raise a
:class:`~scenespeak.errors.ScenespeakError` (anything else is a traceback; returning is
silently wrong). ``expect="either"`` with a check: a returned value must make sense (finite,
not all zero where there is something to see).
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from typing import Any

import numpy as np

from scenespeak.tools.fuzz.corpus import Base, Case, Expect, Writer

SQ = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
RIGHT = SQ + np.array([3.0, 0.0])


def _call(module: str, name: str, *args: Any, **kwargs: Any) -> Callable[[], object]:
    def run() -> object:
        mod = importlib.import_module(module)
        return getattr(mod, name)(*args, **kwargs)

    return run


class WrongAnswer(AssertionError):
    """Raised by a check when a returned value is silently wrong."""


def _sane_histogram(value: object) -> object:
    h = np.asarray(value)
    if h.dtype.kind not in "f" or not np.isfinite(h).all():
        raise WrongAnswer(f"histogram has non-finite values: {h.ravel()[:4]}")
    if not (h > 0).any():
        raise WrongAnswer("histogram is all zero for two separate objects")
    if (h < 0).any():
        raise WrongAnswer("histogram has negative forces")
    return value


def _sane_relation(value: object) -> object:
    sentence = getattr(value, "sentence", "")
    if not isinstance(sentence, str) or not sentence:
        raise WrongAnswer(f"no sentence: {value!r:.80}")
    for field in ("degree", "degrees"):
        d = getattr(value, field, None)
        if isinstance(d, float) and not np.isfinite(d):
            raise WrongAnswer(f"{field} is {d}")
    return value


def _checked(fn: Callable[[], object], check: Callable[[object], object]) -> Callable[[], object]:
    def run() -> object:
        return check(fn())

    return run


def _histogram_cases(w: Writer) -> None:
    """The force and hybrid histograms (and ``relate``) on bad polygons, masks and options."""
    _polygon_cases(w)
    _r_cases(w)
    _directions_cases(w)
    _mask_cases(w)
    _hybrid_p_cases(w)


def _polygon_cases(w: Writer) -> None:
    forces = "scenespeak.spatial.forces"
    polys: dict[str, tuple[Any, Any, Expect]] = {
        "complex": (SQ.astype(complex) + 1j, RIGHT, "error"),
        "complex-list": ([[0j, 0], [1, 0], [1, 1]], RIGHT, "error"),
        "object-array": (np.array([[0, 0], [1, "a"], [1, 1]], dtype=object), RIGHT, "error"),
        "strings": ([["0", "0"], ["1", "0"], ["1", "1"]], RIGHT, "error"),
        "nan": (np.where(SQ == 1.0, np.nan, SQ), RIGHT, "error"),
        "inf": (np.full((4, 2), np.inf), RIGHT, "error"),
        "empty": (np.zeros((0, 2)), RIGHT, "error"),
        "one-vertex": (SQ[:1], RIGHT, "error"),
        "two-vertices": (SQ[:2], RIGHT, "error"),
        "three-d": (np.zeros((4, 3)), RIGHT, "error"),
        "collinear": (np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]]), RIGHT, "error"),
        "bow-tie": (np.array([[0.0, 0.0], [1.0, 1.0], [1.0, 0.0], [0.0, 1.0]]), RIGHT, "error"),
        "scaled-1e-160": (SQ * 1e-160, RIGHT * 1e-160, "either"),
        "scaled-1e150": (SQ * 1e150, RIGHT * 1e150, "either"),
        "scaled-1e300": (SQ * 1e300, RIGHT * 1e300, "either"),
        "offset-1e300": (SQ + 1e300, RIGHT + 1e300, "either"),
        "sliver": (np.array([[0.0, 0.0], [1.0, 1e-12], [2.0, 0.0]]), RIGHT, "either"),
        "far-apart": (SQ, SQ + np.array([1e12, 0.0]), "either"),
        "none": (None, RIGHT, "error"),
        "scalar": (5.0, RIGHT, "error"),
        "bool-list": ([[True, False], [False, True]], RIGHT, "error"),
        "int-huge": (
            np.array([[0, 0], [2**62, 0], [2**62, 2**62]], dtype=np.int64),
            RIGHT,
            "either",
        ),
        "float16": (SQ.astype(np.float16), RIGHT.astype(np.float16), "either"),
        "mask-vs-polygon": (np.ones((4, 4), bool), RIGHT, "error"),
    }
    for name, (a, b, expect) in polys.items():
        for fn in ("force_histogram", "hybrid_histogram"):
            call = _call(forces, fn, a, b, directions=16)
            if expect != "error":
                call = _checked(call, _sane_histogram)
            w.add(Case(f"api/{fn}/polygon-{name}", "api", api=call, expect=expect))
        rel = _call("scenespeak.spatial.language", "relate", a, b)
        w.add(
            Case(
                f"api/relate/polygon-{name}",
                "api",
                api=_checked(rel, _sane_relation) if expect != "error" else rel,
                expect=expect,
            )
        )


def _r_cases(w: Writer) -> None:
    forces = "scenespeak.spatial.forces"
    r_values: tuple[object, ...] = (
        1e6,
        -1e6,
        1e300,
        np.nan,
        np.inf,
        "2",
        None,
        2 + 0j,
        [2.0],
        True,
    )
    for value in r_values:
        call = _call(forces, "force_histogram", SQ, RIGHT, r=value, directions=16)
        expect: Expect = "either" if isinstance(value, float) and np.isfinite(value) else "error"
        if isinstance(value, float) and abs(value) >= 1e6:
            call = _checked(call, _sane_histogram)
        w.add(Case(f"api/force_histogram/r={value!r}", "api", api=call, expect=expect))


def _directions_cases(w: Writer) -> None:
    forces = "scenespeak.spatial.forces"
    directions_values: tuple[object, ...] = (
        2**40,
        10**7,
        "180",
        0,
        -1,
        1.5,
        True,
        None,
        np.nan,
        2**63,
        [180],
    )
    for value in directions_values:
        for fn, args in (
            ("force_histogram", (SQ, RIGHT)),
            ("force_histograms", (SQ, RIGHT)),
            ("hybrid_histogram", (SQ, RIGHT)),
        ):
            w.add(
                Case(
                    f"api/{fn}/directions={value!r}",
                    "api",
                    api=_call(forces, fn, *args, directions=value),
                )
            )
        w.add(
            Case(
                f"api/relate/directions={value!r}",
                "api",
                api=_call("scenespeak.spatial.language", "relate", SQ, RIGHT, directions=value),
            )
        )


def _mask_cases(w: Writer) -> None:
    forces = "scenespeak.spatial.forces"
    mask_a = np.zeros((20, 20), bool)
    mask_a[2:8, 2:8] = True
    mask_b = np.zeros((20, 20), bool)
    mask_b[2:8, 12:18] = True
    for value in (np.inf, np.nan, -1.0, 1e300, "0.5", None, 1j):
        call = _call(forces, "force_histogram", mask_a, mask_b, directions=16, mask_tolerance=value)
        # None is documented ("float | None": the measured outline rule): a sane histogram
        w.add(
            Case(
                f"api/force_histogram/mask_tolerance={value!r}",
                "api",
                api=call if value is not None else _checked(call, _sane_histogram),
                expect="error" if value is not None else "either",
            )
        )
    masks: dict[str, tuple[Any, Any]] = {
        "empty": (np.zeros((20, 20), bool), mask_b),
        "shapes-differ": (mask_a, mask_b[:10]),
        "three-d": (np.zeros((2, 20, 20), bool), np.zeros((2, 20, 20), bool)),
        "one-pixel": (
            np.pad(np.ones((1, 1), bool), 5),
            np.pad(np.ones((1, 1), bool), ((5, 5), (0, 10))),
        ),
    }
    for name, (a, b) in masks.items():
        call = _call(forces, "force_histogram", a, b, directions=16)
        ok = name == "one-pixel"  # a one-pixel mask is a (tiny) region: a histogram is right
        w.add(
            Case(
                f"api/force_histogram/mask-{name}",
                "api",
                expect="either" if ok else "error",
                api=_checked(call, _sane_histogram) if ok else call,
            )
        )


def _hybrid_p_cases(w: Writer) -> None:
    forces = "scenespeak.spatial.forces"
    for p0, p1 in (
        (0.0, 3.0),
        (-1.0, 3.0),
        (np.nan, 3.0),
        (0.01, np.inf),
        (0.01, 0.0),
        (1e300, 1e300),
    ):
        ok = p0 == 0.01 and p1 == 0.0  # Y0 = p0 * D_min: defined
        call = _call(forces, "hybrid_histogram", SQ, RIGHT, p0=p0, p1=p1, directions=16)
        w.add(
            Case(
                f"api/hybrid_histogram/p0={p0}-p1={p1}",
                "api",
                expect="either" if ok else "error",
                api=_checked(call, _sane_histogram) if ok else call,
            )
        )


def _degree_cases(w: Writer) -> None:
    degrees = "scenespeak.spatial.degrees"
    hists: dict[str, Any] = {
        "zeros": np.zeros(180),
        "denormal": np.full(180, 5e-324),
        "tiny": np.full(180, 1e-300),
        "nan": np.full(180, np.nan),
        "inf": np.full(180, np.inf),
        "negative": -np.ones(180),
        "complex": np.ones(180, complex),
        "length-7": np.ones(7),
        "empty": np.zeros(0),
        "two-d": np.ones((2, 90)),
        "strings": np.array(["a"] * 180),
        "huge": np.full(180, 1e308),
    }
    nothing = ("zeros", "denormal", "tiny")
    for name, h in hists.items():
        # all zero: the degrees may say 0 everywhere (nothing), never more
        expect: Expect = "either" if name in nothing else "error"
        w.add(
            Case(
                f"api/four_degrees/{name}",
                "api",
                expect=expect,
                api=_checked(_call(degrees, "four_degrees", h), _all_zero_degrees),
            )
        )
        w.add(
            Case(
                f"api/direction_degree/{name}",
                "api",
                expect=expect,
                api=_checked(_call(degrees, "direction_degree", h, 0), _all_zero_degrees),
            )
        )
        for lang in ("describe_relation", "relation_of_pair"):
            w.add(Case(f"api/{lang}/{name}", "api", api=_call_language(lang, h)))
    for index in (-1, 180, 2**40, 1.5, "0", None):
        w.add(
            Case(
                f"api/direction_degree/index={index!r}",
                "api",
                api=_call(degrees, "direction_degree", np.ones(180), index),
            )
        )


def _all_zero_degrees(value: object) -> object:
    degrees = value.values() if isinstance(value, dict) else [value]
    for d in degrees:
        if getattr(d, "degree", 0.0) != 0.0:
            raise WrongAnswer(
                f"a degree of {getattr(d, 'degree', '?')} from a histogram with no force"
            )
    return value


def _call_language(name: str, h: Any) -> Callable[[], object]:
    """The language functions that take histograms, with ``h`` as F0 and F2."""

    def run() -> object:
        lang = importlib.import_module("scenespeak.spatial.language")
        fn = getattr(lang, name)
        if name == "describe_relation":
            return fn(h, h, "A", "B")
        pair = lang.PairHistograms(h, h, False, 0.0, 1.0, 1.0)
        return fn(pair)

    return run


def _perception_cases(w: Writer, base: Base) -> None:
    features = "scenespeak.perception.features"
    arrays: dict[str, Any] = {
        "complex": np.ones((20, 20), complex),
        "object": np.array([[None] * 4] * 4, dtype=object),
        "bool": np.ones((20, 20), bool),
        "int64-huge": np.full((20, 20), 2**62, np.int64),
        "float-inf": np.full((20, 20), np.inf),
        "zero-size": np.zeros((0, 0), np.uint8),
        "two-channels": np.zeros((20, 20, 2), np.uint8),
        "four-d": np.zeros((2, 2, 2, 2), np.uint8),
        "strings": np.array([["a"]]),
        "list": [[1, 2], [3, 4]],
    }
    for name, arr in arrays.items():
        expect: Expect = "either" if name in ("bool", "int64-huge", "list") else "error"
        w.add(
            Case(f"api/to_gray/{name}", "api", api=_call(features, "to_gray", arr), expect=expect)
        )
        w.add(Case(f"api/detect/{name}", "api", api=_call(features, "detect", arr), expect=expect))
    w.add(
        Case(
            "api/detect/mask-shape",
            "api",
            api=_call(features, "detect", np.zeros((20, 20), np.uint8), mask=np.ones((3, 3), bool)),
        )
    )
    w.add(
        Case(
            "api/detect/mask-complex",
            "api",
            api=_call(
                features, "detect", np.zeros((20, 20), np.uint8), mask=np.ones((20, 20), complex)
            ),
        )
    )
    names: tuple[object, ...] = (123, None, b"\xff\xfe.png", "", "\x00.png")
    for value in names:
        w.add(Case(f"api/load_image/{value!r}", "api", api=_call(features, "load_image", value)))
    cal = "scenespeak.perception.calibration"
    shorts: dict[str, tuple[Any, ...]] = {
        "complex-baseline": (0.12j, 60.0, (320, 240)),
        "nan-baseline": (np.nan, 60.0, (320, 240)),
        "mm-baseline": (120.0, 60.0, (320, 240)),
        "size-fraction": (0.12, 60.0, (320.5, 240)),
        "size-strings": (0.12, 60.0, ("320", "240")),
        "size-bool": (0.12, 60.0, (True, True)),
        "hfov-complex": (0.12, 60j, (320, 240)),
        "up-complex": (0.12, 60.0, (320, 240), [0, -1j, 0]),
        "up-nan": (0.12, 60.0, (320, 240), [0, np.nan, 0]),
    }
    for name, args in shorts.items():
        w.add(Case(f"api/rig_from_short/{name}", "api", api=_call(cal, "rig_from_short", *args)))
    mappings: tuple[object, ...] = (
        {"K_left": np.eye(3) * 1j},
        [],
        None,
        {"baseline": "0.12", "hfov_deg": 60},
    )
    for value in mappings:
        w.add(
            Case(
                f"api/rig_from_mapping/{str(value)[:20]}",
                "api",
                api=_call(cal, "rig_from_mapping", value),
            )
        )
    paths: tuple[object, ...] = (123, None, "", str(base.calib) + "\x00")
    for value in paths:
        w.add(Case(f"api/load_rig/{value!r}", "api", api=_call(cal, "load_rig", value)))
    objects = "scenespeak.perception.objects"
    pts: dict[str, Any] = {
        "complex": np.ones((10, 2), complex),
        "nan": np.full((10, 2), np.nan),
        "one": np.zeros((1, 2)),
        "huge": np.array([[0, 0], [1e300, 0], [0, 1e300]]),
        "wrong-shape": np.zeros((10, 5)),
    }
    for name, arr in pts.items():
        w.add(
            Case(
                f"api/convex_hull/{name}",
                "api",
                api=_call(objects, "convex_hull", arr),
                expect="either" if name in ("one", "huge") else "error",
            )
        )
        w.add(
            Case(
                f"api/dbscan/{name}",
                "api",
                api=_call(objects, "dbscan", arr, 0.1),
                expect="either" if name in ("one", "huge", "wrong-shape") else "error",
            )
        )
    for eps in (0.0, -1.0, np.nan, np.inf, 1j):
        w.add(
            Case(
                f"api/dbscan/eps={eps!r}",
                "api",
                api=_call(objects, "dbscan", np.random.default_rng(0).random((50, 2)), eps),
            )
        )
    dbm = "scenespeak.perception.database"
    for name, mask, tol in (
        ("complex", np.ones((10, 10), complex), 1.0),
        ("tol-nan", np.ones((10, 10), bool), np.nan),
        ("tol-negative", np.ones((10, 10), bool), -1.0),
        ("three-d", np.ones((2, 10, 10), bool), 1.0),
    ):
        w.add(
            Case(
                f"api/outline_from_mask/{name}",
                "api",
                api=_call(dbm, "outline_from_mask", mask, tolerance=tol),
            )
        )

    def add_complex() -> object:
        from scenespeak.perception.database import ObjectDatabase

        path = base.fresh_db("api-complex")
        base.copy_db(path)
        with ObjectDatabase.open(path) as db:
            return db.add_object("cx", [np.ones((50, 50), complex)])

    w.add(Case("api/add_object/complex-image", "api", api=add_complex))
    for name, label in (("empty", ""), ("escape", "\x1b[31m"), ("surrogate", "\udcff"), ("int", 5)):

        def add_label(label: Any = label, name: str = name) -> object:
            from scenespeak.perception.database import ObjectDatabase

            path = base.fresh_db(f"api-label-{name}")
            base.copy_db(path)
            with ObjectDatabase.open(path) as db:
                return db.add_object(label, [base.train["coffee"]])

        w.add(Case(f"api/add_object/label-{name}", "api", api=add_label))
    contract = "scenespeak.contract"
    for name, hull in (("complex", SQ.astype(complex)), ("nan", SQ * np.nan), ("short", SQ[:2])):
        w.add(
            Case(
                f"api/SpatialObject/hull-{name}",
                "api",
                api=_call(contract, "SpatialObject", "a", "a", hull, "horizontal"),
            )
        )


def api(w: Writer, base: Base) -> None:
    """Every public function family."""
    _histogram_cases(w)
    _degree_cases(w)
    _perception_cases(w, base)


BUILDERS = (api,)
