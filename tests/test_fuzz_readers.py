"""Fuzzed readers: every mutation of a shipped case, campaign or graph file ends in success or
a one-line bad-input error, never an unexpected exception, and creates no file.

Mutations (hypothesis, derandomized): delete keys and list entries, change types, insert huge,
tiny, NaN, infinite and negative numbers and injected expressions.  The mutated documents are
written back as TOML and read by the loaders the command line uses; a few go through
``formsync simulate`` / ``formsync sweep`` in-process (``main(argv)``), which must exit 0, 1
or 2 with no traceback.  The default suite runs a bounded number of examples; the ``slow``
marker runs many more.

Three targeted fuzzers besides (issue 34 item 8), with the same property (success, or a
one-line bad-input error, :class:`FormsyncError` of exit 2; never another exception; no file
created in the test's folder, the working directory):

* **engine tables**: mutations only inside the engine's own tables (``[[formations]]``,
  ``[[scenarios]]``, ``[[metrics]]``, ``[[claims]]``, ``[montecarlo]``, ``[families]``,
  ``[report]``) of every shipped engine case, with values that reach their checks (metric
  and formation names, spacecraft indices, graph specs, predicates), read by
  ``load_engine_case``;
* **predicates**: claim predicate texts (random Unicode and ASCII text, and token soups of
  metric ids, unknown names, operators, keywords, numbers of every spelling, Unicode digits
  and quotes) parsed by ``parse_predicate`` and, when they parse, evaluated on random
  intervals, unknown values and texts (a verdict, never an exception);
* **paths**: the graph and design path values of a case (``[case] graph``, ``[case]
  design``, ``[[formations]] graph``) and of a campaign (``graphs``, ``[montecarlo] case``):
  ``..`` chains, absolute paths, NUL bytes, long names, Unicode, random text.
  A name over the system's 255-byte limit is a command-line matter (exit 2 from
  ``formsync``, ``tests/bad_inputs/audits.py``): the loaders let the ``OSError`` through,
  recorded by an expected failure below.
"""

from __future__ import annotations

import copy
import json
import math
import string
import tomllib
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from formsync_design.errors import FormsyncError

ROOT = Path(__file__).resolve().parents[1]
VERIFICATION = ROOT / "verification"
CASES = sorted(p.name for p in VERIFICATION.glob("*.toml") if not p.name.startswith("sweep"))
CAMPAIGNS = sorted(p.name for p in VERIFICATION.glob("sweep_*.toml"))
ENGINE_CASES = sorted(p.name for p in VERIFICATION.glob("*.toml") if not p.name.startswith("sweep")
                      and tomllib.loads(p.read_text(encoding="utf-8")).get("case", {}).get(
                          "kind") == "engine")

#: Values a mutation inserts (the issue's expressions among them).
BAD_VALUES: list[Any] = [
    "", "x", "ring:4", True, False, -1, 0, 1, -0.5, 1e308, -1e308, 1e-320, 10**400, -(10**400),
    math.nan, math.inf, -math.inf, [], {}, [1, 2], [[1]], {"a": 1}, "1e400", "nan", "-inf",
    "__import__('pathlib').Path('PWNED').touch() or 0.02", "__import__('os')", "().__class__",
    "lambda: 1", "exp.__globals__", "[1][0]", "open('PWNED', 'w')", "exp(-t/10)", "t**1000",
    "0.02*exp(-t/10)", "../../../etc/passwd", "/dev/zero", "PWNED", 2**63, 1e15, 1e16,
]
OPS = ("delete", "replace", "wrap", "stringify", "negate")


# -- a small TOML writer (tables, arrays of tables, inline tables; nan/inf as TOML spells them)

def _value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, list):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{json.dumps(str(k))} = {_value(x)}" for k, x in v.items()) + "}"
    raise TypeError(type(v))


def to_toml(doc: dict) -> str:
    lines = [f"{json.dumps(k)} = {_value(v)}" for k, v in doc.items()
             if not isinstance(v, dict) and not (isinstance(v, list) and v
                                                 and all(isinstance(x, dict) for x in v))]
    for k, v in doc.items():
        if isinstance(v, dict):
            lines.append(f"[{json.dumps(k)}]")
            lines += [f"{json.dumps(str(a))} = {_value(b)}" for a, b in v.items()]
        elif isinstance(v, list) and v and all(isinstance(x, dict) for x in v):
            for row in v:
                lines.append(f"[[{json.dumps(k)}]]")
                lines += [f"{json.dumps(str(a))} = {_value(b)}" for a, b in row.items()]
    return "\n".join(lines) + "\n"


def test_the_writer_round_trips_every_shipped_file():
    for p in VERIFICATION.glob("*.toml"):
        doc = tomllib.loads(p.read_text(encoding="utf-8"))
        assert tomllib.loads(to_toml(doc)) == doc


# -- mutations -------------------------------------------------------------------------------

def _paths(node: Any, prefix: tuple = ()) -> list[tuple]:
    out = []
    items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(
        node, list) else ()
    for k, v in items:
        out.append((*prefix, k))
        out += _paths(v, (*prefix, k))
    return out


def _apply(doc: dict, path: tuple, op: str, value: Any) -> None:
    node: Any = doc
    for k in path[:-1]:
        try:
            node = node[k]
        except (KeyError, IndexError, TypeError):
            return
    last = path[-1]
    if isinstance(node, dict) and last not in node or isinstance(node, list) and not (
            isinstance(last, int) and last < len(node)) or not isinstance(node, (dict, list)):
        return
    old = node[last]
    if op == "delete":
        del node[last]
    elif op == "replace":
        node[last] = value
    elif op == "wrap":
        node[last] = [old] if not isinstance(old, list) else {"x": old}
    elif op == "stringify":
        node[last] = str(old)
    elif op == "negate" and isinstance(old, (int, float)) and not isinstance(old, bool):
        node[last] = -old * 10**300 if isinstance(old, int) else -old * 1e300
    elif op == "negate" and isinstance(old, str):
        node[last] = old + "__import__('os')"


@st.composite
def mutated(draw: Any, doc: dict) -> dict:
    paths = _paths(doc)
    out = copy.deepcopy(doc)
    for _ in range(draw(st.integers(1, 3))):
        _apply(out, draw(st.sampled_from(paths)), draw(st.sampled_from(OPS)),
               draw(st.sampled_from(BAD_VALUES)))
    return out


# -- the loaders the command line uses --------------------------------------------------------

def _load_case_file(path: Path) -> None:
    from formsync_design.tomlio import load_toml
    from formsync_design.verify.agentcase import case_is_agent, load_agent_case
    from formsync_design.verify.case import load_case
    from formsync_design.verify.enginecase import load_engine_case
    from formsync_design.verify.engineform import design_form

    data = load_toml(path, "case TOML file")
    load_engine_case(path)  # formsync verify
    if design_form(data, str(path)) is None:  # the base case, as the other commands read it
        (load_agent_case if case_is_agent(path) else load_case)(path)


def _load_campaign_file(path: Path) -> None:
    from formsync_design.sweep import load_campaign

    load_campaign(path)


def _load_graph_file(path: Path) -> None:
    from formsync_design.graphs.theorem import load_graph

    load_graph(str(path))


def _check(load: Any, path: Path, root: Path) -> None:
    """``load(path)`` succeeds or raises a one-line bad-input error; no file appears."""
    before = sorted(p.name for p in root.rglob("*"))
    try:
        load(path)
    except FormsyncError as e:
        assert isinstance(e, ValueError), f"{type(e).__name__} (exit 3) for bad input: {e}"
        msg = str(e)
        assert msg and "\n" not in msg, f"not one line: {msg!r}"
        assert "Traceback" not in msg
    assert sorted(p.name for p in root.rglob("*")) == before, "a file was created"
    assert not (root / "PWNED").exists()


def _fuzz(name: str, text: str, load: Any, loads: Any, tmp: Path, examples: int,
          companions: dict[str, str] | None = None) -> None:
    doc = tomllib.loads(text)
    work = tmp / f"fuzz-{name}"
    work.mkdir()
    for other, body in (companions or {}).items():
        (work / other).write_text(body, encoding="utf-8")

    @settings(max_examples=examples, derandomize=True, deadline=None, database=None,
              suppress_health_check=list(HealthCheck))
    @given(mutated(doc))
    def run(m: dict) -> None:
        p = work / name
        p.write_text(loads(m), encoding="utf-8")
        _check(load, p, work)
        p.unlink()

    run()


def _companions(name: str) -> dict[str, str]:
    return {}


@pytest.fixture
def in_tmp(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    return tmp_path


@pytest.mark.parametrize("name", CASES)
def test_fuzzed_cases(in_tmp, name):
    _fuzz(name, (VERIFICATION / name).read_text(), _load_case_file, to_toml, in_tmp, 12,
          _companions(name))


@pytest.mark.parametrize("name", CAMPAIGNS)
def test_fuzzed_campaigns(in_tmp, name):
    _fuzz(name, (VERIFICATION / name).read_text(), _load_campaign_file, to_toml, in_tmp, 12)


EDGES = "# n = 5\n1 4 0.58\n2 3 0.33\n2 5 0.11\n3 2 0.25\n4 1 0.21\n4 3 0.4\n5 1 0.37\n1 0 1\n"


@st.composite
def mutated_lines(draw: Any, text: str) -> str:
    lines = text.splitlines()
    for _ in range(draw(st.integers(1, 3))):
        k = draw(st.integers(0, len(lines) - 1))
        tokens = lines[k].split()
        op = draw(st.sampled_from(("token", "delete", "append")))
        bad = str(draw(st.sampled_from(BAD_VALUES)))
        if op == "delete" and len(lines) > 1:
            del lines[k]
        elif op == "append":
            lines.append(f"{draw(st.integers(-2, 7))} {draw(st.integers(-1, 7))} {bad}")
        elif tokens:
            tokens[draw(st.integers(0, len(tokens) - 1))] = bad
            lines[k] = " ".join(tokens)
    return "\n".join(lines) + "\n"


def _fuzz_graph(tmp: Path, examples: int) -> None:
    work = tmp / "fuzz-graph"
    work.mkdir()

    @settings(max_examples=examples, derandomize=True, deadline=None, database=None,
              suppress_health_check=list(HealthCheck))
    @given(mutated_lines(EDGES), st.sampled_from(("g.txt", "g.csv")))
    def run(text: str, fname: str) -> None:
        p = work / fname
        p.write_text(text if fname.endswith(".txt") else text.replace(" ", ","),
                     encoding="utf-8")
        _check(_load_graph_file, p, work)
        p.unlink()

    run()


def test_fuzzed_graph_file(in_tmp):
    _fuzz_graph(in_tmp, 40)


# -- a few through the command line ---------------------------------------------------------

@pytest.mark.parametrize("name, argv", [
    ("selftrigger_mrp.toml", ["simulate", "--case", "{p}", "--tf", "0.2", "--figures", "none"]),
    ("sweep_pd_atlas5.toml", ["sweep", "--campaign", "{p}", "--out", "{out}"]),
])
def test_fuzzed_files_through_the_cli(in_tmp, capsys, name, argv):
    from formsync_design.cli import main

    doc = tomllib.loads((VERIFICATION / name).read_text())
    work = in_tmp / "cli"
    work.mkdir()
    # mutations that stop at the reader (a successful run would be a full simulation/sweep)
    injected = [("reference", "rate", 0), ("gains", "r"), ("campaign", "graphs"),
                ("box", 0, "k_p"), ("montecarlo", "runs"), ("graph", "arcs", 0, 2)]

    # an engine case's own tables ([montecarlo], ...) are read by formsync verify, not by the
    # commands that read its base case (verify/agentcase.py sets them aside)
    from formsync_design.verify.agentcase import ENGINE_TABLES

    engine = doc.get("case", {}).get("kind") == "engine"

    @settings(max_examples=6, derandomize=True, deadline=None, database=None,
              suppress_health_check=list(HealthCheck))
    @given(st.sampled_from([p for p in injected if _has(doc, p)
                            and not (engine and p[0] in ENGINE_TABLES)]),
           st.sampled_from([v for v in BAD_VALUES if not isinstance(v, (int, float))
                            or isinstance(v, bool) or v != v or abs(v) > 1e15]))
    def run(path: tuple, value: Any) -> None:
        m = copy.deepcopy(doc)
        _apply(m, path, "replace", value)
        p = work / name
        p.write_text(to_toml(m), encoding="utf-8")
        before = sorted(x.name for x in work.rglob("*"))
        rc = main([a.format(p=p, out=work / "out") for a in argv])
        err = capsys.readouterr().err.strip()
        assert rc in (0, 1, 2), err
        assert "Traceback" not in err and len(err.splitlines()) <= 1, err
        assert sorted(x.name for x in work.rglob("*")) == before
        assert not (in_tmp / "PWNED").exists()

    run()


def _has(doc: Any, path: tuple) -> bool:
    node = doc
    for k in path:
        try:
            node = node[k]
        except (KeyError, IndexError, TypeError):
            return False
    return True


# -- engine tables ---------------------------------------------------------------------------

#: Values that reach the engine tables' own checks (names, indices, specs, predicates).
ENGINE_VALUES: list[Any] = [
    "relative_convergence_time", "peak_torque", "tail_omega_m", "no_such_metric", "ring8",
    "nowhere", "", " ", "ring:2000", "ring:2001", "dir:3", "complete:2", "atlas:2..3",
    "t_ring8 <= 150", "1 == 1", "t_ring8 <=", "not", "(", "t_ring8 <= \u09ea", "x" * 5000,
    99, -1, 0, 3, 2**31, [1, 99], {"spacecraft": 99}, {"tf": -1}, {"torque_limit": math.nan},
    "holds", "fails", "proof", "certificate",
]


def _engine_paths(doc: dict) -> list[tuple]:
    from formsync_design.verify.agentcase import ENGINE_TABLES

    return [p for p in _paths(doc) if p[0] in ENGINE_TABLES]


@st.composite
def engine_mutated(draw: Any, doc: dict) -> dict:
    paths = _engine_paths(doc)
    out = copy.deepcopy(doc)
    for _ in range(draw(st.integers(1, 3))):
        _apply(out, draw(st.sampled_from(paths)), draw(st.sampled_from(OPS)),
               draw(st.sampled_from(BAD_VALUES + ENGINE_VALUES)))
    return out


def _load_engine(path: Path) -> None:
    from formsync_design.verify.enginecase import load_engine_case

    load_engine_case(path)


def _fuzz_engine(name: str, tmp: Path, examples: int) -> None:
    doc = tomllib.loads((VERIFICATION / name).read_text(encoding="utf-8"))
    work = tmp / f"engine-{name}"
    work.mkdir()

    @settings(max_examples=examples, derandomize=True, deadline=None, database=None,
              suppress_health_check=list(HealthCheck))
    @given(engine_mutated(doc))
    def run(m: dict) -> None:
        p = work / name
        p.write_text(to_toml(m), encoding="utf-8")
        _check(_load_engine, p, tmp)
        p.unlink()

    run()


@pytest.mark.parametrize("name", ENGINE_CASES)
def test_fuzzed_engine_tables(in_tmp, name):
    _fuzz_engine(name, in_tmp, 10)


# -- predicates ------------------------------------------------------------------------------

#: The metric ids the fuzzed predicates may name, with their kinds.
KINDS = {"a": "number", "t_ring8": "number", "b2": "number", "verdict": "text"}
TOKENS = [
    "a", "t_ring8", "b2", "verdict", "zz", "_x", "A", "and", "or", "not", "AND", "Not", "<",
    "<=", ">", ">=", "==", "!=", "=", "=>", "<>", "+", "-", "*", "/", "**", "//", "%", "(", ")",
    "[", "]", ".", ",", ";", "@", "'", '"', '"holds"', '"fails"', '"', "\\", "0", "1", "-1",
    "1.5", "1e400", "-1e400", "1e-400", "nan", "inf", "-inf", "NaN", "Infinity", "0x1F", "1_000",
    "10" * 40, ".5", "5.", "1e", "+1", "\u09ea", "\uff18", "\u0663", "\u00b2", "\u2155",
    "\u2212", "\u00a0", "\u200b", "\u0430", "\U0001d7d8", "__import__('os')", "a.real",
    "f(a)", "lambda: 1", "a < b2 < 1", "\n", "\t", "\x00",
]


def _number_text(x: float) -> str:
    return repr(x)


_atom = st.one_of(
    st.sampled_from(["a", "t_ring8", "b2", "verdict", '"holds"', '"x y"', "0", "1e-300", "1e300"]),
    st.floats(-1e6, 1e6).map(_number_text),
    st.integers(-(10**6), 10**6).map(str),
)
_sum = st.recursive(_atom, lambda inner: st.one_of(
    st.tuples(inner, st.sampled_from(["+", "-", "*", "/"]), inner).map(" ".join),
    inner.map(lambda x: f"-{x}"), inner.map(lambda x: f"({x})")), max_leaves=4)
_compare = st.tuples(_sum, st.sampled_from(["<", "<=", ">", ">=", "==", "!="]), _sum).map(
    " ".join)
#: Predicates of the grammar (most parse; the kinds decide the rest), and the same with one
#: token of the soup inserted somewhere.
grammatical = st.recursive(_compare, lambda inner: st.one_of(
    st.tuples(inner, st.sampled_from(["and", "or"]), inner).map(" ".join),
    inner.map(lambda x: f"not {x}"), inner.map(lambda x: f"({x})")), max_leaves=5)
spoiled = st.tuples(grammatical, st.integers(0, 200), st.sampled_from(TOKENS)).map(
    lambda t: t[0][: t[1]] + t[2] + t[0][t[1]:])

predicate_texts = st.one_of(
    grammatical,
    grammatical,
    spoiled,
    st.text(max_size=80),
    st.text(alphabet=string.printable, max_size=80),
    st.lists(st.one_of(st.sampled_from(TOKENS),
                       st.floats(allow_nan=True, allow_infinity=True).map(_number_text),
                       st.integers(-(10**30), 10**30).map(str)),
             max_size=12).flatmap(
        lambda toks: st.sampled_from((" ", "")).map(lambda sep: sep.join(toks))),
)

interval_values = st.one_of(
    st.none(),
    st.tuples(st.floats(allow_nan=True), st.floats(allow_nan=True)),
    st.text(max_size=8),
)


def _values(draw_values: dict) -> dict:
    from formsync_design.verify.predicates import Interval

    out: dict[str, Any] = {}
    for k, kind in KINDS.items():
        v = draw_values.get(k)
        if kind == "number":
            out[k] = Interval(*v) if isinstance(v, tuple) else None
        else:
            out[k] = v if isinstance(v, str) else None
    return out


def _fuzz_predicates(examples: int) -> None:
    from formsync_design.verify.predicates import evaluate, parse_predicate

    @settings(max_examples=examples, derandomize=True, deadline=None, database=None,
              suppress_health_check=list(HealthCheck))
    @given(predicate_texts, st.fixed_dictionaries({k: interval_values for k in KINDS}))
    def run(text: str, vals: dict) -> None:
        try:
            node = parse_predicate(text, KINDS, "claim c's predicate")
        except FormsyncError as e:
            assert isinstance(e, ValueError), f"{type(e).__name__} (exit 3) for {text!r}: {e}"
            msg = str(e)
            assert msg and "\n" not in msg, f"not one line for {text!r}: {msg!r}"
            return
        out = evaluate(node, _values(vals))
        assert out.verdict in ("holds", "fails", "undecided"), (text, out)
        assert set(out.deciding) <= set(KINDS), (text, out)

    run()


def test_fuzzed_predicates():
    _fuzz_predicates(200)


# -- paths -----------------------------------------------------------------------------------

#: Path values a stranger's file may hold (none with a name over 255 bytes: see the module
#: docstring and test_a_name_over_the_system_limit_in_a_data_file below).
PATH_VALUES = [
    "..", "../..", "../" * 40 + "x", "../../../../../../etc/passwd", "/etc/passwd", "/", "/tmp",
    "/nonexistent/g.txt", "/dev/null", "/proc/self/status", "g.txt\x00.py", "\x00", "~/g.txt",
    ".", "./", "g.txt/", "x" * 255, ("x" * 200 + "/") * 15 + "g.txt", "\u00e9/\u00fc.txt",
    "\u202e\u0074\u0078\u0074.py", "C:\\graphs\\g.txt", "con", "nul", "ring:8/../g.txt",
    "file:///etc/passwd", "\\\\server\\share", " g.txt", "g.txt ", "-g.txt", "*", "?",
    "../sibling/ma_so3", "ma_so3.py/..", "liang2016/../liang2016",
]
path_values = st.one_of(
    st.sampled_from(PATH_VALUES),
    st.text(max_size=60),
    st.lists(st.sampled_from(["..", ".", "", "x", "\u00fc", "\x00", "g.txt", "e.py", "x" * 200,
                              "\u0663"]), min_size=1, max_size=8).map("/".join),
    st.lists(st.sampled_from(["..", "x", "\u00fc"]), min_size=1, max_size=6).map(
        lambda parts: "/" + "/".join(parts)),
)

#: (file, its loader, where in the document the path goes)
PATH_TARGETS = [
    ("pd_consensus.toml", _load_case_file, ("case", "graph")),
    ("pd_consensus.toml", _load_case_file, ("case", "design")),
    ("liang2016.toml", _load_engine, ("formations", 1, "graph")),
    ("selftrigger_mrp.toml", _load_engine, ("formations", 0, "graph")),
    ("sweep_pd_atlas5.toml", _load_campaign_file, ("campaign", "graphs", 1)),
    ("sweep_pd_atlas5.toml", _load_campaign_file, ("montecarlo", "case")),
    ("sweep_pd_atlas5.toml", _load_campaign_file, ("campaign", "design")),
]


def _set(doc: dict, where: tuple, value: Any) -> None:
    node: Any = doc
    for k in where[:-1]:
        node = node[k]
    node[where[-1]] = value


def _fuzz_paths(target: tuple, tmp: Path, examples: int) -> None:
    name, load, where = target
    doc = tomllib.loads((VERIFICATION / name).read_text(encoding="utf-8"))
    work = tmp / "paths" / "case"
    work.mkdir(parents=True)

    @settings(max_examples=examples, derandomize=True, deadline=None, database=None,
              suppress_health_check=list(HealthCheck))
    @given(path_values)
    def run(value: str) -> None:
        m = copy.deepcopy(doc)
        _set(m, where, value)
        p = work / name
        p.write_text(to_toml(m), encoding="utf-8")
        _check(load, p, tmp)
        p.unlink()

    run()


@pytest.mark.parametrize("target", PATH_TARGETS, ids=lambda t: f"{t[0]}:{'.'.join(map(str, t[2]))}")
def test_fuzzed_paths(in_tmp, target):
    _fuzz_paths(target, in_tmp, 25)


def test_a_name_over_the_system_limit_in_a_data_file(in_tmp):
    """A name over 255 bytes in a data file is a one-line bad input, never an OSError
    (ENAMETOOLONG from Path.is_file, which the loaders let through before)."""
    doc = tomllib.loads((VERIFICATION / "pd_consensus.toml").read_text(encoding="utf-8"))
    doc["case"]["graph"] = "x" * 300
    p = in_tmp / "c.toml"
    p.write_text(to_toml(doc), encoding="utf-8")
    with pytest.raises(FormsyncError) as e:
        _load_case_file(p)
    assert isinstance(e.value, ValueError) and "\n" not in str(e.value)


# -- the larger run ----------------------------------------------------------------------------

@pytest.mark.slow
@pytest.mark.parametrize("name", CASES + CAMPAIGNS)
def test_fuzzed_readers_many_examples(in_tmp, name):
    load = _load_campaign_file if name.startswith("sweep") else _load_case_file
    _fuzz(name, (VERIFICATION / name).read_text(), load, to_toml, in_tmp, 300,
          _companions(name))


@pytest.mark.slow
def test_fuzzed_graph_file_many_examples(in_tmp):
    _fuzz_graph(in_tmp, 1000)


@pytest.mark.slow
@pytest.mark.parametrize("name", ENGINE_CASES)
def test_fuzzed_engine_tables_many_examples(in_tmp, name):
    _fuzz_engine(name, in_tmp, 200)


@pytest.mark.slow
def test_fuzzed_predicates_many_examples():
    _fuzz_predicates(5000)


@pytest.mark.slow
@pytest.mark.parametrize("target", PATH_TARGETS, ids=lambda t: f"{t[0]}:{'.'.join(map(str, t[2]))}")
def test_fuzzed_paths_many_examples(in_tmp, target):
    _fuzz_paths(target, in_tmp, 400)
