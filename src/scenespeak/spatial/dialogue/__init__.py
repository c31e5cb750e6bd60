"""Questions and answers about a scene, for a robot and a person (issue 13).

A small grammar (no network, no language model) parses what people ask — "where is the mug?",
"is the mug to the left of the can?", "what is near the can?", "which object is closest to
me?", "what do you see?" — and :func:`ask` answers it from a scene: a
:class:`~scenespeak.pipeline.SceneDescription` or the dict of a saved ``describe --format json``
output (:func:`load_scene` reads the file). Everything here reads only plain values; the
spatial half imports nothing from perception, and a saved scene is answered without NumPy
unless it lacks the camera-frame (``viewer``) relations an answer needs.

>>> from scenespeak.spatial.dialogue import ask
>>> scene = {"objects": [
...     {"label": "mug", "centroid": [-0.3, 0.1, 1.0], "hull": [[-0.35, 0.95], [-0.25, 0.95],
...      [-0.25, 1.05], [-0.35, 1.05]]},
...     {"label": "can", "centroid": [0.0, 0.1, 1.0], "hull": [[-0.05, 0.95], [0.05, 0.95],
...      [0.05, 1.05], [-0.05, 1.05]]}],
...   "relations": [
...     {"argument": "mug", "referent": "can", "primary": "left", "secondary": None,
...      "sentence": "The mug is directly to the left of the can.", "confidence": 0.95,
...      "degrees": {"left": 0.97, "right": 0.0, "front": 0.0, "behind": 0.0}},
...     {"argument": "can", "referent": "mug", "primary": "right", "secondary": None,
...      "sentence": "The can is directly to the right of the mug.", "confidence": 0.95,
...      "degrees": {"left": 0.0, "right": 0.97, "front": 0.0, "behind": 0.0}}]}
>>> ask("Is the mug to the left of the can?", scene).to_dict()["answer"]
'Yes.'
>>> ask("where is the mug", scene).answer
'The mug is directly to the left of the can. It is near the can (20 cm apart), 1.0 m from me.'
"""

from __future__ import annotations

from scenespeak.spatial.dialogue.answers import Answer, ask
from scenespeak.spatial.dialogue.grammar import Query, parse
from scenespeak.spatial.dialogue.scene import (
    DialogueObject,
    DialogueRelation,
    DialogueScene,
    load_scene,
    scene_from,
    scene_from_dict,
)
from scenespeak.spatial.dialogue.views import summarize, viewer_entries

__all__ = [
    "Answer",
    "DialogueObject",
    "DialogueRelation",
    "DialogueScene",
    "Query",
    "ask",
    "load_scene",
    "parse",
    "scene_from",
    "scene_from_dict",
    "summarize",
    "viewer_entries",
]
