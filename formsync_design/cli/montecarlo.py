"""``formsync montecarlo``: seeded Monte-Carlo validation of a gain box."""

from __future__ import annotations

import argparse
import math
from dataclasses import replace
from typing import TYPE_CHECKING, Any

from formsync_design.cli.choices import DISTURBANCES, GRAPH_SPEC_HELP, MAX_RUNS, SWITCHES
from formsync_design.cli.options import (
    EXIT_NEGATIVE,
    EXIT_OK,
    add_design_option,
    add_format_option,
    add_theorem_option,
    add_trust_option,
    emit_json,
    parse_gain_assignments,
    whole_number,
    write_summary_and_runs,
)
from formsync_design.cli.simulate import options_from_args
from formsync_design.errors import InputError
from formsync_design.progress import Progress

if TYPE_CHECKING:
    from formsync_design.gains import GainBox

__all__ = ["add_parser", "run", "montecarlo_box"]

_EPILOG = """\
examples:
  formsync montecarlo                                  # 1000 runs around the paper's gains
  formsync montecarlo --ko 1.5:1.7 --kq 0.35:0.45 --beta 0.25:0.3 --runs 2000 --seed 7
  formsync montecarlo --graph path:8 --torque-limit 2 --max-rate 0.5 --out mc/
  formsync montecarlo --ko 1.5:1.7 --replay 1234567890123   # full simulation of one flagged run
  formsync montecarlo --case pd_consensus --gain k_p=0.2:1 --gain k_d=1:2 --runs 200
  formsync montecarlo --design pd_consensus --disturbance none   # declared k_p, k_d ranges

Each run draws its gains uniformly from the box, initial attitudes (random axis, angle
uniform in [0, --max-angle]) and rates (components uniform in [-max-rate, max-rate]) and
disturbance phases from its own seed, printed for every failure; --replay SEED (with the
same box and settings) re-simulates that run with `simulate` in full.  When the
certification module is available the sampled box of controller gains ((K_o, K_q, beta)
for liang2016) is certified with the conditions derived for the design (its multipliers,
such as pd_consensus's eps, searched over their declared ranges) and, for a design with a
switching gain, the smallest K_v is checked against the disturbance bound.

Gains of --design (default: the case's design): --gain NAME=X|LO:HI for any controller
gain (and the switching gain K_v); --ko/--kq/--beta/--kv are the same for liang2016's
gains.  A gain not given takes the case's value when the case has that gain, else the
design's declared range.  A multiplier of the Lyapunov candidate is not a controller gain:
it is never sampled.  --kv for a design without a switching gain is an error.
Runs are integrated by the compiled adaptive DOPRI5 at --rtol 1e-6 / --atol 1e-10 (the
Monte-Carlo default; on the paper's case convergence times identical on the 0.5 s grid and
final metrics within 1e-4 of a tight reference, see benchmarks/bench_simulate.py); --step H
selects the fixed-step RK4 instead.

At most 100000 runs per campaign (each sampled formation is kept in memory); split
larger campaigns over several seeds.

exit status: 0 every run converged; 1 some run failed (not converged, q0 singularity,
divergence or norm drift; listed with seeds); 2 bad input (malformed case or
specification, an option that cannot be honoured, too many runs); 3 a failure that is
not the input (a C compiler failure).
"""


def add_parser(sub: Any) -> None:
    p = sub.add_parser(
        "montecarlo",
        help="validate a gain box on the nonlinear formation with seeded random runs",
        description=(
            "Monte-Carlo validation: simulate many randomized runs of a case (gains from a box, "
            "random initial attitudes and rates, disturbance phases) in one compiled, "
            "multi-threaded batch and report convergence statistics; flag every failing run "
            "with the seed that replays it."
        ),
        epilog=_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--case", metavar="FILE", default=None, help="case TOML (default: the paper's)")
    p.add_argument("--graph", metavar="SPEC", default=None, help=f"graph ({GRAPH_SPEC_HELP})")
    add_design_option(p)
    p.add_argument("--gain", action="append", default=None, metavar="NAME=X|LO:HI",
                   help="a controller gain of the design, a value or an interval to sample "
                        "(repeat); default: the case's value, else the design's declared range")
    for flag, name in (("--ko", "K_o"), ("--kq", "K_q"), ("--beta", "beta"), ("--kv", "K_v")):
        p.add_argument(flag, metavar="X|LO:HI", default=None,
                       help=f"{name} value or interval to sample (default: the case's)")
    p.add_argument("--runs", default="1000", help=f"number of runs (default 1000, at most {MAX_RUNS})")
    p.add_argument("--seed", default="0", help="master seed (default 0)")
    p.add_argument("--max-angle", metavar="DEG", default="100",
                   help="initial attitudes: rotation angle uniform in [0, DEG] degrees, DEG < 180 (default 100)")
    p.add_argument("--max-rate", metavar="RAD_S", default="0.9",
                   help="initial body-rate components uniform in [-R, R] rad/s (default 0.9)")
    p.add_argument("--no-phases", action="store_true", help="keep the disturbance phases of the case")
    p.add_argument("--tf", metavar="S", default=None, help="horizon (s, case default 200)")
    p.add_argument("--switch", choices=SWITCHES, default=None, help="switching term")
    p.add_argument("--boundary-layer", metavar="PHI", default=None, help="boundary layer of sat/tanh")
    p.add_argument("--torque-limit", metavar="NM", default=None, help="per-axis torque limit (N m) or 'none'")
    p.add_argument("--sample-period", metavar="TS", default=None, help="zero-order-hold period (s) or 'none'")
    p.add_argument("--disturbance", choices=DISTURBANCES, default=None, help="disturbance model")
    p.add_argument("--step", metavar="H", default=None, help="rk4 step in seconds (default: adaptive dopri5)")
    p.add_argument("--rtol", default="1e-6", help="dopri5 relative tolerance (default 1e-6 for Monte-Carlo)")
    p.add_argument("--atol", default="1e-10", help="dopri5 absolute tolerance (default 1e-10 for Monte-Carlo)")
    p.add_argument("--output-step", metavar="S", default="0.5", help="summary grid (default 0.5 s)")
    p.add_argument("--q-tol", default=None, help="convergence threshold on Q_m (default 1e-4)")
    p.add_argument("--omega-tol", default=None, help="threshold on Omega_m, rad/s (default 1e-5)")
    p.add_argument("--threads", default=None, help="worker threads (default: all CPUs)")
    p.add_argument("--no-certify", action="store_true", help="skip the certification of the box")
    p.add_argument("--replay", metavar="SEED", default=None, help="re-simulate one run in full from its seed")
    p.add_argument("--out", metavar="DIR", default=None, help="write summary.json and runs.csv here")
    p.add_argument("--overwrite", action="store_true",
                   help="replace the results of an earlier run in --out (refused without it)")
    p.add_argument("--no-compile", action="store_true", help="use CasADi's VM instead of compiled C")
    add_theorem_option(p)
    add_format_option(p)
    add_trust_option(p)
    p.set_defaults(func=run, integrator=None)


def _int(text: str, name: str, lo: int) -> int:
    try:
        v = whole_number(text)
    except argparse.ArgumentTypeError as e:
        raise InputError(f"{name}: {e}") from None
    if v < lo:
        raise InputError(f"expected {name} >= {lo}, received {v}")
    return v


def _float(text: str, name: str) -> float:
    from formsync_design.gains import parse_number

    return float(parse_number(text, name))


def check_run_options(args: argparse.Namespace) -> None:
    """The campaign's own options against their documented ranges, before anything is loaded:
    ``--runs`` in 1..MAX_RUNS, ``--seed``/``--replay`` >= 0, ``--max-angle`` in [0, 180),
    ``--max-rate`` >= 0 and finite (one-line :class:`InputError`, exit 2)."""
    runs = _int(args.runs, "--runs", 1)
    if runs > MAX_RUNS:
        raise InputError(f"expected --runs at most {MAX_RUNS} per montecarlo call, received {runs}; "
                         "split the campaign over several seeds")
    _int(args.seed, "--seed", 0)
    if args.replay is not None:
        _int(args.replay, "--replay", 0)
    ang = _float(args.max_angle, "--max-angle")
    if not 0 <= ang < 180:
        raise InputError(f"expected --max-angle in [0, 180) degrees (q0 > 0 initially), received "
                         f"{args.max_angle}")
    rate = _float(args.max_rate, "--max-rate")
    if not (math.isfinite(rate) and rate >= 0):
        raise InputError(f"expected --max-rate >= 0 rad/s and finite, received {args.max_rate}")


_LEGACY_FLAGS = {"K_o": "--ko", "K_q": "--kq", "beta": "--beta", "K_v": "--kv"}


def montecarlo_box(spec: Any, case_gains: Any, gains: Any = None,
                   legacy: dict[str, Any] | None = None) -> GainBox:
    """The sampled box of a Monte-Carlo campaign of ``spec``: its controller gains (then its
    switching gain ``K_v`` when it has one) from ``--gain NAME=X|LO:HI`` and the legacy
    ``--ko/--kq/--beta/--kv`` (``legacy``: gain name -> text or None).

    A gain not given takes the case's value when ``case_gains`` has it (``K_v``: from the
    smallest to the largest spacecraft's; a diagonal gain: from its smallest to its largest
    entry), else the design's declared range; with neither it is an
    :class:`~formsync_design.errors.InputError`.  A multiplier is not a controller gain
    (never sampled), and ``--kv`` for a design without a switching gain is refused.

    >>> from formsync_design.spec.loader import load_spec
    >>> from formsync_design.sim import Gains
    >>> liang = Gains(1.6, 0.4, 0.3, (0.01,) * 4)
    >>> str(montecarlo_box(load_spec("pd_consensus"), liang, ["k_d=1:2"]))
    'k_p=0.1:2, k_d=1:2'
    >>> str(montecarlo_box(load_spec(None), liang, None, {"K_o": "1.5:1.7"}))
    'K_o=1.5:1.7, K_q=0.4, beta=0.3, K_v=0.01'
    >>> montecarlo_box(load_spec("pd_consensus"), liang, ["eps=0.1"])
    Traceback (most recent call last):
    ...
    formsync_design.errors.InputError: expected --gain for the gains of design pd_consensus (k_p, k_d), received ['eps'] (eps: a multiplier of the Lyapunov candidate, never sampled; the certification searches it)
    """
    from formsync_design.gains import parse_gain_range
    from formsync_design.sim.montecarlo import mc_box

    d = spec.decl
    sw = d.switching
    allowed = tuple(d.controller_gains) + ((sw,) if sw is not None else ())
    named = parse_gain_assignments(gains)
    for name, text in (legacy or {}).items():
        if text is None:
            continue
        flag = _LEGACY_FLAGS.get(name, name)
        if name == "K_v" and sw is None:
            raise InputError(f"expected no {flag} for design {spec.name} (it has no switching gain), "
                             f"received {flag} {text}")
        target = sw if name == "K_v" else name
        if target not in allowed:
            raise InputError(f"expected the gains of design {spec.name} ({', '.join(allowed)}), "
                             f"received {flag} ({name})")
        if target in named:
            raise InputError(f"expected {target} once, received it as --gain and as {flag}")
        named[target] = text
    unknown = [n for n in named if n not in allowed]
    if unknown:
        mult = [n for n in unknown if n in d.multipliers]
        note = (f" ({', '.join(mult)}: a multiplier of the Lyapunov candidate, never sampled; the "
                "certification searches it)" if mult else "")
        raise InputError(f"expected --gain for the gains of design {spec.name} ({', '.join(allowed)}), "
                         f"received {unknown}{note}")
    have = case_gains.as_dict()
    box: dict[str, Any] = {}
    for n in d.controller_gains:
        decl = d.gain(n).range
        if n in named:
            box[n] = parse_gain_range(named[n], n)
        elif n in have:
            v = have[n]
            box[n] = (min(v), max(v)) if isinstance(v, tuple) else v
        elif decl is not None:
            box[n] = decl
        else:
            raise InputError(f"expected --gain {n}=X|LO:HI for design {spec.name} (neither the case "
                             "nor the design gives a value), received none")
    if sw is not None:
        decl = d.gain(sw).range
        if sw in named:
            box[sw] = parse_gain_range(named[sw], sw, positive=False, nonnegative=True)
        elif case_gains.K_v:
            box[sw] = (min(case_gains.K_v), max(case_gains.K_v))
        elif decl is not None:
            box[sw] = decl
        else:
            raise InputError(f"expected --gain {sw}=X|LO:HI for design {spec.name} (neither the case "
                             "nor the design gives a value), received none")
    return mc_box(box, spec)


def _resolve_spec(args: argparse.Namespace, case: Any) -> Any:
    """``--design``, else the case's design, else the paper's (any design the simulator takes)."""
    from formsync_design.spec.loader import load_spec

    return load_spec(args.spec if args.spec is not None else getattr(case, "spec", None))


def run(args: argparse.Namespace) -> int:
    from formsync_design.cli.agent_inputs import agent_design_or_none
    from formsync_design.graphs.build import Graph
    from formsync_design.sim.montecarlo import replay, run_montecarlo
    from formsync_design.sim.montecarlo_data import MonteCarloSettings
    from formsync_design.sim.simulator import simulate

    check_run_options(args)
    agent = agent_design_or_none(args.spec, args.case)
    from formsync_design.cli.defaults import refuse_tracking

    refused = refuse_tracking("montecarlo", agent, "a Monte-Carlo campaign of a formation")
    if refused is not None:
        return refused
    if agent is not None:
        from formsync_design.cli.agent_commands import run_agent_montecarlo_cli

        return run_agent_montecarlo_cli(args, agent)
    from formsync_design.cli.defaults import (
        case_label,
        gains_text,
    )
    from formsync_design.cli.simulate import lagrangian_criterion, lagrangian_setup

    out_dir, defaults, case, spec, graph, theorem = lagrangian_setup(args)
    base = case.formation(graph, args.disturbance)
    flag = {} if theorem.inside else {"outside_theorem": theorem.to_dict()}
    legacy = {name: getattr(args, attr) for attr, name in
              (("ko", "K_o"), ("kq", "K_q"), ("beta", "beta"), ("kv", "K_v"))}
    box = montecarlo_box(spec, base.gains, args.gain, legacy)
    settings = MonteCarloSettings(
        runs=_int(args.runs, "--runs", 1), seed=_int(args.seed, "--seed", 0),
        max_angle_deg=_float(args.max_angle, "--max-angle"), max_rate=_float(args.max_rate, "--max-rate"),
        phases=not args.no_phases,
    ).resolved_for("lagrangian")
    opt = options_from_args(args, replace(case.options, norm_tol=1e-5))
    given = [n for n, v in legacy.items() if v is not None] + list(parse_gain_assignments(args.gain))
    have = {n: v for n, v in base.gains.as_dict().items() if n not in given}
    if have:
        defaults.add(f"gains not given from {case_label(case)}: {gains_text(have)}")
    criterion = lagrangian_criterion(case, opt)
    defaults.add(f"criterion: {criterion}")
    if args.replay is not None:
        seed = _int(args.replay, "--replay", 0)
        f = replay(base, box, settings, seed, spec)
        r = simulate(f, opt, spec=spec)
        gains = f.gains.as_dict()
        if spec.decl.switching is not None:
            gains[spec.decl.switching] = f.gains.K_v[0]
        out = {**flag, "seed": seed, "gains": gains, **r.to_dict()}
        if args.format == "json":
            emit_json(out)
        else:
            if flag:
                print(theorem.note())
            print(f"replay of run seed {seed}: " + " ".join(f"{n}={_v(v, '.6g')}" for n, v in gains.items()))
            print(f"status: {r.status} - {r.message}")
        return EXIT_OK if r.converged else EXIT_NEGATIVE
    threads = _int(args.threads, "--threads", 1) if args.threads is not None else None
    # the certificate needs the derivation, which needs an undirected graph inside the theorem
    certify = not args.no_certify and theorem.inside and isinstance(graph, Graph)
    runs = settings.numbers()[0]
    with Progress(runs, "montecarlo", enabled=args.format == "text", unit="run") as prog:
        # batches of about 1/20 of the campaign move the bar (the runs are the same)
        res = run_montecarlo(base, box, settings, opt, threads=threads, certify=certify, spec=spec,
                             batch=min(2000, max(1, -(-runs // 20))) if prog.enabled
                             else 2000, progress=prog.update)
    summ = {**flag, "case": case.name, "specification": spec.name, "graph": graph.name,
            "disturbance": base.disturbance.kind, "criterion": criterion,
            "defaults": list(defaults.lines), **res.to_dict()}
    written = []
    if out_dir is not None:
        written = write_summary_and_runs(out_dir, summ, [r.to_dict() for r in res.runs])
    if args.format == "json":
        emit_json({**summ, "written": written})
    else:
        defaults.emit("montecarlo")
        print(("" if theorem.inside else theorem.note() + "\n")
              + _text(case, graph, base, res, written, spec) + f"\ncriterion: {criterion}")
    return EXIT_OK if res.all_converged else EXIT_NEGATIVE


def _v(v: Any, fmt: str) -> str:
    """A gain value (a diagonal gain as its three entries)."""
    if isinstance(v, tuple):
        return "(" + ", ".join(format(x, fmt) for x in v) + ")"
    return format(v, fmt)


def _text(case: Any, graph: Any, base: Any, res: Any, written: list[str], spec: Any) -> str:
    s = res.settings
    o = res.options
    bx = res.box.as_floats()
    fmt = lambda iv: f"{iv[0]:g}" if iv[0] == iv[1] else f"[{iv[0]:g}, {iv[1]:g}]"  # noqa: E731
    sw = spec.decl.switching
    switch = o.switch if sw is not None else "none (the design has no switching term)"
    lines = [
        f"Monte-Carlo: case {case.name}, graph {graph.name}, {len(res.runs)} runs, seed {s.seed}, "
        f"tf = {o.tf:g} s, switch {switch}, disturbance {base.disturbance.kind}",
        *([f"  design {spec.name} ({spec.source})"] if spec.name != "liang2016" else []),
        "  box: " + ", ".join(f"{n} {fmt(iv)}" for n, iv in bx.items()) + "; "
        f"initial angle <= {s.max_angle_deg:g} deg, |rate_k| <= {s.max_rate:g} rad/s, "
        f"random phases {'on' if s.phases else 'off'}",
        "  outcomes: " + ", ".join(f"{k} {v}" for k, v in res.counts.items()),
    ]
    ct = res.convergence_time_stats
    if ct["median"] is not None:
        lines.append(f"  convergence time (s): min {ct['min']:.1f}, median {ct['median']:.1f}, "
                     f"p95 {ct['p95']:.1f}, max {ct['max']:.1f}")
    sm = res.summary()
    lines.append(f"  worst final Q_m {_g(sm['worst_final_q_m'])}, worst final Omega_m {_g(sm['worst_final_omega_m'])} rad/s, "
                 f"min q0 {_g(sm['min_q0'], '.4f')}, max |u| {_g(sm['max_peak_torque'], '.3g')} N m")
    lines.append(f"  time: {res.wall_seconds:.2f} s for the batch (+ build {res.build_seconds:.2f} s)")
    c = res.certification or {"status": "skipped"}
    if c.get("status") in ("skipped", "unavailable"):
        lines.append(f"  certification of the box: {c['status']}")
    else:
        lines.append(f"  certification of the ({', '.join(spec.decl.controller_gains)}) box (derived "
                     f"conditions): {c['status']}" + (f" - {c['reason']}" if c.get("reason") else ""))
        if c["kv_holds"] is None:
            lines.append("  no switching gain: the certificate covers the undisturbed loop"
                         + (f" only (ubar = {c['ubar']:.3g} N m here)" if c["ubar"] > 0 else
                            " (no disturbance here)"))
        else:
            lines.append(f"  {sw} >= required for ubar = {c['ubar']:.3g} N m: "
                         f"{'yes' if c['kv_holds'] else 'NO'}")
    if res.failures:
        lines.append(f"FAILURES ({len(res.failures)}; replay with --replay SEED and the same box/settings):")
        for r in res.failures[:20]:
            ev = f" at t = {r.event_time:g} s" if r.event_time is not None else ""
            gains = " ".join(f"{n}={_v(v, '.5g')}" for n, v in r.gains)
            lines.append(f"  run {r.index} seed {r.seed}: {r.status}{ev}; {gains}; final Q_m {r.final_q_m:.2e}, "
                         f"Omega_m {r.final_omega_m:.2e}")
        if len(res.failures) > 20:
            lines.append(f"  ... {len(res.failures) - 20} more (see --out runs.csv or --format json)")
    else:
        lines.append("all runs converged")
    if written:
        lines.append("written: " + ", ".join(written))
    return "\n".join(lines)


def _g(v: float | None, fmt: str = ".3e") -> str:
    return "n/a" if v is None else format(v, fmt)
