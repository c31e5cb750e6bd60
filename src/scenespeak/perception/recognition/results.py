"""What the database returns: objects, training views, detections, a labelling."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

__all__ = ["Detection", "Labelling", "ObjectInfo", "TrainingView"]


# --------------------------------------------------------------------------------------------
# Results
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ObjectInfo:
    """One object of the database, as listed by :meth:`ObjectDatabase.list_objects`.

    Attributes
    ----------
    id : int
        Row id in the ``objects`` table.
    label : str
        The object's name.
    views : int
        Number of training images.
    descriptors : int
        Number of stored SIFT descriptors over all views.
    added : str
        When it was added (ISO-8601, UTC).
    """

    id: int
    label: str
    views: int
    descriptors: int
    added: str


@dataclass(frozen=True)
class TrainingView:
    """One training image of an object (without its descriptors).

    Attributes
    ----------
    id : int
        Row id in the ``views`` table (``Detection.view_id`` refers to it).
    label : str
        The object's label.
    source : str
        The image's file name as given, or ``"<array i>"``.
    width, height : int
        Size of the training image in pixels.
    outline : (M, 2) float32
        The object's outline in the training image, pixels (column, row); the image border
        (pixel edges at -0.5 and size - 0.5) when no mask was given.
    has_mask : bool
        Whether the outline came from a mask.
    keypoints : int
        Number of stored keypoints.
    """

    id: int
    label: str
    source: str
    width: int
    height: int
    outline: NDArray[np.float32]
    has_mask: bool
    keypoints: int


@dataclass(frozen=True)
class Detection:
    """An object recognised in the scene image.

    Attributes
    ----------
    label : str
        The object's label.
    view_id : int
        The training view that matched best (see :meth:`ObjectDatabase.views`).
    homography : (3, 3) float64
        Maps training-view pixels to scene pixels (homogeneous, ``H @ [x, y, 1]``). For a
        similarity model its last row is ``[0, 0, 1]``.
    inliers : (K,) intp
        Indices of the query keypoints that agree with the model (sorted).
    outline_in_scene : (M, 2) float64
        The training outline carried into the scene image by ``homography``.
    score : float
        Number of inliers (the evidence for the object; larger is better).
    model : {"homography", "similarity"}
        Which geometric model was fitted.
    matches : int
        Ratio-test matches to this view before the geometric check.
    """

    label: str
    view_id: int
    homography: NDArray[np.float64]
    inliers: NDArray[np.intp]
    outline_in_scene: NDArray[np.float64]
    score: float
    model: str
    matches: int


@dataclass(frozen=True)
class Labelling:
    """Labels of the query keypoints of one image.

    Attributes
    ----------
    labels : (N,) int32
        For each query keypoint the index of its detection in ``detections``, or ``-1``
        (unknown: not matched, or not an inlier of an accepted object).
    detections : tuple of Detection
        Recognised objects, best score first; one per instance (several of one label when
        it is seen more than once, ``LabelOptions.max_instances``).
    matched : (N,) int32
        Before the geometric check: the database object id each keypoint passed the ratio test
        to, or ``-1``. For figures, diagnostics and the region stage's keypoint votes.
    match_scale, match_turn : (N,) float32
        For a keypoint that passed the ratio test, its SIFT scale over its nearest training
        keypoint's, and its orientation minus that keypoint's (degrees, in [0, 360)); NaN
        elsewhere. Votes of one object seen once agree in both (Lowe 2004, sec. 7: the Hough
        transform's scale and orientation bins); chance matches do not. Empty: not computed.
    synthesised_only : (N,) bool
        Keypoints that passed the ratio test only on a view synthesised at ``db add`` (a
        cylinder seen from higher up, :mod:`~scenespeak.perception.recognition.cylinder_views`).
        They verify detections like any match, but are not counted as keypoint votes for the
        unknown-object cues (``KeypointEvidence``), whose thresholds were measured on learnt
        views' votes. Empty: none.
    """

    labels: NDArray[np.int32]
    detections: tuple[Detection, ...]
    matched: NDArray[np.int32] = field(repr=False)
    match_scale: NDArray[np.float32] = field(
        default_factory=lambda: np.zeros(0, np.float32), repr=False
    )
    match_turn: NDArray[np.float32] = field(
        default_factory=lambda: np.zeros(0, np.float32), repr=False
    )
    synthesised_only: NDArray[np.bool_] = field(
        default_factory=lambda: np.zeros(0, bool), repr=False
    )

    def votes(self) -> NDArray[np.int32]:
        """``matched`` without the keypoints that passed only on a synthesised view (-1
        there): the keypoints' votes for the unknown-object cues."""
        if not self.synthesised_only.size:
            return self.matched
        return np.where(self.synthesised_only, -1, self.matched).astype(np.int32)

    def names(self) -> list[str | None]:
        """The label of each query keypoint, ``None`` where unknown."""
        return [None if i < 0 else self.detections[i].label for i in self.labels.tolist()]

    def detection(self, label: str) -> Detection | None:
        """The detection of ``label``, if the object was recognised."""
        for det in self.detections:
            if det.label == label:
                return det
        return None
