"""A leader's (reference) body rate ``w_ref(t)``: three expressions in ``t`` read from data
without evaluating text, and their CasADi function ``t -> (w_ref, w_ref')`` for the agent
kernels (:mod:`formsync_design.sim.agent_kernel`), the sampled path and the case readers."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import casadi as ca
import sympy as sp

from formsync_design.errors import InputError
from formsync_design.sim.bridge import sympy_to_casadi

__all__ = ["REFERENCE_FUNCTIONS", "reference_rate_expressions", "reference_rate_function"]


def reference_rate_expressions(rate: Sequence[Any], key: str = "reference.rate",
                               path: str | None = None) -> tuple[Any, ...]:
    """The three SymPy expressions in ``t`` (real) of a reference rate: SymPy expressions
    are kept, text and numbers are read by :func:`formsync_design.safeexpr.parse_formula`
    (never evaluated); ``key`` and ``path`` (the file) name the field in messages.

    >>> reference_rate_expressions(["0.1*sin(t)", 0, "0.02"])
    (0.1*sin(t), 0, 0.0200000000000000)
    """
    from formsync_design.safeexpr import parse_formula

    ts = sp.Symbol("t", real=True)
    where_file = f" in {path}" if path else ""
    if isinstance(rate, (str, bytes)) or not isinstance(rate, Sequence) or len(rate) != 3:
        raise InputError(f"expected {key} = three expressions in t{where_file}, received "
                         f"{rate!r:.80}")
    exprs = []
    for k, r in enumerate(rate, start=1):
        if isinstance(r, sp.Basic):
            e = r
        else:
            e = parse_formula(r, f"{key}[{k}]{where_file}", variables={"t": ts},
                              functions=REFERENCE_FUNCTIONS, constants=("pi",))
        if e.free_symbols - {ts}:
            raise InputError(f"expected {key}[{k}]{where_file} in t only, received the symbols "
                             f"{sorted(str(s) for s in e.free_symbols - {ts})}")
        exprs.append(e)
    return tuple(exprs)


#: What a reference rate may call: the functions the kernels compile (:mod:`sim.bridge`),
#: whose derivatives they compile too.
REFERENCE_FUNCTIONS = ("exp", "log", "sin", "cos", "tan", "tanh", "sqrt", "abs", "Abs",
                       "atan", "asin", "acos")


def reference_rate_function(rate: Sequence[Any]) -> ca.Function:
    """``t -> (w_ref(t), w_ref'(t))`` from three SymPy expressions (or formulas) in ``t``
    (:func:`reference_rate_expressions`).

    >>> f = reference_rate_function(["0.1*sin(t)", 0, "0.02"])
    >>> [round(float(x), 6) for x in ca.vertcat(*f(0.0)).full().ravel()]
    [0.0, 0.0, 0.02, 0.1, 0.0, 0.0]
    """
    ts = sp.Symbol("t", real=True)
    exprs = reference_rate_expressions(rate)
    t = ca.SX.sym("t")
    w = ca.vertcat(*[sympy_to_casadi(e, {ts: t}) for e in exprs])
    wd = ca.vertcat(*[sympy_to_casadi(sp.diff(e, ts), {ts: t}) for e in exprs])
    return ca.Function("ref_rate", [t], [w, wd], ["t"], ["w", "wdot"])
