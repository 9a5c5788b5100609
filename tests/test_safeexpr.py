"""The one safe formula reader (formsync_design/safeexpr.py): nothing from a data file runs.

Independent truth: SymPy's own parser on *trusted* test strings (the formulas the reader must
accept build the same expressions), and the file system (an injected payload creates no file).
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest
import sympy as sp

from formsync_design.cli import main
from formsync_design.errors import InputError
from formsync_design.safeexpr import MAX_DEPTH, MAX_LENGTH, parse_formula

ROOT = Path(__file__).resolve().parents[1]
T = sp.Symbol("t", real=True)

#: Payloads a stranger's case file might carry (the issue's list, kept as a regression set).
PAYLOADS = [
    "__import__('pathlib').Path('PWNED').touch() or 0.02",
    "__import__('os')",
    "__import__('os').system('touch PWNED')",
    "().__class__",
    "().__class__.__bases__[0].__subclasses__()",
    "lambda: 1",
    "exp.__globals__",
    "exp(t).__class__",
    "[1][0]",
    "(1, 2)[0]",
    "open('PWNED', 'w')",
    "eval('1')",
    "exec('x = 1')",
    "getattr(t, 'x')",
    "globals()",
    "__builtins__",
    "'a string'",
    "b'bytes'",
    "f'{t}'",
    "[x for x in (1, 2)]",
    "{1: 2}",
    "{1, 2}",
    "*t",
    "exp(*[t])",
    "exp(x=t)",
    "t if t else 1",
    "t < 1",
    "t and 1",
    "not t",
    "~t",
    "t // 2",
    "t % 2",
    "t @ t",
    "t << 2",
    "(x := 1)",
    "Symbol('x')",
    "sympify('1')",
    "S(1)",
    "I",
    "1j",
    "x",
    "nan",
    "oo",
    "1e400",
    "10**10**10",
    "2**1000",
    "t**65",
    "((((10**15)**64)**64)**64)**64",
    "(1e15*1e15)*t",
    "exp(100)",
    "1/0",
    "exp",
    "atan2(t)",
    "min()",
    "0x10",
    "1_000",
    "exp(" * 60 + "t" + ")" * 60,
    "(" * 300 + "t" + ")" * 300,
    "-" * 60 + "t",
    "t+" * (MAX_LENGTH // 2) + "t",
    "",
    "   ",
    "t\n;import os",
    "t; 1",
    "import os",
]


@pytest.mark.parametrize("payload", PAYLOADS)
def test_every_payload_is_refused_in_one_line_naming_field(payload):
    with pytest.raises(InputError) as e:
        parse_formula(payload, "reference.rate[1] in case.toml")
    msg = str(e.value)
    assert "\n" not in msg and "reference.rate[1] in case.toml" in msg
    assert msg.startswith("expected ") and ", received " in msg


@pytest.mark.parametrize(
    "payload, token",
    [("__import__('os')", "'__import__'"), ("().__class__", "'.__class__'"),
     ("lambda: 1", "lambda"), ("exp.__globals__", "'.__globals__'"), ("[1][0]", "subscript"),
     ("open('x')", "'open'"), ("t or 1", "'or'"), ("t < 1", "'<'"), ("x", "'x'"),
     ("t // 2", "'//'"), ("exp(x=t)", "keyword"), ("t**100", "exponent")],
)
def test_message_names_the_offending_token(payload, token):
    with pytest.raises(InputError, match=re.escape(token)):
        parse_formula(payload, "k")


@pytest.mark.parametrize(
    "text",
    ["0.02*exp(-t/10)", "-0.015*exp(-t/10)", "0.03*exp(-t/10)", "0", "0.0", "1e-3", "3/7",
     "0.1*sin(t) + cos(2*t)**2", "sqrt(1 + t**2)", "tanh(t/5) - atan(t)", "-(t - 1)**3",
     "+t", "2*pi*t", "E**t", "log(2 + t)", "asin(0.5) + acos(0.5)", "sinh(t) + cosh(t)",
     "Abs(t) + abs(-t)", "atan2(1, t)", "min(t, 1)", "max(t, 1, 2)", "tan(0.1 * t)", "1.5e+2"],
)
def test_accepted_formulas_build_what_sympy_parses(text):
    # SymPy's parser is the independent truth for these trusted test strings
    ns = {"t": T, "abs": sp.Abs, "min": sp.Min, "max": sp.Max}
    assert parse_formula(text, "k") == sp.sympify(text, locals=ns)


def test_numbers_and_declared_variables():
    x = sp.Symbol("x")
    assert parse_formula(0.25, "k") == sp.Float("0.25")
    assert parse_formula(3, "k") == 3
    assert parse_formula("2*x", "k", variables={"x": x}) == 2 * x
    with pytest.raises(InputError, match="'t'"):
        parse_formula("t", "k", variables=("x",))
    with pytest.raises(InputError, match="'sinh'"):
        parse_formula("sinh(t)", "k", functions=("exp",))
    for bad in (True, None, [1], {"a": 1}, float("nan"), float("inf")):
        with pytest.raises(InputError):
            parse_formula(bad, "k")


def test_depth_limit_is_enforced_below_python_recursion():
    ok = "(" * (MAX_DEPTH - 1) + "t" + ")" * (MAX_DEPTH - 1)
    assert parse_formula(ok, "k") == T  # parentheses alone do not nest the tree
    deep = "-" * (MAX_DEPTH + 1) + "t"
    with pytest.raises(InputError, match="nesting"):
        parse_formula(deep, "k")


# -- the package never evaluates text ----------------------------------------------------------

#: The legitimate uses of ``sympify`` in the package, each applied to a SymPy object (an
#: expression built by a design's Python code or by the library), never to text from a data
#: file: (file, function).  A new use fails the test until it is reviewed and listed here.
SYMPIFY_OF_EXPRESSIONS = {
    ("formsync_design/analysis/modecheck.py", "entry_coeffs"),
    ("formsync_design/analysis/modecheck.py", "hurwitz_conditions"),
    ("formsync_design/analysis/modes.py", "coefficients"),
    ("formsync_design/analysis/modes.py", "poly_coeffs_in_lambda"),
    ("formsync_design/analysis/searched.py", "lp_coeffs"),
    ("formsync_design/analysis/searched.py", "_lp_coeffs_cached"),
    ("formsync_design/derive/agent.py", "time_derivative"),
    ("formsync_design/derive/conditions.py", "_poly_dict"),
    ("formsync_design/derive/conditions.py", "brute_force_vdot"),
    ("formsync_design/derive/report.py", "write_derivation_report"),
    ("formsync_design/derive/so3_sliding.py", "rational_rotation"),
    ("formsync_design/derive/so3_sliding.py", "_points"),
    ("formsync_design/derive/templates.py", "template_cached"),
    ("formsync_design/sim/agent_kernel.py", "translate"),
    ("formsync_design/sim/bridge.py", "sympy_to_casadi"),
    ("formsync_design/spec/agent.py", "_scalar"),
    ("formsync_design/spec/agent_view.py", "sig"),
    ("formsync_design/spec/dag.py", "_nodes"),
    ("formsync_design/spec/dag.py", "xreplace"),
    ("formsync_design/spec/dag.py", "replace_function"),
    ("formsync_design/spec/loader.py", "validate_spec"),
    ("formsync_design/spec/tracking.py", "validate_tracking"),
}
#: A design ``.py`` file is code by nature (README "What can run code, and when"): the one
#: ``exec``, reached only for a shipped design, a file the user named or one trusted by hash.
EXEC_OF_DESIGN_FILES = {("formsync_design/spec/loader.py", "_load_code")}
_EVALUATORS = {"sympify", "parse_expr", "eval", "exec", "S", "literal_eval"}


def _calls(path: Path) -> list[tuple[str, str, int]]:
    """``(callee, enclosing function, line)`` of every call of an evaluator in ``path``."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    out: list[tuple[str, str, int]] = []

    def visit(node: ast.AST, func: str) -> None:
        for child in ast.iter_child_nodes(node):
            f = func
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)):
                f = child.name
            if isinstance(child, ast.ImportFrom):  # an evaluator under another name
                for a in child.names:
                    if a.name in _EVALUATORS:
                        out.append((f"import {a.name}", f, child.lineno))
            if isinstance(child, ast.Call):
                callee = child.func
                name = callee.attr if isinstance(callee, ast.Attribute) else getattr(callee, "id", "")
                if name in _EVALUATORS:
                    out.append((name, f, child.lineno))
            visit(child, f)

    visit(tree, "<module>")
    return out


def _sources() -> list[Path]:
    return sorted(p for d in ("formsync_design", "derivations", "verification")
                  for p in (ROOT / d).rglob("*.py"))


def test_no_evaluation_of_text_anywhere_in_the_package():
    found, seen = [], set()
    for p in _sources():
        rel = p.relative_to(ROOT).as_posix()
        for name, func, line in _calls(p):
            allowed = SYMPIFY_OF_EXPRESSIONS if name == "sympify" else (
                EXEC_OF_DESIGN_FILES if name == "exec" else set())
            if (rel, func) in allowed:
                seen.add((rel, func))
                continue
            found.append(f"{rel}:{line} {name}() in {func}")
    assert not found, "text evaluated (or a new sympify to review): " + "; ".join(found)
    listed = SYMPIFY_OF_EXPRESSIONS | EXEC_OF_DESIGN_FILES
    assert seen == listed, f"stale allow-list entries: {listed - seen}"


def test_the_grep_test_can_fail(tmp_path):
    p = tmp_path / "m.py"
    p.write_text("import sympy\nfrom sympy.parsing.sympy_parser import parse_expr as pe\n\n"
                 "def load(text):\n    return sympy.sympify(text)\n")
    assert _calls(p) == [("import parse_expr", "<module>", 2), ("sympify", "load", 5)]


# -- the CLI: a shipped case with an injected formula -------------------------------------------

def _formula_cases() -> list[tuple[str, int]]:
    """(shipped case, index) for every formula-bearing key: ``[reference] rate``'s entries."""
    out = []
    for p in sorted((ROOT / "verification").glob("*.toml")):
        text = p.read_text(encoding="utf-8")
        if re.search(r"(?m)^rate = \[\s*\"", text) and "[reference]" in text:
            out += [(p.name, k) for k in range(3)]
    return out


def _inject(text: str, k: int, payload: str) -> str:
    m = re.search(r"(?ms)^\[reference\].*?^rate = \[(.*?)\]", text)
    assert m is not None
    entries = [e.strip() for e in m.group(1).split(",")]
    assert '"' not in payload
    entries[k] = '"' + payload + '"'
    return text[: m.start(1)] + ", ".join(entries) + text[m.end(1):]


def test_every_shipped_formula_key_is_found():
    names = {c for c, _ in _formula_cases()}
    assert {"selftrigger_mrp.toml", "lv2012.toml", "lv2012_small.toml"} <= names


@pytest.mark.parametrize("case, k", _formula_cases())
@pytest.mark.parametrize("payload", ["__import__('pathlib').Path('PWNED').touch() or 0.02",
                                     "__import__('os')", "open('PWNED', 'w') and 0"])
def test_injected_case_is_refused_at_load_and_runs_nothing(tmp_path, monkeypatch, capsys,
                                                           case, k, payload):
    src = (ROOT / "verification" / case).read_text(encoding="utf-8")
    copy = tmp_path / "copy.toml"
    copy.write_text(_inject(src, k, payload), encoding="utf-8")
    if case.startswith("lv2012"):  # its companion case, named relative to the case file
        for other in ("lv2012_small.toml",):
            (tmp_path / other).write_text((ROOT / "verification" / other).read_text())
    monkeypatch.chdir(tmp_path)
    rc = main(["simulate", "--case", str(copy), "--tf", "2"])
    err = capsys.readouterr().err.strip()
    assert rc == 2
    assert len(err.splitlines()) == 1, err
    assert f"reference.rate[{k + 1}] in {copy}" in err
    assert not (tmp_path / "PWNED").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        ["copy.toml"] + (["lv2012_small.toml"] if case.startswith("lv2012") else []))
