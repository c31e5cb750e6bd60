"""The stream with its working memory on a rendered sequence (``livedata``), and the generator's
sequence truth."""

from __future__ import annotations

import json

import numpy as np
import pytest

from scenespeak.errors import InputError
from scenespeak.tools.live_evaluation import run_sequence, score_sequence
from scenespeak.tools.sequences import generate_sequence, load_sequence


def test_sequence_truth_is_consistent(live_data) -> None:
    seq = load_sequence(live_data.sequence)
    assert seq.script == "appear" and len(seq.frames) == 10
    (event,) = seq.events
    assert event["kind"] == "appeared"
    k = event["frame"]
    ids = [{o["id"] for o in f.objects} for f in seq.frames]
    assert event["object"] not in ids[k - 1] and event["object"] in ids[k]
    for f in seq.frames:
        for o in f.objects:
            assert 0 <= o["visible_fraction"] <= 1 and 0 <= o["in_view"] <= 1
            assert o["centroid"][2] > 0.3  # in front of the camera
    calib = json.loads(seq.calib.read_text())
    assert calib["image_size"] == [320, 240]
    for k in range(len(seq.frames)):
        assert all(p.stat().st_size > 0 for p in seq.pair(k))


def test_generator_refuses_bad_arguments(tmp_path) -> None:
    with pytest.raises(InputError, match="unknown script"):
        generate_sequence(tmp_path / "x", "dance")
    with pytest.raises(InputError, match="at least 8"):
        generate_sequence(tmp_path / "x", "slide", n_frames=3)
    with pytest.raises(InputError, match="missing"):
        load_sequence(tmp_path)


def test_stream_keeps_ids_reports_the_appearance_and_reuses_work(live_data) -> None:
    seq = load_sequence(live_data.sequence)
    lines, _ = run_sequence(seq, live_data.db)
    score = score_sequence(seq, lines)
    assert score.id_matches >= 20
    assert score.id_kept == score.id_matches
    assert score.reported == score.scripted == 1, score.missed
    assert score.false_events == 0, score.false
    assert score.flickers == 0
    # recognition ran on the first frame and when the tin appeared, not on every frame
    assert lines[0]["recognised"]
    assert sum(ln["recognised"] for ln in lines) <= 4
    assert any(o["source"] == "tracked" for ln in lines for o in ln["objects"] if "source" in o)
    ev = next(ln for ln in lines if ln["events"])
    assert ev["events"] == ["A tin appeared."]
    for ln in lines:
        assert {"frame", "time_s", "objects", "relations", "events"} <= ln.keys()
        assert all("id" in o for o in ln["objects"])


def test_tracked_positions_follow_the_truth(live_data) -> None:
    seq = load_sequence(live_data.sequence)
    lines, _ = run_sequence(seq, live_data.db)
    errors = []
    for ln, fr in zip(lines, seq.frames, strict=True):
        truth = {o["label"]: np.array(o["centroid"]) for o in fr.objects}
        for o in ln["objects"]:
            if o["status"] == "seen" and o["label"] in truth:
                errors.append(np.linalg.norm(np.array(o["centroid"]) - truth[o["label"]]))
    assert len(errors) >= 20
    assert np.median(errors) < 0.08
