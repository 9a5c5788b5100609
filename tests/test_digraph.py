"""Weighted digraphs with pinning: properties checked against networkx's own algorithms.

networkx (an independent implementation) decides weak/strong connectivity, strong
components, reachability (spanning-tree roots, leader reachability) and weighted
degrees on seeded random digraphs; the spectral facts (a simple zero eigenvalue of
L iff a spanning tree; L + B Hurwitz-positive iff the leader reaches everyone) are
checked as theorems against the combinatorial answers.  The paper 002 formation
(Fig. 1) is the worked case.
"""

from __future__ import annotations

import re
from fractions import Fraction

import networkx as nx
import numpy as np
import pytest

from formsync_design.errors import GraphError, InputError
from formsync_design.graphs.build import make_graph
from formsync_design.graphs.digraph import Digraph, GraphProperty
from formsync_design.graphs.digraph_io import digraph_from_edges, make_digraph, read_edge_list

PAPER_002 = [(1, 4, "0.58"), (2, 3, "0.33"), (2, 5, "0.11"), (3, 2, "0.25"), (4, 1, "0.21"), (4, 3, "0.4"), (5, 1, "0.37")]


def random_weighted_digraph(n: int, p: float, seed: int) -> nx.DiGraph:
    g = nx.gnp_random_graph(n, p, seed=seed, directed=True)
    g = nx.relabel_nodes(g, {v: v + 1 for v in g.nodes()})
    rng = np.random.default_rng(seed)
    for u, v in g.edges():
        g[u][v]["weight"] = float(np.round(rng.uniform(0.1, 2.0), 3))
    return g


CASES = [(n, p, seed) for n in (3, 5, 8) for p in (0.15, 0.3, 0.6) for seed in (1, 2, 3)]


@pytest.mark.parametrize("n, p, seed", CASES)
def test_properties_match_networkx(n, p, seed):
    G = random_weighted_digraph(n, p, seed)
    g = make_digraph(G)
    nodes = set(G.nodes())
    assert g.n == n and len(g.arcs) == G.number_of_edges()
    # adjacency: networkx A[u, v] is the arc u -> v, i.e. a_vu
    A_nx = nx.to_numpy_array(G, nodelist=sorted(nodes), weight="weight")
    assert np.allclose(g.adjacency, A_nx.T)
    assert np.allclose(g.laplacian @ np.ones(n), 0)
    assert np.allclose(np.diag(g.laplacian), [G.in_degree(v, weight="weight") for v in sorted(nodes)])
    assert g.is_weakly_connected == nx.is_weakly_connected(G)
    assert g.is_strongly_connected == nx.is_strongly_connected(G)
    assert {frozenset(v + 1 for v in c) for c in g.strong_components} == {
        frozenset(c) for c in nx.strongly_connected_components(G)
    }
    roots_nx = sorted(r for r in nodes if nx.descendants(G, r) | {r} == nodes)
    assert [r + 1 for r in g.spanning_tree_roots] == roots_nx
    assert g.has_spanning_tree == bool(roots_nx)
    balanced_nx = all(
        abs(G.in_degree(v, weight="weight") - G.out_degree(v, weight="weight")) < 1e-12 for v in nodes
    )
    assert g.is_balanced == balanced_nx
    # spectral theorem: zero is a simple eigenvalue of L iff there is a spanning tree
    ev = g.laplacian_eigenvalues
    assert np.min(np.abs(ev)) < 1e-9
    n_zero = int(np.sum(np.abs(ev) < 1e-7))
    assert (n_zero == 1) == g.has_spanning_tree
    # round trip through networkx
    assert make_digraph(g.to_networkx()).arcs == g.arcs


@pytest.mark.parametrize("n, p, seed", CASES[::2])
def test_leader_reachability_matches_networkx_and_spectrum(n, p, seed):
    G = random_weighted_digraph(n, p, seed)
    rng = np.random.default_rng(100 + seed)
    pinned = sorted(int(i) for i in rng.choice(np.arange(1, n + 1), size=1 + seed % 2, replace=False))
    g = make_digraph(G, pinning={i: 0.5 for i in pinned})
    H = G.copy()
    H.add_edges_from((0, i) for i in pinned)
    expect = nx.descendants(H, 0) == set(G.nodes())
    assert g.leader_reachable == expect
    assert sorted(v + 1 for v in g.unreachable_from_leader) == sorted(set(G.nodes()) - nx.descendants(H, 0))
    # theorem: every eigenvalue of L + B has positive real part iff the leader reaches everyone
    assert (np.min(g.pinned_eigenvalues.real) > 1e-9) == expect
    # the leader as a networkx node gives the same pinning
    g2 = make_digraph(g.to_networkx(leader="L"), leader="L")
    assert g2.arcs == g.arcs and g2.pinning == g.pinning


def test_paper_002_formation():
    g = digraph_from_edges(PAPER_002, name="paper002")
    assert g.n == 5 and len(g.arcs) == 7
    assert g.adjacency[0, 3] == 0.58 and g.adjacency[3, 0] == 0.21  # a14, a41
    assert g.has_spanning_tree and [r + 1 for r in g.spanning_tree_roots] == [1, 2, 3, 4, 5]
    assert g.is_strongly_connected and g.is_weakly_connected
    assert not g.is_balanced and not g.is_undirected
    assert g.in_weights[1] == Fraction(44, 100)  # a23 + a25, exact
    G = g.to_networkx()
    assert nx.is_strongly_connected(G)
    ev = g.laplacian_eigenvalues
    assert abs(ev[0]) < 1e-12 and np.all(ev[1:].real > 1e-6)
    g.require([GraphProperty.SPANNING_TREE, "strongly-connected"])
    # spacecraft 1 receives 0.58 (from 4) and sends 0.21 + 0.37 = 0.58; spacecraft 2 receives
    # 0.33 + 0.11 but sends only 0.25
    assert g.in_weights[0] == g.out_weights[0]
    with pytest.raises(GraphError, match="expected a graph that is balanced.*spacecraft 2 receives 0.44 but sends 0.25"):
        g.require(["balanced"])
    d = g.to_dict()
    assert d["spanning_tree_roots"] == [1, 2, 3, 4, 5] and d["arcs"][0] == [1, 4, "29/50"]  # exact, json_number convention


def test_balanced_message_names_first_unbalanced():
    g = digraph_from_edges([(2, 1, 1), (1, 2, 2)], name="two")
    with pytest.raises(GraphError) as e:
        g.require(["balanced"], by="design 'demo'")
    msg = str(e.value)
    assert msg.startswith("expected a graph that is balanced (required by design 'demo'), received 'two'")
    assert "spacecraft 1 receives 2 but sends 1" in msg and "\n" not in msg


def test_require_names_every_missing_property():
    g = digraph_from_edges([(2, 1), (3, 4)], name="split")
    with pytest.raises(GraphError) as e:
        g.require(["weakly-connected", "spanning-tree", "leader-reachable"])
    msg = str(e.value)
    assert "weakly-connected: 2 weak components {1,2}; {3,4}" in msg
    assert "spanning-tree: no root; 2 source components {1}; {4}" in msg
    assert "leader-reachable: no leader" in msg
    with pytest.raises(InputError, match="expected a graph property"):
        g.require(["conected"])


def test_undirected_graph_conversion():
    for spec in ("ring:5", "star:4", "random:7:0.5:3"):
        ug = make_graph(spec)
        g = make_digraph(ug)
        assert np.array_equal(g.laplacian, ug.laplacian.astype(float))
        assert g.is_undirected and g.is_balanced and g.is_strongly_connected
        assert np.allclose(np.sort(g.laplacian_eigenvalues.real), ug.laplacian_eigenvalues)
    assert make_digraph("path:3").arcs == make_digraph(make_graph("path:3")).arcs
    assert make_digraph(nx.path_graph(3)).is_undirected


def test_files_edge_list_and_csv(tmp_path):
    p = tmp_path / "paper002.txt"
    p.write_text("# paper 002, Fig. 1\n# n = 6\n" + "\n".join(f"{i} {j} {w}" for i, j, w in PAPER_002) + "\n1 0 1.5\n")
    g = read_edge_list(p)
    assert g.n == 6 and g.pinning[0] == Fraction(3, 2) and not g.leader_reachable
    assert g.unreachable_from_leader == (5,)
    assert make_digraph(p).arcs == g.arcs
    c = tmp_path / "a.csv"
    A = digraph_from_edges(PAPER_002).adjacency
    c.write_text("# a_ij\n" + "\n".join(",".join(f"{x:g}" for x in row) for row in A) + "\n")
    gc = make_digraph(c, pinning=[0, 0, 1, 0, 0])
    assert gc.arcs == digraph_from_edges(PAPER_002).arcs and gc.leader_reachable


@pytest.mark.parametrize(
    "build, match",
    [
        (lambda: digraph_from_edges([(1, 2, -1)]), "expected a positive weight, received -1"),
        (lambda: digraph_from_edges([(1, 1, 1)]), "expected no self-loops"),
        (lambda: digraph_from_edges([(1, 2), (1, 2, 3)]), "expected each arc once, received a_1,2 twice"),
        (lambda: digraph_from_edges([(1, 0, 1), (1, 0, 2)]), "expected one pinning gain for spacecraft 1"),
        (lambda: digraph_from_edges([(1, 2)], pinning=[1]), "expected 2 pinning gains"),
        (lambda: digraph_from_edges([(1, 2)], pinning=[1, -1]), "expected a pinning gain b_2 >= 0"),
        (lambda: digraph_from_edges([(1, 2, "x")]), "expected a number for weight of"),
        (lambda: digraph_from_edges([(0, 2)]), "expected 1-based spacecraft numbers"),
        (lambda: digraph_from_edges([(1, 2)], n=1), "expected n >= 2"),
        (lambda: make_digraph([[0, -1], [1, 0]]), "expected nonnegative weights"),
        (lambda: make_digraph([[1, 1], [1, 0]]), "expected no self-loops"),
        (lambda: make_digraph([[0, 1, 0], [1, 0]]), "expected a square adjacency matrix"),
        (lambda: make_digraph(nx.DiGraph([(1, "L")]), leader="L"), "expected the leader 'L' only to send"),
        (lambda: make_digraph(3.5), "expected an edge-list or CSV file"),
        (lambda: Digraph(2, ((1, 0, Fraction(1)), (0, 1, Fraction(1)))), "expected arcs in sorted order"),
    ],
)
def test_bad_input_one_line(build, match):
    with pytest.raises(InputError, match=match) as e:
        build()
    assert "\n" not in str(e.value)


def test_bad_edge_list_lines(tmp_path):
    p = tmp_path / "bad.txt"
    p.write_text("1 2 3 4\n")
    with pytest.raises(GraphError, match=r"expected 'i j' or 'i j w'.*bad.txt:1"):
        read_edge_list(p)
    p.write_text("1 2 abc\n")
    with pytest.raises(GraphError, match=r"expected a number for weight a_1,2, received 'abc' in '1 2 abc' at .*bad.txt:1"):
        read_edge_list(p)
    p.write_text("# nothing\n")
    with pytest.raises(GraphError, match="expected at least one arc"):
        read_edge_list(p)


def test_direct_construction_needs_exact_weights():
    with pytest.raises(GraphError, match="expected an exact \\(Fraction\\) weight a_1,2"):
        Digraph(2, ((0, 1, 0.5),))  # type: ignore[arg-type]
    with pytest.raises(GraphError, match="expected a positive weight a_1,2, received -0.5"):
        Digraph(2, ((0, 1, Fraction(-1, 2)),))


def test_undirected_networkx_with_leader_node():
    G = nx.Graph([("L", "a"), ("a", "b"), ("b", "c")])
    g = make_digraph(G, leader="L")
    assert g.n == 3 and g.is_undirected and g.pinning == (Fraction(1), Fraction(0), Fraction(0))
    assert g.leader_reachable and np.min(g.pinned_eigenvalues.real) > 0


#: The weighted edge lists the digraph reader refuses (issue 25): the line, what it says
#: (the reason, with the offending line and ``file:line``), one file each.
BAD_WEIGHTED_EDGE_LISTS = [
    ("zero-weight", "1 2 0\n2 1 1\n", r"expected a positive weight a_1,2 \(leave out an arc of "
     r"weight 0\), received '0' in '1 2 0' at \S+:1$"),
    ("negative-weight", "1 2 1\n2 1 -0.5\n", r"expected a positive weight a_2,1, received '-0.5' in "
     r"'2 1 -0.5' at \S+:2$"),
    ("nan-weight", "1 2 nan\n2 1 1\n", r"expected a finite number for weight a_1,2, received 'nan' "
     r"in '1 2 nan' at \S+:1$"),
    ("self-loop", "1 2 1\n2 2 1\n", r"expected no self-loops, received arc \(2, 2\) in '2 2 1' at \S+:2$"),
    ("duplicate-arc", "1 2 1\n2 1 1\n1 2 0.5\n", r"expected each arc once \(a_1,2\), received a "
     r"second one in '1 2 0.5' at \S+:3 \(the first at \S+:1\)$"),
    ("negative-pinning", "1 2 1\n2 1 1\n1 0 -2\n", r"expected a positive pinning gain b_1 \('i 0 b'\), "
     r"received '-2' in '1 0 -2' at \S+:3$"),
    ("zero-based", "0 1 1\n1 0 1\n", r"expected 1-based spacecraft numbers i >= 1, j >= 1 .*received "
     r"'0 1 1' at \S+:1 \(a 0-based file\? number the spacecraft from 1\)$"),
    ("beyond-size-limit", "1 2 1\n2 1 1\n2001 1 0.5\n", r"expected at most 2000 spacecraft .*received "
     r"N=2001 in '\S+:3'$"),
]


@pytest.mark.parametrize("text, reason", [pytest.param(t, r, id=k) for k, t, r in BAD_WEIGHTED_EDGE_LISTS])
def test_weighted_edge_list_is_refused_with_the_digraph_readers_reason(tmp_path, text, reason):
    """The reader of the file's format (three columns: the digraph reader) gives the reason,
    not the undirected reader's "one 'i j' pair per line"."""
    from formsync_design.graphs.theorem import load_graph

    p = tmp_path / "edges.txt"
    p.write_text(text)
    for read in (read_edge_list, make_digraph, load_graph):
        with pytest.raises(GraphError) as e:
            read(p)
        assert re.search(reason, str(e.value)), (read.__name__, str(e.value))
        assert "'i j' pair" not in str(e.value)


@pytest.mark.parametrize("text, reason", [pytest.param(t, r, id=k) for k, t, r in BAD_WEIGHTED_EDGE_LISTS])
def test_weighted_edge_list_bad_input_is_exit_2_with_one_line(tmp_path, capsys, text, reason):
    """On the command line: exit 2, one line on stderr, the digraph reader's reason."""
    import importlib

    cli_main = importlib.import_module("formsync_design.cli.main")
    p = tmp_path / "edges.txt"
    p.write_text(text)
    rc = cli_main.main(["certify", "--graph", str(p), "--ko", "1.6", "--kq", "0.4", "--beta", "0.3"])
    out = capsys.readouterr()
    lines = out.err.splitlines()
    assert rc == 2 and out.out == "" and len(lines) == 1, out.err
    assert lines[0].startswith("formsync certify: error: expected ")
    assert re.search(reason, lines[0]), lines[0]


def test_pair_list_keeps_the_undirected_readers_reason(tmp_path):
    """Two columns are the undirected reader's format: its reason stays."""
    from formsync_design.graphs.theorem import load_graph

    p = tmp_path / "pairs.txt"
    p.write_text("1 2\n2 3 # a path\n0 1\n")
    with pytest.raises(GraphError, match=r"expected 1-based spacecraft numbers \(>= 1\), received '0 1'"):
        load_graph(p)
