"""The one reader of user text files: one-line errors for every way a file can be wrong.

Every stage that reads a file the user names (graphs, TOML cases and campaigns,
specifications) goes through :func:`read_bytes` / :func:`read_text`, so a missing
file, a folder, an unreadable, binary or non-UTF-8 file is refused with the same
one-line ``expected ..., received ...`` message (exit status 2), raised as the
caller's error class (e.g. :class:`~formsync_design.errors.GraphError`).

>>> read_text("/no/such/file.txt", "edge-list file")
Traceback (most recent call last):
...
formsync_design.errors.InputError: expected a edge-list file, received '/no/such/file.txt' (no such file)
"""

from __future__ import annotations

from pathlib import Path

from formsync_design.errors import InputError

__all__ = ["read_bytes", "read_text"]


def read_bytes(path: str | Path, what: str, error: type[InputError] = InputError) -> bytes:
    """The bytes of an existing, readable regular file ``path`` (``what`` names it in messages)."""
    p = Path(path)
    if not p.exists():
        raise error(f"expected a {what}, received {str(p)!r} (no such file)")
    if not p.is_file():
        raise error(f"expected a {what}, received {str(p)!r} (not a file)")
    try:
        return p.read_bytes()
    except OSError as e:
        raise error(f"expected a readable {what}, received {str(p)!r} ({e.strerror or e})") from None


def read_text(path: str | Path, what: str, error: type[InputError] = InputError) -> str:
    """The UTF-8 text of ``path``; a binary (NUL bytes) or non-UTF-8 file is refused."""
    raw = read_bytes(path, what, error)
    if b"\x00" in raw:
        raise error(f"expected a text {what}, received {str(Path(path))!r} (a binary file)")
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as e:
        raise error(
            f"expected a UTF-8 {what}, received {str(Path(path))!r} (byte {e.start} is not UTF-8)"
        ) from None
