"""Topology sweeps and Monte-Carlo campaigns on Dask.

A *campaign* is a set of communication graphs x a list of gain boxes, with a
reference gain point (default: the paper's ``K_o = 1.6, K_q = 0.4,
beta = 0.3``) and optional Monte-Carlo validation.  One *task* = one graph x
one box; it computes, with the public APIs of :mod:`.derive`, :mod:`.certify`,
:mod:`.region`, :mod:`.design` and :mod:`.montecarlo`:

* spectral facts of the graph (degrees, ``lambda_2`` and ``lambda_max`` of the
  Laplacian, floating point, for plotting only);
* the certification status of the reference gains (:func:`certify_box` at a
  point: certified / refuted / undecided / error, with the rigorous margin
  lower bound and the refuting family);
* the certified-region summary of the box (:func:`region_map` volume fractions
  certified / refuted / undecided at resolution ``R``);
* recommended gains (:func:`design_gains`) and the largest certified box
  around them (:func:`largest_certified_box` through ``design_gains``);
* Monte-Carlo statistics (:func:`run_montecarlo`) when asked.

Graph sets (:func:`expand_graph_set`)
-------------------------------------
``ring:N``, ``path:N``, ``star:N``, ``complete:N`` with ``N`` a number or an
inclusive range ``A..B`` (``ring:4..12``); ``circulant:N:a,b`` (``N`` may be a
range); ``atlas:N`` / ``atlas:A..B`` / ``atlas:N<=7``: every *connected* graph
with ``A <= n <= B`` nodes of :func:`networkx.graph_atlas_g` (``n <= 7``; the
one-node graph is excluded, the formation needs two spacecraft), named
``atlas:G<index>``; ``random:N:P:SEEDS`` with ``SEEDS`` a seed or a range
``S0..S1`` (seeded G(N, P) as in :func:`~.graphs.make_graph`; disconnected
draws are skipped and *listed* in the manifest and the summary, never silently
dropped); ``dir:PATH`` or an existing folder: every ``*.txt``, ``*.edges``,
``*.el``, ``*.edgelist`` or ``*.csv`` file in it (sorted by name), named
``file:<name>``; an existing file: that graph.

Results folder
--------------
``manifest.json``
    the canonical campaign definition, the expanded graph list (ids and
    edges), the columns and ``sha256`` of these (plus the content of the
    Monte-Carlo case file).  A folder whose manifest has another hash is
    refused (:class:`~.errors.InputError`, exit 2), nothing overwritten.
``journal.jsonl``
    one JSON line per finished task, appended with flush + fsync while the
    sweep runs.  A torn last line (killed mid-write) is discarded on
    ``--resume``; a task id seen twice must carry identical rows.
``results.csv``
    the tidy table (:data:`COLUMNS`, schema in :data:`COLUMN_DOC`), one row per
    task, sorted by ``(graph_index, box_index)``, floats with 10 significant
    digits, written atomically (temporary file + rename) once every task is
    done; the journal is then removed.
``summary.md``, ``fraction-vs-lambda-max.png``, ``fraction-vs-max-degree.png``,
``convergence-vs-lambda2.png`` (Monte-Carlo only)
    written from ``results.csv`` only: byte-identical for identical rows (no
    timestamps, no host names, PNG metadata stripped).

Execution: by default a :class:`distributed.LocalCluster` of worker processes
on the loopback (``n_workers=2``, ``threads_per_worker=1``); ``scheduler=``
connects to an existing cluster (its workers must have this package
installed); ``n_workers=0`` runs serially in this process.  Every task is a
pure function of its payload (:func:`run_task`), so the executor cannot
change the rows.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import math
import os
import re
import time
import tomllib
import warnings
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from fractions import Fraction
from pathlib import Path
from typing import Any

from formsync_design.errors import FormsyncError, GraphError, InputError
from formsync_design.graphs.build import Graph, make_graph

__all__ = [
    "FORMAT",
    "GAINS",
    "COLUMNS",
    "COLUMN_DOC",
    "GraphEntry",
    "GainBoxSpec",
    "MonteCarloSpec",
    "Campaign",
    "SweepOutcome",
    "expand_graph_set",
    "expand_graphs",
    "campaign_from_dict",
    "load_campaign",
    "campaign_hash",
    "build_tasks",
    "run_task",
    "run_sweep",
    "read_results",
    "write_summary",
    "plot_fraction",
    "plot_convergence",
]

FORMAT = "formsync-sweep/1"
GAINS = ("K_o", "K_q", "beta")
_FAMILIES = ("ring", "path", "star", "complete", "circulant", "random", "atlas", "dir")
_EDGE_SUFFIXES = (".txt", ".edges", ".el", ".edgelist", ".csv")
ATLAS_MAX_N = 7

# ---------------------------------------------------------------------------
# schema of results.csv
# ---------------------------------------------------------------------------
_SCHEMA: list[tuple[str, str]] = [
    ("task", "unique task id '<graph>@<box>'"),
    ("graph_index", "position of the graph in the expanded graph list (manifest.json)"),
    ("box_index", "position of the gain box in the campaign"),
    ("graph", "graph id: family spec (ring:8), atlas:G<index> (networkx atlas), random:N:P:SEED, file:<name>"),
    ("graph_set", "the graph-set spec the graph came from"),
    ("n", "number of spacecraft N"),
    ("edges", "number of links"),
    ("edge_list", "links as 1-based 'i-j' pairs separated by spaces"),
    ("degree_min", "smallest degree m_i"),
    ("degree_max", "largest degree m_i"),
    ("degree_mean", "mean degree"),
    ("lambda_2", "algebraic connectivity of the Laplacian L (LAPACK, for plots)"),
    ("lambda_max", "largest eigenvalue of L (LAPACK, for plots)"),
    ("conditions", "Lyapunov conditions checked: derived (from the controller) or paper (printed)"),
    ("box", "gain-box name"),
    *[(f"box_{g}_{e}", f"{'lower' if e == 'lo' else 'upper'} bound of {g} in the box")
      for g in GAINS for e in ("lo", "hi")],
    *[(f"ref_{g}", f"reference gain {g}") for g in GAINS],
    ("ref_status", "certify_box at the reference gains: certified|refuted|undecided|error"),
    ("ref_margin", "rigorous lower bound of lambda_min over Theta_i and Pi at the reference gains (certified only)"),
    ("ref_refuted_by", "family with the exactly checked refuting witness (refuted only)"),
    ("resolution", "region_map resolution R (finest box = 1/R of each range)"),
    ("frac_certified", "volume fraction of the box proven admissible (region_map)"),
    ("frac_refuted", "volume fraction proven inadmissible"),
    ("frac_undecided", "volume fraction undecided at resolution R"),
    ("design_status", "design_gains: designed|infeasible|undecided|error"),
    *[(f"rec_{g}", f"recommended {g} (designed only)") for g in GAINS],
    ("rec_margin", "rigorous lower bound of lambda_min at the recommended gains"),
    *[(f"cbox_{g}_{e}", f"largest certified box around the recommended gains: {g} {e}")
      for g in GAINS for e in ("lo", "hi")],
    ("cbox_half_width", "relative half width s of that box (g_i [1-s, 1+s] clipped to the ranges)"),
    ("cbox_status", "certify_box status of that box (with the SDP hint)"),
    ("mc_gains", "gains simulated: reference|recommended (empty: no Monte-Carlo)"),
    ("mc_status", "ran | skipped (reason) | empty"),
    ("mc_runs", "number of Monte-Carlo runs"),
    ("mc_converged", "runs converged (Q_m <= q_tol and Omega_m <= omega_tol to the end)"),
    ("mc_not_converged", "runs not converged within tf"),
    ("mc_singular", "runs that reached q0 <= q0_floor"),
    ("mc_diverged", "runs with NaN/inf"),
    ("mc_inaccurate", "runs with quaternion norm drift above norm_tol"),
    ("mc_conv_time_median", "median convergence time over converged runs (s)"),
    ("mc_conv_time_p95", "95th percentile convergence time (s)"),
    ("mc_conv_time_max", "largest convergence time (s)"),
    ("mc_failed_seeds", "run seeds of non-converged runs (replay with formsync montecarlo --replay), ';'-separated, at most 20"),
]
COLUMNS: tuple[str, ...] = tuple(c for c, _ in _SCHEMA)
COLUMN_DOC: dict[str, str] = dict(_SCHEMA)
_MC_COLUMNS = tuple(c for c in COLUMNS if c.startswith("mc_"))


def _fmt(x: Any) -> str:
    """Fixed text of a cell: '' for None, integers as such, floats with 10 significant digits."""
    if x is None:
        return ""
    if isinstance(x, bool):
        return "true" if x else "false"
    if isinstance(x, int):
        return str(x)
    if isinstance(x, (float, Fraction)):
        f = float(x)
        if math.isnan(f):
            return "nan"
        if math.isinf(f):
            return "inf" if f > 0 else "-inf"
        s = format(f, ".10g")
        return "0" if s == "-0" else s
    return str(x)


def _q(x: Any, what: str) -> Fraction:
    """An exact rational from a TOML/CLI value (decimal text taken literally)."""
    if isinstance(x, bool):
        raise InputError(f"expected a number for {what}, received {x!r}")
    if isinstance(x, int):
        return Fraction(x)
    if isinstance(x, float):
        if not math.isfinite(x):
            raise InputError(f"expected a finite number for {what}, received {x!r}")
        return Fraction(repr(x))
    if isinstance(x, str):
        try:
            q = Fraction(x.strip())
        except (ValueError, ZeroDivisionError):
            raise InputError(f"expected a number for {what}, received {x!r}") from None
        return q
    raise InputError(f"expected a number for {what}, received {x!r}")


def _qs(q: Fraction) -> str:
    return str(q.numerator) if q.denominator == 1 else f"{q.numerator}/{q.denominator}"


# ---------------------------------------------------------------------------
# graph sets
# ---------------------------------------------------------------------------
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
    m = re.fullmatch(r"(\d+)\.\.(\d+)", t)
    if m:
        a, b = int(m.group(1)), int(m.group(2))
        if b < a:
            raise InputError(f"expected a range A..B with A <= B for {what}, received {t!r} in {spec!r}")
        return list(range(a, b + 1))
    m = re.fullmatch(r"N?<=(\d+)", t)
    if m:
        return list(range(2, int(m.group(1)) + 1))
    if re.fullmatch(r"\d+", t):
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


def _folder(path: Path, spec: str) -> list[GraphEntry]:
    if not path.is_dir():
        raise InputError(f"expected an existing folder of edge-list files, received {spec!r}")
    files = sorted(p for p in path.iterdir() if p.is_file() and p.suffix.lower() in _EDGE_SUFFIXES)
    out = []
    for p in files:
        g = make_graph(p)
        gid = f"file:{p.name}"
        out.append(GraphEntry(gid, spec, Graph(g.n, g.edges, gid)))
    return out


def expand_graph_set(spec: str, *, base: Path | None = None) -> tuple[list[GraphEntry], list[str]]:
    """Expand one graph-set spec into graphs (module docstring for the grammar).

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
        out = _folder(root / rest, spec)
    elif fam_l not in _FAMILIES:
        p = root / spec
        if p.is_dir():
            out = _folder(p, spec)
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
            for n in _int_range(parts[1], "N", spec):
                for s in _int_range(parts[3], "seed", spec):
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
    specs: Sequence[str], *, base: Path | None = None
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
        gs, sk = expand_graph_set(s, base=base)
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


# ---------------------------------------------------------------------------
# campaign
# ---------------------------------------------------------------------------
@dataclass(frozen=True)
class GainBoxSpec:
    """A named gain box, exact bounds ``((lo, hi), ...)`` in :data:`GAINS` order."""

    name: str
    bounds: tuple[tuple[Fraction, Fraction], ...]

    def to_dict(self) -> dict[str, Any]:
        return {"name": self.name, **{g: [_qs(lo), _qs(hi)] for g, (lo, hi) in zip(GAINS, self.bounds)}}


@dataclass(frozen=True)
class MonteCarloSpec:
    """Monte-Carlo settings of a campaign (see :mod:`.montecarlo`).

    ``gains``: ``"reference"`` or ``"recommended"``; ``case``: case TOML whose
    inertias (cycled when the graph has more spacecraft than the case),
    orbit, disturbance and ``K_v`` are used (default: the paper's case).
    """

    runs: int = 20
    seed: int = 0
    gains: str = "reference"
    case: str = ""
    K_v: Fraction | None = None
    max_angle_deg: float = 100.0
    max_rate: float = 0.9
    phases: bool = True
    tf: float = 200.0
    step: float = 0.1
    output_step: float = 0.5
    disturbance: str = ""

    def to_dict(self) -> dict[str, Any]:
        return {
            "runs": self.runs, "seed": self.seed, "gains": self.gains, "case": self.case,
            "K_v": None if self.K_v is None else _qs(self.K_v),
            "max_angle_deg": self.max_angle_deg, "max_rate": self.max_rate, "phases": self.phases,
            "tf": self.tf, "step": self.step, "output_step": self.output_step,
            "disturbance": self.disturbance,
        }


@dataclass(frozen=True)
class Campaign:
    """A validated campaign definition (:func:`campaign_from_dict`)."""

    name: str
    title: str
    graphs: tuple[str, ...]
    boxes: tuple[GainBoxSpec, ...]
    reference: tuple[Fraction, ...]
    conditions: str = "derived"
    margin: Fraction = Fraction(0)
    resolution: int = 8
    design_betas: int = 5
    design_penalty: float = 0.0
    montecarlo: MonteCarloSpec | None = None
    base: str = field(default=".", compare=False)

    def to_dict(self) -> dict[str, Any]:
        """Canonical, JSON-ready definition (hashed into the manifest)."""
        return {
            "name": self.name,
            "title": self.title,
            "graphs": list(self.graphs),
            "conditions": self.conditions,
            "margin": _qs(self.margin),
            "reference": {g: _qs(v) for g, v in zip(GAINS, self.reference)},
            "boxes": [b.to_dict() for b in self.boxes],
            "region": {"resolution": self.resolution},
            "design": {"betas": self.design_betas, "penalty": self.design_penalty},
            "montecarlo": None if self.montecarlo is None else self.montecarlo.to_dict(),
        }


_TOP = {"campaign", "reference", "box", "region", "design", "montecarlo"}
_KEYS = {
    "campaign": {"name", "title", "graphs", "conditions", "margin"},
    "reference": set(GAINS),
    "box": {"name", *GAINS},
    "region": {"resolution"},
    "design": {"betas", "penalty"},
    "montecarlo": {"runs", "seed", "gains", "case", "K_v", "max_angle_deg", "max_rate", "phases",
                   "tf", "step", "output_step", "disturbance"},
}
DEFAULT_BOX = {"name": "standard", "K_o": ["0.05", "5"], "K_q": ["0.05", "5"], "beta": ["0.01", "1"]}
DEFAULT_REFERENCE = {"K_o": "1.6", "K_q": "0.4", "beta": "0.3"}


def _check_keys(table: Any, name: str) -> dict:
    if not isinstance(table, dict):
        raise InputError(f"expected a table [{name}], received {table!r}")
    extra = set(table) - _KEYS[name]
    if extra:
        raise InputError(f"expected keys {sorted(_KEYS[name])} in [{name}], received unknown {sorted(extra)}")
    return table


def _pos_int(v: Any, what: str, lo: int = 1, hi: int | None = None) -> int:
    if isinstance(v, bool) or not isinstance(v, int) or v < lo or (hi is not None and v > hi):
        rng = f"{lo}..{hi}" if hi is not None else f">= {lo}"
        raise InputError(f"expected an integer {what} in {rng}, received {v!r}")
    return v


def _pos_float(v: Any, what: str, *, allow_zero: bool = False) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v < 0 or (
        v == 0 and not allow_zero
    ):
        raise InputError(f"expected a {'non-negative' if allow_zero else 'positive'} number for {what}, received {v!r}")
    return float(v)


def campaign_from_dict(data: dict, *, base: str | Path = ".") -> Campaign:
    """Validate a campaign document (the TOML layout of :func:`load_campaign`).

    >>> c = campaign_from_dict({"campaign": {"name": "t", "graphs": ["ring:4"]}})
    >>> c.boxes[0].name, [float(v) for v in c.reference], c.resolution
    ('standard', [1.6, 0.4, 0.3], 8)
    """
    if not isinstance(data, dict):
        raise InputError(f"expected a campaign table, received {data!r}")
    extra = set(data) - _TOP
    if extra:
        raise InputError(f"expected tables {sorted(_TOP)} in the campaign, received unknown {sorted(extra)}")
    c = _check_keys(data.get("campaign", {}), "campaign")
    name = c.get("name", "")
    if not isinstance(name, str) or not re.fullmatch(r"[A-Za-z0-9_.-]+", name):
        raise InputError(f"expected campaign.name made of letters, digits, '_', '.', '-', received {name!r}")
    title = c.get("title", "")
    if not isinstance(title, str):
        raise InputError(f"expected a string campaign.title, received {title!r}")
    graphs = c.get("graphs")
    if isinstance(graphs, str):
        graphs = [graphs]
    if not isinstance(graphs, list) or not graphs or not all(isinstance(g, str) and g.strip() for g in graphs):
        raise InputError(f"expected campaign.graphs as a non-empty list of graph-set specs, received {graphs!r}")
    cond = c.get("conditions", "derived")
    if cond not in ("derived", "paper"):
        raise InputError(f"expected campaign.conditions derived or paper, received {cond!r}")
    margin = _q(c.get("margin", 0), "campaign.margin")
    if margin < 0:
        raise InputError(f"expected a non-negative campaign.margin, received {float(margin):g}")
    ref = _check_keys(data.get("reference", DEFAULT_REFERENCE), "reference")
    for g in GAINS:
        if g not in ref:
            raise InputError(f"expected reference.{g}, received keys {sorted(ref)}")
    reference = tuple(_q(ref[g], f"reference.{g}") for g in GAINS)
    if any(v <= 0 for v in reference):
        raise InputError(f"expected positive reference gains, received {[float(v) for v in reference]}")
    boxes_raw = data.get("box", [DEFAULT_BOX])
    if isinstance(boxes_raw, dict):
        boxes_raw = [boxes_raw]
    if not isinstance(boxes_raw, list) or not boxes_raw:
        raise InputError(f"expected at least one [[box]] table, received {boxes_raw!r}")
    boxes = []
    for k, b in enumerate(boxes_raw):
        b = _check_keys(b, "box")
        bname = b.get("name", f"box{k + 1}")
        if not isinstance(bname, str) or not re.fullmatch(r"[A-Za-z0-9_.-]+", bname):
            raise InputError(f"expected box names made of letters, digits, '_', '.', '-', received {bname!r}")
        bounds = []
        for g in GAINS:
            if g not in b:
                raise InputError(f"expected box.{g} = [lo, hi] in box {bname!r}, received none")
            v = b[g]
            lo, hi = (v if isinstance(v, list) else [v, v]) if not isinstance(v, list) or len(v) == 2 else (None, None)
            if lo is None:
                raise InputError(f"expected box.{g} = [lo, hi] or a number in box {bname!r}, received {v!r}")
            lo_q, hi_q = _q(lo, f"box {bname} {g}"), _q(hi, f"box {bname} {g}")
            if not 0 < lo_q <= hi_q:
                raise InputError(
                    f"expected 0 < lo <= hi for {g} in box {bname!r}, received [{float(lo_q):g}, {float(hi_q):g}]"
                )
            bounds.append((lo_q, hi_q))
        boxes.append(GainBoxSpec(bname, tuple(bounds)))
    if len({b.name for b in boxes}) != len(boxes):
        raise InputError(f"expected distinct box names, received {[b.name for b in boxes]}")
    reg = _check_keys(data.get("region", {}), "region")
    resolution = _pos_int(reg.get("resolution", 8), "region.resolution", 1, 512)
    des = _check_keys(data.get("design", {}), "design")
    betas = _pos_int(des.get("betas", 5), "design.betas", 1, 1000)
    penalty = _pos_float(des.get("penalty", 0.0), "design.penalty", allow_zero=True)
    mc = None
    if "montecarlo" in data:
        m = _check_keys(data["montecarlo"], "montecarlo")
        gains = m.get("gains", "reference")
        if gains not in ("reference", "recommended"):
            raise InputError(f"expected montecarlo.gains reference or recommended, received {gains!r}")
        case = m.get("case", "")
        if not isinstance(case, str):
            raise InputError(f"expected montecarlo.case as a path string, received {case!r}")
        dist = m.get("disturbance", "")
        if dist not in ("", "paper", "gravity-gradient", "none"):
            raise InputError(
                f"expected montecarlo.disturbance paper, gravity-gradient or none, received {dist!r}"
            )
        phases = m.get("phases", True)
        if not isinstance(phases, bool):
            raise InputError(f"expected true/false for montecarlo.phases, received {phases!r}")
        kv = m.get("K_v")
        kvq = None if kv is None else _q(kv, "montecarlo.K_v")
        if kvq is not None and kvq < 0:
            raise InputError(f"expected montecarlo.K_v >= 0, received {float(kvq):g}")
        mc = MonteCarloSpec(
            runs=_pos_int(m.get("runs", 20), "montecarlo.runs", 1, 10**7),
            seed=_pos_int(m.get("seed", 0), "montecarlo.seed", 0),
            gains=gains,
            case=case,
            K_v=kvq,
            max_angle_deg=_pos_float(m.get("max_angle_deg", 100.0), "montecarlo.max_angle_deg", allow_zero=True),
            max_rate=_pos_float(m.get("max_rate", 0.9), "montecarlo.max_rate", allow_zero=True),
            phases=phases,
            tf=_pos_float(m.get("tf", 200.0), "montecarlo.tf"),
            step=_pos_float(m.get("step", 0.1), "montecarlo.step"),
            output_step=_pos_float(m.get("output_step", 0.5), "montecarlo.output_step"),
            disturbance=dist,
        )
    return Campaign(
        name=name, title=title, graphs=tuple(g.strip() for g in graphs), boxes=tuple(boxes),
        reference=reference, conditions=cond, margin=margin, resolution=resolution,
        design_betas=betas, design_penalty=penalty, montecarlo=mc, base=str(base),
    )


def load_campaign(path: str | Path) -> Campaign:
    """Load a campaign TOML file; graph folders and the Monte-Carlo case are
    resolved relative to the current directory.

    Layout::

        [campaign]   name, title, graphs = ["atlas:6", "ring:4..12", ...],
                     conditions = "derived" | "paper", margin = 0
        [reference]  K_o, K_q, beta            (default: the paper's 1.6, 0.4, 0.3)
        [[box]]      name, K_o = [lo, hi], K_q = [lo, hi], beta = [lo, hi]
                     (default: one box "standard" [0.05,5] x [0.05,5] x [0.01,1])
        [region]     resolution = 8
        [design]     betas = 5, penalty = 0.0
        [montecarlo] runs, seed, gains = "reference" | "recommended", case, K_v,
                     max_angle_deg, max_rate, phases, tf, step, output_step,
                     disturbance       (optional table: no Monte-Carlo without it)
    """
    p = Path(path)
    if not p.is_file():
        raise InputError(f"expected a campaign TOML file, received {str(path)!r} (no such file)")
    try:
        data = tomllib.loads(p.read_text(encoding="utf-8"))
    except tomllib.TOMLDecodeError as e:
        raise InputError(f"expected valid TOML in {p}, received a syntax error: {e}") from None
    return campaign_from_dict(data)


def _digest(obj: Any) -> str:
    text = json.dumps(obj, sort_keys=True, separators=(",", ":"), ensure_ascii=True)
    return hashlib.sha256(text.encode()).hexdigest()


def _graph_records(graphs: Sequence[GraphEntry]) -> list[dict[str, Any]]:
    return [
        {"index": k, "id": g.id, "set": g.graph_set, "n": g.graph.n, "edges": g.edge_text()}
        for k, g in enumerate(graphs)
    ]


def _case_text(mc: MonteCarloSpec) -> tuple[str, str]:
    """``(path, TOML text)`` of the Monte-Carlo case (default: the paper's), read here so
    that workers of a remote cluster need no access to the file."""
    from formsync_design.verify.case import default_case_path, load_case

    p = Path(mc.case) if mc.case else default_case_path()
    load_case(p)  # validates (InputError for a missing or malformed case)
    return str(p), p.read_text(encoding="utf-8")


def campaign_hash(campaign: Campaign, graphs: Sequence[GraphEntry]) -> str:
    """sha256 of the canonical definition, the expanded graph list (ids and edges) and,
    with Monte-Carlo, the content of the case file.

    >>> c = campaign_from_dict({"campaign": {"name": "t", "graphs": ["ring:4"]}})
    >>> gs, _ = expand_graphs(c.graphs)
    >>> campaign_hash(c, gs) == campaign_hash(c, gs), len(campaign_hash(c, gs))
    (True, 64)
    """
    doc: dict[str, Any] = {"format": FORMAT, "columns": list(COLUMNS),
                           "campaign": campaign.to_dict(), "graphs": _graph_records(graphs)}
    if campaign.montecarlo is not None:
        doc["case_sha256"] = hashlib.sha256(_case_text(campaign.montecarlo)[1].encode()).hexdigest()
    return _digest(doc)


# ---------------------------------------------------------------------------
# tasks
# ---------------------------------------------------------------------------
def build_tasks(campaign: Campaign, graphs: Sequence[GraphEntry]) -> list[dict[str, Any]]:
    """One payload per graph x box (plain data: picklable, executor-independent)."""
    common = {
        "conditions": campaign.conditions,
        "margin": _qs(campaign.margin),
        "reference": [_qs(v) for v in campaign.reference],
        "resolution": campaign.resolution,
        "design_betas": campaign.design_betas,
        "design_penalty": campaign.design_penalty,
        "montecarlo": None,
    }
    if campaign.montecarlo is not None:
        path, text = _case_text(campaign.montecarlo)
        common["montecarlo"] = {**campaign.montecarlo.to_dict(), "case_path": path, "case_text": text}
    tasks = []
    for gi, g in enumerate(graphs):
        for bi, b in enumerate(campaign.boxes):
            tasks.append({
                "task": f"{g.id}@{b.name}",
                "graph_index": gi,
                "box_index": bi,
                "graph": g.id,
                "graph_set": g.graph_set,
                "n": g.graph.n,
                "edges": [list(e) for e in g.graph.edges],
                "box": b.name,
                "bounds": [[_qs(lo), _qs(hi)] for lo, hi in b.bounds],
                **common,
            })
    return tasks


def _mc_formation(graph: Graph, mc: dict, gains: Sequence[Fraction]) -> Any:
    import numpy as np

    from formsync_design.sim.simulator import Formation, Gains
    from formsync_design.verify.case import make_disturbance, parse_case

    case = parse_case(tomllib.loads(mc["case_text"]), mc["case_path"])
    n = graph.n
    J = np.array([case.inertias[i % case.n] for i in range(n)])
    table = dict(case.disturbance)
    if mc["disturbance"]:
        table = {"model": mc["disturbance"], **({"signs": table["signs"]} if "signs" in table else {})}
    dist = make_disturbance(table, J, case.orbit)
    kv = float(Fraction(mc["K_v"])) if mc["K_v"] is not None else float(min(case.gains.K_v))
    att = np.tile([0.0, 0.0, 0.0, 1.0], (n, 1))
    g = Gains(float(gains[0]), float(gains[1]), float(gains[2]), (kv,) * n)
    return Formation(graph, J, att, np.zeros((n, 3)), g, dist), kv


def _run_mc(graph: Graph, mc: dict, gains: Sequence[Fraction] | None) -> dict[str, Any]:
    from formsync_design.sim.montecarlo import GainBox, MonteCarloSettings, run_montecarlo
    from formsync_design.sim.simulator import SimOptions

    out: dict[str, Any] = {"mc_gains": mc["gains"]}
    if gains is None:
        out["mc_status"] = "skipped (no recommended gains)"
        return out
    base, kv = _mc_formation(graph, mc, gains)
    box = GainBox(*((float(v), float(v)) for v in gains), (kv, kv))
    st = MonteCarloSettings(runs=mc["runs"], seed=mc["seed"], max_angle_deg=mc["max_angle_deg"],
                            max_rate=mc["max_rate"], phases=mc["phases"])
    opt = SimOptions(tf=mc["tf"], step=mc["step"], output_step=mc["output_step"], norm_tol=1e-5)
    r = run_montecarlo(base, box, st, opt, threads=1, certify=False)
    ct = r.convergence_time_stats
    fails = [str(x.seed) for x in r.failures][:20]
    out.update({
        "mc_status": "ran",
        "mc_runs": len(r.runs),
        "mc_converged": r.counts.get("converged", 0),
        "mc_not_converged": r.counts.get("not-converged", 0),
        "mc_singular": r.counts.get("singular", 0),
        "mc_diverged": r.counts.get("diverged", 0),
        "mc_inaccurate": r.counts.get("inaccurate", 0),
        "mc_conv_time_median": ct.get("median"),
        "mc_conv_time_p95": ct.get("p95"),
        "mc_conv_time_max": ct.get("max"),
        "mc_failed_seeds": ";".join(fails),
    })
    return out


def run_task(task: dict[str, Any]) -> dict[str, str]:
    """Compute one row of ``results.csv`` (a pure function of the payload).

    Examples
    --------
    >>> c = campaign_from_dict({"campaign": {"name": "t", "graphs": ["ring:4"]},
    ...                         "region": {"resolution": 2}, "design": {"betas": 2}})
    >>> gs, _ = expand_graphs(c.graphs)
    >>> row = run_task(build_tasks(c, gs)[0])
    >>> row["task"], row["lambda_max"], row["ref_status"]
    ('ring:4@standard', '4', 'certified')
    """
    from formsync_design.certify.design import design_gains
    from formsync_design.certify.engine import certify_box
    from formsync_design.certify.region import region_map
    from formsync_design.derive.conditions import derive_conditions, paper_conditions

    g = Graph(task["n"], tuple(tuple(e) for e in task["edges"]), task["graph"])
    row: dict[str, Any] = {c: None for c in COLUMNS}
    ev = g.laplacian_eigenvalues
    deg = g.degrees
    bounds = [(Fraction(lo), Fraction(hi)) for lo, hi in task["bounds"]]
    ref = [Fraction(v) for v in task["reference"]]
    margin = Fraction(task["margin"])
    row.update({
        "task": task["task"], "graph_index": task["graph_index"], "box_index": task["box_index"],
        "graph": task["graph"], "graph_set": task["graph_set"], "n": g.n, "edges": len(g.edges),
        "edge_list": " ".join(f"{i}-{j}" for i, j in g.edge_list_1based()),
        "degree_min": min(deg), "degree_max": max(deg), "degree_mean": sum(deg) / g.n,
        "lambda_2": float(ev[1]), "lambda_max": float(ev[-1]),
        "conditions": task["conditions"], "box": task["box"], "resolution": task["resolution"],
    })
    for gname, (lo, hi), r in zip(GAINS, bounds, ref):
        row[f"box_{gname}_lo"], row[f"box_{gname}_hi"] = lo, hi
        row[f"ref_{gname}"] = r
    conds = derive_conditions(g) if task["conditions"] == "derived" else paper_conditions(g)
    box = {gname: b for gname, b in zip(GAINS, bounds)}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # solver chatter; statuses are mapped explicitly
        cert = certify_box(conds, dict(zip(GAINS, ref)), margin=margin)
        rm = region_map(conds, box, resolution=task["resolution"], margin=margin)
        des = design_gains(conds, box, betas=task["design_betas"], penalty=task["design_penalty"],
                           margin=margin)
    row["ref_status"] = cert.status
    row["ref_margin"] = cert.margin_lower_bound if cert.certified else None
    row["ref_refuted_by"] = cert.witness.family if cert.witness is not None else None
    row["frac_certified"] = rm.fractions["certified"]
    row["frac_refuted"] = rm.fractions["refuted"]
    row["frac_undecided"] = rm.fractions["undecided"]
    row["design_status"] = des.status
    rec = None
    if des.status == "designed":
        rec = [des.gains[gname] for gname in GAINS]
        for gname, v in zip(GAINS, rec):
            row[f"rec_{gname}"] = v
        row["rec_margin"] = des.margin
        if des.box is not None:
            for gname, (lo, hi) in zip(GAINS, des.box):
                row[f"cbox_{gname}_lo"], row[f"cbox_{gname}_hi"] = lo, hi
            row["cbox_half_width"] = des.box_half_width
            row["cbox_status"] = des.box_result.status if des.box_result is not None else None
    mc = task["montecarlo"]
    if mc is not None:
        row.update(_run_mc(g, mc, ref if mc["gains"] == "reference" else rec))
    return {c: _fmt(row[c]) for c in COLUMNS}


# ---------------------------------------------------------------------------
# results folder: manifest, journal, results.csv
# ---------------------------------------------------------------------------
_OWNED = ("journal.jsonl", "results.csv", "summary.md", "fraction-vs-lambda-max.png",
          "fraction-vs-max-degree.png", "convergence-vs-lambda2.png")


def _atomic_write(path: Path, data: bytes) -> None:
    tmp = path.with_name(f".{path.name}.tmp")
    with open(tmp, "wb") as fh:
        fh.write(data)
        fh.flush()
        os.fsync(fh.fileno())
    os.replace(tmp, path)


def _read_journal(path: Path, *, repair: bool) -> dict[str, dict[str, str]]:
    """Rows of the journal; a torn last line is cut off (when ``repair``)."""
    rows: dict[str, dict[str, str]] = {}
    if not path.is_file():
        return rows
    data = path.read_bytes()
    good = data.rfind(b"\n") + 1
    lines = data[:good].split(b"\n")[:-1] if good else []
    kept = 0
    for k, line in enumerate(lines):
        try:
            row = json.loads(line)
            if not isinstance(row, dict) or set(row) != set(COLUMNS):
                raise ValueError("columns")
        except ValueError:
            if k == len(lines) - 1:  # torn tail with a newline inside a partial write: drop it
                break
            raise InputError(
                f"expected a journal of complete rows in {path}, received a malformed line {k + 1}"
            ) from None
        prev = rows.get(row["task"])
        if prev is not None and prev != row:
            raise InputError(f"expected identical rows for task {row['task']!r} in {path}, received two")
        rows[row["task"]] = row
        kept += len(line) + 1
    if repair and kept != len(data):
        with open(path, "r+b") as fh:
            fh.truncate(kept)
            fh.flush()
            os.fsync(fh.fileno())
    return rows


class _Journal:
    def __init__(self, path: Path) -> None:
        self.fh = open(path, "ab")

    def append(self, row: dict[str, str]) -> None:
        self.fh.write((json.dumps(row, sort_keys=True, ensure_ascii=True) + "\n").encode())
        self.fh.flush()
        os.fsync(self.fh.fileno())

    def close(self) -> None:
        self.fh.close()


def read_results(path: str | Path) -> list[dict[str, str]]:
    """Rows of a ``results.csv`` (strings, in file order), checking the header."""
    import csv

    p = Path(path)
    with open(p, newline="", encoding="utf-8") as fh:
        rd = csv.reader(fh)
        header = next(rd, None)
        if header is None or tuple(header) != COLUMNS:
            raise InputError(f"expected the sweep columns in {p}, received header {header!r}")
        return [dict(zip(COLUMNS, r)) for r in rd]


def _csv_bytes(rows: Sequence[dict[str, str]]) -> bytes:
    import csv
    import io

    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(COLUMNS)
    for r in rows:
        w.writerow([r[c] for c in COLUMNS])
    return buf.getvalue().encode("utf-8")


def _sort_key(r: dict[str, str]) -> tuple[int, int]:
    return int(r["graph_index"]), int(r["box_index"])


# ---------------------------------------------------------------------------
# executors
# ---------------------------------------------------------------------------
@contextlib.contextmanager
def _client(scheduler: str | None, n_workers: int, timeout: float) -> Iterator[Any]:
    import logging

    from distributed import Client, LocalCluster

    if scheduler:
        try:
            client = Client(scheduler, timeout=f"{timeout}s")
        except Exception as e:  # noqa: BLE001 - any connection failure is the same finding
            raise InputError(
                f"expected a reachable Dask scheduler at {scheduler!r}, received no connection "
                f"within {timeout:g} s ({type(e).__name__}: {e})"
            ) from None
        try:
            try:
                client.wait_for_workers(1, timeout=timeout)
            except Exception:  # noqa: BLE001
                raise InputError(
                    f"expected a Dask cluster with workers at {scheduler!r}, received none within {timeout:g} s"
                ) from None
            yield client
        finally:
            client.close()
        return
    try:
        cluster = LocalCluster(
            n_workers=n_workers, threads_per_worker=1, processes=True, host="127.0.0.1",
            dashboard_address=":0", silence_logs=logging.ERROR,
        )
    except Exception as e:  # noqa: BLE001 - not a finding about the campaign
        raise FormsyncError(
            f"expected a local Dask cluster of {n_workers} worker processes to start, received "
            f"{type(e).__name__}: {e}"
        ) from None
    try:
        client = Client(cluster, timeout=f"{max(timeout, 30)}s")
        try:
            yield client
        finally:
            client.close()
    finally:
        cluster.close()


def _execute(
    tasks: Sequence[dict[str, Any]],
    on_row: Callable[[dict[str, str]], None],
    *,
    scheduler: str | None,
    n_workers: int,
    timeout: float,
    task_fn: Callable[[dict[str, Any]], dict[str, str]],
) -> None:
    if not tasks:
        return
    if n_workers == 0 and not scheduler:
        for t in tasks:
            try:
                row = task_fn(t)
            except Exception as e:  # noqa: BLE001 - reported with the task, finished rows kept
                raise FormsyncError(
                    f"expected every task to finish, received a failure in {t['task']!r}: "
                    f"{type(e).__name__}: {e} (finished rows kept: rerun with --resume)"
                ) from e
            on_row(row)
        return
    from distributed import as_completed

    with _client(scheduler, n_workers, timeout) as client:
        salt = hashlib.sha256(os.urandom(16)).hexdigest()[:12]
        futs = client.map(task_fn, list(tasks), key=[f"sweep-{salt}-{k}" for k in range(len(tasks))],
                          pure=False)
        names = {f.key: t["task"] for f, t in zip(futs, tasks)}
        try:
            for fut in as_completed(futs):
                if fut.status == "error":
                    exc = fut.exception()
                    raise FormsyncError(
                        f"expected every task to finish, received a failure in {names[fut.key]!r}: "
                        f"{type(exc).__name__}: {exc} (finished rows kept: rerun with --resume)"
                    )
                on_row(fut.result())
        finally:
            client.cancel(futs)


# ---------------------------------------------------------------------------
# run_sweep
# ---------------------------------------------------------------------------
@dataclass(frozen=True)
class SweepOutcome:
    """What :func:`run_sweep` did (wall time is not written to any file)."""

    out: Path
    sha256: str
    tasks: int
    computed: int
    reused: int
    graphs: int
    skipped: tuple[str, ...]
    files: tuple[Path, ...]
    wall_seconds: float
    executor: str


def _check_folder(out: Path, sha: str, *, resume: bool, overwrite: bool) -> str:
    """'new', 'resume' or 'overwrite' (raises InputError when the folder is not ours)."""
    man = out / "manifest.json"
    if out.exists() and not out.is_dir():
        raise InputError(f"expected a results folder, received the file {str(out)!r}")
    if not man.is_file():
        if out.is_dir() and any(out.iterdir()):
            raise InputError(
                f"expected an empty or new results folder, received {str(out)!r} holding files but no "
                "manifest.json (nothing overwritten)"
            )
        return "new"
    try:
        old = json.loads(man.read_text(encoding="utf-8"))
        old_sha = old["sha256"]
    except (ValueError, KeyError, TypeError):
        raise InputError(f"expected a sweep manifest in {man}, received an unreadable file (nothing overwritten)") from None
    if old_sha != sha:
        raise InputError(
            f"expected results of this campaign (sha256 {sha[:12]}) in {str(out)!r}, received a folder "
            f"written by a different campaign definition (sha256 {str(old_sha)[:12]}); choose another "
            "--out (nothing overwritten)"
        )
    if resume:
        return "resume"
    if overwrite:
        return "overwrite"
    raise InputError(
        f"expected a new results folder, received {str(out)!r} already holding this campaign; pass "
        "--resume to finish it or --overwrite to recompute it (nothing overwritten)"
    )


def run_sweep(
    campaign: Campaign,
    out: str | Path,
    *,
    resume: bool = False,
    overwrite: bool = False,
    scheduler: str | None = None,
    n_workers: int = 2,
    timeout: float = 10.0,
    progress: Callable[[int, int], None] | None = None,
    command: str = "",
    task_fn: Callable[[dict[str, Any]], dict[str, str]] | None = None,
) -> SweepOutcome:
    """Run (or resume) a campaign into the results folder ``out``.

    Parameters
    ----------
    campaign : Campaign
    out : folder (created; see module docstring for its files)
    resume : keep the finished rows of an interrupted run of the same campaign
    overwrite : recompute a folder of the same campaign from scratch
    scheduler : address of an existing Dask scheduler (``tcp://host:8786``)
    n_workers : local worker processes (default 2); 0 = serial, in this process
    timeout : seconds to wait for the scheduler and its workers
    progress : called with ``(computed, pending)`` after every finished task
        (``pending`` = tasks this call computes; finished tasks of a resumed run excluded)
    command : the command line recorded in ``summary.md``
    task_fn : the task function (default :func:`run_task`; tests inject failures)

    Raises
    ------
    InputError
        Bad graph sets, a folder of another campaign, an unreachable scheduler.
    """
    t0 = time.perf_counter()
    if resume and overwrite:
        raise InputError("expected at most one of --resume and --overwrite, received both")
    if isinstance(n_workers, bool) or not isinstance(n_workers, int) or n_workers < 0:
        raise InputError(f"expected a number of workers >= 0, received {n_workers!r}")
    if not (isinstance(timeout, (int, float)) and math.isfinite(timeout) and timeout > 0):
        raise InputError(f"expected a positive timeout in seconds, received {timeout!r}")
    graphs, skipped = expand_graphs(campaign.graphs, base=Path(campaign.base))
    sha = campaign_hash(campaign, graphs)  # also validates the Monte-Carlo case file
    outp = Path(out)
    mode = _check_folder(outp, sha, resume=resume, overwrite=overwrite)
    tasks = build_tasks(campaign, graphs)
    ids = {t["task"] for t in tasks}
    done: dict[str, dict[str, str]] = {}
    jpath = outp / "journal.jsonl"
    if mode == "resume":
        if (outp / "results.csv").is_file():
            for r in read_results(outp / "results.csv"):
                done[r["task"]] = r
        for k, r in _read_journal(jpath, repair=True).items():
            if k in done and done[k] != r:
                raise InputError(f"expected identical rows for task {k!r} in results.csv and the journal")
            done[k] = r
        stray = set(done) - ids
        if stray:
            raise InputError(f"expected only tasks of this campaign, received {sorted(stray)[:3]} in {outp}")
    pending = [t for t in tasks if t["task"] not in done]
    executor = "serial" if (n_workers == 0 and not scheduler) else (
        f"dask scheduler {scheduler}" if scheduler else f"dask LocalCluster ({n_workers} worker processes)"
    )
    manifest = {
        "format": FORMAT,
        "sha256": sha,
        "campaign": campaign.to_dict(),
        "graphs": _graph_records(graphs),
        "skipped": skipped,
        "tasks": len(tasks),
        "columns": list(COLUMNS),
    }
    man_bytes = (json.dumps(manifest, indent=1, sort_keys=True, ensure_ascii=True) + "\n").encode()

    started = {"ok": False}
    journal: _Journal | None = None
    count = {"n": 0}

    def on_row(row: dict[str, str]) -> None:
        nonlocal journal
        if not started["ok"]:
            _begin()
        assert journal is not None
        if row["task"] in done:
            raise FormsyncError(f"expected each task once, received {row['task']!r} twice")
        journal.append(row)
        done[row["task"]] = row
        count["n"] += 1
        if progress:
            progress(count["n"], len(pending))

    def _begin() -> None:
        nonlocal journal
        outp.mkdir(parents=True, exist_ok=True)
        for name in _OWNED + ("manifest.json",):  # temporaries of a killed atomic write
            (outp / f".{name}.tmp").unlink(missing_ok=True)
        if mode == "overwrite":
            for name in _OWNED:
                (outp / name).unlink(missing_ok=True)
        if mode != "resume" or not (outp / "manifest.json").is_file():
            _atomic_write(outp / "manifest.json", man_bytes)
        journal = _Journal(jpath)
        started["ok"] = True

    if pending:
        # connect first: an unreachable scheduler must not leave anything behind
        fn = task_fn or run_task
        if n_workers == 0 and not scheduler:
            _begin()
            try:
                _execute(pending, on_row, scheduler=None, n_workers=0, timeout=timeout, task_fn=fn)
            finally:
                if journal is not None:
                    journal.close()
        else:
            try:
                _execute(pending, on_row, scheduler=scheduler, n_workers=n_workers, timeout=timeout,
                         task_fn=fn)
            finally:
                if journal is not None:
                    journal.close()
    if not started["ok"]:
        _begin()
        assert journal is not None
        journal.close()
    rows = sorted((done[t["task"]] for t in tasks), key=_sort_key)
    _atomic_write(outp / "results.csv", _csv_bytes(rows))
    files = [outp / "manifest.json", outp / "results.csv"]
    files += write_summary(outp, rows, manifest, command=command)
    jpath.unlink(missing_ok=True)
    return SweepOutcome(
        out=outp, sha256=sha, tasks=len(tasks), computed=len(pending),
        reused=len(tasks) - len(pending), graphs=len(graphs), skipped=tuple(skipped),
        files=tuple(files), wall_seconds=time.perf_counter() - t0, executor=executor,
    )


# ---------------------------------------------------------------------------
# summary: figures and Markdown
# ---------------------------------------------------------------------------
def _f(s: str) -> float | None:
    return None if s == "" else float(s)


def _pyplot() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot_fraction(rows: Sequence[dict[str, str]], x: str) -> Any:
    """Certified volume fraction of each box against column ``x`` (one marker per
    graph; colour = status of the reference gains).  Returns the figure.

    >>> fig = plot_fraction([{"box": "b", "lambda_max": "4", "frac_certified": "0.5",
    ...                       "ref_status": "certified"}], "lambda_max")
    >>> len(fig.axes)
    1
    """
    plt = _pyplot()
    boxes = list(dict.fromkeys(r["box"] for r in rows))
    fig, axs = plt.subplots(1, len(boxes), figsize=(5.2 * len(boxes), 4.0), squeeze=False)
    colors = {"certified": "tab:green", "refuted": "tab:red", "undecided": "tab:orange",
              "error": "black"}
    label = {"lambda_max": r"$\lambda_{\max}(L)$", "degree_max": "maximum degree",
             "lambda_2": r"$\lambda_2(L)$"}.get(x, x)
    for ax, b in zip(axs[0], boxes):
        sub = [r for r in rows if r["box"] == b]
        for st, col in colors.items():
            pts = [(float(r[x]), float(r["frac_certified"])) for r in sub if r["ref_status"] == st]
            if pts:
                xs, ys = zip(*pts)
                ax.scatter(xs, ys, s=22, c=col, alpha=0.6, edgecolors="none",
                           label=f"reference gains {st} ({len(pts)})")
        ax.set_xlabel(label)
        ax.set_ylabel("certified fraction of the box")
        ax.set_title(f"box {b}")
        ax.set_ylim(-0.02, 1.02)
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8, loc="upper right")
    fig.tight_layout()
    return fig


def plot_convergence(rows: Sequence[dict[str, str]]) -> Any:
    """Median (marker) and maximum (bar top) Monte-Carlo convergence time against
    ``lambda_2``.  Returns the figure."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(5.6, 4.0))
    pts = [r for r in rows if r["mc_status"] == "ran" and r["mc_conv_time_median"] != ""]
    for b in dict.fromkeys(r["box"] for r in pts):
        sub = [r for r in pts if r["box"] == b]
        x = [float(r["lambda_2"]) for r in sub]
        med = [float(r["mc_conv_time_median"]) for r in sub]
        mx = [float(r["mc_conv_time_max"]) for r in sub]
        ax.vlines(x, med, mx, colors="0.6", linewidth=0.8)
        ax.scatter(x, med, s=20, label=f"{b}: median (line to max)")
    ax.set_xlabel(r"$\lambda_2(L)$")
    ax.set_ylabel("convergence time (s)")
    ax.grid(True, alpha=0.3)
    if pts:
        ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def _save(fig: Any, path: Path) -> None:
    import io

    plt = _pyplot()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100, metadata={"Software": None})
    plt.close(fig)
    _atomic_write(path, buf.getvalue())


def _table(header: Sequence[str], body: Sequence[Sequence[Any]]) -> list[str]:
    out = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    out += ["| " + " | ".join(str(c) for c in row) + " |" for row in body]
    return out


def _pct(x: float) -> str:
    return f"{100 * x:.1f}%"


def write_summary(
    out: str | Path, rows: Sequence[dict[str, str]], manifest: dict[str, Any], *, command: str = ""
) -> list[Path]:
    """Write ``summary.md`` and the figures from the rows; returns the paths."""
    d = Path(out)
    camp = manifest["campaign"]
    paths = []
    fig = plot_fraction(rows, "lambda_max")
    p = d / "fraction-vs-lambda-max.png"
    _save(fig, p)
    paths.append(p)
    fig = plot_fraction(rows, "degree_max")
    p = d / "fraction-vs-max-degree.png"
    _save(fig, p)
    paths.append(p)
    has_mc = any(r["mc_status"] == "ran" for r in rows)
    if has_mc:
        p = d / "convergence-vs-lambda2.png"
        _save(plot_convergence(rows), p)
        paths.append(p)
    ref = camp["reference"]
    L: list[str] = []
    L.append(f"# Sweep `{camp['name']}`" + (f": {camp['title']}" if camp["title"] else ""))
    L.append("")
    L.append("Generated by `formsync sweep` (formsync_design/sweep/campaign.py); do not edit by hand.")
    if command:
        L.append(f"Regenerate with `{command}`.")
    L.append("")
    L.append(f"- campaign sha256: `{manifest['sha256']}`")
    L.append(f"- graph sets: {', '.join('`' + g + '`' for g in camp['graphs'])} "
             f"({len(manifest['graphs'])} graphs, {len(rows)} tasks)")
    if manifest["skipped"]:
        L.append(f"- skipped (listed, not analysed): {', '.join(manifest['skipped'])}")
    L.append(f"- conditions: {camp['conditions']} Lyapunov conditions (Theta_i > {camp['margin']}, "
             f"Pi > {camp['margin']})")
    L.append("- reference gains: " + ", ".join(f"{g} = {float(Fraction(ref[g])):g}" for g in GAINS))
    for b in camp["boxes"]:
        L.append(f"- box `{b['name']}`: " + " x ".join(
            f"{g} in [{float(Fraction(b[g][0])):g}, {float(Fraction(b[g][1])):g}]" for g in GAINS))
    L.append(f"- region resolution R = {camp['region']['resolution']} per axis; design: "
             f"{camp['design']['betas']} beta values, penalty {camp['design']['penalty']:g}")
    if camp["montecarlo"]:
        m = camp["montecarlo"]
        L.append(f"- Monte-Carlo: {m['runs']} runs per graph at the {m['gains']} gains, seed "
                 f"{m['seed']}, tf = {m['tf']:g} s, step {m['step']:g} s, initial angle <= "
                 f"{m['max_angle_deg']:g} deg, rates <= {m['max_rate']:g} rad/s")
    L.append("")
    L.append("Certified / refuted statuses are proofs (rigorous re-check of every vertex of a "
             "multi-affine family); spectral values are floating point and only position the "
             "points in the figures.")
    L.append("")
    # reference gains by N
    L.append("## Reference gains by formation size")
    L.append("")
    first_box = [r for r in rows if r["box_index"] == "0"]
    ns = sorted({int(r["n"]) for r in first_box})
    body = []
    for n in ns:
        sub = [r for r in first_box if int(r["n"]) == n]
        cnt = {s: sum(r["ref_status"] == s for r in sub) for s in ("certified", "refuted", "undecided", "error")}
        by = {}
        for r in sub:
            if r["ref_refuted_by"]:
                fam = "Pi" if r["ref_refuted_by"].startswith("Pi") else "Theta_i"
                by[fam] = by.get(fam, 0) + 1
        body.append([n, len(sub), cnt["certified"], cnt["refuted"], cnt["undecided"], cnt["error"],
                     ", ".join(f"{k}: {v}" for k, v in sorted(by.items())) or "-"])
    L += _table(["N", "graphs", "certified", "refuted", "undecided", "error", "refuted by"], body)
    L.append("")
    # certified fraction by box and max degree
    for bi, b in enumerate(camp["boxes"]):
        sub = [r for r in rows if r["box_index"] == str(bi)]
        L.append(f"## Box `{b['name']}`: certified fraction by maximum degree")
        L.append("")
        body = []
        for dm in sorted({int(r["degree_max"]) for r in sub}):
            s2 = [r for r in sub if int(r["degree_max"]) == dm]
            fr = [float(r["frac_certified"]) for r in s2]
            lm = [float(r["lambda_max"]) for r in s2]
            des = sum(r["design_status"] == "designed" for r in s2)
            body.append([dm, len(s2), f"{min(lm):.4g} .. {max(lm):.4g}", _pct(min(fr)),
                         _pct(sum(fr) / len(fr)), _pct(max(fr)), f"{des}/{len(s2)}"])
        L += _table(["max degree", "graphs", "lambda_max range", "certified min", "mean", "max",
                     "designed"], body)
        L.append("")
    if has_mc:
        L.append("## Monte-Carlo")
        L.append("")
        mc = [r for r in rows if r["mc_status"] == "ran"]
        runs = sum(int(r["mc_runs"]) for r in mc)
        conv = sum(int(r["mc_converged"]) for r in mc)
        L.append(f"{conv} of {runs} runs converged over {len(mc)} tasks; "
                 f"{sum(r['mc_status'].startswith('skipped') for r in rows)} tasks skipped.")
        bad = [r for r in mc if int(r["mc_converged"]) < int(r["mc_runs"])]
        if bad:
            L.append("")
            L += _table(["task", "ref status", "runs", "converged", "not converged", "singular",
                         "diverged", "inaccurate", "failed seeds"],
                        [[r["task"], r["ref_status"], r["mc_runs"], r["mc_converged"],
                          r["mc_not_converged"], r["mc_singular"], r["mc_diverged"],
                          r["mc_inaccurate"], r["mc_failed_seeds"]] for r in bad])
            L.append("")
            L.append("not converged: Q_m or Omega_m above tolerance at tf; singular: some q0 reached "
                     "q0_floor; diverged: NaN/inf; inaccurate: quaternion norm drift above 1e-5 "
                     "(integrator step too coarse for the run).")
        L.append("")
    L.append("## Figures")
    L.append("")
    L.append("![certified fraction vs lambda_max](fraction-vs-lambda-max.png)")
    L.append("")
    L.append("![certified fraction vs maximum degree](fraction-vs-max-degree.png)")
    if has_mc:
        L.append("")
        L.append("![convergence time vs lambda_2](convergence-vs-lambda2.png)")
    L.append("")
    L.append("## results.csv columns")
    L.append("")
    L += _table(["column", "meaning"], [[c, COLUMN_DOC[c]] for c in COLUMNS])
    L.append("")
    p = d / "summary.md"
    _atomic_write(p, ("\n".join(L)).encode("utf-8"))
    paths.append(p)
    return paths
