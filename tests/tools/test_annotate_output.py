"""The resumable JSON Lines output of ``annotate`` (no images: pure file handling)."""

from __future__ import annotations

import json
from pathlib import Path

import pyarrow.parquet as pq
import pytest

from scenespeak.errors import InputError
from scenespeak.tools.output import ResumableJsonl, SceneRecord, log_path, write_parquet


def _line(scene: str, k: int) -> str:
    return json.dumps(
        {
            "scene": scene,
            "argument": f"a{k}",
            "referent": f"b{k}",
            "primary": "left",
            "secondary": None,
            "sentence": "The a is to the left of the b.",
            "degrees": {"left": 1.0, "right": 0.0, "front": 0.0, "behind": 0.0},
            "confidence": 0.9,
            "ambiguous": False,
        }
    )


def _record(scene: str, pairs: int) -> SceneRecord:
    return SceneRecord(scene, tuple(_line(scene, k) for k in range(pairs)), objects=2)


def test_log_path_beside_the_output(tmp_path: Path) -> None:
    assert log_path(tmp_path / "relations.jsonl") == tmp_path / "relations.scenes.jsonl"
    assert log_path(tmp_path / "labels") == tmp_path / "labels.scenes.jsonl"


def test_a_torn_batch_is_cut_off_and_run_again(tmp_path: Path) -> None:
    out = tmp_path / "r.jsonl"
    with ResumableJsonl.open(out) as sink:
        sink.write([_record("s1", 2), _record("s2", 0)])
        sink.write([SceneRecord("s3", error="x.png: cannot be read")])
    good = out.read_bytes()
    # A run killed in the middle of the next batch: half its pair lines, a torn log line.
    with out.open("ab") as fh:
        fh.write((_line("s4", 0) + "\n" + _line("s4", 1)[:20]).encode())
    with log_path(out).open("ab") as fh:
        fh.write(b'{"scene": "s4", "pai')
    with ResumableJsonl.open(out, resume=True) as sink:
        assert sink.finished == {"s1", "s2", "s3"} and sink.failed == {"s3"}
        assert sink.pairs == 2
        assert out.read_bytes() == good
        sink.write([_record("s4", 2)])
    lines = out.read_text().splitlines()
    assert [json.loads(x)["scene"] for x in lines] == ["s1", "s1", "s4", "s4"]
    log = [json.loads(x) for x in log_path(out).read_text().splitlines()]
    assert [r["scene"] for r in log] == ["s1", "s2", "s3", "s4"]
    assert log[2]["error"] == "x.png: cannot be read" and log[2]["pairs"] == 0


def test_retry_failed_runs_failed_scenes_again(tmp_path: Path) -> None:
    out = tmp_path / "r.jsonl"
    with ResumableJsonl.open(out) as sink:
        sink.write([_record("s1", 1), SceneRecord("s2", error="boom")])
    with ResumableJsonl.open(out, resume=True, retry_failed=True) as sink:
        assert sink.finished == {"s1"}
        sink.write([_record("s2", 3)])
    with ResumableJsonl.open(out, resume=True) as sink:  # the newest log line counts
        assert sink.finished == {"s1", "s2"} and sink.failed == set()
        assert sink.pairs == 4


def test_refuses_what_it_cannot_resume_safely(tmp_path: Path) -> None:
    out = tmp_path / "r.jsonl"
    with ResumableJsonl.open(out) as sink:
        sink.write([_record("s1", 3)])
    with pytest.raises(InputError, match="already exists; pass --resume"):
        ResumableJsonl.open(out)
    # The output lost bytes the log says were written.
    out.write_bytes(out.read_bytes()[:-10])
    with pytest.raises(InputError, match="cannot resume safely"):
        ResumableJsonl.open(out, resume=True)
    # A broken line in the middle of the log (not a torn last line).
    log_path(out).write_text('{"scene": "s1", "end": 1}\nnot json\n{"scene": "s2", "end": 1}\n')
    with pytest.raises(InputError, match="line 2 is not a scene record"):
        ResumableJsonl.open(out, resume=True)
    # An output without its log.
    log_path(out).unlink()
    with pytest.raises(InputError, match="has no scene log"):
        ResumableJsonl.open(out, resume=True)
    with pytest.raises(InputError, match="does not exist"):
        ResumableJsonl.open(tmp_path / "nowhere" / "r.jsonl")


def test_resume_of_nothing_starts_afresh(tmp_path: Path) -> None:
    with ResumableJsonl.open(tmp_path / "r.jsonl", resume=True) as sink:
        assert sink.finished == set()


def test_parquet_has_the_same_rows_and_columns(tmp_path: Path) -> None:
    out = tmp_path / "r.jsonl"
    with ResumableJsonl.open(out) as sink:
        sink.write([_record("s1", 3), _record("s2", 2)])
    n = write_parquet(out, tmp_path / "r.parquet", rows=2)  # three row groups
    table = pq.read_table(tmp_path / "r.parquet")
    assert n == 5 and table.num_rows == 5
    assert table.column_names == [
        "scene", "argument", "referent", "primary", "secondary", "sentence", "degrees",
        "confidence", "ambiguous",
    ]  # fmt: skip
    rows = table.to_pylist()
    assert rows == [json.loads(x) for x in out.read_text().splitlines()]
    assert not (tmp_path / ".r.parquet.partial").exists()
