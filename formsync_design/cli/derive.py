"""``formsync derive``: the symbolic derivation, as numbers or as a report."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from formsync_design.cli.choices import GRAPH_SPEC_HELP
from formsync_design.cli.options import (
    EXIT_OK,
    add_design_option,
    add_format_option,
    add_theorem_option,
    design_box,
    emit_json,
    parse_gain_assignments,
)
from formsync_design.errors import InputError

__all__ = ["add_parser", "run", "numeric_conditions"]

_HELP = """\
Derive the paper's closed loop and Lyapunov conditions symbolically.

Two modes:
  * with --ko/--kq/--beta: print Theta_i (every spacecraft) and Pi evaluated at
    those gains as numeric matrices (3-axis, i.e. per-axis matrix (x) I_3);
    zeta is ordered as in the paper's eq. (9): qdot_1..qdot_n, then
    s_1..s_n with s_i = sum_j (q_i - q_j), x,y,z within each;
  * otherwise: write the Markdown derivation report (with LaTeX) and a LaTeX
    fragment to --out (default: reports/). Each paper-versus-derivation verdict
    is decided in the same run by the computation printed beside it (symbolic
    identity, exact evaluation at a stated point, exact coefficient-by-coefficient
    comparison of the matrix families, or eigenvalues); --format json lists the
    verdicts with their computations.

examples:
  formsync derive                                  # report for the default ring:8
  formsync derive --graph star:8 --out /tmp/rep    # report for another topology
  formsync derive --graph ring:8 --ko 1.6 --kq 0.4 --beta 0.3 --format json
  formsync derive --graph edges.txt --spec my_candidate.py --out out/
"""


def add_parser(sub: Any) -> None:
    p = sub.add_parser(
        "derive", help="derive the closed loop, V', Theta_i and Pi (report or numbers)",
        description=_HELP, formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--graph", default=None,
                   help=f"communication graph: {GRAPH_SPEC_HELP} (default: ring:8, "
                        "an assumption: the paper's Fig. 2 topology was lost)")
    add_design_option(p)
    add_theorem_option(p)
    p.add_argument("--ko", help="K_o (a single value) for numeric output (liang2016)")
    p.add_argument("--kq", help="K_q (a single value) for numeric output (liang2016)")
    p.add_argument("--beta", help="beta (a single value) for numeric output (liang2016)")
    p.add_argument("--gain", action="append", default=None, metavar="NAME=X",
                   help="a gain of the design (a single value) for numeric output; repeat")
    p.add_argument("--out", default=None, help="directory for the report (default: reports)")
    add_format_option(p)
    p.set_defaults(func=run)


def _labels3(labels: tuple[str, ...]) -> list[str]:
    return [f"{lab}.{ax}" for lab in labels for ax in "xyz"]


def numeric_conditions(conds: Any, point: tuple[float, ...]) -> dict:
    """Theta_i and Pi at a gain point as full 3-axis matrices with labels."""
    import numpy as np

    thetas = []
    for fam in conds.theta:
        F = fam.evaluate(point)
        thetas.append({
            "spacecraft": fam.spacecraft,
            "chi_order": _labels3(fam.row_labels),
            "matrix": np.kron(F, np.eye(3)).tolist(),
            "lambda_min": float(np.linalg.eigvalsh(F)[0]),
        })
    P = conds.pi.evaluate(point)
    return {
        "theta": thetas,
        "pi": {
            "zeta_order": _labels3(conds.pi.row_labels),
            "matrix": np.kron(P, np.eye(3)).tolist(),
            "lambda_min": float(np.linalg.eigvalsh(P)[0]),
        },
    }


def run(args: argparse.Namespace) -> int:
    import numpy as np

    from formsync_design.cli.agent_commands import run_agent_derive
    from formsync_design.cli.agent_inputs import agent_design_or_none
    from formsync_design.cli.certify import default_graph
    from formsync_design.cli.options import design_graph
    from formsync_design.derive.conditions import derive_conditions
    from formsync_design.derive.report import DEFAULT_GRAPH, write_derivation_report
    from formsync_design.spec.loader import load_spec
    from formsync_design.verify.defaults import Defaults, is_tracking

    agent = agent_design_or_none(args.spec)
    if is_tracking(agent):
        return _derive_tracking(args, agent)
    if agent is not None:
        return run_agent_derive(args, agent)
    spec = load_spec(args.spec)
    if args.graph is None and args.spec is not None:
        defaults = Defaults()
        args.graph = default_graph(None, spec, defaults)
        if args.format == "text":
            defaults.emit("derive")
    graph, theorem = design_graph(args.graph or DEFAULT_GRAPH, spec, args.allow_outside_theorem)
    if not theorem.inside:
        sys.stderr.write(theorem.note() + "\n")
    gains = [args.ko, args.kq, args.beta]
    named = parse_gain_assignments(getattr(args, "gain", None))
    if any(x is not None for x in gains) or named:
        if any(x is not None for x in gains) and any(x is None for x in gains):
            raise InputError(
                "expected all of --ko, --kq, --beta for numeric output, received only "
                + ", ".join(n for n, x in zip(("--ko", "--kq", "--beta"), gains) if x is not None)
            )
        legacy = dict(zip(("K_o", "K_q", "beta"), gains))
        missing = [n for n in spec.gains if n not in named and legacy.get(n) is None]
        if missing:
            raise InputError(f"expected a value for every gain of design {spec.name} "
                             f"({', '.join(spec.gains)}) for numeric output, missing {missing}")
        rng = design_box(spec, named, legacy).ranges
        if any(not r.is_point for r in rng):
            raise InputError("expected single values for the gains here "
                             "(ranges belong to `formsync certify`), received a range")
        point = tuple(float(r.lo) for r in rng)
        conds = derive_conditions(graph, spec)
        num = numeric_conditions(conds, point)
        doc = {
            "graph": graph.name, "n": graph.n, "edges": graph.edge_list_1based(),
            "specification": spec.name, "gains": dict(zip(spec.gains, point)),
            "zeta_order_note": "zeta = (qdot_1..qdot_n, s_1..s_n), s_i = sum_{j in G_i}(q_i - q_j), "
                               "x,y,z within each (paper eq. 9)",
            **num,
        }
        if args.out is None:
            if args.format == "json":
                emit_json(doc)
            else:
                w = sys.stdout.write
                w(f"graph {graph.name} ({graph.n} spacecraft), gains "
                  + " ".join(f"{n}={v:g}" for n, v in zip(spec.gains, point)) + "\n")
                w(f"zeta order: {', '.join(num['pi']['zeta_order'])}\n\n")
                for t in num["theta"]:
                    w(f"Theta_{t['spacecraft']}  (chi = {', '.join(t['chi_order'])}), "
                      f"lambda_min = {t['lambda_min']:.6g}\n")
                    w(np.array2string(np.array(t["matrix"]), precision=4, max_line_width=200) + "\n")
                w(f"\nPi, lambda_min = {num['pi']['lambda_min']:.6g}\n")
                w(np.array2string(np.array(num["pi"]["matrix"]), precision=4,
                                  max_line_width=400, threshold=100000) + "\n")
            return EXIT_OK
    from formsync_design.outdir import claim

    claim(args.out or "reports")  # one writer per folder (a concurrent writer: exit 2)
    rep = write_derivation_report(
        graph, args.out or "reports", spec,
        command="formsync derive" + (f" --graph {graph.name}" if args.graph else "")
        + (f" --design {args.spec}" if args.spec else "")
        + (f" --out {args.out}" if args.out else ""),
    )
    if args.format == "json":
        emit_json({"markdown": str(rep.markdown), "latex": str(rep.latex),
                   "brute_force_checked": rep.brute_force_checked,
                   "findings": [f.to_dict() for f in rep.findings]})
    else:
        sys.stdout.write(f"wrote {rep.markdown}\nwrote {rep.latex}\n")
        for f in rep.findings:
            sys.stdout.write(f"  {f.verdict:10s} {f.key:17s} (decided by {f.computation.kind})\n")
    return EXIT_OK


def _derive_tracking(args: argparse.Namespace, spec: Any) -> int:
    """``formsync derive`` of a design on the relative-orbit plant: ``V'`` of its attitude loop
    derived along the closed loop (:func:`~formsync_design.derive.tracking.derive_tracking_attitude`),
    with and without the inertia mismatch; no graph."""
    from formsync_design.cli.options import EXIT_NEGATIVE
    from formsync_design.derive.tracking import derive_tracking_attitude

    if args.graph is not None or getattr(args, "gain", None) or any(
            getattr(args, f, None) is not None for f in ("ko", "kq", "beta")):
        raise InputError(f"expected no --graph/--gain for the relative-orbit design {spec.name} "
                         "(one spacecraft, its derivation is symbolic in the gains), received one")
    d = derive_tracking_attitude(spec)
    if args.format == "json":
        emit_json({"design": spec.name, "plant": spec.decl.plant, **d.to_dict()})
        return EXIT_OK
    print(f"design {spec.name} (relative-orbit plant, one spacecraft, no graph): attitude loop "
          "derived")
    print(f"  V' along the closed loop (J_hat = J): {d.vdot}")
    print(f"  the design's claim V' = {d.claim}: {'holds' if d.nominal_holds else 'FAILS'}")
    print(f"  with an inertia mismatch dJ = J_hat - J: V' - claim = {d.mismatch_form} "
          f"({'derived' if d.mismatch_matches else 'does NOT match the derivation'})")
    return EXIT_OK if d.nominal_holds else EXIT_NEGATIVE
