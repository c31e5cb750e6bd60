"""One way to replace single fields of a frozen options dataclass, refusing unknown names.

Every stage's options class (``LabelOptions``, ``ObjectOptions``, the stereo options, the
generator's, ``annotate``'s, the figures' style) accepts the old flat keywords through
:func:`replace_fields`; each caller keeps its own error (a ``TypeError`` like Python's for a
keyword, or an :class:`~scenespeak.errors.InputError` naming the input).

>>> from dataclasses import dataclass
>>> @dataclass(frozen=True)
... class Knobs:
...     ratio: float = 0.6
...     steps: int = 3
>>> replace_fields(Knobs(), {"steps": 5}, lambda bad, names: TypeError(f"{bad} not in {names}"))
Knobs(ratio=0.6, steps=5)
>>> replace_fields(Knobs(), {"step": 5}, lambda bad, names: TypeError(f"{bad} not in {names}"))
Traceback (most recent call last):
...
TypeError: ['step'] not in ['ratio', 'steps']
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import fields, replace
from typing import TypeVar

__all__ = ["replace_fields"]

T = TypeVar("T")


def replace_fields(
    base: T,
    overrides: Mapping[str, object],
    error: Callable[[list[str], list[str]], Exception],
) -> T:
    """``base`` (a dataclass instance) with the fields in ``overrides`` replaced.

    Parameters
    ----------
    base : dataclass instance
        The options to start from (returned as it is when ``overrides`` is empty).
    overrides : mapping
        Field name → new value.
    error : callable
        ``error(unknown_names, field_names)`` (both sorted) → the exception raised when a name
        is not a field.
    """
    names = sorted(f.name for f in fields(base))  # type: ignore[arg-type]
    unknown = sorted(set(overrides) - set(names))
    if unknown:
        raise error(unknown, names)
    if not overrides:
        return base
    return replace(base, **overrides)  # type: ignore[type-var]
