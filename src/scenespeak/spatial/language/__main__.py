"""``python -m scenespeak.spatial.language --table``: print the README's layout table."""

from scenespeak.spatial.language.table import main

raise SystemExit(main())
