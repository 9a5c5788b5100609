"""Undirected communication graphs of a spacecraft formation.

Spacecraft are numbered ``1..N`` wherever a user sees them (specs, files,
reports); internally they are ``0..N-1``.  A :class:`Graph` is immutable and
always valid for the paper's controller: undirected, simple, unweighted (0/1),
connected, with at least two spacecraft.

Accepted inputs (:func:`make_graph`)
------------------------------------
* spec strings ``ring:N``, ``path:N``, ``star:N`` (centre = spacecraft 1),
  ``complete:N``, ``circulant:N:a,b,...`` and ``random:N:P:SEED``
  (seeded Erdos-Renyi G(N, P), rejected if disconnected);
* a path to an edge-list file (one ``i j`` pair per line, 1-based, ``#``
  comments) or to an adjacency-matrix CSV file (``.csv``);
* a :class:`networkx.Graph`, a square numpy array (adjacency), or a ``Graph``.

Size limit
----------
A formation has at most :data:`MAX_SPACECRAFT` (2000) spacecraft.  A
:class:`Graph` keeps its adjacency and Laplacian as dense ``N x N`` int64
matrices (``8 N^2`` bytes each: 32 MB at the cap, 80 PB for ``ring:10^8``) and
computes the Laplacian spectrum with a dense ``O(N^3)`` eigen-decomposition
(seconds at the cap); the symbolic derivation, the certification and the
simulation grow faster still.  Larger sizes are refused up front with a
one-line :class:`~formsync_design.errors.GraphError` before anything is
allocated, instead of exhausting the memory.
"""

from __future__ import annotations

import csv
import errno
import os
import re
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np

from formsync_design.errors import GraphError
from formsync_design.textio import ascii_float, check_ascii, cut, read_text

__all__ = ["Graph", "make_graph", "parse_graph_spec", "check_size", "GRAPH_SPEC_HELP", "MAX_SPACECRAFT",
           "path_is_file", "check_name_length"]

MAX_SPACECRAFT = 2000
"""Largest formation accepted (module docstring: dense N x N matrices, O(N^3) spectrum)."""

GRAPH_SPEC_HELP = (
    "ring:N | path:N | star:N | complete:N | circulant:N:a,b,... | random:N:P:SEED "
    "| cycle:N (directed) | an edge-list file (1-based 'i j' per line) | an adjacency CSV file"
)


@dataclass(frozen=True)
class Graph:
    """A validated undirected communication graph.

    Parameters
    ----------
    n : int
        Number of spacecraft.
    edges : tuple of (int, int)
        0-based edges ``(i, j)`` with ``i < j``, sorted, no duplicates.
    name : str
        A human-readable name (the spec it came from).

    Examples
    --------
    >>> g = make_graph("ring:4")
    >>> g.n, g.degrees
    (4, (2, 2, 2, 2))
    >>> g.neighbors(0)
    (1, 3)
    """

    n: int
    edges: tuple[tuple[int, int], ...]
    name: str = "graph"

    def __post_init__(self) -> None:
        _validate(self.n, self.edges)

    @cached_property
    def adjacency(self) -> np.ndarray:
        """Integer adjacency matrix (N x N)."""
        a = np.zeros((self.n, self.n), dtype=np.int64)
        for i, j in self.edges:
            a[i, j] = a[j, i] = 1
        return a

    @cached_property
    def laplacian(self) -> np.ndarray:
        """Integer graph Laplacian ``D - A`` (N x N)."""
        a = self.adjacency
        return np.diag(a.sum(axis=1)) - a

    @cached_property
    def degrees(self) -> tuple[int, ...]:
        """Degree ``m_i`` of every spacecraft (number of neighbours)."""
        return tuple(int(d) for d in self.adjacency.sum(axis=1))

    def neighbors(self, i: int) -> tuple[int, ...]:
        """0-based neighbours of 0-based spacecraft ``i`` in increasing order."""
        return tuple(int(j) for j in np.flatnonzero(self.adjacency[i]))

    @cached_property
    def laplacian_eigenvalues(self) -> np.ndarray:
        """Eigenvalues of the Laplacian in increasing order (floating point)."""
        return np.linalg.eigvalsh(self.laplacian.astype(float))

    @property
    def algebraic_connectivity(self) -> float:
        """lambda_2 of the Laplacian (floating point)."""
        return float(self.laplacian_eigenvalues[1])

    @property
    def laplacian_spectral_radius(self) -> float:
        """lambda_max of the Laplacian (floating point)."""
        return float(self.laplacian_eigenvalues[-1])

    def edge_list_1based(self) -> list[list[int]]:
        """Edges as 1-based pairs, as a user sees them."""
        return [[i + 1, j + 1] for i, j in self.edges]

    def to_networkx(self) -> Any:
        """The graph as a :class:`networkx.Graph` with nodes ``1..N``."""
        import networkx as nx

        g = nx.Graph()
        g.add_nodes_from(range(1, self.n + 1))
        g.add_edges_from((i + 1, j + 1) for i, j in self.edges)
        return g


def check_size(n: int, where: str = "") -> None:
    """Refuse a formation of more than :data:`MAX_SPACECRAFT` spacecraft (one line).

    >>> check_size(8)
    >>> check_size(100000000, "ring:100000000")
    Traceback (most recent call last):
    ...
    formsync_design.errors.GraphError: expected at most 2000 spacecraft (dense N x N Laplacian and O(N^3) spectrum), received N=100000000 in 'ring:100000000'
    """
    if n > MAX_SPACECRAFT:
        at = f" in {where!r}" if where else ""
        raise GraphError(
            f"expected at most {MAX_SPACECRAFT} spacecraft (dense N x N Laplacian and O(N^3) "
            f"spectrum), received N={int(n)}{at}"
        )


def _validate(n: int, edges: tuple[tuple[int, int], ...]) -> None:
    if isinstance(n, (bool, np.bool_)) or not isinstance(n, (int, np.integer)) or n < 2:
        shown = int(n) if isinstance(n, (int, np.integer)) else repr(n)
        raise GraphError(f"expected a formation of at least 2 spacecraft, received {shown}")
    check_size(int(n))
    seen: set[tuple[int, int]] = set()
    for e in edges:
        i, j = e
        if i == j:
            raise GraphError(f"expected no self-loops, received edge ({i + 1}, {j + 1})")
        if not (0 <= i < n and 0 <= j < n):
            raise GraphError(
                f"expected spacecraft numbers in 1..{n}, received edge ({i + 1}, {j + 1})"
            )
        if i > j:
            raise GraphError(f"expected internal edges (i, j) with i < j, received {e}")
        if (i, j) in seen:
            raise GraphError(f"expected each edge once, received ({i + 1}, {j + 1}) twice")
        seen.add((i, j))
    if tuple(sorted(edges)) != tuple(edges):
        raise GraphError("expected internal edges in sorted order")
    # connectivity by union-find
    parent = list(range(n))

    def find(x: int) -> int:
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x

    for i, j in edges:
        parent[find(i)] = find(j)
    roots = {find(i) for i in range(n)}
    if len(roots) > 1:
        comps: dict[int, list[int]] = {}
        for i in range(n):
            comps.setdefault(find(i), []).append(i + 1)
        parts = sorted(comps.values())
        raise GraphError(
            "expected a connected graph (the formation cannot synchronize otherwise), "
            f"received {len(parts)} components: "
            + "; ".join("{" + ",".join(map(str, p)) + "}" for p in parts)
        )


def _from_pairs(n: int, pairs: list[tuple[int, int]], name: str) -> Graph:
    """Build from 0-based pairs, checking duplicates in either orientation."""
    check_size(n, name)
    norm: list[tuple[int, int]] = []
    seen: set[tuple[int, int]] = set()
    for i, j in pairs:
        if i == j:
            raise GraphError(f"expected no self-loops, received edge ({i + 1}, {j + 1})")
        if not (0 <= i < n and 0 <= j < n):
            raise GraphError(
                f"expected spacecraft numbers in 1..{n}, received edge ({i + 1}, {j + 1})"
            )
        key = (min(i, j), max(i, j))
        if key in seen:
            raise GraphError(
                f"expected each edge once, received ({key[0] + 1}, {key[1] + 1}) twice"
            )
        seen.add(key)
        norm.append(key)
    return Graph(n=n, edges=tuple(sorted(norm)), name=name)


def _int_field(text: str, what: str, spec: str) -> int:
    """An integer of ASCII digits 0-9 (``int`` would also take ``'\u09ea'``, ``'1_0'``)."""
    if not re.fullmatch(r"[0-9]{1,12}", text.strip()):
        raise GraphError(
            f"expected an integer {what} (digits 0-9) in graph spec, received {cut(text)} in "
            f"{cut(spec, 40)}"
        )
    return int(text)


def parse_graph_spec(spec: str) -> Graph:
    """Build a graph from a spec string such as ``ring:8``.

    Parameters
    ----------
    spec : str
        ``ring:N``, ``path:N``, ``star:N`` (centre = spacecraft 1), ``complete:N``,
        ``circulant:N:a,b,...`` (spacecraft i linked to i +/- a mod N) or
        ``random:N:P:SEED``.

    Returns
    -------
    Graph

    Examples
    --------
    >>> parse_graph_spec("star:4").edge_list_1based()
    [[1, 2], [1, 3], [1, 4]]
    >>> parse_graph_spec("circulant:8:1,4").degrees
    (3, 3, 3, 3, 3, 3, 3, 3)
    """
    if not isinstance(spec, str):
        raise GraphError(f"expected a graph spec string ({GRAPH_SPEC_HELP}), received {cut(spec, 40)}")
    check_ascii(spec, f"the graph spec {cut(spec, 40)}", GraphError)
    parts = spec.strip().split(":")
    kind = parts[0].lower()
    arity = {"ring": 2, "path": 2, "star": 2, "complete": 2, "circulant": 3, "random": 4}
    if kind not in arity:
        raise GraphError(f"expected a graph spec of the form {GRAPH_SPEC_HELP}, received {cut(spec, 40)}")
    if len(parts) != arity[kind]:
        form = {
            "ring": "ring:N", "path": "path:N", "star": "star:N", "complete": "complete:N",
            "circulant": "circulant:N:a,b,...", "random": "random:N:P:SEED",
        }[kind]
        raise GraphError(f"expected {form}, received {cut(spec, 40)}")
    n = _int_field(parts[1], "number of spacecraft N", spec)
    if n < 2:
        raise GraphError(f"expected at least 2 spacecraft, received N={n} in {cut(spec, 40)}")
    check_size(n, spec.strip())
    name = spec.strip()
    if kind == "ring":
        if n < 3:
            raise GraphError(f"expected N >= 3 for a ring (a cycle), received N={n} in {cut(spec, 40)}")
        return _from_pairs(n, [(i, (i + 1) % n) for i in range(n)], name)
    if kind == "path":
        return _from_pairs(n, [(i, i + 1) for i in range(n - 1)], name)
    if kind == "star":
        return _from_pairs(n, [(0, i) for i in range(1, n)], name)
    if kind == "complete":
        return _from_pairs(n, [(i, j) for i in range(n) for j in range(i + 1, n)], name)
    if kind == "circulant":
        offs = [_int_field(a, "circulant offset", spec) for a in parts[2].split(",") if a != ""]
        if not offs:
            raise GraphError(f"expected at least one circulant offset, received {cut(spec, 40)}")
        pairs: set[tuple[int, int]] = set()
        for a in offs:
            if not 1 <= a <= n // 2:
                raise GraphError(
                    f"expected circulant offsets in 1..{n // 2} for N={n}, received {a} in {cut(spec, 40)}"
                )
            for i in range(n):
                j = (i + a) % n
                pairs.add((min(i, j), max(i, j)))
        if len(set(offs)) != len(offs):
            raise GraphError(f"expected distinct circulant offsets, received {cut(parts[2])}")
        return Graph(n=n, edges=tuple(sorted(pairs)), name=name)
    # random
    p_or_none = ascii_float(parts[2])
    if p_or_none is None:
        raise GraphError(f"expected an edge probability P in (0, 1], received {cut(parts[2])}")
    p = p_or_none
    if not (0.0 < p <= 1.0):
        raise GraphError(f"expected an edge probability P in (0, 1], received {p!r}")
    seed = _int_field(parts[3], "seed", spec)
    rng = np.random.default_rng(seed)
    pairs_r = [(i, j) for i in range(n) for j in range(i + 1, n) if rng.random() < p]
    return _from_pairs(n, pairs_r, name)


def _from_adjacency(a: Any, name: str) -> Graph:
    arr = np.asarray(a)
    if arr.ndim != 2 or arr.shape[0] != arr.shape[1]:
        shape = "x".join(str(int(k)) for k in arr.shape) or "scalar"
        raise GraphError(f"expected a square adjacency matrix, received shape {shape}")
    check_size(arr.shape[0], name)
    if arr.dtype == object or not np.issubdtype(arr.dtype, np.number):
        try:
            arr = arr.astype(float)
        except (TypeError, ValueError):
            raise GraphError(
                f"expected a numeric adjacency matrix, received dtype {arr.dtype}"
            ) from None
    if not np.all(np.isfinite(arr)):
        raise GraphError("expected finite 0/1 adjacency entries, received NaN or inf")
    bad = np.argwhere((arr != 0) & (arr != 1))
    if bad.size:
        i, j = bad[0]
        raise GraphError(
            f"expected 0/1 adjacency weights, received {float(arr[i, j]):g} at ({i + 1}, {j + 1})"
        )
    if np.any(np.diag(arr) != 0):
        i = int(np.flatnonzero(np.diag(arr))[0])
        raise GraphError(f"expected no self-loops, received a 1 on the diagonal at ({i + 1}, {i + 1})")
    asym = np.argwhere(arr != arr.T)
    if asym.size:
        i, j = asym[0]
        raise GraphError(
            "expected a symmetric adjacency matrix (this controller needs an undirected graph), "
            f"received a[{i + 1},{j + 1}]={float(arr[i, j]):g} but a[{j + 1},{i + 1}]={float(arr[j, i]):g}"
        )
    n = arr.shape[0]
    pairs = [(i, j) for i in range(n) for j in range(i + 1, n) if arr[i, j] == 1]
    return Graph(n=n, edges=tuple(pairs), name=name)


def _read_text(path: Path, what: str) -> str:
    """A UTF-8 text file's content; one-line :class:`GraphError` otherwise."""
    return read_text(path, what, GraphError)


def _read_edge_list(path: Path) -> Graph:
    pairs: list[tuple[int, int]] = []
    nmax = 0
    declared_n: int | None = None
    for lineno, raw in enumerate(_read_text(path, "edge-list file").splitlines(), start=1):
        line = raw.split("#", 1)[0].strip()
        if not line:
            # a comment of the form "# n = 8" declares isolated trailing spacecraft
            c = raw.split("#", 1)[1].strip().replace(" ", "") if "#" in raw else ""
            if c.lower().startswith("n="):
                declared_n = _int_field(c[2:], "spacecraft count in '# n = N'", str(path))
            continue
        fields = line.replace(",", " ").split()
        if len(fields) != 2:
            raise GraphError(
                f"expected one 'i j' pair per line, received {len(fields)} fields "
                f"{cut(line)} at {path}:{lineno}"
            )
        bad = next((f for f in fields if not re.fullmatch(r"[0-9]{1,12}", f)), None)
        if bad is not None:
            raise GraphError(
                f"expected integer spacecraft numbers (digits 0-9), received {cut(bad)} at "
                f"{path}:{lineno}, column {raw.index(bad) + 1}"
            )
        i, j = int(fields[0]), int(fields[1])
        if i < 1 or j < 1:
            raise GraphError(
                f"expected 1-based spacecraft numbers (>= 1), received {cut(line)} at {path}:{lineno}"
            )
        pairs.append((i - 1, j - 1))
        nmax = max(nmax, i, j)
        check_size(nmax, f"{path}:{lineno}")
    if not pairs:
        raise GraphError(f"expected at least one edge in {path}, received none")
    n = declared_n if declared_n is not None else nmax
    check_size(n, str(path))
    return _from_pairs(n, pairs, str(path))


def _symmetric_arc_list(path: Path) -> Graph | None:
    """The undirected graph of an arc-list file (``i j w`` lines, the digraph format: each
    line one arc) that lists every link both ways with weight 1 and no leader; else None.
    A file of ``i j`` pairs alone is this reader's format, where each link is listed once.

    >>> import tempfile
    >>> p = Path(tempfile.mkdtemp()) / "g.txt"
    >>> _ = p.write_text("1 2 1\\n2 1 1\\n2 3 1\\n3 2 1\\n")
    >>> _symmetric_arc_list(p).edges, _symmetric_arc_list(p).name == str(p)
    (((0, 1), (1, 2)), True)
    """
    from formsync_design.graphs.digraph_io import read_edge_list

    lines = (ln.split("#", 1)[0].replace(",", " ").split() for ln in _read_text(path, "edge-list file").splitlines())
    if not any(len(f) == 3 for f in lines):
        return None
    try:
        d = read_edge_list(path)
    except GraphError:
        return None
    if d.has_leader or not d.is_undirected or any(w != 1 for _, _, w in d.arcs):
        return None
    try:
        return Graph(d.n, tuple(sorted({(i, j) for i, j, _ in d.arcs if i < j})), str(path))
    except GraphError:  # e.g. disconnected: the digraph reader's reading stands
        return None


def _read_csv(path: Path) -> Graph:
    import io

    rows: list[list[float]] = []
    text = _read_text(path, "adjacency CSV file")
    for lineno, row in enumerate(csv.reader(io.StringIO(text, newline="")), start=1):
        cells = [c.strip() for c in row]
        if not cells or all(c == "" for c in cells) or cells[0].startswith("#"):
            continue
        if len(rows) > MAX_SPACECRAFT or len(cells) > MAX_SPACECRAFT + 1:
            check_size(max(len(rows), len(cells)), str(path))
        vals = [ascii_float(c) for c in cells]
        bad = next((c for c, v in zip(cells, vals) if v is None), None)
        if bad is not None:
            raise GraphError(
                f"expected numeric 0/1 entries (digits 0-9) in adjacency CSV, received {cut(bad)} "
                f"at {path}:{lineno}"
            )
        rows.append([float(v) for v in vals if v is not None])
    if not rows or len({len(r) for r in rows}) != 1:
        raise GraphError(
            f"expected a square adjacency matrix in {path}, received rows of lengths "
            f"{sorted({len(r) for r in rows})}"
        )
    return _from_adjacency(np.array(rows), str(path))


def path_is_file(p: str | os.PathLike[str]) -> bool:
    """Whether ``p`` is an existing regular file (symlinks followed); a name the system
    cannot look up (over its length limit) is not a file, never an ``OSError``.

    >>> path_is_file("x" * 300), path_is_file("ring:8")
    (False, False)
    """
    try:
        return Path(p).is_file()
    except OSError as e:  # ENAMETOOLONG: Path.is_file lets it through
        if e.errno == errno.ENAMETOOLONG:
            return False
        raise


def check_name_length(text: str) -> None:
    """Refuse a path with a component over the system's limit (255 bytes), as the command line
    does, so a too-long name read from a data file is named as such.

    >>> check_name_length("x" * 300)
    Traceback (most recent call last):
    ...
    formsync_design.errors.GraphError: expected a path within the system's limits (a name of at most 255 bytes), received one too long (300 characters, 'xxxxxxxxxxxxxxxxxxxxxx…')
    """
    if any(len(os.fsencode(part)) > 255 for part in Path(text).parts):
        raise GraphError("expected a path within the system's limits (a name of at most 255 "
                         f"bytes), received one too long ({len(text)} characters, {cut(text)})")


def make_graph(obj: Any) -> Graph:
    """Build a validated :class:`Graph` from any supported input.

    Parameters
    ----------
    obj : str, os.PathLike, networkx.Graph, numpy.ndarray or Graph
        A spec string, a path to an edge-list or adjacency-CSV file, a
        networkx graph (nodes are relabelled ``1..N`` in sorted order), or a
        square 0/1 adjacency array.

    Returns
    -------
    Graph

    Raises
    ------
    GraphError
        For a directed/asymmetric, weighted, self-looped, disconnected or
        too small graph, or a malformed spec or file.

    Examples
    --------
    >>> import numpy as np
    >>> make_graph(np.array([[0, 1], [1, 0]])).edges
    ((0, 1),)
    >>> make_graph("path:3").laplacian.tolist()
    [[1, -1, 0], [-1, 2, -1], [0, -1, 1]]
    """
    if isinstance(obj, Graph):
        return obj
    if isinstance(obj, (str, os.PathLike)):
        text = os.fspath(obj)
        if not text.strip():  # Path('') is the working folder: never implied
            raise GraphError(f"expected a graph spec ({GRAPH_SPEC_HELP}) or an existing file, "
                             f"received {text!r} (an empty name)")
        p = Path(text)
        spec = isinstance(obj, str) and ":" in text and text.split(":", 1)[0].lower() in {
            "ring", "path", "star", "complete", "circulant", "random"
        }
        # an existing path that is no regular file (a folder, a FIFO, a symlink loop) is
        # refused by the reader, each with its own reason
        if path_is_file(p) or (not spec and os.path.lexists(p)):
            if p.suffix.lower() == ".csv":
                return _read_csv(p)
            try:
                return _read_edge_list(p)
            except GraphError as first:  # an i j w arc list listing each link both ways?
                g = _symmetric_arc_list(p) if path_is_file(p) else None
                if g is None:
                    raise first from None
                return g
        if spec:
            return parse_graph_spec(text)
        check_name_length(text)
        if ":" in text:  # a look-alike family ('ｒｉｎｇ:8') is named with its column
            check_ascii(text, f"the graph spec {cut(text, 40)}", GraphError)
        raise GraphError(
            f"expected a graph spec ({GRAPH_SPEC_HELP}) or an existing file, received {cut(text, 40)}"
        )
    try:
        import networkx as nx
    except ImportError:  # pragma: no cover - networkx is a dependency
        nx = None
    if nx is not None and isinstance(obj, nx.Graph):
        if obj.is_directed():
            raise GraphError(
                "expected an undirected graph (this controller needs bidirectional links), "
                "received a directed networkx graph"
            )
        if obj.is_multigraph():
            raise GraphError("expected a simple graph, received a networkx multigraph")
        check_size(obj.number_of_nodes(), getattr(obj, "name", "") or "networkx graph")
        nodes = sorted(obj.nodes())
        idx = {v: k for k, v in enumerate(nodes)}
        for u, v, data in obj.edges(data=True):
            w = data.get("weight", 1)
            if w != 1:
                raise GraphError(f"expected unweighted (0/1) edges, received weight {w!r} on ({u}, {v})")
        pairs = [(idx[u], idx[v]) for u, v in obj.edges()]
        return _from_pairs(len(nodes), pairs, getattr(obj, "name", "") or "networkx")
    if isinstance(obj, np.ndarray) or isinstance(obj, (list, tuple)):
        return _from_adjacency(obj, "adjacency")
    raise GraphError(
        f"expected a graph spec, file path, networkx.Graph or adjacency array, received {type(obj).__name__}"
    )
