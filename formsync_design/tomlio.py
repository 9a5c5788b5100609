"""The one TOML loader of the toolbox (case files, campaign files).

:func:`load_toml` turns every way a user's file can be unreadable into a
one-line :class:`~formsync_design.errors.InputError` ("expected X, received
Y"): a missing file, a folder, a binary or non-UTF-8 file, and a TOML syntax
error (with its line and column, as :mod:`tomllib` reports them).

>>> import tempfile, pathlib
>>> p = pathlib.Path(tempfile.mkdtemp()) / "x.toml"
>>> _ = p.write_text('[case]\\nname = "x"\\n', encoding="utf-8")
>>> load_toml(p)
{'case': {'name': 'x'}}
"""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Any

from formsync_design.errors import InputError
from formsync_design.textio import read_text

__all__ = ["load_toml", "parse_toml"]


def load_toml(path: str | Path, what: str = "TOML file") -> dict[str, Any]:
    """Read and parse a UTF-8 TOML file; one-line :class:`InputError` on any failure.

    Parameters
    ----------
    path : str or Path
        The file.
    what : str
        What the file should be, for the messages (``"case TOML file"``).

    Returns
    -------
    dict
        The parsed document.

    Examples
    --------
    >>> load_toml("/no/such/file.toml")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    formsync_design.errors.InputError: expected a TOML file, received '/no/such/file.toml' (no such file)
    """
    p = Path(path)
    text = read_text(p, what)
    return parse_toml(text, str(p))


def parse_toml(text: str, source: str) -> dict[str, Any]:
    """Parse TOML text read elsewhere (``source`` names it in messages); one-line errors.

    >>> parse_toml("a = 1", "inline")
    {'a': 1}
    >>> parse_toml("a = ", "inline")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    formsync_design.errors.InputError: expected valid TOML in inline, received a syntax error: ...
    """
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        msg = str(e).splitlines()[0] if str(e) else "syntax error"
        raise InputError(f"expected valid TOML in {source}, received a syntax error: {msg}") from None
