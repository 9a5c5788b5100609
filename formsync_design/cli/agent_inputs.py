"""The inputs of an agent design's ``formsync`` command (``FORM = "agent"``): which design a
command is asked for, its case (the ``--case`` file, the design's shipped case, or the
paper's spacecraft with the design's gains), its options, the formation a certificate is
about (digraph and inertias) and the graph and gain box of a certificate.

Every controller gain needs a value (``--gain``, the case's, or the middle of its declared
range when no shipped case names the design; said on stderr): nothing is guessed.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import numpy as np

from formsync_design.cli.certify_inputs import read_inertias
from formsync_design.cli.options import design_gains, parse_gain_assignments
from formsync_design.errors import InputError

__all__ = [
    "agent_design_or_none",
    "agent_case_for",
    "refuse_lagrangian_options",
    "agent_options",
    "formation_inputs",
    "graph_and_box",
]


def agent_design_or_none(design_arg: Any, case_arg: Any = None) -> Any:
    """The agent design a command is asked for (``--design``, else the ``--case`` file's
    ``[case] design``), or ``None`` for a Lagrangian design (the command's own path)."""
    from formsync_design.spec.loader import agent_design_of, load_design

    if design_arg is not None:  # a design with a Lagrangian view: the command's own path
        return agent_design_of(design_arg)
    if case_arg is None:
        return None
    from formsync_design.verify.agentcase import (  # the verify stage only here
        case_design_ref,
        case_is_agent,
    )

    ref = case_design_ref(_case_path(case_arg))
    if ref is None:
        return None
    path = _case_path(case_arg)
    from formsync_design.spec.trust import resolve_design_ref

    try:
        d = load_design(resolve_design_ref(ref, path, "case.design"))
    except InputError:
        return None  # the command's own case loader reports a bad reference
    return d if getattr(d, "form", None) == "agent" and case_is_agent(path) else None


def _case_path(case_arg: Any) -> Path:
    p = Path(str(case_arg))
    if p.suffix != ".toml" and not p.exists():
        from formsync_design.resources import case_file, case_names

        if str(case_arg) in case_names():
            return case_file(str(case_arg))
    return p


def agent_case_for(design: Any, case_arg: Any, gains: Any, defaults: Any = None) -> Any:
    """The :class:`~formsync_design.verify.agentcase.AgentCase` of a run (module docstring),
    with ``--gain`` values over the case's; the defaults taken are said in ``defaults``
    (:class:`~formsync_design.verify.defaults.Defaults`)."""
    from dataclasses import replace

    from formsync_design.cli.defaults import agent_case
    from formsync_design.verify.agentcase import load_agent_case, parse_agent_case

    if case_arg is not None:
        case = load_agent_case(_case_path(case_arg), design=design)
    else:
        case = agent_case(design, None, gains, defaults)
        if case is None:
            case = _paper_spacecraft_case(design, gains, parse_agent_case, defaults)
    if gains:
        case = replace(case, gains=design_gains(design, case.gains, gains))
    return case


def _paper_spacecraft_case(design: Any, gains: Any, parse: Any, defaults: Any = None) -> Any:
    from formsync_design.cli.defaults import gains_text
    from formsync_design.gains import parse_number
    from formsync_design.verify.case import load_case

    if design.decl.leader:
        raise InputError(f"expected --case FILE with a [reference] for design {design.name} (it "
                         "declares a leader; no shipped case names it), received none")
    named = parse_gain_assignments(gains)
    vals: dict[str, float] = {}
    mid: dict[str, float] = {}
    for n in design.decl.controller_gains:
        if n in named:
            vals[n] = float(parse_number(str(named[n]), n))
            continue
        r = design.decl.gain(n).range
        if r is None:
            raise InputError(f"expected --gain {n}=X for design {design.name} (no shipped case "
                             "names it and it declares no range for the gain), or --case FILE")
        vals[n] = mid[n] = float((r.lo + r.hi) / 2)
    paper = load_case()
    if defaults is not None:
        defaults.add(f"case from verification/{Path(paper.path).name} (no shipped case names "
                     f"design {design.name}: the paper's spacecraft, disturbance and graph)")
        if mid:
            defaults.add("gains at the middle of their declared ranges: " + gains_text(mid))
    doc = {
        "case": {"name": f"{design.name}-on-{paper.name}", "graph": paper.graph_spec,
                 "assumptions": [f"spacecraft, disturbance and graph of the {paper.name} case"]},
        "gains": vals,
        "disturbance": dict(paper.disturbance),
        "orbit": {"altitude_km": paper.orbit.altitude / 1e3},
        "spacecraft": [{"inertia": paper.inertias[i].tolist(), "rate": paper.rates[i].tolist(),
                        "quaternion": paper.attitudes[i].tolist()} for i in range(paper.n)],
    }
    return parse(doc, paper.path, design=design)


def refuse_lagrangian_options(args: argparse.Namespace, names: tuple[str, ...], design: Any) -> None:
    for name in names:
        v = getattr(args, name, None)
        if v not in (None, False, [], "paper", "derived", "npz", "png"):
            flag = "--" + name.replace("_", "-")
            raise InputError(f"expected no {flag} for the agent design {design.name} (it applies "
                             f"to the Lagrangian designs), received {flag} {v}")


def _positive_flag(text: Any, flag: str) -> float:
    from formsync_design.gains import parse_number

    x = float(parse_number(text, flag))
    if not x > 0:
        raise InputError(f"expected a positive {flag}, received {text}")
    return x


def agent_options(args: argparse.Namespace, base: Any) -> Any:
    from dataclasses import replace

    from formsync_design.gains import parse_number

    kw: dict[str, Any] = {}
    for attr, name in (("tf", "tf"), ("boundary_layer", "phi"), ("step", "step"),
                       ("output_step", "output_step"), ("rtol", "rtol"), ("atol", "atol"),
                       ("angle_tol", "angle_tol"), ("rate_tol", "rate_tol")):
        v = getattr(args, attr, None)
        if v is not None:
            flag = "--" + attr.replace("_", "-")
            x = float(parse_number(v, flag))
            if not x > 0:  # named by the flag, not by the option's field (phi)
                raise InputError(f"expected a positive {flag}, received {v}")
            kw[name] = x
    tl = getattr(args, "torque_limit", None)
    if tl is not None:
        kw["torque_limit"] = None if str(tl).lower() == "none" else _positive_flag(tl, "--torque-limit")
    sp_ = getattr(args, "sample_period", None)
    if sp_ is not None:
        kw["period"] = None if str(sp_).lower() == "none" else _positive_flag(sp_, "--sample-period")
    if getattr(args, "switch", None) is not None:
        kw["switch"] = args.switch
    if getattr(args, "integrator", None) is not None:
        # auto with --step is the fixed step (the flag's documented meaning)
        kw["integrator"] = ("rk4" if args.integrator == "auto" and getattr(args, "step", None)
                            is not None else args.integrator)
    return replace(base, **kw)


def formation_inputs(args: argparse.Namespace, design: Any, graph: Any) -> tuple[Any, Any, str]:
    """The digraph, the inertias and a note saying where they came from, for the formation
    certificate of ``design`` on ``graph`` (``--inertia FILE``, else the shipped case that
    simulates the design, its spacecraft cycled ``i mod n`` to the graph's size)."""
    from formsync_design.graphs.digraph_io import make_digraph
    from formsync_design.verify.agentcase import (
        formation_case_path,
        formation_inertias,
        load_agent_case,
    )

    g = make_digraph(graph)
    if getattr(args, "inertia", None):
        return g, np.array(read_inertias(args.inertia, g.n)), f"inertias from {args.inertia}"
    J, note = formation_inertias(design, g.n)
    path = formation_case_path(design)
    if design.decl.leader and not g.has_leader and path is not None:
        case = load_agent_case(path)
        if case.n == g.n:
            g = make_digraph(g, pinning=case.graph().pinning)
    return g, J, note


def graph_and_box(design: Any, graph_arg: Any, gains: Any, defaults: Any, *,
                   free: int) -> tuple[Any, Any]:
    """The graph (``graph_arg``, else the design's case's) and the gain box (``--gain``, the
    case's values for the gains not given, ``free`` of them over their declared ranges) of
    an agent certificate, the defaults said in ``defaults``; a leader design's ``graph_arg``
    without pinning gains takes its case's pinning rule
    (:func:`~formsync_design.cli.defaults.case_pinning`)."""
    from formsync_design.cli.defaults import agent_box, agent_case, case_pinning
    from formsync_design.graphs.theorem import load_graph

    named = parse_gain_assignments(gains)
    needs_case = graph_arg is None or any(n not in named for n in design.decl.controller_gains)
    case = agent_case_for(design, None, None, defaults if graph_arg is None else None) \
        if needs_case else None
    if graph_arg is None:
        assert case is not None
        graph = case.graph()
        defaults.add(f"graph from the case {case.name}: {graph.name} ({graph.n} spacecraft)")
    else:  # a leader design keeps the case's pinning rule on --graph (said in defaults)
        graph = case_pinning(design, case if case is not None else agent_case(design, None, None, None),
                             load_graph(graph_arg), defaults)
    return graph, agent_box(design, gains, case, defaults, free=free)
