"""``formsync design``: recommend gains with the largest certified margin."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from formsync_design.cli.options import (
    EXIT_NEGATIVE,
    EXIT_OK,
    add_format_option,
    add_trust_option,
    emit_json,
    whole_number,
)

__all__ = ["add_parser", "run"]

_DESC = """\
Recommend gains (K_o, K_q, beta) within your ranges.  For each beta on a grid
the matrices are affine in (K_o, K_q), so maximizing the smallest eigenvalue
t of every Theta_i and Pi (minus PENALTY * (K_o/K_o_max + K_q/K_q_max), to
prefer small gains) is a semidefinite program (cvxpy + Clarabel).  The best
point is rounded to a short decimal, certified with the same rigorous re-check
as 'formsync certify', and the largest certified box g*(1 +- s) around it is
reported.

With --min-delay TAU, --graphs-set SET and/or --torque-limit U the design
maximises instead the certified decay rate (searched quadratic V, exact
re-check) over a grid of --grid^dim candidate points (any design, in its own
gains), keeping only points whose searched certificate holds, whose
processing-delay margin is >= TAU, (with --graphs-set) that have one Lyapunov
function common to the graph set and (with --torque-limit) whose certified peak
torque from --att0/--rate0 is <= U; it reports the largest box g (1 +- s) around
the winner on which every certificate still holds for every gain of the box (the
delay margin and the torque bound are proven over the whole box).

Exit status: 0 gains recommended and certified, 1 none found, 2 bad input.

examples:
  formsync design --graph ring:8 --ko 0.05:5 --kq 0.05:5 --beta 0.01:1
  formsync design --graph star:8 --ko 0.1:3 --kq 0.1:3 --beta 0.01:0.5 --penalty 0.1 --betas 21
  formsync design --graph ring:6 --ko 1:3 --kq 0.2:1 --beta 0.1:0.3 --min-delay 0.5 --graphs-set minus:1
  formsync design --design pd_consensus --graph ring:8 --gain k_p=0.1:1 --gain k_d=0.5:3 \\
      --torque-limit 40 --inertia J.txt --att0 0.05 --min-delay 0.5
"""


def add_parser(sub: Any) -> None:
    p = sub.add_parser(
        "design",
        help="recommend gains maximizing the certified margin (SDP per beta)",
        description=_DESC,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    from formsync_design.cli.certify import add_gain_options

    add_gain_options(p)
    p.add_argument("--betas", type=whole_number, default=11, metavar="N",
                   help="number of beta values swept over the beta range (default 11)")
    p.add_argument("--penalty", default="0", metavar="RHO",
                   help="weight on normalized gain size K_o/K_o_max + K_q/K_q_max (default 0)")
    p.add_argument("--min-delay", default=None, metavar="TAU",
                   help="require a processing-delay margin >= TAU s (constrained design)")
    p.add_argument("--graphs-set", default=None, metavar="minus:K|G1,G2,...",
                   help="require one Lyapunov function common to a graph set (constrained design)")
    p.add_argument("--torque-limit", default=None, metavar="U",
                   help="require a certified peak torque <= U N m from the initial set --att0/--rate0 "
                   "(constrained design; needs --inertia or --case)")
    p.add_argument("--inertia", default=None, metavar="FILE",
                   help="inertias for --torque-limit: text/CSV, 3 rows per spacecraft (or 3 rows for all)")
    p.add_argument("--case", default=None, metavar="FILE", help="TOML case file: inertias for --torque-limit")
    p.add_argument("--att0", default="0.1", metavar="R", help="initial set |q_i(0)| <= R (default 0.1)")
    p.add_argument("--rate0", default="0.01", metavar="W", help="initial set |omega_i(0)| <= W rad/s "
                   "(default 0.01)")
    p.add_argument("--grid", type=whole_number, default=4, metavar="K",
                   help="candidates per gain axis of the constrained design (default 4, max 16)")
    add_format_option(p)
    add_trust_option(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from formsync_design.certify.design import design_gains
    from formsync_design.cli.agent_commands import run_agent_design
    from formsync_design.cli.agent_inputs import agent_design_or_none
    from formsync_design.cli.certify import (
        default_graph,
        gain_box_from_args,
        load_conditions,
        parse_margin,
    )
    from formsync_design.cli.defaults import lagrangian_range_gains, refuse_tracking
    from formsync_design.cli.options import design_graph
    from formsync_design.errors import InputError
    from formsync_design.gains import GainBox, parse_number
    from formsync_design.spec.loader import load_spec
    from formsync_design.verify.defaults import Defaults

    if not 1 <= args.grid <= 16:  # every path, before anything runs (never clipped)
        raise InputError(f"expected --grid in 1..16, received {args.grid}")
    agent = agent_design_or_none(args.spec)
    refused = refuse_tracking("design", agent, "a gain design on a communication graph")
    if refused is not None:
        return refused
    if agent is not None:
        return run_agent_design(args, agent)
    spec = load_spec(args.spec)
    defaults = Defaults()
    args.graph = default_graph(args.graph, spec, defaults)
    lagrangian_range_gains(args, spec, defaults)
    if args.format == "text":
        defaults.emit("design")
    _, theorem = design_graph(args.graph, spec, args.allow_outside_theorem)
    if not theorem.inside:
        sys.stderr.write(theorem.note() + "\n")
    box = gain_box_from_args(args, spec)
    hold = tuple(n for n in spec.decl.multipliers if n not in box)
    if hold:  # a multiplier not given: swept over its declared range, held in the box
        rs = {r.name: r for r in box}
        for n in hold:
            r = spec.decl.gain(n).range
            assert r is not None  # a multiplier declares its range (checked at load)
            rs[n] = r
        box = GainBox(tuple(rs[n] for n in spec.gains))
    margin = parse_margin(args.margin)
    pen = parse_number(args.penalty, "--penalty")
    if pen < 0:
        raise InputError(f"expected a non-negative penalty (--penalty), received {args.penalty!r}")
    if not 1 <= args.betas <= 1000:
        raise InputError(f"expected --betas in 1..1000, received {args.betas}")
    if args.min_delay is not None or args.graphs_set is not None or args.torque_limit is not None:
        return _run_constrained(args, spec, gain_box_from_args(args, spec))
    conds = load_conditions(args.graph, args.conditions, args.spec)
    d = design_gains(conds, box, betas=args.betas, penalty=float(pen), margin=margin, hold=hold)
    g0, g1, g2 = conds.gains
    if args.format == "json":
        emit_json(d.to_dict())
    else:
        print(f"{d.status.upper()}: {conds.graph.name} (N={conds.graph.n}), {conds.source} conditions")
        if d.reason:
            print(f"  reason: {d.reason}")
        if d.gains:
            print("  recommended: " + ", ".join(f"{k}={float(v):g}" for k, v in d.gains.items()))
        if d.margin is not None:
            print(f"  certified margin: lambda_min >= {float(d.margin):.6g}")
        if d.box is not None:
            print(f"  largest certified box (relative half-width {d.box_half_width:.3g}): "
                  + ", ".join(f"{k} in [{float(lo):.4g}, {float(hi):.4g}]"
                              for k, (lo, hi) in zip(conds.gains, d.box)))
        print(f"  {g2} sweep (SDP hints):")
        for s in d.sweep:
            tt = "-" if s.t is None else f"{s.t:.5g}"
            ko = "-" if s.K_o is None else f"{s.K_o:.4g}"
            kq = "-" if s.K_q is None else f"{s.K_q:.4g}"
            print(f"    {g2}={float(s.beta):<8.4g} {s.outcome:<10} margin={tt:<10} {g0}={ko:<8} "
                  f"{g1}={kq}")
    return EXIT_OK if d.status == "designed" else EXIT_NEGATIVE


def _run_constrained(args: argparse.Namespace, spec: Any, box: Any) -> int:
    from formsync_design.analysis.design import design_with_constraints
    from formsync_design.analysis.requirements import parse_graph_set
    from formsync_design.errors import InputError
    from formsync_design.gains import parse_number

    if args.conditions != "derived":
        raise InputError("expected --conditions derived with --min-delay/--graphs-set, received "
                         f"--conditions {args.conditions}")
    tau = 0.0
    if args.min_delay is not None:
        tau = float(parse_number(args.min_delay, "--min-delay"))
        if tau < 0:
            raise InputError(f"expected a non-negative --min-delay, received {args.min_delay!r}")
    gs, label = (None, "")
    if args.graphs_set is not None:
        gs, label = parse_graph_set(args.graphs_set, args.graph)
    given = [n for n in spec.decl.multipliers if n in box.names]
    if given:
        raise InputError(f"expected no multiplier ({', '.join(given)}) in a constrained design (it uses the "
                         f"searched certificate), received {', '.join(given)}")
    torque: dict[str, Any] = {}
    if args.torque_limit is not None:
        from formsync_design.cli.certify import requirements_from_args

        ns = argparse.Namespace(**{**vars(args), "decay": None, "settle": None, "x0_radius": "1",
                                   "accuracy": "1", "delay": None, "graphs_set": None})
        r = requirements_from_args(ns, args.graph)
        if r.inertias is None:
            raise InputError("expected inertias (--inertia or --case) with --torque-limit, received none")
        torque = {"torque_limit": r.torque_limit, "inertias": r.inertias, "att_radius": r.att_radius,
                  "rate_radius": r.rate_radius}
    d = design_with_constraints(args.graph, box, min_delay=tau, graph_set=gs, resolution=args.grid,
                                spec=spec, **torque)
    if args.format == "json":
        emit_json({**d.to_dict(), "min_delay_s": tau, "graphs_set": label or None})
    else:
        print(f"{str(d.status).upper()}: {d.graph}, constrained design (searched certificate"
              + (f", delay margin >= {tau:g} s" if args.min_delay is not None else "")
              + (f", common V over {label}" if label else "")
              + (f", peak torque <= {float(args.torque_limit):g} N m" if torque else "") + ")")
        print(f"  {d.reason}")
        if d.gains is not None:
            print("  recommended: " + ", ".join(f"{k}={float(v):g}" for k, v in zip(d.names, d.gains)))
            print(f"  certified decay rate: alpha >= {float(d.alpha):.6g} 1/s; processing-delay margin "
                  f"{d.delay_margin:.6g} s")
        if d.box is not None:
            print("  largest certified box: " + ", ".join(
                f"{r.name} in [{float(r.lo):.4g}, {float(r.hi):.4g}]" for r in d.box)
                  + ("" if d.torque_bound is None else
                     f"; certified peak torque <= {d.torque_bound:.6g} N m for every gain of it"))
    return EXIT_OK if d.status == "certified" else EXIT_NEGATIVE
