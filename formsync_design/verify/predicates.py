"""Claims as predicates over metric ids: a tiny grammar parsed here, never evaluated as code.

A claim of an ``engine`` case (:mod:`formsync_design.verify.enginecase`) states the paper's
words and a *predicate* over the ids of the case's ``[[metrics]]``::

    predicate := or
    or        := and ("or" and)*
    and       := not ("and" not)*
    not       := "not" not | compare
    compare   := sum [OP sum]              OP: <  <=  >  >=  ==  !=   (not chained)
    sum       := product (("+" | "-") product)*
    product   := unary (("*" | "/") unary)*
    unary     := "-" unary | atom
    atom      := NUMBER | "text" | METRIC_ID | "(" or ")"

Precedence is Python's: arithmetic binds tighter than a comparison, a comparison tighter
than ``not``, ``not`` tighter than ``and``, ``and`` tighter than ``or``.  A metric id is a
letter followed by letters, digits and ``_``; a text is in double quotes (no escapes); a
predicate is ASCII (a Bengali or fullwidth digit, which Python's ``float`` reads as a digit,
is refused with its column).  The
parser (:func:`parse_predicate`) reads tokens by a fixed table and builds a tree of frozen
nodes; nothing is handed to ``eval``, ``compile`` or SymPy, and anything else (``_x``,
``f(x)``, ``a.b``, ``[``, ``'``, ``**``, a chained ``a < b < c``) is refused with one line
naming the column.  Types are checked against the metrics' kinds when the case is read:
arithmetic and ordering take numbers, ``==``/``!=`` compare two numbers or two texts, and
``and``/``or``/``not`` take truth values (a bare metric is no predicate).  Every comparison
reads at least one metric: ``1 == 1`` would be a verdict typed in, not computed, and is
refused.

**Semantics** (:func:`evaluate`).  A number metric is an *interval* ``[lo, hi]`` of what the
quantity can be: a measured or exact value is ``[v, v]``; a certified lower bound ``b`` is
``[b, inf]`` (a certified decay rate; a convergence time not reached by the horizon ``tf``
is ``[tf, inf]``); a metric without a value (a certificate undecided, a run that diverged)
is *unknown*.  Arithmetic is interval arithmetic (``0 * inf = 0``; a divisor interval that
contains 0 gives ``[-inf, inf]``).  A comparison **holds** when it holds for every value of
the intervals, **fails** when it fails for every value, else it is **undecided**; with an
unknown operand it is undecided.  ``and``/``or``/``not`` are Kleene's three-valued logic: a
false conjunct decides ``and`` even when another is undecided, a true disjunct decides
``or``.  The metrics that *decide* a verdict are returned with it: all the metrics of a
comparison; for ``and`` the failing conjuncts (fails), every conjunct (holds) or the
undecided ones; dually for ``or``.  The report's evidence of a verdict is the evidence of
those metrics (a proof only when every one is a certificate).

>>> kinds = {"t": "number", "v": "text", "d": "number"}
>>> p = parse_predicate('t < 60 and (v == "certified" or not d >= 2 * 0.5)', kinds)
>>> sorted(p.names())
['d', 't', 'v']
>>> evaluate(p, {"t": Interval(42, 42), "v": "undecided", "d": Interval(0.3, math.inf)})
Outcome(verdict='undecided', deciding=('d',))
>>> evaluate(p, {"t": Interval(80, math.inf), "v": None, "d": None}).verdict
'fails'
>>> parse_predicate("__import__('os')", kinds)  # doctest: +ELLIPSIS
Traceback (most recent call last):
...
formsync_design.errors.InputError: expected a metric id, number, "text", operator or parenthesis at column 1 of the predicate, received '_'...
"""

from __future__ import annotations

import difflib
import math
import re
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from formsync_design.errors import InputError
from formsync_design.textio import check_ascii

__all__ = ["Interval", "Outcome", "Node", "parse_predicate", "evaluate", "HOLDS", "FAILS",
           "UNDECIDED", "KEYWORDS", "MAX_PREDICATE_LENGTH", "closest"]

HOLDS, FAILS, UNDECIDED = "holds", "fails", "undecided"

#: Words of the grammar (never metric ids).
KEYWORDS = frozenset({"and", "or", "not"})

#: Longest predicate read (characters) and deepest nesting.
MAX_PREDICATE_LENGTH = 1000
_MAX_DEPTH = 40

_TOKEN = re.compile(r"""
    (?P<space>\s+)
  | (?P<number>(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)
  | (?P<text>"[^"\\\n]*")
  | (?P<name>[A-Za-z][A-Za-z0-9_]*)
  | (?P<op><=|>=|==|!=|<|>|\+|-|\*|/|\(|\))
""", re.VERBOSE | re.ASCII)

_COMPARE = ("<", "<=", ">", ">=", "==", "!=")


@dataclass(frozen=True)
class Interval:
    """The values a number metric can have: ``lo <= x <= hi`` (``lo == hi``: known)."""

    lo: float
    hi: float

    def __post_init__(self) -> None:
        lo, hi = float(self.lo), float(self.hi)
        if math.isnan(lo) or math.isnan(hi) or lo > hi:
            lo, hi = -math.inf, math.inf
        object.__setattr__(self, "lo", lo)
        object.__setattr__(self, "hi", hi)


@dataclass(frozen=True)
class Outcome:
    """A verdict (``holds``/``fails``/``undecided``) and the metric ids that decided it."""

    verdict: str
    deciding: tuple[str, ...]


@dataclass(frozen=True)
class Node:
    """A node of a parsed predicate: ``op`` one of ``num``, ``text``, ``name``, ``neg``,
    ``+ - * /``, the comparisons, ``not``, ``and``, ``or``; ``value`` for a leaf;
    ``args`` the operands; ``type`` ``number``, ``text`` or ``truth``."""

    op: str
    type: str
    value: Any = None
    args: tuple[Node, ...] = ()

    def names(self) -> set[str]:
        """The metric ids the predicate reads."""
        if self.op == "name":
            return {str(self.value)}
        out: set[str] = set()
        for a in self.args:
            out |= a.names()
        return out


class _Parser:
    def __init__(self, text: str, kinds: Mapping[str, str], where: str) -> None:
        self.text, self.kinds, self.where = text, kinds, where
        self.toks = self._tokens()
        self.i = 0
        self.depth = 0

    def fail(self, expected: str, col: int | None = None) -> InputError:
        if col is None:
            col = self.toks[self.i][2] if self.i < len(self.toks) else len(self.text) + 1
        got = (repr(self.toks[self.i][1]) if self.i < len(self.toks) else "the end")
        return InputError(f"expected {expected} at column {col} of {self.where}, received {got} "
                          f"in {self.text[:80]!r}")

    def _tokens(self) -> list[tuple[str, str, int]]:
        check_ascii(self.text, self.where)
        out, pos = [], 0
        while pos < len(self.text):
            m = _TOKEN.match(self.text, pos)
            if m is None:
                raise InputError(f"expected a metric id, number, \"text\", operator or "
                                 f"parenthesis at column {pos + 1} of {self.where}, received "
                                 f"{self.text[pos]!r} in {self.text[:80]!r}")
            kind = m.lastgroup or ""
            if kind != "space":
                tok = m.group()
                if kind == "name" and tok in KEYWORDS:
                    kind = "op"
                out.append((kind, tok, pos + 1))
            pos = m.end()
        return out

    def peek(self) -> str | None:
        return self.toks[self.i][1] if self.i < len(self.toks) else None

    def take(self) -> tuple[str, str, int]:
        tok = self.toks[self.i]
        self.i += 1
        return tok

    def parse(self) -> Node:
        if not self.toks:
            raise InputError(f"expected a predicate in {self.where}, received an empty text")
        node = self.or_()
        if self.i < len(self.toks):
            raise self.fail("an operator 'and'/'or' or the end")
        if node.type != "truth":
            raise InputError(f"expected a predicate (a comparison, and, or, not) in "
                             f"{self.where}, received a {node.type} expression "
                             f"{self.text[:80]!r}")
        return node

    def _truth(self, node: Node, word: str, col: int) -> Node:
        if node.type != "truth":
            raise InputError(f"expected a comparison as the operand of '{word}' at column {col} "
                             f"of {self.where}, received a {node.type} expression in "
                             f"{self.text[:80]!r}")
        return node

    def _logic(self, word: str, sub: Any) -> Node:
        col = self.toks[self.i][2] if self.i < len(self.toks) else 0
        args = [sub()]
        while self.peek() == word:
            c = self.take()[2]
            args.append(self._truth(sub(), word, c))
        if len(args) == 1:
            return args[0]
        return Node(word, "truth", args=tuple(self._truth(a, word, col) for a in args))

    def or_(self) -> Node:
        return self._logic("or", self.and_)

    def and_(self) -> Node:
        return self._logic("and", self.not_)

    def not_(self) -> Node:
        if self.peek() == "not":
            col = self.take()[2]
            return Node("not", "truth", args=(self._truth(self.nested(self.not_), "not", col),))
        return self.compare()

    def nested(self, f: Any) -> Node:
        self.depth += 1
        if self.depth > _MAX_DEPTH:
            raise self.fail(f"at most {_MAX_DEPTH} nested levels")
        try:
            node: Node = f()
        finally:
            self.depth -= 1
        return node

    def compare(self) -> Node:
        left = self.sum_()
        if self.peek() not in _COMPARE:
            return left
        _, op, col = self.take()
        right = self.sum_()
        if self.peek() in _COMPARE:
            raise self.fail("one comparison (write 'a < b and b < c' for a chain)")
        types = {left.type, right.type}
        sides = f"a {left.type} and a {right.type}"  # left, then right, as written
        if "truth" in types:
            raise InputError(f"expected numbers or texts on both sides of '{op}' at column {col} "
                             f"of {self.where}, received {sides} in {self.text[:80]!r}")
        if len(types) != 1:
            raise InputError(f"expected two numbers or two texts on both sides of '{op}' at "
                             f"column {col} of {self.where}, received {sides} (left, right)")
        if "text" in types and op not in ("==", "!="):
            raise InputError(f"expected '==' or '!=' between texts at column {col} of "
                             f"{self.where}, received '{op}'")
        node = Node(op, "truth", args=(left, right))
        if not node.names():  # a verdict typed in, not computed: refused
            raise InputError(f"expected the comparison at column {col} of {self.where} to read "
                             f"a metric, received one of constants only in {self.text[:80]!r}")
        return node

    def _arith(self, ops: tuple[str, ...], sub: Any) -> Node:
        node: Node = sub()
        while self.peek() in ops:
            _, op, col = self.take()
            right = sub()
            for x in (node, right):
                if x.type != "number":
                    raise InputError(f"expected numbers around '{op}' at column {col} of "
                                     f"{self.where}, received a {x.type} expression")
            node = Node(op, "number", args=(node, right))
        return node

    def sum_(self) -> Node:
        return self._arith(("+", "-"), self.product)

    def product(self) -> Node:
        return self._arith(("*", "/"), self.unary)

    def unary(self) -> Node:
        if self.peek() == "-":
            col = self.take()[2]
            arg = self.nested(self.unary)
            if arg.type != "number":
                raise InputError(f"expected a number after '-' at column {col} of {self.where}, "
                                 f"received a {arg.type} expression")
            return Node("neg", "number", args=(arg,))
        return self.atom()

    def atom(self) -> Node:
        if self.i >= len(self.toks):
            raise self.fail("a metric id, number, \"text\" or '('")
        kind, tok, col = self.toks[self.i]
        if tok == "(":
            self.i += 1
            node = self.nested(self.or_)
            if self.peek() != ")":
                raise self.fail("')'")
            self.i += 1
            return node
        if kind == "number":
            self.i += 1
            v = float(tok)
            if not math.isfinite(v) or abs(v) > 1e15:
                raise InputError(f"expected a number of magnitude at most 1e+15 at column {col} "
                                 f"of {self.where}, received {tok}")
            return Node("num", "number", v)
        if kind == "text":
            self.i += 1
            return Node("text", "text", tok[1:-1])
        if kind == "name":
            if tok not in self.kinds:
                raise InputError(f"expected a metric id of the case ({closest(tok, self.kinds)}) "
                                 f"at column {col} of {self.where}, received {tok[:40]!r}")
            self.i += 1
            if self.peek() == "(":
                raise self.fail(f"an operator after the metric id {tok!r} (no calls)")
            return Node("name", self.kinds[tok], tok)
        raise self.fail("a metric id, number, \"text\" or '('")


def closest(name: str, names: Any, n: int = 5) -> str:
    """The few of ``names`` closest to ``name``, for an unknown name's message: all of them
    when there are at most ``n``, else the ``n`` closest (:func:`difflib.get_close_matches`),
    never the whole list.

    >>> closest("zzz", ["peak_torque", "control_effort"])
    'among control_effort, peak_torque'
    >>> pool = ["peak_torque", "control_effort", "decay_rate", "abscissa", "final_rate", "x"]
    >>> closest("peak_torqe", pool), closest("zzz", pool)
    ('closest: peak_torque', 'none close among 6')
    """
    pool = sorted(str(x) for x in names)
    if len(pool) <= n:
        return ("among " + ", ".join(pool)) if pool else "none defined"
    near = difflib.get_close_matches(str(name), pool, n=n, cutoff=0.6)
    return ("closest: " + ", ".join(near)) if near else f"none close among {len(pool)}"


def parse_predicate(text: Any, kinds: Mapping[str, str], where: str = "the predicate") -> Node:
    """Parse ``text`` (module docstring) with the metric ids ``kinds`` (id -> ``"number"``
    or ``"text"``); bad text is a one-line :class:`~formsync_design.errors.InputError`.

    >>> parse_predicate("a <= b * 1.5", {"a": "number", "b": "number"}).op
    '<='
    >>> parse_predicate("a < 1 < 2", {"a": "number"})  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    formsync_design.errors.InputError: expected one comparison (write 'a < b and b < c' for a chain) at column 7 ...
    """
    if not isinstance(text, str):
        raise InputError(f"expected {where} as a text, received {type(text).__name__}")
    if len(text) > MAX_PREDICATE_LENGTH:
        raise InputError(f"expected {where} of at most {MAX_PREDICATE_LENGTH} characters, "
                         f"received {len(text)}")
    return _Parser(text, kinds, where).parse()


# ------------------------------------------------------------------------------ evaluation


def _mul(a: float, b: float) -> float:
    return 0.0 if a == 0 or b == 0 else a * b


def _num(node: Node, values: Mapping[str, Any]) -> tuple[Interval | None, set[str]]:
    """The interval of a number expression (``None``: a metric without a value) and the
    metrics without a value."""
    if node.op == "num":
        return Interval(node.value, node.value), set()
    if node.op == "name":
        v = values.get(node.value)
        return (None, {node.value}) if v is None else (v, set())
    parts = [_num(a, values) for a in node.args]
    missing = set().union(*(m for _, m in parts))
    if any(iv is None for iv, _ in parts):
        return None, missing
    ivs = [iv for iv, _ in parts]
    assert all(iv is not None for iv in ivs)
    a = ivs[0]
    assert a is not None
    if node.op == "neg":
        return Interval(-a.hi, -a.lo), missing
    b = ivs[1]
    assert b is not None
    if node.op == "+":
        return Interval(a.lo + b.lo, a.hi + b.hi), missing
    if node.op == "-":
        return Interval(a.lo - b.hi, a.hi - b.lo), missing
    if node.op == "/":
        if b.lo <= 0 <= b.hi:
            return Interval(-math.inf, math.inf), missing
        b = Interval(1 / b.hi, 1 / b.lo)
    prods = [_mul(x, y) for x in (a.lo, a.hi) for y in (b.lo, b.hi)]
    return Interval(min(prods), max(prods)), missing


def _compare(op: str, a: Any, b: Any) -> str:
    if isinstance(a, str) or isinstance(b, str):
        eq = a == b
        return HOLDS if eq == (op == "==") else FAILS
    if op in (">", ">="):
        a, b, op = b, a, "<" if op == ">" else "<="
    if op == "<":
        return HOLDS if a.hi < b.lo else FAILS if a.lo >= b.hi else UNDECIDED
    if op == "<=":
        return HOLDS if a.hi <= b.lo else FAILS if a.lo > b.hi else UNDECIDED
    if a.hi < b.lo or b.hi < a.lo:
        eq = FAILS
    elif a.lo == a.hi == b.lo == b.hi:
        eq = HOLDS
    else:
        return UNDECIDED
    return eq if op == "==" else (FAILS if eq == HOLDS else HOLDS)


def evaluate(node: Node, values: Mapping[str, Any]) -> Outcome:
    """The verdict of a parsed predicate (module docstring); ``values``: metric id -> an
    :class:`Interval` (number metrics), a ``str`` (text metrics) or ``None`` (no value)."""
    if node.op in _COMPARE:
        names = tuple(sorted(node.names()))
        sides = []
        missing: set[str] = set()
        for a in node.args:
            if a.type == "text":
                v = a.value if a.op == "text" else values.get(a.value)
                if v is None:
                    missing.add(a.value)
                sides.append(v)
            else:
                iv, m = _num(a, values)
                missing |= m
                sides.append(iv)
        if missing or any(s is None for s in sides):
            return Outcome(UNDECIDED, tuple(sorted(missing)))
        return Outcome(_compare(node.op, sides[0], sides[1]), names)
    if node.op == "not":
        o = evaluate(node.args[0], values)
        flip = {HOLDS: FAILS, FAILS: HOLDS, UNDECIDED: UNDECIDED}
        return Outcome(flip[o.verdict], o.deciding)
    if node.op not in ("and", "or"):
        raise InputError(f"expected a predicate node, received {node.op!r}")  # parse_predicate refuses it
    outs = [evaluate(a, values) for a in node.args]
    decisive = FAILS if node.op == "and" else HOLDS
    other = HOLDS if node.op == "and" else FAILS

    def union(sel: list[Outcome]) -> tuple[str, ...]:
        return tuple(sorted(set().union(*(o.deciding for o in sel))))

    if any(o.verdict == decisive for o in outs):
        return Outcome(decisive, union([o for o in outs if o.verdict == decisive]))
    if all(o.verdict == other for o in outs):
        return Outcome(other, union(outs))
    return Outcome(UNDECIDED, union([o for o in outs if o.verdict == UNDECIDED]))
