"""Topology sweeps and Monte-Carlo campaigns on Dask.

A *campaign* runs one design (``[campaign] design``, default liang2016) over a set
of communication graphs x a list of boxes of the design's controller gains, with a
reference gain point (default for liang2016: the paper's ``K_o = 1.6, K_q = 0.4,
beta = 0.3``; see :mod:`.designs`) and optional Monte-Carlo validation.  One *task* =
one graph x one box; it computes, with the public APIs of :mod:`.derive`,
:mod:`.certify`, :mod:`.region`, :mod:`.design` and :mod:`.montecarlo`:

* spectral facts of the graph (degrees, ``lambda_2`` and ``lambda_max`` of the
  Laplacian, floating point, for plotting only);
* the certification status of the reference gains (:func:`certify_box` at a
  point: certified / refuted / undecided / error, with the rigorous margin
  lower bound and the refuting family);
* the certified-region summary of the box (:func:`region_map` volume fractions
  certified / refuted / undecided at resolution ``R``);
* recommended gains (:func:`design_gains`) and the largest certified box
  around them (:func:`largest_certified_box` through ``design_gains``);
* Monte-Carlo statistics (:func:`run_montecarlo`; for an agent design
  :func:`~formsync_design.sim.agent_montecarlo.run_agent_montecarlo` on its agent case,
  :class:`MonteCarloSpec`) when asked.

A design whose Lyapunov candidate has multipliers (pd_consensus's ``eps``) has them
searched over their declared ranges, as ``formsync certify`` and ``formsync region`` do
(:func:`~formsync_design.certify.multipliers.certify_with_multipliers`,
:func:`~formsync_design.certify.multiregion.region_with_multipliers`; the gain design
sweeps the multiplier as its third dimension and holds it in the certified box): the
chosen values are reported as evidence (``ref_cert_eps``, ``rec_cert_eps``).  The
columns are named after the design's gains (:class:`~.schema.SweepSchema`).

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
    the tidy table (columns named after the design's gains,
    :class:`~.schema.SweepSchema`; liang2016's are :data:`~.schema.COLUMNS`, meanings
    in ``summary.md``), one row per task, sorted by ``(graph_index, box_index)``, floats with 10 significant
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

import hashlib
import json
import math
import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from fractions import Fraction
from pathlib import Path
from typing import Any

from formsync_design.errors import InputError
from formsync_design.gains import GainBox, parse_number
from formsync_design.ranges import check_range, quantity_of
from formsync_design.sweep.campaign_fields import campaign_base, campaign_field, shown
from formsync_design.sweep.designs import (
    check_agent_box,
    check_sweepable,
    default_box,
    default_reference,
    gain_key_error,
    is_default_design,
    load_design,
)
from formsync_design.sweep.graphsets import GraphEntry
from formsync_design.sweep.mccase import MonteCarloSpec, case_text
from formsync_design.sweep.schema import CLASSIC_SCHEMA, FORMAT, SweepSchema, rational_text

__all__ = [
    "GainBoxSpec",
    "Campaign",
    "campaign_from_dict",
    "load_campaign",
    "campaign_hash",
    "graph_records",
    "resolve_spec",
    "spec_key",
]


@dataclass(frozen=True)
class GainBoxSpec:
    """A named gain box of a campaign: a :class:`~formsync_design.gains.GainBox` over
    the design's controller gains (exact bounds) with the name used in ``results.csv``.

    >>> b = GainBoxSpec("b", GainBox.parse({"K_o": "1:2", "K_q": 1, "beta": "0.1:0.3"}))
    >>> b.bounds[0], b.to_dict()["beta"]
    ((Fraction(1, 1), Fraction(2, 1)), ['1/10', '3/10'])
    """

    name: str
    box: GainBox

    def __post_init__(self) -> None:
        object.__setattr__(self, "box", GainBox.parse(self.box))

    @property
    def bounds(self) -> tuple[tuple[Fraction, Fraction], ...]:
        """Exact ``((lo, hi), ...)`` in the box's gain order."""
        return self.box.bounds

    def to_dict(self) -> dict[str, Any]:
        """Canonical form (bounds as exact ``"p/q"`` text: hashed into the manifest)."""
        return {"name": self.name,
                **{g: [rational_text(lo), rational_text(hi)]
                   for g, (lo, hi) in zip(self.box.names, self.bounds)}}


@dataclass(frozen=True)
class Campaign:
    """A validated campaign definition (:func:`campaign_from_dict`).

    ``spec``: the design as written (``[campaign] design``: a shipped name or a file
    relative to ``spec_dir``; ``""``: liang2016, or ``spec_value``); ``spec_value``: a
    design given as a value (``campaign_from_dict(..., spec=...)``); ``schema``: the
    design's gain names the tables and columns are keyed by.
    """

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
    spec: str = ""
    base: str = field(default=".", compare=False)
    spec_dir: str = field(default=".", compare=False)
    schema: SweepSchema = CLASSIC_SCHEMA
    spec_value: Any = field(default=None, compare=False, repr=False)
    compare: str = ""
    source: str = field(default="", compare=False)

    def load_design(self) -> Any:
        """The design ``[campaign] design`` names: from a campaign file (``source``), a shipped
        name or a trusted ``.py`` file beside it (:mod:`formsync_design.spec.trust`); from a
        dict built in Python, a name or a path (relative to ``spec_dir``) the caller gave."""
        return _campaign_design(self.spec, self.source, self.spec_dir)

    def to_dict(self) -> dict[str, Any]:
        """Canonical, JSON-ready definition (hashed into the manifest)."""
        return {
            "name": self.name,
            "title": self.title,
            "graphs": list(self.graphs),
            "conditions": self.conditions,
            "margin": rational_text(self.margin),
            "reference": {g: rational_text(v) for g, v in zip(self.schema.box, self.reference)},
            "boxes": [b.to_dict() for b in self.boxes],
            "region": {"resolution": self.resolution},
            "design": {"betas": self.design_betas, "penalty": self.design_penalty},
            "montecarlo": None if self.montecarlo is None else self.montecarlo.to_dict(),
            **({"spec": self.spec} if self.spec else {}),
            **({"compare": self.compare} if self.compare else {}),
        }


_TOP = {"campaign", "reference", "box", "region", "design", "montecarlo"}
_KEYS = {
    "campaign": {"name", "title", "graphs", "conditions", "margin", "spec", "design", "compare"},
    "region": {"resolution"},
    "design": {"betas", "penalty"},
    "montecarlo": {"runs", "seed", "gains", "case", "max_angle_deg", "max_rate", "phases",
                   "tf", "step", "output_step", "disturbance"},
}


def _check_keys(table: Any, name: str, keys: set[str] | None = None) -> dict:
    if not isinstance(table, dict):
        raise InputError(f"expected a table [{name}], received {table!r}")
    allowed = _KEYS[name] if keys is None else keys
    extra = set(table) - allowed
    if extra:
        raise InputError(f"expected keys {sorted(allowed)} in [{name}], received unknown {sorted(extra)}")
    return table


def _pos_int(v: Any, what: str, lo: int = 1, hi: int | None = None) -> int:
    if isinstance(v, bool) or not isinstance(v, int) or v < lo or (hi is not None and v > hi):
        rng = f"{lo}..{hi}" if hi is not None else f">= {lo}"
        raise InputError(f"expected an integer {what} in {rng}, received {v!r}")
    return v


def _pos_float(v: Any, what: str, *, allow_zero: bool = False) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or (
            isinstance(v, float) and not math.isfinite(v)) or v < 0 or (v == 0 and not allow_zero):
        shown = repr(v) if len(repr(v)) <= 60 else repr(v)[:57] + "..."
        raise InputError(f"expected a {'non-negative' if allow_zero else 'positive'} number for "
                         f"{what}, received {shown}")
    check_range(v, quantity_of(what), what)
    return float(v)


def _campaign_design(ref: str, source: str | Path, spec_dir: str | Path) -> Any:
    """:meth:`Campaign.load_design` (``source``: the campaign file, ``""`` for a dict)."""
    from formsync_design.resources import design_names

    if source:
        return load_design(ref, Path(source))
    if ref and ref not in design_names() and not Path(ref).is_absolute():
        ref = str(Path(spec_dir) / ref)
    return load_design(ref)


def _design_ref(c: dict, spec: Any) -> tuple[str, Any]:
    """``([campaign] design as written, the design value given as an argument)``."""
    if "spec" in c and "design" in c:
        raise InputError("expected one of campaign.design or campaign.spec (its old name), received both")
    key = "design" if "design" in c else "spec"
    ref = c.get(key, "")
    if not isinstance(ref, str):
        raise InputError(f"expected campaign.{key} as a design name or a .py path string, received {ref!r}")
    if spec is not None and ref.strip():
        raise InputError(f"expected one design, received both a design argument and campaign.{key} = "
                         f"{ref!r}")
    return ref.strip(), spec


def _gain_values(table: dict, where: str, sp: Any, schema: SweepSchema) -> dict[str, Any]:
    """The gain entries of a ``[reference]`` or ``[[box]]`` table, checked against the design."""
    gains = {k: v for k, v in table.items() if k != "name"}
    err = gain_key_error(sp, schema, where, list(gains))
    if err is not None:
        raise err
    for g in schema.box:
        if g not in gains:
            form = " = [lo, hi]" if where.startswith("[[box]]") else ""
            raise InputError(f"expected {g}{form} in {where} (design {sp.name}: "
                             f"{', '.join(schema.box)}), received keys {sorted(gains)}")
    return gains


def _boxes(data: dict, sp: Any, schema: SweepSchema) -> list[GainBoxSpec]:
    boxes_raw = data["box"] if "box" in data else [default_box(sp, schema)]
    if isinstance(boxes_raw, dict):
        boxes_raw = [boxes_raw]
    if not isinstance(boxes_raw, list) or not boxes_raw:
        raise InputError(f"expected at least one [[box]] table, received {boxes_raw!r}")
    boxes = []
    for k, b in enumerate(boxes_raw):
        if not isinstance(b, dict):
            raise InputError(f"expected a table [[box]], received {b!r}")
        bname = b.get("name", f"box{k + 1}")
        if not isinstance(bname, str) or not re.fullmatch(r"[A-Za-z0-9_.-]+", bname):
            raise InputError(f"expected box names made of letters, digits, '_', '.', '-', received {bname!r}")
        given = _gain_values(b, f"[[box]] {bname!r}", sp, schema)
        bounds = []
        for g in schema.box:
            v = given[g]
            lo, hi = (v if isinstance(v, list) else [v, v]) if not isinstance(v, list) or len(v) == 2 else (None, None)
            if lo is None:
                raise InputError(f"expected box.{g} = [lo, hi] or a number in box {bname!r}, received {v!r}")
            lo_q, hi_q = parse_number(lo, f"box {bname} {g}"), parse_number(hi, f"box {bname} {g}")
            if not 0 < lo_q <= hi_q:
                raise InputError(
                    f"expected 0 < lo <= hi for {g} in box {bname!r}, received [{float(lo_q):g}, {float(hi_q):g}]"
                )
            bounds.append((lo_q, hi_q))
        boxes.append(GainBoxSpec(bname, GainBox.parse(bounds, schema.box)))
    if len({b.name for b in boxes}) != len(boxes):
        raise InputError(f"expected distinct box names, received {[b.name for b in boxes]}")
    return boxes


_LAGRANGIAN_MC = ("phases", "K_v")


def _montecarlo(m: Any, sp: Any, schema: SweepSchema, base: Path = Path("."),
                source: str = "") -> MonteCarloSpec:
    sw = schema.switching
    if isinstance(m, dict) and schema.agent:
        for k in _LAGRANGIAN_MC:
            if k in m:
                raise InputError(f"expected no montecarlo.{k} for the agent design {sp.name} (it "
                                 "applies to the Lagrangian designs), received one")
    keys = _KEYS["montecarlo"] | ({sw} if sw else set())
    if isinstance(m, dict) and sw is None and "K_v" in m:
        raise InputError(f"expected no montecarlo.K_v for design {sp.name} (it has no switching "
                         "gain), received one")
    m = _check_keys(m, "montecarlo", keys)
    gains = m.get("gains", "reference")
    if gains not in ("reference", "recommended"):
        raise InputError(f"expected montecarlo.gains reference or recommended, received {gains!r}")
    case = m.get("case", "")
    if not isinstance(case, str):
        raise InputError(f"expected montecarlo.case as a path string or a shipped case's name, "
                         f"received {case!r}")
    dist = m.get("disturbance", "")
    if dist not in ("", "paper", "gravity-gradient", "none"):
        raise InputError(
            f"expected montecarlo.disturbance paper, gravity-gradient or none, received {dist!r}"
        )
    phases = m.get("phases", True)
    if not isinstance(phases, bool):
        raise InputError(f"expected true/false for montecarlo.phases, received {phases!r}")
    kv = m.get(sw) if sw else None
    kvq = None if kv is None else parse_number(kv, f"montecarlo.{sw}")
    if kvq is not None and kvq < 0:
        raise InputError(f"expected montecarlo.{sw} >= 0, received {float(kvq):g}")
    return MonteCarloSpec(
        runs=_pos_int(m.get("runs", 20), "montecarlo.runs", 1, 10**7),
        seed=_pos_int(m.get("seed", 0), "montecarlo.seed", 0),
        gains=gains,
        case=case,
        K_v=kvq,
        max_angle_deg=_pos_float(m.get("max_angle_deg", 100.0), "montecarlo.max_angle_deg", allow_zero=True),
        max_rate=_pos_float(m.get("max_rate", 0.9), "montecarlo.max_rate", allow_zero=True),
        phases=phases,
        tf=_sim_option(m, "tf", 200.0, schema.agent),
        step=_sim_option(m, "step", 0.1, schema.agent),
        output_step=_sim_option(m, "output_step", 0.5, schema.agent),
        disturbance=dist,
        switching=sw,
        agent=schema.agent,
        base=str(base),
        source=source,
    )


def _sim_option(m: dict, key: str, default: float, agent: bool) -> float | None:
    """``montecarlo.KEY`` (positive); not given: ``default``, or ``None`` for an agent design
    (its case's ``[simulation]`` value)."""
    if key not in m and agent:
        return None
    return _pos_float(m.get(key, default), f"montecarlo.{key}")


def _check_agent_campaign(sp: Any, schema: SweepSchema, boxes: Sequence[GainBoxSpec],
                          penalty: float, mc: MonteCarloSpec | None) -> None:
    """What a campaign of an agent design cannot hold (one-line errors)."""
    for b in boxes:
        check_agent_box(sp, schema, b.name, b.bounds)
    if penalty:
        raise InputError(f"expected design.penalty 0 for the agent design {sp.name} (its gain "
                         f"design is a grid, as formsync design), received {penalty:g}")
    if mc is not None and sp.decl.leader:
        raise InputError(f"expected no [montecarlo] (--mc-runs) for the design {sp.name}: it "
                         "declares a leader and a sweep's graphs pin no spacecraft to it (run "
                         f"formsync montecarlo --design {sp.name} with a case whose graph pins), "
                         "received one")


def _reference(data: dict, sp: Any, schema: SweepSchema) -> tuple[Fraction, ...]:
    ref = data["reference"] if "reference" in data else default_reference(sp, schema)
    if not isinstance(ref, dict):
        raise InputError(f"expected a table [reference], received {shown(ref)}")
    if "name" in ref:
        raise InputError(f"expected only gains in [reference], received unknown {['name']}")
    ref = _gain_values(ref, "[reference]", sp, schema)
    reference = tuple(parse_number(ref[g], f"reference.{g}") for g in schema.box)
    for g, v in zip(schema.box, reference):
        check_range(v, "gain", f"reference.{g}")
    if any(v <= 0 for v in reference):
        raise InputError(f"expected positive reference gains, received {[float(v) for v in reference]}")
    return reference


def campaign_from_dict(data: dict, *, base: str | Path = ".", spec_dir: str | Path = ".",
                       spec: Any = None, source: str = "") -> Campaign:
    """Validate a campaign document (the TOML layout of :func:`load_campaign`).

    ``source``: the campaign file the document was read from; its paths (graph files and
    folders, ``compare``, ``montecarlo.case``) then stay inside ``base``
    (:func:`~formsync_design.textio.confined_path`), and its ``[campaign] design`` may name
    only a shipped design or a trusted ``.py`` file beside it
    (:mod:`formsync_design.spec.trust`).  ``""``: the command line's or the caller's own
    document (built in Python: the user's paths, not confined).

    ``spec``: the design (a ``Spec``, a shipped design's name or a ``.py`` path relative
    to the current folder) when the document names none (``[campaign] design``,
    ``spec_dir``); default liang2016.  The gain tables are checked against the design's
    gains.

    >>> c = campaign_from_dict({"campaign": {"name": "t", "graphs": ["ring:4"]}})
    >>> c.boxes[0].name, [float(v) for v in c.reference], c.resolution
    ('standard', [1.6, 0.4, 0.3], 8)
    >>> c = campaign_from_dict({"campaign": {"name": "t", "graphs": ["ring:4"],
    ...                                      "design": "pd_consensus"}})
    >>> c.schema.box, [float(v) for v in c.reference], str(c.boxes[0].box)
    (('k_p', 'k_d'), [0.4, 1.6], 'k_p=0.1:2, k_d=0.5:3')
    >>> c = campaign_from_dict({"campaign": {"name": "t", "graphs": ["ring:4"], "design": "ma_so3"},
    ...                         "box": {"K1": [1, 2], "K2": [0.1, 0.2], "P1": 0.03, "P2": 0.03,
    ...                                 "eps": 0.01}})
    >>> c.schema.form, [float(v) for v in c.reference]
    ('agent', [1.15, 0.15, 0.03, 0.03, 0.01])
    """
    if not isinstance(data, dict):
        raise InputError(f"expected a campaign table, received {data!r:.60}")
    extra = set(data) - _TOP
    if extra:
        raise InputError(f"expected tables {sorted(_TOP)} in the campaign, received unknown {sorted(extra)}")
    c = _check_keys(data.get("campaign", {}), "campaign")
    # [campaign] field by field in the order written (the first error named is the first
    # fault of the file), then the fields left out (their defaults, or "required")
    f: dict[str, Any] = {}
    for key in [*c, *(k for k in ("name", "graphs") if k not in c)]:
        f[key] = campaign_field(key, c.get(key), Path(base), source)
    ref_text, spec_arg = _design_ref(c, spec)
    sp = load_design(spec_arg) if spec_arg is not None else _campaign_design(ref_text, source,
                                                                             spec_dir)
    schema = check_sweepable(sp)
    cond = f.get("conditions", "derived")
    if cond == "paper" and not is_default_design(sp):
        raise InputError(f"expected campaign.conditions derived for design {sp.name} (the printed "
                         "conditions are liang2016's), received paper")
    # the other tables in the order written (each needs only the design)
    reference: tuple[Fraction, ...] = ()
    boxes: list[GainBoxSpec] = []
    resolution, betas, penalty, mc = 8, 5, 0.0, None
    for table in [*(t for t in data if t != "campaign"), "reference", "box"]:
        if table == "reference" and not reference:
            reference = _reference(data, sp, schema)
        elif table == "box" and not boxes:
            boxes = _boxes(data, sp, schema)
        elif table == "region":
            reg = _check_keys(data["region"], "region")
            resolution = _pos_int(reg.get("resolution", 8), "region.resolution", 1, 512)
        elif table == "design":
            des = _check_keys(data["design"], "design")
            betas = _pos_int(des.get("betas", 5), "design.betas", 1, 1000)
            penalty = _pos_float(des.get("penalty", 0.0), "design.penalty", allow_zero=True)
        elif table == "montecarlo":
            mc = _montecarlo(data["montecarlo"], sp, schema, Path(base), source)
    if schema.agent:
        _check_agent_campaign(sp, schema, boxes, penalty, mc)
    name, title, graphs = f["name"], f.get("title", ""), f["graphs"]
    margin, compare = f.get("margin", Fraction(0)), f.get("compare", "")
    return Campaign(
        name=name, title=title, graphs=graphs, boxes=tuple(boxes),
        reference=reference, conditions=cond, margin=margin, resolution=resolution,
        design_betas=betas, design_penalty=penalty, montecarlo=mc, base=str(base),
        spec=ref_text, spec_dir=str(spec_dir), schema=schema,
        spec_value=sp if spec_arg is not None else None, compare=compare, source=source,
    )


def load_campaign(path: str | Path, spec: Any = None, *, trust: Any = ()) -> Campaign:
    """Load a campaign TOML file; its relative paths -- ``compare``, graph folders
    (``dir:PATH``), the Monte-Carlo case and ``campaign.design`` (a shipped design's name or
    a design file, default liang2016) -- resolve relative to the campaign file
    (:func:`campaign_base`), never to the current directory, and stay inside that folder (an
absolute path or a ``..`` out of it is refused).  Each table is validated
    field by field in the order written.
    ``spec``: the design when the file names none (``--design``).  ``campaign.design`` names
    a shipped design or a ``.py`` file inside the campaign's folder that the user trusts
    (``trust``: its paths, ``--trust-design``; :mod:`formsync_design.spec.trust`).

    Layout::

        [campaign]   name, title, graphs = ["atlas:6", "ring:4..12", ...],
                     conditions = "derived" | "paper", margin = 0,
                     design = "pd_consensus" | "my_design.py"  (optional; default liang2016;
                     old name: spec),
                     compare = "reports/sweep-atlas6"  (optional: another sweep's results
                     folder; the summary compares the reference statuses, .compare)
        [reference]  the design's controller gains: K_o, K_q, beta for liang2016 (default
                     the paper's 1.6, 0.4, 0.3); k_p, k_d for pd_consensus (default: its
                     shipped case's)
        [[box]]      name, one [lo, hi] per controller gain: K_o = [lo, hi], ...
                     (default: one box "standard", the declared ranges, liang2016's
                     [0.05,5] x [0.05,5] x [0.01,1])
        [region]     resolution = 8
        [design]     betas = 5 (values of the swept third gain: beta; a multiplier such
                     as eps), penalty = 0.0
        [montecarlo] runs, seed, gains = "reference" | "recommended", case, K_v (the
                     switching gain, only for a design with one), max_angle_deg,
                     max_rate, phases, tf, step, output_step, disturbance
                     (optional table: no Monte-Carlo without it)

    Multipliers of the design's Lyapunov candidate are never given: every certificate
    searches them over their declared ranges.
    """
    from formsync_design.spec.trust import trusting
    from formsync_design.tomlio import load_toml

    p = Path(path)
    data = load_toml(p, "campaign TOML file")
    with trusting(*trust):
        return campaign_from_dict(data, base=campaign_base(p), spec_dir=p.parent, spec=spec,
                                  source=str(p))



def resolve_spec(campaign: Campaign, spec: Any = None) -> Any:
    """The :class:`~formsync_design.spec.loader.Spec` a campaign runs: ``spec`` (a
    ``Spec``, a name, a path) or else the campaign's design, else the paper's.

    Raises :class:`InputError` when both name a design, or when the design's gains are
    not the ones the campaign's tables were checked against.

    >>> c = campaign_from_dict({"campaign": {"name": "t", "graphs": ["ring:4"]}})
    >>> resolve_spec(c).name
    'liang2016'
    >>> resolve_spec(c, "pd_consensus")
    Traceback (most recent call last):
    ...
    formsync_design.errors.InputError: expected a design with the campaign's gains (K_o, K_q, beta), received design pd_consensus with k_p, k_d (multipliers eps)
    """
    if spec is not None and (campaign.spec or campaign.spec_value is not None):
        raise InputError(
            f"expected one specification, received both a spec argument and the campaign's design "
            f"{campaign.spec or campaign.spec_value.name!r}"
        )
    if spec is not None:
        sp = load_design(spec)
    elif campaign.spec_value is not None:
        sp = campaign.spec_value
    else:
        sp = campaign.load_design()
    schema = SweepSchema.of_design(sp)
    if schema != campaign.schema:
        mult = f" (multipliers {', '.join(schema.multipliers)})" if schema.multipliers else ""
        raise InputError(f"expected a design with the campaign's gains ({', '.join(campaign.schema.box)}), "
                         f"received design {sp.name} with {', '.join(schema.box)}{mult}")
    return sp


def spec_key(spec: Any) -> str:
    """sha256 of a specification's content (its ``key``; for a file, the sha256 of its bytes).

    >>> from formsync_design.spec.loader import load_spec
    >>> len(spec_key(load_spec(None)))
    64
    """
    return str(spec.key)


def _digest(obj: Any) -> str:
    text = json.dumps(obj, sort_keys=True, separators=(",", ":"), ensure_ascii=True)
    return hashlib.sha256(text.encode()).hexdigest()


def graph_records(graphs: Sequence[GraphEntry]) -> list[dict[str, Any]]:
    return [
        {"index": k, "id": g.id, "set": g.graph_set, "n": g.graph.n, "edges": g.edge_text()}
        for k, g in enumerate(graphs)
    ]


def campaign_hash(campaign: Campaign, graphs: Sequence[GraphEntry], spec: Any = None) -> str:
    """sha256 of the canonical definition, the expanded graph list (ids and edges), the
    columns, the content key of the design (``spec``, resolved by :func:`resolve_spec`),
    with Monte-Carlo the content of the case file, and with ``compare`` the compared
    sweep's results.

    The package version is deliberately *not* hashed: the committed reports must
    regenerate byte for byte across releases, and a folder stays resumable across
    releases that do not change its rows.  A release that changes how a row is
    computed bumps :data:`~formsync_design.sweep.schema.FORMAT` instead, which is
    hashed (so such a folder is refused).

    >>> from formsync_design.sweep.graphsets import expand_graphs
    >>> c = campaign_from_dict({"campaign": {"name": "t", "graphs": ["ring:4"]}})
    >>> gs, _ = expand_graphs(c.graphs)
    >>> campaign_hash(c, gs) == campaign_hash(c, gs), len(campaign_hash(c, gs))
    (True, 64)
    """
    doc: dict[str, Any] = {"format": FORMAT, "columns": list(campaign.schema.columns),
                           "campaign": campaign.to_dict(), "graphs": graph_records(graphs),
                           "spec_sha256": spec_key(resolve_spec(campaign, spec))}
    if campaign.montecarlo is not None:
        text = case_text(campaign.montecarlo, resolve_spec(campaign, spec))[1]
        doc["case_sha256"] = hashlib.sha256(text.encode()).hexdigest()
    if campaign.compare:
        from formsync_design.sweep.compare import load_compared

        doc["compare_sha256"] = load_compared(campaign.compare, campaign.base).sha256
    return _digest(doc)
