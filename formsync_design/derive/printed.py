"""Loader of a paper's printed expressions (``derivations/<paper>_printed.py``)."""

from __future__ import annotations

import hashlib
import importlib.util
from functools import cache
from pathlib import Path
from types import ModuleType

from formsync_design.errors import InputError

__all__ = ["load_printed", "default_printed_path", "PrintedLike"]

#: What the comparison functions accept as printed expressions: ``None`` (the
#: paper's), a path to a printed-expressions file, or an already loaded module.
PrintedLike = str | Path | ModuleType | None


def default_printed_path() -> Path:
    """``derivations/liang2016_printed.py`` (shipped as ``formsync_design.derivations``)."""
    from formsync_design.resources import design_file

    return design_file("liang2016_printed")


def load_printed(printed: PrintedLike = None) -> ModuleType:
    """Import a module of printed expressions (``None``: the paper's; a path; a module).

    Loaded once per file content, so a changed file is loaded afresh.

    >>> load_printed().printed_theta(1, 1, 1, 1).shape
    (2, 2)
    """
    if isinstance(printed, ModuleType):
        return printed
    p = Path(printed) if printed is not None else default_printed_path()
    if not p.is_file():
        raise InputError(f"expected the printed-expressions file {p}, received no such file")
    try:
        data = p.read_bytes()
    except OSError as e:
        raise InputError(f"expected a readable printed-expressions file, received {p} ({e.strerror})") from None
    return _load(str(p), hashlib.sha256(data).hexdigest())


@cache
def _load(path: str, digest: str) -> ModuleType:
    s = importlib.util.spec_from_file_location(f"_formsync_printed_{digest[:16]}", path)
    if s is None or s.loader is None:
        raise InputError(f"expected an importable Python file, received {path}")
    mod = importlib.util.module_from_spec(s)
    try:
        s.loader.exec_module(mod)
    except Exception as e:  # a user's file: one line, no traceback
        raise InputError(
            f"expected a loadable printed-expressions file, {path} raised {type(e).__name__}: {e}"
        ) from None
    return mod
