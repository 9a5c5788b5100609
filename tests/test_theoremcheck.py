"""A design's theorem checked on graph families: verdicts equal certify_formation's, the
first failing cycle of ma_so3 at the paper's gains, counterexample simulations."""

from __future__ import annotations

import pytest

from formsync_design.certify.formation import certify_formation
from formsync_design.gains import GainBox
from formsync_design.graphs.digraph_io import digraph_from_edges
from formsync_design.resources import case_file
from formsync_design.verify.agentcase import load_agent_case
from formsync_design.verify.theoremcheck import check_theorem, theorem_graphs


def test_families_have_the_declared_structure():
    gs = theorem_graphs(5, cycles=(5,), chains=(4,), stars=(4,), random_graphs=3, seed=1)
    for fam, name, arcs, n in gs:
        g = digraph_from_edges(arcs, n=n, name=name)
        assert g.has_spanning_tree, name
        if fam == "directed cycle":
            assert g.is_strongly_connected and len(arcs) == n


def test_rows_are_the_formation_certificates_and_the_verdict_follows_them():
    c = load_agent_case(case_file("ma_so3"))
    tc = check_theorem(c, cycles=(7, 8), chains=(4,), stars=(), random_graphs=0, simulate=False)
    box = GainBox.parse(c.gains.as_dict())
    for row in tc.rows:
        if row.family == "directed cycle":
            g = digraph_from_edges([(i + 1, (i - 1) % row.n + 1, 1) for i in range(row.n)],
                                   n=row.n, name=row.graph)
            r = certify_formation(c.design, g, c.cycled(row.n).inertias, box)
            assert str(r.status) == row.status
    assert [r.status for r in tc.rows if r.family == "directed cycle"] == ["certified", "refuted"]
    assert tc.verdict == "refuted" and tc.first_failing_cycle == 8
    assert "Verdict on the theorem: refuted" in "\n".join(tc.markdown())


def test_a_theorem_without_counterexample_is_not_said_to_hold():
    c = load_agent_case(case_file("lv2012"))
    tc = check_theorem(c, cycles=(), chains=(), stars=(), random_graphs=0, simulate=False)
    assert tc.verdict == "no counterexample found"
    assert {r.family for r in tc.rows} >= {"undirected ring", "the case's graph"}


@pytest.mark.slow
def test_a_counterexample_is_simulated_and_does_not_converge():
    c = load_agent_case(case_file("ma_so3"))
    tc = check_theorem(c, cycles=(9,), chains=(), stars=(), random_graphs=0, sim_tf=150.0)
    (row,) = [r for r in tc.rows if r.graph == "C9"]
    assert row.status == "refuted" and row.sim_final_deg > 10 * row.sim_initial_deg
