"""The flat parameter vectors of the compiled kernels: named slices in declaration order.

>>> lay = param_slices([("gains", 3), ("phi", 1)])
>>> lay["phi"], lay["_size"]
(slice(3, 4, None), slice(0, 4, None))
"""

from __future__ import annotations

from collections.abc import Iterable

__all__ = ["param_slices"]


def param_slices(sizes: Iterable[tuple[str, int]]) -> dict[str, slice]:
    """``name -> slice`` of consecutive blocks of the given sizes, plus ``"_size"`` (the whole)."""
    out, k = {}, 0
    for name, s in sizes:
        out[name] = slice(k, k + s)
        k += s
    out["_size"] = slice(0, k)
    return out
