"""Certificates of an agent design over graph families: a gain box decided on each graph,
and a graph outside the design's theorem (e.g. without a directed spanning tree) refused as a
*finding* (a row with status ``refused`` and the reason), never an error.

>>> import sympy as sp
>>> from formsync_design.spec.agent import agent_design_from_functions
>>> d = agent_design_from_functions(lambda v: -v.k * v.J * v.w, gains={"k": {}},
...     graphs=("spanning-tree",), conditions=lambda c: [("k", sp.Matrix([[c.gains["k"]]]))])
>>> rows = certify_agent_graphs(d, ["ring:3", [[0, 0, 0], [1, 0, 0], [0, 0, 0]]], {"k": "1:2"})
>>> [(r.graph, r.status) for r in rows]
[('ring:3', 'certified'), ('adjacency', 'refused')]
>>> rows[1].reason.startswith("spanning-tree:")
True
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any

from formsync_design.gains import json_number

__all__ = ["GraphCertificate", "certify_agent_graphs"]


@dataclass(frozen=True)
class GraphCertificate:
    """One graph's verdict.

    Attributes
    ----------
    graph : str
    n : int
    properties : dict name -> bool (the graph's properties)
    status : str
        ``certified`` / ``refuted`` / ``undecided`` / ``error`` (the certificate's status) or
        ``refused`` (outside the design's theorem: ``reason`` says which property and why).
    reason : str
    margin : float or None (the certified margin)
    multipliers : dict name -> float (the certifying multiplier values)
    """

    graph: str
    n: int
    properties: dict[str, bool]
    status: str
    reason: str
    margin: float | None = None
    multipliers: Mapping[str, float] | None = None

    def to_dict(self) -> dict[str, Any]:
        return {"graph": self.graph, "n": self.n, "properties": dict(self.properties),
                "status": self.status, "reason": self.reason,
                "margin": None if self.margin is None else json_number(self.margin),
                "multipliers": {k: json_number(v) for k, v in (self.multipliers or {}).items()}}


def certify_agent_graphs(design: Any, graphs: Iterable[Any], box: Mapping[str, Any],
                         names: Iterable[str] | None = None) -> list[GraphCertificate]:
    """Decide ``box`` (the design's controller gains; multipliers searched over their declared
    ranges) with the design's ``conditions(c)`` families on every graph (module docstring).

    ``names`` optionally labels the graphs (default: each graph's own name).
    """
    from formsync_design.certify.engine import certify_box
    from formsync_design.certify.multipliers import certify_with_multipliers
    from formsync_design.derive.agent import agent_conditions
    from formsync_design.graphs.theorem import as_digraph, check_theorem_graph, load_graph

    labels = list(names) if names is not None else None
    out: list[GraphCertificate] = []
    for k, spec in enumerate(graphs):
        g = as_digraph(load_graph(spec))
        label = labels[k] if labels is not None else str(g.name)
        props = g.properties()
        chk = check_theorem_graph(g, design.decl.graphs, allow_outside=True, design=design.name)
        if not chk.inside:
            why = "; ".join(f"{p}: {r}" for p, r in zip(chk.missing, chk.reasons))
            out.append(GraphCertificate(label, g.n, props, "refused", why))
            continue
        conds = agent_conditions(design, g)
        mult = {n: design.decl.gain(n).range for n in design.decl.multipliers}
        res = certify_with_multipliers(conds, box, mult) if mult else certify_box(conds, box)
        lb = res.margin_lower_bound
        chosen = ({n: float(res.box[n].lo) for n in mult} if str(res.status) == "certified"
                  else {})
        out.append(GraphCertificate(label, g.n, props, str(res.status), res.reason,
                                    None if lb is None else float(lb), chosen))
    return out
