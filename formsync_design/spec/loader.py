"""Controller and Lyapunov-candidate specifications.

A specification is a Python module (the paper's is
``derivations/liang2016.py``) defining

``controller(view: ControllerView) -> sympy matrix expression``
    the body-frame torque ``u_i`` of spacecraft ``i`` as a 3x1 matrix
    expression in the *opaque* model matrices ``view.A``, ``view.B``,
    ``view.Q`` (3x3 ``MatrixSymbol``), the vectors ``view.qd`` (``q_i'``) and
    ``view.s`` (``sum_{j in G_i} (q_i - q_j)``), the scalar gains
    ``view.K_o``, ``view.K_q``, ``view.beta``, ``view.K_v`` (``K_vi``), and
    a switching term ``view.sw(arg)`` (sgn, or a smooth substitute chosen at
    simulation time) that returns a 3x1 symbol and records ``arg``;

``lyapunov(view: LyapunovView) -> sympy scalar``
    the term ``V_i`` of ``V = sum_i V_i`` in explicit 3-vectors
    ``view.qd`` (``q_i'``) and ``view.edges`` (``q_i - q_j`` for the ``m``
    neighbours ``j``), with ``view.s = sum(view.edges)`` and the gains.

Optional module attributes: ``NAME`` (short id), ``TITLE`` (one line).
"""

from __future__ import annotations

import importlib.util
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from types import ModuleType
from typing import Any

import sympy as sp

from formsync_design.errors import DerivationError, InputError

__all__ = [
    "ControllerView",
    "LyapunovView",
    "Spec",
    "load_spec",
    "default_spec_path",
    "gain_symbols",
]


def gain_symbols() -> tuple[sp.Symbol, sp.Symbol, sp.Symbol]:
    """The shared gain symbols ``(K_o, K_q, beta)`` (positive reals)."""
    return sp.symbols("K_o K_q beta", positive=True)


@dataclass
class ControllerView:
    """What ``controller(view)`` may use (see module docstring)."""

    A: sp.MatrixSymbol = field(default_factory=lambda: sp.MatrixSymbol("A", 3, 3))
    B: sp.MatrixSymbol = field(default_factory=lambda: sp.MatrixSymbol("B", 3, 3))
    Q: sp.MatrixSymbol = field(default_factory=lambda: sp.MatrixSymbol("Q", 3, 3))
    qd: sp.MatrixSymbol = field(default_factory=lambda: sp.MatrixSymbol("qd", 3, 1))
    s: sp.MatrixSymbol = field(default_factory=lambda: sp.MatrixSymbol("s", 3, 1))
    K_v: sp.Symbol = field(default_factory=lambda: sp.Symbol("K_v", positive=True))
    K_o: sp.Symbol = field(init=False)
    K_q: sp.Symbol = field(init=False)
    beta: sp.Symbol = field(init=False)
    switch_arguments: list[Any] = field(default_factory=list)

    def __post_init__(self) -> None:
        self.K_o, self.K_q, self.beta = gain_symbols()

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


@dataclass
class LyapunovView:
    """What ``lyapunov(view)`` may use for a spacecraft with ``m`` neighbours."""

    m: int
    qd: sp.Matrix = field(init=False)
    edges: list[sp.Matrix] = field(init=False)
    K_o: sp.Symbol = field(init=False)
    K_q: sp.Symbol = field(init=False)
    beta: sp.Symbol = field(init=False)

    def __post_init__(self) -> None:
        self.K_o, self.K_q, self.beta = gain_symbols()
        self.qd = sp.Matrix(sp.symbols("qd_x qd_y qd_z", real=True))
        self.edges = [
            sp.Matrix(sp.symbols(f"e{k}_x e{k}_y e{k}_z", real=True)) for k in range(1, self.m + 1)
        ]

    @property
    def s(self) -> sp.Matrix:
        """``sum_k edges[k]``."""
        out = sp.zeros(3, 1)
        for e in self.edges:
            out += e
        return out


@dataclass(frozen=True)
class Spec:
    """A loaded controller + Lyapunov-candidate specification."""

    name: str
    title: str
    path: str
    controller: Callable[[ControllerView], Any]
    lyapunov: Callable[[LyapunovView], Any]


def default_spec_path() -> Path:
    """Path of the paper's specification, ``derivations/liang2016.py``.

    Shipped inside the package as ``formsync_design.derivations``.
    """
    from formsync_design.resources import design_file

    return design_file("liang2016")


def load_spec(path: str | Path | None = None) -> Spec:
    """Load a specification module (default: the paper's).

    >>> spec = load_spec()
    >>> spec.name
    'liang2016'
    """
    p = Path(path) if path is not None else default_spec_path()
    if not p.is_file():
        raise InputError(f"expected a specification .py file, received {str(p)!r} (no such file)")
    mod_name = f"_formsync_spec_{abs(hash(str(p.resolve())))}"
    s = importlib.util.spec_from_file_location(mod_name, p)
    if s is None or s.loader is None:
        raise InputError(f"expected an importable Python file, received {str(p)!r}")
    mod: ModuleType = importlib.util.module_from_spec(s)
    try:
        s.loader.exec_module(mod)
    except Exception as e:  # a user's file: report, don't crash
        raise InputError(f"expected a loadable specification, {p} raised {type(e).__name__}: {e}") from None
    for fn in ("controller", "lyapunov"):
        if not callable(getattr(mod, fn, None)):
            raise InputError(f"expected a function {fn}(view) in {p}, received none")
    return Spec(
        name=str(getattr(mod, "NAME", p.stem)),
        title=str(getattr(mod, "TITLE", p.stem)),
        path=str(p),
        controller=mod.controller,
        lyapunov=mod.lyapunov,
    )
