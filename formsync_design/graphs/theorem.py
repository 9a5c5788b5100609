"""The graphs a design's theorem covers: loading any graph input, and checking it.

A design declares the :class:`~formsync_design.graphs.digraph.GraphProperty` names its
theorem needs (``GRAPHS`` in the design file, e.g. ``("undirected", "weakly-connected")``
for Liang et al. 2016).  :func:`check_theorem_graph` decides them on a graph: a graph
that lacks one is refused with one line naming the design, the graph, the missing
property and why (a :class:`~formsync_design.errors.GraphError`, exit 2), unless the
user allows running outside the theorem, in which case the returned
:class:`TheoremCheck` lists what is missing so that every output can flag it.

:func:`load_graph` is the one entry point for a graph given by a user: an undirected,
unweighted input gives the :class:`~formsync_design.graphs.build.Graph` the derivation
works on; a directed or weighted input (an ``i j w`` edge list, a non-symmetric adjacency
CSV, a networkx ``DiGraph``) gives a :class:`~formsync_design.graphs.digraph.Digraph`.
"""

from __future__ import annotations

import os
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from formsync_design.errors import GraphError
from formsync_design.graphs.build import Graph, make_graph
from formsync_design.graphs.digraph import Digraph, GraphProperty
from formsync_design.graphs.digraph_io import make_digraph
from formsync_design.textio import read_text

__all__ = ["TheoremCheck", "check_theorem_graph", "load_graph", "as_digraph"]


def as_digraph(graph: Any) -> Digraph:
    """``graph`` as a :class:`Digraph` (an undirected ``Graph``: both arcs of each edge).

    >>> as_digraph("ring:4").is_balanced
    True
    """
    return graph if isinstance(graph, Digraph) else make_digraph(graph)


def load_graph(obj: Any) -> Graph | Digraph:
    """A graph from any input: a :class:`Graph` when the input is undirected and
    unweighted (graph specs, ``i j`` edge lists, symmetric 0/1 CSV), else a :class:`Digraph`.

    Examples
    --------
    >>> type(load_graph("ring:5")).__name__
    'Graph'
    >>> type(load_graph([[0, 1, 0], [0, 0, 1], [1, 0, 0]])).__name__
    'Digraph'
    """
    if isinstance(obj, (Graph, Digraph)):
        return obj
    try:
        return make_graph(obj)
    except GraphError as first:
        try:
            d = make_digraph(obj)
        except GraphError as second:
            # both readers refuse: the reason is the one of the reader whose format it is
            cycle = isinstance(obj, str) and obj.lower().startswith("cycle:")
            raise (second if cycle or _weighted_edge_list(obj) else first) from None
    return d


def _weighted_edge_list(obj: Any) -> bool:
    """Whether ``obj`` names an edge-list file in the digraph reader's format: a line of three
    columns ``i j w`` (the undirected reader takes ``i j`` pairs only).

    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "g.txt"
    >>> _ = p.write_text("# a weighted digraph\\n1 2 0.5\\n2 1\\n")
    >>> _weighted_edge_list(p), _weighted_edge_list("ring:4")
    (True, False)
    """
    if not isinstance(obj, (str, os.PathLike)):
        return False
    p = Path(os.fspath(obj))
    if p.suffix.lower() == ".csv" or not p.is_file():
        return False
    try:
        text = read_text(p, "edge-list file", GraphError)
    except GraphError:
        return False
    return any(len(line.split("#", 1)[0].replace(",", " ").split()) == 3
               for line in text.splitlines())


@dataclass(frozen=True)
class TheoremCheck:
    """What a graph lacks of a design's theorem (empty ``missing``: covered).

    Attributes
    ----------
    graph, design : str
    required : tuple of str
        The design's ``GRAPHS``.
    missing : tuple of str
        The required properties the graph lacks.
    reasons : tuple of str
        Why, one per missing property.
    """

    graph: str
    design: str
    required: tuple[str, ...]
    missing: tuple[str, ...] = ()
    reasons: tuple[str, ...] = ()

    @property
    def inside(self) -> bool:
        return not self.missing

    def note(self) -> str:
        """One line for outputs ("" inside the theorem)."""
        if self.inside:
            return ""
        why = "; ".join(f"{p}: {r}" for p, r in zip(self.missing, self.reasons))
        return (f"OUTSIDE THE THEOREM of design {self.design}: graph {self.graph!r} lacks {why} "
                "(running with --allow-outside-theorem: none of its guarantees applies)")

    def to_dict(self) -> dict[str, Any]:
        return {"graph": self.graph, "design": self.design, "required": list(self.required),
                "inside": self.inside, "missing": list(self.missing), "reasons": list(self.reasons)}


def check_theorem_graph(
    graph: Any,
    required: Iterable[str],
    *,
    allow_outside: bool = False,
    design: str = "",
) -> TheoremCheck:
    """Decide the properties a design's theorem needs on ``graph``.

    Parameters
    ----------
    graph : Graph, Digraph or any input of :func:`load_graph`
    required : iterable of str
        :class:`GraphProperty` names (a design's ``spec.decl.graphs``).
    allow_outside : bool
        False (default): a missing property is a :class:`GraphError`.  True: the
        result lists it (and the caller flags it).
    design : str
        The design's name, for messages.

    Examples
    --------
    >>> check_theorem_graph("ring:6", ["undirected", "weakly-connected"]).inside
    True
    >>> chain = [[0, 0, 0], [1, 0, 0], [0, 1, 0]]
    >>> check_theorem_graph(chain, ["undirected"], design="liang2016")
    Traceback (most recent call last):
    ...
    formsync_design.errors.GraphError: expected a graph that is undirected (a_ij = a_ji) (required by design liang2016), received 'adjacency' which lacks undirected: a_2,1 = 1 but a_1,2 = 0
    >>> check_theorem_graph(chain, ["undirected", "spanning-tree"], allow_outside=True).missing
    ('undirected',)
    """
    req = tuple(str(GraphProperty(p)) for p in required)
    g = load_graph(graph)
    d = as_digraph(g)
    by = f"design {design}" if design else ""
    if not allow_outside:
        d.require(req, by=by)
        return TheoremCheck(graph=str(g.name), design=design, required=req)
    missing = tuple(p for p in dict.fromkeys(req) if not d.has(p))
    reasons = tuple(d.why_not(p) for p in missing)
    return TheoremCheck(graph=str(g.name), design=design, required=req, missing=missing,
                        reasons=reasons)
