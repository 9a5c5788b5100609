"""``formsync region``: map certified / refuted / undecided gain boxes."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from formsync_design.cli.certify import CERTIFICATE_HELP
from formsync_design.cli.options import (
    EXIT_OK,
    add_format_option,
    add_trust_option,
    emit_json,
    whole_number,
)
from formsync_design.errors import InputError
from formsync_design.outdir import save_figure as save_atomic_figure, write_text
from formsync_design.progress import Progress

__all__ = ["add_parser", "run"]

_SEVERITY = {"certified": 0, "undecided": 1, "refuted": 2, "error": 3}

_DESC_FMT = """\
Subdivide a gain box adaptively into boxes that are certified (every gain in
the box satisfies Theta_i > 0 and Pi > 0, proven), refuted (every gain in the
box violates them: one exactly checked vector x refutes the whole box) or
undecided (boxes of the finest size 1/R of each range straddling the
boundary).  Writes DIR/region.json (boxes, classes, volume fractions) and
figures: K_o-K_q slices at chosen beta, beta-K_o slices at chosen K_q, and a
3-D view.  Repeat --graph to compare topologies on one figure; with
--conditions both the paper's printed conditions are outlined over the
derived ones.  Dashed lines: closed-form boundaries from the derivation.

A range with LO == HI makes that axis a slice (2-D map).

With --certificate exact|searched|spectral or a requirement (--decay, --settle,
--graphs-set, --delay, --torque-limit) every cell of an R x R x R grid (R x R for a
two-gain design such as pd_consensus; 1 cell along a point axis) is decided by that
certificate and the requirements, for any design; DIR/region.json lists the
cells and the certified / refuted / undecided volume fractions (the certified
fraction is a rigorous lower bound of the admissible volume).  Default R = 8
there.  --delay TAU decides every gain of each cell by the proven monotonicity of
the exact delay margin (processing: worst at K_o lo, K_q hi; transmission on a
regular graph: delay-independent where K_o^2 >= 2 K_q d; otherwise undecided).
--torque-limit U decides every gain of each cell with the certified peak-torque bound
valid over the whole cell (from --att0/--rate0, inertias from --inertia or --case):
certified within U, refuted when a state of the initial set already needs more than U
at t = 0 at a gain of the cell, undecided in between.

%s
examples:
  formsync region --graph ring:8 --ko 0.05:5 --kq 0.05:5 --beta 0.01:1 --out out/ring8
  formsync region --graph ring:8 --graph star:8 --ko 0.05:5 --kq 0.05:5 --beta 0.01:1 \\
      --resolution 32 --conditions both --beta-slices 0.1,0.3 --out out/compare
  formsync region --graph star:8 --ko 0.5:4 --kq 0.1:2 --beta 0.05:0.5 --certificate searched \\
      --decay 0.02 --resolution 4 --out out/star8
  formsync region --design pd_consensus --graph star:8 --gain k_p=0.01:2 --gain k_d=0.01:2 \\
      --out out/pd        # another design: its gains, its multipliers searched per cell
  formsync region --graph ring:8 --ko 0.5:3 --kq 0.1:1 --beta 0.3 --certificate spectral \\
      --torque-limit 40 --inertia J.txt --att0 0.05 --out out/torque
  formsync region --design pd_consensus --graph star:8 --gain k_p=0.1:2 --gain k_d=0.5:3 \\
      --certificate searched --decay 0.1 --delay 0.5 --out out/pd-req
"""


def _values(text: str | None, name: str) -> list[float]:
    from formsync_design.gains import parse_gain_range

    if not text:
        return []
    out = []
    for part in text.split(","):
        out.append(float(parse_gain_range(part, name).lo))
    return out


def add_parser(sub: Any) -> None:
    p = sub.add_parser(
        "region",
        help="map certified/refuted/undecided gain boxes (adaptive subdivision, figures)",
        description=_DESC_FMT.replace("%s\n", CERTIFICATE_HELP),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    from formsync_design.cli.certify import add_certificate_options, add_gain_options

    add_gain_options(p, ranges=True)
    p.set_defaults(conditions="derived")
    for a in p._actions:
        if a.dest == "conditions":
            a.metavar = "derived|paper|both"
            a.help = ("matrices: 'derived' (default), 'paper' (printed), or 'both' (derived map, "
                      "paper's certified region outlined)")
    p.add_argument("--resolution", type=whole_number, default=None, metavar="R",
                   help="finest box = 1/R of each range (default 32, max 512; with --certificate "
                   "other than paper or a requirement: R^3 cells, default 8, max 64)")
    p.add_argument("--out", default=None, metavar="DIR",
                   help="output directory (default out/region-<design>-<graph> under the "
                   "working directory)")
    p.add_argument("--overwrite", action="store_true",
                   help="replace the region.json of an earlier run in --out (refused without it)")
    p.add_argument("--beta-slices", default=None, metavar="B1,B2,...",
                   help="beta values of the K_o-K_q slices (default: 10%%, 30%%, 60%% of the range)")
    p.add_argument("--kq-slices", default=None, metavar="K1,K2,...",
                   help="K_q values of the beta-K_o slices (default: 10%%, 30%%, 60%% of the range)")
    p.add_argument("--no-progress", action="store_true", help="no progress line on stderr")
    add_certificate_options(p, point_options=False)
    p.add_argument("--delay", default=None, metavar="TAU",
                   help="require a delay margin > TAU s for every gain of a cell (proven monotonicity)")
    p.add_argument("--delay-model", default="processing", choices=("processing", "transmission"),
                   help="processing: both terms of s_i late; transmission: neighbours' states late; "
                   "default processing")
    p.add_argument("--torque-limit", default=None, metavar="U",
                   help="require a certified peak torque |u_i(t)|_2 <= U N m for every gain of a cell (needs "
                   "--inertia or --case)")
    p.add_argument("--inertia", default=None, metavar="FILE",
                   help="inertias for --torque-limit: text/CSV, 3 rows per spacecraft (or 3 rows for all)")
    p.add_argument("--case", default=None, metavar="FILE", help="TOML case file: inertias for --torque-limit")
    p.add_argument("--att0", default="0.1", metavar="R", help="initial set |q_i(0)| <= R (default 0.1)")
    p.add_argument("--rate0", default="0.01", metavar="W",
                   help="initial set |omega_i(0)| <= W rad/s (default 0.01)")
    add_format_option(p)
    add_trust_option(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from formsync_design.certify.plots import write_region
    from formsync_design.certify.region import region_map
    from formsync_design.cli.agent_commands import run_agent_region
    from formsync_design.cli.agent_inputs import agent_design_or_none
    from formsync_design.cli.certify import (
        default_graph,
        gain_box_from_args,
        load_conditions,
        parse_margin,
        requirements_from_args,
    )
    from formsync_design.cli.defaults import default_out, lagrangian_range_gains, refuse_tracking
    from formsync_design.cli.options import check_out_dir, design_graph
    from formsync_design.spec.loader import load_spec
    from formsync_design.verify.defaults import Defaults

    check_out_dir(args.out, overwrite=args.overwrite, results=("region.json",))
    agent = agent_design_or_none(args.spec)
    refused = refuse_tracking("region", agent, "a region map of gains on a communication graph")
    if refused is not None:
        return refused
    if agent is not None:
        return run_agent_region(args, agent)
    spec = load_spec(args.spec)
    defaults = Defaults()
    if args.graph is None:
        args.graph = [default_graph(None, spec, defaults)]
    if args.out is None:
        args.out = str(default_out("region", spec, args.graph[0]))
        defaults.add(f"output folder {args.out} (give --out DIR for another)")
        check_out_dir(args.out, overwrite=args.overwrite, results=("region.json",))
    lagrangian_range_gains(args, spec, defaults)
    if args.format == "text":
        defaults.emit("region")
    for gspec in args.graph:  # the design's graph class (a note on stderr when outside it)
        _, theorem = design_graph(gspec, spec, args.allow_outside_theorem)
        if not theorem.inside:
            sys.stderr.write(theorem.note() + "\n")
    box = gain_box_from_args(args, spec)
    margin = parse_margin(args.margin)
    req = requirements_from_args(args, args.graph[0])
    if args.torque_limit is None and (args.inertia or args.case):
        raise InputError("expected --inertia/--case only with --torque-limit, received them without it")
    if args.certificate != "paper" or req.any():
        return _run_cells(args, spec, box, margin, req)
    if tuple(spec.gains) != ("K_o", "K_q", "beta"):
        return _run_design(args, spec, box, margin, req)
    if args.resolution is None:
        args.resolution = 32
    if args.conditions not in ("derived", "paper", "both"):
        raise InputError(f"expected --conditions derived, paper or both, received {args.conditions!r}")
    if not 1 <= args.resolution <= 512:
        raise InputError(f"expected --resolution in 1..512, received {args.resolution}")
    bvals = _values(args.beta_slices, "beta slice")
    kvals = _values(args.kq_slices, "K_q slice")
    for v in bvals:
        if not box["beta"].lo <= v <= box["beta"].hi:
            raise InputError(f"expected beta slices within {box['beta']}, received {v:g}")
    for v in kvals:
        if not box["K_q"].lo <= v <= box["K_q"].hi:
            raise InputError(f"expected K_q slices within {box['K_q']}, received {v:g}")
    which = "derived" if args.conditions == "both" else args.conditions
    conds = [load_conditions(g, which, args.spec) for g in args.graph]
    over = [load_conditions(g, "paper") for g in args.graph] if args.conditions == "both" else None
    cells = 1
    for gr in box:
        cells *= 1 if gr.is_point else args.resolution
    nmaps = len(conds) * (2 if over else 1)
    prog = Progress(cells * nmaps, "region", enabled=not args.no_progress and args.format == "text")
    maps = [region_map(c, box, resolution=args.resolution, margin=margin, progress=prog.update)
            for c in conds]
    omaps = ([region_map(c, box, resolution=args.resolution, margin=margin, progress=prog.update)
              for c in over] if over else None)
    paths = write_region(args.out, maps, overlay=omaps, conditions=conds,
                         beta_values=bvals, kq_values=kvals)
    if args.format == "json":
        emit_json({
            "files": [str(p) for p in paths],
            "maps": [
                {"graph": m.graph, "conditions": m.source, "fractions": m.fractions,
                 "boxes": len(m.boxes), "vertices_evaluated": m.vertices_evaluated,
                 "elapsed_s": m.elapsed}
                for m in maps + (omaps or [])
            ],
        })
    else:
        _print_maps(maps + (omaps or []), paths)
    return EXIT_OK


def _print_maps(maps: list[Any], paths: Any) -> None:
    for m in maps:
        f = m.fractions
        print(f"{m.graph} ({m.source}): certified {f['certified']:.1%}, refuted "
              f"{f['refuted']:.1%}, undecided {f['undecided']:.1%} of the box "
              f"({len(m.boxes)} boxes, {m.vertices_evaluated} vertices, {m.elapsed:.2f} s)")
    for p in paths:
        print(f"wrote {p}")


def _run_design(args: argparse.Namespace, spec: Any, box: Any, margin: Any, req: Any) -> int:
    """The region of a design other than liang2016: its own box gains, multipliers searched
    per cell (:func:`~formsync_design.certify.multiregion.region_with_multipliers`)."""
    import json
    from pathlib import Path

    from formsync_design.certify.multiregion import region_with_multipliers
    from formsync_design.certify.plots import plot_slices
    from formsync_design.certify.subdivision import map_to_dict
    from formsync_design.cli.options import to_json_value
    from formsync_design.derive.conditions import derive_conditions
    from formsync_design.graphs import make_graph

    if args.conditions != "derived":
        raise InputError(f"expected --conditions derived for design {spec.name} (printed "
                         f"conditions are liang2016's), received --conditions {args.conditions}")
    if args.beta_slices or args.kq_slices:
        raise InputError(f"expected no --beta-slices/--kq-slices for design {spec.name} (its gains "
                         f"are {', '.join(spec.gains)}), received them")
    res = 32 if args.resolution is None else args.resolution
    if not 1 <= res <= 512:
        raise InputError(f"expected --resolution in 1..512, received {res}")
    if len(spec.gains) != 3:
        raise InputError(f"expected a design with three box dimensions for a region map, "
                         f"received {spec.name} with {', '.join(spec.gains)}")
    mult = {n: r for n in spec.decl.multipliers
            if n not in box and (r := spec.decl.gain(n).range) is not None}
    out = Path(args.out)
    prog = Progress(len(args.graph), "region", enabled=not args.no_progress and args.format == "text")
    maps = []
    for gspec in args.graph:
        conds = derive_conditions(make_graph(gspec), spec)
        maps.append(region_with_multipliers(conds, box, mult, resolution=res, margin=margin))
        prog.update()
    ctrl = [n for n in spec.gains if n not in mult]
    fixed = next(n for n in spec.gains if n not in ctrl[:2])
    fa = spec.gains.index(fixed)
    value = float(maps[0].ranges[fa][0])
    fig = plot_slices(maps, axes=(ctrl[0], ctrl[1]), fixed=fixed, values=[value])
    if mult:
        for ax, m in zip(fig.axes, maps):
            ax.set_title(f"{m.graph}: {fixed} searched per cell", fontsize=9)
    stem = f"{spec.name}-region"
    fig_path = out / f"{stem}-{ctrl[0]}-{ctrl[1]}.png"
    save_atomic_figure(fig, fig_path, dpi=120, metadata={"Software": None})
    json_path = out / "region.json"
    doc = {"design": spec.name, "maps": [map_to_dict(m, timing=False) for m in maps]}
    write_text(json_path, json.dumps(to_json_value(doc), indent=1, allow_nan=False) + "\n")
    paths = [json_path, fig_path]
    if args.format == "json":
        emit_json({"files": [str(p) for p in paths],
                   "maps": [{"graph": m.graph, "conditions": m.source, "fractions": m.fractions,
                             "boxes": len(m.boxes), "vertices_evaluated": m.vertices_evaluated}
                            for m in maps]})
    else:
        _print_maps(maps, paths)
    return EXIT_OK


def _run_cells(args: argparse.Namespace, spec: Any, box: Any, margin: Any, req: Any) -> int:
    """The grid of cells decided by one certificate and the requirements (any design)."""
    import dataclasses
    import itertools
    import json
    from fractions import Fraction
    from pathlib import Path

    from formsync_design.analysis.celldelay import delay_cell_check
    from formsync_design.analysis.modecheck import split_box
    from formsync_design.analysis.modes import mode_model
    from formsync_design.analysis.requirements import certify_requirements
    from formsync_design.analysis.results import Verdict
    from formsync_design.analysis.spectrum import laplacian_spectrum
    from formsync_design.cli.certify import requirements_from_args
    from formsync_design.gains import GainBox
    from formsync_design.graphs import make_graph

    res = 8 if args.resolution is None else args.resolution
    if not 1 <= res <= 64:
        raise InputError(f"expected --resolution in 1..64 with --certificate or a requirement, received {res}")
    if args.conditions != "derived":
        raise InputError("expected --conditions derived with --certificate or a requirement option, "
                         f"received --conditions {args.conditions}")
    if args.certificate != "paper" and margin != 0:
        raise InputError(f"expected --margin only with --certificate paper, received --margin {args.margin}")
    if args.beta_slices or args.kq_slices:
        raise InputError("expected no --beta-slices/--kq-slices with --certificate or a requirement option "
                         "(the cells are written to region.json), received them")
    mm = mode_model(spec)
    ctrl, given = split_box(mm, box)
    fixed = list(given.ranges) if given is not None else []
    axes = []
    for gr in ctrl:
        k = 1 if gr.is_point else res
        axes.append([(gr.lo + (gr.hi - gr.lo) * Fraction(i, k), gr.lo + (gr.hi - gr.lo) * Fraction(i + 1, k))
                     for i in range(k)])
    ncell = 1
    for ax in axes:
        ncell *= len(ax)
    prog = Progress(ncell * len(args.graph), "region", enabled=not args.no_progress and args.format == "text")
    out_maps = []
    for gspec in args.graph:
        g = make_graph(gspec)
        sp_ = laplacian_spectrum(g)
        greq = requirements_from_args(args, g) if req.graph_set is not None else req
        nreq = dataclasses.replace(greq, delay=None)  # the delay is decided per cell below
        cells, counts = [], {"certified": 0, "refuted": 0, "undecided": 0, "error": 0}
        for combo in itertools.product(*axes):
            cell = GainBox((*(GainBox.parse({gr.name: c}, (gr.name,)).ranges[0] for gr, c in zip(ctrl, combo)),
                            *fixed))
            r = certify_requirements(g, cell, args.certificate, nreq, spec=spec, margin=margin,
                                     spectrum=sp_, use_sdp=False)
            status, checks = r.status, list(r.checks)
            if greq.delay is not None and r.base.status is not Verdict.ERROR:
                dc = delay_cell_check(g, cell, greq.delay, greq.delay_model, spec=spec)
                checks.append(dc)
                status = max([status, dc.status], key=lambda v: _SEVERITY[v])
            counts[str(status)] += 1
            cells.append({"box": cell.to_dict(), "status": str(status),
                          "certificate": str(r.base.status),
                          "requirements": {ch.name: str(ch.status) for ch in checks}})
            prog.update(1)
        out_maps.append({"graph": g.name, "certificate": args.certificate,
                         "requirements": _req_dict(greq), "resolution": res, "cells": len(cells),
                         "fractions": {k: Fraction(v, len(cells)) for k, v in counts.items()},
                         "boxes": cells})
    out = Path(args.out)
    path = out / "region.json"
    from formsync_design.cli.options import to_json_value

    doc = {"design": spec.name, "box": box.to_dict(), "maps": out_maps}
    write_text(path, json.dumps(to_json_value(doc), indent=1) + "\n")
    if args.format == "json":
        emit_json({"files": [str(path)], "maps": [{k: v for k, v in m.items() if k != "boxes"}
                                                  for m in out_maps]})
    else:
        for m in out_maps:
            f = m["fractions"]
            print(f"{m['graph']} ({m['certificate']} certificate"
                  + (", " + ", ".join(m["requirements"]) if m["requirements"] else "") + "): "
                  f"certified {float(f['certified']):.1%}, refuted {float(f['refuted']):.1%}, undecided "
                  f"{float(f['undecided']):.1%} of the box ({m['cells']} cells)")
        print(f"wrote {path}")
    return EXIT_OK


def _req_dict(req: Any) -> dict[str, Any]:
    d: dict[str, Any] = {}
    if req.decay is not None:
        d["decay"] = req.decay
    if req.settle is not None:
        d.update(settle=req.settle, x0_radius=req.x0_radius, accuracy=req.accuracy)
    if req.graph_set is not None:
        d["graphs_set"] = req.graph_set_label
    if req.delay is not None:
        d.update(delay=req.delay, delay_model=str(req.delay_model))
    if req.torque_limit is not None:
        d.update(torque_limit=req.torque_limit, att0=req.att_radius, rate0=req.rate_radius)
    return d
