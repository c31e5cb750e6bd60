"""Build of the one compiled extension, ``scenespeak.perception.stereo._sgbm_c`` (OpenCV's
3-way SGBM as C loops; docs/calibration.md). Everything else is in pyproject.toml.

The extension is optional: without a C compiler the package installs all the same and the
dense check runs OpenCV's SGBM (``dense.use_compiled``). The hot loops are compiled for
x86-64-v4, AVX2 and the baseline in one portable binary (GCC ``target_clones``; the loader
picks the widest the CPU runs), so no ``-march=native``.
"""

from __future__ import annotations

import sys

from setuptools import Extension, setup

_FLAGS = [] if sys.platform == "win32" else ["-O3", "-std=c99", "-fno-wrapv"]
_LINK = [] if sys.platform == "win32" else ["-pthread"]

setup(
    ext_modules=[
        Extension(
            "scenespeak.perception.stereo._sgbm_c",
            sources=["src/scenespeak/perception/stereo/_sgbm_c.c"],
            extra_compile_args=_FLAGS,
            extra_link_args=_LINK,
            optional=True,
        )
    ]
)
