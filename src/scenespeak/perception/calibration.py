"""Stage 0: the stereo rig — calibration files, rectification, the up vector, the ground frame.

A :class:`StereoRig` holds both cameras' intrinsics and distortion, the extrinsics in OpenCV's
``stereoCalibrate`` convention (a point ``X`` in the left camera frame is ``R @ X + T`` in the
right camera frame, so a right camera 12 cm to the right has ``T = [-0.12, 0, 0]``), the image
size and the world's ``up`` direction in the left camera frame.

Calibrations load from

* the JSON short form ``{"baseline", "hfov_deg", "image_size", "up"?}`` (:func:`rig_from_short`),
* the JSON full form (``K_left``, ``K_right``, ``dist_left``, ``dist_right``, ``R``, ``T``, ...),
* OpenCV FileStorage YAML/XML/JSON with the names OpenCV's stereo samples use
  (``K1``/``M1``, ``D1``, ``K2``/``M2``, ``D2``, ``R``, ``T``, image size),
* a pair of ROS ``camera_info`` YAML files (:func:`load_ros_rig`).

Every loader validates and raises :class:`~scenespeak.errors.CalibrationError` naming the file
and the problem.

The rig lives in :mod:`scenespeak.perception.rig`, the readers of each file form in
:mod:`scenespeak.perception.rig_readers`, the rectification in
:mod:`scenespeak.perception.rectification`; this module exports all of them.

>>> from scenespeak.perception.calibration import rig_from_short, rectify, ground_basis
>>> rig = rig_from_short(0.12, 60.0, (640, 480))
>>> round(rig.baseline, 3), round(float(rig.K_left[0, 0]), 1)
(0.12, 554.3)
>>> rectify(rig).needs_resampling
False
>>> ground_basis([0, -1, 0]).tolist()
[[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]
"""

from __future__ import annotations

from scenespeak.geometry.frames import DEFAULT_UP, ground_basis, heights, to_ground
from scenespeak.perception.rectification import Rectification, rectify
from scenespeak.perception.rig import (
    CalibrationMismatchError,
    StereoRig,
    rig_from_short,
)
from scenespeak.perception.rig_readers import (
    load_rig,
    load_ros_rig,
    rig_from_mapping,
)

__all__ = [
    "DEFAULT_UP",
    "CalibrationMismatchError",
    "Rectification",
    "StereoRig",
    "ground_basis",
    "heights",
    "load_rig",
    "load_ros_rig",
    "rectify",
    "rig_from_mapping",
    "rig_from_short",
    "to_ground",
]
