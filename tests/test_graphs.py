"""Communication graphs: specs, files, arrays, networkx, and every bad input."""

from __future__ import annotations

import networkx as nx
import numpy as np
import pytest

from formsync_design.errors import FormsyncError, GraphError
from formsync_design.graphs.build import Graph, make_graph


@pytest.mark.parametrize(
    "spec, n, m, degrees",
    [
        ("ring:5", 5, 5, {2}),
        ("path:4", 4, 3, {1, 2}),
        ("star:6", 6, 5, {1, 5}),
        ("complete:5", 5, 10, {4}),
        ("circulant:8:1,4", 8, 12, {3}),
        ("circulant:6:1,3", 6, 9, {3}),
    ],
)
def test_specs_match_networkx(spec, n, m, degrees):
    g = make_graph(spec)
    assert g.n == n and len(g.edges) == m and set(g.degrees) == degrees
    ref = {
        "ring": lambda k: nx.cycle_graph(k),
        "path": lambda k: nx.path_graph(k),
        "star": lambda k: nx.star_graph(k - 1),
        "complete": lambda k: nx.complete_graph(k),
    }
    kind = spec.split(":")[0]
    if kind in ref:
        assert nx.is_isomorphic(g.to_networkx(), ref[kind](n))
    # Laplacian rows sum to zero and L = D - A
    assert np.all(g.laplacian.sum(axis=1) == 0)
    assert np.array_equal(np.diag(g.laplacian), np.array(g.degrees))


def test_star_centre_is_spacecraft_1():
    g = make_graph("star:5")
    assert g.degrees[0] == 4 and g.neighbors(0) == (1, 2, 3, 4)


def test_random_is_seeded_and_connected():
    a = make_graph("random:12:0.4:7")
    b = make_graph("random:12:0.4:7")
    assert a == b
    assert nx.is_connected(a.to_networkx())
    with pytest.raises(GraphError, match="connected"):
        make_graph("random:12:0.01:1")


def test_edge_list_file(tmp_path):
    f = tmp_path / "e.txt"
    f.write_text("# a 4-cycle\n1 2\n2 3  # inline comment\n3 4\n4 1\n")
    g = make_graph(f)
    assert g.n == 4 and g.degrees == (2, 2, 2, 2)


def test_adjacency_csv_and_array(tmp_path):
    a = make_graph("path:3").adjacency
    f = tmp_path / "a.csv"
    f.write_text("\n".join(",".join(str(int(x)) for x in row) for row in a) + "\n")
    assert make_graph(f).edges == make_graph(a).edges == ((0, 1), (1, 2))


def test_networkx_input_relabels_to_1_based():
    g = make_graph(nx.Graph([("a", "b"), ("b", "c")]))
    assert g.n == 3 and g.edge_list_1based() == [[1, 2], [2, 3]]


@pytest.mark.parametrize(
    "bad, fragment",
    [
        (np.array([[0, 1], [0, 0]]), "undirected"),
        (np.array([[1, 1], [1, 0]]), "self-loops"),
        (np.array([[0, 2], [2, 0]]), "0/1"),
        (np.array([[0, 0.5], [0.5, 0]]), "0/1"),
        (np.array([[0, 1, 0, 0], [1, 0, 0, 0], [0, 0, 0, 1], [0, 0, 1, 0]]), "connected"),
        (np.array([[0]]), "at least 2"),
        (np.zeros((2, 3)), "square"),
        ("ring:2", "N >= 3"),
        ("path:1", "at least 2"),
        ("ring:x", "integer"),
        ("ring", "graph spec"),
        ("ring:4:1", "ring:N"),
        ("hexagon:6", "graph spec"),
        ("circulant:8:5", "offsets"),
        ("circulant:8:1,1", "distinct"),
        ("random:5:1.5:1", "probability"),
        (nx.DiGraph([(1, 2)]), "undirected"),
        (3.14, "expected a graph spec"),
    ],
)
def test_bad_inputs_have_clear_messages(bad, fragment):
    with pytest.raises(GraphError) as ei:
        make_graph(bad)
    msg = str(ei.value)
    assert fragment in msg and "expected" in msg and "\n" not in msg
    assert isinstance(ei.value, (FormsyncError, ValueError))


@pytest.mark.parametrize(
    "text, fragment",
    [
        ("1 2\n2 2\n", "self-loops"),
        ("1 2\n2 1\n", "twice"),
        ("1 2\n0 1\n", "1-based"),
        ("1 2 3\n", "one 'i j' pair"),
        ("1 a\n", "integer"),
        ("# nothing\n", "at least one edge"),
        ("1 2\n3 4\n", "connected"),
        ("# n = 3\n1 2\n", "connected"),
    ],
)
def test_bad_edge_files(tmp_path, text, fragment):
    f = tmp_path / "bad.txt"
    f.write_text(text)
    with pytest.raises(GraphError, match=fragment):
        make_graph(f)


def test_graph_rejects_invalid_direct_construction():
    with pytest.raises(GraphError):
        Graph(n=3, edges=((0, 1),))


# ---------------------------------------------------------------------------
# size limit, binary files, numpy reprs (issue 9: items 13 and "bad input")
# ---------------------------------------------------------------------------
def test_size_cap_is_enforced_before_allocation():
    import resource

    from formsync_design.graphs.build import MAX_SPACECRAFT

    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    for spec in ("ring:100000000", "complete:1000000", f"path:{MAX_SPACECRAFT + 1}",
                 "random:50000000:0.5:1"):
        with pytest.raises(GraphError, match=f"at most {MAX_SPACECRAFT} spacecraft"):
            make_graph(spec)
    # refused up front: no N x N allocation (80 PB for ring:1e8)
    assert resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before < 200_000  # KB
    # the cap itself is accepted, and its Laplacian is right (independent: networkx)
    g = make_graph(f"path:{MAX_SPACECRAFT}")
    assert g.n == MAX_SPACECRAFT
    ref = nx.laplacian_matrix(nx.path_graph(MAX_SPACECRAFT)).toarray()
    assert (g.laplacian == ref).all()


def test_size_cap_applies_to_files_and_arrays(tmp_path):
    f = tmp_path / "big.txt"
    f.write_text("1 2\n2 3000000\n")
    with pytest.raises(GraphError, match="at most 2000 spacecraft"):
        make_graph(f)
    with pytest.raises(GraphError, match="at most 2000 spacecraft"):
        make_graph(nx.path_graph(2001))
    with pytest.raises(GraphError, match="at most 2000 spacecraft"):
        Graph(2001, tuple((i, i + 1) for i in range(2000)))


@pytest.mark.parametrize("name, data, fragment", [
    ("g.txt", b"1 2\n\x00\x01\x02\xff", "binary"),
    ("g.txt", "1 2\n# caf\u00e9\n".encode("latin-1"), "not UTF-8"),
    ("g.csv", b"\x89PNG\r\n\x1a\n\x00\x00", "binary"),
    ("g.csv", "0,1\n1,0\n# \u00e9\n".encode("latin-1"), "not UTF-8"),
])
def test_binary_and_non_utf8_graph_files(tmp_path, name, data, fragment):
    f = tmp_path / name
    f.write_bytes(data)
    with pytest.raises(GraphError, match=fragment) as e:
        make_graph(f)
    assert str(f) in str(e.value) and "\n" not in str(e.value)


def test_messages_carry_no_numpy_reprs():
    for bad in (np.array([[0, 0.5], [0.5, 0]]), np.array([[0.0, 1.0], [0.0, 0.0]]),
                np.zeros((2, 3))):
        with pytest.raises(GraphError) as e:
            make_graph(bad)
        assert "np." not in str(e.value) and "float64" not in str(e.value)
    with pytest.raises(GraphError) as e:
        Graph(np.int64(1), ())
    assert str(e.value) == "expected a formation of at least 2 spacecraft, received 1"
