"""tools.folders.folder_in_place: a scene or sequence folder appears whole or not at all."""

from __future__ import annotations

import stat
from pathlib import Path

import pytest

from scenespeak.tools.folders import folder_in_place


def test_the_folder_appears_whole_and_replaces_the_old_one(tmp_path: Path) -> None:
    out = tmp_path / "deep" / "scene"
    with folder_in_place(out) as tmp:
        assert tmp.parent == out.parent and tmp.name.startswith(".scene-")
        (tmp / "a.txt").write_text("1")
        assert not out.exists()  # nothing at the final place until the end
    assert sorted(p.name for p in out.iterdir()) == ["a.txt"]
    assert stat.S_IMODE(out.stat().st_mode) == 0o755
    with folder_in_place(out) as tmp:
        (tmp / "b.txt").write_text("2")
    assert sorted(p.name for p in out.iterdir()) == ["b.txt"]
    assert sorted(p.name for p in out.parent.iterdir()) == ["scene"]  # no temporary left


@pytest.mark.parametrize("error", [RuntimeError("render failed"), KeyboardInterrupt()])
def test_an_interrupted_write_leaves_the_old_folder(tmp_path: Path, error: BaseException) -> None:
    out = tmp_path / "scene"
    out.mkdir()
    (out / "old.txt").write_text("old")
    with pytest.raises(type(error)):
        with folder_in_place(out) as tmp:
            (tmp / "new.txt").write_text("half")
            raise error
    assert sorted(p.name for p in tmp_path.iterdir()) == ["scene"]
    assert sorted(p.name for p in out.iterdir()) == ["old.txt"]
