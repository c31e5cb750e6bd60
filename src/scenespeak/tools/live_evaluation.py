"""How well the working memory does on generated sequences (:mod:`.sequences`).

Three measures, each against the truth of every frame (``docs/live.md``):

- **id stability**: each frame's described objects are matched to the truth objects seen in
  that frame (same label, nearest centroid within ``match_distance`` metres); over every truth
  object matched in two consecutive frames, the share whose stream ``id`` stayed the same;
- **flicker**: on *static stretches* (three consecutive frames in which no object moved by more
  than 1 mm and the camera did not turn), the number of times a pair's sentence changed for one
  frame and changed back; also every sentence change on static stretches;
- **events**: a scripted event is *reported* when the stream said an event of the same kind
  about the same objects (for ``moved``: the same pair and direction, either way round)
  within ``window`` frames of the scripted frame; a reported event no scripted event explains
  is a *false event*; one with nothing moving, appearing or leaving in the ``window`` frames
  before it is a false event *where nothing changed*.
"""

from __future__ import annotations

import itertools
import time
from collections import Counter
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from os import PathLike
from typing import Any

import numpy as np

from scenespeak.tools.sequences import HIDDEN_VISIBLE, OUT_OF_VIEW_INSIDE, SequenceTruth

__all__ = ["SequenceScore", "run_sequence", "score_sequence", "summarize"]

_OPPOSITE = {"left": "right", "right": "left", "front": "behind", "behind": "front"}


@dataclass(frozen=True)
class SequenceScore:
    """The measures of one sequence (see the module docstring)."""

    name: str
    id_matches: int
    id_kept: int
    static_checks: int
    flickers: int
    static_changes: int
    scripted: int
    reported: int
    false_events: int
    missed: list[dict[str, Any]] = field(default_factory=list)
    false: list[dict[str, Any]] = field(default_factory=list)
    delays: list[int] = field(default_factory=list)
    frames: int = 0
    seconds: float = 0.0
    recognised: int = 0
    false_static: int = 0


def run_sequence(
    seq: SequenceTruth, db_path: str | PathLike[str], options: Any = None
) -> tuple[list[dict[str, Any]], float]:
    """Stream a generated sequence through :class:`scenespeak.live.stream.SceneStream`;
    return the JSON lines and the seconds spent in ``process`` (images already decoded)."""
    from scenespeak.live.stream import SceneStream
    from scenespeak.perception.calibration import load_rig
    from scenespeak.perception.database import ObjectDatabase
    from scenespeak.perception.features import load_image

    rig = load_rig(seq.calib)
    lines = []
    spent = 0.0
    with ObjectDatabase.open(db_path, readonly=True) as db:
        stream = SceneStream(rig, db, options)
        for k in range(len(seq.frames)):
            lp, rp = seq.pair(k)
            left, right = load_image(lp, gray=False), load_image(rp, gray=False)
            t0 = time.perf_counter()
            frame = stream.process(left, right, k / 30.0)
            spent += time.perf_counter() - t0
            lines.append(frame.to_dict())
    return lines, spent


def _seen_truth(o: dict[str, Any]) -> bool:
    return bool(o["in_view"] >= OUT_OF_VIEW_INSIDE and o["visible_fraction"] >= HIDDEN_VISIBLE)


def _match_frame(
    line: dict[str, Any], truth: Iterable[dict[str, Any]], match_distance: float
) -> dict[int, int]:
    """truth id → stream id for one frame."""
    out: dict[int, int] = {}
    used: set[int] = set()
    for t in truth:
        if not _seen_truth(t):
            continue
        best, best_d = None, match_distance
        for o in line["objects"]:
            if o["status"] != "seen" or o["label"] != t["label"] or o["id"] in used:
                continue
            if "centroid" not in o:
                continue
            d = float(np.linalg.norm(np.subtract(o["centroid"], t["centroid"])))
            if d < best_d:
                best, best_d = o["id"], d
        if best is not None:
            out[int(t["id"])] = int(best)
            used.add(int(best))
    return out


def _static(seq: SequenceTruth, k: int) -> bool:
    """Frames k-1 and k show the same scene (no object moved > 1 mm, same pan)."""
    a, b = seq.frames[k - 1], seq.frames[k]
    if abs(a.pan_deg - b.pan_deg) > 1e-9:
        return False
    ida = {o["id"]: o for o in a.objects}
    idb = {o["id"]: o for o in b.objects}
    if ida.keys() != idb.keys():
        return False
    return all(
        np.linalg.norm(np.subtract(ida[i]["centroid"], idb[i]["centroid"])) < 1e-3 for i in ida
    )


def _event_matches(rep: dict[str, Any], ev: dict[str, Any], to_truth: dict[int, int]) -> bool:
    if rep["kind"] != ev["kind"]:
        return False
    obj = to_truth.get(rep["object"])
    if ev["kind"] != "moved":
        return obj == ev["object"]
    ref = to_truth.get(rep.get("referent") or -1)
    if (obj, ref) == (ev["object"], ev["referent"]):
        return bool(rep["relation"] == ev["relation"])
    if (obj, ref) == (ev["referent"], ev["object"]):
        return bool(rep["relation"] == _OPPOSITE.get(ev["relation"]))
    return False


def _where_nothing_changed(
    seq: SequenceTruth, events: Sequence[dict[str, Any]], window: int
) -> list[dict[str, Any]]:
    """The events with nothing moving, appearing or leaving in the ``window`` frames before."""
    return [
        r
        for r in events
        if all(_static(seq, k) for k in range(max(1, r["frame"] - window), r["frame"] + 1))
    ]


def score_sequence(
    seq: SequenceTruth,
    lines: Sequence[dict[str, Any]],
    *,
    match_distance: float = 0.25,
    window: int = 3,
) -> SequenceScore:
    """The measures of one streamed sequence (module docstring)."""
    matches = [
        _match_frame(ln, f.objects, match_distance)
        for ln, f in zip(lines, seq.frames, strict=False)
    ]
    id_n, id_kept = _ids_kept(matches)
    to_truth = _stream_to_truth(matches)
    checks, flickers, changes = _steadiness(seq, lines)
    reported_events = [dict(r, frame=ln["frame"]) for ln in lines for r in ln["event_records"]]
    missed, delays, explained = _explain_events(seq, reported_events, to_truth, window)
    false = [r for i, r in enumerate(reported_events) if i not in explained]
    # a false event "where nothing changed": no object moved, appeared or left in the frames
    # before it (``window`` of them)
    still = _where_nothing_changed(seq, false, window)
    return SequenceScore(
        seq.root.name,
        id_n,
        id_kept,
        checks,
        flickers,
        changes,
        len(seq.events),
        len(seq.events) - len(missed),
        len(false),
        missed,
        false,
        delays,
        len(lines),
        0.0,
        sum(1 for ln in lines if ln["recognised"]),
        len(still),
    )


def _ids_kept(matches: Sequence[dict[int, int]]) -> tuple[int, int]:
    """(true objects matched in two consecutive frames, of those with the same stream id)."""
    id_n = id_kept = 0
    for a, b in itertools.pairwise(matches):
        for tid, sid in a.items():
            if tid in b:
                id_n += 1
                id_kept += int(b[tid] == sid)
    return id_n, id_kept


def _stream_to_truth(matches: Sequence[dict[int, int]]) -> dict[int, int]:
    """Stream id → the true id it was matched to most often."""
    votes: dict[int, Counter[int]] = {}
    for m in matches:
        for tid, sid in m.items():
            votes.setdefault(sid, Counter())[tid] += 1
    return {sid: c.most_common(1)[0][0] for sid, c in votes.items()}


def _steadiness(seq: SequenceTruth, lines: Sequence[dict[str, Any]]) -> tuple[int, int, int]:
    """(static checks, flickers, sentence changes) over the frames where nothing moved.

    A change: a pair's sentence differs from the frame before although the scene did not
    change. A flicker: with three still frames, the middle one's sentence differs from the
    two around it, which agree.
    """
    sentences: list[dict[tuple[int, int], str]] = [
        {(r["argument_id"], r["referent_id"]): r["sentence"] for r in ln["relations"]}
        for ln in lines
    ]
    checks = flickers = changes = 0
    for k in range(1, len(lines)):
        if not _static(seq, k):
            continue
        now, prev = sentences[k], sentences[k - 1]
        changes += sum(1 for pair, s in now.items() if pair in prev and prev[pair] != s)
        if k + 1 < len(lines) and _static(seq, k + 1):
            nxt = sentences[k + 1]
            for pair, s in now.items():
                before, after = prev.get(pair), nxt.get(pair)
                if before is not None and after is not None:
                    checks += 1
                    flickers += int(before == after != s)
    return checks, flickers, changes


def _explain_events(
    seq: SequenceTruth,
    reported: Sequence[dict[str, Any]],
    to_truth: dict[int, int],
    window: int,
) -> tuple[list[dict[str, Any]], list[int], set[int]]:
    """Each scripted event against the first unexplained report within ``window`` frames that
    matches it: (missed events, delays in frames, indices of the reports that explain one)."""
    explained: set[int] = set()
    missed: list[dict[str, Any]] = []
    delays: list[int] = []
    for ev in seq.events:
        hit = next(
            (
                i
                for i, rep in enumerate(reported)
                if i not in explained
                and abs(rep["frame"] - ev["frame"]) <= window
                and _event_matches(rep, ev, to_truth)
            ),
            None,
        )
        if hit is None:
            missed.append(dict(ev))
        else:
            explained.add(hit)
            delays.append(int(reported[hit]["frame"] - ev["frame"]))
    return missed, delays, explained


def summarize(scores: Sequence[SequenceScore]) -> dict[str, Any]:
    """Totals over sequences, with the shares the issue's targets are stated in."""
    n = sum(s.id_matches for s in scores)
    kept = sum(s.id_kept for s in scores)
    scripted = sum(s.scripted for s in scores)
    reported = sum(s.reported for s in scores)
    frames = sum(s.frames for s in scores)
    return {
        "sequences": len(scores),
        "frames": frames,
        "id_matches": n,
        "id_stable": kept / n if n else float("nan"),
        "static_checks": sum(s.static_checks for s in scores),
        "flickers": sum(s.flickers for s in scores),
        "static_changes": sum(s.static_changes for s in scores),
        "scripted_events": scripted,
        "reported_in_window": reported,
        "false_events": sum(s.false_events for s in scores),
        "false_events_where_nothing_changed": sum(s.false_static for s in scores),
        "delays": sorted(d for s in scores for d in s.delays),
        "recognised_frames": sum(s.recognised for s in scores),
    }
