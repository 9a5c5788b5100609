"""Tasks of a sweep: one payload per graph x box, and the pure function computing its row.

A row is computed for any design the sweep takes (:func:`~.designs.check_sweepable`):
the reference point and the box are over the design's controller gains, its
multipliers are searched over their declared ranges by the certificate of the
reference point (:func:`~formsync_design.certify.multipliers.certify_with_multipliers`)
and per cell by the region map
(:func:`~formsync_design.certify.multiregion.region_with_multipliers`) - for a design
without multipliers these are :func:`certify_box` and :func:`region_map` - and the
gain design optimizes the first two family gains, sweeps the third and holds a
multiplier at its recommended value in the largest certified box, as ``formsync
certify``, ``formsync region`` and ``formsync design`` do.  An agent design's row is
computed by :mod:`formsync_design.certify.agent` (its ``conditions(c)`` families on the
graph), as those commands compute it for an agent design, plus the ``theorem`` column.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from fractions import Fraction
from pathlib import Path
from typing import Any

from formsync_design.graphs.build import Graph
from formsync_design.sweep.campaign import Campaign
from formsync_design.sweep.graphsets import GraphEntry
from formsync_design.sweep.mccase import case_text
from formsync_design.sweep.schema import SweepSchema, fmt_cell, rational_text

__all__ = ["build_tasks", "run_task", "agent_mc_inputs"]


def build_tasks(
    campaign: Campaign, graphs: Sequence[GraphEntry], spec: Any = None
) -> list[dict[str, Any]]:
    """One payload per graph x box (plain data: picklable, executor-independent).

    ``spec`` (a ``Spec``, a name or a path; default the campaign's design, else the
    paper's) is carried as its file path and the sha256 of its content (``None`` for the
    paper's; a worker loads that path only with that content), or as the ``Spec`` value
    itself when it was built in Python (Dask pickles it by value).
    """
    from formsync_design.sweep.campaign import resolve_spec
    from formsync_design.sweep.designs import is_default_design

    sp = resolve_spec(campaign, spec)
    if is_default_design(sp):
        spec_payload: Any = None
    elif getattr(sp, "source", sp.path) == "<python>":
        spec_payload = sp
    else:
        spec_payload = str(Path(sp.path).resolve())
    common = {
        "spec": spec_payload,
        # the content a worker may load for that path (the content trusted and checked here)
        "spec_sha256": sp.key if isinstance(spec_payload, str) else None,
        "schema": campaign.schema.to_dict(),
        "conditions": campaign.conditions,
        "margin": rational_text(campaign.margin),
        "reference": [rational_text(v) for v in campaign.reference],
        "resolution": campaign.resolution,
        "design_betas": campaign.design_betas,
        "design_penalty": campaign.design_penalty,
        "montecarlo": None,
    }
    if campaign.montecarlo is not None:
        path, text = case_text(campaign.montecarlo, sp)
        common["montecarlo"] = {**campaign.montecarlo.to_dict(), "case_path": path, "case_text": text,
                                "case_trust": _case_trust(path)}
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
                "bounds": [[rational_text(lo), rational_text(hi)] for lo, hi in b.bounds],
                **common,
            })
    return tasks


def _case_trust(path: str) -> list[str] | None:
    """``[path, sha256]`` of the trusted design file the Monte-Carlo case names (checked when
    the campaign was read here), for the workers that parse the case again; else ``None``."""
    from formsync_design.spec.trust import pinned_digest
    from formsync_design.verify.agentcase import case_design_ref

    ref = case_design_ref(path)
    if ref is None or not ref.endswith(".py"):
        return None
    target = Path(path).parent / ref
    sha = pinned_digest(target)
    return None if sha is None else [str(target), sha]


def _mc_formation(graph: Graph, mc: dict, schema: SweepSchema,
                  gains: Sequence[Fraction]) -> tuple[Any, float | None]:
    import numpy as np

    from formsync_design.sim.formation import Formation, Gains
    from formsync_design.spec.trust import TrustedFile, trusting
    from formsync_design.tomlio import parse_toml
    from formsync_design.verify.case import make_disturbance, parse_case

    trust = [TrustedFile(*mc["case_trust"])] if mc.get("case_trust") else []
    with trusting(*trust):  # the case's design file, trusted with this content where it was read
        case = parse_case(parse_toml(mc["case_text"], mc["case_path"]), mc["case_path"])
    n = graph.n
    J = np.array([case.inertias[i % case.n] for i in range(n)])
    table = dict(case.disturbance)
    if mc["disturbance"]:
        table = {"model": mc["disturbance"], **({"signs": table["signs"]} if "signs" in table else {})}
    dist = make_disturbance(table, J, case.orbit)
    att = np.tile([0.0, 0.0, 0.0, 1.0], (n, 1))
    values = {g: float(v) for g, v in zip(schema.box, gains)}
    if schema.switching is None:
        return Formation(graph, J, att, np.zeros((n, 3)), Gains(values), dist), None
    kv_given = mc[schema.switching]
    kv = float(Fraction(kv_given)) if kv_given is not None else float(min(case.gains.K_v))
    return Formation(graph, J, att, np.zeros((n, 3)), Gains(values, (kv,) * n), dist), kv


def _task_spec(task: dict[str, Any]) -> Any:
    from formsync_design.spec.loader import Spec, load_design, load_spec

    sp = task.get("spec")
    if isinstance(sp, Spec) or getattr(sp, "form", None) == "agent":
        return sp
    sha = task.get("spec_sha256")
    return (load_design(sp, sha256=sha) if task["schema"].get("form") == "agent"
            else load_spec(sp, sha256=sha))


def _run_mc(graph: Graph, mc: dict, schema: SweepSchema, gains: Sequence[Fraction] | None,
            spec: Any = None) -> dict[str, Any]:
    from formsync_design.gains import GainBox
    from formsync_design.sim.formation import SimOptions
    from formsync_design.sim.montecarlo import run_montecarlo
    from formsync_design.sim.montecarlo_data import MonteCarloSettings

    out: dict[str, Any] = {"mc_gains": mc["gains"]}
    if gains is None:
        out["mc_status"] = "skipped (no recommended gains)"
        return out
    base, kv = _mc_formation(graph, mc, schema, gains)
    point: dict[str, Any] = dict(zip(schema.box, gains))
    if schema.switching is not None:
        point[schema.switching] = kv
    box = GainBox.parse(point, positive=schema.box)
    st = MonteCarloSettings(runs=mc["runs"], seed=mc["seed"], max_angle_deg=mc["max_angle_deg"],
                            max_rate=mc["max_rate"], phases=mc["phases"])
    opt = SimOptions(tf=mc["tf"], step=mc["step"], output_step=mc["output_step"], norm_tol=1e-5)
    r = run_montecarlo(base, box, st, opt, threads=1, certify=False, spec=spec)
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


def _mc_cells(runs: Sequence[Any], statuses: Sequence[str]) -> dict[str, Any]:
    """The ``mc_*`` cells of a list of runs (each with ``status``, ``seed`` and
    ``convergence_time``): counts per status, the convergence-time statistics of
    :func:`~formsync_design.sim.montecarlo.run_montecarlo` and at most 20 failed seeds."""
    import numpy as np

    ct = np.array([r.convergence_time for r in runs if r.convergence_time is not None])
    return {
        "mc_status": "ran", "mc_runs": len(runs),
        **{f"mc_{s.replace('-', '_')}": sum(str(r.status) == s for r in runs) for s in statuses},
        "mc_conv_time_median": float(np.median(ct)) if ct.size else None,
        "mc_conv_time_p95": float(np.percentile(ct, 95)) if ct.size else None,
        "mc_conv_time_max": float(ct.max()) if ct.size else None,
        "mc_failed_seeds": ";".join([str(r.seed) for r in runs
                                     if str(r.status) != "converged"][:20]),
    }


def agent_mc_inputs(graph: Graph, mc: dict[str, Any], design: Any,
                    gains: Sequence[Fraction]) -> tuple[Any, Any, Any, Any]:
    """``(formation, box, settings, options)`` of an agent design's Monte-Carlo in a sweep
    task, for :func:`~formsync_design.sim.agent_montecarlo.run_agent_montecarlo`.

    The case (``mc["case_text"]``, an agent case) is resized to the graph's spacecraft by
    :meth:`~formsync_design.verify.agentcase.AgentCase.cycled`: spacecraft ``i`` takes the
    inertia, initial attitude, rate and controller states of the case's spacecraft
    ``i % case.n``, as the Lagrangian Monte-Carlo cycles inertias (attitudes and rates are
    drawn per run anyway).  The box is the point ``gains`` over the design's controller
    gains; the options are the case's, with ``tf``, ``step``, ``output_step`` of
    ``[montecarlo]`` where given; ``disturbance`` (when given) replaces the case's model.
    """
    from dataclasses import replace

    from formsync_design.gains import GainBox
    from formsync_design.sim.montecarlo_data import MonteCarloSettings
    from formsync_design.tomlio import parse_toml
    from formsync_design.verify.agentcase import parse_agent_case

    case = parse_agent_case(parse_toml(mc["case_text"], mc["case_path"]), mc["case_path"],
                            design=design).cycled(graph.n)
    names = tuple(design.decl.controller_gains)
    box = GainBox.parse([(v, v) for v in gains], names)
    settings = MonteCarloSettings(runs=mc["runs"], seed=mc["seed"],
                                  max_angle_deg=mc["max_angle_deg"],
                                  max_rate=mc["max_rate"]).resolved_for("agent")
    opt = replace(case.options, **{k: mc[k] for k in ("tf", "step", "output_step")
                                   if mc[k] is not None})
    base = case.formation(graph, disturbance=mc["disturbance"] or None)
    return base, box, settings, opt


def _run_agent_mc(graph: Graph, mc: dict[str, Any], design: Any,
                  gains: Sequence[Fraction] | None) -> dict[str, Any]:
    from formsync_design.sim.agent_montecarlo import run_agent_montecarlo
    from formsync_design.sim.agents import AGENT_STATUSES

    out: dict[str, Any] = {"mc_gains": mc["gains"]}
    if gains is None:
        out["mc_status"] = "skipped (no recommended gains)"
        return out
    base, box, settings, opt = agent_mc_inputs(graph, mc, design, gains)
    r = run_agent_montecarlo(design, base, box, settings, opt, certify=False)
    out.update(_mc_cells(r.runs, [str(s) for s in AGENT_STATUSES]))
    return out


def _chosen(box: Any, names: Sequence[str]) -> dict[str, Fraction]:
    """The multiplier values a certificate's box holds (points when certified)."""
    if box is None:
        return {}
    return {n: box[n].lo for n in names if n in box and box[n].is_point}


def _agent_row(task: dict[str, Any], g: Graph, design: Any, schema: SweepSchema,
               bounds: Sequence[tuple[Fraction, Fraction]], ref: Sequence[Fraction],
               margin: Fraction) -> dict[str, Any]:
    """The certificate, region and design cells of an agent design's row, as ``formsync
    certify``, ``region`` and ``design`` compute them (:mod:`formsync_design.certify.agent`);
    a graph outside the design's theorem is flagged in ``theorem``, not refused."""
    from formsync_design.certify.agent import certify_agent, design_agent, region_agent
    from formsync_design.derive.agent import agent_conditions
    from formsync_design.gains import GainBox
    from formsync_design.graphs.theorem import check_theorem_graph

    theorem = check_theorem_graph(g, design.decl.graphs, allow_outside=True, design=design.name)
    out: dict[str, Any] = {"theorem": "inside" if theorem.inside else "outside: lacks " + "; ".join(
        f"{p}: {r}" for p, r in zip(theorem.missing, theorem.reasons))}
    conds = agent_conditions(design, g)
    box = GainBox.parse(list(bounds), schema.box)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # solver chatter; statuses are mapped explicitly
        cert = certify_agent(design, conds, GainBox.parse([(r, r) for r in ref], schema.box),
                             margin=margin)
        rm, _, _ = region_agent(design, conds, box, resolution=task["resolution"], margin=margin)
        des = design_agent(design, conds, box, grid=task["design_betas"])
    out.update(_formation_cells(design, g, ref, schema))
    out["ref_status"] = str(cert.status)
    out["ref_margin"] = cert.margin_lower_bound if cert.certified else None
    out["ref_refuted_by"] = cert.witness.family if cert.witness is not None else None
    if cert.certified:
        out.update({f"ref_cert_{m}": v for m, v in _chosen(cert.box, schema.multipliers).items()})
    out.update({f"frac_{k}": rm.fractions[k] for k in ("certified", "refuted", "undecided")})
    out["design_status"] = "designed" if des.status == "recommended" else des.status
    if des.status == "recommended":
        out.update({f"rec_{n}": des.gains[n] for n in schema.box})
        out.update({f"rec_cert_{m}": v for m, v in des.multipliers.items()})
        out["rec_margin"] = des.margin
        if des.box is not None:
            for n, (lo, hi) in zip(schema.box, des.box):
                out[f"cbox_{n}_lo"], out[f"cbox_{n}_hi"] = lo, hi
            out["cbox_half_width"] = des.scale
            out["cbox_status"] = None if des.box_result is None else str(des.box_result.status)
    return out


def _formation_cells(design: Any, g: Graph, ref: Sequence[Fraction],
                     schema: SweepSchema) -> dict[str, Any]:
    """The formation-level verdict at the reference gains (as ``formsync certify`` decides
    it: :func:`~formsync_design.certify.formation.certify_formation`)."""
    from formsync_design.certify.formation import certify_formation
    from formsync_design.gains import GainBox
    from formsync_design.graphs.digraph_io import make_digraph
    from formsync_design.verify.agentcase import formation_inertias

    dg = make_digraph(g)
    if design.decl.leader and not dg.has_leader:   # nobody pinned: the reference cannot be reached
        dg = make_digraph(dg, pinning=[0] * dg.n)
    J, _ = formation_inertias(design, dg.n)
    point = {n: v for n, v in zip(schema.box, ref) if n not in design.decl.multipliers}
    fixed = {x.name: x.range.lo for x in design.decl.gains
             if x.name not in point and x.role == "controller" and x.range is not None
             and x.range.lo == x.range.hi}
    r = certify_formation(design, dg, J, GainBox.parse({**{k: (v, v) for k, v in fixed.items()},
                                                        **{k: (v, v) for k, v in point.items()}}))
    return {"formation": str(r.status), "formation_decay": r.decay,
            "formation_unstable_re": None if r.witness is None else r.witness.eigenvalue.real}


def run_task(task: dict[str, Any]) -> dict[str, str]:
    """Compute one row of ``results.csv`` (a pure function of the payload).

    Examples
    --------
    >>> from formsync_design.sweep import campaign_from_dict, expand_graphs
    >>> c = campaign_from_dict({"campaign": {"name": "t", "graphs": ["ring:4"]},
    ...                         "region": {"resolution": 2}, "design": {"betas": 2}})
    >>> gs, _ = expand_graphs(c.graphs)
    >>> row = run_task(build_tasks(c, gs)[0])
    >>> row["task"], row["lambda_max"], row["ref_status"]
    ('ring:4@standard', '4', 'certified')
    """
    from formsync_design.certify.design import design_gains
    from formsync_design.certify.multipliers import certify_with_multipliers
    from formsync_design.certify.multiregion import region_with_multipliers
    from formsync_design.derive.conditions import derive_conditions, paper_conditions

    schema = SweepSchema.from_dict(task["schema"])
    columns = schema.columns
    g = Graph(task["n"], tuple(tuple(e) for e in task["edges"]), task["graph"])
    row: dict[str, Any] = {c: None for c in columns}
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
    for gname, (lo, hi), r in zip(schema.box, bounds, ref):
        row[f"box_{gname}_lo"], row[f"box_{gname}_hi"] = lo, hi
        row[f"ref_{gname}"] = r
    spec = _task_spec(task)
    if schema.agent:
        row.update(_agent_row(task, g, spec, schema, bounds, ref, margin))
        mc = task["montecarlo"]
        if mc is not None:
            rec = ([row[f"rec_{n}"] for n in schema.box] if row["design_status"] == "designed"
                   else None)
            row.update(_run_agent_mc(g, mc, spec, ref if mc["gains"] == "reference" else rec))
        return {c: fmt_cell(row[c]) for c in columns}
    conds = derive_conditions(g, spec) if task["conditions"] == "derived" else paper_conditions(g)
    box = {gname: b for gname, b in zip(schema.box, bounds)}
    mult = {m: spec.decl.gain(m).range for m in schema.multipliers}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # solver chatter; statuses are mapped explicitly
        cert = certify_with_multipliers(conds, dict(zip(schema.box, ref)), mult, margin=margin)
        rm = region_with_multipliers(conds, box, mult, resolution=task["resolution"], margin=margin)
        des = design_gains(conds, {**box, **mult}, betas=task["design_betas"],
                           penalty=task["design_penalty"], margin=margin, hold=schema.multipliers)
    row["ref_status"] = cert.status
    row["ref_margin"] = cert.margin_lower_bound if cert.certified else None
    row["ref_refuted_by"] = cert.witness.family if cert.witness is not None else None
    if cert.certified:
        for m, v in _chosen(cert.box, schema.multipliers).items():
            row[f"ref_cert_{m}"] = v
    row["frac_certified"] = rm.fractions["certified"]
    row["frac_refuted"] = rm.fractions["refuted"]
    row["frac_undecided"] = rm.fractions["undecided"]
    row["design_status"] = des.status
    rec = None
    if des.status == "designed":
        rec = [des.gains[gname] for gname in schema.box]
        for gname, v in zip(schema.box, rec):
            row[f"rec_{gname}"] = v
        for m in schema.multipliers:
            row[f"rec_cert_{m}"] = des.gains[m]
        row["rec_margin"] = des.margin
        if des.box is not None:
            for gname, (lo, hi) in zip(conds.gains, des.box):
                if gname in schema.box:
                    row[f"cbox_{gname}_lo"], row[f"cbox_{gname}_hi"] = lo, hi
            row["cbox_half_width"] = des.box_half_width
            row["cbox_status"] = des.box_result.status if des.box_result is not None else None
    mc = task["montecarlo"]
    if mc is not None:
        row.update(_run_mc(g, mc, schema, ref if mc["gains"] == "reference" else rec, spec))
    return {c: fmt_cell(row[c]) for c in columns}
