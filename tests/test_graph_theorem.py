"""A design's graph class: loading any graph, checking the theorem's properties, refusing
or flagging a graph outside it, and simulating a weighted digraph outside the theorem.

Independent truths: networkx for the graph properties; the exact linear closed loop of
the PD design on a weighted digraph (matrix exponential) for the simulation.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import networkx as nx
import numpy as np
import pytest

from formsync_design.errors import GraphError
from formsync_design.graphs import Digraph, Graph, check_theorem_graph, load_graph

PD = "pd_consensus"


def _formsync(*args: str) -> subprocess.CompletedProcess:
    exe = Path(sys.executable).with_name("formsync")
    return subprocess.run([str(exe), *args], capture_output=True, text=True, timeout=300)


def _edges(tmp_path, lines: str) -> str:
    p = tmp_path / "g.txt"
    p.write_text(lines)
    return str(p)


def test_load_graph_types():
    assert isinstance(load_graph("star:5"), Graph)
    assert isinstance(load_graph([[0, 1, 0], [0, 0, 1], [1, 0, 0]]), Digraph)
    assert isinstance(load_graph(nx.DiGraph([(1, 2), (2, 3), (3, 1)])), Digraph)


@pytest.mark.parametrize("seed", range(6))
def test_theorem_properties_against_networkx(seed):
    rng = np.random.default_rng(seed)
    n = 6
    A = (rng.random((n, n)) < 0.3).astype(int)
    np.fill_diagonal(A, 0)
    G = nx.DiGraph()  # arc j -> i when i receives from j (a_ij = 1)
    G.add_nodes_from(range(n))
    G.add_edges_from((j, i) for i in range(n) for j in range(n) if A[i, j])
    want = {
        "strongly-connected": nx.is_strongly_connected(G),
        "weakly-connected": nx.is_weakly_connected(G),
        "spanning-tree": any(len(nx.descendants(G, r)) == n - 1 for r in G),
        "undirected": bool((A == A.T).all()),
    }
    chk = check_theorem_graph(A.tolist(), list(want), allow_outside=True, design="x")
    assert set(chk.missing) == {p for p, ok in want.items() if not ok}
    assert chk.inside == all(want.values())
    for p, ok in want.items():
        if not ok:
            with pytest.raises(GraphError) as e:
                check_theorem_graph(A.tolist(), [p], design="x")
            assert "\n" not in str(e.value) and "required by design x" in str(e.value)


def test_cli_refuses_or_flags_a_digraph_outside_the_theorem(tmp_path):
    g = _edges(tmp_path, "2 1 1\n3 2 0.5\n4 3 1\n1 4 2\n")
    r = _formsync("simulate", "--case", PD, "--graph", g)
    assert r.returncode == 2 and "lacks undirected" in r.stderr and r.stderr.count("\n") == 1
    r = _formsync("simulate", "--case", PD, "--graph", g, "--allow-outside-theorem", "--format", "json")
    assert r.returncode in (0, 1), r.stderr
    doc = json.loads(r.stdout)
    assert doc["outside_theorem"]["missing"] == ["undirected"]
    r = _formsync("simulate", "--case", PD, "--graph", g, "--allow-outside-theorem")
    assert r.stdout.startswith("OUTSIDE THE THEOREM of design pd_consensus")
    for cmd in (["certify", "--ko", "1", "--kq", "1", "--beta", "0.1"], ["derive"]):
        r = _formsync(*cmd, "--graph", g, "--allow-outside-theorem", "--out", str(tmp_path / "o")) \
            if cmd == ["derive"] else _formsync(*cmd, "--graph", g, "--allow-outside-theorem")
        assert r.returncode == 2 and "undirected unweighted graph" in r.stderr, r.stderr


def test_pd_on_a_weighted_digraph_matches_the_directed_linear_loop(tmp_path):
    """Outside the theorem the simulation still solves the model: q'' = -k_d q' - k_p (L (x) I3) q
    with the weighted in-degree Laplacian of the digraph."""
    from scipy.linalg import expm

    from formsync_design.models.disturbances import no_disturbance
    from formsync_design.sim import Formation, Gains, SimOptions, simulate
    from formsync_design.spec.loader import load_spec

    g = load_graph(_edges(tmp_path, "2 1 1\n3 2 0.5\n4 3 1\n1 4 2\n"))
    assert isinstance(g, Digraph)
    n = g.n
    rng = np.random.default_rng(3)
    q = rng.uniform(-0.15, 0.15, size=(n, 3))
    att = np.column_stack([q, np.sqrt(1 - (q**2).sum(1))])
    kp, kd = 0.5, 1.2
    f = Formation(g, np.array([np.diag([50.0, 55, 60])] * n), att, np.zeros((n, 3)),
                  Gains(k_p=kp, k_d=kd), no_disturbance(n))
    r = simulate(f, SimOptions(tf=15, step=0.01), spec=load_spec(PD))
    L = np.asarray(g.laplacian, dtype=float)
    assert not np.allclose(L, L.T)
    M = np.block([[np.zeros((n, n)), np.eye(n)], [-kp * L, -kd * np.eye(n)]])
    for k in (40, 150):
        z = expm(M * r.t[k]) @ np.vstack([q, np.zeros((n, 3))])
        np.testing.assert_allclose(r.x[k, : 4 * n].reshape(n, 4)[:, :3], z[:n], atol=1e-8)
