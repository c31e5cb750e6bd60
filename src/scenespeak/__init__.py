"""scenespeak: say in words where objects are, from a stereo camera pair.

The pipeline runs images → features → stereo points → labelled objects → hulls → force
histograms → relations → sentences; each stage is one module (see ``docs/architecture.md``).

>>> import numpy as np
>>> import scenespeak
>>> hat = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
>>> mug = hat + [3.0, 0.0]
>>> scenespeak.relate(hat, mug, argument="hat", referent="mug").primary
'left'
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from scenespeak.errors import (
    CalibrationError,
    DatabaseError,
    ImageError,
    InputError,
    ScenespeakError,
)

__version__ = "0.1.0"

__all__ = [
    "CalibrationError",
    "DatabaseError",
    "ImageError",
    "InputError",
    "ScenespeakError",
    "__version__",
    "relate",
]

if TYPE_CHECKING:  # pragma: no cover
    from scenespeak.spatial.language import relate


def __getattr__(name: str) -> Any:
    # ``relate`` lives in the language stage; import it lazily so that ``import scenespeak``
    # stays cheap and never pulls in more than the caller uses.
    if name == "relate":
        from scenespeak.spatial.language import relate

        return relate
    raise AttributeError(f"module 'scenespeak' has no attribute {name!r}")
