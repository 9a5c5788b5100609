"""Building a :class:`~formsync_design.graphs.digraph.Digraph` from files, arrays and networkx.

Accepted inputs (:func:`make_digraph`, :func:`digraph_from_edges`)
------------------------------------------------------------------
* an edge-list text file or a sequence of triples ``i j w`` (1-based, weight
  ``w > 0``, default 1): ``i`` receives from ``j`` with weight ``w``;
  ``j = 0`` denotes the leader, so ``i 0 b`` sets the pinning gain ``b_i``;
  ``#`` starts a comment and ``# n = N`` declares the number of spacecraft;
* an adjacency CSV file (``.csv``) or a square array: entry ``(i, j)`` is ``a_ij``;
* a :class:`networkx.DiGraph` whose arc ``u -> v`` (attribute ``weight``,
  default 1) means ``v`` receives from ``u`` (arcs from the node ``leader``
  give pinning gains); an undirected :class:`networkx.Graph` gives both arcs;
* an undirected :class:`~formsync_design.graphs.build.Graph` or a graph spec
  such as ``ring:6`` (every edge becomes two arcs of weight 1);
* the directed cycle ``cycle:N`` (:func:`directed_cycle`: ``i`` receives from
  ``i - 1``, spacecraft 1 from ``N``), the spec a case file's formations take too.

Weights are parsed exactly with :func:`formsync_design.gains.parse_number`.
"""

from __future__ import annotations

import csv
import os
import re
from collections.abc import Iterable, Mapping, Sequence
from fractions import Fraction
from pathlib import Path
from typing import Any

import numpy as np

from formsync_design.errors import GraphError, InputError
from formsync_design.gains import parse_number
from formsync_design.graphs.build import Graph, check_size, make_graph, path_is_file
from formsync_design.graphs.digraph import Arc, Digraph
from formsync_design.textio import check_ascii, cut, read_text

__all__ = ["make_digraph", "digraph_from_edges", "read_edge_list", "directed_cycle",
           "parse_cycle_spec"]


def _pinning(pinning: Any, n: int, name: str) -> tuple[Fraction, ...]:
    if pinning is None:
        return ()
    if isinstance(pinning, Mapping):
        b = [Fraction(0)] * n
        for k, v in pinning.items():
            if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or not 1 <= k <= n:
                raise GraphError(f"expected pinned spacecraft numbers in 1..{n}, received {k!r} in {name!r}")
            b[int(k) - 1] = parse_number(v, f"b_{k}")
        return tuple(b)
    if not isinstance(pinning, (list, tuple, np.ndarray)):
        raise GraphError(f"expected pinning gains b_1..b_{n} as a list or {{i: b_i}}, received "
                         f"{type(pinning).__name__} {repr(pinning)[:40]} in {name!r}")
    vals = list(pinning)
    if len(vals) != n:
        raise GraphError(f"expected {n} pinning gains b_i, received {len(vals)} in {name!r}")
    return tuple(parse_number(v, f"b_{k + 1}") for k, v in enumerate(vals))


def digraph_from_edges(
    edges: Iterable[Sequence[Any]], n: int | None = None, pinning: Any = None, name: str = "edges"
) -> Digraph:
    """Build from 1-based triples ``(i, j, w)`` (``i`` receives from ``j``; ``j = 0`` pins ``i`` to the leader).

    Parameters
    ----------
    edges : iterable of (int, int, number)
        Pairs ``(i, j)`` take weight 1.
    n : int, optional
        Number of spacecraft (default: the largest number used).
    pinning : sequence or mapping, optional
        ``b_1..b_N``, or ``{i: b_i}``; overrides ``j = 0`` triples.
    name : str
        Shown in messages.

    Examples
    --------
    The paper 002 formation (Fig. 1):

    >>> g = digraph_from_edges([(1, 4, "0.58"), (2, 3, "0.33"), (2, 5, "0.11"), (3, 2, "0.25"),
    ...                         (4, 1, "0.21"), (4, 3, "0.4"), (5, 1, "0.37")], name="paper002")
    >>> [r + 1 for r in g.spanning_tree_roots], g.is_strongly_connected, g.is_balanced
    ([1, 2, 3, 4, 5], True, False)
    """
    arcs: list[Arc] = []
    pins: dict[int, Fraction] = {}
    nmax = 0
    for e in edges:
        e = tuple(e)
        if len(e) not in (2, 3):
            raise GraphError(f"expected an arc (i, j) or (i, j, w), received {e!r} in {name!r}")
        i, j = e[0], e[1]
        if any(isinstance(v, bool) or not isinstance(v, (int, np.integer)) for v in (i, j)):
            raise GraphError(f"expected integer spacecraft numbers, received {e!r} in {name!r}")
        w = parse_number(e[2], f"weight of ({i}, {j})") if len(e) == 3 else Fraction(1)
        if i < 1 or j < 0:
            raise GraphError(f"expected 1-based spacecraft numbers (0 = leader as sender), received {e!r} in {name!r}")
        if w <= 0:
            raise GraphError(f"expected a positive weight, received {float(w):g} on ({i}, {j}) in {name!r}")
        nmax = max(nmax, int(i), int(j))
        check_size(nmax, name)
        if j == 0:
            if int(i) in pins:
                raise GraphError(f"expected one pinning gain for spacecraft {i}, received two in {name!r}")
            pins[int(i)] = w
        else:
            arcs.append((int(i) - 1, int(j) - 1, w))
    if n is None:
        n = nmax
    if not isinstance(n, (int, np.integer)) or isinstance(n, bool) or n < max(nmax, 1):
        raise GraphError(f"expected n >= {max(nmax, 1)} spacecraft, received n={n!r} in {name!r}")
    b = _pinning(pinning if pinning is not None else (pins or None), int(n), name)
    return Digraph(n=int(n), arcs=tuple(sorted(arcs)), pinning=b, name=name)


def read_edge_list(path: str | os.PathLike[str], pinning: Any = None) -> Digraph:
    """Read an edge-list file of ``i j [w]`` lines (module docstring).

    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "g.txt"
    >>> _ = p.write_text("# n = 3\\n2 1 0.5  # 2 hears 1\\n3 2\\n1 0 2\\n")
    >>> g = read_edge_list(p)
    >>> g.edge_list_1based(), g.leader_reachable
    ([[2, 1, 0.5], [3, 2, 1], [1, 0, 2]], True)
    """
    p = Path(path)
    text = read_text(p, "edge-list file", GraphError)
    triples: list[tuple[int, int, Any]] = []
    declared: int | None = None
    seen: dict[tuple[int, int], int] = {}  # (i, j) -> the line that gave it
    for lineno, raw in enumerate(text.splitlines(), start=1):
        line, _, comment = raw.partition("#")
        line = line.strip()
        if not line:
            c = comment.replace(" ", "").lower()
            if c.startswith("n="):
                if not re.fullmatch(r"[0-9]{1,12}", c[2:]):
                    raise GraphError(f"expected '# n = N' with an integer N (digits 0-9), received "
                                     f"{cut(c[2:])} at {p}:{lineno}")
                declared = int(c[2:])
            continue
        f = line.replace(",", " ").split()
        if len(f) not in (2, 3):
            raise GraphError(f"expected 'i j' or 'i j w' with integer i, j, received {len(f)} "
                             f"fields {cut(line)} at {p}:{lineno}")
        bad = next((x for x in f[:2] if not re.fullmatch(r"[0-9]{1,12}", x)), None)
        if bad is not None:
            raise GraphError(f"expected 'i j' or 'i j w' with integer i, j (digits 0-9), received "
                             f"{cut(bad)} at {p}:{lineno}, column {raw.index(bad) + 1}")
        triples.append((int(f[0]), int(f[1]), f[2] if len(f) == 3 else 1))
        i, j, w = triples[-1]
        _check_line(i, j, w, seen, line if len(line) <= 40 else line[:39] + "…", f"{p}:{lineno}")
        seen[(i, j)] = lineno
    if not triples:
        raise GraphError(f"expected at least one arc in {str(p)!r}, received none")
    return digraph_from_edges(triples, n=declared, pinning=pinning, name=str(p))


def _check_line(i: int, j: int, w: Any, seen: Mapping[tuple[int, int], int], raw: str,
                where: str) -> None:
    """One line ``i j [w]`` of an edge-list file, checked where the user can find it
    (``where`` = ``path:line``): 1-based numbers within the size limit, no self-loop, each
    arc and pinning gain once, a finite positive weight or pinning gain.

    >>> _check_line(1, 2, "0", {}, "1 2 0", "g.txt:1")
    Traceback (most recent call last):
    ...
    formsync_design.errors.GraphError: expected a positive weight a_1,2 (leave out an arc of weight 0), received '0' in '1 2 0' at g.txt:1
    """
    if i < 1 or j < 0:
        base = " (a 0-based file? number the spacecraft from 1)" if i == 0 else ""
        raise GraphError(f"expected 1-based spacecraft numbers i >= 1, j >= 1 (j = 0: the leader "
                         f"pins i), received {raw!r} at {where}{base}")
    check_size(max(i, j), where)
    if i == j:
        raise GraphError(f"expected no self-loops, received arc ({i}, {i}) in {raw!r} at {where}")
    what = f"pinning gain b_{i} ('i 0 b')" if j == 0 else f"weight a_{i},{j}"
    try:
        value = parse_number(w, what)
    except InputError as e:
        raise GraphError(f"{e} in {raw!r} at {where}") from None
    if value <= 0:
        hint = "" if value != 0 else (" (leave out the line of a spacecraft the leader does not "
                                      "pin)" if j == 0 else " (leave out an arc of weight 0)")
        raise GraphError(f"expected a positive {what}{hint}, received {str(w)!r} in {raw!r} at {where}")
    if (i, j) in seen:
        first = f"{where.rsplit(':', 1)[0]}:{seen[(i, j)]}"
        twice = f"one pinning gain for spacecraft {i}" if j == 0 else f"each arc once (a_{i},{j})"
        raise GraphError(f"expected {twice}, received a second one in {raw!r} at {where} (the first "
                         f"at {first})")


def _from_matrix(a: Any, pinning: Any, name: str) -> Digraph:
    rows = [list(r) for r in a] if not isinstance(a, np.ndarray) else a.tolist()
    n = len(rows)
    if n == 0 or any(len(r) != n for r in rows):
        raise GraphError(f"expected a square adjacency matrix, received rows of lengths {sorted({len(r) for r in rows})} in {name!r}")
    check_size(n, name)
    arcs: list[Arc] = []
    for i in range(n):
        for j in range(n):
            v = rows[i][j]
            w = parse_number(v.strip() if isinstance(v, str) else v, f"a_{i + 1},{j + 1}")
            if w < 0:
                raise GraphError(f"expected nonnegative weights, received a_{i + 1},{j + 1} = {float(w):g} in {name!r}")
            if w > 0 and i == j:
                raise GraphError(f"expected no self-loops, received a_{i + 1},{i + 1} = {float(w):g} in {name!r}")
            if w > 0:
                arcs.append((i, j, w))
    return Digraph(n=n, arcs=tuple(arcs), pinning=_pinning(pinning, n, name), name=name)


def _from_networkx(g: Any, pinning: Any, leader: Any) -> Digraph:
    name = str(getattr(g, "name", "") or "networkx")
    if g.is_multigraph():
        raise GraphError(f"expected a simple graph, received a networkx multigraph {name!r}")
    nodes = sorted(v for v in g.nodes() if leader is None or v != leader)
    idx = {v: k for k, v in enumerate(nodes)}
    pairs = list(g.edges(data="weight", default=1))
    if not g.is_directed():  # both arcs of each edge, but the leader only sends
        both = [(u, v, w) for u, v, w in pairs] + [(v, u, w) for u, v, w in pairs]
        pairs = [(u, v, w) for u, v, w in both if leader is None or v != leader]
    arcs: list[Arc] = []
    pins: dict[int, Any] = {}
    for u, v, w in pairs:
        if leader is not None and v == leader:
            raise GraphError(f"expected the leader {leader!r} only to send, received an arc {u!r} -> {v!r} in {name!r}")
        if leader is not None and u == leader:
            pins[idx[v] + 1] = w
        else:
            arcs.append((idx[v] + 1, idx[u] + 1, w))
    return digraph_from_edges(
        arcs + [(i, 0, b) for i, b in pins.items()], n=len(nodes), pinning=pinning, name=name
    )


def directed_cycle(n: int) -> Digraph:
    """The directed cycle on ``n`` spacecraft (``i`` receives from ``i - 1``, 1 from ``n``),
    the graph of the spec ``cycle:N``.

    >>> g = directed_cycle(4)
    >>> g.name, g.n, g.is_undirected
    ('cycle:4', 4, False)
    """
    return digraph_from_edges([(i, i - 1 if i > 1 else n, 1) for i in range(1, n + 1)], n=n,
                              name=f"cycle:{n}")


def parse_cycle_spec(text: str) -> Digraph | None:
    """The digraph of the spec ``cycle:N`` (None for a text that is not a ``cycle:`` spec);
    a malformed or over-size one is refused (:class:`~formsync_design.errors.GraphError`).

    >>> parse_cycle_spec("cycle:3").arcs == directed_cycle(3).arcs, parse_cycle_spec("ring:3")
    (True, None)
    """
    if not text.lower().startswith("cycle:"):
        return None
    check_ascii(text, f"the graph spec {cut(text, 40)}", GraphError)
    m = re.fullmatch(r"cycle:([0-9]{1,9})", text.strip())
    if m is None or int(m.group(1)) < 2:
        raise GraphError(f"expected cycle:N with an integer N >= 2, received {cut(text, 40)}")
    check_size(int(m.group(1)), text)
    return directed_cycle(int(m.group(1)))


def make_digraph(obj: Any, pinning: Any = None, *, leader: Any = None) -> Digraph:
    """Build a :class:`Digraph` from any supported input (module docstring).

    Parameters
    ----------
    obj : str, os.PathLike, networkx graph, array_like, Graph or Digraph
        An edge-list or ``.csv`` adjacency file, an undirected graph spec
        (``ring:6``) or ``cycle:N``, a networkx graph, a square adjacency array, an
        undirected :class:`~formsync_design.graphs.build.Graph`.
    pinning : sequence or mapping, optional
        Pinning gains ``b_1..b_N`` or ``{i: b_i}`` (replaces any in ``obj``).
    leader : hashable, optional
        The networkx node that is the leader (its arcs give pinning gains).

    Examples
    --------
    >>> g = make_digraph("path:3", pinning={1: 1})
    >>> g.is_undirected, g.leader_reachable, g.laplacian.tolist()
    (True, True, [[1.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.0]])
    >>> make_digraph([[0, 1], [0, 0]]).spanning_tree_roots
    (1,)
    """
    if isinstance(obj, Digraph):
        if pinning is None:
            return obj
        return Digraph(obj.n, obj.arcs, _pinning(pinning, obj.n, obj.name), obj.name)
    if isinstance(obj, Graph):
        arcs = [(i + 1, j + 1, 1) for i, j in obj.edges] + [(j + 1, i + 1, 1) for i, j in obj.edges]
        return digraph_from_edges(arcs, n=obj.n, pinning=pinning, name=obj.name)
    if isinstance(obj, (str, os.PathLike)):
        p = Path(os.fspath(obj))
        is_file = path_is_file(p)
        if is_file and p.suffix.lower() == ".csv":
            lines = read_text(p, "adjacency CSV file", GraphError).splitlines()
            rows = [r for r in csv.reader(lines) if r and any(c.strip() for c in r) and not r[0].strip().startswith("#")]
            return _from_matrix(rows, pinning, str(p))
        if is_file:
            return read_edge_list(p, pinning)
        cycle = parse_cycle_spec(os.fspath(obj))
        return make_digraph(cycle if cycle is not None else make_graph(os.fspath(obj)), pinning)
    try:
        import networkx as nx
    except ImportError:  # pragma: no cover - networkx is a dependency
        nx = None
    if nx is not None and isinstance(obj, nx.Graph):
        return _from_networkx(obj, pinning, leader)
    if isinstance(obj, (np.ndarray, list, tuple)):
        return _from_matrix(obj, pinning, "adjacency")
    raise GraphError(
        f"expected an edge-list or CSV file, graph spec, networkx graph, adjacency array or Graph, received {type(obj).__name__}"
    )
