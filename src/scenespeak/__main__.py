"""``python -m scenespeak``: the same as the ``scenespeak`` command."""

from __future__ import annotations

import sys

from scenespeak.cli import main

if __name__ == "__main__":  # pragma: no cover - exercised through subprocess in the tests
    sys.exit(main())
