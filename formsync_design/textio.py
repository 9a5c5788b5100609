"""The one reader of user text files, and the one resolver of paths named inside them.

Every stage that reads a file the user names (graphs, TOML cases and campaigns,
specifications) goes through :func:`read_bytes` / :func:`read_text`, so every way a file can
be wrong is refused with the same one-line ``expected ..., received ...`` message (exit
status 2), raised as the caller's error class (e.g.
:class:`~formsync_design.errors.GraphError`):

* only a **regular file** is read: a folder, a FIFO (never opened: reading one blocks), a
  device (``/dev/zero``), a socket, a symlink loop and a dangling symlink each get their own
  refusal;
* a file larger than :data:`MAX_FILE_BYTES` (64 MiB) is refused from its ``os.stat`` size,
  **before** a byte is read; the read itself goes in 1 MiB chunks (Ctrl-C stops it between
  two chunks) and stops at the cap should the file grow meanwhile;
* a binary (NUL bytes) or non-UTF-8 file is refused by :func:`read_text`.

A path written *inside* a data file (a case's graph file, a campaign's ``dir:`` graph set)
is the data file's author's choice, not the user's: :func:`confined_path` resolves it against
the data file's folder and refuses an absolute path and anything that leaves that folder,
after resolving symlinks.  A path given on the command line is the user's and is not
confined.  Messages quote a value of a file cut by :func:`cut` (a few dozen characters), so
an error never echoes a file's content beyond the offending token.

>>> read_text("/no/such/file.txt", "edge-list file")
Traceback (most recent call last):
...
formsync_design.errors.InputError: expected an edge-list file, received '/no/such/file.txt' (no such file)
"""

from __future__ import annotations

import errno
import os
import re
import stat
from pathlib import Path

from formsync_design.errors import InputError

__all__ = ["MAX_FILE_BYTES", "read_bytes", "read_text", "check_regular", "confined_path", "cut",
           "check_ascii", "ascii_float"]

#: The largest file read (bytes): graph files, adjacency CSVs, case and campaign TOML files.
#: A 2000-spacecraft complete graph as an edge list is about 20 MB.
MAX_FILE_BYTES = 64 * 1024 * 1024

_CHUNK = 1024 * 1024


def cut(value: object, limit: int = 24) -> str:
    """``repr`` of a value read from a file, cut to about ``limit`` characters with an ellipsis.

    >>> cut("root:x:0:0:root:/root:/bin/bash")
    "'root:x:0:0:root:/root:…'"
    >>> cut("1 2")
    "'1 2'"
    """
    text = repr(value)
    if len(text) <= limit:
        return text
    return text[: limit - 1] + "…" + (text[0] if text[0] in "'\"" else "")


def check_ascii(text: str, where: str, error: type[InputError] = InputError) -> str:
    """``text`` when every character is ASCII; else a one-line refusal naming the first other
    character, its code point and its column (1-based) in ``where``.

    Numbers, metric ids and graph specs are ASCII: Python's ``int`` and ``float`` read the
    Bengali digit four (U+09EA, which looks like an 8) or a fullwidth digit as a number, so
    they are refused before a number is read.

    >>> check_ascii("ring:8", "the graph spec")
    'ring:8'
    >>> check_ascii("peak < \u09ea", "the predicate")
    Traceback (most recent call last):
    ...
    formsync_design.errors.InputError: expected ASCII characters in the predicate, received '৪' (U+09EA) at column 8
    """
    for col, ch in enumerate(text, start=1):
        if ord(ch) > 127:
            raise error(f"expected ASCII characters in {where}, received {ch!r} "
                        f"(U+{ord(ch):04X}) at column {col}")
    return text


_DECIMAL = re.compile(r"[0-9.eE+-]+")


def ascii_float(text: str) -> float | None:
    """The float a data file's field spells in ASCII (digits 0-9, ``.``, ``e``, a sign), or
    ``None``: ``float`` alone would read a Bengali or fullwidth digit, ``'1_0'``, ``'inf'``
    and ``'nan'`` (a finite check stays the caller's).

    >>> ascii_float("0.5"), ascii_float("1e-3"), ascii_float("\u09ea"), ascii_float("1e")
    (0.5, 0.001, None, None)
    """
    t = text.strip()
    if not _DECIMAL.fullmatch(t):
        return None
    try:
        return float(t)
    except ValueError:
        return None


def _an(what: str) -> str:
    return ("an " if what[:1].lower() in "aeiou" else "a ") + what


def _kind(mode: int) -> str | None:
    """Why a file of ``mode`` is not read (``None``: a regular file)."""
    if stat.S_ISREG(mode):
        return None
    if stat.S_ISDIR(mode):
        return "a folder, not a file"
    if stat.S_ISFIFO(mode):
        return "a FIFO (named pipe), not a regular file"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "a device, not a regular file"
    if stat.S_ISSOCK(mode):
        return "a socket, not a regular file"
    return "not a regular file"


def _stat(p: Path, what: str, error: type[InputError]) -> os.stat_result:
    """``os.stat(p)`` (symlinks followed), its failures as one-line refusals."""
    try:
        return os.stat(p)
    except OSError as e:
        if e.errno == errno.ELOOP:
            why = "a symlink loop"
        elif e.errno == errno.ENOENT and os.path.islink(p):
            why = "a dangling symlink"
        elif e.errno in (errno.ENOENT, errno.ENOTDIR):
            why = "no such file"
        else:
            raise error(f"expected a readable {what}, received {cut(str(p), 120)} "
                        f"({e.strerror or e})") from None
        raise error(f"expected {_an(what)}, received {cut(str(p), 120)} ({why})") from None


def check_regular(path: str | Path, what: str, error: type[InputError] = InputError) -> int:
    """The size of ``path`` when it is a regular file of at most :data:`MAX_FILE_BYTES`
    (symlinks followed), without opening it; else the one-line refusal :func:`read_bytes`
    gives (a folder, a FIFO, a device, a symlink loop, a dangling symlink, no such file,
    too large).

    >>> check_regular("/no/such.toml", "existing case TOML file")
    Traceback (most recent call last):
    ...
    formsync_design.errors.InputError: expected an existing case TOML file, received '/no/such.toml' (no such file)
    """
    p = Path(path)
    st = _stat(p, what, error)
    why = _kind(st.st_mode)
    if why is not None:
        raise error(f"expected {_an(what)}, received {cut(str(p), 120)} ({why})")
    if st.st_size > MAX_FILE_BYTES:
        raise error(f"expected {_an(what)} of at most {MAX_FILE_BYTES // 2**20} MiB, received "
                    f"{cut(str(p), 120)} ({st.st_size} bytes)")
    return st.st_size


def read_bytes(path: str | Path, what: str, error: type[InputError] = InputError) -> bytes:
    """The bytes of an existing, readable regular file of at most :data:`MAX_FILE_BYTES`.

    Parameters
    ----------
    path : str or Path
        The file.
    what : str
        What it should be, for the messages (``"edge-list file"``).
    error : type
        The :class:`~formsync_design.errors.InputError` subclass raised.

    Returns
    -------
    bytes

    Examples
    --------
    >>> read_bytes("/dev/zero", "graph file")
    Traceback (most recent call last):
    ...
    formsync_design.errors.InputError: expected a graph file, received '/dev/zero' (a device, not a regular file)
    """
    p = Path(path)
    check_regular(p, what, error)
    try:  # O_NONBLOCK: should the path have become a FIFO since the stat, open does not block
        fd = os.open(p, os.O_RDONLY | os.O_NONBLOCK | os.O_NOCTTY | getattr(os, "O_CLOEXEC", 0))
    except OSError as e:
        raise error(f"expected a readable {what}, received {cut(str(p), 120)} "
                    f"({e.strerror or e})") from None
    try:
        why = _kind(os.fstat(fd).st_mode)
        if why is not None:
            raise error(f"expected {_an(what)}, received {cut(str(p), 120)} ({why})")
        chunks: list[bytes] = []
        size = 0
        while True:
            chunk = os.read(fd, _CHUNK)
            if not chunk:
                break
            size += len(chunk)
            if size > MAX_FILE_BYTES:
                raise error(f"expected {_an(what)} of at most {MAX_FILE_BYTES // 2**20} MiB, "
                            f"received {cut(str(p), 120)} (more than that, and growing)")
            chunks.append(chunk)
        return b"".join(chunks)
    except OSError as e:
        raise error(f"expected a readable {what}, received {cut(str(p), 120)} "
                    f"({e.strerror or e})") from None
    finally:
        os.close(fd)


def read_text(path: str | Path, what: str, error: type[InputError] = InputError) -> str:
    """The UTF-8 text of ``path`` (:func:`read_bytes`); a binary (NUL bytes) or non-UTF-8
    file is refused.

    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "g.txt"
    >>> _ = p.write_bytes(b"1 2\\x00")
    >>> read_text(p, "edge-list file")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    formsync_design.errors.InputError: expected a text edge-list file, received '...g.txt' (a binary file)
    """
    raw = read_bytes(path, what, error)
    if b"\x00" in raw:
        raise error(f"expected a text {what}, received {cut(str(path), 120)} (a binary file)")
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as e:
        raise error(
            f"expected a UTF-8 {what}, received {cut(str(path), 120)} (byte {e.start} is not UTF-8)"
        ) from None


def confined_path(text: str, data_file: str | Path, key: str, *, base: str | Path | None = None,
                  error: type[InputError] = InputError) -> Path:
    """A path written in a data file, resolved inside that file's folder.

    Parameters
    ----------
    text : str
        The path as the data file writes it (relative to ``base``).
    data_file : str or Path
        The data file (named in messages).
    key : str
        The key that holds the path (``"formations[2].graph"``), named in messages.
    base : str or Path, optional
        The folder the path is relative to and must stay inside (default: the data file's).
    error : type
        The :class:`~formsync_design.errors.InputError` subclass raised.

    Returns
    -------
    Path
        ``base / text`` (not resolved: messages and ids keep the name as written); it
        resolves, after every symlink, inside ``base``.

    Raises
    ------
    InputError
        An absolute path, or one that leaves ``base`` (``..``, a symlink out of it).

    Examples
    --------
    >>> str(confined_path("edges.txt", "cases/c.toml", "case.graph"))
    'cases/edges.txt'
    >>> confined_path("../../../etc/passwd", "cases/c.toml", "case.graph")
    Traceback (most recent call last):
    ...
    formsync_design.errors.InputError: expected case.graph as a path inside the folder of cases/c.toml (a path outside it is given on the command line), received '../../../etc/passwd' (it leaves the folder)
    """
    folder = Path(base) if base is not None else Path(data_file).parent
    where = f"{key} as a path inside the folder of {data_file}"
    hint = "(a path outside it is given on the command line)"
    if "\x00" in text:
        raise error(f"expected {where}, received {cut(text)} (a NUL character)")
    if Path(text).is_absolute() or text.startswith("~"):
        raise error(f"expected {where} {hint}, received {cut(text)} (an absolute path)")
    p = folder / text
    root = folder.resolve()
    try:
        target = p.resolve()
    except (OSError, RuntimeError):  # a symlink loop: refused as such when read
        target = Path(os.path.abspath(p))
    if target != root and root not in target.parents:
        raise error(f"expected {where} {hint}, received {cut(text)} (it leaves the folder)")
    return p
