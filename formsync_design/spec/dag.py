"""SymPy expressions as DAGs: traversals that visit each distinct sub-expression once.

A design law that composes its quantities deeply (an SO(3) command built from the
neighbours, its two time derivatives, the errors, the surface and the torque) is a small
DAG whose *tree* is enormous: SymPy's own recursive traversals (``free_symbols``,
``srepr``, ``replace``, ``xreplace``) walk the tree and take minutes where the DAG has a
few thousand nodes.  These helpers walk the DAG (a memo per call), so their cost is the
number of distinct sub-expressions.

>>> x = sp.Symbol("x")
>>> e = x
>>> for _ in range(60):      # a tree of 2**60 leaves, a DAG of ~120 nodes
...     e = e * e + e
>>> sorted(map(str, free_symbols(e))), dag_size(e) < 200
(['x'], True)
>>> y = sp.Symbol("y")
>>> free_symbols(xreplace(e, {x: y}))
{y}
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import sympy as sp

__all__ = ["dag_size", "free_symbols", "xreplace", "replace_function"]


def _nodes(expr: Any) -> list[Any]:
    roots = list(expr) if isinstance(expr, sp.MatrixBase) else [sp.sympify(expr)]
    seen: set[Any] = set()
    order: list[Any] = []
    stack = list(roots)
    while stack:
        e = stack.pop()
        if e in seen:
            continue
        seen.add(e)
        order.append(e)
        stack.extend(e.args)
    return order


def dag_size(expr: Any) -> int:
    """Distinct sub-expressions of ``expr`` (a scalar or a matrix)."""
    return len(_nodes(expr))


def free_symbols(expr: Any) -> set[Any]:
    """``expr.free_symbols`` in one pass over the DAG (symbols only; no bound variables
    occur in design laws)."""
    return {e for e in _nodes(expr) if e.is_Symbol}


def _rebuild(expr: Any, leaf: Callable[[Any], Any | None], memo: dict[Any, Any]) -> Any:
    """Post-order rebuild of the DAG: ``leaf(e)`` returns a replacement or ``None``."""
    stack: list[tuple[Any, bool]] = [(expr, False)]
    while stack:
        e, done = stack.pop()
        if e in memo:
            continue
        if not done:
            stack.append((e, True))
            stack.extend((a, False) for a in e.args if a not in memo)
            continue
        new = leaf(e)
        if new is None:
            args = tuple(memo[a] for a in e.args)
            new = e if all(a is b for a, b in zip(args, e.args)) else _make(e.func, args)
        memo[e] = new
    return memo[expr]


def _make(func: Any, args: tuple[Any, ...]) -> Any:
    # unevaluated: re-evaluating Abs/Max/sign on big arguments runs SymPy's simplifiers
    try:
        return func(*args, evaluate=False)
    except TypeError:
        return func(*args)


def xreplace(expr: Any, rule: Mapping[Any, Any]) -> Any:
    """``expr.xreplace(rule)`` with each distinct sub-expression rebuilt once (shared
    sub-expressions stay shared; rebuilt nodes are not re-evaluated)."""
    memo: dict[Any, Any] = {}
    if isinstance(expr, sp.MatrixBase):
        return expr.applyfunc(lambda e: _rebuild(sp.sympify(e), rule.get, memo))
    return _rebuild(sp.sympify(expr), rule.get, memo)


def replace_function(expr: Any, func: Any, new: Callable[[Any], Any]) -> Any:
    """Every application ``func(a)`` replaced by ``new(a')`` (``a'``: its argument with the
    replacement done), each distinct sub-expression rebuilt once.

    >>> replace_function(sp.sin(sp.sin(sp.Symbol("x"))), sp.sin, sp.cos)
    cos(cos(x))
    """
    memo: dict[Any, Any] = {}

    def leaf(e: Any) -> Any | None:
        if e.func is func:
            return new(*(memo[a] for a in e.args))
        return None

    if isinstance(expr, sp.MatrixBase):
        return expr.applyfunc(lambda e: _rebuild(sp.sympify(e), leaf, memo))
    return _rebuild(sp.sympify(expr), leaf, memo)
