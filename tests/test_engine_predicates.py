"""The claim predicates of the verification engine: grammar, precedence, refusals, semantics.

Truth is checked two ways: hand-evaluated cases, and seeded random predicates whose value
CPython's own grammar computes (the same precedence: arithmetic, comparison, not, and, or)
from text the test writes itself - a second implementation, never the library's data.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from formsync_design.errors import InputError
from formsync_design.verify.predicates import Interval, evaluate, parse_predicate

KINDS = {"a": "number", "b": "number", "c": "number", "v": "text", "w": "text"}
VALUES = {"a": 2.0, "b": 3.0, "c": -1.5, "v": "certified", "w": "refuted"}


def _truth(text: str, values: dict | None = None) -> str:
    vals = values or VALUES
    iv = {k: (Interval(v, v) if isinstance(v, float) else v) for k, v in vals.items()}
    return evaluate(parse_predicate(text, KINDS), iv).verdict


@pytest.mark.parametrize("text, expected", [
    ("a < 3", "holds"),
    ("a <= 2", "holds"),
    ("a > 2", "fails"),
    ("a >= b - 1", "holds"),
    ("a == 2 and b != 3", "fails"),
    ("a == 2 or b != 3", "holds"),
    ("not a < 1", "holds"),
    ("a + b * 2 == 8", "holds"),        # * before +
    ("(a + b) * 2 == 10", "holds"),
    ("a - b - 1 == -2", "holds"),       # left-associative
    ("a / b * 3 == 2", "holds"),
    ("-a * -b == 6", "holds"),
    ("-c > 1", "holds"),
    ("a < 1 or a < 3 and b < 1", "fails"),      # and binds tighter than or
    ("(a < 1 or a < 3) and b < 1", "fails"),
    ("a < 1 and b < 1 or a < 3", "holds"),
    ("not a < 1 and b < 1", "fails"),           # not binds tighter than and
    ("not (a < 1 and b < 1)", "holds"),
    ('v == "certified"', "holds"),
    ('v != "certified" or w == "refuted"', "holds"),
    ("v == w", "fails"),
    ("not not a < 3", "holds"),
    ("a <= b * 1.5", "holds"),
    ("1e-3 < a", "holds"),
    (".5 * 4 == a", "holds"),
])
def test_hand_evaluated_truth(text, expected):
    assert _truth(text) == expected


def _random_predicate(rng: np.random.Generator, depth: int) -> str:
    def num(d: int) -> str:
        r = rng.integers(5 if d > 0 else 2)
        if r == 0:
            return str(rng.choice(["a", "b", "c"]))
        if r == 1:
            return f"{rng.integers(-4, 5)}"
        op = str(rng.choice(["+", "-", "*"]))
        left, right = num(d - 1), num(d - 1)
        if rng.random() < 0.5:
            return f"({left} {op} {right})"
        return f"{left} {op} {right}"

    def pred(d: int) -> str:
        r = rng.integers(4 if d > 0 else 1)
        if r == 0:  # a comparison reads a metric (one of constants only is refused)
            while True:
                left, right = num(2), num(2)
                if any(ch in left + right for ch in "abc"):
                    return f"{left} {rng.choice(['<', '<=', '>', '>=', '==', '!='])} {right}"
        if r == 1:
            return f"not {pred(d - 1)}"
        word = str(rng.choice(["and", "or"]))
        left, right = pred(d - 1), pred(d - 1)
        return f"({left} {word} {right})" if rng.random() < 0.5 else f"{left} {word} {right}"

    return pred(depth)


def test_random_predicates_agree_with_pythons_precedence():
    rng = np.random.default_rng(23)
    env = {"a": 2.0, "b": 3.0, "c": -1.5}
    for _ in range(400):
        text = _random_predicate(rng, 3)
        want = "holds" if eval(text, {"__builtins__": {}}, dict(env)) else "fails"  # noqa: S307
        assert _truth(text) == want, text


@pytest.mark.parametrize("text", [
    "__import__('os')",
    "__import__(\"os\").system(\"true\")",
    "a.real < 1",
    "f(a) < 1",
    "a ** 2 < 1",
    "a < b < c",
    "'x' == v",
    "[a] == [b]",
    "a < 1; b < 1",
    "lambda: a",
    "a if b else c",
    "a",
    "a + 1",
    "not a",
    "a and b < 1",
    "a + v == 1",
    'v < "x"',
    'v == 1',
    "(a < 1) + 1 < 2",
    "(a < 1) == (b < 1)",
    "zzz < 1",
    "a < 1e400",
    "",
    "a <",
    "(a < 1",
    "a < 1)",
    "a < 1 and",
    "open < 1",
    "a\\\n< 1",
    "(" * 60 + "a < 1" + ")" * 60,
    "a < 1 or " * 200 + "a < 1",
])
def test_refusals_are_one_line_input_errors(text):
    with pytest.raises(InputError) as e:
        parse_predicate(text, KINDS, "claim x's predicate")
    assert "\n" not in str(e.value) and str(e.value).startswith("expected")


def test_refuses_a_non_text_predicate():
    with pytest.raises(InputError):
        parse_predicate(1, KINDS)  # type: ignore[arg-type]


def test_three_valued_semantics_intervals_and_unknowns():
    lower = {"a": Interval(80.0, math.inf), "b": Interval(3.0, 3.0), "v": None, "w": "x",
             "c": None}
    ev = lambda t: evaluate(parse_predicate(t, KINDS), lower)  # noqa: E731
    assert ev("a < 60").verdict == "fails"          # >= 80 decides it
    assert ev("a > 60").verdict == "holds"
    assert ev("a < 100").verdict == "undecided"     # the bound does not decide
    assert ev("a == 80").verdict == "undecided"
    assert ev("a != 70").verdict == "holds"
    assert ev('v == "certified"').verdict == "undecided"
    # a failing conjunct decides `and` even with an unknown one; a holding disjunct `or`
    o = ev('v == "certified" and b > 5')
    assert (o.verdict, o.deciding) == ("fails", ("b",))
    o = ev('v == "certified" or b < 5')
    assert (o.verdict, o.deciding) == ("holds", ("b",))
    o = ev('v == "certified" and b < 5')
    assert (o.verdict, o.deciding) == ("undecided", ("v",))
    assert ev('not v == "certified"').verdict == "undecided"
    # interval arithmetic: [80, inf] - 3 > 70 holds; [80, inf] * 0 == 0 holds; division by
    # an interval containing 0 decides nothing
    assert ev("a - b > 70").verdict == "holds"
    assert ev("a * 0 == 0").verdict == "holds"
    assert ev("b / (a - a) < 1").verdict == "undecided"
    assert ev("c + 1 < 2").verdict == "undecided"


def test_names_are_the_metrics_read():
    p = parse_predicate('a < b * 2 or (not v == "x" and c > 0)', KINDS)
    assert p.names() == {"a", "b", "c", "v"}


@pytest.mark.parametrize("text", ["1 == 1", '"certified" == "certified"', "t < 3 or 2 > 1",
                                  "not (0 < 1)", "-(1) <= 2 * 3"])
def test_a_comparison_of_constants_is_a_typed_in_verdict_and_refused(text: str) -> None:
    with pytest.raises(InputError, match="to read a metric"):
        parse_predicate(text, {"t": "number"})
