"""``formsync simulate``: nonlinear formation simulation of a case file."""

from __future__ import annotations

import argparse
import json
from dataclasses import replace
from pathlib import Path
from typing import Any

from formsync_design.cli.choices import DISTURBANCES, GRAPH_SPEC_HELP, INTEGRATORS, SWITCHES
from formsync_design.cli.options import (
    EXIT_NEGATIVE,
    EXIT_OK,
    add_format_option,
    add_theorem_option,
    add_trust_option,
    check_out_dir,
    closing_lines,
    design_gains,
    emit_json,
    with_design_code,
)
from formsync_design.errors import InputError
from formsync_design.outdir import write_text

__all__ = ["add_parser", "run", "options_from_args", "add_spec_option", "resolve_cli_spec",
           "lagrangian_case_and_spec", "lagrangian_criterion"]

_EPILOG = """\
examples:
  formsync simulate                                   # the paper's case (verification/liang2016.toml)
  formsync simulate --graph star:8 --tf 300           # another topology, longer horizon
  formsync simulate --switch tanh --boundary-layer 0.05 --torque-limit 5 --out out/
  formsync simulate --sample-period 0.1 --disturbance gravity-gradient --format json
  formsync simulate --case my_case.toml --integrator cvodes --rtol 1e-9
  formsync simulate --design my_design.py             # another controller (own cached kernel)
  formsync simulate --design pd_consensus --gain k_p=0.5 --gain k_d=1.5   # the PD baseline
  formsync simulate --case pd_consensus --trigger event:0.05:1e-5   # event-triggered broadcasts
  formsync simulate --design my_agent_design.py --case my_agent_case.toml   # an agent design
                                   # (FORM = "agent": SO(3)/MRP/quaternion laws on digraphs)

outputs (with --out DIR): summary.json, trajectory.npz (t, x, u, omega_m, q_m, names)
and/or trajectory.csv, and figures omega_m, q_m, torques_1-4, torques_5-8 (.png or .svg).
State layout: x = (q1_1,q2_1,q3_1,q0_1, ..., q0_N, w1_1,w2_1,w3_1, ..., w3_N).

Options that cannot be honoured are errors: --step longer than the output step (or the
sample period), --tf not a whole multiple of it, more than 1e7 output intervals.

environment: FORMSYNC_CACHE_DIR (compiled kernels, default ~/.cache/formsync-design),
FORMSYNC_NO_COMPILE=1 (CasADi virtual machine instead of compiled C).

exit status: 0 converged (Q_m <= q-tol and Omega_m <= omega-tol from some time to tf);
1 not converged within --tf, or q0 of some spacecraft reached the singularity floor
(spacecraft and time named); 2 bad input (malformed case or specification, graph size
mismatch, an option that cannot be honoured, ...); 3 a failure that is not the input
(NaN/inf away from the singularity, named with its time; a C compiler failure).
"""


def add_parser(sub: Any) -> None:
    p = sub.add_parser(
        "simulate",
        help="simulate the nonlinear formation under the controller (paper Figs. 3-6)",
        description=(
            "Simulate N spacecraft (quaternion kinematics + Euler's equation) under controller (4) "
            "built from the symbolic derivation, with disturbances, actuator limits and sampled "
            "control. Reports the paper's metrics Omega_m (relative rate, rad/s) and Q_m (relative "
            "attitude), the convergence time, peak torques, minimum q0 and the common drift. "
            "Command-line options override the case file's [simulation] table."
        ),
        epilog=_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--case", metavar="FILE", default=None,
                   help="case TOML (default: the shipped case verification/liang2016.toml)")
    p.add_argument("--graph", metavar="SPEC", default=None,
                   help=f"communication graph overriding the case's ({GRAPH_SPEC_HELP})")
    add_spec_option(p)
    p.add_argument("--tf", metavar="S", default=None, help="horizon in seconds (case default 200)")
    p.add_argument("--switch", choices=SWITCHES, default=None,
                   help="switching term: sgn (the paper's (4)), sat(tau/phi) or tanh(tau/phi)")
    p.add_argument("--boundary-layer", metavar="PHI", default=None,
                   help="boundary layer phi of sat/tanh (case default 0.01, an assumption)")
    p.add_argument("--torque-limit", metavar="NM", default=None,
                   help="per-axis actuator limit |u_k| <= NM (N m), or 'none'")
    p.add_argument("--sample-period", metavar="TS", default=None,
                   help="zero-order-hold control period in seconds, or 'none' for continuous control")
    p.add_argument("--disturbance", choices=DISTURBANCES, default=None,
                   help="paper: u_mg + u_un (section 3); gravity-gradient alone; none")
    p.add_argument("--integrator", choices=INTEGRATORS, default=None,
                   help="auto (default): dopri5, or rk4 when --step is given or --switch sgn; "
                        "rk4: compiled fixed step; dopri5: compiled adaptive Dormand-Prince 5(4) "
                        "stopping at every kink; cvodes: adaptive reference (BDF)")
    p.add_argument("--step", metavar="H", default=None,
                   help="rk4 step in seconds (default 0.05); giving it selects rk4 under auto")
    p.add_argument("--max-step", metavar="H", default=None, help="largest dopri5/cvodes step (s)")
    p.add_argument("--output-step", metavar="S", default=None, help="output grid spacing (default 0.1 s)")
    p.add_argument("--rtol", default=None, help="dopri5/cvodes relative tolerance (default 1e-8)")
    p.add_argument("--atol", default=None, help="dopri5/cvodes absolute tolerance (default 1e-12)")
    p.add_argument("--q-tol", default=None, help="convergence threshold on Q_m (default 1e-4)")
    p.add_argument("--omega-tol", default=None, help="convergence threshold on Omega_m in rad/s (default 1e-5)")
    p.add_argument("--angle-tol", default=None, metavar="DEG",
                   help="agent designs: convergence threshold on the attitude disagreement (deg)")
    p.add_argument("--rate-tol", default=None, metavar="RAD_S",
                   help="agent designs: convergence threshold on the rate error (rad/s)")
    p.add_argument("--out", metavar="DIR", default=None, help="write summary, trajectories and figures here")
    p.add_argument("--overwrite", action="store_true",
                   help="replace the results of an earlier run in --out (refused without it)")
    p.add_argument("--export", choices=("npz", "csv", "both", "none"), default="npz",
                   help="trajectory file format under --out (default npz)")
    p.add_argument("--figures", choices=("png", "svg", "none"), default="png",
                   help="figure format under --out (default png)")
    p.add_argument("--no-compile", action="store_true",
                   help="evaluate the rk4 kernel in CasADi's virtual machine instead of compiled C")
    add_format_option(p)
    add_trust_option(p)
    p.set_defaults(func=run)


def add_spec_option(p: argparse.ArgumentParser) -> None:
    """``--spec FILE``: the controller/Lyapunov specification (default: the case's, else the paper's)."""
    add_theorem_option(p)
    p.add_argument("--trigger", default=None, metavar="periodic:T|event:SIGMA[:FLOOR]",
                   help="per-spacecraft sample-and-hold: broadcast every T s, or when |q_i - "
                   "qhat_i| >= SIGMA |shat_i| + FLOOR (exact hybrid integration; outputs the "
                   "transmissions); required for a design that declares sampling")
    p.add_argument("--gain", action="append", default=None, metavar="NAME=X",
                   help="a controller gain of the design (repeat); default: the case's gain of "
                   "that name")
    p.add_argument("--design", "--spec", dest="spec", metavar="NAME|FILE", default=None,
                   help="the design: a shipped design's name or a design .py (default: the case's "
                        "[case] spec, else liang2016; --spec is the old name)")


def resolve_cli_spec(args: argparse.Namespace, case: Any) -> Any:
    """The specification of a run: ``--spec``, else the case's, else the paper's (validated
    now, before any output is written)."""
    from formsync_design.spec.loader import load_spec

    given = getattr(args, "spec", None)
    spec = load_spec(given if given is not None else getattr(case, "spec", None))
    return spec


def simulation_graph(args: argparse.Namespace, case: Any, spec: Any) -> tuple[Any, Any]:
    """``--graph`` (any graph the design's theorem covers, or with
    ``--allow-outside-theorem`` any graph, directed and weighted included) or the case's,
    sized to the case, and its theorem check."""
    from formsync_design.cli.options import design_graph

    g, chk = design_graph(args.graph if args.graph is not None else case.graph(),
                          spec, getattr(args, "allow_outside_theorem", False), derivation=False)
    return case.graph(g), chk


def lagrangian_case_and_spec(args: argparse.Namespace, defaults: Any) -> tuple[Any, Any]:
    """The case and the design of a Lagrangian run: ``--case`` and ``--design``; with only
    ``--design``, the design's shipped case (else the paper's), said in ``defaults``."""
    from formsync_design.spec.loader import load_spec
    from formsync_design.verify.case import load_case
    from formsync_design.verify.defaults import lagrangian_case_for

    if args.case is None and getattr(args, "spec", None) is not None:
        spec = load_spec(args.spec)
        return lagrangian_case_for(spec, None, defaults), spec
    case = load_case(args.case)
    return case, resolve_cli_spec(args, case)


def lagrangian_setup(args: argparse.Namespace) -> Any:
    """The common start of ``simulate`` and ``montecarlo`` of a Lagrangian design: the
    ``--out`` folder (claimed), the defaults, the case and design, the graph and its theorem
    check (a design on the relative-orbit plant was refused before, in the command:
    :func:`~formsync_design.cli.defaults.refuse_tracking`)."""
    from formsync_design.cli.defaults import lagrangian_graph
    from formsync_design.verify.defaults import Defaults

    out_dir = check_out_dir(args.out, overwrite=getattr(args, "overwrite", False))
    defaults = Defaults()
    case, spec = lagrangian_case_and_spec(args, defaults)
    case, graph, theorem = lagrangian_graph(args, case, spec, defaults)
    return out_dir, defaults, case, spec, graph, theorem


def lagrangian_criterion(case: Any, opt: Any) -> str:
    """The convergence criterion of a Lagrangian run in words, with where it comes from."""
    from formsync_design.cli.defaults import case_label

    src = case_label(case)
    return (f"Q_m <= {opt.q_tol:g} and Omega_m <= {opt.omega_tol:g} rad/s from some time to "
            f"tf = {opt.tf:g} s (the tolerances of {src} [simulation] and the options given)")


def _positive(text: str, name: str) -> float:
    from formsync_design.gains import parse_number

    v = parse_number(text, name)
    if v <= 0:
        raise InputError(f"expected a positive {name}, received {text}")
    return float(v)


def _opt_num(v: str | None, name: str) -> float | None:
    return None if v is None else _positive(v, name)


def _opt_none_or_num(v: str | None, name: str) -> tuple[bool, float | None]:
    if v is None:
        return False, None
    if v.strip().lower() == "none":
        return True, None
    return True, _positive(v, name)


def options_from_args(args: argparse.Namespace, base: Any) -> Any:
    """Apply the command-line overrides to the case's :class:`SimOptions`."""
    kw: dict[str, Any] = {}
    for attr, name in (("tf", "tf"), ("boundary_layer", "phi"), ("step", "step"),
                       ("output_step", "output_step"), ("rtol", "rtol"), ("atol", "atol"),
                       ("q_tol", "q_tol"), ("omega_tol", "omega_tol"), ("max_step", "max_step")):
        v = _opt_num(getattr(args, attr, None), "--" + attr.replace("_", "-"))
        if v is not None:
            kw[name] = v
    for attr in ("torque_limit", "sample_period"):
        given, v = _opt_none_or_num(getattr(args, attr), "--" + attr.replace("_", "-"))
        if given:
            kw[attr] = v
    if args.switch is not None:
        kw["switch"] = args.switch
    if args.integrator is not None:
        kw["integrator"] = args.integrator
        if args.integrator == "cvodes" and "sample_period" not in kw:
            kw["sample_period"] = None
        if args.integrator in ("dopri5", "cvodes") and "step" not in kw:
            kw["step"] = None  # the case's RK4 step does not apply
    if args.no_compile:
        kw["compile"] = False
    try:
        return replace(base, **kw)
    except InputError as e:  # name the command-line option that cannot be honoured
        msg = str(e)
        for needle, flag in (("RK4 step", "--step"), ("no step with", "--step"), ("expected tf", "--tf"),
                             ("output intervals", "--tf / --output-step")):
            if needle in msg:
                raise InputError(f"{flag}: {msg}") from None
        raise


def _text(case: Any, graph: Any, f: Any, r: Any, written: list[str], spec: Any = None) -> str:
    import numpy as np

    o = r.options
    ctl = "continuous control" if o.sample_period is None else f"ZOH control Ts = {o.sample_period:g} s"
    sw = o.switch if o.switch == "sgn" else f"{o.switch} (phi = {o.phi:g})"
    if spec is not None and spec.decl.switching is None:
        sw = "none (the design has no switching term)"
    lim = "unlimited torque" if o.torque_limit is None else f"|u_k| <= {o.torque_limit:g} N m"
    lines = [
        f"case {case.name} ({Path(case.path).name}): {r.n} spacecraft, graph {graph.name}, tf = {o.tf:g} s",
        f"  switch {sw}, {lim}, {ctl}, disturbance {f.disturbance.kind}",
        *([f"  specification {spec.name} ({spec.source})"] if spec is not None and spec.name != "liang2016" else []),
        f"status: {r.status} - {r.message}",
        f"final metrics: Q_m = {r.final_q_m:.3e}, Omega_m = {r.final_omega_m:.3e} rad/s",
    ]
    i_min = int(np.argmin(r.min_q0))
    lines.append(f"minimum q0: {r.min_q0[i_min]:.4f} (S/C{i_min + 1})")
    cr = r.common_rate
    lines.append(
        f"absolute rates at tf: mean (common drift) = ({cr[0]:.3e}, {cr[1]:.3e}, {cr[2]:.3e}) rad/s, "
        f"max |omega_i| = {np.linalg.norm(r.final_rates, axis=1).max():.3e} rad/s"
    )
    if o.torque_limit is not None:
        se = r.saturation_end_time
        lines.append("torque limit never reached" if se is None else f"torque limit last reached at t = {se:g} s")
    lines.append("peak torque |u| per spacecraft (N m):     u1        u2        u3")
    for i, row in enumerate(r.peak_torque):
        lines.append(f"  S/C{i + 1:<3d}{'':29s}{row[0]:9.4f} {row[1]:9.4f} {row[2]:9.4f}")
    st = r.stats
    where = 'compiled C' if st.get('compiled') else 'CasADi VM'
    if st["integrator"] == "rk4":
        lines.append(
            f"integrator: rk4 h = {st['step']:g} s, {st['steps']} steps, {st['rhs_evaluations']} rhs evaluations, "
            f"{where}, {st['wall_seconds'] * 1e3:.1f} ms "
            f"(+ build {st['build_seconds']:.2f} s), quaternion norm drift {st['max_norm_error']:.1e}"
        )
    elif st["integrator"] == "dopri5":
        lines.append(
            f"integrator: dopri5 rtol {st['rtol']:g} atol {st['atol']:g}, {st['steps']} steps "
            f"({st['rejected_steps']} rejected), {st['rhs_evaluations']} rhs evaluations, {where}, "
            f"{st['wall_seconds'] * 1e3:.1f} ms (+ build {st['build_seconds']:.2f} s), quaternion "
            f"norm drift {st['max_norm_error']:.1e}"
        )
    else:
        lines.append(
            f"integrator: cvodes rtol {st['rtol']:g} atol {st['atol']:g}, {st['steps']} steps, "
            f"{st['rhs_evaluations']} rhs evaluations, {st['wall_seconds'] * 1e3:.1f} ms, "
            f"quaternion norm drift {st['max_norm_error']:.1e}"
        )
    ev = st.get("events")
    if ev is not None:
        parts = []
        for key, label in (("switching", "switching"), ("torque_limit", "torque limit")):
            e = ev[key]
            if e["count"]:
                parts.append(f"{label} {e['count']} (first {e['first']:.6f} s, last {e['last']:.6f} s)")
        lines.append(f"events located to {ev['tolerance']:g} s: " + ("; ".join(parts) if parts else "none"))
    lines += closing_lines(case.assumptions, written)
    return "\n".join(lines)


def _run_sampled(args: argparse.Namespace, case: Any, graph: Any, f: Any, opt: Any, spec: Any,
                 out_dir: Path | None, theorem: Any) -> int:
    """``--trigger``: the exact hybrid simulation with per-spacecraft sample-and-hold."""
    from formsync_design.sim.result import SimStatus
    from formsync_design.sim.sampled import parse_trigger
    from formsync_design.sim.simulator import simulate

    if args.trigger is None:
        raise InputError(f"expected --trigger periodic:T or event:SIGMA[:FLOOR]: design "
                         f"{spec.name} declares {spec.decl.sampling} sampling, received none")
    if opt.sample_period is not None or args.integrator is not None:
        raise InputError("expected --trigger without --sample-period and --integrator (the "
                         "hybrid integrator is DOP853 with event location)")
    trig = parse_trigger(args.trigger)
    r = simulate(f, opt, spec=spec, trigger=trig)
    assert r.transmissions is not None and r.min_interevent is not None  # a sampled run's
    doc = {**({"outside_theorem": theorem.to_dict()} if not theorem.inside else {}),
           "case": case.name, "graph": graph.name, "gains": f.gains.as_dict(),
           "disturbance": f.disturbance.kind, "trigger": trig.text(), **r.to_dict()}
    if out_dir is not None:
        pth = write_text(out_dir / "summary.json", json.dumps(with_design_code(doc), indent=2, allow_nan=False) + "\n")
        doc["written"] = [str(pth)]
    if args.format == "json":
        emit_json(doc)
    else:
        ct = r.convergence_time
        lines = [
            f"case {case.name}: {f.n} spacecraft, graph {graph.name}, tf = {opt.tf:g} s, "
            f"design {spec.name}, trigger {trig.text()}",
            f"status: {r.status} - " + (f"converged at t = {ct:.2f} s" if ct is not None else
                                        f"not converged within {opt.tf:g} s"
                                        if r.status == SimStatus.NOT_CONVERGED else
                                        f"the run stopped at t = {r.stop_time:g} s"),
            f"final metrics: Q_m = {r.final_q_m:.3e}, Omega_m = {r.final_omega_m:.3e} rad/s",
            "transmissions per spacecraft: " + ", ".join(str(int(k)) for k in r.transmissions),
            "shortest inter-event time per spacecraft (s): "
            + ", ".join(f"{v:.3g}" for v in r.min_interevent),
        ]
        if r.status in (SimStatus.STOPPED, SimStatus.DIVERGED):
            lines.append(r.message)
        if not theorem.inside:
            lines.insert(0, theorem.note())
        print("\n".join(lines))
    return EXIT_OK if r.converged else EXIT_NEGATIVE


def run(args: argparse.Namespace) -> int:
    from formsync_design.cli.agent_commands import run_agent_simulate
    from formsync_design.cli.agent_inputs import agent_design_or_none
    from formsync_design.sim.simulator import simulate

    agent = agent_design_or_none(args.spec, args.case)
    from formsync_design.cli.defaults import refuse_tracking

    refused = refuse_tracking("simulate", agent, "a formation simulation")
    if refused is not None:
        return refused
    if agent is not None:
        return run_agent_simulate(args, agent)
    from formsync_design.cli.defaults import (
        case_label,
        gains_text,
    )

    out_dir, defaults, case, spec, graph, theorem = lagrangian_setup(args)
    opt = options_from_args(args, case.options)
    f = case.formation(graph, args.disturbance)
    if args.gain or tuple(f.gains.names) != spec.decl.controller_gains:
        f = replace(f, gains=design_gains(spec, f.gains, args.gain))
    elif not args.gain:
        defaults.add(f"gains from {case_label(case)}: {gains_text(f.gains.as_dict())}")
    criterion = lagrangian_criterion(case, opt)
    defaults.add(f"criterion: {criterion}")
    if args.trigger is not None or spec.decl.sampling != "continuous":
        if args.format == "text":
            defaults.emit("simulate")
        return _run_sampled(args, case, graph, f, opt, spec, out_dir, theorem)
    r = simulate(f, opt, spec=spec)
    written: list[str] = []
    summary = {
        **({"outside_theorem": theorem.to_dict()} if not theorem.inside else {}),
        "case": case.name,
        "case_file": case.path,
        "specification": spec.name,
        "specification_source": spec.source,
        "graph": graph.name,
        "gains": f.gains.as_dict(),
        "disturbance": f.disturbance.kind,
        "assumptions": list(case.assumptions),
        "criterion": criterion,
        "defaults": list(defaults.lines),
        **r.to_dict(),
    }
    if out_dir is not None:
        out = out_dir
        p = write_text(out / "summary.json", json.dumps(with_design_code(summary), indent=2, allow_nan=False) + "\n")
        written.append(str(p))
        if args.export in ("npz", "both"):
            written.append(str(r.to_npz(out / "trajectory.npz")))
        if args.export in ("csv", "both"):
            written.append(str(r.to_csv(out / "trajectory.csv")))
        if args.figures != "none":
            from formsync_design.sim.figures import all_figures, save_figure

            for name, fig in all_figures(r).items():
                written.append(str(save_figure(fig, out / f"{name}.{args.figures}")))
    if args.format == "json":
        emit_json({**summary, "written": written})
    else:
        defaults.emit("simulate")
        print(("" if theorem.inside else theorem.note() + "\n") + _text(case, graph, f, r, written, spec))
    return EXIT_OK if r.converged else EXIT_NEGATIVE
