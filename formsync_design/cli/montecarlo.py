"""``formsync montecarlo``: seeded Monte-Carlo validation of a gain box."""

from __future__ import annotations

import argparse
import csv
import json
from dataclasses import replace
from typing import Any

from formsync_design.cli.options import (
    EXIT_NEGATIVE,
    EXIT_OK,
    Progress,
    add_format_option,
    emit_json,
)
from formsync_design.cli.simulate import (
    add_spec_option,
    check_out_dir,
    options_from_args,
    resolve_cli_spec,
)
from formsync_design.errors import InputError
from formsync_design.gains import parse_gain_range, parse_number
from formsync_design.graphs.build import GRAPH_SPEC_HELP
from formsync_design.models.disturbances import DISTURBANCES
from formsync_design.sim.bridge import SWITCHES
from formsync_design.sim.montecarlo import (
    MAX_RUNS,
    MonteCarloSettings,
    mc_box,
    replay,
    run_montecarlo,
)
from formsync_design.sim.simulator import simulate
from formsync_design.verify.case import load_case

__all__ = ["add_parser", "run"]

_EPILOG = """\
examples:
  formsync montecarlo                                  # 1000 runs around the paper's gains
  formsync montecarlo --ko 1.5:1.7 --kq 0.35:0.45 --beta 0.25:0.3 --runs 2000 --seed 7
  formsync montecarlo --graph path:8 --torque-limit 2 --max-rate 0.5 --out mc/
  formsync montecarlo --ko 1.5:1.7 --replay 1234567890123   # full simulation of one flagged run

Each run draws its gains uniformly from the box, initial attitudes (random axis, angle
uniform in [0, --max-angle]) and rates (components uniform in [-max-rate, max-rate]) and
disturbance phases from its own seed, printed for every failure; --replay SEED (with the
same box and settings) re-simulates that run with `simulate` in full.  When the
certification module is available the sampled (K_o, K_q, beta) box is certified with the
derived conditions and the smallest K_v is checked against the disturbance bound.

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
    add_spec_option(p)
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
    p.add_argument("--step", metavar="H", default="0.1", help="rk4 step (default 0.1 s for Monte-Carlo)")
    p.add_argument("--output-step", metavar="S", default="0.5", help="summary grid (default 0.5 s)")
    p.add_argument("--q-tol", default=None, help="convergence threshold on Q_m (default 1e-4)")
    p.add_argument("--omega-tol", default=None, help="threshold on Omega_m, rad/s (default 1e-5)")
    p.add_argument("--threads", default=None, help="worker threads (default: all CPUs)")
    p.add_argument("--no-certify", action="store_true", help="skip the certification of the box")
    p.add_argument("--replay", metavar="SEED", default=None, help="re-simulate one run in full from its seed")
    p.add_argument("--out", metavar="DIR", default=None, help="write summary.json and runs.csv here")
    p.add_argument("--no-compile", action="store_true", help="use CasADi's VM instead of compiled C")
    add_format_option(p)
    p.set_defaults(func=run, integrator=None, rtol=None, atol=None)


def _int(text: str, name: str, lo: int) -> int:
    try:
        v = int(str(text).strip())
    except ValueError:
        raise InputError(f"expected an integer for {name}, received {text}") from None
    if v < lo:
        raise InputError(f"expected {name} >= {lo}, received {v}")
    return v


def _float(text: str, name: str) -> float:
    return float(parse_number(text, name))


def run(args: argparse.Namespace) -> int:
    out_dir = check_out_dir(args.out)
    case = load_case(args.case)
    spec = resolve_cli_spec(args, case)
    graph = case.graph(args.graph)
    base = case.formation(graph, args.disturbance)
    g = base.gains
    iv: dict[str, Any] = {}
    for attr, name, default in (("ko", "K_o", (g.K_o, g.K_o)), ("kq", "K_q", (g.K_q, g.K_q)),
                                ("beta", "beta", (g.beta, g.beta)), ("kv", "K_v", (min(g.K_v), max(g.K_v)))):
        text = getattr(args, attr)
        if text is None:
            iv[name] = default
        else:
            iv[name] = parse_gain_range(text, name, positive=name != "K_v", nonnegative=name == "K_v")
    box = mc_box(iv)
    settings = MonteCarloSettings(
        runs=_int(args.runs, "--runs", 1), seed=_int(args.seed, "--seed", 0),
        max_angle_deg=_float(args.max_angle, "--max-angle"), max_rate=_float(args.max_rate, "--max-rate"),
        phases=not args.no_phases,
    )
    opt = options_from_args(args, replace(case.options, norm_tol=1e-5))
    if args.replay is not None:
        seed = _int(args.replay, "--replay", 0)
        f = replay(base, box, settings, seed)
        r = simulate(f, opt, spec=spec)
        out = {"seed": seed, "gains": {"K_o": f.gains.K_o, "K_q": f.gains.K_q, "beta": f.gains.beta,
                                       "K_v": f.gains.K_v[0]}, **r.to_dict()}
        if args.format == "json":
            emit_json(out)
        else:
            print(f"replay of run seed {seed}: K_o={f.gains.K_o:.6g} K_q={f.gains.K_q:.6g} "
                  f"beta={f.gains.beta:.6g} K_v={f.gains.K_v[0]:.6g}")
            print(f"status: {r.status} - {r.message()}")
        return EXIT_OK if r.converged else EXIT_NEGATIVE
    threads = _int(args.threads, "--threads", 1) if args.threads is not None else None
    prog = Progress(1, "montecarlo", enabled=args.format == "text")
    res = run_montecarlo(base, box, settings, opt, threads=threads,
                         certify=not args.no_certify, spec=spec)
    prog.update(1)
    summ = {"case": case.name, "specification": spec.name, "graph": graph.name,
            "disturbance": base.disturbance.kind, **res.to_dict()}
    written = []
    if out_dir is not None:
        d = out_dir
        d.mkdir(parents=True, exist_ok=True)
        (d / "summary.json").write_text(json.dumps(summ, indent=2, allow_nan=False) + "\n")
        with open(d / "runs.csv", "w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=list(res.runs[0].to_dict()))
            w.writeheader()
            for run_ in res.runs:
                w.writerow(run_.to_dict())
        written = [str(d / "summary.json"), str(d / "runs.csv")]
    if args.format == "json":
        emit_json({**summ, "written": written})
    else:
        print(_text(case, graph, base, res, written))
    return EXIT_OK if res.all_converged else EXIT_NEGATIVE


def _text(case: Any, graph: Any, base: Any, res: Any, written: list[str]) -> str:
    s = res.settings
    o = res.options
    bx = res.box.as_floats()
    fmt = lambda iv: f"{iv[0]:g}" if iv[0] == iv[1] else f"[{iv[0]:g}, {iv[1]:g}]"  # noqa: E731
    lines = [
        f"Monte-Carlo: case {case.name}, graph {graph.name}, {len(res.runs)} runs, seed {s.seed}, "
        f"tf = {o.tf:g} s, switch {o.switch}, disturbance {base.disturbance.kind}",
        f"  box: K_o {fmt(bx['K_o'])}, K_q {fmt(bx['K_q'])}, beta {fmt(bx['beta'])}, K_v {fmt(bx['K_v'])}; "
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
    c = res.certification
    if c.get("status") in ("skipped", "unavailable"):
        lines.append(f"  certification of the box: {c['status']}")
    else:
        lines.append(f"  certification of the (K_o, K_q, beta) box (derived conditions): {c['status']}"
                     + (f" - {c['reason']}" if c.get("reason") else ""))
        lines.append(f"  K_v >= required for ubar = {c['ubar']:.3g} N m: {'yes' if c['kv_holds'] else 'NO'}")
    if res.failures:
        lines.append(f"FAILURES ({len(res.failures)}; replay with --replay SEED and the same box/settings):")
        for r in res.failures[:20]:
            ev = f" at t = {r.event_time:g} s" if r.event_time is not None else ""
            lines.append(f"  run {r.index} seed {r.seed}: {r.status}{ev}; K_o={r.K_o:.5g} K_q={r.K_q:.5g} "
                         f"beta={r.beta:.5g} K_v={r.K_v:.5g}; final Q_m {r.final_q_m:.2e}, "
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
