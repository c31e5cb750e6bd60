"""The dialogue's figures on generated scenes with known truth (issue 13, "What it must show").

For a dataset of the scene generator (``truth.json`` per scene) and the saved descriptions of
its scenes (``describe --viewer --format json``, one ``<scene>.json`` each; :func:`describe_dataset`
writes them through the library), :func:`dialogue_figures` asks the questions and scores them:

- **yes/no** — for every clear pair (the truth's direction ≥ 25° from a diagonal, footprints
  apart, neither hidden) and each of the four directions, "is the A <direction> the B?": right
  when the asked true direction gets a yes-like answer ("Yes", "Mostly", "Probably"), its
  opposite a "No", and the two others anything but a plain "Yes.";
- **where** — "where is the X?" for every true object that was described: right when the
  answer names X, a referent (an object of the truth, or "me") and a direction within 65° of
  the true direction (the said direction's sector reaches the truth's, with the generator's
  20° diagonal tolerance; "on top of" when the truth says so);
- **summary** — at most n + 1 sentences and every object (not clutter) named;
- **viewer** — the said left/right agrees with the sign of the true bearing, or nothing
  lateral is said and the object is within 20° of straight ahead;
- **reliability** — the relations' confidence (raw self-assessment and calibrated) in ten bins
  against how often the primary direction is right, and the expected calibration error
  ECE = Σ_b (n_b / N) |acc_b − conf_b| (Naeini et al., AAAI 2015).
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Sequence
from dataclasses import dataclass
from os import PathLike
from pathlib import Path
from typing import TYPE_CHECKING, Any

from scenespeak.errors import InputError

if TYPE_CHECKING:
    from scenespeak.spatial.dialogue.scene import DialogueScene

__all__ = [
    "DIRECTIONS",
    "DOC_QUESTIONS",
    "LayoutScene",
    "ReliabilityBin",
    "describe_dataset",
    "dialogue_figures",
    "layout_scene",
    "question_table",
    "reliability",
    "said_direction",
    "update_doc_table",
    "viewer_consistent",
    "where_consistent",
]

DIRECTIONS = ("left", "right", "front", "behind")
_ANGLE = {"right": 0.0, "behind": 90.0, "left": 180.0, "front": 270.0}
_OPPOSITE = {"right": "left", "left": "right", "front": "behind", "behind": "front"}
_COMPOUND = {"front-left": 225.0, "front-right": 315.0, "rear-left": 135.0, "rear-right": 45.0}


def describe_dataset(
    dataset: str | PathLike[str], out: str | PathLike[str], db: str | PathLike[str] | None = None
) -> list[Path]:
    """Describe every scene of a generated dataset and save ``describe --viewer --format json``
    as ``out/<scene>.json`` (already saved scenes are kept)."""
    from scenespeak.pipeline import database_from_dataset, describe_files
    from scenespeak.spatial.dialogue import scene_from_dict, viewer_entries
    from scenespeak.tools.scenes import load_dataset

    ds = load_dataset(dataset)
    out_dir = Path(out)
    out_dir.mkdir(parents=True, exist_ok=True)
    db_path = Path(db) if db is not None else out_dir / "objects.db"
    if db is None and not db_path.exists():
        database_from_dataset(dataset, db_path)
    written = []
    for scene in ds.scenes:
        target = out_dir / f"{scene.name}.json"
        if not target.exists():
            try:
                desc = describe_files(
                    scene / "left.png", scene / "right.png", scene / "calib.json", db_path
                )
            except InputError as exc:
                data: dict[str, Any] = {"objects": [], "relations": [], "error": str(exc)}
            else:
                data = desc.to_dict()
                data["viewer"] = viewer_entries(scene_from_dict(data))
            target.write_text(json.dumps(data), encoding="utf-8")
        written.append(target)
    return written


@dataclass(frozen=True)
class LayoutScene:
    """A generated layout described without rendering: the describe dict and its truth.

    ``description`` is what ``describe --format json`` would say if perception were perfect
    (hulls = the true footprints, heights = the true extents, relations from the force
    histograms and the rule base); ``truth`` is the generator's ``truth.json``-like record of
    objects (label, centroid, footprint, on) and relations (primary, angle_deg, ambiguous).
    """

    description: dict[str, Any]
    truth: dict[str, Any]


def layout_scene(seed: int, *, stacked: bool = False, n_objects: int | None = None) -> LayoutScene:
    """A scene from the generator's layouts (``tools.scenes.sample_layout``, level rig),
    described by the spatial half alone — the fast test bed of the dialogue.

    >>> ls = layout_scene(3)
    >>> len(ls.description["objects"]) == len(ls.truth["objects"])
    True
    """
    import numpy as np

    from scenespeak.spatial.language import relate_objects
    from scenespeak.tools.scenes import Rig, footprint_relation, sample_layout

    rig = Rig()
    placed = sample_layout(seed, rig, stacked=stacked, n_objects=n_objects)
    objects, truth_objects, hulls, heights = [], [], [], []
    for pl in placed:
        fp = pl.footprint_world()  # level rig: plane (x, y) = world (x, y)
        cx, cy, cz = pl.centroid_world()
        lo = pl.position[2] - rig.height
        hi = lo + pl.obj.size[2]
        centroid = [float(cx), float(rig.height - cz), float(cy)]
        hull = [[float(x), float(y)] for x, y in fp]
        objects.append(
            {"label": pl.obj.label, "points": 200, "centroid": centroid, "hull": hull,
             "plane_centroid": [float(cx), float(cy)], "height_range": [lo, hi]}
        )  # fmt: skip
        truth_objects.append(
            {"label": pl.obj.label, "centroid": centroid, "footprint": hull, "on": pl.on,
             "size": list(pl.obj.size), "visible_fraction": 1.0}
        )  # fmt: skip
        hulls.append(fp)
        heights.append(np.linspace(lo, hi, 5))
    names = [str(o["label"]) for o in objects]
    found = relate_objects(hulls, names=names, heights=heights)
    relations = []
    for rel, _ in found:
        d = rel.to_dict()
        relations.append(d)
    truth_rel = []
    for i, _a in enumerate(placed):
        for j, _b in enumerate(placed):
            if i != j:
                primary, angle, ambiguous = footprint_relation(hulls[i], hulls[j])
                truth_rel.append(
                    {"argument": names[i], "referent": names[j], "primary": primary,
                     "angle_deg": angle, "ambiguous": ambiguous}
                )  # fmt: skip
    camera = {"focal_px": 554.256, "baseline_m": rig.baseline}
    return LayoutScene(
        {"objects": objects, "relations": relations, "camera": camera},
        {"objects": truth_objects, "relations": truth_rel},
    )


def _wrap(deg: float) -> float:
    return abs((deg + 180.0) % 360.0 - 180.0)


_SAID = [
    ("front-left", r"front-left of"),
    ("front-right", r"front-right of"),
    ("rear-left", r"rear-left of"),
    ("rear-right", r"rear-right of"),
    ("on top of", r"on top of|above"),
    ("below", r"below|under"),
    ("left", r"to the left of"),
    ("right", r"to the right of"),
    ("front", r"in front of"),
    ("behind", r"behind"),
]


def said_direction(sentence: str) -> str | None:
    """The main direction a relation sentence states ("front-left", "behind", ...)."""
    first = sentence.split(". ")[0]
    for name, pattern in _SAID:
        if re.search(rf"\b(?:{pattern})\b", first):
            return name
    return None


def where_consistent(said: str | None, truth_angle: float, truth_on: bool) -> bool:
    """Whether a said direction agrees with the true angle of the argument from the referent."""
    if said is None:
        return False
    if said in ("on top of", "below"):
        return truth_on if said == "on top of" else False
    angle = _COMPOUND.get(said, _ANGLE.get(said))
    return angle is not None and _wrap(angle - truth_angle) < 65.0


def viewer_consistent(entry: dict[str, Any], true_x: float, true_z: float) -> bool:
    """Whether a ``viewer`` entry's left/right/front agrees with the true position (camera
    frame X right, Z forward)."""
    lateral = {entry.get("primary"), entry.get("secondary")} & {"left", "right"}
    bearing = math.degrees(math.atan2(true_x, true_z))
    if "front" not in (entry.get("primary"), entry.get("secondary")) and not lateral:
        return False
    if true_z <= 0:
        return False
    if not lateral:
        return abs(bearing) <= 20.0
    side = lateral.pop()
    return (side == "left") == (bearing < 0)


@dataclass(frozen=True)
class ReliabilityBin:
    """One confidence bin: [low, high), count, mean confidence, accuracy."""

    low: float
    high: float
    n: int
    confidence: float
    accuracy: float


def reliability(
    confidences: Sequence[float], correct: Sequence[bool], bins: int = 10
) -> tuple[list[ReliabilityBin], float]:
    """Reliability table and expected calibration error of confidences against outcomes.

    >>> table, ece = reliability([0.95, 0.95, 0.55, 0.55], [True, True, True, False])
    >>> [(b.n, b.accuracy) for b in table if b.n], round(ece, 3)
    ([(2, 0.5), (2, 1.0)], 0.05)
    """
    out = []
    total = len(confidences)
    ece = 0.0
    for k in range(bins):
        lo, hi = k / bins, (k + 1) / bins
        idx = [i for i, c in enumerate(confidences) if lo <= c < hi or (k == bins - 1 and c >= 1.0)]
        if not idx:
            out.append(ReliabilityBin(lo, hi, 0, math.nan, math.nan))
            continue
        conf = sum(confidences[i] for i in idx) / len(idx)
        acc = sum(bool(correct[i]) for i in idx) / len(idx)
        ece += len(idx) / max(total, 1) * abs(acc - conf)
        out.append(ReliabilityBin(lo, hi, len(idx), conf, acc))
    return out, ece


def _load(path: Path) -> dict[str, Any]:
    try:
        data: dict[str, Any] = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, json.JSONDecodeError) as exc:
        raise InputError(path, f"cannot be read as JSON ({exc})") from exc
    return data


_YES = re.compile(r"^(?:yes|mostly|probably(?!.*\bnot\b)|probably, mostly)", re.IGNORECASE)


def _yes_no_right(answer: str, asked: str, truth: str) -> bool:
    if asked == truth:
        return bool(_YES.match(answer))
    if asked == _OPPOSITE[truth]:
        return answer.startswith("No")
    return not answer.startswith("Yes")


def _sentences(text: str) -> int:
    return len([s for s in re.split(r"(?<=[.!?])\s+", text.strip()) if s])


def _score_scene(desc: dict[str, Any], truth: dict[str, Any], tally: dict[str, list[Any]]) -> None:
    """Score one scene's questions into ``tally`` (yes/no, where, viewer, summary, relations)."""
    from scenespeak.spatial.dialogue import scene_from_dict

    scene = scene_from_dict(desc)
    tobj = {o["label"]: o for o in truth["objects"]}
    trel = {(r["argument"], r["referent"]): r for r in truth["relations"]}
    _score_yes_no(scene, trel, tally)
    _score_where(scene, desc, tobj, trel, tally)
    _score_summary(scene, tally)
    _score_relations(scene, trel, tally)


def _score_yes_no(
    scene: DialogueScene, trel: dict[tuple[str, str], Any], tally: dict[str, list[Any]]
) -> None:
    """The four "is the A <direction> the B?" questions of every clear, described pair."""
    from scenespeak.spatial.dialogue import ask

    names = set(scene.names)
    for (a, b), r in trel.items():
        if a not in names or b not in names or r["ambiguous"]:
            continue
        for asked in DIRECTIONS:
            q = f"Is the {a} {_PHRASE[asked]} the {b}?"
            tally["yes_no"].append(_yes_no_right(ask(q, scene).answer, asked, r["primary"]))


def _score_where(
    scene: DialogueScene,
    desc: dict[str, Any],
    tobj: dict[str, Any],
    trel: dict[tuple[str, str], Any],
    tally: dict[str, list[Any]],
) -> None:
    """The "where is the X?" question of every described true object, and its viewer side."""
    from scenespeak.spatial.dialogue import ask

    names = set(scene.names)
    for label, o in tobj.items():
        if label not in names:
            continue
        ans = ask(f"Where is the {label}?", scene)
        ok = ans.objects[:1] == (label,)
        if len(ans.objects) >= 2:
            ref = ans.objects[1]
            t = trel.get((label, ref))
            on = o.get("on") == ref
            ok = (
                ok
                and t is not None
                and where_consistent(said_direction(ans.answer), float(t["angle_deg"]), on)
            )
        else:
            v = next(e for e in desc.get("viewer", []) if e["object"] == label)
            ok = (
                ok
                and "me" in ans.answer
                and viewer_consistent(v, o["centroid"][0], o["centroid"][2])
            )
        tally["where"].append(ok)
        tally["where_referent"].append(ans.objects[1] if len(ans.objects) > 1 else "me")
        v = next((e for e in desc.get("viewer", []) if e["object"] == label), None)
        if v is not None:
            tally["viewer"].append(viewer_consistent(v, o["centroid"][0], o["centroid"][2]))


def _score_summary(scene: DialogueScene, tally: dict[str, list[Any]]) -> None:
    """At most n + 1 sentences naming every object that is not clutter."""
    from scenespeak.spatial.dialogue import summarize
    from scenespeak.spatial.dialogue.words import display_name, is_clutter

    if scene.objects:
        text = summarize(scene)
        shown = [display_name(x, scene) for x in scene.objects if not is_clutter(x)]
        tally["summary"].append(
            _sentences(text) <= len(shown) + 1 and all(f"the {n}" in text for n in shown)
        )


def _score_relations(
    scene: DialogueScene, trel: dict[tuple[str, str], Any], tally: dict[str, list[Any]]
) -> None:
    """Each true relation's described primary direction and its raw and calibrated confidence."""
    from scenespeak.spatial.dialogue.uncertainty import relation_confidence

    for (a, b), r in trel.items():
        rel = scene.relation(a, b)
        if rel is None:
            continue
        tally["rel_correct"].append(rel.primary == r["primary"])
        tally["rel_raw"].append(max(0.0, min(1.0, rel.confidence)))
        tally["rel_cal"].append(relation_confidence(rel, scene))
        tally["rel_ambiguous"].append(bool(r["ambiguous"]))


_PHRASE = {
    "left": "to the left of",
    "right": "to the right of",
    "front": "in front of",
    "behind": "behind",
}


def dialogue_figures(
    dataset: str | PathLike[str], described: str | PathLike[str]
) -> dict[str, Any]:
    """Ask and score every question of the module docstring over a described dataset."""
    from scenespeak.tools.scenes import load_dataset

    ds = load_dataset(dataset)
    tally: dict[str, list[Any]] = {
        k: []
        for k in (
            "yes_no",
            "where",
            "where_referent",
            "viewer",
            "summary",
            "rel_correct",
            "rel_raw",
            "rel_cal",
            "rel_ambiguous",
        )
    }
    for scene in ds.scenes:
        desc = _load(Path(described) / f"{scene.name}.json")
        truth = _load(scene / "truth.json")
        _score_scene(desc, truth, tally)

    def frac(key: str) -> dict[str, Any]:
        v = tally[key]
        return {"right": sum(v), "total": len(v), "fraction": sum(v) / len(v) if v else None}

    raw_table, raw_ece = reliability(tally["rel_raw"], tally["rel_correct"])
    cal_table, cal_ece = reliability(tally["rel_cal"], tally["rel_correct"])
    refs = tally["where_referent"]
    return {
        "dataset": str(dataset),
        "scenes": len(ds.scenes),
        "yes_no_clear": frac("yes_no"),
        "where": frac("where"),
        "where_referent_me": sum(r == "me" for r in refs),
        "summary": frac("summary"),
        "viewer": frac("viewer"),
        "relations": len(tally["rel_correct"]),
        "relations_right": sum(tally["rel_correct"]),
        "ece_raw": raw_ece,
        "ece_calibrated": cal_ece,
        "reliability_raw": [b.__dict__ for b in raw_table],
        "reliability_calibrated": [b.__dict__ for b in cal_table],
        "_samples": {k: tally[k] for k in ("rel_correct", "rel_raw", "rel_cal")},
    }


#: The questions of the table in ``docs/dialogue.md`` (asked on ``layout_scene(2, stacked=True)``).
DOC_QUESTIONS = (
    "What do you see?",
    "How many objects do you see?",
    "Where is the mug?",
    "Where's the card?",
    "Can you tell me where the shoebox is, please?",
    "Is the mug on top of the tin?",
    "Is the can to the left of the shoebox?",
    "Is the can behind the shoebox?",
    "Is the card in front of the shoebox?",
    "Is the card to the right of the tin?",
    "Is the card near the tin?",
    "How far is the can from the shoebox?",
    "What is to the left of the tin?",
    "Is there anything next to the shoebox?",
    "Which object is closest to me?",
    "What is the leftmost object?",
    "Is the tin between the card and the can?",
    "What is between the card and the can?",
    "Is the tin to the right of me?",
    "Where are the mugs?",
    "Where is the cup?",
    "Sing me a song.",
)
_START = "<!-- dialogue-table:start (generated by tools.dialogue_eval.update_doc_table) -->"
_END = "<!-- dialogue-table:end -->"


def question_table() -> str:
    """The Markdown table of :data:`DOC_QUESTIONS` and the answers given on one scene."""
    from scenespeak.spatial.dialogue import ask, scene_from_dict, summarize

    ls = layout_scene(2, stacked=True)
    scene = scene_from_dict(ls.description)
    rows = ["| question | answer | kind | degree | objects |", "| --- | --- | --- | --- | --- |"]
    for q in DOC_QUESTIONS:
        a = ask(q, scene)
        deg = "" if a.degree is None else f"{a.degree:.2f}"
        answer = a.answer.replace("|", "\\|")
        rows.append(f"| {q} | {answer} | {a.kind} | {deg} | {', '.join(a.objects)} |")
    layout = ", ".join(
        f"{o['label']} ({o['centroid'][0]:+.2f}, {o['centroid'][2]:.2f})"
        + (f" on the {o['on']}" if o["on"] else "")
        for o in ls.truth["objects"]
    )
    head = (
        f"The scene: `layout_scene(2, stacked=True)` — objects at (X, Z) metres from the camera: "
        f"{layout}.\n\n`--summary`: {summarize(scene)}\n"
    )
    return head + "\n" + "\n".join(rows)


def update_doc_table(text: str) -> str:
    """``text`` with the part between the table markers replaced by :func:`question_table`."""
    start, end = text.index(_START) + len(_START), text.index(_END)
    return text[:start] + "\n" + question_table() + "\n" + text[end:]
