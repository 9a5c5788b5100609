"""One writer per output folder, and result files written atomically.

* :func:`acquire` (or the context manager :func:`locked`) takes an exclusive
  lock on an output folder before its first write: the folder is created, a
  lock file ``.formsync.lock`` in it is opened and locked with ``flock``, and
  the holder's pid, host and command are written into it.  A second writer
  (another process) is refused with :class:`FolderBusyError` (an
  :class:`~formsync_design.errors.InputError`, exit 2), one line naming the
  folder and the holder.  The kernel drops the lock when its process dies, so
  a lock file left by a killed run is never stale: the next writer takes it
  over.  Locks are reentrant within a process (the sweep engine and the
  command line may both hold the folder); the last release removes the lock
  file and any folder the lock created that is still empty (a refused run
  leaves nothing behind).
* :func:`claim` holds a folder until the end of the :func:`session` (the
  command line wraps every subcommand in one), so commands claim their
  ``--out`` after checking it and release it however they end.
* :func:`atomic_path` yields a temporary path in the target's folder and
  renames it over the target only when the writer finished (fsync'ed first):
  an interrupted or failing write leaves the old file or the new one, never a
  partial file.  :func:`write_bytes`, :func:`write_text`, :func:`save_figure`
  and :func:`save_npz` are the common cases.
* A write that fails for want of room (disk full ``ENOSPC``, the file-size limit
  ``EFBIG``, a quota ``EDQUOT``, an I/O error ``EIO``) raises
  :class:`~formsync_design.errors.WriteError` (exit status 3) naming the file and
  the errno (:func:`write_error`); the temporary is removed, so the target keeps
  its previous content.

>>> import tempfile
>>> d = Path(tempfile.mkdtemp()) / "out"
>>> with locked(d) as lk:
...     _ = write_text(d / "a.txt", "new\\n")
...     sorted(p.name for p in d.iterdir())
['.formsync.lock', 'a.txt']
>>> sorted(p.name for p in d.iterdir())
['a.txt']
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import json
import os
import socket
import sys
import threading
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

from formsync_design.errors import InputError, WriteError

__all__ = [
    "LOCK_NAME",
    "FolderBusyError",
    "FolderLock",
    "acquire",
    "locked",
    "claim",
    "session",
    "atomic_path",
    "write_bytes",
    "write_text",
    "save_figure",
    "save_npz",
    "ROOM_ERRNOS",
    "write_error",
]

LOCK_NAME = ".formsync.lock"
"""The lock file inside a locked output folder (removed when the folder is released)."""


ROOM_ERRNOS = frozenset({errno.ENOSPC, errno.EFBIG, errno.EDQUOT, errno.EIO})
"""The errnos of a write that failed for want of room (not the user's input: exit 3)."""


def write_error(path: str | Path, e: OSError, what: str = "") -> WriteError:
    """The :class:`~formsync_design.errors.WriteError` of a failed write of ``path``.

    The message names the file (``what`` describes it), the errno and what to do.

    >>> import errno
    >>> str(write_error("out/r.json", OSError(errno.ENOSPC, "No space left on device")))
    'writing out/r.json failed: No space left on device (ENOSPC); free some disk space or write elsewhere'
    """
    code = e.errno if e.errno is not None else errno.EIO
    name = errno.errorcode.get(code, str(code))
    said = e.strerror or os.strerror(code)
    if code == errno.EFBIG:
        import resource

        soft = resource.getrlimit(resource.RLIMIT_FSIZE)[0]
        limit = "unlimited" if soft == resource.RLIM_INFINITY else f"{soft} bytes"
        hint = f"the file-size limit (ulimit -f) is {limit}: raise it or write smaller outputs"
    elif code == errno.EDQUOT:
        hint = "the disk quota is used up: free some space or write elsewhere"
    elif code == errno.EIO:
        hint = "the device reported an I/O error: check it or write elsewhere"
    else:
        hint = "free some disk space or write elsewhere"
    label = f"{what} {path}" if what else str(path)
    return WriteError(code, f"writing {label} failed: {said} ({name}); {hint}", str(path))


class FolderBusyError(InputError):
    """Another process is writing to the output folder."""


_GUARD = threading.RLock()
_HELD: dict[str, FolderLock] = {}
_SESSIONS: list[list[FolderLock]] = []


def _holder_text(lock_file: Path) -> str:
    try:
        info = json.loads(lock_file.read_text(encoding="utf-8", errors="replace"))
        cmd = " ".join(str(info.get("command", "")).split())[:160]
        return f"pid {int(info['pid'])} on host {info.get('host', '?')}" + (f" ({cmd})" if cmd else "")
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return "another process (it has not written its pid yet)"


class FolderLock:
    """An exclusive, reentrant (within this process) lock on one output folder.

    Create it with :func:`acquire`; :meth:`release` once per acquisition.
    """

    def __init__(self, folder: Path, key: str, fd: int, created: list[Path]) -> None:
        self.folder = folder
        self.key = key
        self._fd = fd
        self._created = created
        self._count = 1

    @property
    def lock_file(self) -> Path:
        return self.folder / LOCK_NAME

    def release(self) -> None:
        """Drop one acquisition; the last removes the lock file and empty created folders."""
        with _GUARD:
            self._count -= 1
            if self._count > 0:
                return
            _HELD.pop(self.key, None)
            with contextlib.suppress(OSError):
                self.lock_file.unlink()  # still holding the flock: nobody else can own this inode
            with contextlib.suppress(OSError):
                os.close(self._fd)
            for d in reversed(self._created):  # deepest first; a folder with files stays
                with contextlib.suppress(OSError):
                    d.rmdir()


def _make_folder(folder: Path) -> list[Path]:
    """Create ``folder`` (and parents); return the folders created, outermost first."""
    for a in (folder, *folder.parents):
        if a.is_symlink() and not a.exists():  # dangling, or a loop: not a file, not a folder
            try:
                target = os.readlink(a)
            except OSError:
                target = "?"
            raise InputError(f"expected an output folder, received {str(folder)!r}"
                             + ("" if a == folder else f" under {str(a)!r}")
                             + f", a symbolic link to {target[:80]!r}, which does not resolve "
                             "(a missing target or a loop)")
    if folder.exists() and not folder.is_dir():
        raise InputError(f"expected an output folder, received the file {str(folder)!r}")
    missing = [a for a in (folder, *folder.parents) if not a.exists()]
    missing.reverse()
    created = []
    for d in missing:
        try:
            d.mkdir()
            created.append(d)
        except FileExistsError:
            if not d.is_dir():
                raise InputError(f"expected an output folder, received {str(folder)!r} under the "
                                 f"file {str(d)!r}") from None
        except NotADirectoryError:
            raise InputError(f"expected an output folder, received {str(folder)!r} under a "
                             "file") from None
    return created


def acquire(folder: str | Path, command: str | None = None) -> FolderLock:
    """Lock ``folder`` (created if missing) for this process; see the module docstring.

    Parameters
    ----------
    folder : the output folder
    command : what the holder is doing, shown to a refused writer (default: ``sys.argv``)

    Raises
    ------
    FolderBusyError
        Another process holds the folder.
    InputError
        ``folder`` is a file or lies under one.
    """
    p = Path(folder)
    with _GUARD:
        created = _make_folder(p)
        key = os.path.realpath(p)
        held = _HELD.get(key)
        if held is not None:
            held._count += 1
            return held
        lock_file = p / LOCK_NAME
        try:
            while True:
                fd = os.open(lock_file, os.O_RDWR | os.O_CREAT, 0o644)
                try:
                    fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                except OSError:
                    os.close(fd)
                    raise FolderBusyError(
                        f"expected --out {str(p)!r} free of other writers, received a folder in use by "
                        f"{_holder_text(lock_file)}; wait for it to finish or choose another --out"
                    ) from None
                try:
                    same = os.stat(lock_file).st_ino == os.fstat(fd).st_ino
                except FileNotFoundError:
                    same = False
                if same:
                    break
                os.close(fd)  # the previous holder removed the file while we opened it: retry
        except BaseException:
            for d in reversed(created):
                with contextlib.suppress(OSError):
                    d.rmdir()
            raise
        cmd = command if command is not None else " ".join(["formsync", *sys.argv[1:]])
        info = {"pid": os.getpid(), "host": socket.gethostname(), "command": cmd}
        lk = FolderLock(p, key, fd, created)
        try:
            os.ftruncate(fd, 0)
            os.write(fd, (json.dumps(info) + "\n").encode())
        except OSError as e:  # no room even for the lock file: release it, report the write
            lk.release()
            if e.errno in ROOM_ERRNOS:
                raise write_error(lock_file, e, "the lock file") from None
            raise
        _HELD[key] = lk
        return lk


@contextlib.contextmanager
def locked(folder: str | Path, command: str | None = None) -> Iterator[FolderLock]:
    """``with locked(out):`` holds the folder's lock for the block (:func:`acquire`)."""
    lk = acquire(folder, command)
    try:
        yield lk
    finally:
        lk.release()


def claim(folder: str | Path, command: str | None = None) -> FolderLock:
    """Lock ``folder`` until the innermost :func:`session` ends (until the process ends when
    no session is open)."""
    lk = acquire(folder, command)
    with _GUARD:
        if _SESSIONS:
            _SESSIONS[-1].append(lk)
    return lk


@contextlib.contextmanager
def session() -> Iterator[None]:
    """Release every folder :func:`claim` locked in this block when it ends."""
    with _GUARD:
        _SESSIONS.append([])
    try:
        yield
    finally:
        with _GUARD:
            held = _SESSIONS.pop()
        for lk in reversed(held):
            lk.release()


@contextlib.contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """A temporary path beside ``path``; renamed over it when the block ends normally.

    The temporary is fsync'ed before the rename and removed if the block raises,
    so ``path`` holds its old content or the complete new one.  A write that fails
    for want of room (:data:`ROOM_ERRNOS`) is re-raised as the
    :class:`~formsync_design.errors.WriteError` of ``path`` (:func:`write_error`).

    >>> import tempfile
    >>> p = Path(tempfile.mkdtemp()) / "r.txt"
    >>> _ = p.write_text("old")
    >>> try:
    ...     with atomic_path(p) as tmp:
    ...         _ = tmp.write_text("half")
    ...         raise RuntimeError("crash")
    ... except RuntimeError:
    ...     pass
    >>> p.read_text(), sorted(x.name for x in p.parent.iterdir())
    ('old', ['r.txt'])
    """
    target = Path(path)
    tmp = target.with_name(f".{target.name}.{os.getpid()}.{threading.get_ident()}.tmp")
    try:
        yield tmp
        fd = os.open(tmp, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)
        os.replace(tmp, target)
    except OSError as e:
        if e.errno in ROOM_ERRNOS and not isinstance(e, WriteError):
            raise write_error(target, e) from None
        raise
    finally:
        with contextlib.suppress(OSError):
            tmp.unlink()


def _write_with(path: str | Path, writer: Callable[[Any], None]) -> Path:
    target = Path(path)
    with atomic_path(target) as tmp, open(tmp, "wb") as fh:
        writer(fh)
    return target


def write_bytes(path: str | Path, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically; return ``path``."""
    return _write_with(path, lambda fh: fh.write(data))


def write_text(path: str | Path, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` atomically; return ``path``."""
    return write_bytes(path, text.encode("utf-8"))


def save_figure(fig: Any, path: str | Path, **savefig_kw: Any) -> Path:
    """``fig.savefig`` into ``path`` atomically (the format from the suffix); return ``path``."""
    target = Path(path)
    fmt = target.suffix.lstrip(".").lower() or None
    return _write_with(target, lambda fh: fig.savefig(fh, format=fmt, **savefig_kw))


def save_npz(path: str | Path, **arrays: Any) -> Path:
    """``numpy.savez_compressed`` into ``path`` atomically; return ``path``."""
    import numpy as np

    return _write_with(path, lambda fh: np.savez_compressed(fh, **arrays))
