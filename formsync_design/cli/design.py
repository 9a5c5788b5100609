"""``formsync design``: recommend gains with the largest certified margin."""

from __future__ import annotations

import argparse
from typing import Any

from formsync_design.cli.options import EXIT_NEGATIVE, EXIT_OK, add_format_option, emit_json

__all__ = ["add_parser", "run"]

_DESC = """\
Recommend gains (K_o, K_q, beta) within your ranges.  For each beta on a grid
the matrices are affine in (K_o, K_q), so maximizing the smallest eigenvalue
t of every Theta_i and Pi (minus PENALTY * (K_o/K_o_max + K_q/K_q_max), to
prefer small gains) is a semidefinite program (cvxpy + Clarabel).  The best
point is rounded to a short decimal, certified with the same rigorous re-check
as 'formsync certify', and the largest certified box g*(1 +- s) around it is
reported.

Exit status: 0 gains recommended and certified, 1 none found, 2 bad input.

examples:
  formsync design --graph ring:8 --ko 0.05:5 --kq 0.05:5 --beta 0.01:1
  formsync design --graph star:8 --ko 0.1:3 --kq 0.1:3 --beta 0.01:0.5 --penalty 0.1 --betas 21
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
    p.add_argument("--betas", type=int, default=11, metavar="N",
                   help="number of beta values swept over the beta range (default 11)")
    p.add_argument("--penalty", default="0", metavar="RHO",
                   help="weight on normalized gain size K_o/K_o_max + K_q/K_q_max (default 0)")
    add_format_option(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from formsync_design.certify.design import design_gains
    from formsync_design.cli.certify import gain_box_from_args, load_conditions, parse_margin
    from formsync_design.errors import InputError
    from formsync_design.gains import parse_number

    box = gain_box_from_args(args)
    margin = parse_margin(args.margin)
    pen = parse_number(args.penalty, "penalty")
    if pen < 0:
        raise InputError(f"expected a non-negative penalty, received {args.penalty!r}")
    if not 1 <= args.betas <= 1000:
        raise InputError(f"expected --betas in 1..1000, received {args.betas}")
    conds = load_conditions(args.graph, args.conditions, args.spec)
    d = design_gains(conds, box, betas=args.betas, penalty=float(pen), margin=margin)
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
        print("  beta sweep (SDP hints):")
        for s in d.sweep:
            tt = "-" if s.t is None else f"{s.t:.5g}"
            ko = "-" if s.K_o is None else f"{s.K_o:.4g}"
            kq = "-" if s.K_q is None else f"{s.K_q:.4g}"
            print(f"    beta={float(s.beta):<8.4g} {s.outcome:<10} margin={tt:<10} K_o={ko:<8} K_q={kq}")
    return EXIT_OK if d.status == "designed" else EXIT_NEGATIVE
