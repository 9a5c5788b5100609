"""Formulas from data files and flags, read without running them.

A formula in a case file (``[reference] rate = ["0.02*exp(-t/10)", ...]``) is *data from a
stranger*: it is never given to ``eval``, ``sympify`` or ``parse_expr`` (both evaluate the
text as Python).  :func:`parse_formula` parses it with :func:`ast.parse` and walks the tree
with an allow-list, building the SymPy expression node by node:

* numbers (decimal literals, finite, ``|x| <= 1e15``);
* the variables the field declares (e.g. ``t``);
* ``+ - * / **``, unary ``+``/``-`` and parentheses;
* calls of the named functions :data:`FUNCTIONS` (``exp, log, sin, cos, tan, tanh, sinh,
  cosh, sqrt, abs/Abs, atan, asin, acos, atan2, min, max``) with positional arguments;
* the constants ``pi`` and ``E``.

Everything else -- attributes, calls of other names, subscripts, lambdas, comprehensions,
strings, keywords, starred arguments, comparisons, boolean operators, unknown or dunder
names -- and text longer than :data:`MAX_LENGTH`, nesting deeper than :data:`MAX_DEPTH`, a
numeric exponent beyond :data:`MAX_EXPONENT` or a constant (sub-)expression beyond
:data:`MAX_NUMBER` in magnitude is refused with a one-line
:class:`~formsync_design.errors.InputError` naming the field (file and key) and the
offending token.

>>> parse_formula("0.02*exp(-t/10)", "rate[1] in c.toml")
0.02*exp(-t/10)
>>> parse_formula("__import__('os')", "rate[1] in c.toml")
Traceback (most recent call last):
...
formsync_design.errors.InputError: expected rate[1] in c.toml to be a formula in t (numbers, + - * / **, exp, log, sin, cos, tan, tanh, sinh, cosh, sqrt, abs, Abs, atan, asin, acos, atan2, min, max, pi, E), received the call '__import__' in "__import__('os')"
"""

from __future__ import annotations

import ast
import math
import re
from collections.abc import Callable, Iterable, Mapping
from typing import Any

from formsync_design.errors import InputError

__all__ = [
    "FUNCTIONS",
    "CONSTANTS",
    "MAX_LENGTH",
    "MAX_DEPTH",
    "MAX_EXPONENT",
    "MAX_NUMBER",
    "parse_formula",
]

#: Longest formula text accepted (characters).
MAX_LENGTH = 500
#: Deepest nesting of operators and calls accepted.
MAX_DEPTH = 40
#: Largest ``|exponent|`` of ``**`` when the exponent is a number.
MAX_EXPONENT = 64
#: Largest magnitude of a number literal.
MAX_NUMBER = 1e15

#: Function names a formula may call, with their number of arguments (``None``: one or more).
FUNCTIONS: dict[str, int | None] = {
    "exp": 1, "log": 1, "sin": 1, "cos": 1, "tan": 1, "tanh": 1, "sinh": 1, "cosh": 1,
    "sqrt": 1, "abs": 1, "Abs": 1, "atan": 1, "asin": 1, "acos": 1, "atan2": 2,
    "min": None, "max": None,
}
#: Constant names a formula may use.
CONSTANTS: tuple[str, ...] = ("pi", "E")

_DECIMAL = re.compile(r"^(\d+(\.\d*)?|\.\d+)([eE][+-]?\d+)?$")
_BINOPS = {ast.Add: "+", ast.Sub: "-", ast.Mult: "*", ast.Div: "/", ast.Pow: "**"}
_OPNAMES = {ast.FloorDiv: "//", ast.Mod: "%", ast.MatMult: "@", ast.LShift: "<<",
            ast.RShift: ">>", ast.BitOr: "|", ast.BitXor: "^", ast.BitAnd: "&",
            ast.Not: "not", ast.Invert: "~"}
_COMPARE = {ast.Eq: "==", ast.NotEq: "!=", ast.Lt: "<", ast.LtE: "<=", ast.Gt: ">",
            ast.GtE: ">=", ast.Is: "is", ast.IsNot: "is not", ast.In: "in", ast.NotIn: "not in"}


def _sympy_functions() -> dict[str, Callable[..., Any]]:
    import sympy as sp

    return {"exp": sp.exp, "log": sp.log, "sin": sp.sin, "cos": sp.cos, "tan": sp.tan,
            "tanh": sp.tanh, "sinh": sp.sinh, "cosh": sp.cosh, "sqrt": sp.sqrt, "abs": sp.Abs,
            "Abs": sp.Abs, "atan": sp.atan, "asin": sp.asin, "acos": sp.acos,
            "atan2": sp.atan2, "min": sp.Min, "max": sp.Max}


def _short(s: str, n: int = 40) -> str:
    return s if len(s) <= n else s[: n - 3] + "..."


class _Reader:
    """One walk of one formula's tree (the allow-list of the module docstring)."""

    def __init__(self, text: str, where: str, variables: Mapping[str, Any],
                 functions: Iterable[str], constants: Iterable[str]) -> None:
        import sympy as sp

        self.sp = sp
        self.text = text
        self.where = where
        self.variables = dict(variables)
        self.functions = {k: v for k, v in _sympy_functions().items() if k in set(functions)}
        consts = {"pi": sp.pi, "E": sp.E}
        self.constants = {k: consts[k] for k in constants}

    # -- messages ---------------------------------------------------------------
    def expected(self) -> str:
        vars_ = ", ".join(self.variables) or "no variables"
        allowed = ", ".join([*self.functions, *self.constants])
        return (f"expected {self.where} to be a formula in {vars_} (numbers, + - * / **"
                f"{', ' + allowed if allowed else ''})")

    def refuse(self, what: str) -> InputError:
        return InputError(f"{self.expected()}, received {what} in {_short(self.text, 80)!r}")

    def segment(self, node: ast.AST) -> str:
        return _short(ast.get_source_segment(self.text, node) or type(node).__name__)

    # -- the walk ---------------------------------------------------------------
    def build(self, node: ast.AST, depth: int) -> Any:
        """The expression of ``node``; a constant sub-expression stays within
        ``|x| <= MAX_NUMBER`` (so no power of powers grows without bound)."""
        e = self._build(node, depth)
        if getattr(e, "is_number", False):
            try:
                mag = abs(complex(e))
            except (OverflowError, TypeError, ValueError):
                mag = math.inf
            if not mag <= MAX_NUMBER:
                raise self.refuse(f"the constant {self.segment(node)!r} beyond "
                                  f"{MAX_NUMBER:g} in magnitude")
        return e

    def _build(self, node: ast.AST, depth: int) -> Any:
        sp = self.sp
        if depth > MAX_DEPTH:
            raise self.refuse(f"nesting deeper than {MAX_DEPTH}")
        if isinstance(node, ast.Constant):
            return self.number(node)
        if isinstance(node, ast.Name):
            if node.id in self.variables:
                return self.variables[node.id]
            if node.id in self.constants:
                return self.constants[node.id]
            if node.id in self.functions:
                raise self.refuse(f"the function {node.id!r} without a call")
            raise self.refuse(f"the unknown name {node.id!r}")
        if isinstance(node, ast.UnaryOp):
            if isinstance(node.op, ast.USub):
                return -self.build(node.operand, depth + 1)
            if isinstance(node.op, ast.UAdd):
                return self.build(node.operand, depth + 1)
            raise self.refuse(f"the operator {_OPNAMES.get(type(node.op), '?')!r}")
        if isinstance(node, ast.BinOp):
            op = type(node.op)
            if op not in _BINOPS:
                raise self.refuse(f"the operator {_OPNAMES.get(op, '?')!r}")
            a = self.build(node.left, depth + 1)
            b = self.build(node.right, depth + 1)
            if op is ast.Add:
                return a + b
            if op is ast.Sub:
                return a - b
            if op is ast.Mult:
                return a * b
            if op is ast.Div:
                if b.is_zero:
                    raise self.refuse(f"a division by zero {self.segment(node)!r}")
                return a / b
            if b.is_number and not (b.is_finite and abs(float(b)) <= MAX_EXPONENT):
                raise self.refuse(f"the exponent {self.segment(node.right)!r} (|exponent| "
                                  f"<= {MAX_EXPONENT})")
            return sp.Pow(a, b)
        if isinstance(node, ast.Call):
            return self.call(node, depth)
        described = {
            ast.Attribute: "the attribute", ast.Subscript: "the subscript",
            ast.Lambda: "the lambda", ast.Compare: "the comparison",
            ast.BoolOp: "the boolean operator", ast.IfExp: "the conditional",
            ast.Starred: "the starred", ast.NamedExpr: "the assignment",
            ast.JoinedStr: "the string",
        }
        for kind, label in described.items():
            if isinstance(node, kind):
                return self._refuse_node(label, node)
        return self._refuse_node(f"the {type(node).__name__.lower()}", node)

    def _refuse_node(self, label: str, node: ast.AST) -> Any:
        token = self.segment(node)
        if isinstance(node, ast.Attribute):
            token = "." + node.attr
        elif isinstance(node, ast.BoolOp):
            token = "or" if isinstance(node.op, ast.Or) else "and"
        elif isinstance(node, ast.Compare):
            token = _COMPARE.get(type(node.ops[0]), "?")
        raise self.refuse(f"{label} {token!r}")

    def number(self, node: ast.Constant) -> Any:
        sp = self.sp
        v = node.value
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            what = "the string" if isinstance(v, (str, bytes)) else "the constant"
            raise self.refuse(f"{what} {self.segment(node)!r}")
        token = ast.get_source_segment(self.text, node) or repr(v)
        if not _DECIMAL.match(token):
            raise self.refuse(f"the number {_short(token)!r} (write plain decimals)")
        if not (math.isfinite(float(v)) and abs(float(v)) <= MAX_NUMBER):
            raise self.refuse(f"the number {_short(token)!r} (|x| <= {MAX_NUMBER:g})")
        return sp.Integer(v) if isinstance(v, int) else sp.Float(token)

    def call(self, node: ast.Call, depth: int) -> Any:
        f = node.func
        if not isinstance(f, ast.Name):
            if isinstance(f, ast.Attribute):
                raise self.refuse(f"the attribute {'.' + f.attr!r}")
            raise self.refuse(f"the call {self.segment(f)!r}")
        if f.id not in self.functions:
            raise self.refuse(f"the call {f.id!r}")
        if node.keywords:
            raise self.refuse(f"the keyword argument {self.segment(node.keywords[0])!r}")
        for a in node.args:
            if isinstance(a, ast.Starred):
                raise self.refuse(f"the starred {self.segment(a)!r}")
        want = FUNCTIONS[f.id]
        if (want is None and not node.args) or (want is not None and len(node.args) != want):
            n = "one or more" if want is None else str(want)
            raise self.refuse(f"{f.id} with {len(node.args)} arguments (takes {n})")
        args = [self.build(a, depth + 1) for a in node.args]
        return self.functions[f.id](*args)


def parse_formula(
    text: Any,
    where: str,
    *,
    variables: Mapping[str, Any] | Iterable[str] = ("t",),
    functions: Iterable[str] = tuple(FUNCTIONS),
    constants: Iterable[str] = CONSTANTS,
) -> Any:
    """The SymPy expression of ``text``, read with the allow-list of the module docstring.

    Parameters
    ----------
    text : str, int or float
        The formula (a number is its value).
    where : str
        The field, shown in messages: the key and the file (``"reference.rate[2] in c.toml"``).
    variables : mapping name -> sympy.Symbol, or names
        The variables the field declares; names become real symbols.
    functions, constants : names
        Subsets of :data:`FUNCTIONS` and :data:`CONSTANTS` (what the consumer supports).

    Raises
    ------
    InputError
        One line naming ``where`` and the offending token.

    Examples
    --------
    >>> parse_formula("-0.015*exp(-t/10)", "rate").free_symbols
    {t}
    >>> parse_formula(0.1, "rate"), parse_formula("2**3", "x")
    (0.100000000000000, 8)
    >>> parse_formula("().__class__", "k in f.toml")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    formsync_design.errors.InputError: expected k in f.toml ... received the attribute '.__class__' in '().__class__'
    """
    import sympy as sp

    if isinstance(variables, Mapping):
        symbols = dict(variables)
    else:
        symbols = {v: sp.Symbol(v, real=True) for v in variables}
    unknown = [f for f in functions if f not in FUNCTIONS] + [c for c in constants
                                                               if c not in CONSTANTS]
    if unknown:
        raise ValueError(f"expected functions and constants of the allow-list, received {unknown}")
    reader = _Reader("", where, symbols, functions, constants)
    if isinstance(text, bool) or not isinstance(text, (str, int, float)):
        raise InputError(f"{reader.expected()}, received {type(text).__name__} "
                         f"{_short(repr(text))}")
    if not isinstance(text, str):
        text = str(text)
    reader.text = text
    if len(text) > MAX_LENGTH:
        raise reader.refuse(f"{len(text)} characters (at most {MAX_LENGTH})")
    if not text.strip():
        raise reader.refuse("an empty text")
    bad = next((k for k, ch in enumerate(text) if ord(ch) > 127), None)
    if bad is not None:  # Python reads a fullwidth 'ｅｘｐ' as exp (NFKC): names are ASCII
        raise reader.refuse(f"the non-ASCII character {text[bad]!r} (U+{ord(text[bad]):04X}) "
                            f"at column {bad + 1}")
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except (SyntaxError, ValueError, MemoryError, RecursionError):
        raise reader.refuse("text that is not a formula") from None
    reader.text = text.strip()
    try:
        expr = reader.build(tree.body, 0)
    except RecursionError:
        raise reader.refuse(f"nesting deeper than {MAX_DEPTH}") from None
    except (TypeError, ValueError, OverflowError, ZeroDivisionError) as e:
        if isinstance(e, InputError):
            raise
        raise reader.refuse(f"a formula SymPy cannot build ({type(e).__name__})") from None
    if expr.has(sp.zoo, sp.oo, -sp.oo, sp.nan) or expr.has(sp.I):
        raise reader.refuse("a formula that is not a finite real number")
    return expr
