"""The exact linear part of a design law at an equilibrium, with what it covers.

:func:`linear_part` walks a SymPy expression as a DAG (each distinct sub-expression once,
so a deeply composed law costs its DAG size, not its tree size) and returns, for every
node, its value at the equilibrium ``v0`` and either its exact linear part in the
perturbation directions (the node is differentiable at the equilibrium) or a lower bound
of the order ``a`` of ``f - v0 = O(|delta|^a)`` when it is not.

The rules are those of a first-order expansion, sound for the non-smooth primitives of
sliding-mode and finite-time laws:

* ``f g``: ``f0 g0 + f0 (g - g0) + g0 (f - f0) + (f - f0)(g - g0)``; the last term is
  ``O(|delta|^(a + b))`` and drops out of the linear part when ``a + b > 1`` (so
  ``|x|^(1/2) * sat(x/phi)`` has linear part 0: it is ``O(|x|^(3/2))``);
* ``f**r`` at ``f0 = 0``: order ``r a`` (``r > 0``); a negative power at 0 is singular;
* ``|x|``, ``sign(x)`` at ``x0 = 0`` with a differentiable ``x``: on each side of the
  hyperplane ``lin(x) = 0`` they are ``s x`` and ``s`` with ``s = +-1``; a symbol ``s``
  per argument is carried (``s**2 = 1``) and the function is differentiable at the
  equilibrium exactly when its value and its linear part do not depend on any ``s`` (the
  pieces then share one tangent; every law here is Lipschitz, so the thin cones around
  the hyperplanes add ``o(|delta|)``) - this is how ``sign(x) (l1 |x| + l2 |x|^2)``
  linearises to ``l1 x``;
* ``Min``/``Max``/``Piecewise``: the branch active at the equilibrium (strict inequalities
  decided exactly; a tie of different tangents is a kink);
* the switching function ``sgn`` as it is realised: ``sign`` (piecewise constant),
  ``sat(x/phi)`` or ``tanh(x/phi)`` (the boundary layer ``phi``, a positive symbol);
* any other SymPy function by the chain rule (its derivative finite at ``v0``).

A value that must be decided (zero or not, a sign, a branch) is decided exactly by SymPy
under the symbols' assumptions (gains and weights are positive); one it cannot decide
raises :class:`~formsync_design.errors.DerivationError` naming the sub-expression.

>>> x, y = sp.symbols("x y", real=True)
>>> lp = LinearPart({x: Chart(0, {0: 1}), y: Chart(0, {1: 1})})
>>> r = lp.result(sp.sign(x) * (3 * sp.Abs(x) - sp.Abs(x)**2) + y**2 + sp.sqrt(sp.Abs(y)) * x**2)
>>> r.differentiable, r.v0, dict(r.lin)
(True, 0, {0: 3})
>>> lp.result(sp.sqrt(sp.Abs(x))).differentiable, lp.result(sp.sqrt(sp.Abs(x))).order
(False, 0.5)
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any

import sympy as sp

from formsync_design.errors import DerivationError

__all__ = ["Chart", "Local", "LinearPart", "SWITCH_REALISATIONS", "as_expr"]

#: How the switching function ``sgn`` of a design is realised (the simulator's ``switch``).
SWITCH_REALISATIONS: tuple[str, ...] = ("sgn", "sat", "tanh")


@dataclass(frozen=True)
class Chart:
    """A moving symbol at the equilibrium: its value ``v0`` and its linear part ``lin``
    (direction index -> coefficient) in the chart's coordinates."""

    v0: Any
    lin: Mapping[int, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class Local:
    """A node at the equilibrium.

    ``v0``: the exact value; ``lin``: the linear part (direction -> coefficient) when the
    node is differentiable there, else ``None``; ``order``: a lower bound of the order of
    ``f - v0`` (``inf`` for a constant, 1 for a differentiable node, ``a`` in ``[0, 1]``
    otherwise: 0 is a jump); ``why``: for a node that is not differentiable, the
    sub-expression responsible.
    """

    v0: Any
    lin: Mapping[int, Any] | None
    order: float
    why: str = ""

    @property
    def differentiable(self) -> bool:
        return self.lin is not None

    @property
    def constant(self) -> bool:
        return self.order == math.inf


def as_expr(x: Any) -> Any:
    """A SymPy object, an int, a Fraction or a float as a SymPy number (never text: no
    parsing, so nothing from a data file is evaluated).

    >>> as_expr(3), as_expr(Fraction(1, 2)), as_expr(sp.Symbol("x")) + 1
    (3, 1/2, x + 1)
    """
    if isinstance(x, sp.Basic):
        return x
    if isinstance(x, bool):
        raise DerivationError(f"expected a number or a SymPy expression, received {x!r}")
    if isinstance(x, int):
        return sp.Integer(x)
    if isinstance(x, Fraction):
        return sp.Rational(x.numerator, x.denominator)
    if isinstance(x, float):
        return sp.Float(x)
    raise DerivationError(f"expected a number or a SymPy expression, received {type(x).__name__}")


def _short(e: Any, width: int = 100) -> str:
    """A short text of ``e`` that never walks a large tree (deeply composed laws)."""
    from formsync_design.spec.dag import dag_size

    if dag_size(e) <= 40:
        return str(e)[:width]
    return f"{type(e).__name__}(...) of {dag_size(e)} distinct sub-expressions"


def _const(v: Any) -> Local:
    return Local(as_expr(v), {}, math.inf)


def _rough(v0: Any, order: float, why: str) -> Local:
    return Local(v0, None, order, why)


def _scale(lin: Mapping[int, Any], c: Any) -> dict[int, Any]:
    if c == 0:
        return {}
    return {k: c * v for k, v in lin.items()}


def _add_into(acc: dict[int, Any], lin: Mapping[int, Any]) -> None:
    for k, v in lin.items():
        acc[k] = acc[k] + v if k in acc else v


class LinearPart:
    """The linear part of expressions at one equilibrium (module docstring).

    Parameters
    ----------
    charts : the moving symbols (state, neighbours' states) with their :class:`Chart`
    values : other symbols with a value at the equilibrium (the reference at rest, ``t``)
    switch : how ``sgn`` is realised (:data:`SWITCH_REALISATIONS`); ``phi`` the boundary
        layer symbol or number for ``sat``/``tanh``
    """

    def __init__(self, charts: Mapping[Any, Chart], values: Mapping[Any, Any] | None = None, *,
                 switch: str = "sgn", phi: Any = None) -> None:
        if switch not in SWITCH_REALISATIONS:
            raise DerivationError(f"expected a switch in {list(SWITCH_REALISATIONS)}, "
                                  f"received {switch!r}")
        if switch != "sgn" and phi is None:
            raise DerivationError(f"expected a boundary layer phi for switch {switch!r}")
        self.charts = dict(charts)
        self.values = {k: as_expr(v) for k, v in (values or {}).items()}
        self.switch = switch
        self.phi = phi
        self.memo: dict[Any, Local] = {}
        self.signs: dict[Any, sp.Symbol] = {}
        self._zero: dict[Any, bool] = {}

    # ------------------------------------------------------------------ decisions

    def is_zero(self, e: Any) -> bool:
        """Whether ``e`` is zero at the equilibrium (undecidable: ``DerivationError``)."""
        z = self.maybe_zero(e)
        if z is None:
            raise DerivationError(f"expected a value that is decidably zero or not at the "
                                  f"equilibrium, received {_short(as_expr(e), 200)}")
        return z

    def maybe_zero(self, e: Any) -> bool | None:
        """Whether ``e`` is zero at the equilibrium, ``None`` when SymPy cannot decide."""
        try:
            return self._decide_zero(e)
        except DerivationError:
            return None

    def _decide_zero(self, e: Any) -> bool:
        e = as_expr(e)
        if e.is_Number:
            return bool(e == 0)
        if e in self._zero:
            return self._zero[e]
        side = e.free_symbols & set(self.signs.values())
        if side:
            import itertools

            vals = [self.is_zero(e.xreplace(dict(zip(side, combo))))
                    for combo in itertools.product((1, -1), repeat=len(side))]
            if all(vals) or not any(vals):
                self._zero[e] = vals[0]
                return vals[0]
            raise DerivationError(f"expected a value that is zero on both sides of a switching "
                                  f"surface or on neither, received {_short(e, 200)}")
        z = e.is_zero
        if z is None:
            red = self.reduce(sp.expand(e))
            z = True if red == 0 else red.is_zero
        if z is None:
            z = True if sp.simplify(e) == 0 else None
        if z is None:
            raise DerivationError(f"expected a value that is decidably zero or not at the "
                                  f"equilibrium, received {_short(e, 200)}")
        self._zero[e] = bool(z)
        return bool(z)

    def sign(self, e: Any, what: Any) -> int:
        e = as_expr(e)
        if self.is_zero(e):
            return 0
        for cand in (e, sp.simplify(e)):
            if cand.is_positive:
                return 1
            if cand.is_negative:
                return -1
        what = what() if callable(what) else what
        raise DerivationError(f"expected the sign of {what} at the equilibrium to be decidable, "
                              f"received {_short(e, 200)}")

    def compare(self, a: Any, b: Any, what: Any) -> int:
        return self.sign(as_expr(a) - as_expr(b), what)

    def reduce(self, e: Any) -> Any:
        """``e`` with every ``s**k`` of a side symbol reduced by ``s**2 = 1``."""
        if not self.signs:
            return e
        ss = set(self.signs.values())
        return as_expr(e).replace(
            lambda x: x.is_Pow and x.base in ss and x.exp.is_Integer,
            lambda x: x.base ** (int(x.exp) % 2))

    def side(self, arg: Any) -> sp.Symbol:
        if arg not in self.signs:
            self.signs[arg] = sp.Symbol(f"s_side{len(self.signs) + 1}")
        return self.signs[arg]

    # ------------------------------------------------------------------ the walk

    def local(self, expr: Any) -> Local:
        """The :class:`Local` of ``expr`` (post-order over the DAG, memoised)."""
        expr = as_expr(expr)
        stack: list[tuple[Any, bool]] = [(expr, False)]
        while stack:
            e, done = stack.pop()
            if e in self.memo:
                continue
            if not done and e.args and e not in self.charts:
                stack.append((e, True))
                stack.extend((a, False) for a in e.args if a not in self.memo)
                continue
            self.memo[e] = self._node(e)
        return self.memo[expr]

    def result(self, expr: Any) -> Local:
        """:meth:`local` with the side symbols resolved: a node whose value or linear part
        depends on a side ``s`` is not differentiable (a kink or a jump)."""
        r = self.local(expr)
        ss = set(self.signs.values())
        v0 = self.reduce(sp.expand(r.v0)) if ss else r.v0
        if ss and (as_expr(v0).free_symbols & ss):
            return _rough(v0, 0.0, f"a jump at the equilibrium in {_short(expr)}")
        if r.lin is None:
            return Local(v0, None, r.order, r.why)
        lin: dict[int, Any] = {}
        for k, c in r.lin.items():
            c2 = self.reduce(sp.expand(c)) if ss else sp.expand(c)
            if ss and (c2.free_symbols & ss):
                return _rough(v0, 1.0, f"a kink at the equilibrium in {_short(expr)}")
            if c2 != 0:
                lin[k] = c2
        return Local(v0, lin, r.order)

    def _node(self, e: Any) -> Local:
        if e in self.charts:
            c = self.charts[e]
            return Local(as_expr(c.v0), dict(c.lin), 1.0)
        if e.is_Symbol:
            return _const(self.values.get(e, e))
        if e.is_Number or e.is_NumberSymbol or not e.args:
            return _const(e)
        args = [self.memo[a] for a in e.args]
        if all(a.constant for a in args):
            try:
                return _const(e.func(*[a.v0 for a in args]))
            except (TypeError, ValueError) as exc:
                raise DerivationError(f"expected {_short(e)} to be defined at the "
                                      f"equilibrium, received {exc}") from None
        if e.is_Add:
            return self._add(args)
        if e.is_Mul:
            acc = args[0]
            for a in args[1:]:
                acc = self._mul(acc, a)
            return acc
        if e.is_Pow:
            return self._pow(args[0], args[1], e)
        name = type(e).__name__
        if isinstance(e, sp.Abs):
            return self._abs(args[0], e.args[0])
        if isinstance(e, sp.sign) or (name == "sgn" and self.switch == "sgn"):
            return self._sign(args[0], e.args[0])
        if name == "sgn":
            return self._boundary_layer(args[0], e)
        if isinstance(e, (sp.Min, sp.Max)):
            return self._minmax(args, e)
        if isinstance(e, sp.Piecewise):
            return self._piecewise(e)
        return self._function(e, args)

    def _add(self, args: list[Local]) -> Local:
        v0 = sp.Add(*[a.v0 for a in args])
        rough = [a for a in args if a.lin is None]
        if rough:
            worst = min(rough, key=lambda a: a.order)
            return _rough(v0, worst.order, worst.why)
        lin: dict[int, Any] = {}
        for a in args:
            _add_into(lin, a.lin or {})
        return Local(v0, lin, 1.0)

    def _mul(self, f: Local, g: Local) -> Local:
        v0 = f.v0 * g.v0
        if f.lin is not None and g.lin is not None:
            lin = _scale(g.lin, f.v0)
            _add_into(lin, _scale(f.lin, g.v0))
            return Local(v0, lin, math.inf if f.constant and g.constant else 1.0)
        lin = {}
        orders: list[tuple[float, str]] = []
        for a, b in ((f, g), (g, f)):   # the term a0 (b - b0)
            if b.constant or self.maybe_zero(a.v0):   # undecidable: kept (conservative)
                continue
            if b.lin is None:
                orders.append((b.order, b.why))
            else:
                _add_into(lin, _scale(b.lin, a.v0))
        cross = f.order + g.order
        if cross <= 1:
            orders.append((cross, f.why or g.why))
        if orders:
            o, why = min(orders)
            return _rough(v0, o, why)
        return Local(v0, lin, 1.0)

    def _pow(self, b: Local, x: Local, e: Any) -> Local:
        if not x.constant:
            raise DerivationError(f"expected a constant exponent in {_short(e)}")
        r = x.v0
        if not self.is_zero(b.v0):
            if not r.is_integer and self.sign(b.v0, lambda: f"the base of {_short(e, 80)}") < 0:
                raise DerivationError(f"expected a positive base for the fractional power "
                                      f"{_short(e)} at the equilibrium, received a negative one")
            if b.lin is None:
                return _rough(b.v0**r, b.order, b.why)
            return Local(b.v0**r, _scale(b.lin, r * b.v0 ** (r - 1)), 1.0)
        if not (r.is_number and r.is_positive):
            raise DerivationError(f"expected {_short(e)} to be defined at the equilibrium, "
                                  "received a non-positive power of 0")
        if r == 1:
            return b
        o = float(r) * b.order
        if o > 1:
            return Local(sp.Integer(0), {}, 1.0)
        return _rough(sp.Integer(0), o, b.why or f"{_short(e)} (a power {r} at 0)")

    def _abs(self, a: Local, arg: Any) -> Local:
        if not self.is_zero(a.v0):
            s = self.sign(a.v0, lambda: f"|{_short(arg, 80)}|")
            return Local(s * a.v0, None if a.lin is None else _scale(a.lin, s), a.order, a.why)
        if a.lin is None:
            return _rough(sp.Integer(0), a.order, a.why)
        s = self.side(arg)
        return Local(sp.Integer(0), _scale(a.lin, s), 1.0)

    def _sign(self, a: Local, arg: Any) -> Local:
        if not self.is_zero(a.v0):
            return _const(self.sign(a.v0, lambda: f"sign({_short(arg, 80)})"))
        if a.lin is None or not a.lin:
            return _rough(sp.Integer(0), 0.0, f"sign({_short(arg, 80)}) at 0")
        return Local(self.side(arg), {}, math.inf)

    def _boundary_layer(self, a: Local, e: Any) -> Local:
        phi = self.phi
        if self.switch == "tanh":
            v0 = sp.tanh(a.v0 / phi)
            if a.lin is None:
                return _rough(v0, a.order, a.why)
            return Local(v0, _scale(a.lin, (1 - v0**2) / phi), 1.0)
        inside = self.compare(sp.Abs(a.v0), phi, lambda: f"|{_short(e, 80)}| against phi")
        if inside > 0:
            return _const(self.sign(a.v0, lambda: _short(e, 80)))
        if inside == 0:
            return _rough(a.v0 / phi, 1.0, f"{_short(e, 80)} on the boundary layer's edge")
        if a.lin is None:
            return _rough(a.v0 / phi, a.order, a.why)
        return Local(a.v0 / phi, _scale(a.lin, 1 / phi), 1.0)

    def _minmax(self, args: list[Local], e: Any) -> Local:
        best = [args[0]]
        for a in args[1:]:
            c = self.compare(a.v0, best[0].v0, lambda: _short(e, 80))
            c = c if isinstance(e, sp.Max) else -c
            if c > 0:
                best = [a]
            elif c == 0:
                best.append(a)
        if len(best) == 1:
            return best[0]
        first = best[0]
        if all(b.lin is not None for b in best) and all(
                all(self.is_zero(as_expr(b.lin.get(k, 0)) - first.lin.get(k, 0))  # type: ignore[union-attr]
                    for k in set(b.lin) | set(first.lin or {})) for b in best):  # type: ignore[arg-type]
            return first
        return _rough(first.v0, min(1.0, *(b.order for b in best)),
                      f"{_short(e, 80)}: a tie of different branches at the equilibrium")

    def _piecewise(self, e: Any) -> Local:
        for val, cond in e.args:
            c = self._condition(cond, e)
            if c:
                return self.local(val)
        raise DerivationError(f"expected a branch of {_short(e)} at the equilibrium")

    def _condition(self, cond: Any, e: Any) -> bool:
        if cond is sp.true:
            return True
        if cond is sp.false:
            return False
        if isinstance(cond, (sp.And, sp.Or)):
            parts = [self._condition(c, e) for c in cond.args]
            return all(parts) if isinstance(cond, sp.And) else any(parts)
        if isinstance(cond, sp.Not):
            return not self._condition(cond.args[0], e)
        if isinstance(cond, sp.core.relational.Relational):
            lhs, rhs = self.local(cond.lhs), self.local(cond.rhs)
            c = self.compare(lhs.v0, rhs.v0, lambda: f"the condition {cond} of {_short(e, 80)}")
            if c == 0 and not (lhs.constant and rhs.constant):
                raise DerivationError(f"expected the equilibrium strictly inside a branch of "
                                      f"{_short(e)}, received it on the boundary {cond}")
            op = cond.rel_op
            return {"<": c < 0, "<=": c <= 0, ">": c > 0, ">=": c >= 0, "==": c == 0,
                    "!=": c != 0}[op]
        raise DerivationError(f"expected a relational condition in {_short(e)}, "
                              f"received {cond}")

    def _function(self, e: Any, args: list[Local]) -> Local:
        v0 = e.func(*[a.v0 for a in args])
        rough = [a for a in args if a.lin is None and not a.constant]
        if rough:
            worst = min(rough, key=lambda a: a.order)
            return _rough(v0, worst.order, worst.why)
        lin: dict[int, Any] = {}
        point = {}
        dummies = [sp.Dummy(f"a{k}") for k in range(len(args))]
        for k, a in enumerate(args):
            point[dummies[k]] = a.v0
        generic = e.func(*dummies)
        for k, a in enumerate(args):
            if a.constant:
                continue
            try:
                d = generic.diff(dummies[k]).xreplace(point)
            except (TypeError, ValueError, NotImplementedError):
                d = sp.nan
            if d.has(sp.zoo, sp.oo, -sp.oo, sp.nan) or d.has(sp.Derivative, sp.Subs):
                raise DerivationError(f"expected {type(e).__name__} to be differentiable at the "
                                      f"equilibrium, received {_short(e)}")
            _add_into(lin, _scale(a.lin or {}, d))
        return Local(v0, lin, 1.0)

