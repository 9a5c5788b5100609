"""Graph sets of a campaign: the ``FAMILY:A..B`` grammar, the atlas, folders of files."""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from formsync_design.errors import GraphError, InputError
from formsync_design.graphs.build import Graph, make_graph
from formsync_design.textio import check_ascii, confined_path

__all__ = ["ATLAS_MAX_N", "MAX_SET_SIZE", "GraphEntry", "expand_graph_set", "expand_graphs",
           "graph_set_bound"]

MAX_SET_SIZE = 100_000  # values of one A..B range (= the campaign task limit, runner.MAX_TASKS)

_FAMILIES = ("ring", "path", "star", "complete", "circulant", "random", "atlas", "dir")
_EDGE_SUFFIXES = (".txt", ".edges", ".el", ".edgelist", ".csv")
ATLAS_MAX_N = 7


@dataclass(frozen=True)
class GraphEntry:
    """One graph of a campaign: ``id`` (unique), the set it came from, the graph."""

    id: str
    graph_set: str
    graph: Graph

    def edge_text(self) -> str:
        return " ".join(f"{i}-{j}" for i, j in self.graph.edge_list_1based())


def _int_range(text: str, what: str, spec: str) -> list[int]:
    t = text.strip()
    m = re.fullmatch(r"([0-9]+)\.\.([0-9]+)", t)
    if m:
        a, b = int(m.group(1)), int(m.group(2))
        if b < a:
            raise InputError(f"expected a range A..B with A <= B for {what}, received {t!r} in {spec!r}")
        if b - a + 1 > MAX_SET_SIZE:
            raise InputError(
                f"expected at most {MAX_SET_SIZE} values in a range A..B (a campaign holds at most "
                f"that many tasks), received {b - a + 1} for {what} in {spec!r}"
            )
        return list(range(a, b + 1))
    m = re.fullmatch(r"N?<=([0-9]+)", t)
    if m:
        return list(range(2, int(m.group(1)) + 1))
    if re.fullmatch(r"[0-9]+", t):
        return [int(t)]
    raise InputError(f"expected {what} as a number or a range A..B, received {t!r} in {spec!r}")


def _atlas(ns: Sequence[int], spec: str) -> list[GraphEntry]:
    import networkx as nx

    if not ns or min(ns) < 2 or max(ns) > ATLAS_MAX_N:
        raise InputError(
            f"expected atlas sizes within 2..{ATLAS_MAX_N} (networkx graph atlas), received {spec!r}"
        )
    want = set(ns)
    out = []
    for k, g in enumerate(nx.graph_atlas_g()):
        n = g.number_of_nodes()
        if n in want and nx.is_connected(g):
            out.append(GraphEntry(f"atlas:G{k}", spec, make_graph(nx.to_numpy_array(g, dtype=int))))
    return [GraphEntry(e.id, e.graph_set, Graph(e.graph.n, e.graph.edges, e.id)) for e in out]


def _path(root: Path, rel: str, source: str | None) -> Path:
    """``root / rel``; inside ``root`` when a campaign file ``source`` names it."""
    if source:
        return confined_path(rel, source, "campaign.graphs", base=root)
    return root / rel


def _folder(path: Path, spec: str, source: str | None = None) -> list[GraphEntry]:
    if not path.is_dir():
        raise InputError(f"expected an existing folder of edge-list files, received {spec!r}")
    files = sorted(p for p in path.iterdir() if p.is_file() and p.suffix.lower() in _EDGE_SUFFIXES)
    out = []
    for p in files:
        if source:  # a file of the folder may be a symlink out of the campaign's folder
            _path(path, p.name, source)
        g = make_graph(p)
        gid = f"file:{p.name}"
        out.append(GraphEntry(gid, spec, Graph(g.n, g.edges, gid)))
    return out


def graph_set_bound(spec: str, *, base: Path | None = None, source: str | None = None) -> int:
    """An upper bound of the number of graphs of a set, computed without building them
    (0 for a spec :func:`expand_graph_set` will reject).

    >>> graph_set_bound("ring:4..12"), graph_set_bound("random:8:0.4:0..19")
    (9, 20)
    """
    if not isinstance(spec, str):
        return 0
    parts = spec.strip().split(":")
    fam = parts[0].lower()
    try:
        if fam in ("ring", "path", "star", "complete", "atlas") and len(parts) == 2:
            return len(_int_range(parts[1], "N", spec)) if fam != "atlas" else 1253
        if fam == "circulant" and len(parts) == 3:
            return len(_int_range(parts[1], "N", spec))
        if fam == "random" and len(parts) == 4:
            return len(_int_range(parts[1], "N", spec)) * len(_int_range(parts[3], "seed", spec))
    except InputError:
        return 0
    if fam in _FAMILIES and fam != "dir":
        return 0
    try:
        p = _path(base or Path("."), spec.partition(":")[2] if fam == "dir" else spec, source)
    except InputError:
        return 1  # refused by expand_graph_set
    if p.is_dir():
        return sum(1 for q in p.iterdir() if q.suffix.lower() in _EDGE_SUFFIXES)
    return 1


def expand_graph_set(spec: str, *, base: Path | None = None,
                     source: str | None = None) -> tuple[list[GraphEntry], list[str]]:
    """Expand one graph-set spec into graphs (module docstring for the grammar).

    ``base``: the folder relative files and folders resolve against; ``source``: the
    campaign file that names the set (its files and folders then stay inside ``base``;
    ``None``: the command line's, the user's paths).

    Returns ``(graphs, skipped)``: ``skipped`` lists random draws rejected as
    disconnected (``"random:8:0.2:3 (disconnected)"``).

    Raises
    ------
    InputError
        Unknown family, malformed range, an empty set.

    Examples
    --------
    >>> gs, skipped = expand_graph_set("ring:4..6")
    >>> [g.id for g in gs], skipped
    (['ring:4', 'ring:5', 'ring:6'], [])
    >>> len(expand_graph_set("atlas:4")[0])  # the 6 connected graphs on 4 nodes
    6
    """
    if not isinstance(spec, str) or not spec.strip():
        raise InputError(f"expected a graph-set spec, received {spec!r}")
    spec = spec.strip()
    root = base or Path(".")
    fam, _, rest = spec.partition(":")
    fam_l = fam.lower()
    skipped: list[str] = []
    if fam_l == "dir":
        out = _folder(_path(root, rest, source), spec, source)
    elif fam_l not in _FAMILIES:
        p = _path(root, spec, source)
        if p.is_dir():
            out = _folder(p, spec, source)
        elif p.is_file():
            g = make_graph(p)
            gid = f"file:{p.name}"
            out = [GraphEntry(gid, spec, Graph(g.n, g.edges, gid))]
        else:
            raise InputError(
                "expected a graph set FAMILY:N or FAMILY:A..B (families: "
                + ", ".join(_FAMILIES) + ") or an existing file or folder, received " + repr(spec)
            )
    else:
        check_ascii(spec, f"the graph set {spec[:40]!r}")
        parts = spec.split(":")
        if fam_l == "atlas":
            if len(parts) != 2:
                raise InputError(f"expected atlas:N, atlas:A..B or atlas:N<=7, received {spec!r}")
            out = _atlas(_int_range(parts[1], "atlas size", spec), spec)
        elif fam_l in ("ring", "path", "star", "complete"):
            if len(parts) != 2:
                raise InputError(f"expected {fam_l}:N or {fam_l}:A..B, received {spec!r}")
            out = []
            for n in _int_range(parts[1], "N", spec):
                gid = f"{fam_l}:{n}"
                out.append(GraphEntry(gid, spec, make_graph(gid)))
        elif fam_l == "circulant":
            if len(parts) != 3:
                raise InputError(f"expected circulant:N:a,b,... (N may be A..B), received {spec!r}")
            out = []
            for n in _int_range(parts[1], "N", spec):
                gid = f"circulant:{n}:{parts[2].strip()}"
                out.append(GraphEntry(gid, spec, make_graph(gid)))
        else:  # random
            if len(parts) != 4:
                raise InputError(
                    f"expected random:N:P:SEEDS (N and SEEDS a number or A..B), received {spec!r}"
                )
            out = []
            ns, seeds = _int_range(parts[1], "N", spec), _int_range(parts[3], "seed", spec)
            if len(ns) * len(seeds) > MAX_SET_SIZE:
                raise InputError(
                    f"expected at most {MAX_SET_SIZE} graphs in a set, received {len(ns)} sizes x "
                    f"{len(seeds)} seeds in {spec!r}"
                )
            for n in ns:
                for s in seeds:
                    gid = f"random:{n}:{parts[2].strip()}:{s}"
                    try:
                        out.append(GraphEntry(gid, spec, make_graph(gid)))
                    except GraphError as e:
                        if "connected" not in str(e):
                            raise
                        skipped.append(f"{gid} (disconnected)")
    if not out:
        extra = f" ({len(skipped)} draws disconnected)" if skipped else ""
        raise InputError(f"expected a non-empty graph set, received {spec!r} with no graphs{extra}")
    return out, skipped


def expand_graphs(
    specs: Sequence[str], *, base: Path | None = None, source: str | None = None
) -> tuple[list[GraphEntry], list[str]]:
    """Expand several graph-set specs in order; a graph id met twice is kept once
    (its edges must agree).  Returns ``(graphs, skipped)``.

    >>> gs, _ = expand_graphs(["ring:4..5", "ring:5..6"])
    >>> [g.id for g in gs]
    ['ring:4', 'ring:5', 'ring:6']
    """
    if not specs:
        raise InputError("expected at least one graph set, received none")
    seen: dict[str, GraphEntry] = {}
    out: list[GraphEntry] = []
    skipped: list[str] = []
    for s in specs:
        gs, sk = expand_graph_set(s, base=base, source=source)
        skipped.extend(sk)
        for g in gs:
            if g.id in seen:
                if seen[g.id].graph.edges != g.graph.edges or seen[g.id].graph.n != g.graph.n:
                    raise InputError(
                        f"expected one graph per id, received two different graphs named {g.id!r}"
                    )
                continue
            seen[g.id] = g
            out.append(g)
    return out, skipped

