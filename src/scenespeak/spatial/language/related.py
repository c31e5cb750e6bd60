"""What :func:`~.relate.relate_objects` returns: every ordered pair's relation and histograms,
made on first use."""

from __future__ import annotations

import contextlib
import gc
import sys
import threading
from collections.abc import Callable, Iterator, Sequence
from typing import Any, overload

from scenespeak.spatial.language.pairs import PairHistograms
from scenespeak.spatial.language.relation import Relation

__all__ = ["RelatedPairs"]

Pair = tuple[Relation, PairHistograms]


@contextlib.contextmanager
def _collector_paused() -> Iterator[None]:
    """Pause Python's cycle collector while the pairs are related, then restore it.

    A scene's results are about five container objects per ordered pair (100,000 for 100
    objects: the results, and the lists their numbers come from) and no reference cycle, but
    every 700 of them would start a collection, every tenth of those a larger one, and some of
    those scan the whole heap (everything the process holds, Numba's and NumPy's modules
    included): that took as long as the rest of :func:`~.relate.relate_objects` on 100
    objects (``benchmarks/bench_relate.py``). With the collector paused over the whole call
    (not only the loop that builds the results) the lists made and freed inside it start
    none. Nothing is left uncollected: the collector runs again, as before, once the call is
    done. If it was disabled, it stays disabled.
    """
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            gc.enable()


class RelatedPairs(Sequence[Pair]):
    """Every ordered pair's ``(Relation, PairHistograms)``: a sequence that behaves as the
    list of them, whose objects are made when it is first read.

    :func:`~.relate.relate_objects` decides every pair on arrays; making the 2 x 9,900
    result objects of 100 objects (and their 5 x 9,900 dicts of degrees, and freeing them)
    cost about as much as deciding. They are made, all at once and once only (also when
    several threads read it first), by the first read that needs them: an item, a slice,
    iteration, ``in``, ``==``, ``repr``, ``+``, pickling. ``len`` needs none. A caller that
    reads every result pays what it paid for the list (``bench_relate.py``'s "with every
    to_dict()"); one that keeps, passes on or counts the results does not. It compares equal
    to the list (and to another such sequence of equal items), and pickles and copies as
    that list.

    Examples
    --------
    >>> import numpy as np
    >>> from scenespeak.spatial.language import relate_objects
    >>> sq = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    >>> found = relate_objects([sq, sq + [3.0, 0.0]], names=["hat", "mug"])
    >>> len(found), found[1][0].sentence
    (2, 'The mug is directly to the right of the hat.')
    >>> found == list(found), [rel.primary for rel, _ in found[:1]]
    (True, ['left'])
    """

    __slots__ = ("_items", "_lock", "_make", "_size")

    def __init__(self, make: Callable[[], list[Pair]], size: int) -> None:
        """``make()`` returns the list of ``size`` pairs (called once, with the collector
        paused)."""
        self._make: Callable[[], list[Pair]] | None = make
        self._items: list[Pair] | None = None
        self._size = size
        self._lock = threading.Lock()

    def _list(self) -> list[Pair]:
        """The pairs, made on the first call (the maker and what it holds are then freed)."""
        items = self._items
        if items is None:
            with self._lock:
                items = self._items
                if items is None:
                    make = self._make
                    assert make is not None
                    with _collector_paused():
                        items = make()
                    self._items, self._make = items, None
        return items

    def __len__(self) -> int:
        return self._size

    @overload
    def __getitem__(self, index: int) -> Pair: ...

    @overload
    def __getitem__(self, index: slice) -> list[Pair]: ...

    def __getitem__(self, index: int | slice) -> Pair | list[Pair]:
        return self._list()[index]

    def __iter__(self) -> Iterator[Pair]:
        return iter(self._list())

    def __reversed__(self) -> Iterator[Pair]:
        return reversed(self._list())

    def __contains__(self, value: object) -> bool:
        return value in self._list()

    def index(self, value: Any, start: int = 0, stop: int = sys.maxsize) -> int:
        return self._list().index(value, start, stop)

    def count(self, value: Any) -> int:
        return self._list().count(value)

    def __eq__(self, other: object) -> bool:
        return self._list() == (other._list() if isinstance(other, RelatedPairs) else other)

    __hash__ = None  # type: ignore[assignment]  # as a list's: unhashable

    def __add__(self, other: list[Pair] | RelatedPairs) -> list[Pair]:
        return self._list() + (other._list() if isinstance(other, RelatedPairs) else other)

    def __radd__(self, other: list[Pair]) -> list[Pair]:
        return other + self._list()

    def __mul__(self, times: int) -> list[Pair]:
        return self._list() * times

    __rmul__ = __mul__

    def __repr__(self) -> str:
        return repr(self._list())

    def __reduce__(self) -> tuple[type[list[Pair]], tuple[list[Pair]]]:
        """Pickle (and copy) as the list."""
        return list, (self._list(),)
