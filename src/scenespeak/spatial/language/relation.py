"""The relation: where the argument is relative to the referent, words and numbers."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, fields, make_dataclass
from typing import Any

__all__ = ["Relation"]


@dataclass(frozen=True, slots=True)
class Relation:
    """Where the argument is relative to the referent, in words and in the numbers behind them.

    Attributes
    ----------
    argument, referent : str
        Labels ("What is the relation of *argument* to *referent*?"). For viewer relations the
        referent is ``"me"``.
    primary : str
        ``"left"``, ``"right"``, ``"front"``, ``"behind"`` or ``"surrounded"`` (also for "partly
        surrounded"; see ``kind``). For a compound, the front/behind part. In viewer relations
        the directions are the viewer's: ``"front"`` is farther from the camera.
    secondary : str or None
        One of the four directions, or None. For a compound, the left/right part.
    hedge : str or None
        ``"directly"``, ``"mostly"``, ``"loosely"`` or None (no hedge).
    secondary_hedge : str or None
        ``"somewhat"``, ``"slightly"``, ``"extends"`` or None.
    kind : str
        ``"direction"``, ``"compound"``, ``"surrounded"``, ``"partly surrounded"``,
        ``"surrounds"`` or ``"partly surrounds"`` (the argument is the larger, enclosing object;
        ``primary`` is then ``"surrounded"`` too): which horizontal rule produced the words.
    sentence : str
        The sentence to say. When ``vertical`` is set it is the vertical sentence ("The mug is
        on top of the can."), otherwise ``horizontal_sentence``.
    horizontal_sentence : str
        The sentence of the horizontal rule set alone.
    confidence : float
        Self-assessment in [0, 1]: high when the winning degree is high and F0 and F2 agree.
    degrees0, degrees2, degrees : dict of str to float
        Degrees of truth of the four directions from F0, from F2 (or F02) and their mean.
    deviation0, deviation2 : dict of str to float
        Signed mean deviation (radians, counter-clockwise positive) of each histogram's
        effective forces from each direction.
    deviation : float
        F2's deviation from the primary direction (radians); its sign picks the secondary side.
    coverage : float
        Fraction of directions covered by the smoothed F0 (the surround measure).
    extends_share : float
        Share of F0's mass within 45° of the secondary direction (the "extends" measure), 0
        when there is no secondary.
    overlap : float or None
        area(A ∩ B) / area(A) when known (``relate`` computes it), else None.
    referent_overlap : float or None
        area(A ∩ B) / area(B) when known, else None.
    vertical : str or None
        ``"on top of"``, ``"above"``, ``"below"``, ``"under"`` or None.
    hybrid : bool
        True when ``f2`` was the hybrid F02 (touching or intersecting objects).
    frame : str
        ``"object"`` or ``"viewer"`` (the camera is the referent).

    Notes
    -----
    The fields are slots (no per-instance ``__dict__``): a scene of 100 objects makes 9,900
    relations (:func:`~.relate.relate_objects`), and each costs less to make and to free.
    """

    argument: str
    referent: str
    primary: str
    secondary: str | None
    hedge: str | None
    sentence: str
    confidence: float
    secondary_hedge: str | None = None
    kind: str = "direction"
    horizontal_sentence: str = ""
    degrees0: dict[str, float] = field(default_factory=dict)
    degrees2: dict[str, float] = field(default_factory=dict)
    degrees: dict[str, float] = field(default_factory=dict)
    deviation0: dict[str, float] = field(default_factory=dict)
    deviation2: dict[str, float] = field(default_factory=dict)
    deviation: float = 0.0
    coverage: float = 0.0
    extends_share: float = 0.0
    overlap: float | None = None
    referent_overlap: float | None = None
    vertical: str | None = None
    hybrid: bool = False
    frame: str = "object"

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready values; angles in degrees (``deviation_deg``, ``deviation0_deg``, ...).

        Examples
        --------
        >>> import numpy as np
        >>> from scenespeak.spatial.language import describe_relation
        >>> h = np.zeros(180); h[90] = 1.0
        >>> d = describe_relation(h, h, argument="mug", referent="can").to_dict()
        >>> d["primary"], d["secondary"], d["sentence"]
        ('left', None, 'The mug is directly to the left of the can.')
        """
        # Field by field, in the fields' order (one generic loop over ``fields`` cost about
        # twice as much: ``relate_objects`` on 100 objects makes 9,900 of them).
        deg = math.degrees
        return {
            "argument": _plain(self.argument),
            "referent": _plain(self.referent),
            "primary": _plain(self.primary),
            "secondary": _plain(self.secondary),
            "hedge": _plain(self.hedge),
            "sentence": _plain(self.sentence),
            "confidence": _plain(self.confidence),
            "secondary_hedge": _plain(self.secondary_hedge),
            "kind": _plain(self.kind),
            "horizontal_sentence": _plain(self.horizontal_sentence),
            "degrees0": _plain(self.degrees0),
            "degrees2": _plain(self.degrees2),
            "degrees": _plain(self.degrees),
            "deviation0_deg": {k: deg(v) for k, v in self.deviation0.items()},
            "deviation2_deg": {k: deg(v) for k, v in self.deviation2.items()},
            "deviation_deg": deg(self.deviation),
            "coverage": _plain(self.coverage),
            "extends_share": _plain(self.extends_share),
            "overlap": _plain(self.overlap),
            "referent_overlap": _plain(self.referent_overlap),
            "vertical": _plain(self.vertical),
            "hybrid": _plain(self.hybrid),
            "frame": _plain(self.frame),
        }

    def __reduce__(self) -> tuple[Callable[..., Relation], tuple[Any, ...]]:
        """Pickle (and copy) as the field values, rebuilt by :func:`_relation`."""
        return _relation, tuple(getattr(self, name) for name in _NAMES)


_NAMES = tuple(f.name for f in fields(Relation))


def _plain(value: Any) -> Any:
    """A field's JSON-ready value: dicts of plain floats, plain floats, the rest as it is."""
    if type(value) is str or value is None:
        return value
    if isinstance(value, dict):
        if type(value) is dict and all(type(v) is float for v in value.values()):
            return value.copy()  # float(v) is v for a float: the same new dict, faster
        return {k: float(v) for k, v in value.items()}
    if isinstance(value, float):
        return float(value)
    return value


def _twin(cls: type[Any]) -> type[Any]:
    """A mutable twin of the slotted frozen dataclass ``cls``: the same fields, the same slots
    (so an instance can become a ``cls`` by ``__class__`` assignment), and an ``__init__`` that
    stores them directly, where the frozen ``__init__`` calls ``object.__setattr__`` per field
    (three to four times slower for :class:`Relation`)."""
    spec = [(f.name, f.type, f) for f in fields(cls)]
    twin: type[Any] = make_dataclass(f"_{cls.__name__}Fill", spec, eq=False, slots=True, repr=False)
    if twin.__slots__ != cls.__slots__:
        raise TypeError(f"{cls.__name__} and its twin must have the same slots")
    return twin


_RelationFill = _twin(Relation)


def _relation(*values: Any) -> Relation:
    """A :class:`Relation` of its field values in order: what ``Relation(*values)`` makes,
    through :func:`_twin`'s ``__init__``.

    Examples
    --------
    >>> r = Relation("mug", "can", "left", None, None, "The mug is left of the can.", 0.9)
    >>> _relation(*(getattr(r, name) for name in _NAMES)) == r
    True
    """
    made = _RelationFill(*values)
    made.__class__ = Relation
    return made
