"""Output folders written whole: into a private temporary sibling, renamed into place at the end.

The scene generator (:mod:`scenespeak.tools.scenes`) and the sequence generator
(:mod:`scenespeak.tools.sequences`) write every scene or sequence this way, so an interrupted
call leaves the old folder or the new one, never half of one.

>>> import tempfile
>>> from pathlib import Path
>>> out = Path(tempfile.mkdtemp()) / "scene"
>>> with folder_in_place(out) as tmp:
...     _ = (tmp / "truth.json").write_text("{}")
>>> sorted(p.name for p in out.iterdir())
['truth.json']
"""

from __future__ import annotations

import os
import shutil
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

__all__ = ["folder_in_place"]


@contextmanager
def folder_in_place(folder: Path) -> Iterator[Path]:
    """A temporary folder beside ``folder`` to write into, which becomes ``folder`` at the end.

    When the block ends normally the temporary folder is made readable by all (``mkdtemp``
    makes it private, 0700; a scene is ordinary output), an existing ``folder`` is removed and
    the temporary one renamed to it. When the block raises (an error, Ctrl-C), the temporary
    folder is removed and ``folder`` is left as it was.

    Parameters
    ----------
    folder : Path
        The folder to write (its parent is created if needed).

    Yields
    ------
    Path
        The temporary folder (a hidden sibling, ``.NAME-xxxx``).
    """
    folder.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{folder.name}-", dir=folder.parent))
    try:
        yield tmp
        tmp.chmod(0o755)
        if folder.exists():
            shutil.rmtree(folder)
        os.replace(tmp, folder)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
