"""The output of ``annotate``: JSON Lines that survive a killed run, and their Parquet copy.

Two files, written only by the client (``docs/annotate.md``):

- ``OUT`` (e.g. ``relations.jsonl``): one line per ordered pair, exactly the fields of
  ``interfaces.md``; the lines of one scene are contiguous.
- the **scene log** ``OUT`` with ``.scenes.jsonl`` for its suffix (``relations.scenes.jsonl``):
  one line per finished scene, ``{"scene", "pairs", "objects", "skipped", "seconds",
  "error", "end"}``; ``error`` is null for a described scene and the one-line reason for a
  scene that failed (it then has no pair lines); ``end`` is the size of ``OUT`` in bytes once
  the scene's lines were written.

Each finished batch is one ``write`` appended to ``OUT`` and ``fsync``-ed, then its scenes'
log lines, also one fsync-ed append. The log line is the scene's completion marker: a scene is
finished exactly when its log line is complete. :meth:`ResumableJsonl.open` with
``resume=True`` drops a truncated last log line, cuts ``OUT`` back to the last logged ``end``
(the lines of a batch whose log line never got written: they will be written again) and
returns the finished scenes, so a resumed run loses no finished scene and writes none twice.

>>> import tempfile
>>> from pathlib import Path
>>> with tempfile.TemporaryDirectory() as tmp:
...     out = Path(tmp) / "relations.jsonl"
...     with ResumableJsonl.open(out) as sink:
...         sink.write([SceneRecord("s1", ('{"scene": "s1"}',), objects=2)])
...     with ResumableJsonl.open(out, resume=True) as sink:
...         sorted(sink.finished), out.read_text()
(['s1'], '{"scene": "s1"}\\n')
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from os import PathLike
from pathlib import Path
from types import TracebackType
from typing import Any

from scenespeak.errors import InputError

__all__ = ["PARQUET_FIELDS", "ResumableJsonl", "SceneRecord", "log_path", "write_parquet"]


@dataclass(frozen=True)
class SceneRecord:
    """What a worker sends back for one scene.

    Attributes
    ----------
    scene : str
        The scene's name (its folder's name).
    lines : tuple of str
        One JSON text per ordered pair (no newline); empty for a failed scene.
    objects, skipped : int
        Objects described, and objects seen but not described.
    seconds : float
        Time the worker spent on the scene.
    error : str or None
        Why the scene could not be described (one line), or None.
    """

    scene: str
    lines: tuple[str, ...] = ()
    objects: int = 0
    skipped: int = 0
    seconds: float = 0.0
    error: str | None = None


def log_path(out: str | PathLike[str]) -> Path:
    """The scene log beside ``out``: ``relations.jsonl`` → ``relations.scenes.jsonl``."""
    p = Path(out)
    return p.with_name(f"{p.stem if p.suffix else p.name}.scenes.jsonl")


def _append(fd: int, data: bytes) -> None:
    """One append of ``data`` (looping over short writes), then fsync."""
    view = memoryview(data)
    while view:
        n = os.write(fd, view)
        view = view[n:]
    os.fsync(fd)


def _read_log(path: Path) -> tuple[list[dict[str, Any]], int]:
    """The log's complete records and the byte length they take (a torn last line excluded)."""
    data = path.read_bytes()
    cut = data.rfind(b"\n") + 1  # everything after the last newline is a torn write
    records: list[dict[str, Any]] = []
    for number, raw in enumerate(data[:cut].splitlines(), 1):
        try:
            record = json.loads(raw)
            str(record["scene"])
            int(record["end"])
        except (ValueError, KeyError, TypeError) as exc:
            raise InputError(
                path, f"line {number} is not a scene record ({exc}); cannot resume from it"
            ) from None
        records.append(record)
    return records, cut


class ResumableJsonl:
    """The pair lines and the scene log of one run (module docstring); use :meth:`open`.

    Attributes
    ----------
    path, log : Path
        The output and its scene log.
    finished : set of str
        Scenes already finished (described or failed) when the file was opened.
    failed : set of str
        Those of ``finished`` that failed.
    pairs : int
        Pair lines in the output (before this run plus written by it).
    """

    def __init__(self, path: Path, log: Path, finished: dict[str, bool], pairs: int) -> None:
        self.path = path
        self.log = log
        self.finished = {name for name in finished}
        self.failed = {name for name, ok in finished.items() if not ok}
        self.pairs = pairs
        flags = os.O_WRONLY | os.O_APPEND | os.O_CREAT
        #: Made by this run (not resumed): removed again if the run fails before a scene.
        self._new = not path.exists() and not log.exists()
        self._out = os.open(path, flags, 0o644)
        self._log = os.open(log, flags, 0o644)
        self._wrote = False

    @classmethod
    def open(
        cls, path: str | PathLike[str], *, resume: bool = False, retry_failed: bool = False
    ) -> ResumableJsonl:
        """Start a new output, or continue the one a previous run left (``resume``).

        Parameters
        ----------
        path : path
            The JSON Lines file of pairs.
        resume : bool
            Continue: keep what the log says is finished, cut off anything after it.
        retry_failed : bool
            With ``resume``: scenes that failed are not counted as finished (they run again;
            the newest log line of a scene is the one that counts).

        Raises
        ------
        InputError
            Without ``resume``, the output or its log exists already; with it, the output
            exists but its log does not, a log line in the middle is broken, or the output is
            shorter than its log says (it was changed after the run).
        """
        out = Path(path)
        log = log_path(out)
        if not out.parent.is_dir():
            raise InputError(out, f"the folder {str(out.parent)!r} does not exist")
        if not resume:
            cls.refuse_existing(out)
            return cls(out, log, {}, 0)
        if not log.exists():
            if out.exists() and out.stat().st_size > 0:
                raise InputError(
                    out,
                    f"has no scene log {log.name}, so which scenes are complete is unknown; "
                    "write to a new --out instead of --resume",
                )
            return cls(out, log, {}, 0)
        return cls._recover(out, log, retry_failed)

    @staticmethod
    def refuse_existing(path: str | PathLike[str]) -> None:
        """Raise :class:`InputError` if ``path`` or its scene log exists (a new run would mix
        with it); callers check this before any long preparation."""
        out = Path(path)
        for p in (out, log_path(out)):
            if p.exists():
                raise InputError(
                    p, "already exists; pass --resume to continue that run, or remove it"
                )

    @classmethod
    def _recover(cls, out: Path, log: Path, retry_failed: bool) -> ResumableJsonl:
        records, log_bytes = _read_log(log)
        end = int(records[-1]["end"]) if records else 0
        size = out.stat().st_size if out.exists() else 0
        if size < end:
            raise InputError(
                out,
                f"is {size} bytes but its scene log {log.name} says {end} were written: it was "
                "changed after the run; cannot resume safely",
            )
        with log.open("r+b") as fh:
            fh.truncate(log_bytes)
            os.fsync(fh.fileno())
        if out.exists():
            with out.open("r+b") as fh:
                fh.truncate(end)
                os.fsync(fh.fileno())
        finished: dict[str, bool] = {}
        pairs = 0
        for r in records:
            finished[str(r["scene"])] = r.get("error") is None
        for r in records:
            pairs += int(r.get("pairs", 0))
        if retry_failed:
            finished = {name: ok for name, ok in finished.items() if ok}
        return cls(out, log, finished, pairs)

    def write(self, records: Sequence[SceneRecord]) -> None:
        """Append finished scenes: their pair lines (one fsync-ed write), then their log lines."""
        self._wrote = True
        lines = [line for r in records if r.error is None for line in r.lines]
        if lines:
            _append(self._out, ("\n".join(lines) + "\n").encode("utf-8"))
        end = os.fstat(self._out).st_size
        log = []
        for r in records:
            entry = {
                "scene": r.scene,
                "pairs": len(r.lines) if r.error is None else 0,
                "objects": r.objects,
                "skipped": r.skipped,
                "seconds": round(r.seconds, 3),
                "error": r.error,
                "end": end,
            }
            log.append(json.dumps(entry, ensure_ascii=False))
            self.finished.add(r.scene)
            if r.error is None:
                self.failed.discard(r.scene)
                self.pairs += len(r.lines)
            else:
                self.failed.add(r.scene)
        if log:
            _append(self._log, ("\n".join(log) + "\n").encode("utf-8"))

    def close(self) -> None:
        """Close both files (idempotent)."""
        for name in ("_out", "_log"):
            fd = getattr(self, name)
            if fd >= 0:
                os.close(fd)
                setattr(self, name, -1)

    def __enter__(self) -> ResumableJsonl:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()
        if exc_type is not None and self._new and not self._wrote:
            # refused before any scene (no scheduler, a bad database): leave nothing behind,
            # so that the corrected command does not meet "already exists; pass --resume"
            for p in (self.path, self.log):
                if p.exists() and p.stat().st_size == 0:
                    p.unlink()


# --------------------------------------------------------------------------------------------
# Parquet

#: The columns of the Parquet file, in order: the JSON line's fields.
PARQUET_FIELDS = (
    "scene",
    "argument",
    "referent",
    "primary",
    "secondary",
    "sentence",
    "degrees",
    "confidence",
    "ambiguous",
)


def _schema() -> Any:
    import pyarrow as pa

    degree = pa.float64()
    return pa.schema(
        [
            ("scene", pa.string()),
            ("argument", pa.string()),
            ("referent", pa.string()),
            ("primary", pa.string()),
            ("secondary", pa.string()),
            ("sentence", pa.string()),
            (
                "degrees",
                pa.struct(
                    [("left", degree), ("right", degree), ("front", degree), ("behind", degree)]
                ),
            ),
            ("confidence", pa.float64()),
            ("ambiguous", pa.bool_()),
        ]
    )


def _chunks(path: Path, rows: int) -> Iterator[list[dict[str, Any]]]:
    chunk: list[dict[str, Any]] = []
    with path.open("r", encoding="utf-8") as fh:
        for number, line in enumerate(fh, 1):
            try:
                chunk.append(json.loads(line))
            except ValueError as exc:
                raise InputError(path, f"line {number} is not JSON ({exc})") from None
            if len(chunk) >= rows:
                yield chunk
                chunk = []
    if chunk:
        yield chunk


def write_parquet(
    jsonl: str | PathLike[str], parquet: str | PathLike[str], *, rows: int = 65536
) -> int:
    """Copy the pair lines of ``jsonl`` into a Parquet file with the same columns.

    Streams: ``rows`` lines at a time, one row group each, so memory does not grow with the
    file. Written to a temporary file beside ``parquet`` and renamed at the end (never half a
    file). ``degrees`` is a struct column ``{left, right, front, behind}``. Returns the rows.

    Raises
    ------
    InputError
        A line that is not JSON or lacks a field; ``parquet``'s folder missing.
    """
    import pyarrow as pa
    import pyarrow.parquet as pq

    from scenespeak.safetext import check_output

    src, dst = Path(jsonl), check_output(parquet, what="Parquet file")  # never over a device
    tmp = dst.with_name(f".{dst.name}.partial")
    schema = _schema()
    total = 0
    try:
        with pq.ParquetWriter(tmp, schema) as writer:
            for chunk in _chunks(src, rows):
                try:
                    columns = {f: [r[f] for r in chunk] for f in PARQUET_FIELDS}
                except KeyError as exc:
                    raise InputError(src, f"a line lacks the field {exc}") from None
                writer.write_table(pa.Table.from_pydict(columns, schema=schema))
                total += len(chunk)
        os.replace(tmp, dst)
    finally:
        tmp.unlink(missing_ok=True)
    return total
