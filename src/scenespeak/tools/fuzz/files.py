"""Corpus families of files: images and masks (:mod:`~scenespeak.tools.fuzz.images`),
calibrations (:mod:`~scenespeak.tools.fuzz.calibrations`: JSON, YAML, XML, ROS, the OpenCV
stereo_calib pair) and datasets with their ``truth.json`` (:mod:`~scenespeak.tools.fuzz.datasets`).

This module keeps their builders together, in the corpus order, and the names the other
families import from it.
"""

from __future__ import annotations

from scenespeak.tools.fuzz.calibrations import (
    _billion_laughs,
    calibrations,
    opencv_yaml,
)
from scenespeak.tools.fuzz.datasets import datasets
from scenespeak.tools.fuzz.images import _jpeg_huge, images, masks, png_header_only

__all__ = [
    "BUILDERS",
    "_billion_laughs",
    "_jpeg_huge",
    "calibrations",
    "datasets",
    "images",
    "masks",
    "opencv_yaml",
    "png_header_only",
]

BUILDERS = (images, masks, calibrations, datasets)
