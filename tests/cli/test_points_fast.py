"""``scenespeak points`` runs the pipeline's stereo stage (threaded SIFT, cropped dense check)
and must give the same points as the plain ``stereo_points`` over the whole image."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import pytest

from cardscene import BASELINE, HFOV, H, W, card_pair, write_rgb
from scenespeak.cli import main
from scenespeak.perception import calibration, stereo
from scenespeak.perception.features import load_image

CARDS = {"astronaut": (-0.5, 1.6, 0.5), "coffee": (0.45, 2.2, 0.6)}


@pytest.mark.parametrize("size", [(W, H), (2 * W, 2 * H)])
def test_points_are_those_of_the_uncropped_stereo_stage(
    size: tuple[int, int], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    left, right = card_pair(CARDS)
    if size != (W, H):
        left = cv2.resize(left, size, interpolation=cv2.INTER_LINEAR)
        right = cv2.resize(right, size, interpolation=cv2.INTER_LINEAR)
    lp, rp = write_rgb(tmp_path / "l.png", left), write_rgb(tmp_path / "r.png", right)
    calib = tmp_path / "calib.json"
    calib.write_text(json.dumps({"baseline": BASELINE, "hfov_deg": HFOV, "image_size": list(size)}))
    assert main(["points", "--calib", str(calib), str(lp), str(rp)]) == 0
    got = json.loads(capsys.readouterr().out)
    rig = calibration.rig_from_short(BASELINE, HFOV, size)
    ref = stereo.stereo_points(load_image(lp), load_image(rp), rig).points
    assert len(ref.xyz) > 100
    assert got == stereo.points_to_json(ref)
