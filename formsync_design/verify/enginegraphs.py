"""The graphs of an engine case's formations: ``[[formations]]`` rows name a graph (a spec,
a file, the directed cycle ``cycle:N``, the case's own) or list its arcs, with optional
pinning gains (:func:`formation_graph`, :func:`directed_cycle`).  The rest of a formation row
is read by :mod:`formsync_design.verify.enginecase`.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from formsync_design.errors import InputError
from formsync_design.graphs.digraph_io import directed_cycle, parse_cycle_spec
from formsync_design.ranges import check_range
from formsync_design.textio import check_ascii, cut
from formsync_design.verify.case import case_path

__all__ = ["directed_cycle", "formation_graph"]


def formation_graph(row: dict, where: str, case_graph: Callable[[], Any],
                    path: str) -> tuple[Any, str]:
    """The graph of a ``[[formations]]`` row and where it came from (``graph`` = a graph spec,
    a file relative to the case file ``path``, ``cycle:N`` or ``case``: ``case_graph()``; or
    ``arcs`` with ``n``), with its ``pinning`` gains.  Bad input is a one-line
    :class:`~formsync_design.errors.InputError` naming ``where``.

    >>> g, src = formation_graph({"graph": "cycle:3", "pinning": [1, 0, 0]}, "f[1]",
    ...                          lambda: None, "case.toml")
    >>> g.name, g.has_leader, src
    ('cycle:3', True, 'cycle:3')
    """
    from formsync_design.graphs.digraph_io import digraph_from_edges, make_digraph

    pin = row.get("pinning")
    if pin is not None:
        if not isinstance(pin, list) or not pin:
            raise InputError(f"expected {where}.pinning = [b_1, ..., b_N], received {pin!r:.60}")
        for k, b in enumerate(pin, 1):
            if isinstance(b, bool) or not isinstance(b, (int, float)):
                raise InputError(f"expected numbers in {where}.pinning, received {b!r:.30}")
            check_range(b, "weight", f"{where}.pinning[{k}]")
    if "arcs" in row:
        if "graph" in row:
            raise InputError(f"expected one of {where}.graph or {where}.arcs, received both")
        arcs = row["arcs"]
        if not isinstance(arcs, list) or not all(isinstance(a, list) for a in arcs):
            raise InputError(f"expected {where}.arcs = [[i, j, a_ij], ...], received {arcs!r:.60}")
        n = row.get("n")
        if n is not None and (isinstance(n, bool) or not isinstance(n, int)):
            raise InputError(f"expected {where}.n as an integer, received {n!r:.30}")
        return digraph_from_edges([tuple(a) for a in arcs], n=n, pinning=pin,
                                  name=str(row["name"])), "arcs"
    if "n" in row:
        raise InputError(f"expected {where}.n only with {where}.arcs, received it with a graph")
    spec = row.get("graph", "case")
    if not isinstance(spec, str) or not spec.strip():
        raise InputError(f"expected {where}.graph as a graph spec or file, received {spec!r:.60}")
    spec = spec.strip()
    if spec == "case":
        g = case_graph()
        return (g if pin is None else make_digraph(g, pinning=pin)), "the case's graph"
    check_ascii(spec, f"{where}.graph {cut(spec, 40)}")
    cycle = parse_cycle_spec(spec)  # the one parser of cycle:N, also --graph's
    if cycle is not None:
        return (cycle if pin is None else make_digraph(cycle, pinning=pin)), spec
    return make_digraph(case_path(spec, path, f"{where}.graph"), pinning=pin), spec
