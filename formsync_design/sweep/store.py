"""The results folder of a sweep: manifest check, fsync'ed journal, ``results.csv``."""

from __future__ import annotations

import contextlib
import errno
import json
import os
import signal
import threading
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from formsync_design.errors import InputError
from formsync_design.outdir import LOCK_NAME, ROOM_ERRNOS, write_bytes, write_error
from formsync_design.sweep.schema import COLUMNS

__all__ = ["OWNED", "atomic_write", "read_journal", "Journal", "read_results", "csv_bytes",
           "sort_key", "check_folder"]

OWNED = ("journal.jsonl", "results.csv", "summary.md", "fraction-vs-lambda-max.png",
          "fraction-vs-max-degree.png", "convergence-vs-lambda2.png")


def atomic_write(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` atomically (:func:`formsync_design.outdir.write_bytes`)."""
    write_bytes(path, data)


def read_journal(path: Path, *, repair: bool,
                 columns: Sequence[str] = COLUMNS) -> dict[str, dict[str, str]]:
    """Rows of the journal (each with exactly ``columns``, the campaign's); a torn last
    line is cut off (when ``repair``)."""
    rows: dict[str, dict[str, str]] = {}
    if not path.is_file():
        return rows
    data = path.read_bytes()
    good = data.rfind(b"\n") + 1
    lines = data[:good].split(b"\n")[:-1] if good else []
    kept = 0
    for k, line in enumerate(lines):
        try:
            row = json.loads(line)
            if not isinstance(row, dict) or set(row) != set(columns):
                raise ValueError("columns")
        except ValueError:
            if k == len(lines) - 1:  # torn tail with a newline inside a partial write: drop it
                break
            raise InputError(
                f"expected a journal of complete rows in {path}, received a malformed line {k + 1}"
            ) from None
        prev = rows.get(row["task"])
        if prev is not None and prev != row:
            raise InputError(f"expected identical rows for task {row['task']!r} in {path}, received two")
        rows[row["task"]] = row
        kept += len(line) + 1
    if repair and kept != len(data):
        with open(path, "r+b") as fh:
            fh.truncate(kept)
            fh.flush()
            os.fsync(fh.fileno())
    return rows


class Journal:
    """The append-only journal of finished rows (one JSON line each, flushed and fsync'ed).

    A Ctrl-C arriving while a line is written is held until the line is complete
    (SIGINT blocked around the write), so an interrupt never tears a row; a torn
    tail from a kill is cut off by :func:`read_journal`.  A line that cannot be
    written whole (disk full, file-size limit) is cut off again at once and raises
    the :class:`~formsync_design.errors.WriteError` naming the journal (exit 3): the
    journal keeps its complete rows, and ``--resume`` continues after them.

    >>> import tempfile
    >>> p = Path(tempfile.mkdtemp()) / "journal.jsonl"
    >>> j = Journal(p); j.append({"task": "a"}); j.close()
    >>> p.read_text()
    '{"task": "a"}\\n'
    """

    def __init__(self, path: Path) -> None:
        self.path = Path(path)
        self.fh = open(path, "ab", buffering=0)  # unbuffered: a failed write fails here

    def append(self, row: dict[str, str]) -> None:
        data = (json.dumps(row, sort_keys=True, ensure_ascii=True) + "\n").encode()
        blocked = threading.current_thread() is threading.main_thread()
        if blocked:
            signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
        start = os.fstat(self.fh.fileno()).st_size
        try:
            view = memoryview(data)
            while view:  # a raw write may be short: write the rest, or fail with its errno
                n = self.fh.write(view)
                if not n:
                    raise OSError(errno.EIO, "the write made no progress")
                view = view[n:]
            os.fsync(self.fh.fileno())
        except OSError as e:
            with contextlib.suppress(OSError):  # cut the partial line: the rows stay whole
                os.ftruncate(self.fh.fileno(), start)
            if e.errno in ROOM_ERRNOS:
                raise write_error(self.path, e, "the sweep journal") from None
            raise
        finally:
            if blocked:  # a pending SIGINT is delivered here, after the complete line
                signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})

    def close(self) -> None:
        self.fh.close()


def read_results(path: str | Path, columns: Sequence[str] | None = None) -> list[dict[str, str]]:
    """Rows of a ``results.csv`` (strings, in file order), checking the header: the
    campaign's ``columns`` when given, else any sweep header (its columns are named after
    the design's gains, :class:`~formsync_design.sweep.schema.SweepSchema`).

    >>> import tempfile
    >>> p = Path(tempfile.mkdtemp()) / "results.csv"
    >>> _ = p.write_bytes(csv_bytes([{c: "1" for c in COLUMNS}]))
    >>> len(read_results(p)), read_results(p, COLUMNS)[0]["task"]
    (1, '1')
    """
    import csv

    p = Path(path)
    with open(p, newline="", encoding="utf-8") as fh:
        rd = csv.reader(fh)
        header: Any = next(rd, None)
        ok = header is not None and (tuple(header) == tuple(columns) if columns is not None
                                     else header[:3] == list(COLUMNS[:3]))
        if not ok:
            raise InputError(f"expected the sweep columns in {p}, received header {header!r}")
        rows = []
        for k, r in enumerate(rd, start=2):
            if len(r) != len(header):
                raise InputError(f"expected {len(header)} cells per row in {p}, received {len(r)} "
                                 f"at line {k}")
            rows.append(dict(zip(header, r)))
        return rows


def csv_bytes(rows: Sequence[dict[str, str]], columns: Sequence[str] = COLUMNS) -> bytes:
    """``results.csv`` of ``rows`` (the campaign's ``columns``, in order)."""
    import csv
    import io

    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(columns)
    for r in rows:
        w.writerow([r[c] for c in columns])
    return buf.getvalue().encode("utf-8")


def sort_key(r: dict[str, str]) -> tuple[int, int]:
    return int(r["graph_index"]), int(r["box_index"])


def _check_writable(out: Path) -> None:
    """Refuse, before any computation, a folder that cannot be created or written."""
    anc = out.absolute()
    while not anc.exists() and anc != anc.parent:
        anc = anc.parent
    if not anc.is_dir():
        raise InputError(f"expected a results folder, received {str(out)!r} under the file {str(anc)!r}")
    if not os.access(anc, os.W_OK | os.X_OK):
        raise InputError(f"expected a writable results folder, received {str(out)!r} ({str(anc)!r} is "
                         "not writable)")


def check_folder(out: Path, sha: str, *, resume: bool, overwrite: bool) -> str:
    """'new', 'resume' or 'overwrite' (raises InputError when the folder is not ours)."""
    man = out / "manifest.json"
    if out.exists() and not out.is_dir():
        raise InputError(f"expected a results folder, received the file {str(out)!r}")
    _check_writable(out)
    if not man.is_file():
        if out.is_dir() and any(p.name != LOCK_NAME for p in out.iterdir()):
            raise InputError(
                f"expected an empty or new results folder, received {str(out)!r} holding files but no "
                "manifest.json (nothing overwritten)"
            )
        return "new"
    try:
        old = json.loads(man.read_text(encoding="utf-8"))
        old_sha = old["sha256"]
    except (ValueError, KeyError, TypeError):
        raise InputError(f"expected a sweep manifest in {man}, received an unreadable file (nothing overwritten)") from None
    if old_sha != sha:
        raise InputError(
            f"expected results of this campaign (sha256 {sha[:12]}) in {str(out)!r}, received a folder "
            f"written by a different campaign definition (sha256 {str(old_sha)[:12]}); choose another "
            "--out (nothing overwritten)"
        )
    if resume:
        return "resume"
    if overwrite:
        return "overwrite"
    raise InputError(
        f"expected a new results folder, received {str(out)!r} already holding this campaign; pass "
        "--resume to finish it or --overwrite to recompute it (nothing overwritten)"
    )

