"""PipelineOptions: the stages' own options composed, the flat knobs of before still accepted."""

from __future__ import annotations

import dataclasses
import pickle

import numpy as np
import pytest

from scenespeak.errors import InputError
from scenespeak.perception.objects import ObjectOptions, UnknownOptions, build_objects, make_object
from scenespeak.perception.recognition.options import LabelOptions
from scenespeak.perception.scene_objects import StrategyOptions
from scenespeak.perception.stage_options import DENSE_MARGIN, StereoOptions
from scenespeak.pipeline import FLAT_OPTIONS, PipelineOptions
from scenespeak.spatial.options import RelationOptions

#: The flat defaults PipelineOptions had before it was made of stage options (session 3).
OLD_DEFAULTS = {
    "ratio": 0.6,
    "label_ratio": 0.8,
    "min_inliers": 8,
    "min_inliers_small": 4,
    "small_area": 8000.0,
    "dense": True,
    "dense_min_points": 30,
    "dense_max_points": 300,
    "dense_crop": True,
    "dense_margin": 16,
    "unknown": True,
    "unknown_max_distance": 2.5,
    "min_points": 3,
    "outliers": "both",
    "radius": 0.5,
    "eps": 0.05,
    "directions": 180,
    "summary": True,
    "geometry": True,
}


def test_the_flat_knobs_read_the_old_defaults() -> None:
    opts = PipelineOptions()
    assert set(FLAT_OPTIONS) == set(OLD_DEFAULTS)
    assert {k: getattr(opts, k) for k in OLD_DEFAULTS} == OLD_DEFAULTS
    assert opts.threads == 2
    assert opts.stereo.dense_margin == DENSE_MARGIN == 16


def test_each_flat_knob_sets_its_stage_field() -> None:
    for key, (stage, name) in FLAT_OPTIONS.items():
        value = not OLD_DEFAULTS[key] if isinstance(OLD_DEFAULTS[key], bool) else 7
        if key == "outliers":
            value = "radius"
        opts = PipelineOptions(**{key: value})
        assert getattr(getattr(opts, stage), name) == value, key
        assert getattr(opts, key) == value, key


def test_stage_options_compose_and_flat_knobs_apply_on_top() -> None:
    opts = PipelineOptions(
        stereo=StereoOptions(ratio=0.7),
        labels=LabelOptions(min_inliers=5),
        strategy=StrategyOptions(dense=False),
        objects=ObjectOptions(radius=None),
        relations=RelationOptions(summary=False),
        threads=1,
        min_inliers=6,
    )
    assert (opts.ratio, opts.min_inliers, opts.dense, opts.radius, opts.summary) == (
        0.7,
        6,
        False,
        None,
        False,
    )
    again = dataclasses.replace(opts, label_ratio=0.9)
    assert again.labels.ratio == 0.9 and again.labels.min_inliers == 6 and again.threads == 1
    assert pickle.loads(pickle.dumps(opts)) == opts
    assert hash(opts) == hash(dataclasses.replace(opts))


def test_bad_knobs_are_refused() -> None:
    with pytest.raises(TypeError, match="bogus"):
        PipelineOptions(bogus=1)
    with pytest.raises(InputError, match="threads"):
        PipelineOptions(threads=3)
    with pytest.raises(AttributeError):
        _ = PipelineOptions().nonsense
    with pytest.raises(ValueError, match="outliers"):
        PipelineOptions(outliers="some")


def test_make_object_and_build_objects_take_options_or_the_old_keywords() -> None:
    rng = np.random.default_rng(3)
    pts = np.vstack([rng.normal([0.1, 0.0, 1.0], 0.02, (40, 3)), [[0.9, 0.0, 1.0]]])
    by_options = make_object("mug", pts, options=ObjectOptions(outliers="radius", radius=0.3))
    by_keywords = make_object("mug", pts, outliers="radius", radius=0.3)
    assert by_options.n_points == by_keywords.n_points == 40  # type: ignore[union-attr]
    with pytest.raises(TypeError, match="bogus"):
        make_object("mug", pts, bogus=1)
    far = rng.normal([0.0, 0.0, 3.0], 0.01, (20, 3))
    labels = [None] * 20
    kept, _ = build_objects(far, labels, unknown_options=UnknownOptions(max_distance=2.5))
    also, _ = build_objects(far, labels, unknown_max_distance=2.5)
    near, _ = build_objects(far, labels)
    assert kept == also == [] and [o.label for o in near] == ["unknown object 1"]
