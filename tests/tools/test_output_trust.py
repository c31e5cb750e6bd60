"""Outputs under bad targets (issue 12): never written over a device, a FIFO or a folder, and a
run refused before its first scene leaves no file behind."""

from __future__ import annotations

import os
import stat
from pathlib import Path

import pytest

from scenespeak.errors import InputError
from scenespeak.safetext import check_output
from scenespeak.tools.output import ResumableJsonl, write_parquet


def test_check_output_refuses_what_is_not_a_file(tmp_path: Path) -> None:
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    with pytest.raises(InputError, match="FIFO"):
        check_output(fifo)
    with pytest.raises(InputError, match="folder"):
        check_output(tmp_path)
    with pytest.raises(InputError, match="does not exist"):
        check_output(tmp_path / "missing" / "x.parquet")
    link = tmp_path / "link.parquet"
    link.symlink_to(tmp_path / "elsewhere")
    assert check_output(link) == link  # a link is replaced by the rename, not written through
    assert check_output(tmp_path / "new.parquet").name == "new.parquet"


def test_parquet_over_a_device_is_refused_and_the_device_kept(tmp_path: Path) -> None:
    jsonl = tmp_path / "pairs.jsonl"
    jsonl.write_text("")
    target = tmp_path / "full"
    try:  # a private /dev/full (character device 1, 7); a FIFO where that is not allowed
        os.mknod(target, 0o666 | stat.S_IFCHR, os.makedev(1, 7))
    except OSError:
        os.mkfifo(target)
    kind = stat.S_IFMT(target.lstat().st_mode)
    with pytest.raises(InputError, match=r"is a (device|FIFO)"):
        write_parquet(jsonl, target)
    assert stat.S_IFMT(target.lstat().st_mode) == kind  # not replaced by a regular file


def test_a_run_refused_before_its_first_scene_leaves_nothing(tmp_path: Path) -> None:
    out = tmp_path / "pairs.jsonl"
    with pytest.raises(InputError), ResumableJsonl.open(out):
        raise InputError("--scheduler", "nothing listens")
    assert sorted(p.name for p in tmp_path.iterdir()) == []
    ResumableJsonl.open(out).close()  # the corrected command starts cleanly
    assert out.exists()


def test_a_scheduler_where_nothing_listens_is_refused_at_once() -> None:
    import socket
    import time

    from scenespeak.tools.engine import _probe_scheduler

    with socket.socket() as s:  # a port that was free a moment ago
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    start = time.monotonic()
    with pytest.raises(InputError, match="nothing listens"):
        _probe_scheduler(f"tcp://127.0.0.1:{port}")
    assert time.monotonic() - start < 5
    _probe_scheduler("inproc://x")  # other forms are left to Dask
