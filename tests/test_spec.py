"""Specifications as values: content keys, Spec.from_functions, and one-line errors for
every malformed specification (exit 2 from the CLI, no traceback, no output folder)."""

from __future__ import annotations

import hashlib
from pathlib import Path

import pytest
import sympy as sp

from formsync_design.cli.main import main
from formsync_design.errors import DerivationError, InputError
from formsync_design.spec.lagrangian_view import ControllerView, LyapunovView
from formsync_design.spec.loader import Spec, default_spec_path, load_spec

DATA = Path(__file__).parent / "data"


def _paper_controller(v):
    tau = v.qd + v.beta * v.s
    return v.Q.I.T * ((v.B - v.K_o * v.A) * v.qd - v.K_q * v.A * v.s - v.K_v * v.A * v.sw(tau))


def _paper_lyapunov(v):
    c = (v.K_q + v.beta * v.K_o) / 4
    return (c * sum((e.dot(e) for e in v.edges), 0) + v.qd.dot(v.qd) / 2
            + v.beta * sum((e.dot(v.qd) for e in v.edges), 0))


# -- the value contract ------------------------------------------------------------------


def test_file_key_is_the_sha256_of_its_bytes():
    spec = load_spec(None)
    assert spec.key == hashlib.sha256(default_spec_path().read_bytes()).hexdigest()
    assert spec.source == spec.path == str(default_spec_path())
    assert load_spec(spec) is spec
    assert load_spec(Path(spec.path)).key == spec.key


def test_same_bytes_elsewhere_same_key_other_bytes_other_key(tmp_path):
    paper = default_spec_path().read_bytes()
    a = tmp_path / "copy.py"
    a.write_bytes(paper)
    b = tmp_path / "edited.py"
    b.write_bytes(paper + b"\n# a comment changes the content\n")
    assert load_spec(a).key == load_spec(None).key
    assert load_spec(b).key != load_spec(None).key


def test_file_edited_in_place_is_reloaded(tmp_path):
    """A cache keyed by path would return the stale design; the content key does not."""
    p = tmp_path / "design.py"
    p.write_text(default_spec_path().read_text())
    first = load_spec(p)
    p.write_text((DATA / "controller_variant_spec.py").read_text())
    second = load_spec(p)
    assert second.key != first.key and second.name == "double-kq"


def test_from_functions_is_a_spec_with_a_content_key():
    s1 = Spec.from_functions(_paper_controller, _paper_lyapunov, name="inline")
    s2 = Spec.from_functions(_paper_controller, _paper_lyapunov, name="inline")
    assert s1.source == s1.path == "<python>" and s1.title == "inline"
    assert s1.key == s2.key and len(s1.key) == 64
    assert load_spec(s1) is s1

    def other_controller(v):
        return v.Q.I.T * ((v.B - v.K_o * v.A) * v.qd - 3 * v.K_q * v.A * v.s)

    s3 = Spec.from_functions(other_controller, _paper_lyapunov, name="inline")
    assert s3.key != s1.key


def test_from_functions_closures_with_different_values_get_different_keys():
    """Same source text, different captured gain: the evaluated expressions tell them apart."""

    def make(k):
        def controller(v):
            return v.Q.I.T * ((v.B - v.K_o * v.A) * v.qd - k * v.K_q * v.A * v.s)

        return controller

    a = Spec.from_functions(make(2), _paper_lyapunov)
    b = Spec.from_functions(make(3), _paper_lyapunov)
    assert a.key != b.key


def test_from_functions_without_source_uses_a_unique_token():
    ctrl = eval("lambda v: v.Q.I.T * (v.B * v.qd - v.K_q * v.A * v.s)")  # no source file
    lyap = eval("lambda v: v.qd.dot(v.qd) / 2")
    a = Spec.from_functions(ctrl, lyap)
    ctrl2 = eval("lambda v: v.Q.I.T * (v.B * v.qd - v.K_q * v.A * v.s)")
    b = Spec.from_functions(ctrl2, lyap)
    assert a.key == Spec.from_functions(ctrl, lyap).key  # stable per object
    assert a.key != b.key  # another object: never silently shared


def test_inline_spec_derives_like_the_file():
    from formsync_design.derive.closed_loop import derive_closed_loop

    inline = Spec.from_functions(_paper_controller, _paper_lyapunov, name="inline")
    a = derive_closed_loop(inline)
    b = derive_closed_loop(load_spec(None))
    assert (a.c_qd, a.c_s, a.c_sigma) == (b.c_qd, b.c_s, b.c_sigma)


def test_load_spec_rejects_other_types():
    with pytest.raises(InputError, match="received a int"):
        load_spec(3)  # type: ignore[arg-type]
    with pytest.raises(InputError, match="no such file"):
        load_spec("does/not/exist.py")


# -- malformed specifications: one line naming the file, the function, what was expected --

BAD = {
    "bad_spec_import_error.py": ("import", "RuntimeError"),
    "bad_spec_no_controller.py": ("function controller(view)", "received none"),
    "bad_spec_shape.py": ("controller(view)", "shape (3, 3)"),
    "bad_spec_attribute.py": ("controller(view)", "view.omega"),
    "bad_spec_unknown_symbol.py": ("lyapunov(view)", "gamma"),
    "bad_spec_name_error.py": ("controller(view)", "K_extra"),
    "bad_spec_raises.py": ("lyapunov(view)", "IndexError"),
}


@pytest.mark.parametrize("name", sorted(BAD))
def test_bad_spec_is_one_line_derivation_error(name):
    path = DATA / name
    with pytest.raises(DerivationError) as ei:
        load_spec(path)
    msg = str(ei.value)
    assert "\n" not in msg
    assert str(path) in msg and "expected" in msg
    for part in BAD[name]:
        assert part in msg, msg


def _write_bad(tmp_path: Path, kind: str) -> Path:
    p = tmp_path / f"{kind}.py"
    if kind == "syntax":
        p.write_text("def controller(v)\n    return v.qd\n")
    elif kind == "latin1":
        p.write_bytes("# d\xe9sign\ndef controller(v):\n    return v.qd\n".encode("latin-1"))
    elif kind == "binary":
        p.write_bytes(bytes(range(256)))
    elif kind == "nul":
        p.write_bytes(b"def controller(v):\x00\n")
    return p


@pytest.mark.parametrize("kind,needle", [("syntax", "syntax error at line 1"),
                                         ("latin1", "non-UTF-8"), ("binary", "non-UTF-8"),
                                         ("nul", "binary")])
def test_unreadable_spec_is_one_line(tmp_path, kind, needle):
    p = _write_bad(tmp_path, kind)
    with pytest.raises(DerivationError) as ei:
        load_spec(p)
    msg = str(ei.value)
    assert "\n" not in msg and str(p) in msg and needle in msg


def test_lyapunov_returning_a_vector_is_refused():
    with pytest.raises(DerivationError, match="lyapunov\\(view\\): expected a scalar"):
        Spec.from_functions(_paper_controller, lambda v: v.qd)


def test_controller_returning_a_number_is_refused():
    with pytest.raises(DerivationError, match="expected a 3x1 matrix expression, received a int"):
        Spec.from_functions(lambda v: 0, _paper_lyapunov)


def test_views_provide_what_the_docstring_says():
    v = ControllerView()
    for name in ("A", "B", "Q", "qd", "s", "K_o", "K_q", "beta", "K_v"):
        assert getattr(v, name) is not None
    lv = LyapunovView(3)
    assert len(lv.edges) == 3 and lv.s == lv.edges[0] + lv.edges[1] + lv.edges[2]
    assert isinstance(lv.qd, sp.Matrix)


# -- the CLI: exit 2, one line on stderr, no traceback, nothing written --------------------

COMMANDS = [
    ["derive", "--graph", "ring:4"],
    ["simulate", "--tf", "1", "--no-compile"],
    ["montecarlo", "--runs", "1", "--tf", "1", "--no-compile", "--no-certify"],
]


@pytest.mark.parametrize("cmd", COMMANDS, ids=lambda c: c[0])
@pytest.mark.parametrize("name", ["bad_spec_attribute.py", "bad_spec_import_error.py",
                                  "bad_spec_shape.py"])
def test_cli_bad_spec_exit_2_one_line_no_output(tmp_path, capsys, cmd, name):
    out = tmp_path / "out"
    rc = main([*cmd, "--spec", str(DATA / name), "--out", str(out)])
    cap = capsys.readouterr()
    err = cap.err.strip()
    assert rc == 2
    errors = [ln for ln in err.splitlines() if ": error: " in ln]  # after the design-code line
    assert len(errors) == 1 and "Traceback" not in err and name in errors[0]
    assert not out.exists()


def test_cli_binary_spec_exit_2(tmp_path, capsys):
    p = _write_bad(tmp_path, "binary")
    assert main(["derive", "--graph", "ring:4", "--spec", str(p)]) == 2
    err = capsys.readouterr().err.strip()
    errors = [ln for ln in err.splitlines() if ": error: " in ln]  # after the design-code line
    assert len(errors) == 1 and "non-UTF-8" in errors[0]


# -- one design, two views: an agent design file that also provides its Lagrangian view ----

_DUAL = '''FORM = "agent"
NAME = "dual"
GAINS = {"K_o": {}, "K_q": {}, "beta": {}, "K_v": {"role": "switching"}}


def controller(v):
    return -v.K_o * v.w
'''
_LAG = '''

def lagrangian_controller(v):
    return v.Q.I.T * ((v.B - v.K_o * v.A) * v.qd - v.K_q * v.A * v.s
                      - v.K_v * v.A * v.sw(v.qd + v.beta * v.s))
'''
_LYA = '''

def lyapunov(v):
    return v.qd.dot(v.qd) / 2
'''


def test_a_design_file_gives_its_agent_form_and_its_lagrangian_view(tmp_path):
    from formsync_design.spec.loader import lagrangian_view, load_design

    p = tmp_path / "dual.py"
    p.write_text(_DUAL + _LAG + _LYA)
    d = load_design(p)
    view = load_spec(p)
    assert d.form == "agent" and isinstance(view, Spec) and view is d.lagrangian
    assert lagrangian_view(d) is view and lagrangian_view(view) is view
    assert view.name == d.name == "dual" and view.key == d.key == hashlib.sha256(
        p.read_bytes()).hexdigest()
    # one GAINS table: K_v is the view's switching gain and a controller gain of the agent form
    assert view.decl.switching == "K_v" and view.gains == ("K_o", "K_q", "beta")
    assert d.gains == ("K_o", "K_q", "beta", "K_v")
    assert lagrangian_view(load_design("ma_so3")) is None


@pytest.mark.parametrize("body, needle", [
    (_DUAL + _LAG, "expected a function lyapunov(view) for the design's Lagrangian view"),
    (_DUAL + "\n\ndef lagrangian_controller(v):\n    return v.A\n" + _LYA,
     "controller(view): expected a 3x1 matrix expression, received shape (3, 3)"),
    (_DUAL + _LYA, "GAINS['K_v'].role: expected 'controller' or 'multiplier' in an agent design"),
])
def test_a_malformed_lagrangian_view_is_one_line(tmp_path, body, needle):
    from formsync_design.spec.loader import load_design

    p = tmp_path / "bad_dual.py"
    p.write_text(body)
    with pytest.raises(DerivationError) as e:
        load_design(p)
    assert needle in str(e.value) and "\n" not in str(e.value)


def test_the_shipped_designs_are_one_file_with_both_views():
    from formsync_design.resources import design_names
    from formsync_design.spec.loader import load_design

    assert "liang2016_agent" not in design_names()
    for name in ("liang2016", "pd_consensus"):
        d = load_design(name)
        assert d.form == "agent" and load_spec(name) is d.lagrangian
        assert load_spec(name).controller.__name__ == "lagrangian_controller"
