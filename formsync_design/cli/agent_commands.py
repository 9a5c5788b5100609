"""The agent-design paths of ``formsync simulate``, ``certify``, ``region``, ``design``,
``derive`` and ``montecarlo``.

Each of those subcommands hands an agent design (``FORM = "agent"``,
:mod:`formsync_design.spec.agent`) to the function here, after its own parser ran: the
options keep their meaning (``--graph``, ``--gain NAME=X|LO:HI``, ``--tf``, ``--switch``,
``--out``, ``--format json``, ``--allow-outside-theorem``, ...), and those that only make
sense for the Lagrangian designs (``--ko/--kq/--beta``, ``--trigger``, ``--certificate``,
``--conditions``, the ``K_v`` check) are refused with one line.

The case of a run: ``--case FILE`` (an agent case, :mod:`formsync_design.verify.agentcase`),
else the shipped case whose ``[case] design`` names the design, else the spacecraft,
disturbance and graph of the paper's case (``verification/liang2016.toml``) with the gains
from ``--gain`` (nothing is guessed: every controller gain needs a value).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

import numpy as np

from formsync_design.cli.agent_inputs import (
    agent_case_for,
    agent_options,
    formation_inputs,
    graph_and_box,
    refuse_lagrangian_options,
)
from formsync_design.cli.certify_text import format_result
from formsync_design.cli.options import (
    EXIT_NEGATIVE,
    EXIT_OK,
    check_out_dir,
    closing_lines,
    emit_json,
    parse_gain_assignments,
    parse_positive,
    with_design_code,
    write_summary_and_runs,
)
from formsync_design.errors import DerivationError, InputError
from formsync_design.outdir import (
    atomic_path,
    save_figure as save_atomic_figure,
    save_npz,
    write_text,
)

__all__ = [
    "run_agent_simulate",
    "run_agent_certify",
    "run_agent_derive",
    "run_agent_montecarlo_cli",
    "run_agent_region",
    "run_agent_design",
]


def run_agent_simulate(args: argparse.Namespace, design: Any) -> int:
    """``formsync simulate`` of an agent design (module docstring)."""
    from formsync_design.cli.defaults import agent_criterion, agent_graph
    from formsync_design.graphs.theorem import check_theorem_graph
    from formsync_design.sim.agents import simulate_agents
    from formsync_design.verify.defaults import Defaults

    refuse_lagrangian_options(args, ("trigger", "q_tol", "omega_tol"), design)
    out_dir = check_out_dir(args.out, overwrite=getattr(args, "overwrite", False))
    defaults = Defaults()
    case = agent_case_for(design, args.case, args.gain, defaults)
    case, graph = agent_graph(case, args.graph, defaults, design)
    theorem = check_theorem_graph(graph, design.decl.graphs,
                                  allow_outside=getattr(args, "allow_outside_theorem", False),
                                  design=design.name)
    opt = agent_options(args, case.options)
    if design.decl.sampling == "periodic" and opt.period is None:
        raise InputError(f"expected --sample-period T for the periodic design {design.name} (or "
                         "simulation.period in the case), received none")
    criterion, _ = agent_criterion(case, opt, args.disturbance
                                   or str(case.disturbance.get("model", "none")))
    defaults.add(f"criterion: {criterion}")
    f = case.formation(graph, disturbance=args.disturbance)
    if getattr(args, "no_compile", False):
        import os

        os.environ["FORMSYNC_NO_COMPILE"] = "1"
    r = simulate_agents(design, f, opt)
    doc = {**({"outside_theorem": theorem.to_dict()} if not theorem.inside else {}),
           "case": case.name, "case_file": case.path, "design": design.name,
           "design_source": design.source, "graph": graph.name,
           "gains": {k: (list(v) if isinstance(v, tuple) else v)
                     for k, v in f.gains.as_dict().items()},
           "disturbance": f.disturbance.kind if f.disturbance else "none",
           "assumptions": list(case.assumptions), "criterion": criterion,
           "defaults": list(defaults.lines), **r.to_dict()}
    written: list[str] = []
    if out_dir is not None:
        p = write_text(out_dir / "summary.json", json.dumps(with_design_code(doc), indent=2, allow_nan=False) + "\n")
        written.append(str(p))
        if args.export in ("npz", "both"):
            npz = out_dir / "trajectory.npz"
            save_npz(npz, t=r.t, quaternions=r.quaternions, rates=r.rates,
                                states=r.states, torques=r.torques,
                                reference=r.reference if r.reference is not None else np.zeros(0),
                                names=np.array(r.state_names))
            written.append(str(npz))
        if args.export in ("csv", "both"):
            csv = out_dir / "trajectory.csv"
            cols = [r.t[:, None], r.quaternions.reshape(len(r.t), -1), r.rates.reshape(len(r.t), -1),
                    r.torques.reshape(len(r.t), -1)]
            head = ["t", *[n for n in r.state_names[: 7 * f.n]],
                    *[f"u{c}_{i}" for i in range(1, f.n + 1) for c in (1, 2, 3)]]
            with atomic_path(csv) as tmp:
                np.savetxt(tmp, np.hstack(cols), delimiter=",", header=",".join(head), comments="")
            written.append(str(csv))
        if args.figures != "none":
            from formsync_design.sim.agent_figures import agent_figures
            from formsync_design.sim.figures import save_figure

            for name, fig in agent_figures(r, opt.angle_tol).items():
                written.append(str(save_figure(fig, out_dir / f"{name}.{args.figures}")))
    if args.format == "json":
        emit_json({**doc, "written": written})
    else:
        defaults.emit("simulate")
        print(("" if theorem.inside else theorem.note() + "\n") + _text(case, graph, f, opt, r,
                                                                         design, written))
    return EXIT_OK if str(r.status) == "converged" else EXIT_NEGATIVE


def _text(case: Any, graph: Any, f: Any, opt: Any, r: Any, design: Any, written: list[str]) -> str:
    sw = opt.switch if opt.switch == "sgn" else f"{opt.switch} (phi = {opt.phi:g})"
    lim = "unlimited torque" if opt.torque_limit is None else f"|u_k| <= {opt.torque_limit:g} N m"
    rule = design.decl.sampling + (f" (T = {opt.period:g} s)" if design.decl.sampling == "periodic"
                                   else "")
    kind = "directed" if not graph.is_undirected else "undirected"
    lines = [
        f"design {design.name} ({design.representation}): {design.title}",
        f"case {case.name}: {f.n} spacecraft, {kind} graph {graph.name}, tf = {opt.tf:g} s",
        f"  switch {sw}, {lim}, sampling {rule}, disturbance "
        f"{f.disturbance.kind if f.disturbance else 'none'}, integrator {r.integrator}",
    ]
    ct = r.convergence_time
    tol = f"attitude disagreement <= {opt.angle_tol:g} deg and rate error <= {opt.rate_tol:g} rad/s"
    if r.diverged_time is not None:  # the message is the finding itself
        lines.append(f"status: {r.status} - {r.message}")
    else:
        lines.append(f"status: {r.status} - " + (f"{tol} from t = {ct:.2f} s" if ct is not None
                                                 else f"{tol} not reached to the end"))
    if r.message and r.diverged_time is None:
        lines.append(f"  {r.message}")
    lines.append(f"final attitude disagreement {r.attitude_error[-1]:.3e} deg, rate error "
                 f"{r.rate_error[-1]:.3e} rad/s"
                 + (f", error to the reference {r.reference_error[-1]:.3e} deg"
                    if r.reference_error is not None else ""))
    lines.append("peak torque |u| per spacecraft (N m):     u1        u2        u3     effort")
    for i, row in enumerate(r.peak_torque):
        lines.append(f"  S/C{i + 1:<3d}{'':29s}{row[0]:9.4f} {row[1]:9.4f} {row[2]:9.4f}  "
                     f"{r.effort[i]:9.4g}")
    for name, vals in r.monitors.items():
        lines.append(f"monitor {name}: min {np.nanmin(vals):.6g}, max {np.nanmax(vals):.6g}")
    if r.transmissions is not None:
        lines.append("transmissions per spacecraft: " + ", ".join(str(int(k)) for k in r.transmissions))
        assert r.min_interevent is not None
        lines.append("shortest inter-event time per spacecraft (s): "
                     + ", ".join(f"{v:.3g}" for v in r.min_interevent))
    lines += closing_lines(case.assumptions, written)
    return "\n".join(lines)


def run_agent_certify(args: argparse.Namespace, design: Any) -> int:
    """``formsync certify`` of an agent design: the **formation-level** certificate on
    ``--graph`` (its exact linearisation at consensus, the disagreement decided over the
    ``--gain`` box: :func:`~formsync_design.certify.formation.certify_formation`) decides the
    exit status; the design's own ``conditions(c)`` families, when it has them, are decided
    too and reported with their own scope (multipliers searched over their declared ranges).
    With ``--allow-outside-theorem`` on a graph outside the design's theorem, conditions that
    do not apply to the graph (the hook refuses it) are reported as not applicable, with the
    hook's reason, and the formation certificate still decides."""
    from formsync_design.certify.agent import certify_agent
    from formsync_design.certify.formation import certify_formation, conditions_scope
    from formsync_design.cli.certify import certify_activity
    from formsync_design.derive.agent import agent_conditions
    from formsync_design.gains import GainBox, parse_number
    from formsync_design.graphs.theorem import check_theorem_graph
    from formsync_design.verify.defaults import Defaults

    refuse_lagrangian_options(args, ("ko", "kq", "beta", "ud", "kv", "case", "delay", "decay", "settle",
                   "torque_limit", "graphs_set"), design)
    if getattr(args, "certificate", "paper") != "paper" or getattr(args, "conditions",
                                                                  "derived") != "derived":
        raise InputError(f"expected no --certificate/--conditions for the agent design "
                         f"{design.name} (its certificates are the formation certificate and its "
                         "conditions(c) hook), received one")
    defaults = Defaults()
    graph, box = graph_and_box(design, args.graph, args.gain, defaults, free=0)
    theorem = check_theorem_graph(graph, design.decl.graphs,
                                  allow_outside=getattr(args, "allow_outside_theorem", False),
                                  design=design.name)
    g, inertias, note = formation_inputs(args, design, graph)
    note += "".join(f"; {ln}" for ln in defaults.lines if ln.startswith("pinning for --graph"))
    switch = getattr(args, "switch", None) or "sat"
    phi = getattr(args, "boundary_layer", None) or "1/100"
    if getattr(args, "boundary_layer", None) is not None:
        parse_positive(args.boundary_layer, "--boundary-layer")
    with certify_activity(g, args.format) as bar:
        bar.note("the formation certificate")
        ctrl = GainBox(tuple(r for r in box.ranges if r.name not in design.decl.multipliers))
        form = certify_formation(design, g, inertias, ctrl, switch=switch, phi=phi)
        evidence = None
        if str(form.status) == "undecided" and "not differentiable" in form.scope.covers:
            # no proof decides: a seeded falsification search in simulation, reported as evidence
            from formsync_design.verify.falsify import falsify_formation

            point = {r.name: (r.lo + r.hi) / 2 for r in ctrl.ranges}
            case = agent_case_for(design, None, [f"{k}={v}" for k, v in point.items()])
            evidence = falsify_formation(case, g, switch=getattr(args, "switch", None),
                                         phi=None if getattr(args, "boundary_layer", None) is None
                                         else float(parse_number(args.boundary_layer, "--boundary-layer")))
        res = None
        not_applicable = ""
        if callable(design.module.get("conditions")):
            try:
                conds = agent_conditions(design, graph)
            except (InputError, DerivationError) as e:
                if theorem.inside:  # inside the theorem the hook must apply: a real refusal
                    raise
                not_applicable = " ".join(str(e).split())
            else:
                bar.note("the design's conditions(c)")
                res = certify_agent(design, conds, box, margin=getattr(args, "margin", None) or 0)
    if args.format == "json":
        doc: dict[str, Any] = {**({"outside_theorem": theorem.to_dict()} if not theorem.inside
                                  else {}), "design": design.name, "status": str(form.status),
                               "formation": {**form.to_dict(), "inputs": note}}
        if evidence is not None:
            doc["falsification"] = evidence.to_dict()
        if res is not None:
            doc["design_conditions"] = {**res.to_dict(), "scope": conditions_scope(design).to_dict()}
        elif not_applicable:
            doc["design_conditions"] = {"status": "not applicable", "reason": not_applicable,
                                        "scope": conditions_scope(design).to_dict()}
        emit_json(doc)
    else:
        defaults.emit("certify")
        lines = [] if theorem.inside else [theorem.note()]
        lines += [form.text(), f"  inputs: {note}"]
        if evidence is not None:
            lines.append("  " + evidence.text().replace("\n", "\n  "))
        if res is not None:
            lines += ["", "design conditions (" + conditions_scope(design).text() + "):",
                      format_result(res)]
        elif not_applicable:
            lines += ["", "design conditions (" + conditions_scope(design).text() + "): not "
                      f"applicable on {graph.name!r}, outside the design's theorem ({not_applicable})"]
        print("\n".join(lines))
    return EXIT_OK if form.certified else EXIT_NEGATIVE


def run_agent_derive(args: argparse.Namespace, design: Any) -> int:
    """``formsync derive`` of an agent design: the derivation report (Markdown) of the design
    on ``--graph`` (default: its shipped case's graph, else ring:8), or its JSON summary."""
    from formsync_design.cli.defaults import agent_case, case_pinning
    from formsync_design.derive.agent_report import agent_derivation, write_agent_derivation_report
    from formsync_design.graphs.theorem import check_theorem_graph, load_graph
    from formsync_design.verify.defaults import Defaults

    refuse_lagrangian_options(args, ("ko", "kq", "beta"), design)
    if getattr(args, "gain", None):
        raise InputError(f"expected no --gain for the derivation of the agent design {design.name} "
                         "(its conditions are symbolic in the gains; certify a box with formsync "
                         "certify), received --gain")
    defaults = Defaults()
    if args.graph is not None:
        graph = case_pinning(design, agent_case(design, None, None, None), load_graph(args.graph),
                             defaults)
    else:
        case = agent_case(design, None, None, None)
        graph = case.graph() if case is not None else load_graph("ring:8")
        defaults.add(f"graph from the case {case.name}: {graph.name}" if case is not None
                     else "graph ring:8 (no shipped case names the design)")
    theorem = check_theorem_graph(graph, design.decl.graphs,
                                  allow_outside=getattr(args, "allow_outside_theorem", False),
                                  design=design.name)
    if not theorem.inside:
        sys.stderr.write(theorem.note() + "\n")
    deriv = agent_derivation(design, graph)
    if args.format == "json":
        emit_json(deriv.to_dict())
        return EXIT_OK
    out = args.out or "reports"
    cmd = f"formsync derive --design {args.spec or design.name}" + (
        f" --graph {args.graph}" if args.graph else "")
    if args.out:
        cmd += f" --out {args.out}"
    from formsync_design.outdir import claim

    claim(out)  # one writer per folder (a concurrent writer: exit 2)
    md = write_agent_derivation_report(deriv, out, command=cmd)
    defaults.emit("derive")
    print(f"wrote {md}")
    return EXIT_OK


def _montecarlo_integrator(args: argparse.Namespace, design: Any, opt: Any, defaults: Any) -> Any:
    """The Monte-Carlo integrator of an agent design: the compiled adaptive DOPRI5 at
    ``--rtol``/``--atol`` (the command's documented default) where ``auto`` chooses it
    (:func:`~formsync_design.sim.agents.resolve_auto`), ``--step H`` the fixed-step RK4;
    otherwise the case's integrator (said in the defaults)."""
    from dataclasses import replace

    from formsync_design.sim.agents import resolve_auto

    if args.step is not None:
        return replace(opt, integrator="rk4")
    if resolve_auto(design, switch=opt.switch) != "dopri5":
        defaults.add(f"integrator: the case's {opt.integrator} (dopri5 needs a continuous law "
                     "that does not switch under sgn, and a C compiler)")
        return opt
    defaults.add(f"integrator: dopri5 rtol {opt.rtol:g} atol {opt.atol:g} (the Monte-Carlo "
                 "default; --step H for rk4)")
    return replace(opt, integrator="dopri5")


def run_agent_montecarlo_cli(args: argparse.Namespace, design: Any) -> int:
    """``formsync montecarlo`` of an agent design: gains sampled from the ``--gain`` box (a
    gain not given: the case's value), random initial attitudes and rates from per-run seeds,
    ``--replay SEED`` re-simulates one run in full."""
    from dataclasses import replace

    from formsync_design.cli.options import design_box
    from formsync_design.gains import GainBox, GainRange, parse_number
    from formsync_design.graphs.theorem import check_theorem_graph
    from formsync_design.progress import Progress
    from formsync_design.sim.agent_montecarlo import agent_run_formation, run_agent_montecarlo
    from formsync_design.sim.agents import simulate_agents
    from formsync_design.sim.montecarlo_data import MonteCarloSettings

    refuse_lagrangian_options(args, ("ko", "kq", "beta", "kv", "q_tol", "omega_tol", "no_phases", "threads"), design)
    from formsync_design.cli.defaults import agent_criterion, agent_graph
    from formsync_design.verify.defaults import Defaults

    out_dir = check_out_dir(args.out, overwrite=getattr(args, "overwrite", False))
    defaults = Defaults()
    case = agent_case_for(design, args.case, None, defaults)
    case, graph = agent_graph(case, args.graph, defaults, design)
    theorem = check_theorem_graph(graph, design.decl.graphs,
                                  allow_outside=getattr(args, "allow_outside_theorem", False),
                                  design=design.name)
    named = parse_gain_assignments(args.gain)
    have = case.gains.as_dict()
    for n in design.decl.controller_gains:
        if n not in named:
            v = have[n]
            lo, hi = (min(v), max(v)) if isinstance(v, tuple) else (v, v)
            named[n] = f"{lo!r}:{hi!r}" if lo != hi else repr(lo)
    box = design_box(design, named)
    box = GainBox(tuple(r for r in box.ranges if r.name in design.decl.controller_gains))
    assert all(isinstance(r, GainRange) for r in box.ranges)
    settings = MonteCarloSettings(
        runs=int(args.runs), seed=int(args.seed),  # checked up front (cli.montecarlo.run)
        max_angle_deg=float(parse_number(args.max_angle, "--max-angle")),
        max_rate=float(parse_number(args.max_rate, "--max-rate"))).resolved_for("agent")
    opt = agent_options(args, case.options)
    criterion, dist = agent_criterion(case, opt, args.disturbance)
    defaults.add(f"criterion: {criterion}")
    base = case.formation(graph, disturbance=dist)
    if getattr(args, "no_compile", False):
        import os

        os.environ["FORMSYNC_NO_COMPILE"] = "1"
    opt = _montecarlo_integrator(args, design, opt, defaults)
    flag = {} if theorem.inside else {"outside_theorem": theorem.to_dict()}
    if args.replay is not None:
        seed = int(args.replay)
        f = agent_run_formation(design, base, box, settings, seed)
        r = simulate_agents(design, f, opt)
        doc = {**flag, "seed": seed, "gains": {k: (list(v) if isinstance(v, tuple) else v)
                                              for k, v in f.gains.as_dict().items()},
               **r.to_dict()}
        if args.format == "json":
            emit_json(doc)
        else:
            print(f"replay of run seed {seed}: status {r.status}, final attitude disagreement "
                  f"{r.attitude_error[-1]:.3e} deg" + (f" ({r.message})" if r.diverged_time is not None
                                                       else ""))
        return EXIT_OK if str(r.status) == "converged" else EXIT_NEGATIVE
    prog = Progress(settings.numbers()[0], "montecarlo", enabled=args.format == "text")
    res = run_agent_montecarlo(design, replace(base), box, settings, opt,
                               certify=not args.no_certify and theorem.inside,
                               progress=prog.update)
    doc = {**flag, "case": case.name, "criterion": criterion, "defaults": list(defaults.lines),
           **res.to_dict()}
    written: list[str] = []
    if out_dir is not None:
        written = write_summary_and_runs(out_dir, doc, [r.to_dict() for r in res.runs])
    if args.format == "json":
        emit_json({**doc, "written": written})
    else:
        lines = [f"design {design.name}: {settings.runs} runs on {graph.name}, box {box}, "
                 f"angles <= {settings.max_angle_deg:g} deg, rates <= {settings.max_rate:g} rad/s",
                 f"criterion: {criterion}",
                 f"converged: {doc['converged']}/{settings.runs}"
                 + (f", longest convergence time {doc['convergence_time_max']:.4g} s"
                    if doc["convergence_time_max"] is not None else "")]
        if doc["diverged"]:
            first = next(r for r in res.runs if r.diverged_time is not None)
            lines.append(f"diverged: {doc['diverged']} runs (non-finite state; seed {first.seed} "
                         f"diverged at t = {first.diverged_time:g} s)")
        if res.certificate is not None:
            lines.append(f"box certificate: {res.certificate}"
                         + (f" ({res.certificate_reason})" if res.certificate_reason else ""))
        if res.failures:
            lines.append("failed runs (replay with --replay SEED): "
                         + ", ".join(str(r.seed) for r in res.failures[:20])
                         + (" ..." if len(res.failures) > 20 else ""))
        if written:
            lines.append("written: " + ", ".join(written))
        if not theorem.inside:
            lines.insert(0, theorem.note())
        defaults.emit("montecarlo")
        print("\n".join(lines))
    return EXIT_OK if res.all_converged else EXIT_NEGATIVE


def run_agent_region(args: argparse.Namespace, design: Any) -> int:
    """``formsync region`` of an agent design: its ``conditions(c)`` families mapped over at
    most three gain ranges (the other gains fixed at their single ``--gain`` value,
    multipliers searched per cell), region.json and a slice figure per graph."""

    from formsync_design.certify.agent import agent_multipliers, region_agent
    from formsync_design.certify.formation import conditions_scope
    from formsync_design.certify.plots import plot_slices
    from formsync_design.certify.subdivision import map_to_dict
    from formsync_design.cli.defaults import (
        agent_case,
        case_pinning,
        default_out,
        refuse_uncertified,
    )
    from formsync_design.cli.options import to_json_value
    from formsync_design.derive.agent import agent_conditions
    from formsync_design.graphs.theorem import check_theorem_graph, load_graph
    from formsync_design.progress import Progress
    from formsync_design.verify.defaults import Defaults

    refused = refuse_uncertified("region", design)
    if refused is not None:
        return refused
    refuse_lagrangian_options(args, ("ko", "kq", "beta", "beta_slices", "kq_slices", "delay", "torque_limit",
                   "decay", "settle", "graphs_set", "inertia", "case"), design)
    if getattr(args, "certificate", "paper") != "paper" or getattr(args, "conditions",
                                                                  "derived") != "derived":
        raise InputError(f"expected no --certificate/--conditions for the agent design "
                         f"{design.name} (its certificate is its conditions(c) hook), received one")
    res = 32 if args.resolution is None else args.resolution
    if not 1 <= res <= 512:
        raise InputError(f"expected --resolution in 1..512, received {res}")
    defaults = Defaults()
    graph0, box = graph_and_box(design, args.graph[0] if args.graph else None, args.gain,
                                 defaults, free=2)
    mult = agent_multipliers(design, box)
    graphs = [graph0, *(case_pinning(design, agent_case(design, None, None, None), load_graph(g),
                                     defaults) for g in args.graph[1:])] if args.graph else [graph0]
    out = Path(args.out) if args.out else default_out("region", design, graph0.name)
    if not args.out:
        defaults.add(f"output folder {out} (give --out DIR for another)")
        check_out_dir(str(out), overwrite=args.overwrite, results=("region.json",))
    maps, notes = [], []
    prog = Progress(len(graphs), "region", enabled=not args.no_progress and args.format == "text")
    for gspec in graphs:
        g = gspec if not isinstance(gspec, str) else load_graph(gspec)
        theorem = check_theorem_graph(g, design.decl.graphs,
                                      allow_outside=args.allow_outside_theorem, design=design.name)
        if not theorem.inside:
            notes.append(theorem.note())
        m, red, rbox = region_agent(design, agent_conditions(design, g), box, resolution=res,
                                    margin=getattr(args, "margin", 0) or 0)
        maps.append((m, red))
        prog.update()
    red0 = maps[0][1]
    axes = [n for n in red0.gains if n not in mult]
    free = [n for n in axes if rbox[n][0] != rbox[n][1]] or axes
    plot_axes = (free + [n for n in axes if n not in free])[:2]
    fixed = next(n for n in red0.gains if n not in plot_axes)
    value = float(maps[0][0].ranges[red0.gains.index(fixed)][0])
    fig = plot_slices([m for m, _ in maps], axes=(plot_axes[0], plot_axes[1]), fixed=fixed,
                      values=[value])
    fig_path = out / f"{design.name}-region-{plot_axes[0]}-{plot_axes[1]}.png"
    save_atomic_figure(fig, fig_path, dpi=120, metadata={"Software": None})
    doc = {"design": design.name,
           "fixed": {n: str(v) for n, v in red0.fixed},
           "maps": [map_to_dict(m, timing=False) for m, _ in maps]}
    json_path = out / "region.json"
    write_text(json_path, json.dumps(to_json_value(doc), indent=1, allow_nan=False) + "\n")
    if args.format == "json":
        emit_json({"files": [str(json_path), str(fig_path)], "fixed": doc["fixed"],
                   "scope": conditions_scope(design).to_dict(),
                   "maps": [{"graph": m.graph, "fractions": m.fractions, "boxes": len(m.boxes)}
                            for m, _ in maps]})
    else:
        defaults.emit("region")
        print(f"scope: {conditions_scope(design).text()} (formsync certify decides the "
              "formation on the graph)")
        for note in notes:
            print(note)
        for m, r in maps:
            f = m.fractions
            fx = ", ".join(f"{n} = {float(v):g}" for n, v in r.fixed)
            print(f"{m.graph} ({design.name}): certified {f['certified']:.1%}, refuted "
                  f"{f['refuted']:.1%}, undecided {f['undecided']:.1%} of the box"
                  + (f" (fixed {fx})" if fx else ""))
        print(f"wrote {json_path}\nwrote {fig_path}")
    return EXIT_OK


def run_agent_design(args: argparse.Namespace, design: Any) -> int:
    """``formsync design`` of an agent design: the gain point of a ``--grid`` over the box with
    the largest certified margin of its ``conditions(c)`` families (multipliers searched, exact
    re-check), and the largest certified box around it."""
    from formsync_design.certify.agent import design_agent
    from formsync_design.certify.formation import certify_formation, conditions_scope
    from formsync_design.cli.defaults import refuse_uncertified
    from formsync_design.derive.agent import agent_conditions
    from formsync_design.gains import GainBox, json_number
    from formsync_design.graphs.theorem import check_theorem_graph
    from formsync_design.verify.defaults import Defaults

    refused = refuse_uncertified("design", design)
    if refused is not None:
        return refused
    refuse_lagrangian_options(args, ("ko", "kq", "beta", "min_delay", "graphs_set", "torque_limit", "inertia",
                   "case"), design)
    if getattr(args, "penalty", "0") not in ("0", 0, None):
        raise InputError(f"expected no --penalty for the agent design {design.name}, received one")
    defaults = Defaults()
    graph, box = graph_and_box(design, args.graph, args.gain, defaults, free=2)
    theorem = check_theorem_graph(graph, design.decl.graphs,
                                  allow_outside=args.allow_outside_theorem, design=design.name)
    k = int(args.grid)
    if k < 2:  # the grid's corners at least: never silently raised to 2
        raise InputError(f"expected --grid >= 2 for an agent design (the box's corners at "
                         f"least), received {k}")
    des = design_agent(design, agent_conditions(design, graph), box, grid=k)
    doc: dict[str, Any] = {"design": design.name, "graph": graph.name, "box": str(box),
                           "grid": k, "points": des.points}
    if not theorem.inside:
        doc["outside_theorem"] = theorem.to_dict()
    if des.status != "recommended":
        doc.update(status="not-found", reason="no grid point is certified")
        if args.format == "json":
            emit_json(doc)
        else:
            defaults.emit("design")
            print(f"NOT FOUND: no point of the {k}-per-axis grid over {box} is certified for "
                  f"{design.name} on {graph.name}")
        return EXIT_NEGATIVE
    assert des.margin is not None
    lb, point, chosen, cbox, s, cres = (des.margin, des.gains, des.multipliers, des.box, des.scale,
                                        des.box_result)
    doc.update(status="recommended", gains={n: json_number(v) for n, v in point.items()},
               multipliers={n: json_number(v) for n, v in chosen.items()},
               margin=json_number(lb), scale=json_number(s),
               certified_box=None if cbox is None else
               {n: [json_number(lo), json_number(hi)] for n, (lo, hi) in zip(box.names, cbox)},
               certified_box_status=None if cres is None else str(cres.status))
    # the recommended gains decided for the formation on the graph (the families above are
    # the design's own conditions)
    g, J, note = formation_inputs(args, design, graph)
    fixed = {x.name: x.range.lo for x in design.decl.gains if x.role == "controller"
             and x.name not in point and x.range is not None and x.range.lo == x.range.hi}
    form = certify_formation(design, g, J, GainBox.parse(
        {k: (v, v) for k, v in {**fixed, **{n: point[n] for n in point
                                            if n not in design.decl.multipliers}}.items()}))
    doc.update(scope=conditions_scope(design).to_dict(),
               formation={**form.to_dict(), "inputs": note})
    if args.format == "json":
        emit_json(doc)
    else:
        defaults.emit("design")
        if not theorem.inside:
            print(theorem.note())
        pts = ", ".join(f"{n} = {float(v):g}" for n, v in point.items())
        mm = ", ".join(f"{n} = {float(v):g}" for n, v in chosen.items())
        print(f"RECOMMENDED for {design.name} on {graph.name}: {pts}"
              + (f" (multiplier {mm})" if mm else "")
              + f", certified margin {float(lb):.6g} (best of a {k}-per-axis grid over {box})")
        if cbox is not None:
            bx = ", ".join(f"{n} in [{float(lo):g}, {float(hi):g}]"
                           for n, (lo, hi) in zip(box.names, cbox))
            print(f"largest certified box around it (+-{s:.3g} relative, "
                  f"{cres.status if cres else '-'}): {bx}")
        print(f"scope of the recommendation: {conditions_scope(design).text()}")
        print("at the recommended gains, " + form.text())
    return EXIT_OK if form.certified else EXIT_NEGATIVE
