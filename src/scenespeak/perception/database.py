"""Compatibility path: ``scenespeak.perception.database`` → ``perception.recognition``.

Kept for scripts written before the split; new code imports ``scenespeak.perception.recognition``.
At run time this module *is* that package (``sys.modules``); type checkers see its names.
"""

import sys
from typing import TYPE_CHECKING

from scenespeak.perception import recognition as _impl

if TYPE_CHECKING:  # pragma: no cover
    from scenespeak.perception.recognition import *  # noqa: F403

sys.modules[__name__] = _impl
