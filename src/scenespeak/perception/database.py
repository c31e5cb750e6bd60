"""Compatibility path: ``scenespeak.perception.database`` → ``perception.recognition``.

Kept for scripts written before the split; new code imports ``scenespeak.perception.recognition``.
"""

import sys

from scenespeak.perception import recognition as _impl

sys.modules[__name__] = _impl
