"""The working memory on hand-made footprints: steady words, status, events, forgetting."""

from __future__ import annotations

import numpy as np
import pytest

from scenespeak.contract import SpatialObject
from scenespeak.spatial.memory import MemoryOptions, Sighting, WorkingMemory

SQ = np.array([[0.0, 0.0], [0.08, 0.0], [0.08, 0.08], [0.0, 0.08]])


def _obj(label: str, x: float, y: float) -> SpatialObject:
    return SpatialObject(label, label, SQ + np.array([x, y]))


def _frame(mug_x: float, can=True, jitter=0.0, rng=None) -> list[Sighting]:
    j = (lambda: rng.normal(0, jitter, 2)) if rng is not None else (lambda: np.zeros(2))
    out = [Sighting(1, _obj("mug", mug_x + j()[0], 1.0 + j()[1]))]
    if can:
        out.append(Sighting(2, _obj("can", 0.0 + j()[0], 1.0 + j()[1])))
    return out


def test_jitter_near_a_boundary_does_not_change_the_words() -> None:
    # The mug stands on the diagonal (left-behind) of the can, where the raw words change with
    # a centimetre of noise; the memory keeps one sentence.
    rng = np.random.default_rng(0)
    mem = WorkingMemory()
    said = []
    raw = []
    from scenespeak.spatial.language import relate

    for _ in range(60):
        sightings = [
            Sighting(1, _obj("mug", -0.12 + rng.normal(0, 0.01), 1.12 + rng.normal(0, 0.01))),
            Sighting(2, _obj("can", 0.0, 1.0)),
        ]
        out = mem.update(sightings)
        said.append(out.relations[0].sentence)
        raw.append(
            relate(
                sightings[0].object.hull, sightings[1].object.hull, argument="mug", referent="can"
            ).sentence
        )
        assert out.events == ()
    assert len(set(raw)) > 1  # the raw words do change
    assert len(set(said)) == 1


def test_one_frame_changes_are_never_said() -> None:
    mem = WorkingMemory()
    seq = [-0.3] * 5 + [0.3] + [-0.3] * 5  # the mug jumps right for one frame
    primaries = [mem.update(_frame(x)).relations[0].primary for x in seq]
    assert set(primaries) == {"left"}


def test_a_lasting_move_is_one_event_of_the_mover() -> None:
    mem = WorkingMemory()
    events = []
    for x in [-0.3] * 4 + [0.3] * 4:
        events.extend(mem.update(_frame(x)).events)
    assert events == ["The mug moved to the right of the can."]


def test_appeared_hidden_out_of_view_and_back() -> None:
    mem = WorkingMemory(MemoryOptions(confirm=2))
    ev: list[tuple[int, str]] = []
    frames = (
        [_frame(-0.3, can=False)] * 3
        + [_frame(-0.3)] * 3
        + [[_frame(-0.3)[0], Sighting(2, _obj("can", 0, 1), seen=False, why="hidden", behind=1)]]
        * 3
        + [[_frame(-0.3)[0], Sighting(2, _obj("can", 0, 1), seen=False, why="out of view")]] * 3
        + [_frame(-0.3)] * 3
    )
    for k, f in enumerate(frames):
        out = mem.update(f)
        ev.extend((k, e) for e in out.events)
    assert ev == [
        (4, "A can appeared."),
        (7, "The can is hidden behind the mug."),
        (10, "The can is out of view."),
        (13, "The can is back in view."),
    ]


def test_objects_of_the_first_frames_did_not_appear() -> None:
    mem = WorkingMemory()
    assert all(mem.update(_frame(-0.3)).events == () for _ in range(5))


def test_out_of_view_objects_are_remembered_then_forgotten() -> None:
    mem = WorkingMemory(MemoryOptions(forget_after=5))
    for _ in range(3):
        mem.update(_frame(-0.3))
    statuses = []
    for _ in range(8):
        out = mem.update(_frame(-0.3, can=False))
        statuses.append({o.id: o.status for o in out.objects}.get(2))
        if 2 in mem.forgotten:
            break
    assert statuses[:2] == ["seen", "out of view"]
    assert statuses[-1] is None or 2 in mem.forgotten
    out = mem.update(_frame(-0.3, can=False))
    assert [o.id for o in out.objects] == [1]
    # an out-of-view object is said so, and is in no relation
    assert out.relations == ()


def test_two_objects_of_one_label_get_distinct_names() -> None:
    mem = WorkingMemory()
    out = mem.update([Sighting(1, _obj("mug", -0.3, 1)), Sighting(7, _obj("mug", 0.3, 1))])
    assert {o.name for o in out.objects} == {"mug 1", "mug 7"}
    assert out.relations[0].sentence.startswith("The mug 1 is")


@pytest.mark.parametrize("confirm", [1, 2, 3])
def test_confirm_sets_the_delay(confirm: int) -> None:
    mem = WorkingMemory(MemoryOptions(confirm=confirm))
    for _ in range(4):
        mem.update(_frame(-0.3))
    delay = next(k for k in range(6) if mem.update(_frame(0.3)).events)
    assert delay == confirm - 1
