"""Power functions of finite-time sliding-mode designs, written for agent-design laws.

``fpow(x, eps)`` is the nonsingular fast-terminal power ``|x|^{1/2} sgn x`` outside
``|x| < eps`` and its C^1 quadratic continuation ``l1 x + l2 x|x|`` inside
(``l1 = 3/(2 sqrt eps)``, ``l2 = -1/(2 eps^{3/2})``): the derivative of ``|x|^{1/2}`` is
unbounded as ``x -> 0``, the continuation's is bounded by ``3/(2 sqrt eps)`` (Yu, Yu,
Shirinzadeh, Man, *Automatica* 41, 2005; the "second surface near small errors" of the SO(3)
design).  ``dfpow`` is its derivative.  Both use only ``Abs``, ``Min``, ``Max``, ``sign`` and
``sqrt`` (built unevaluated: SymPy's evaluation of ``Abs``/``Max`` on big arguments runs its
simplifiers), so the CasADi bridge translates them; the branches are checked exactly by
:func:`formsync_design.derive.so3_sliding.power_lemmas` and by finite differences in the tests.

>>> x, eps = sp.Rational(1, 4), sp.Rational(1, 100)
>>> fpow(x, eps).doit(), fpow(-x, eps).doit()
(1/2, -1/2)
>>> float(fpow(sp.Rational(1, 200), eps).doit()), float(dfpow(sp.Integer(0), eps).doit())
(0.0625, 15.0)
"""

from __future__ import annotations

from typing import Any

import sympy as sp

__all__ = ["fpow", "dfpow"]


def fpow(x: Any, eps: Any) -> Any:
    """``beta(x)`` (module docstring)."""
    r = sp.Abs(x, evaluate=False)
    lo = sp.Min(r, eps, evaluate=False)
    h = (sp.sqrt(sp.Max(r, eps, evaluate=False)) - sp.sqrt(eps) + sp.Rational(3, 2) / sp.sqrt(eps) * lo
         - lo**2 / (2 * eps ** sp.Rational(3, 2)))
    return sp.sign(x, evaluate=False) * h


def dfpow(x: Any, eps: Any) -> Any:
    """``beta'(x)`` (module docstring)."""
    r = sp.Abs(x, evaluate=False)
    lo = sp.Min(r, eps, evaluate=False)
    return (1 / (2 * sp.sqrt(sp.Max(r, eps, evaluate=False))) - 1 / (2 * sp.sqrt(eps))
            + sp.Rational(3, 2) / sp.sqrt(eps) - lo / eps ** sp.Rational(3, 2))
