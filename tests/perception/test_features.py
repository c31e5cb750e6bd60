"""Features: image loading errors, SIFT through OpenCV, descriptors as uint8, positions."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
from scipy.spatial import cKDTree
from skimage import data

from scenespeak.errors import ImageError
from scenespeak.perception.features import Features, detect, load_image, to_gray


@pytest.fixture(scope="module")
def camera() -> np.ndarray:
    return data.camera()


def test_load_image_gray_and_rgb(tmp_path: Path) -> None:
    rgb = data.astronaut()
    p = tmp_path / "a.png"
    cv2.imwrite(str(p), cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))
    np.testing.assert_array_equal(load_image(p, gray=False), rgb)
    g = load_image(p)
    assert g.ndim == 2 and g.dtype == np.uint8 and g.shape == rgb.shape[:2]


@pytest.mark.parametrize(
    ("name", "content", "problem"),
    [
        ("missing.png", None, "no such file"),
        ("empty.png", b"", "the file is empty"),
        ("corrupt.png", b"\x89PNG\r\n\x1a\n\x00\x00garbage", "cannot be read as an image"),
        ("text.jpg", b"hello, I am not a JPEG", "cannot be read as an image"),
    ],
)
def test_bad_image_files_name_the_file(
    tmp_path: Path, name: str, content: bytes | None, problem: str
) -> None:
    p = tmp_path / name
    if content is not None:
        p.write_bytes(content)
    with pytest.raises(ImageError, match=problem) as info:
        load_image(p)
    assert str(p) in str(info.value)


def test_folder_is_not_an_image(tmp_path: Path) -> None:
    with pytest.raises(ImageError, match="folder"):
        load_image(tmp_path)


def test_to_gray_forms() -> None:
    rgb = data.astronaut()
    assert to_gray(rgb).shape == rgb.shape[:2]
    rgba = np.dstack([rgb, np.full(rgb.shape[:2], 255, np.uint8)])
    np.testing.assert_array_equal(to_gray(rgba), to_gray(rgb))
    f = rgb.astype(np.float64) / 255.0
    assert np.max(np.abs(to_gray(f).astype(int) - to_gray(rgb).astype(int))) <= 1
    with pytest.raises(ImageError, match="NaN"):
        to_gray(np.full((4, 4), np.nan))
    with pytest.raises(ImageError, match="shape"):
        to_gray(np.zeros((4, 4, 2)))
    with pytest.raises(ImageError, match="shape"):
        to_gray(np.zeros((0, 4)))


def test_detect_gives_uint8_descriptors(camera: np.ndarray) -> None:
    f = detect(camera)
    assert len(f) > 500
    assert f.descriptors.dtype == np.uint8 and f.descriptors.shape == (len(f), 128)
    assert f.xy.shape == (len(f), 2)
    assert np.all((f.xy >= 0) & (f.xy < [camera.shape[1], camera.shape[0]]))
    sub = f.subset(np.arange(10))
    assert len(sub) == 10
    np.testing.assert_array_equal(sub.descriptors, f.descriptors[:10])


def test_mask_limits_detection(camera: np.ndarray) -> None:
    mask = np.zeros(camera.shape, bool)
    mask[100:300, 100:300] = True
    f = detect(camera, mask=mask)
    assert len(f) > 20
    assert np.all((f.xy >= 95) & (f.xy < 305))
    with pytest.raises(ImageError, match="mask shape"):
        detect(camera, mask=mask[:10])


def test_textureless_image_has_no_features() -> None:
    f = detect(np.full((100, 100), 7, np.uint8))
    assert len(f) == 0
    assert Features.empty().descriptors.shape == (0, 128)


def test_classic_and_precise_upscale_positions_agree(camera: np.ndarray) -> None:
    # OpenCV's classic SIFT reports positions +0.25 px off; detect() corrects it
    a = detect(camera, precise_upscale=False)
    b = detect(camera, precise_upscale=True)
    dist, idx = cKDTree(b.xy).query(a.xy)
    same = dist < 0.6
    assert same.sum() > 300
    shift = np.median(a.xy[same] - b.xy[idx[same]], axis=0)
    assert np.all(np.abs(shift) < 0.05)
