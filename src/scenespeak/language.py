"""Compatibility path: ``scenespeak.language`` is ``scenespeak.spatial.language``.

Outside scripts import ``scenespeak.language`` (docs/interfaces.md); the code lives in
:mod:`scenespeak.spatial.language`. This module is that module under its old name.
"""

import sys

from scenespeak.spatial import language as _impl

sys.modules[__name__] = _impl
