"""``formsync certify``: prove a gain box admissible for a graph, or refute it."""

from __future__ import annotations

import argparse
import sys
from fractions import Fraction
from typing import TYPE_CHECKING, Any

from formsync_design.cli.certify_inputs import read_case, read_inertias
from formsync_design.cli.certify_text import format_requirement_result, format_result
from formsync_design.cli.choices import GRAPH_SPEC_HELP
from formsync_design.cli.options import (
    EXIT_NEGATIVE,
    EXIT_OK,
    add_design_option,
    add_format_option,
    add_theorem_option,
    add_trust_option,
    design_box,
    design_graph,
    emit_json,
)
from formsync_design.errors import InputError

if TYPE_CHECKING:

    from formsync_design.gains import GainBox

__all__ = ["add_parser", "run", "load_conditions", "certify_design", "require_classic", "add_gain_options",
           "gain_box_from_args", "add_certificate_options", "requirements_from_args",
           "CERTIFICATE_HELP", "certify_activity"]

#: One line per certificate (``--help``).
CERTIFICATE_HELP = """\
certificates (--certificate, most to least conservative; each proves the whole box; any design,
in its own gains, through its derived closed loop q'' = c_qd q' + c_s s + c_sigma sigma):
  paper     the paper's per-spacecraft test: every Theta_i > 0 and Pi > 0 (default)
  exact     the design's own V on the whole graph: V > 0 and V' <= 0 per Laplacian mode
            (a multiplier of V not given, e.g. pd_consensus's eps, is chosen from its declared range)
  searched  the best quadratic V keeping the switching structure, common over the box
            (vertex LMIs, exact re-check; when none exists, an exact dual refutation of the class);
            a design without a switching term: every quadratic V per mode
  spectral  the nominal linear loop is stable (Routh-Hurwitz per Laplacian mode): the outer bound
requirements (restrict the admissible gains; each certified, refuted or undecided):
  --decay ALPHA          V' <= -2 ALPHA V on the whole box (certified rate >= ALPHA)
  --settle T             |x(t)| <= --accuracy for t >= T from every |x(0)| <= --x0-radius
  --delay TAU            delay margin > TAU at a gain point (--delay-model processing|transmission)
  --graphs-set SET       one Lyapunov function common to the graphs of SET (minus:K or G1,G2,...),
                         or with --min-dwell T a certified dwell time <= T s (gain points)
  --torque-limit U       certified |u_i(t)| <= U N m from every |q_i(0)| <= --att0, |omega_i(0)| <= --rate0
                         for every gain of the box (inertias from --inertia or --case); refuted when a
                         state of that set already needs more at t = 0

"""

_DESC = """\
Decide whether Theta_i > 0 for every spacecraft and Pi > 0 (the Lyapunov
conditions of the paper's Theorem 1, derived from the controller) hold for
EVERY gain in a box, not just sampled points.

Each gain is a value X or a closed range LO:HI: K_o (1/s), K_q (1/s^2),
beta (1/s), as in q_i'' = -K_o q_i' - K_q s_i - ...  Because every matrix is
multi-affine in the gains, the box is covered by its 8 vertices.  A cvxpy +
Clarabel SDP gives a hint; the verdict comes from an independent re-check in
exact rational or rigorously rounded arithmetic (a failed or inaccurate solve
never vetoes it; exact ties such as K_o = beta lambda_max(L) are decided
exactly).  A refutation prints a gain point, the matrix, the spacecraft and an
integer vector x with x^T M x <= 0, checked exactly.  Only a certified box
prints a certified margin.

Optional switching-gain check: with --ud (disturbance bound per axis, N m),
inertia data (--inertia or --case) and --kv, also checks
K_vi >= (ubar/2) max_v ||J_i^{-1} v||_2 for every spacecraft.

Exit status: 0 certified, 1 refuted or undecided (or an unknown solver status
with an inconclusive re-check), 2 bad input, 3 a failure that is not the input's.

""" + CERTIFICATE_HELP + """

examples:
  formsync certify --graph ring:8 --ko 1.6 --kq 0.4 --beta 0.3
  formsync certify --graph ring:8 --ko 1.3:2 --kq 0.2:1 --beta 0.1:0.3 --margin 0.01
  formsync certify --graph star:8 --ko 1.6 --kq 0.4 --beta 0.3 --format json
  formsync certify --graph ring:8 --ko 1.6 --kq 0.4 --beta 0.3 --conditions paper
  formsync certify --graph ring:4 --ko 1.6 --kq 0.4 --beta 0.3 --ud 0.5 --inertia J.txt --kv 0.01
  formsync certify --graph star:8 --ko 1.6 --kq 0.4 --beta 0.3 --certificate spectral
  formsync certify --graph ring:8 --ko 1.6 --kq 0.4 --beta 0.3 --certificate exact --decay 0.05 \\
      --settle 120 --delay 0.5 --graphs-set minus:1
  formsync certify --design pd_consensus --graph star:8 --gain k_p=0.1:2 --gain k_d=0.5:3
      (another design: its own gains; its multiplier eps searched, the certifying value reported)
  formsync certify --design pd_consensus --graph star:8 --gain k_p=0.4 --gain k_d=1.6 \
      --certificate searched --decay 0.1 --delay 0.5 --graphs-set minus:1
"""


def add_gain_options(p: argparse.ArgumentParser, *, ranges: bool = False) -> None:
    """--graph, --ko, --kq, --beta, --conditions, --spec."""
    form = "LO:HI" if ranges else "X|LO:HI"
    p.add_argument("--graph", default=None, action="append" if ranges else "store",
                   metavar="SPEC", help=f"communication graph: {GRAPH_SPEC_HELP}"
                   + (" (repeat to compare graphs)" if ranges else "")
                   + "; default: the graph of the design's shipped case")
    p.add_argument("--ko", default=None, metavar=form,
                   help="K_o, rate-damping gain (> 0) of liang2016 (same as --gain K_o=...)")
    p.add_argument("--kq", default=None, metavar=form,
                   help="K_q, coupling gain (> 0) of liang2016 (same as --gain K_q=...)")
    p.add_argument("--beta", default=None, metavar=form,
                   help="beta, sliding-variable weight (> 0) of liang2016 (same as --gain beta=...)")
    p.add_argument("--gain", action="append", default=None, metavar=f"NAME={form}",
                   help="a gain of the design by name (repeat); a gain not given takes the design's "
                   "declared default range; a multiplier not given is searched (see 'formsync derive "
                   "--design NAME')")
    p.add_argument("--margin", default="0", metavar="EPS",
                   help="require lambda_min > EPS for every matrix (default 0: positive definite)")
    p.add_argument("--conditions", default="derived", metavar="derived|paper",
                   help="matrices to check: 'derived' from the controller (default) or 'paper' "
                   "as printed in Liang et al. 2016")
    add_design_option(p)
    add_theorem_option(p)


def add_certificate_options(p: argparse.ArgumentParser, *, point_options: bool = True) -> None:
    """--certificate and the requirement options (--decay, --settle, --delay, --graphs-set)."""
    p.add_argument("--certificate", default="paper", choices=("paper", "exact", "searched", "spectral"),
                   help="which certificate decides the box (default paper; see 'certificates' above)")
    p.add_argument("--decay", default=None, metavar="ALPHA",
                   help="require a certified exponential decay rate >= ALPHA (1/s)")
    p.add_argument("--settle", default=None, metavar="T",
                   help="require |x(t)| <= --accuracy for t >= T s from every |x(0)| <= --x0-radius")
    p.add_argument("--x0-radius", default="0.5", metavar="R",
                   help="initial disagreement bound |x(0)| (mode coordinates of q and q'), default 0.5")
    p.add_argument("--accuracy", default="0.01", metavar="EPS",
                   help="accuracy |x| <= EPS that --settle asks for (default 0.01)")
    if point_options:
        p.add_argument("--delay", default=None, metavar="TAU",
                       help="require a delay margin > TAU s (neighbour data TAU s late; gain points only)")
        p.add_argument("--delay-model", default="processing", choices=("processing", "transmission"),
                       help="processing: both terms of s_i late; transmission: neighbours' states late "
                       "(exact margin on regular graphs, a Lyapunov-Krasovskii lower bound "
                       "otherwise); default processing")
    p.add_argument("--graphs-set", default=None, metavar="minus:K|G1,G2,...",
                   help="require one Lyapunov function common to a graph set: the graph and every "
                   "connected graph without K links, or a list of graph specs")
    if point_options:
        p.add_argument("--min-dwell", default=None, metavar="T",
                       help="with --graphs-set: accept switching that stays >= T s on each graph when no "
                       "common Lyapunov function exists (dwell-time certificate, gain points)")
        p.add_argument("--torque-limit", default=None, metavar="U",
                       help="require a certified peak torque |u_i(t)|_2 <= U N m for every gain of the box "
                       "(needs --inertia or --case)")
        p.add_argument("--att0", default="0.1", metavar="R",
                       help="initial set: |q_i(0)| <= R, quaternion vector part (default 0.1)")
        p.add_argument("--rate0", default="0.01", metavar="W",
                       help="initial set: |omega_i(0)| <= W rad/s (default 0.01)")


def requirements_from_args(args: argparse.Namespace, graph: Any) -> Any:
    """The requirement options as :class:`~formsync_design.analysis.requirements.Requirements`.

    >>> ns = argparse.Namespace(decay="0.1", settle=None, x0_radius="0.5", accuracy="0.01",
    ...                         delay=None, delay_model="processing", graphs_set=None)
    >>> requirements_from_args(ns, "ring:4").decay
    Fraction(1, 10)
    """
    from formsync_design.analysis.delay import DelayModel
    from formsync_design.analysis.requirements import Requirements, parse_graph_set
    from formsync_design.cli.options import parse_positive
    from formsync_design.gains import parse_number
    from formsync_design.graphs.build import make_graph

    decay = None if args.decay is None else parse_number(args.decay, "--decay")
    if decay is not None and decay <= 0:
        raise InputError(f"expected a positive --decay ALPHA, received {args.decay!r}")
    gs, label = (None, "")
    if args.graphs_set is not None:
        gs, label = parse_graph_set(args.graphs_set, graph)
    delay = getattr(args, "delay", None)
    dwell = getattr(args, "min_dwell", None)
    if dwell is not None and args.graphs_set is None:
        raise InputError(f"expected --graphs-set with --min-dwell, received --min-dwell {dwell!r} alone")
    torque = getattr(args, "torque_limit", None)
    extra: dict[str, Any] = {}
    if torque is not None:
        n = make_graph(graph).n
        if getattr(args, "inertia", None) and getattr(args, "case", None):
            raise InputError("expected one of --inertia or --case, received both")
        if getattr(args, "inertia", None):
            extra["inertias"] = read_inertias(args.inertia, n)
        elif getattr(args, "case", None):
            extra["inertias"] = read_case(args.case, n)["inertias"]
        att = parse_number(args.att0, "--att0")
        if not 0 <= att < 1:
            raise InputError(f"expected 0 <= --att0 < 1 (quaternion vector part), received {args.att0!r}")
        rate = parse_number(args.rate0, "--rate0")
        if rate < 0:
            raise InputError(f"expected a non-negative --rate0, received {args.rate0!r}")
        extra.update(torque_limit=parse_positive(torque, "--torque-limit"), att_radius=att,
                     rate_radius=rate)
    return Requirements(
        decay=decay,
        settle=None if args.settle is None else parse_positive(args.settle, "--settle"),
        x0_radius=parse_positive(args.x0_radius, "--x0-radius"),
        accuracy=parse_positive(args.accuracy, "--accuracy"),
        delay=None if delay is None else parse_positive(delay, "--delay"),
        delay_model=DelayModel(getattr(args, "delay_model", "processing")),
        graph_set=gs, graph_set_label=label,
        min_dwell=None if dwell is None else parse_positive(dwell, "--min-dwell"), **extra,
    )


def gain_box_from_args(args: argparse.Namespace, spec: Any = None) -> GainBox:
    """The gain options (``--gain NAME=RANGE`` and liang2016's ``--ko/--kq/--beta``) as
    one exact :class:`~formsync_design.gains.GainBox` over the design's gains.

    >>> ns = argparse.Namespace(ko="1.3:2", kq="0.4", beta="0.3")
    >>> str(gain_box_from_args(ns))
    'K_o=1.3:2, K_q=0.4, beta=0.3'
    >>> ns = argparse.Namespace(gain=["k_p=0.5:1"], spec="pd_consensus")
    >>> str(gain_box_from_args(ns))
    'k_p=0.5:1, k_d=0.5:3'
    """
    from formsync_design.spec.loader import load_spec

    sp_ = load_spec(spec if spec is not None else getattr(args, "spec", None))
    return design_box(sp_, getattr(args, "gain", None),
                      {"K_o": getattr(args, "ko", None), "K_q": getattr(args, "kq", None),
                       "beta": getattr(args, "beta", None)})


def parse_margin(text: str) -> Fraction:
    """``--margin EPS`` as an exact non-negative rational.

    >>> parse_margin("0.01")
    Fraction(1, 100)
    """
    from formsync_design.gains import parse_number

    m = parse_number(text, "--margin")
    if m < 0:
        raise InputError(f"expected a non-negative margin EPS (--margin), received {text!r}")
    return m


def load_conditions(graph: Any, which: str, spec: str | None = None) -> Any:
    """Derived or printed conditions for a graph (``which`` in derived|paper).

    >>> load_conditions("ring:4", "paper").source
    'paper'
    """
    from formsync_design.derive.conditions import derive_conditions, paper_conditions
    from formsync_design.graphs.build import make_graph
    from formsync_design.spec.loader import load_spec

    if which not in ("derived", "paper"):
        raise InputError(f"expected --conditions derived or paper, received {which!r}")
    g = make_graph(graph)
    if which == "paper":
        if spec is not None and load_spec(spec).name != "liang2016":
            raise InputError("expected no --spec with --conditions paper (printed matrices), "
                             f"received --spec {spec!r}")
        return paper_conditions(g)
    return derive_conditions(g, load_spec(spec) if spec else None)


def add_parser(sub: Any) -> None:
    p = sub.add_parser(
        "certify",
        help="certify (or refute) the Lyapunov conditions for a whole gain box",
        description=_DESC,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    add_gain_options(p)
    p.add_argument("--ud", default=None, metavar="BOUND",
                   help="disturbance bound |u_d,k| <= BOUND (N m) for the K_v check")
    p.add_argument("--inertia", default=None, metavar="FILE",
                   help="inertias J_i (kg m^2): text/CSV, 3 rows per spacecraft (or 3 rows for all)")
    p.add_argument("--case", default=None, metavar="FILE",
                   help="TOML case file (e.g. verification/liang2016.toml): inertias, disturbance "
                   "model (its per-spacecraft bound is used unless --ud is given) and K_v")
    p.add_argument("--kv", default=None, metavar="X", help="switching gain K_v (> 0) for the K_v check")
    p.add_argument("--switch", choices=("sgn", "sat", "tanh"), default=None,
                   help="agent designs: how the formation certificate realises sgn (default sat: "
                   "the boundary-layer law; the ideal sgn is covered only where the law stays "
                   "differentiable at consensus)")
    p.add_argument("--boundary-layer", metavar="PHI", default=None,
                   help="agent designs: the boundary layer of sat/tanh (default 0.01)")
    add_certificate_options(p)
    add_format_option(p)
    add_trust_option(p)
    p.set_defaults(func=run)


def _kv_from_args(args: argparse.Namespace, conds: Any) -> Any:
    from formsync_design.certify.engine import check_kv
    from formsync_design.cli.options import parse_positive
    from formsync_design.gains import parse_number

    n = conds.graph.n
    want = any(v is not None for v in (args.ud, args.inertia, args.case, args.kv))
    if not want:
        return None
    if args.inertia and args.case:
        raise InputError("expected one of --inertia or --case, received both")
    case = read_case(args.case, n) if args.case else {}
    ubar = parse_positive(args.ud, "--ud") if args.ud is not None else case.get("ubar")
    kv: Any = parse_positive(args.kv, "--kv") if args.kv is not None else case.get("kv")
    inertias = read_inertias(args.inertia, n) if args.inertia else case.get("inertias")
    missing = [name for name, v in (("--ud/--case", ubar), ("--inertia/--case", inertias),
                                     ("--kv/--case", kv)) if v is None]
    if missing:
        raise InputError(
            f"expected --ud, inertia data and --kv together for the K_v check, missing {missing}"
        )
    assert inertias is not None  # checked above (missing)
    if args.kv is not None:
        kv = parse_number(args.kv, "--kv")
    if args.ud is not None:
        ubar = parse_number(args.ud, "--ud")
    return check_kv(kv, inertias, ubar, switching_matches=getattr(conds, "switching_matches", True))


def require_classic(spec: Any, what: str) -> None:
    """Refuse (exit 2) an analysis written for the classic gains on another design.

    >>> from formsync_design.spec.loader import load_spec
    >>> require_classic(load_spec("pd_consensus"), "--certificate exact")
    Traceback (most recent call last):
    ...
    formsync_design.errors.InputError: expected a design with the gains K_o, K_q, beta (liang2016's) for --certificate exact, received design pd_consensus with k_p, k_d, eps
    """
    if tuple(spec.gains) != ("K_o", "K_q", "beta"):
        raise InputError(
            f"expected a design with the gains K_o, K_q, beta (liang2016's) for {what}, received "
            f"design {spec.name} with {', '.join(spec.gains)}"
        )


def certify_design(conds: Any, box: GainBox, spec: Any, *, margin: Any = 0, kv: Any = None,
                   use_sdp: bool = True) -> Any:
    """``certify_box``, with the design's multipliers not in ``box`` searched
    (:func:`~formsync_design.certify.multipliers.certify_with_multipliers`)."""
    from formsync_design.certify.engine import certify_box
    from formsync_design.certify.multipliers import certify_with_multipliers

    mult = {n: r for n in spec.decl.multipliers
            if n not in box and (r := spec.decl.gain(n).range) is not None}
    if conds.source == "derived" and mult:
        return certify_with_multipliers(conds, box, mult, margin=margin, kv=kv, use_sdp=use_sdp)
    res = certify_box(conds, box, margin=margin, kv=kv, use_sdp=use_sdp)
    given = [n for n in spec.decl.multipliers if n in box]
    if given and str(res.status) == "refuted":
        import dataclasses

        note = (f"refutes the Lyapunov candidate with the given multiplier "
                f"{', '.join(given)} only; leave it out to search its declared range")
        res = dataclasses.replace(res, reason=f"{res.reason}; {note}" if res.reason else note)
    return res


def default_graph(graph: Any, spec: Any, defaults: Any) -> Any:
    """``--graph``, else the graph of the Lagrangian design's shipped case (else the paper's),
    said in ``defaults``."""
    if graph is not None:
        return graph
    from formsync_design.verify.defaults import lagrangian_case_for

    case = lagrangian_case_for(spec, None)
    defaults.add(f"graph from the case {case.name}: {case.graph_spec}")
    return case.graph_spec


def run(args: argparse.Namespace) -> int:
    from formsync_design.cli.agent_commands import run_agent_certify
    from formsync_design.cli.agent_inputs import agent_design_or_none
    from formsync_design.cli.defaults import lagrangian_point_box, refuse_tracking
    from formsync_design.spec.loader import load_spec
    from formsync_design.verify.defaults import Defaults

    agent = agent_design_or_none(args.spec)
    refused = refuse_tracking("certify", agent, "a gain certificate on a communication graph")
    if refused is not None:
        return refused
    if agent is not None:
        return run_agent_certify(args, agent)
    spec = load_spec(args.spec)
    defaults = Defaults()
    args.graph = default_graph(args.graph, spec, defaults)
    no_gains = not args.gain and all(getattr(args, f, None) is None for f in ("ko", "kq", "beta"))
    point = lagrangian_point_box(spec, defaults) if no_gains else None
    box = point if point is not None else gain_box_from_args(args, spec)
    if args.format == "text":
        defaults.emit("certify")
    margin = parse_margin(args.margin)
    req = requirements_from_args(args, args.graph)
    g, theorem = design_graph(args.graph, spec, args.allow_outside_theorem)
    if args.certificate != "paper" or req.any():
        if not theorem.inside:
            sys.stderr.write(theorem.note() + "\n")
        with certify_activity(g, args.format):
            return _run_analysis(args, spec, box, margin, req)
    with certify_activity(g, args.format) as bar:
        bar.note("deriving the conditions")
        conds = load_conditions(args.graph, args.conditions, args.spec)
        kv = _kv_from_args(args, conds)
        if kv is not None and spec.decl.switching is None:
            raise InputError(f"expected no K_v check (--ud/--inertia/--case/--kv) for design "
                             f"{spec.name}: it has no switching term")
        bar.note("deciding the blocks at the box's vertices")
        res = certify_design(conds, box, spec, margin=margin, kv=kv)
    from formsync_design.certify.formation import lagrangian_scope

    scope = lagrangian_scope(conds.graph, spec, kv is not None)
    if args.conditions == "paper":
        import dataclasses

        scope = dataclasses.replace(scope, covers="the paper's printed Theta_i and Pi (not the "
                                    "derivation): a check of the paper's conditions")
    if args.format == "json":
        emit_json({**({"outside_theorem": theorem.to_dict()} if not theorem.inside else {}),
                   **res.to_dict(), "scope": scope.to_dict()})
    else:
        print(("" if theorem.inside else theorem.note() + "\n") + format_result(res)
              + f"\nscope: {scope.text()}")
    return EXIT_OK if res.certified else EXIT_NEGATIVE


def certify_activity(graph: Any, fmt: str) -> Any:
    """The progress of one certificate on a terminal (:func:`formsync_design.progress.activity`):
    its elapsed time and stage.  Its stages do not count their steps (one eigen-decomposition
    of a 4000 x 4000 block on 2000 spacecraft is one step), which the label says up front."""
    from formsync_design.progress import activity

    return activity(f"certify on {graph.name} (N = {graph.n}; elapsed time, no step count)",
                    enabled=fmt == "text")


def _run_analysis(args: argparse.Namespace, spec: Any, box: GainBox, margin: Fraction, req: Any) -> int:
    from formsync_design.analysis.requirements import certify_requirements

    if args.conditions != "derived":
        raise InputError("expected --conditions derived with --certificate or a requirement option "
                         f"(they use the derived closed loop), received --conditions {args.conditions}")
    if args.certificate != "paper" and margin != 0:
        raise InputError(f"expected --margin only with --certificate paper, received --margin {args.margin} "
                         f"with --certificate {args.certificate}")
    if any(v is not None for v in (args.ud, args.kv)) or (
            req.torque_limit is None and (args.inertia or args.case)):
        raise InputError("expected the K_v check (--ud/--inertia/--case/--kv) without --certificate or "
                         "requirement options, received both (run them separately)")
    res = certify_requirements(args.graph, box, args.certificate, req, spec=spec, margin=margin)
    if args.format == "json":
        emit_json(res.to_dict())
    else:
        print(format_requirement_result(res))
    return EXIT_OK if res.certified else EXIT_NEGATIVE


