"""Loader of a paper's printed expressions (``derivations/<paper>_printed.py``)."""

from __future__ import annotations

import importlib.util
from functools import cache
from pathlib import Path
from types import ModuleType

from formsync_design.errors import InputError

__all__ = ["load_printed", "default_printed_path"]


def default_printed_path() -> Path:
    """``derivations/liang2016_printed.py`` (shipped as ``formsync_design.derivations``)."""
    from formsync_design.resources import design_file

    return design_file("liang2016_printed")


@cache
def load_printed(path: str | None = None) -> ModuleType:
    """Import the module of printed expressions.

    >>> load_printed().printed_theta(1, 1, 1, 1).shape
    (2, 2)
    """
    p = Path(path) if path else default_printed_path()
    if not p.is_file():
        raise InputError(f"expected the printed-expressions file {p}, received no such file")
    s = importlib.util.spec_from_file_location("_formsync_printed", p)
    assert s is not None and s.loader is not None
    mod = importlib.util.module_from_spec(s)
    s.loader.exec_module(mod)
    return mod
