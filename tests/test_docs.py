"""The documentation's own code: the tutorial's design file works as the page says, the API
reference lists exactly ``formsync_design.__all__``, and the command reference's parser is
``formsync``'s with only its texts made literal.  (The Sphinx build itself runs in ``.ci/run``
with warnings as errors.)"""

from __future__ import annotations

import argparse
import importlib.util
import re
import sys
from pathlib import Path

import numpy as np
import pytest

import formsync_design as fs
from formsync_design.cli.main import build_parser, main
from formsync_design.spec.loader import load_design

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
TUTORIAL = DOCS / "tutorial" / "my_design.py"


@pytest.fixture(autouse=True)
def _vm(monkeypatch):
    monkeypatch.setenv("FORMSYNC_NO_COMPILE", "1")  # CasADi's VM: no C compiler needed


def test_tutorial_design_loads_with_its_declarations():
    d = load_design(TUTORIAL)
    assert d.form == "agent" and d.name == "my_design" and d.representation == "mrp"
    assert d.decl.controller_gains == ("k_1", "k_2")
    assert d.has("monitors") and callable(d.module.get("conditions"))


def test_tutorial_certificate_is_derived_and_decides_boxes():
    d = load_design(TUTORIAL)
    conds = fs.agent_conditions(d, "path:3")  # in-degrees 1 and 2: both derivations run
    assert [f.name for f in conds.families] == ["reaching: V' = -k_2 |s|^2 at d = 0",
                                                "surface gain"]
    box = {"k_1": "0.05:1", "k_2": "0.05:1"}
    assert str(fs.certify_box(conds, box).status) == "certified"
    # the families are k_2 and k_1: their least value on the box is 1/20, so a margin above it
    # is refuted at the vertex k_1 = k_2 = 1/20
    assert str(fs.certify_box(conds, box, margin="1/20").status) != "certified"
    assert str(fs.certify_box(conds, box, margin="1/10").status) == "refuted"


def test_tutorial_certificate_refuses_a_law_that_breaks_the_identity(tmp_path):
    # the same file with the reaching term's gain doubled in the law: s' = -2 k_2 s, and the
    # hook's check of s' = -k_2 s + J^-1 d must refuse it (one line, exit 2)
    src = TUTORIAL.read_text().replace("v.J * (v.k_1 * ed + v.k_2 * s)",
                                       "v.J * (v.k_1 * ed + 2 * v.k_2 * s)")
    assert "2 * v.k_2 * s" in src
    bad = tmp_path / "broken_design.py"
    bad.write_text(src)
    d = load_design(bad)
    with pytest.raises(fs.DerivationError, match="s' is not -k_2 s"):
        fs.agent_conditions(d, "path:2")


def _mrp(q: np.ndarray) -> np.ndarray:
    """Short-set MRPs of (..., 4) quaternions ``(q1, q2, q3, q0)``."""
    q = np.where(q[..., 3:4] < 0, -q, q)
    return q[..., :3] / (1 + q[..., 3:4])


def test_tutorial_simulate_command_and_the_sliding_variable_decays_at_rate_k2(tmp_path, capsys):
    # the page's command, in-process, disturbance-free: s_i = w_i + k_1 e_i must obey
    # s_i' = -k_2 s_i exactly, i.e. |s_i(t)| = |s_i(0)| exp(-k_2 t), checked on the written
    # trajectory with the consensus error computed here from the ring's Laplacian
    out = tmp_path / "run"
    rc = main(["simulate", "--design", str(TUTORIAL), "--gain", "k_1=1", "--gain", "k_2=0.5",
               "--tf", "20", "--disturbance", "none", "--out", str(out), "--figures", "none"])
    text = capsys.readouterr().out
    assert rc in (0, 1), text
    assert "design my_design (mrp)" in text and "graph ring:8" in text
    z = np.load(out / "trajectory.npz")
    t, q, w = z["t"], z["quaternions"], z["rates"]
    assert q.shape[1] == 8 and t[-1] == pytest.approx(20.0)
    n = q.shape[1]
    A = np.zeros((n, n))
    for i in range(n):
        A[i, (i + 1) % n] = A[i, (i - 1) % n] = 1.0
    L = np.diag(A.sum(axis=1)) - A
    s = w + 1.0 * np.einsum("ij,tjk->tik", L, _mrp(q))
    norm = np.linalg.norm(s, axis=2)
    assert np.all(norm[0] > 1e-2)  # a real initial sliding error on every spacecraft
    predicted = norm[0][None, :] * np.exp(-0.5 * t)[:, None]
    np.testing.assert_allclose(norm, predicted, rtol=1e-5)


def test_api_reference_lists_exactly_the_public_names():
    text = (DOCS / "api.rst").read_text()
    listed = re.findall(r"^   ([A-Za-z_]\w*)$", text, re.M)
    assert len(listed) == len(set(listed)), "a name is listed twice in docs/api.rst"
    public = set(fs.__all__) - {"__version__"}
    assert not public - set(listed), f"missing from docs/api.rst: {sorted(public - set(listed))}"
    assert not set(listed) - public, f"not in fs.__all__: {sorted(set(listed) - public)}"


def _reference_parser() -> argparse.ArgumentParser:
    spec = importlib.util.spec_from_file_location("cli_reference", DOCS / "_ext" / "cli_reference.py")
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    sys.modules.setdefault("cli_reference", mod)
    spec.loader.exec_module(mod)
    return mod.reference_parser()


def _texts(p: argparse.ArgumentParser) -> dict[str, object]:
    subs = [a for a in p._actions if isinstance(a, argparse._SubParsersAction)]
    return {
        "options": [(tuple(a.option_strings), a.dest, a.default, a.choices) for a in p._actions
                    if not isinstance(a, argparse._SubParsersAction)],
        "helps": [a.help for a in p._actions],
        "description": p.description,
        "subcommands": {name: _texts(sp) for a in subs for name, sp in a.choices.items()},
    }


def _unescape(x: object) -> object:
    if isinstance(x, str):
        if x.startswith("::\n\n"):  # a literal block: the text, re-wrapped
            return " ".join(line.strip() for line in x[4:].splitlines() if line.strip())
        return re.sub(r"\\(.)", r"\1", x)
    if isinstance(x, list):
        return [_unescape(v) for v in x]
    if isinstance(x, dict):
        return {k: _unescape(v) for k, v in x.items()}
    return x


def _normalised(x: object) -> object:
    if isinstance(x, str):
        return " ".join(x.split())
    if isinstance(x, list):
        return [_normalised(v) for v in x]
    if isinstance(x, dict):
        return {k: _normalised(v) for k, v in x.items()}
    return x


def test_command_reference_parser_is_formsyncs_with_the_same_texts():
    ref, real = _texts(_reference_parser()), _texts(build_parser())
    assert set(ref["subcommands"]) == {"derive", "certify", "region", "design", "simulate",
                                       "montecarlo", "sweep", "verify"}
    assert _normalised(_unescape(ref)) == _normalised(real)
    # and the markup characters of the terminal texts are escaped for reStructuredText
    trigger = next(a.help for a in _reference_parser()._subparsers._group_actions[0]
                   .choices["simulate"]._actions if "--trigger" in a.option_strings)
    assert r"\|q\_i - qhat\_i\|" in trigger


_INCLUDE = re.compile(r"^```\{include\} (\S+)\n((?::[\w-]+:.*\n)*)```", re.M)


def test_every_included_section_marker_is_found_once():
    # the guide includes README/ARCHITECTURE sections between headings: a renamed heading
    # breaks the build (-W); this names the page and the marker instead
    checked = 0
    for page in sorted(DOCS.rglob("*.md")):
        if "_build" in page.parts or page.parts[len(DOCS.parts)] == "reports":
            continue
        for target, options in _INCLUDE.findall(page.read_text()):
            text = (page.parent / target).resolve().read_text()
            for key, value in re.findall(r"^:(start-after|end-before): (.*)$", options, re.M):
                marker = value.strip()
                if marker.startswith('"') and marker.endswith('"'):
                    marker = marker[1:-1].replace('\\"', '"')
                n = text.count(marker)
                assert n == 1, f"{page.relative_to(ROOT)}: {key} {marker!r} occurs {n} times in {target}"
                checked += 1
    assert checked > 20


def test_tutorial_verify_prints_what_the_page_shows_and_its_findings_are_true(tmp_path, capsys):
    """The page's `formsync verify` block is the command's real output, and the two failing
    claims are true findings: checked here without the engine - the path of six simulated on
    its own does not converge by the horizon, and the ring's run has a torque above 5 N m."""
    from formsync_design.sim.agents import simulate_agents
    from formsync_design.verify.agentcase import load_agent_case

    case_path = DOCS / "tutorial" / "my_design.toml"
    rc = main(["verify", str(case_path), "--out", str(tmp_path / "o"),
               "--trust-design", str(case_path.with_name("my_design.py"))])
    out = capsys.readouterr().out
    assert rc == 0, out
    page = (DOCS / "tutorial" / "index.md").read_text(encoding="utf-8")
    block = page.split("formsync verify docs/tutorial/my_design.toml --trust-design "
                       "docs/tutorial/my_design.py --out out/my_design")[1]
    shown = block.split("```text\n", 1)[1].split("```", 1)[0].splitlines()[1:]
    assert [ln.rstrip() for ln in out.splitlines()[1:]] == [ln.rstrip() for ln in shown]
    base = load_agent_case(case_path, trust=[case_path.with_name("my_design.py")])
    ring = simulate_agents(base.design, base.formation(), base.options)
    assert ring.convergence_time is not None and ring.convergence_time < 40
    assert float(np.max(np.abs(ring.torques))) > 5
    path = base.cycled(6)
    run = simulate_agents(base.design, path.formation("path:6"), path.options)
    assert run.t[-1] == pytest.approx(60.0)
    assert run.convergence_time is None  # not converged by tf = 60 s
