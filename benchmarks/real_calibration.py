"""Depth on real chessboards for every calibration form (issue 12).

    PYTHONPATH=src python3 benchmarks/real_calibration.py

For OpenCV's 13 pairs and XIMEA's 25 pairs: calibrate with OpenCV (cv2.stereoCalibrate), write
every form scenespeak reads, load each as the CLI does, triangulate the board corners of every
pair and compare their depth with the board plane cv2.solvePnP finds in the left image. Also
XIMEA's own intrinsics.yml/extrinsics.yml (millimetres, cameras named the wrong way round) with
``--units mm --swap``. Prints the median and the worst per-pair median relative error.
"""

from __future__ import annotations

import os
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests" / "perception"))
sys.path.insert(0, str(ROOT / "tests"))

import test_real_calibration as t  # noqa: E402


def main() -> None:
    real = Path(os.environ.get("SCENESPEAK_REAL_DATA", ROOT.parent / "shared" / "data" / "real"))
    print(f"load average: {os.getloadavg()}")
    chess = t.calibrate_sets(real)
    tmp = Path(tempfile.mkdtemp(prefix="realcal-"))
    print("| set | pairs | stereo RMS (px) | form | median error | worst pair |")
    print("| --- | ---: | ---: | --- | ---: | ---: |")
    for name, c in chess.items():
        for form, (calib, right, options) in t._write_forms(c, tmp / name).items():
            errors = t._board_depth_errors(t._load(calib, right, options), c)
            print(
                f"| {name} | {len(c['pairs'])} | {c['rms']:.3f} | {form} | "
                f"{np.median(errors):.3%} | {max(errors):.3%} |"
            )
    folder = real / "chess" / "ximea"
    rig = t._load(
        folder / "intrinsics.yml",
        folder / "extrinsics.yml",
        {"image_size": chess["ximea"]["size"], "units": "mm", "swap": True},
    )
    errors = t._board_depth_errors(rig, chess["ximea"])
    print(
        f"| ximea (own yml pair, --units mm --swap) | {len(chess['ximea']['pairs'])} | - | "
        f"stereo_calib pair | {np.median(errors):.3%} | {max(errors):.3%} |"
    )


if __name__ == "__main__":
    main()
