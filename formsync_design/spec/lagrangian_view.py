"""The views a Lagrangian design's functions are called on: :class:`ControllerView` (what
``controller(view)`` may use: the model matrices, the neighbours' sums, the gains) and
:class:`LyapunovView` (what ``lyapunov(view)`` may use).  The loader
(:mod:`formsync_design.spec.loader`) calls them at load to validate a
design; the derivation calls them to build the closed loop and the conditions.

>>> v = ControllerView()
>>> sorted(v.gains)
['K_o', 'K_q', 'K_v', 'beta']
"""

from __future__ import annotations

from typing import Any

import sympy as sp

from formsync_design.errors import DerivationError
from formsync_design.spec.declarations import CLASSIC, Declarations, GainKind, GainRole

__all__ = ["ControllerView", "LyapunovView"]


class ControllerView:
    """What ``controller(view)`` may use (see module docstring).

    The opaque model matrices ``A``, ``B``, ``Q`` (3x3), the vectors ``qd``
    and ``s`` (3x1), the switching term ``sw(arg)`` and one attribute per
    declared controller or switching gain (a positive symbol; a diagonal gain
    is a 3x3 matrix symbol).  Multipliers belong to the Lyapunov candidate only.

    >>> v = ControllerView()
    >>> sorted(v.gains)
    ['K_o', 'K_q', 'K_v', 'beta']
    """

    def __init__(self, decl: Declarations = CLASSIC) -> None:
        self.decl = decl
        self.A = sp.MatrixSymbol("A", 3, 3)
        self.B = sp.MatrixSymbol("B", 3, 3)
        self.Q = sp.MatrixSymbol("Q", 3, 3)
        self.qd = sp.MatrixSymbol("qd", 3, 1)
        self.s = sp.MatrixSymbol("s", 3, 1)
        self.switch_arguments: list[Any] = []
        self.gains: dict[str, Any] = {}
        for g in decl.gains:
            if g.role == GainRole.MULTIPLIER:
                continue
            val = g.matrix if g.kind == GainKind.DIAG else g.symbol
            self.gains[g.name] = val
            setattr(self, g.name, val)

    @property
    def sigma(self) -> sp.MatrixSymbol:
        """The 3x1 symbol standing for ``sw(arg)``."""
        return sp.MatrixSymbol("sigma", 3, 1)

    def sw(self, arg: Any) -> sp.MatrixSymbol:
        """Switching term ``sgn(arg)`` (componentwise); records ``arg``."""
        if getattr(arg, "shape", None) != (3, 1):
            raise DerivationError(
                f"expected sw() of a 3x1 vector expression, received shape {getattr(arg, 'shape', None)}"
            )
        if self.switch_arguments and self.switch_arguments[0] != arg:
            raise DerivationError("expected a single switching term per controller, received two")
        self.switch_arguments.append(arg)
        return self.sigma

    def attributes(self) -> str:
        """The names this view provides, for messages."""
        return ", ".join(["A", "B", "Q", "qd", "s", *self.gains, "sw"])

    def symbols(self) -> set[Any]:
        """Every symbol a controller expression may contain."""
        return {self.A, self.B, self.Q, self.qd, self.s, self.sigma, *self.gains.values()}


class LyapunovView:
    """What ``lyapunov(view)`` may use for a spacecraft with ``m`` neighbours:
    explicit 3-vectors ``qd`` and ``edges`` (``s`` their sum) and one positive
    symbol per declared controller gain and multiplier (a diagonal gain is its
    per-axis entry).

    >>> lv = LyapunovView(2)
    >>> len(lv.edges), sorted(lv.gains)
    (2, ['K_o', 'K_q', 'beta'])
    """

    def __init__(self, m: int, decl: Declarations = CLASSIC) -> None:
        self.m = m
        self.decl = decl
        self.qd = sp.Matrix(sp.symbols("qd_x qd_y qd_z", real=True))
        self.edges = [
            sp.Matrix(sp.symbols(f"e{k}_x e{k}_y e{k}_z", real=True)) for k in range(1, m + 1)
        ]
        self.gains: dict[str, sp.Symbol] = {}
        for g in decl.gains:
            if g.role == GainRole.SWITCHING:
                continue
            self.gains[g.name] = g.symbol
            setattr(self, g.name, g.symbol)

    @property
    def s(self) -> sp.Matrix:
        """``sum_k edges[k]``."""
        out = sp.zeros(3, 1)
        for e in self.edges:
            out += e
        return out

    def attributes(self) -> str:
        return ", ".join(["m", "qd", "edges", "s", *self.gains])

    def symbols(self) -> set[Any]:
        """Every symbol ``V_i`` may contain."""
        return set(self.qd) | {x for e in self.edges for x in e} | set(self.gains.values())
