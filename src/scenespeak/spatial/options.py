"""The relations stage's options: how many directions the histograms have, and the summary.

The pipeline's last stage relates every ordered pair of objects
(:func:`scenespeak.spatial.language.relate_objects`) and, optionally, writes a short paragraph
about the scene (:func:`scenespeak.spatial.language.summarize_scene`). The rule base's own
thresholds stay with the rules (``spatial.language.Thresholds``).
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["RelationOptions"]


@dataclass(frozen=True)
class RelationOptions:
    """Knobs of the relations stage.

    Attributes
    ----------
    directions : int
        180 — bins of the force histograms (2° each; the forces figures are measured at 180).
    summary : bool
        True — also write a short scene summary (``language.summarize_scene``).

    Examples
    --------
    >>> RelationOptions().directions
    180
    """

    directions: int = 180
    summary: bool = True
