"""Verification of a published design: re-derive, certify, simulate, judge the claims.

A case file (``verification/liang2016.toml``; physical layout in
:mod:`formsync_design.verify.case`) holds the published simulation case and a
``[claims]`` table::

    [case]
    spec = "my_design.py"                 # optional: the specification (default: the paper's)

    [claims]
    topologies = ["ring:8", ...]          # candidate graphs to verify over
    topology_note = "why these"
    saturation_torque_limit = 10.0        # N m per axis, for the saturation claim
    tail_fraction = 0.2                   # steady state = the last 20 % of the horizon
    max_tf = 800.0                        # lengthen a run up to this horizon (s) to reach
                                          # its steady state (default: simulation.tf)
    phi_sweep = [...]                     # boundary layers for the sensitivity study
    torque_limit_sweep = [...]            # torque limits (N m, or "unlimited"; 0 = unlimited)

    [claims.items.KEY]
    text = "what the paper claims"
    paper = "where / how it says it"
    quantity = "convergence_time"         # one of claims.QUANTITIES
    op = "<="                             # <=, <, >=, >, ==
    value = 150.0
    unit = "s"
    note = "how the claim is read ({saturation_torque_limit} = the limit with its unit)"

Each claim is measured on every candidate topology and judged with the rules of
:mod:`formsync_design.verify.claims` (what "never happened", "not reached within
the horizon" and "stopped at a singularity" mean for each operator); its
verdict is ``holds``, ``fails``, ``depends on topology`` or ``undecided`` (the
horizon, or a certificate, could not decide it).  A run that has not reached its steady state within
``simulation.tf`` is simulated again with the horizon doubled, up to
``claims.max_tf``, before any claim is judged on it.

The specification (controller and Lyapunov candidate) is ``spec=`` if given,
else the case file's ``[case] spec``, else the paper's; the derivation, the
certification and every simulation of the run use it.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import replace
from fractions import Fraction
from pathlib import Path
from typing import Any

import numpy as np

from formsync_design.errors import InputError
from formsync_design.verify.claims import (
    ClaimResult,
    Measurement,
    Outcome,
    chatter_end_time,
    combine,
    judge,
    measure_run,
    parse_claims,
    steady_state_start,
    torque_reversals,
)
from formsync_design.verify.output import display_path
from formsync_design.verify.results import SensitivityRow, TopologyRun, VerificationResult

__all__ = [
    "verify_case",
    "verification_json",
]


def _needs_longer(r: Any, frac: float) -> bool:
    """A finished run whose steady-state tail starts before it converged."""
    if r.status in ("singular", "diverged"):
        return False
    k0 = steady_state_start(r.t, frac)
    return r.convergence_time is None or r.convergence_time > float(r.t[k0])


def verify_case(case_path: str | Path | None = None, *, spec: Any = None,
                progress: Callable[[str], None] | None = None) -> VerificationResult:
    """Re-derive, certify, simulate and judge the claims of a case file.

    Parameters
    ----------
    case_path : path, optional
        Default: the paper's case (``verification/liang2016.toml``).
    spec : Spec, path or None
        The specification; default the case file's ``[case] spec``, else the paper's.
    progress : callable(str), optional
        Called with a short message before each step.

    Returns
    -------
    VerificationResult

    Examples
    --------
    >>> res = verify_case("tests/data/small_case.toml")  # doctest: +SKIP
    >>> res.claims[0].verdict  # doctest: +SKIP
    <Verdict.HOLDS: 'holds'>
    """
    from formsync_design.certify.engine import certify_box, check_kv
    from formsync_design.certify.multipliers import certify_with_multipliers
    from formsync_design.derive.closed_form import required_kv
    from formsync_design.derive.compare import all_findings
    from formsync_design.derive.conditions import derive_conditions, paper_conditions
    from formsync_design.derive.report import report_basename
    from formsync_design.graphs.theorem import check_theorem_graph
    from formsync_design.sim.simulator import simulate
    from formsync_design.spec.loader import Spec, load_spec
    from formsync_design.verify.case import default_case_path, load_case

    say = progress or (lambda msg: None)
    path = Path(case_path) if case_path is not None else default_case_path()
    case = load_case(path)
    settings, claims = parse_claims(case.claims, case.path)
    frac = settings.tail_fraction
    tf = case.options.tf
    max_tf = settings.max_tf if settings.max_tf is not None else tf
    if max_tf < tf:
        raise InputError(f"expected claims.max_tf >= simulation.tf ({tf:g} s), received {max_tf:g}")
    spec_arg = spec if spec is not None else case.spec
    sp = spec_arg if isinstance(spec_arg, Spec) else load_spec(spec_arg)
    # None keeps every stage on its default (the paper's) specification
    with_spec: dict[str, Any] = {} if spec_arg is None else {"spec": sp}
    graphs = [case.graph(g) for g in settings.topologies]
    for g in graphs:  # every candidate topology inside the design's theorem (else exit 2)
        check_theorem_graph(g, sp.decl.graphs, design=sp.name)
    gains = case.gains
    # a diagonal gain: the per-axis families share one symbol, so the hull of its
    # entries is certified (sound for every axis)
    box: dict[str, Any] = {}
    for n in sp.decl.controller_gains:
        v = gains.as_dict()[n]
        box[n] = ((Fraction(str(min(v))), Fraction(str(max(v)))) if isinstance(v, tuple)
                  else Fraction(str(v)))
    multipliers = {n: r for n in sp.decl.multipliers if (r := sp.decl.gain(n).range) is not None}
    dist = case.formation(graphs[0]).disturbance
    ubar = dist.bound(case.inertias)
    switching = sp.decl.switching is not None
    kv_req: tuple[float, ...] = ()
    kv_ratio = None
    if switching:
        kv_req = tuple(required_kv(J, float(u)) for J, u in zip(case.inertias, ubar, strict=True))
        check_kv(list(gains.K_v), list(case.inertias), [float(x) for x in ubar])
        kv_ratio = min(float(k) / r for k, r in zip(gains.K_v, kv_req, strict=True))
    printed = sp.name == "liang2016"  # the printed conditions are the paper's
    if not switching:
        bad = [c.key for c in claims if c.quantity == "kv_ratio"]
        if bad:
            raise InputError(f"expected claims the design can be judged on, received {bad} about "
                             f"kv_ratio: design {sp.name} has no switching gain")

    sims: dict = {}

    def run(g: Any, options: Any) -> Any:
        """Simulate once per (graph, options): the sweeps repeat the default settings."""
        key = (g.name, options)
        if key not in sims:
            sims[key] = simulate(case.formation(g), options, **with_spec)
        return sims[key]

    runs = []
    default_result = None
    for g in graphs:
        say(f"certify and simulate {g.name}")
        der = certify_with_multipliers(derive_conditions(g, **with_spec), box, multipliers)
        pap = certify_box(paper_conditions(g), box) if printed else None
        theta = [fm.status for fm in der.families if fm.name.startswith("Theta")]
        pi = [fm.status for fm in der.families if fm.name == "Pi"]
        theta_ok = all(st == "certified" for st in theta)
        pi_ok = all(st == "certified" for st in pi)
        opts = case.options
        r = run(g, opts)
        while _needs_longer(r, frac) and opts.tf < max_tf:
            opts = replace(opts, tf=min(2 * opts.tf, max_tf))
            say(f"simulate {g.name} to {opts.tf:g} s (steady state not reached)")
            r = run(g, opts)
        rs = run(g, replace(case.options, torque_limit=settings.saturation_torque_limit))
        q = measure_run(r, frac)
        q.update(measure_run(rs, frac, event="saturation"))
        q["theta_pd"] = _certificate(theta)
        q["pi_pd"] = _certificate(pi)
        if kv_ratio is not None:
            q["kv_ratio"] = Measurement.of(kv_ratio)
        runs.append(TopologyRun(
            graph=g.name, lambda_max=float(g.laplacian_spectral_radius), max_degree=max(g.degrees),
            derived_status=str(der.status), derived_margin=_margin(der),
            paper_status=str(pap.status) if pap is not None else "n/a",
            paper_margin=_margin(pap) if pap is not None else None,
            theta_certified=theta_ok, pi_certified=pi_ok,
            sim=r.summary(), sat_sim=rs.summary(), quantities=q, horizon=float(r.t[-1]),
        ))
        if default_result is None:
            default_result = r

    results = []
    for c in claims:
        measured = {t.graph: t.quantities[c.quantity] for t in runs}
        verdicts = {k: judge(c, m) for k, m in measured.items()}
        verdict, reason = combine(verdicts)
        notes = [f"{k}: {m.note}" for k, m in measured.items() if m.note]
        if notes:
            reason += " (" + "; ".join(notes) + ")"
        results.append(ClaimResult(c, measured, verdicts, verdict, reason))

    # sensitivity on the first (default) topology
    sens = []
    g0 = graphs[0]
    for phi in settings.phi_sweep:
        say(f"sensitivity: boundary layer {phi:g}")
        sens.append(_sens_row("boundary_layer", phi, run(g0, replace(case.options, phi=phi)), frac))
    for lim in settings.torque_limit_sweep:
        say(f"sensitivity: torque limit {lim:g}" if lim is not None else "sensitivity: unlimited torque")
        sens.append(_sens_row("torque_limit", lim, run(g0, replace(case.options, torque_limit=lim)), frac))

    findings = all_findings(g0, **with_spec) if printed else ()
    return VerificationResult(
        case_name=case.name, case_path=display_path(path), case_digest=case.digest,
        report_name=path.stem, spec_name=sp.name,
        spec_source=display_path(sp.path),
        topologies=tuple(runs), claims=tuple(results),
        sensitivity=tuple(sens), kv_required=kv_req,
        kv_used=tuple(float(k) for k in gains.K_v) if switching else (),
        ubar=tuple(float(x) for x in ubar),
        assumptions=case.assumptions, topology_note=settings.topology_note,
        derivation_report=f"{report_basename(sp, g0)}.md",
        derivation_verdicts=tuple(
            (f.key, str(f.verdict), str(getattr(f, "meaning", "") or f.item)) for f in findings),
        saturation_torque_limit=settings.saturation_torque_limit, tf=tf, max_tf=max_tf,
        default_sim=default_result,
    )


def _certificate(statuses: list[Any]) -> Measurement:
    """1 when every family is certified, 0 when one is refuted, else undecided."""
    if all(st == "certified" for st in statuses):
        return Measurement.of(1.0)
    if any(st == "refuted" for st in statuses):
        return Measurement.of(0.0)
    return Measurement(Outcome.UNDECIDED, note="certificate undecided")


def _margin(res: Any) -> float | None:
    """Rigorous lower bound of min lambda_min when certified, else the (negative) hint."""
    if res.margin_lower_bound is not None:
        return float(res.margin_lower_bound)
    hints = [fm.hint for fm in res.families if fm.hint is not None]
    return float(min(hints)) if hints else None


def _sens_row(param: str, value: float | None, r: Any, frac: float) -> SensitivityRow:
    """A descriptive row (values over the tail whether or not the run converged)."""
    if r.status == "singular":
        return SensitivityRow(param, value, r.status, r.message(), None, None, None, None, None, None, None)
    k0 = steady_state_start(r.t, frac)
    return SensitivityRow(
        parameter=param, value=value, status=r.status, message=r.message(),
        convergence_time=r.convergence_time,
        tail_q_m=float(np.max(r.q_m[k0:])), tail_omega_m=float(np.max(r.omega_m[k0:])),
        final_abs_rate=float(np.max(np.linalg.norm(r.final_rates, axis=1))),
        chatter_end_time=chatter_end_time(r.t, r.u),
        chatter_reversals_tail=int(torque_reversals(r.u)[k0:].sum()),
        saturation_end_time=r.saturation_end_time if value is not None and param == "torque_limit" else None,
    )


def verification_json(res: VerificationResult) -> str:
    """The verdicts as JSON text (numbers by :func:`formsync_design.gains.json_number`:
    exact where they round-trip, ``"inf"``/``"-inf"``/``"nan"`` for the rest)."""
    return json.dumps(res.to_dict(), indent=2, allow_nan=False)
