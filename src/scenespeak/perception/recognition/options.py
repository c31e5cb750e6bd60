"""The labelling stage's options: ratio test, RANSAC verification and the small-object rule."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from scenespeak.errors import InputError
from scenespeak.overrides import replace_fields

__all__ = ["LabelOptions"]


@dataclass(frozen=True)
class LabelOptions:
    """Knobs of :meth:`ObjectDatabase.label` (the pipeline's defaults).

    Attributes
    ----------
    ratio : float
        0.8 — Lowe's ratio test: nearest distance < ``ratio`` × distance to the nearest
        descriptor of a *different* object, among the ``k`` nearest neighbours. If all ``k``
        are of one object, the ``k``-th distance stands in, unless they lie in ``k`` different
        views (one point's copies: then ``deep_k``). Synthesised views take part as
        :mod:`~scenespeak.perception.recognition.ratio` says. Lowe (IJCV 2004) recommends 0.8;
        0.85 and 0.9 were measured and not better (``docs/database.md``).
    min_inliers : int
        8 — geometric inliers needed to accept an object (a few stray matches never make one).
    ransac_threshold : float
        4.0 — reprojection tolerance in scene pixels.
    k : int
        16 — neighbours fetched per query descriptor.
    deep_k : int
        128 — neighbours fetched, in a second search, for a query whose ``k`` neighbours are
        all of one object and in ``k`` different views; the second neighbour is then the
        nearest other object's or the first one from a view already seen (``k`` or less: off).
    homography_min : int
        12 — matches needed to try a homography; a similarity is also tried from 2 matches.
    max_scale_ratio, max_angle_deg : float
        2.0, 30° — each inlier's SIFT scale and orientation must agree with the model this
        closely.
    max_views : int
        3 — training views per object tried, most matched first. A query that passed the
        ratio test is a candidate in every view of its object where one of its ``k``
        neighbours lies and passes the ratio test too (the nearest such one per view), so
        matches split between near-identical views are pooled.
    nprobe : int
        4 — inverted-file cells visited per query descriptor (large databases only).
    min_inliers_small : int
        4 — inliers at distinct positions enough to accept a *small* detection (its outline
        in the scene covers at most ``small_area``): far objects carry few keypoints.
    small_area : float
        8,000 px² — largest outline area for the small-detection rule (0: off). 4 under 8,000
        px² was measured on the 100-scene evaluation (366/393 objects, no false objects in
        clutter; ``docs/database.md``).
    small_share : float
        0.1 — ... and only when its inliers are at least this share of its view's matches. A
        texture that only looks like a learnt one passes the ratio test many times, and among
        many matches a handful agree with some model by chance (Lowe 2004, sec. 7.4: the
        probability of a false match grows with the matches examined): a never-learnt brick
        crate gave "cereal" 6 inliers of 178 matches, 5 of 59 (leave-part-out, tuning-40).
        Right small detections on tuning-40 and stress60 had 0.11-1.0 (a brick crate's 5 of
        45 the lowest).
    max_instances : int
        4 — instances of one object looked for: after each accepted detection the matches
        inside its outline are taken away and the object is searched again (1: one per label).
    instance_overlap : float
        0.25 — a further instance is accepted only if its outline's convex hull overlaps every
        earlier instance's by at most this share of the smaller hull (else it is another face
        or strip of an object already found, and the search stops).
    instance_span : float
        1.3 — ... and only if the two detections' inliers together span more than this many
        times one object's extent along the line between them (two training views of a
        cylinder each explain the half they saw: side by side, but within one object).
    finer_upscale : float
        2 — the finer search (:mod:`~scenespeak.perception.recognition.finer`, when the
        scene image is given to :meth:`ObjectDatabase.label`) enlarges the boxes round
        unexplained ratio-test matches this much (1: off).
    finer_contrast : float
        0.02 — SIFT's contrast threshold in those boxes (half OpenCV's default).
    finer_pad : float
        24 px — half the side of the box round each such match (merged where they overlap).
    finer_max_area, finer_max_boxes : float, int
        40,000 px², 6 — larger boxes are skipped, and at most this many are searched (those
        with most unexplained matches first): the finer look stays a small share of the
        scene's SIFT time.
    finer_budget : float
        0.15 — the boxes searched cover at most this share of the scene (before enlarging).
    colour : bool
        True — the pipeline names unknown objects whose colours and proportions fit one
        learnt object only (:mod:`~scenespeak.perception.recognition.colour`; False: off).
    closer : bool
        True — the pipeline looks again, enlarged, at each unknown object's own image region
        and names it after what that verifies (:mod:`~scenespeak.perception.recognition.closer`;
        False: off).
    """

    ratio: float = 0.8
    min_inliers: int = 8
    ransac_threshold: float = 4.0
    k: int = 16
    deep_k: int = 128
    homography_min: int = 12
    max_scale_ratio: float = 2.0
    max_angle_deg: float = 30.0
    max_views: int = 3
    nprobe: int = 4
    min_inliers_small: int = 4
    small_area: float = 8000.0
    small_share: float = 0.1
    max_instances: int = 4
    instance_overlap: float = 0.25
    instance_span: float = 1.3
    finer_upscale: float = 2.0
    finer_contrast: float = 0.02
    finer_pad: float = 24.0
    finer_max_area: float = 40000.0
    finer_max_boxes: int = 6
    finer_budget: float = 0.15
    colour: bool = True
    closer: bool = True

    @classmethod
    def with_overrides(
        cls, options: LabelOptions | None, overrides: Mapping[str, float]
    ) -> LabelOptions:
        """``options`` (or the defaults) with single fields replaced.

        Examples
        --------
        >>> LabelOptions.with_overrides(None, {"min_inliers": 5}).min_inliers
        5
        """
        return replace_fields(
            options if options is not None else cls(),
            overrides,
            lambda bad, names: InputError(
                "label options", f"unknown {', '.join(bad)}; the fields are {names}"
            ),
        )
