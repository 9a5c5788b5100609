"""Tasks of a sweep: one payload per graph x box, and the pure function computing its row."""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from fractions import Fraction
from pathlib import Path
from typing import Any

from formsync_design.graphs.build import Graph
from formsync_design.sweep.campaign import Campaign, case_text
from formsync_design.sweep.graphsets import GraphEntry
from formsync_design.sweep.schema import COLUMNS, GAINS, fmt_cell, rational_text

__all__ = ["build_tasks", "run_task"]


def build_tasks(
    campaign: Campaign, graphs: Sequence[GraphEntry], spec: Any = None
) -> list[dict[str, Any]]:
    """One payload per graph x box (plain data: picklable, executor-independent).

    ``spec`` (a ``Spec`` or a path; default the campaign's, else the paper's) is
    carried as its file path (``None`` for the paper's), or as the ``Spec`` value
    itself when it was built in Python (Dask pickles it by value).
    """
    from formsync_design.sweep.campaign import resolve_spec

    sp = resolve_spec(campaign, spec)
    if spec is None and campaign.spec_path is None:
        spec_payload: Any = None
    elif getattr(sp, "source", sp.path) == "<python>":
        spec_payload = sp
    else:
        spec_payload = str(Path(sp.path).resolve())
    common = {
        "spec": spec_payload,
        "conditions": campaign.conditions,
        "margin": rational_text(campaign.margin),
        "reference": [rational_text(v) for v in campaign.reference],
        "resolution": campaign.resolution,
        "design_betas": campaign.design_betas,
        "design_penalty": campaign.design_penalty,
        "montecarlo": None,
    }
    if campaign.montecarlo is not None:
        path, text = case_text(campaign.montecarlo)
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
                "bounds": [[rational_text(lo), rational_text(hi)] for lo, hi in b.bounds],
                **common,
            })
    return tasks


def _mc_formation(graph: Graph, mc: dict, gains: Sequence[Fraction]) -> Any:
    import numpy as np

    from formsync_design.sim.simulator import Formation, Gains
    from formsync_design.tomlio import parse_toml
    from formsync_design.verify.case import make_disturbance, parse_case

    case = parse_case(parse_toml(mc["case_text"], mc["case_path"]), mc["case_path"])
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


def _task_spec(task: dict[str, Any]) -> Any:
    from formsync_design.spec.loader import Spec, load_spec

    sp = task.get("spec")
    return sp if isinstance(sp, Spec) else load_spec(sp)


def _run_mc(graph: Graph, mc: dict, gains: Sequence[Fraction] | None,
            spec: Any = None) -> dict[str, Any]:
    from formsync_design.gains import GainBox
    from formsync_design.sim.montecarlo import MonteCarloSettings, run_montecarlo
    from formsync_design.sim.simulator import SimOptions

    out: dict[str, Any] = {"mc_gains": mc["gains"]}
    if gains is None:
        out["mc_status"] = "skipped (no recommended gains)"
        return out
    base, kv = _mc_formation(graph, mc, gains)
    box = GainBox.parse({**dict(zip(GAINS, gains)), "K_v": kv}, positive=GAINS)
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
    spec = _task_spec(task)
    conds = derive_conditions(g, spec) if task["conditions"] == "derived" else paper_conditions(g)
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
        row.update(_run_mc(g, mc, ref if mc["gains"] == "reference" else rec, spec))
    return {c: fmt_cell(row[c]) for c in COLUMNS}

