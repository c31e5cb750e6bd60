"""Corpus family of calibration files: JSON, YAML, XML, ROS camera_info and the OpenCV
stereo_calib pair."""

from __future__ import annotations

import functools
import itertools
import json
from pathlib import Path

from scenespeak.tools.fuzz.corpus import (
    BASELINE,
    FOCAL,
    HFOV,
    Base,
    Case,
    Expect,
    H,
    W,
    Writer,
    make_fifo,
)


def _full_form() -> dict[str, object]:
    k = [[FOCAL, 0.0, W / 2], [0.0, FOCAL, H / 2], [0.0, 0.0, 1.0]]
    eye = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
    return {
        "image_size": [W, H],
        "K_left": k,
        "K_right": k,
        "dist_left": [0.0] * 5,
        "dist_right": [0.0] * 5,
        "R": eye,
        "T": [-BASELINE, 0.0, 0.0],
    }


_HUGE_INT = "1" + "0" * 400
_BAD_VALUES: dict[str, str] = {
    "null": "null",
    "text": '"abc"',
    "nan": "NaN",
    "inf": "Infinity",
    "1e300": "1e300",
    "1e999": "1e999",
    "int400": _HUGE_INT,
    "empty-list": "[]",
    "short-list": "[1, 2]",
    "bool": "true",
    "deep": "[" * 3000 + "]" * 3000,
    "dict": '{"a": 1}',
}


def _json_calibs() -> dict[str, tuple[str, Expect, tuple[str, ...]]]:
    """name → (file text, expect, says)."""
    full = _full_form()
    short = {"baseline": BASELINE, "hfov_deg": HFOV, "image_size": [W, H]}
    out: dict[str, tuple[str, Expect, tuple[str, ...]]] = {
        "ok-short.json": (json.dumps(short), "ok", ()),
        "ok-full.json": (json.dumps(full), "ok", ()),
        "empty.json": ("", "error", ()),
        "space.json": ("  \n\t\n", "error", ()),
        "garbage.json": ("{baseline: 0.12,,}", "error", ()),
        "list.json": ("[1, 2, 3]", "error", ()),
        "null.json": ("null", "error", ()),
        "string.json": ('"calib"', "error", ()),
        "number.json": ("42", "error", ()),
        "deep-list.json": ("[" * 100_000 + "]" * 100_000, "error", ()),
        "deep-dict.json": ('{"a":' * 5000 + "1" + "}" * 5000, "error", ()),
        "bom.json": ("\ufeff" + json.dumps(short), "ok", ()),
        "lone-surrogate.json": (
            '{"baseline": 0.12, "hfov_deg": 60, "image_size": [320, 240], "note": "\\ud800"}',
            "either",
            (),
        ),
        "many-keys.json": (json.dumps({**short, **{f"k{i}": i for i in range(100_000)}}), "ok", ()),
        "truncated.json": (json.dumps(full)[:100], "error", ()),
    }
    for key in full:
        text = json.dumps({k: v for k, v in full.items() if k != key})
        expect: Expect = "ok" if key.startswith("dist") else "error"
        out[f"full-missing-{key}.json"] = (text, expect, ())
        for bad, literal in _BAD_VALUES.items():
            doc = json.dumps({**full, key: "@@"}).replace('"@@"', literal)
            ok_null = bad in ("null", "empty-list") and key.startswith("dist")
            out[f"full-{key}-{bad}.json"] = (doc, "ok" if ok_null else "error", ())
    for key in short:
        for bad, literal in _BAD_VALUES.items():
            doc = json.dumps({**short, key: "@@"}).replace('"@@"', literal)
            out[f"short-{key}-{bad}.json"] = (doc, "error", ())
    semantics: dict[str, tuple[dict[str, object], Expect, tuple[str, ...]]] = {
        "short-baseline-mm.json": ({**short, "baseline": 120.0}, "error", ("millimetres",)),
        "short-baseline-zero.json": ({**short, "baseline": 0.0}, "error", ()),
        "short-baseline-negative.json": ({**short, "baseline": -0.12}, "error", ()),
        "short-baseline-1e-9.json": ({**short, "baseline": 1e-9}, "error", ()),
        "short-hfov-0.json": ({**short, "hfov_deg": 0.0}, "error", ()),
        "short-hfov-180.json": ({**short, "hfov_deg": 180.0}, "error", ()),
        "short-hfov-179.99.json": ({**short, "hfov_deg": 179.99}, "error", ()),
        "short-size-zero.json": ({**short, "image_size": [0, 0]}, "error", ()),
        "short-size-negative.json": ({**short, "image_size": [-320, 240]}, "error", ()),
        "short-size-fraction.json": ({**short, "image_size": [320.5, 240]}, "error", ()),
        "short-size-huge.json": ({**short, "image_size": [10**9, 10**9]}, "error", ()),
        "short-size-three.json": ({**short, "image_size": [320, 240, 3]}, "error", ()),
        "short-up-zero.json": ({**short, "up": [0, 0, 0]}, "error", ()),
        "short-up-two.json": ({**short, "up": [0, 1]}, "error", ()),
        "short-up-forward.json": ({**short, "up": [0, 0, 1]}, "either", ()),
        "full-T-mm.json": ({**full, "T": [-193.0, 0.0, 0.0]}, "error", ("millimetres",)),
        "full-T-zero.json": ({**full, "T": [0.0, 0.0, 0.0]}, "error", ()),
        "full-T-swapped.json": ({**full, "T": [BASELINE, 0.0, 0.0]}, "error", ("swap",)),
        "full-T-vertical.json": ({**full, "T": [0.0, -BASELINE, 0.0]}, "either", ()),
        "full-K-singular.json": ({**full, "K_left": [[0.0] * 3] * 3}, "error", ()),
        "full-K-negative-f.json": (
            {**full, "K_left": [[-FOCAL, 0, W / 2], [0, -FOCAL, H / 2], [0, 0, 1]]},
            "error",
            (),
        ),
        "full-K-last-row.json": (
            {**full, "K_left": [[FOCAL, 0, W / 2], [0, FOCAL, H / 2], [1, 1, 1]]},
            "error",
            (),
        ),
        "full-K-f-1e-6.json": (
            {**full, "K_left": [[1e-6, 0, W / 2], [0, 1e-6, H / 2], [0, 0, 1]]},
            "error",
            (),
        ),
        "full-R-scaled.json": ({**full, "R": [[2.0, 0, 0], [0, 2.0, 0], [0, 0, 2.0]]}, "error", ()),
        "full-R-mirror.json": (
            {**full, "R": [[1.0, 0, 0], [0, 1.0, 0], [0, 0, -1.0]]},
            "error",
            (),
        ),
        "full-R-rvec.json": ({**full, "R": [0.0, 0.0, 0.0]}, "ok", ()),
        "full-R-rvec-huge.json": ({**full, "R": [1e12, 0.0, 0.0]}, "either", ()),
        "full-dist-7.json": ({**full, "dist_left": [0.0] * 7}, "error", ()),
        "full-dist-wild.json": ({**full, "dist_left": [1e6, -1e6, 0, 0, 1e6]}, "either", ()),
        "full-opencv-names.json": (
            {
                "imageSize": [W, H],
                "M1": full["K_left"],
                "M2": full["K_right"],
                "D1": full["dist_left"],
                "D2": full["dist_right"],
                "R": full["R"],
                "T": full["T"],
            },
            "ok",
            (),
        ),
    }
    for name, (mapping, expect, says) in semantics.items():
        out[name] = (json.dumps(mapping), expect, says)
    return out


_OPENCV_MAT = "!!opencv-matrix\n   rows: {r}\n   cols: {c}\n   dt: d\n   data: [ {data} ]\n"


def _cv_mat(values: list[float], rows: int, cols: int) -> str:
    return _OPENCV_MAT.format(r=rows, c=cols, data=", ".join(repr(float(v)) for v in values))


def opencv_yaml(*, t_x: float = -BASELINE, size_as_matrix: bool = False, extra: str = "") -> str:
    """An OpenCV FileStorage YAML stereo calibration (as ``cv2.FileStorage.write`` writes)."""
    k = [FOCAL, 0.0, W / 2, 0.0, FOCAL, H / 2, 0.0, 0.0, 1.0]
    eye = [1.0, 0, 0, 0, 1.0, 0, 0, 0, 1.0]
    size = _cv_mat([W, H], 2, 1) if size_as_matrix else f"[ {W}, {H} ]\n"
    return (
        "%YAML:1.0\n---\n"
        f"imageSize: {size}"
        f"M1: {_cv_mat(k, 3, 3)}D1: {_cv_mat([0.0] * 5, 1, 5)}"
        f"M2: {_cv_mat(k, 3, 3)}D2: {_cv_mat([0.0] * 5, 1, 5)}"
        f"R: {_cv_mat(eye, 3, 3)}T: {_cv_mat([t_x, 0.0, 0.0], 3, 1)}" + extra
    )


def _billion_laughs() -> str:
    lines = ['a: &a ["lol","lol","lol","lol","lol","lol","lol","lol","lol"]']
    names = "abcdefghij"
    for prev, cur in itertools.pairwise(names):
        lines.append(f"{cur}: &{cur} [" + ",".join([f"*{prev}"] * 9) + "]")
    return "\n".join(lines) + "\n"


def _yaml_calibs(marker: Path) -> dict[str, tuple[str, Expect, tuple[str, ...]]]:
    ok = opencv_yaml()
    cmd = f"touch {marker}"
    return {
        "ok.yml": (ok, "ok", ()),
        "size-as-matrix.yml": (opencv_yaml(size_as_matrix=True), "ok", ()),
        "no-header.yml": (ok.split("---\n", 1)[1], "ok", ()),
        "mm.yml": (opencv_yaml(t_x=-193.0), "error", ("millimetres",)),
        "swapped.yml": (opencv_yaml(t_x=0.193), "error", ("swap",)),
        "billion-laughs.yml": (_billion_laughs(), "error", ("max_yaml_nodes",)),
        "billion-laughs-in-calib.yml": (
            ok + _billion_laughs(),
            "error",
            ("max_yaml_nodes",),
        ),
        "python-apply.yml": (f'x: !!python/object/apply:os.system ["{cmd}"]\n', "error", ()),
        "python-name.yml": ("x: !!python/name:os.system\n", "error", ()),
        "python-module.yml": ("x: !!python/module:os\n", "error", ()),
        "python-new.yml": (
            f'x: !!python/object/new:subprocess.Popen [["sh","-c","{cmd}"]]\n',
            "error",
            (),
        ),
        "custom-tag.yml": ("x: !evil {a: 1}\n", "error", ()),
        "deep-flow.yml": ("a: " + "[" * 50_000 + "]" * 50_000 + "\n", "error", ()),
        "deep-block.yml": (
            "".join(" " * i + "a:\n" for i in range(0, 4000, 2)) + " " * 4000 + "1\n",
            "error",
            (),
        ),
        "deep-dash.yml": ("- " * 5000 + "1\n", "error", ()),
        "int400.yml": (
            ok.replace("rows: 3\n   cols: 1", f"rows: {_HUGE_INT}\n   cols: 1"),
            "error",
            (),
        ),
        "rows-1e12.yml": (
            ok.replace("rows: 3\n   cols: 1", "rows: 1000000000000\n   cols: 1"),
            "error",
            (),
        ),
        "rows-negative.yml": (
            ok.replace("rows: 3\n   cols: 1", "rows: -3\n   cols: 1"),
            "error",
            (),
        ),
        "data-short.yml": (ok.replace("data: [ -0.12, 0.0, 0.0 ]", "data: [ -0.12 ]"), "error", ()),
        "data-text.yml": (
            ok.replace("data: [ -0.12, 0.0, 0.0 ]", "data: [ a, b, c ]"),
            "error",
            (),
        ),
        "inf.yml": (
            ok.replace("data: [ -0.12, 0.0, 0.0 ]", "data: [ -.inf, 0.0, 0.0 ]"),
            "error",
            (),
        ),
        "nan.yml": (
            ok.replace("data: [ -0.12, 0.0, 0.0 ]", "data: [ .nan, 0.0, 0.0 ]"),
            "error",
            (),
        ),
        "1e300.yml": (
            ok.replace("data: [ -0.12, 0.0, 0.0 ]", "data: [ -1e300, 0.0, 0.0 ]"),
            "error",
            (),
        ),
        "tabs.yml": (ok.replace("   ", "\t"), "error", ()),
        "duplicate-keys.yml": (ok + "T: [1, 2, 3]\n", "either", ()),
        "empty.yml": ("", "error", ()),
        "comment-only.yml": ("# nothing here\n", "error", ()),
        "list.yml": ("- 1\n- 2\n", "error", ()),
        "scalar.yml": ("hello\n", "error", ()),
        "binary.yml": ("\x00\x01\x02garbage\x7f", "error", ()),
        "unclosed.yml": ("a: [1, 2\n", "error", ()),
        "anchors-small.yml": ("k: &k " + "[1.0, 0, 0]\n" + ok.split("---\n", 1)[1], "ok", ()),
        "missing-T.yml": (ok.split("T:")[0], "error", ()),
    }


def _opencv_xml(t_x: float = -BASELINE, extra: str = "") -> str:
    def mat(name: str, rows: int, cols: int, data: list[float]) -> str:
        vals = " ".join(repr(float(v)) for v in data)
        return (
            f'<{name} type_id="opencv-matrix"><rows>{rows}</rows><cols>{cols}</cols>'
            f"<dt>d</dt><data>{vals}</data></{name}>\n"
        )

    k = [FOCAL, 0.0, W / 2, 0.0, FOCAL, H / 2, 0.0, 0.0, 1.0]
    eye = [1.0, 0, 0, 0, 1.0, 0, 0, 0, 1.0]
    return (
        '<?xml version="1.0"?>\n<opencv_storage>\n'
        f"<imageSize>{W} {H}</imageSize>\n"
        + mat("M1", 3, 3, k)
        + mat("D1", 1, 5, [0.0] * 5)
        + mat("M2", 3, 3, k)
        + mat("D2", 1, 5, [0.0] * 5)
        + mat("R", 3, 3, eye)
        + mat("T", 3, 1, [t_x, 0.0, 0.0])
        + extra
        + "</opencv_storage>\n"
    )


def _xml_calibs() -> dict[str, tuple[str, Expect, tuple[str, ...]]]:
    ok = _opencv_xml()
    lol = (
        '<?xml version="1.0"?>\n<!DOCTYPE lolz [<!ENTITY lol "lol">'
        + "".join(
            f'<!ENTITY lol{i} "' + f"&lol{i - 1 if i > 1 else ''};" * 10 + '">' for i in range(1, 9)
        )
        + "]>\n<opencv_storage><note>&lol8;</note></opencv_storage>\n"
    )
    return {
        "ok.xml": (ok, "ok", ()),
        "mm.xml": (_opencv_xml(t_x=-193.0), "error", ("millimetres",)),
        "empty.xml": ("", "error", ()),
        "garbage.xml": ("this is not xml at all", "error", ()),
        "truncated.xml": (ok[: len(ok) // 2], "error", ()),
        "billion-laughs.xml": (lol, "error", ()),
        "external-entity.xml": (
            '<?xml version="1.0"?>\n<!DOCTYPE x [<!ENTITY e SYSTEM "file:///etc/passwd">]>\n'
            "<opencv_storage><note>&e;</note></opencv_storage>\n",
            "error",
            (),
        ),
        "doctype.xml": (
            '<?xml version="1.0"?>\n<!DOCTYPE opencv_storage>\n' + ok.split("\n", 1)[1],
            "error",
            (),
        ),
        "deep.xml": (
            '<?xml version="1.0"?>\n<opencv_storage>'
            + "<a>" * 20_000
            + "1"
            + "</a>" * 20_000
            + "</opencv_storage>\n",
            "error",
            (),
        ),
        "rows-1e9.xml": (
            ok.replace("<rows>3</rows><cols>1</cols>", "<rows>1000000000</rows><cols>1000</cols>"),
            "error",
            (),
        ),
        "missing-T.xml": (ok.replace(ok[ok.index("<T ") : ok.index("</T>") + 5], ""), "error", ()),
        "nan.xml": (ok.replace("<data>-0.12", "<data>nan"), "error", ()),
        "json-inside.xml": (json.dumps(_full_form()), "error", ()),
        "yaml-inside.xml": (opencv_yaml(), "error", ()),
        "unclosed.xml": (ok.replace("</opencv_storage>", ""), "error", ()),
        "binary.xml": ("\x00\x00\x00<opencv_storage>", "error", ()),
    }


def _ros_camera(
    name: str,
    *,
    tx: float = 0.0,
    width: int = W,
    height: int = H,
    extra: str = "",
    f: float = FOCAL,
) -> str:
    k = [f, 0.0, W / 2, 0.0, f, H / 2, 0.0, 0.0, 1.0]
    p = [f, 0.0, W / 2, tx, 0.0, f, H / 2, 0.0, 0.0, 0.0, 1.0, 0.0]

    def mat(rows: int, cols: int, data: list[float]) -> str:
        values = ", ".join(repr(float(x)) for x in data)
        return f"\n  rows: {rows}\n  cols: {cols}\n  data: [{values}]\n"

    return (
        f"image_width: {width}\nimage_height: {height}\ncamera_name: {name}\n"
        f"camera_matrix:{mat(3, 3, k)}distortion_model: plumb_bob\n"
        f"distortion_coefficients:{mat(1, 5, [0.0] * 5)}"
        f"rectification_matrix:{mat(3, 3, [1.0, 0, 0, 0, 1.0, 0, 0, 0, 1.0])}"
        f"projection_matrix:{mat(3, 4, p)}" + extra
    )


def calibrations(w: Writer, base: Base) -> None:
    """Every broken calibration, in ``describe`` and ``points``."""
    marker = w.root / "PWNED-by-yaml"
    entries: dict[str, tuple[str, Expect, tuple[str, ...]]] = {}
    entries.update(_json_calibs())
    entries.update(_yaml_calibs(marker))
    entries.update(_xml_calibs())

    def no_code_ran(code: int, out: str, err: str) -> tuple[str, str] | None:
        return ("security", "a YAML tag ran code") if marker.exists() else None

    for name, (text, expect, says) in entries.items():
        p = str(w.text(f"calib/{name}", text))
        for cmd in ("describe", "points"):
            argv: tuple[str, ...] = (cmd, "--calib", p, str(base.left), str(base.right), "-q")
            if cmd == "describe":
                argv = (*argv, "--db", str(base.db))
            w.add(
                Case(
                    f"calib/{name}/{cmd}",
                    "calibration",
                    argv,
                    expect=expect,
                    names=p,
                    says=says,
                    check=no_code_ran if "python" in name else None,
                )
            )
    big = w.path("calib/over-16MB.json")
    w.do(lambda: big.write_text('{"a": "' + "x" * (17 << 20) + '"}'))
    folder = w.path("calib/folder.xml")
    w.do(lambda: folder.mkdir(exist_ok=True))
    folder_json = w.path("calib/folder.json")
    w.do(lambda: folder_json.mkdir(exist_ok=True))
    fifo = w.path("calib/fifo.yml")
    w.do(functools.partial(make_fifo, fifo))
    fifo_xml = w.path("calib/fifo.xml")
    w.do(functools.partial(make_fifo, fifo_xml))
    specials = {
        "over-16MB.json": big,
        "folder.xml": folder,
        "folder.json": folder_json,
        "fifo.yml": fifo,
        "fifo.xml": fifo_xml,
        "dev-zero": Path("/dev/zero"),
        "dev-urandom.yml": Path("/dev/urandom"),
        "missing.json": w.root / "calib" / "missing.json",
        "name-300.json": w.root / "calib" / ("c" * 300 + ".json"),
        "in-missing-dir.xml": w.root / "nodir" / "calib.xml",
    }
    for name, path in specials.items():
        for cmd in ("describe", "points"):
            argv = (cmd, "--calib", str(path), str(base.left), str(base.right), "-q")
            if cmd == "describe":
                argv = (*argv, "--db", str(base.db))
            w.add(Case(f"calib/{name}/{cmd}", "calibration", argv, names=str(path)))
    _ros(w, base)


def _ros(w: Writer, base: Base) -> None:
    """ROS camera_info pairs and the OpenCV stereo_calib intrinsics/extrinsics pair."""
    tx = -FOCAL * BASELINE
    pairs: dict[str, tuple[str, str, Expect, tuple[str, ...]]] = {
        "ok": (_ros_camera("left"), _ros_camera("right", tx=tx), "ok", ()),
        "up-in-file": (
            _ros_camera("left", extra="up: [0.0, -0.9, -0.44]\n"),
            _ros_camera("right", tx=tx),
            "ok",
            (),
        ),
        "mm": (_ros_camera("left"), _ros_camera("right", tx=tx * 1000), "error", ("millimetres",)),
        "swapped": (_ros_camera("left", tx=tx), _ros_camera("right"), "error", ()),
        "right-tx-zero": (_ros_camera("left"), _ros_camera("right"), "error", ()),
        "sizes-differ": (_ros_camera("left"), _ros_camera("right", tx=tx, width=640), "error", ()),
        "right-positive-tx": (
            _ros_camera("left"),
            _ros_camera("right", tx=-tx),
            "error",
            ("swap",),
        ),
        "fisheye": (
            _ros_camera("left").replace("plumb_bob", "fisheye"),
            _ros_camera("right", tx=tx),
            "error",
            (),
        ),
        "right-billion-laughs": (_ros_camera("left"), _billion_laughs(), "error", ()),
        "right-python-tag": (_ros_camera("left"), "x: !!python/name:os.system\n", "error", ()),
        "right-empty": (_ros_camera("left"), "", "error", ()),
        "right-f-zero": (_ros_camera("left"), _ros_camera("right", tx=tx, f=0.0), "error", ()),
        "left-size-missing": (
            _ros_camera("left").split("camera_name")[1],
            _ros_camera("right", tx=tx),
            "error",
            (),
        ),
    }
    for name, (left, right, expect, says) in pairs.items():
        lp = str(w.text(f"ros/{name}/left.yaml", left))
        rp = str(w.text(f"ros/{name}/right.yaml", right))
        argv = ("points", "--calib", lp, "--calib-right", rp, str(base.left), str(base.right))
        w.add(
            Case(
                f"ros/{name}/points",
                "calibration",
                (*argv, "-q"),
                expect=expect,
                names=f"ros/{name}/",
                says=says,
            )
        )
    single = str(w.text("ros/single/left.yaml", _ros_camera("left")))
    w.add(
        Case(
            "ros/single-file/points",
            "calibration",
            ("points", "--calib", single, str(base.left), str(base.right), "-q"),
            names=single,
            says=("--calib-right",),
        )
    )
    # OpenCV's stereo_calib sample: intrinsics.yml (M1 D1 M2 D2) + extrinsics.yml (R T R1 ...)
    full = opencv_yaml()
    intr = full.split("R: ")[0]
    extr = "%YAML:1.0\n---\nR: " + full.split("R: ", 1)[1]
    ip = str(w.text("stereo_calib/ok/intrinsics.yml", intr))
    ep = str(w.text("stereo_calib/ok/extrinsics.yml", extr))
    w.add(
        Case(
            "stereo_calib/pair/points",
            "calibration",
            (
                "points",
                "--calib",
                ip,
                "--calib-right",
                ep,
                "--image-size",
                f"{W}x{H}",
                str(base.left),
                str(base.right),
                "-q",
            ),
            expect="ok",
        )
    )
    w.add(
        Case(
            "stereo_calib/intrinsics-alone/points",
            "calibration",
            ("points", "--calib", ip, str(base.left), str(base.right), "-q"),
            names=ip,
            says=("extrinsics",),
        )
    )
    w.add(
        Case(
            "stereo_calib/extrinsics-alone/points",
            "calibration",
            ("points", "--calib", ep, str(base.left), str(base.right), "-q"),
            names=ep,
            says=("intrinsics",),
        )
    )
    mm_e = extr.replace("data: [ -0.12, 0.0, 0.0 ]", "data: [ -120.0, 0.0, 0.0 ]")
    mp = str(w.text("stereo_calib/mm/extrinsics.yml", mm_e))
    w.add(
        Case(
            "stereo_calib/mm/points",
            "calibration",
            (
                "points",
                "--calib",
                ip,
                "--calib-right",
                mp,
                "--image-size",
                f"{W}x{H}",
                str(base.left),
                str(base.right),
                "-q",
            ),
            says=("millimetres",),
        )
    )
    w.add(
        Case(
            "stereo_calib/mm-with-units/points",
            "calibration",
            (
                "points",
                "--calib",
                ip,
                "--calib-right",
                mp,
                "--image-size",
                f"{W}x{H}",
                "--units",
                "mm",
                str(base.left),
                str(base.right),
                "-q",
            ),
            expect="ok",
        )
    )


BUILDERS = (calibrations,)
