"""Weighted directed communication graphs, with optional pinning gains to a leader.

Convention
----------
Spacecraft are numbered ``1..N`` wherever a user sees them and ``0..N-1``
inside.  ``a_ij > 0`` **if spacecraft i receives information from spacecraft
j** (the information flows along the arc ``j -> i``); ``a_ii = 0``.  The
Laplacian is ``L = D - A`` with ``D = diag(sum_j a_ij)`` (weighted in-degree,
the row sums), so ``L 1 = 0``.  A leader (or reference) is seen by spacecraft
``i`` with pinning gain ``b_i >= 0``; ``B = diag(b)``.

Inputs (edge lists ``i j w`` with ``j = 0`` for the leader, adjacency CSV,
networkx, undirected graphs) are read by
:mod:`formsync_design.graphs.digraph_io`.  Weights are kept exact
(:class:`fractions.Fraction`), so *balanced* and *undirected* are decided
exactly; the matrices are floats.

Properties (:class:`GraphProperty`) a theorem may require
----------------------------------------------------------
``weakly-connected``, ``spanning-tree`` (a node from which every node is
reachable along arcs: the *roots*), ``strongly-connected``, ``balanced``
(weighted in-degree = out-degree at every node), ``undirected``
(``a_ij = a_ji``) and ``leader-reachable`` (every spacecraft is reachable
from the leader, which talks only to pinned spacecraft: then all eigenvalues
of ``L + B`` have positive real part).
"""

from __future__ import annotations

import enum
from collections.abc import Iterable
from dataclasses import dataclass
from fractions import Fraction
from functools import cached_property
from typing import Any

import numpy as np

from formsync_design.errors import GraphError, InputError
from formsync_design.gains import json_number
from formsync_design.graphs.build import check_size
from formsync_design.ranges import check_range

__all__ = ["GraphProperty", "Digraph", "Arc"]

Arc = tuple[int, int, Fraction]
"""An arc ``(i, j, a_ij)``, 0-based: spacecraft ``i`` receives from ``j`` with weight ``a_ij``."""


class GraphProperty(enum.StrEnum):
    """A graph property a design's theorem may require (module docstring)."""

    WEAKLY_CONNECTED = "weakly-connected"
    SPANNING_TREE = "spanning-tree"
    STRONGLY_CONNECTED = "strongly-connected"
    BALANCED = "balanced"
    UNDIRECTED = "undirected"
    LEADER_REACHABLE = "leader-reachable"


_WORDING = {
    GraphProperty.WEAKLY_CONNECTED: "weakly connected",
    GraphProperty.SPANNING_TREE: "with a directed spanning tree",
    GraphProperty.STRONGLY_CONNECTED: "strongly connected",
    GraphProperty.BALANCED: "balanced",
    GraphProperty.UNDIRECTED: "undirected (a_ij = a_ji)",
    GraphProperty.LEADER_REACHABLE: "with every spacecraft reachable from the leader",
}


def _sets(groups: Iterable[Iterable[int]]) -> str:
    return "; ".join("{" + ",".join(str(v + 1) for v in sorted(g)) + "}" for g in sorted(sorted(g) for g in groups))


@dataclass(frozen=True)
class Digraph:
    """A validated weighted digraph with optional pinning gains (module docstring).

    Parameters
    ----------
    n : int
        Number of spacecraft (at least 1).
    arcs : tuple of (int, int, Fraction)
        0-based ``(i, j, a_ij)``: ``i`` receives from ``j``; sorted, no duplicates.
    pinning : tuple of Fraction
        ``b_1..b_N`` (all ``>= 0``), or empty when there is no leader.
    name : str
        Where the graph came from.

    Examples
    --------
    >>> from formsync_design.graphs.digraph_io import digraph_from_edges
    >>> g = digraph_from_edges([(2, 1, 1), (3, 2, "0.5")], pinning=[1, 0, 0], name="chain")
    >>> g.laplacian.tolist()
    [[0.0, 0.0, 0.0], [-1.0, 1.0, 0.0], [0.0, -0.5, 0.5]]
    >>> g.spanning_tree_roots, g.is_strongly_connected, g.leader_reachable
    ((0,), False, True)
    """

    n: int
    arcs: tuple[Arc, ...]
    pinning: tuple[Fraction, ...] = ()
    name: str = "digraph"

    def __post_init__(self) -> None:
        n = self.n
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
            raise GraphError(f"expected at least 1 spacecraft, received {n!r}")
        check_size(int(n), self.name)
        seen: set[tuple[int, int]] = set()
        for i, j, w in self.arcs:
            if not (0 <= i < n and 0 <= j < n):
                raise GraphError(f"expected spacecraft numbers in 1..{n}, received arc ({i + 1}, {j + 1}) in {self.name!r}")
            if i == j:
                raise GraphError(f"expected no self-loops, received arc ({i + 1}, {j + 1}) in {self.name!r}")
            if not isinstance(w, Fraction):
                raise GraphError(
                    f"expected an exact (Fraction) weight a_{i + 1},{j + 1} (build with make_digraph or "
                    f"digraph_from_edges), received {type(w).__name__}"
                )
            if w <= 0:
                raise GraphError(f"expected a positive weight a_{i + 1},{j + 1}, received {float(w):g} in {self.name!r}")
            check_range(w, "weight", f"a_{i + 1},{j + 1} in {self.name!r}")
            if (i, j) in seen:
                raise GraphError(f"expected each arc once, received a_{i + 1},{j + 1} twice in {self.name!r}")
            seen.add((i, j))
        if tuple(sorted(self.arcs)) != tuple(self.arcs):
            raise GraphError("expected arcs in sorted order (use make_digraph or digraph_from_edges)")
        if self.pinning:
            if len(self.pinning) != n:
                raise GraphError(f"expected {n} pinning gains b_i, received {len(self.pinning)} in {self.name!r}")
            for i, b in enumerate(self.pinning):
                if not isinstance(b, Fraction):
                    raise GraphError(f"expected an exact (Fraction) pinning gain b_{i + 1}, received {type(b).__name__}")
                if b < 0:
                    raise GraphError(f"expected a pinning gain b_{i + 1} >= 0, received {float(b):g} in {self.name!r}")
                check_range(b, "weight", f"b_{i + 1} in {self.name!r}")

    # ------------------------------------------------------------ matrices
    @cached_property
    def adjacency(self) -> np.ndarray:
        """``A`` with ``A[i, j] = a_ij`` (float, N x N)."""
        a = np.zeros((self.n, self.n))
        for i, j, w in self.arcs:
            a[i, j] = float(w)
        return a

    @cached_property
    def laplacian(self) -> np.ndarray:
        """``L = D - A``, ``D`` the row sums (weighted in-degrees)."""
        a = self.adjacency
        return np.diag(a.sum(axis=1)) - a

    @property
    def has_leader(self) -> bool:
        """Whether pinning gains were given (a leader or reference exists)."""
        return bool(self.pinning)

    @cached_property
    def pinning_matrix(self) -> np.ndarray:
        """``B = diag(b_i)`` (zeros when there is no leader)."""
        return np.diag([float(b) for b in self.pinning]) if self.pinning else np.zeros((self.n, self.n))

    @cached_property
    def laplacian_eigenvalues(self) -> np.ndarray:
        """Eigenvalues of ``L`` (complex), sorted by real then imaginary part."""
        return np.sort_complex(np.linalg.eigvals(self.laplacian).astype(complex))

    @cached_property
    def pinned_eigenvalues(self) -> np.ndarray:
        """Eigenvalues of ``L + B`` (complex), sorted by real then imaginary part."""
        return np.sort_complex(np.linalg.eigvals(self.laplacian + self.pinning_matrix).astype(complex))

    @cached_property
    def in_weights(self) -> tuple[Fraction, ...]:
        """Exact weighted in-degree ``sum_j a_ij`` of every spacecraft."""
        out = [Fraction(0)] * self.n
        for i, _, w in self.arcs:
            out[i] += w
        return tuple(out)

    @cached_property
    def out_weights(self) -> tuple[Fraction, ...]:
        """Exact weighted out-degree ``sum_i a_ij`` of every spacecraft."""
        out = [Fraction(0)] * self.n
        for _, j, w in self.arcs:
            out[j] += w
        return tuple(out)

    def receives_from(self, i: int) -> tuple[int, ...]:
        """0-based spacecraft that 0-based ``i`` receives from, increasing."""
        return tuple(j for a, j, _ in self.arcs if a == i)

    # ------------------------------------------------------------ structure
    @cached_property
    def _succ(self) -> tuple[tuple[int, ...], ...]:
        succ: list[list[int]] = [[] for _ in range(self.n)]
        for i, j, _ in self.arcs:
            succ[j].append(i)  # information flows j -> i
        return tuple(tuple(s) for s in succ)

    def reachable_from(self, sources: Iterable[int]) -> frozenset[int]:
        """0-based spacecraft reachable along arcs from 0-based ``sources`` (inclusive)."""
        seen = set(sources)
        stack = list(seen)
        while stack:
            for v in self._succ[stack.pop()]:
                if v not in seen:
                    seen.add(v)
                    stack.append(v)
        return frozenset(seen)

    @cached_property
    def strong_components(self) -> tuple[frozenset[int], ...]:
        """Strongly connected components (Kosaraju, iterative), sorted by smallest member."""
        n, succ = self.n, self._succ
        pred: list[list[int]] = [[] for _ in range(n)]
        for j in range(n):
            for i in succ[j]:
                pred[i].append(j)
        order: list[int] = []
        seen = [False] * n
        for s in range(n):
            if seen[s]:
                continue
            seen[s] = True
            stack = [(s, 0)]
            while stack:
                v, k = stack[-1]
                if k < len(succ[v]):
                    stack[-1] = (v, k + 1)
                    w = succ[v][k]
                    if not seen[w]:
                        seen[w] = True
                        stack.append((w, 0))
                else:
                    stack.pop()
                    order.append(v)
        comp = [-1] * n
        comps: list[set[int]] = []
        for s in reversed(order):
            if comp[s] >= 0:
                continue
            comp[s] = len(comps)
            members, stack2 = {s}, [s]
            while stack2:
                for w in pred[stack2.pop()]:
                    if comp[w] < 0:
                        comp[w] = comp[s]
                        members.add(w)
                        stack2.append(w)
            comps.append(members)
        return tuple(sorted((frozenset(c) for c in comps), key=min))

    @cached_property
    def source_components(self) -> tuple[frozenset[int], ...]:
        """Strong components that receive nothing from outside themselves."""
        where = {v: k for k, c in enumerate(self.strong_components) for v in c}
        fed = {where[i] for i, j, _ in self.arcs if where[i] != where[j]}
        return tuple(c for k, c in enumerate(self.strong_components) if k not in fed)

    @property
    def spanning_tree_roots(self) -> tuple[int, ...]:
        """0-based roots of directed spanning trees (empty if there is none)."""
        src = self.source_components
        return tuple(sorted(src[0])) if len(src) == 1 else ()

    @property
    def has_spanning_tree(self) -> bool:
        """Whether some spacecraft reaches every other along arcs."""
        return bool(self.spanning_tree_roots)

    @property
    def is_strongly_connected(self) -> bool:
        """Whether every spacecraft reaches every other."""
        return len(self.strong_components) == 1

    @cached_property
    def weak_components(self) -> tuple[frozenset[int], ...]:
        """Components of the graph with arc directions ignored, sorted by smallest member."""
        parent = list(range(self.n))

        def find(x: int) -> int:
            while parent[x] != x:
                parent[x] = parent[parent[x]]
                x = parent[x]
            return x

        for i, j, _ in self.arcs:
            parent[find(i)] = find(j)
        groups: dict[int, set[int]] = {}
        for v in range(self.n):
            groups.setdefault(find(v), set()).add(v)
        return tuple(sorted((frozenset(g) for g in groups.values()), key=min))

    @property
    def is_weakly_connected(self) -> bool:
        """Whether the graph is connected when directions are ignored."""
        return len(self.weak_components) == 1

    @property
    def is_balanced(self) -> bool:
        """Whether weighted in-degree equals out-degree at every spacecraft (exact)."""
        return self.in_weights == self.out_weights

    @cached_property
    def is_undirected(self) -> bool:
        """Whether ``a_ij = a_ji`` for all pairs (exact)."""
        w = {(i, j): a for i, j, a in self.arcs}
        return all(w.get((j, i)) == a for (i, j), a in w.items())

    @property
    def unreachable_from_leader(self) -> tuple[int, ...]:
        """0-based spacecraft the leader cannot reach through pinned spacecraft (all, if no leader)."""
        pinned = [i for i, b in enumerate(self.pinning) if b > 0]
        reach = self.reachable_from(pinned)
        return tuple(v for v in range(self.n) if v not in reach)

    @property
    def leader_reachable(self) -> bool:
        """Whether there is a leader and it reaches every spacecraft."""
        return self.has_leader and not self.unreachable_from_leader

    # ------------------------------------------------------------ theorem checks
    def has(self, prop: GraphProperty | str) -> bool:
        """Whether the graph has ``prop`` (a :class:`GraphProperty` or its name).

        >>> from formsync_design.graphs.digraph_io import make_digraph
        >>> make_digraph("ring:4").has("balanced")
        True
        """
        p = _property(prop)
        return {
            GraphProperty.WEAKLY_CONNECTED: lambda: self.is_weakly_connected,
            GraphProperty.SPANNING_TREE: lambda: self.has_spanning_tree,
            GraphProperty.STRONGLY_CONNECTED: lambda: self.is_strongly_connected,
            GraphProperty.BALANCED: lambda: self.is_balanced,
            GraphProperty.UNDIRECTED: lambda: self.is_undirected,
            GraphProperty.LEADER_REACHABLE: lambda: self.leader_reachable,
        }[p]()

    def properties(self) -> dict[str, bool]:
        """Every :class:`GraphProperty` with whether the graph has it."""
        return {str(p): self.has(p) for p in GraphProperty}

    def why_not(self, prop: GraphProperty | str) -> str:
        """Why the graph lacks ``prop`` (one phrase; meaningful when ``not has(prop)``).

        >>> from formsync_design.graphs.digraph_io import make_digraph
        >>> make_digraph([[0, 1], [0, 0]]).why_not("strongly-connected")
        '2 strong components {1}; {2}'
        """
        return self._why_not(_property(prop))

    def _why_not(self, p: GraphProperty) -> str:
        if p is GraphProperty.WEAKLY_CONNECTED:
            return f"{len(self.weak_components)} weak components {_sets(self.weak_components)}"
        if p is GraphProperty.SPANNING_TREE:
            return f"no root; {len(self.source_components)} source components {_sets(self.source_components)}"
        if p is GraphProperty.STRONGLY_CONNECTED:
            return f"{len(self.strong_components)} strong components {_sets(self.strong_components)}"
        if p is GraphProperty.BALANCED:
            i = next(k for k in range(self.n) if self.in_weights[k] != self.out_weights[k])
            return f"spacecraft {i + 1} receives {float(self.in_weights[i]):g} but sends {float(self.out_weights[i]):g}"
        if p is GraphProperty.UNDIRECTED:
            w = {(i, j): a for i, j, a in self.arcs}
            i, j = next(k for k, a in w.items() if w.get((k[1], k[0])) != a)
            back = float(w.get((j, i), 0))
            return f"a_{i + 1},{j + 1} = {float(w[(i, j)]):g} but a_{j + 1},{i + 1} = {back:g}"
        if not self.has_leader:
            return "no leader (no pinning gains b_i)"
        return f"spacecraft {_sets([self.unreachable_from_leader])} not reachable from the leader"

    def require(self, props: Iterable[GraphProperty | str], by: str = "") -> None:
        """Raise one-line :class:`GraphError` naming every property in ``props`` the graph lacks.

        Parameters
        ----------
        props : iterable of GraphProperty or str
            What the theorem needs.
        by : str
            Who needs it (a design name), shown in the message.

        Examples
        --------
        >>> from formsync_design.graphs.digraph_io import digraph_from_edges
        >>> g = digraph_from_edges([(2, 1, 1), (3, 2, 1)], name="chain")
        >>> g.require(["spanning-tree"])
        >>> g.require(["strongly-connected"], by="design 'x'")
        Traceback (most recent call last):
        ...
        formsync_design.errors.GraphError: expected a graph that is strongly connected (required by design 'x'), received 'chain' which lacks strongly-connected: 3 strong components {1}; {2}; {3}
        """
        wanted = [_property(p) for p in props]
        missing = [p for p in dict.fromkeys(wanted) if not self.has(p)]
        if not missing:
            return
        need = " and ".join(_WORDING[p] for p in missing)
        for_ = f" (required by {by})" if by else ""
        why = "; and ".join(f"{p}: {self._why_not(p)}" for p in missing)
        raise GraphError(f"expected a graph that is {need}{for_}, received {self.name!r} which lacks {why}")

    # ------------------------------------------------------------ exports
    def edge_list_1based(self) -> list[list[Any]]:
        """Arcs as ``[i, j, a_ij]`` (1-based, JSON numbers), then ``[i, 0, b_i]`` for pinned spacecraft."""
        rows = [[i + 1, j + 1, json_number(w)] for i, j, w in self.arcs]
        return rows + [[i + 1, 0, json_number(b)] for i, b in enumerate(self.pinning) if b > 0]

    def to_networkx(self, leader: Any = 0) -> Any:
        """A :class:`networkx.DiGraph` on nodes ``1..N`` with arcs ``j -> i`` (attribute ``weight``);
        with a leader, node ``leader`` and arcs ``leader -> i`` weighted ``b_i``."""
        import networkx as nx

        g = nx.DiGraph(name=self.name)
        g.add_nodes_from(range(1, self.n + 1))
        g.add_weighted_edges_from((j + 1, i + 1, float(w)) for i, j, w in self.arcs)
        if self.has_leader:
            g.add_node(leader)
            g.add_weighted_edges_from((leader, i + 1, float(b)) for i, b in enumerate(self.pinning) if b > 0)
        return g

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready description: arcs, pinning, properties and spanning-tree roots (1-based)."""
        return {
            "name": self.name,
            "n": self.n,
            "convention": "a_ij > 0 if spacecraft i receives from j; L = D - A (row sums)",
            "arcs": [[i + 1, j + 1, json_number(w)] for i, j, w in self.arcs],
            "pinning": [json_number(b) for b in self.pinning],
            "properties": self.properties(),
            "spanning_tree_roots": [r + 1 for r in self.spanning_tree_roots],
        }


def _property(p: GraphProperty | str) -> GraphProperty:
    try:
        return GraphProperty(p)
    except ValueError:
        names = ", ".join(x.value for x in GraphProperty)
        raise InputError(f"expected a graph property ({names}), received {p!r}") from None
