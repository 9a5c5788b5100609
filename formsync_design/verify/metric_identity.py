r"""When two registrations of a metric name are one metric (:func:`same_metric`): a user's
copy of a design file registers its metrics again from another path, which is accepted only
when the function, everything of the file it calls and the declarations are the same; where
a metric function is defined (:func:`origin`).  Used by
:func:`~formsync_design.verify.metrics.register_metric`.

>>> src = "def helper(x): return x + {}\ndef m(ctx): return helper(ctx)\n"
>>> a, b, c = {}, {}, {}
>>> exec(src.format(1), a); exec(src.format(1), b); exec(src.format(2), c)
>>> _same_function(a["m"], b["m"], set()), _same_function(a["m"], c["m"], set())
(True, False)
"""

from __future__ import annotations

from collections.abc import Callable
from types import ModuleType
from typing import Any

__all__ = ["same_metric", "origin"]


def same_metric(a: Any, b: Any) -> bool:
    """Whether two registrations are one metric: a copy of a design file (a user's folder)
    registering the same function text with the same declarations.  Code objects compare
    by their bytecode, constants and names, not by the file they came from, and so do the
    functions of the design file they call (a copy whose helper differs is another metric:
    refused, never silently run as the first); the first registration is kept."""
    return ((a.unit, a.evidence, a.doc, a.value, a.args, a.needs_families)
            == (b.unit, b.evidence, b.doc, b.value, b.args, b.needs_families)
            and (a.applies is None) == (b.applies is None)
            and _same_function(a.fn, b.fn, set())
            and (a.applies is None or _same_function(a.applies, b.applies, set())))


def _same_function(f: Any, g: Any, seen: set[tuple[int, int]]) -> bool:
    """Same code, and every global name the code reads bound to the same value: a function
    of the same text (compared the same way, recursively), a module, or an equal value.
    Functions of this package compare by identity (a copy imports the same ones)."""
    if f is g:
        return True
    code_f, code_g = getattr(f, "__code__", None), getattr(g, "__code__", None)
    if code_f is None or code_f != code_g:
        return False
    if (id(f), id(g)) in seen:
        return True
    seen.add((id(f), id(g)))
    cells = [(c.cell_contents, d.cell_contents)
             for c, d in zip(f.__closure__ or (), g.__closure__ or ())]
    names = sorted(_global_names(code_f))
    glob_f, glob_g = getattr(f, "__globals__", {}), getattr(g, "__globals__", {})
    pairs = cells + [(glob_f.get(n, _MISSING), glob_g.get(n, _MISSING)) for n in names]
    return all(_same_value(x, y, seen) for x, y in pairs)


_MISSING = object()


def _global_names(code: Any) -> set[str]:
    """The names a code object (and the code of its nested functions) may read as globals."""
    out = set(code.co_names)
    for c in code.co_consts:
        if hasattr(c, "co_names"):
            out |= _global_names(c)
    return out


def _same_value(x: Any, y: Any, seen: set[tuple[int, int]]) -> bool:
    if x is y:
        return True
    if hasattr(x, "__code__"):
        return _same_function(x, y, seen)
    if isinstance(x, ModuleType) or isinstance(y, ModuleType):
        return False  # two different module objects under one name
    try:
        return bool(type(x) is type(y) and x == y)
    except Exception:  # noqa: BLE001 - an uncomparable value: not the same
        return False


def origin(fn: Callable[..., Any]) -> tuple[str, str]:
    """Where a metric function is defined (a reloaded file registers it again: accepted)."""
    code = getattr(fn, "__code__", None)
    return (getattr(fn, "__qualname__", repr(fn)),
            f"{getattr(code, 'co_filename', '?')}:{getattr(fn, '__qualname__', '?')}")
