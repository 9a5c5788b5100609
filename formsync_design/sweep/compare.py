"""Comparing a sweep with another sweep on the same graphs (``[campaign] compare``).

A campaign may name the results folder of another sweep (typically of another design on
the same graph sets, e.g. the PD baseline against liang2016's ``reports/sweep-atlas6``).
Its ``results.csv`` and ``manifest.json`` are read when the campaign is hashed (their
content is part of the campaign sha256) and the summary gains a table: per formation
size, on the graphs both sweeps hold, how often each design's reference gains are
certified - here, there, by both, by one only - and the mean certified fraction of each
sweep's own first box.  Graphs are matched up to a relabelling of the spacecraft (graph
isomorphism, :func:`networkx.is_isomorphic`): relabelling permutes the ``Theta_i`` and
conjugates ``Pi`` by a permutation, so a certificate's status is a property of the
unlabelled graph (``ring:6`` here is ``atlas:G105`` there).  Statuses are taken as
written by each sweep (each a proof of its own run); nothing is recomputed.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Sequence
from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path
from typing import Any

from formsync_design.errors import InputError

__all__ = ["Compared", "load_compared", "match_rows", "comparison_lines"]


@dataclass(frozen=True)
class Compared:
    """The compared sweep: where it was named, its manifest, its rows and their digest."""

    label: str
    manifest: dict[str, Any]
    rows: tuple[dict[str, str], ...]
    sha256: str

    @property
    def design(self) -> str:
        return str(self.manifest.get("spec", {}).get("name", "liang2016"))


def load_compared(folder: str, base: str | Path = ".") -> Compared:
    """Read the results folder ``folder`` (relative to ``base``) of another sweep.

    Raises
    ------
    InputError
        Not a finished sweep folder (no ``manifest.json`` or ``results.csv``, unreadable).
    """
    from formsync_design.sweep.store import read_results
    from formsync_design.textio import read_text

    p = Path(folder)
    if not p.is_absolute():
        p = Path(base) / p
    man_p, res_p = p / "manifest.json", p / "results.csv"
    if not (man_p.is_file() and res_p.is_file()):
        raise InputError(f"expected campaign.compare to name a finished sweep folder (manifest.json "
                         f"and results.csv), received {folder!r}")
    text = read_text(man_p, "sweep manifest")  # a regular file under the size cap
    try:
        manifest = json.loads(text)
        sha = str(manifest["sha256"])
        camp = manifest["campaign"]
    except (ValueError, KeyError, TypeError, UnicodeDecodeError):
        raise InputError(f"expected a sweep manifest in {man_p}, received an unreadable file") from None
    if not isinstance(camp, dict) or not isinstance(camp.get("reference"), dict):
        raise InputError(f"expected a sweep manifest in {man_p}, received no campaign reference")
    rows = tuple(read_results(res_p))
    digest = hashlib.sha256(res_p.read_bytes() + sha.encode()).hexdigest()
    return Compared(folder, manifest, rows, digest)


def _graph(r: dict[str, str]) -> Any:
    import networkx as nx

    g = nx.Graph()
    g.add_nodes_from(range(1, int(r["n"]) + 1))
    g.add_edges_from(tuple(map(int, e.split("-"))) for e in r["edge_list"].split())
    return g


def _invariant(g: Any) -> tuple[int, int, tuple[int, ...]]:
    return g.number_of_nodes(), g.number_of_edges(), tuple(sorted(d for _, d in g.degree()))


def match_rows(rows: Sequence[dict[str, str]], other: Sequence[dict[str, str]]
               ) -> list[tuple[dict[str, str], dict[str, str] | None]]:
    """Each first-box row of ``rows`` with the first-box row of ``other`` of an isomorphic
    graph (``None`` when ``other`` has none).

    >>> a = [{"n": "3", "edge_list": "1-2 2-3", "box_index": "0", "graph": "path:3"}]
    >>> b = [{"n": "3", "edge_list": "1-2 1-3", "box_index": "0", "graph": "atlas:G6"}]
    >>> [(x["graph"], y["graph"]) for x, y in match_rows(a, b)]
    [('path:3', 'atlas:G6')]
    """
    import networkx as nx

    index: dict[tuple[int, int, tuple[int, ...]], list[tuple[Any, dict[str, str]]]] = {}
    for r in other:
        if r["box_index"] == "0":
            g = _graph(r)
            index.setdefault(_invariant(g), []).append((g, r))
    out: list[tuple[dict[str, str], dict[str, str] | None]] = []
    for r in rows:
        if r["box_index"] != "0":
            continue
        g = _graph(r)
        hit = next((o for h, o in index.get(_invariant(g), []) if nx.is_isomorphic(g, h)), None)
        out.append((r, hit))
    return out


def _ref_text(camp: dict[str, Any]) -> str:
    return ", ".join(f"{g} = {float(Fraction(v)):g}" for g, v in camp["reference"].items())


def comparison_lines(rows: Sequence[dict[str, str]], manifest: dict[str, Any],
                     other: Compared) -> list[str]:
    """The summary section comparing the reference statuses with ``other``'s."""
    pairs = match_rows(rows, other.rows)
    common = [(a, b) for a, b in pairs if b is not None]
    me = manifest["spec"]["name"]
    L = [f"## Compared with `{other.design}` (`{other.label}`)", ""]
    L.append(f"Reference gains certified by each design on the graphs both sweeps hold (matched "
             f"up to a relabelling of the spacecraft; first box of each): here `{me}` at "
             f"{_ref_text(manifest['campaign'])}, there `{other.design}` at "
             f"{_ref_text(other.manifest['campaign'])} (results sha256 `{other.sha256[:16]}`); "
             f"the certified fractions are of each sweep's own box. {len(common)} of {len(pairs)} "
             "graphs of this campaign are in the compared sweep.")
    L.append("")
    header = ["N", "graphs", f"certified: {me}", f"certified: {other.design}", "both",
              f"{me} only", f"{other.design} only", "neither", f"mean fraction: {me}",
              f"mean fraction: {other.design}"]
    L.append("| " + " | ".join(header) + " |")
    L.append("|" + "|".join("---" for _ in header) + "|")
    for n in sorted({int(a["n"]) for a, _ in common}):
        sub = [(a, b) for a, b in common if int(a["n"]) == n]
        x = [a["ref_status"] == "certified" for a, _ in sub]
        y = [b["ref_status"] == "certified" for _, b in sub]
        fx = sum(float(a["frac_certified"]) for a, _ in sub) / len(sub)
        fy = sum(float(b["frac_certified"]) for _, b in sub) / len(sub)
        cells = [n, len(sub), sum(x), sum(y), sum(p and q for p, q in zip(x, y)),
                 sum(p and not q for p, q in zip(x, y)), sum(q and not p for p, q in zip(x, y)),
                 sum(not p and not q for p, q in zip(x, y)), f"{100 * fx:.1f}%", f"{100 * fy:.1f}%"]
        L.append("| " + " | ".join(str(c) for c in cells) + " |")
    only = [f"`{a['graph']}` (= `{b['graph']}`, {other.design} {b['ref_status']}"
            + (f" by {b['ref_refuted_by']}" if b["ref_refuted_by"] else "") + ")"
            for a, b in common if a["ref_status"] == "certified" and b["ref_status"] != "certified"]
    if only:
        L.append("")
        L.append(f"Certified for `{me}` only: " + ", ".join(only) + ".")
    L.append("")
    return L
