"""Valid inputs that were refused (issue 34, item 6), each checked against an independent
reading of the same graph: an explicit file that spells it out arc by arc (and pin by pin)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from formsync_design.cli import main
from formsync_design.graphs.build import make_graph
from formsync_design.graphs.digraph_io import make_digraph
from formsync_design.graphs.theorem import load_graph


def _run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, Any, str]:
    capsys.readouterr()
    rc = main([*argv, "--format", "json"])
    out, err = capsys.readouterr()
    return rc, (json.loads(out) if out.strip() else None), err


def _write(folder: Path, name: str, text: str) -> str:
    p = folder / name
    p.write_text(text)
    return str(p)


def _verdict(doc: dict) -> tuple:
    """What a Lagrangian certificate decides: the status and the certified margin."""
    return doc["status"], doc["certified_margin"], doc["conditions"], doc["box"]


# -- undirected unit-weight edge lists ---------------------------------------------------------

_K3_ARCS = "1 2 1\n2 1 1\n2 3 1\n3 2 1\n1 3 1\n3 1 1\n"


@pytest.mark.parametrize("text", [_K3_ARCS, "1 2 1\n2 1\n2 3\n3 2\n1 3\n3 1\n",
                                  "# n = 3\n1 2 1.0\n2 1 1\n1 3 1\n3 1 1\n2 3 1\n3 2 1\n"])
def test_a_symmetric_unit_weight_arc_list_is_the_undirected_graph(tmp_path: Path, text: str) -> None:
    """Every link listed both ways with weight 1 is the undirected graph: its Laplacian is the
    adjacency CSV's and complete:3's (computed here from the matrix itself)."""
    g = load_graph(_write(tmp_path, "k3.txt", text))
    csv = load_graph(_write(tmp_path, "k3.csv", "0,1,1\n1,0,1\n1,1,0\n"))
    truth = 3 * np.eye(3) - np.ones((3, 3))
    assert type(g).__name__ == "Graph" and g.n == 3
    np.testing.assert_array_equal(g.laplacian, truth)
    np.testing.assert_array_equal(csv.laplacian, truth)
    np.testing.assert_array_equal(make_graph("complete:3").laplacian, truth)


@pytest.mark.parametrize("text", ["1 2 1\n2 3 1\n3 1 1\n",         # a directed cycle
                                  "1 2 0.5\n2 1 0.5\n2 3 1\n3 2 1\n",  # weighted
                                  "1 2 1\n2 1 1\n2 3 1\n3 2 1\n1 0 1\n"])  # a leader
def test_a_directed_weighted_or_pinned_arc_list_stays_a_digraph(tmp_path: Path, text: str) -> None:
    assert type(load_graph(_write(tmp_path, "g.txt", text))).__name__ == "Digraph"


@pytest.mark.parametrize("design", ["pd_consensus", "liang2016"])
def test_certify_accepts_the_edge_list_and_decides_as_on_the_csv(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], design: str) -> None:
    el = _write(tmp_path, "k3.txt", _K3_ARCS)
    csv = _write(tmp_path, "k3.csv", "0,1,1\n1,0,1\n1,1,0\n")
    got = {}
    for g in (el, csv, "complete:3"):
        rc, doc, err = _run(capsys, "certify", "--design", design, "--graph", g)
        assert rc in (0, 1) and doc is not None, err
        got[g] = (rc, _verdict(doc))
    assert got[el] == got[csv] == got["complete:3"], got


# -- cycle:N on --graph ------------------------------------------------------------------------

def test_cycle_n_is_one_spec_for_case_files_and_the_command_line(tmp_path: Path) -> None:
    """``cycle:100`` on --graph is the case files' directed cycle; its Laplacian is the one of
    the arcs written out (i hears i - 1, 1 hears 100)."""
    from formsync_design.verify.enginegraphs import formation_graph

    arcs = "".join(f"{i} {i - 1 if i > 1 else 100} 1\n" for i in range(1, 101))
    explicit = load_graph(_write(tmp_path, "c100.txt", arcs))
    cli = load_graph("cycle:100")
    case, _ = formation_graph({"graph": "cycle:100"}, "formations[1]", lambda: None,
                              str(tmp_path / "case.toml"))
    assert cli.name == case.name == "cycle:100" and not cli.is_undirected
    np.testing.assert_array_equal(cli.laplacian, explicit.laplacian)
    np.testing.assert_array_equal(case.laplacian, explicit.laplacian)
    assert make_digraph("cycle:4", pinning=[1, 0, 0, 0]).leader_reachable


@pytest.mark.parametrize("spec", ["cycle:1", "cycle:x", "cycle:2001"])
def test_a_bad_cycle_spec_is_refused_as_a_cycle(spec: str, capsys: pytest.CaptureFixture[str]) -> None:
    rc = main(["certify", "--design", "ma_so3", "--graph", spec])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1, err
    assert "cycle:N" in err[0] or "2000" in err[0], err


def test_certify_takes_cycle_n_and_decides_as_on_the_arcs(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    arcs = _write(tmp_path, "c4.txt", "1 4 1\n2 1 1\n3 2 1\n4 3 1\n")
    rc1, a, err = _run(capsys, "certify", "--design", "ma_so3", "--graph", "cycle:4")
    assert rc1 == 0 and a is not None, err
    rc2, b, _ = _run(capsys, "certify", "--design", "ma_so3", "--graph", arcs)
    assert rc2 == rc1 and a["status"] == b["status"] == "certified"
    assert a["formation"]["decay_rate"] == pytest.approx(b["formation"]["decay_rate"], rel=1e-12)


# -- --graph keeps the case's pinning ----------------------------------------------------------

def _pinned_ring(folder: Path, n: int) -> str:
    lines = [f"{i} {i % n + 1} 1\n{i % n + 1} {i} 1\n" for i in range(1, n + 1)]
    return _write(folder, f"ring{n}-pinned.txt", "".join(lines) + "".join(
        f"{i} 0 1\n" for i in range(1, n + 1)))


@pytest.mark.parametrize("n", [8, 6])
def test_resizing_a_leader_design_keeps_the_case_pinning(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], n: int) -> None:
    """lv2012's case pins every spacecraft with b = 1: ``--graph ring:N`` keeps that rule and
    says so; the certificate equals the one on ring:N with the pins written out."""
    rc, a, err = _run(capsys, "certify", "--design", "lv2012", "--graph", f"ring:{n}")
    assert rc == 0 and a is not None, err
    assert f"pinning for --graph ring:{n}: " in a["formation"]["inputs"], a["formation"]
    rc2, b, _ = _run(capsys, "certify", "--design", "lv2012", "--graph", _pinned_ring(tmp_path, n))
    assert rc2 == rc and a["formation"]["status"] == b["formation"]["status"] == "certified"
    assert a["formation"]["decay_rate"] == pytest.approx(b["formation"]["decay_rate"], rel=1e-12)


def test_a_pinning_without_a_rule_for_another_size_is_refused(tmp_path: Path) -> None:
    from formsync_design.errors import InputError
    from formsync_design.resources import case_file
    from formsync_design.verify.agentcase import load_agent_case

    text = case_file("lv2012").read_text().replace("pinning = [1, 1, 1, 1, 1, 1, 1, 1]",
                                                   "pinning = [1, 0, 2, 0, 0, 0, 0, 0]")
    case = load_agent_case(_write(tmp_path, "lv.toml", text))
    assert [str(b) for b in case.pinning_rule(8)[0]] == ["1", "0", "2", "0", "0", "0", "0", "0"]
    with pytest.raises(InputError, match="no rule for another size"):
        case.pinning_rule(5)
    one = load_agent_case(_write(tmp_path, "lv1.toml", text.replace("[1, 0, 2,", "[3, 0, 0,")))
    assert [str(b) for b in one.pinning_rule(3)[0]] == ["3", "0", "0"]


# -- --allow-outside-theorem reaches the formation certificate -----------------------------------

def test_outside_the_theorem_the_design_conditions_are_not_applicable(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """lv2012 on a directed cycle: its own conditions(c) need an undirected graph, so they are
    reported as not applicable (with why) and the formation certificate decides, as on the
    same pinned cycle written out arc by arc; without the flag the graph is refused."""
    rc, a, err = _run(capsys, "certify", "--design", "lv2012", "--graph", "cycle:5",
                      "--allow-outside-theorem")
    assert rc in (0, 1) and a is not None, err
    dc = a["design_conditions"]
    assert dc["status"] == "not applicable" and "undirected" in dc["reason"], dc
    assert a["outside_theorem"]["missing"] == ["undirected"]
    pinned = _write(tmp_path, "c5.txt", "1 5 1\n2 1 1\n3 2 1\n4 3 1\n5 4 1\n"
                    + "".join(f"{i} 0 1\n" for i in range(1, 6)))
    rc2, b, _ = _run(capsys, "certify", "--design", "lv2012", "--graph", pinned,
                     "--allow-outside-theorem")
    assert rc2 == rc and a["status"] == b["status"] == a["formation"]["status"]
    assert a["formation"]["decay_rate"] == pytest.approx(b["formation"]["decay_rate"], rel=1e-12)
    capsys.readouterr()
    assert main(["certify", "--design", "lv2012", "--graph", "cycle:5"]) == 2
    capsys.readouterr()
    assert main(["certify", "--design", "lv2012", "--graph", "cycle:5",
                 "--allow-outside-theorem"]) == rc
    text = capsys.readouterr().out
    assert "not applicable on 'cycle:5', outside the design's theorem" in text, text


def test_an_i_j_pair_file_still_lists_each_link_once(tmp_path: Path) -> None:
    """The undirected ``i j`` format lists each link once: both ways is a duplicate there."""
    from formsync_design.errors import GraphError

    with pytest.raises(GraphError, match="twice"):
        make_graph(_write(tmp_path, "g.txt", "1 2\n2 1\n"))


def test_simulate_and_region_keep_the_case_pinning_too(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The simulations' graph (``agent_graph``) and every graph of an agent region map take the
    same rule: ring:6 for lv2012 has every spacecraft pinned with b = 1, and the case resized."""
    from formsync_design.cli.defaults import agent_case, agent_graph
    from formsync_design.spec.loader import load_design
    from formsync_design.verify.defaults import Defaults

    lv = load_design("lv2012")
    d = Defaults()
    case, g = agent_graph(agent_case(lv, None, None, None), "ring:6", d, lv)
    assert case.n == 6 and [str(b) for b in g.pinning] == ["1"] * 6 and g.leader_reachable
    np.testing.assert_array_equal(g.laplacian, make_graph("ring:6").laplacian)
    assert any(ln.startswith("pinning for --graph ring:6: every spacecraft") for ln in d.lines)
    rc = main(["region", "--design", "lv2012", "--graph", "ring:4", "--graph", "ring:5",
               "--resolution", "2", "--format", "json", "--out", str(tmp_path / "r")])
    assert rc == 0, capsys.readouterr().err
