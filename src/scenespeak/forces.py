"""Compatibility path: ``scenespeak.forces`` is ``scenespeak.spatial.forces``.

Outside scripts import ``scenespeak.forces`` (docs/interfaces.md); the code lives in
:mod:`scenespeak.spatial.forces`. This module is that module under its old name.
"""

import sys

from scenespeak.spatial import forces as _impl

sys.modules[__name__] = _impl
