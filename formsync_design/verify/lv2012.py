"""The verifier of the ``lv2012`` case kind: output feedback without rate gyros (Lv et al. 2012).

``formsync verify lv2012`` reads ``verification/lv2012.toml`` (an agent case,
:mod:`formsync_design.verify.agentcase`, whose ``[claims]`` table is this module's) and, for
the case and its ``[claims] small_case``, computes in the run:

* the design's **nonlinear storage** certificate (the design's ``conditions(c)`` hook: ``V' =
  sum w.d - k_d |y|^2`` checked symbolically, families certified on the design's gain ranges)
  and the **measured quantities**: the law's free symbols, for every in-degree of the graph,
  against the rate symbols (no angular velocity, own or neighbours');
* the lead filter's **transfer function** ``y(s)/e(s)`` from the design's own expressions,
  against ``a_f s/(s + a_f)``;
* the exact **linearisation** (:mod:`formsync_design.derive.linearize`) and the **certified L2
  gain** at the case's gains (:mod:`formsync_design.analysis.l2gain`; on the small case also by
  the SDP, and on ``[claims] box`` a whole-box certificate and a refutation with an exact
  witness), and the **gain design** within ``[claims] torque_budget``
  (:mod:`formsync_design.analysis.l2design`);
* **simulations**: without disturbance (convergence), with the case's disturbance and a perfect,
  a biased and noisy, and a failed gyro, for this design and for the comparison design
  (controller (4) of Liang et al. 2016 reading its gyro); **measured L2 gains** from the
  commanded attitude at rest under random disturbances, the paper's disturbance and the
  worst-case sinusoid of the linearisation;
* **scope: global or local?** (``[claims] scope_angles``, optional): seeded runs without
  disturbance from large initial attitudes, both signs of ``q0``
  (:mod:`formsync_design.verify.large_angle`), whose verdict is computed from the runs; the
  certificates above are of the linearisation, so local;
* the **claims** and their verdicts (:func:`judge`), then the report
  (:mod:`formsync_design.verify.lv2012_report`).
"""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from formsync_design.errors import InputError
from formsync_design.verify.kinds import VerifyRequest

__all__ = ["CLAIM_KEYS", "CaseOutcome", "Claim", "analyse_case", "judge", "verify_lv2012"]

#: ``[claims]`` keys this verifier reads (anything else is refused).
CLAIM_KEYS = {
    "small_case", "torque_budget", "tail_fraction", "comparison_design",
    "comparison_gains", "comparison_tf", "comparison_step", "comparison_switch", "comparison_phi",
    "gyro_bias", "gyro_noise", "gyro_seed", "failed_gyro", "failed_at", "l2_signals", "l2_rms",
    "l2_tf", "l2_seed", "box", "box_gamma", "refute_gamma", "scope_angles", "scope_signs",
    "scope_seed", "scope_tf",
}


def _claims(case: Any) -> dict[str, Any]:
    c = dict(case.claims)
    extra = sorted(set(c) - CLAIM_KEYS)
    if extra:
        raise InputError(f"expected [claims] keys among {sorted(CLAIM_KEYS)} in {case.path}, "
                         f"received unknown {extra}")
    need = ("torque_budget", "comparison_design", "comparison_gains", "failed_gyro")
    missing = [k for k in need if k not in c]
    if missing:
        raise InputError(f"expected [claims] {missing} in {case.path}, received none")
    if "scope_angles" in c:
        ang, sg = c["scope_angles"], c.get("scope_signs", [1, -1])
        if (not isinstance(ang, list) or not ang or not isinstance(sg, list) or not sg
                or not all(isinstance(a, (int, float)) and not isinstance(a, bool)
                           and 0 <= a <= 180 for a in ang)
                or not all(x in (1, -1) and not isinstance(x, bool) for x in sg)):
            raise InputError(f"expected [claims] scope_angles a list of degrees in [0, 180] and "
                             f"scope_signs a list of +-1 in {case.path}, received {ang!r}, {sg!r}")
    if not 1 <= int(c["failed_gyro"]) <= case.n:
        raise InputError(f"expected [claims] failed_gyro in 1..{case.n}, received "
                         f"{c['failed_gyro']!r}")
    if case.reference is None or not case.reference.constant_rate or any(
            not r.is_zero for r in case.reference.rate):
        raise InputError(f"expected a reference at rest ([reference] rate = 0) in {case.path} "
                         "(the design regulates to a constant attitude)")
    return c


@dataclass(frozen=True)
class Run:
    """One simulation summarised (numbers only; the trajectory for the figures)."""

    label: str
    design: str
    gyro: str
    status: str
    convergence_time: float | None
    tail_attitude_deg: float
    tail_reference_deg: float | None
    tail_rate: float
    peak_torque: float
    effort: float
    t: np.ndarray = field(repr=False)
    attitude_error: np.ndarray = field(repr=False)
    reference_error: np.ndarray | None = field(repr=False)
    torque_norm: np.ndarray = field(repr=False)
    quaternions: np.ndarray = field(repr=False)


@dataclass(frozen=True)
class CaseOutcome:
    """Everything computed for one case (module docstring)."""

    name: str
    path: str
    case: Any
    storage: Any                      # CertificationResult of the nonlinear storage families
    rate_free: dict[int, bool]        # in-degree -> the law has no rate symbol
    measured: tuple[str, ...]
    filter_tf: str                    # y/e as computed from the design
    filter_ok: bool
    linearisation: Any
    gamma: Any                        # L2Certificate at the case's gains (Riccati)
    gamma_sdp: Any | None             # the SDP route (small systems)
    design: Any                       # L2Design
    box: Any | None
    refute: Any | None
    torque_bound: float
    runs: dict[str, Run]
    identical_gyros: float            # max |difference| of the design's runs across gyro models
    steady_bound_deg: float           # the linearisation's steady-state bound implied by gamma
    l2: list[tuple[str, float]]       # (signal, measured gain)
    claims: list[Claim] = field(default_factory=list)
    scope: Any | None = None          # ScopeStudy of the large-angle runs ([claims] scope_angles)
    theorem: Any | None = None        # TheoremCheck: the declared graph class on graph families


@dataclass(frozen=True)
class Claim:
    """A claim and its verdict (``holds`` / ``fails`` / ``undecided``) with the evidence."""

    key: str
    text: str
    source: str
    verdict: str
    evidence: str


def _run(label: str, design: Any, gyro: str, f: Any, opt: Any, tail: float, **kw: Any) -> Run:
    from formsync_design.sim.agents import simulate_agents

    r = simulate_agents(design, f, opt, **kw)
    k = max(1, int(round(tail * len(r.t))))
    tn = np.linalg.norm(r.torques, axis=2).max(axis=1)
    return Run(label=label, design=design.name, gyro=gyro, status=str(r.status),
               convergence_time=r.convergence_time,
               tail_attitude_deg=float(r.attitude_error[-k:].max()),
               tail_reference_deg=None if r.reference_error is None
               else float(r.reference_error[-k:].max()),
               tail_rate=float(r.rate_error[-k:].max()),
               peak_torque=float(np.abs(r.torques).max()), effort=float(np.sum(r.effort)),
               t=r.t, attitude_error=r.attitude_error, reference_error=r.reference_error,
               torque_norm=tn, quaternions=r.quaternions)


def _filter_transfer(design: Any) -> tuple[str, bool]:
    """``y(s)/e(s)`` of the design's filter, from its own expressions (reference at identity,
    ``e = q``): ``x' = A x + B e``, ``y = C x + D e`` by exact Jacobians."""
    import sympy as sp

    from formsync_design.spec.agent import agent_expressions

    ex = agent_expressions(design, 0)
    v = ex["view"]
    y = design.module["virtual_rate"](v)
    xs = list(v.z["x"])
    at = {v.q0: 1, v.ref.q0: 1, **{s: 0 for s in (*v.ref.q, *v.q, *xs)}}
    xd = ex["states"]["x"]
    A, B = xd.jacobian(xs).xreplace(at), xd.jacobian(list(v.q)).xreplace(at)
    C, D = y.jacobian(xs).xreplace(at), y.jacobian(list(v.q)).xreplace(at)
    s = sp.Symbol("s")
    G = sp.simplify(C * (s * sp.eye(3) - A).inv() * B + D)
    a = design.decl.gain("a_f").symbol
    want = a * s / (s + a)
    ok = all(sp.simplify(G[i, j] - (want if i == j else 0)) == 0 for i in range(3) for j in range(3))
    return str(sp.factor(G[0, 0])), ok


def _rate_free(design: Any, degrees: list[int]) -> dict[int, bool]:
    from formsync_design.spec.agent import agent_expressions

    out = {}
    for m in degrees:
        ex = agent_expressions(design, m)
        v = ex["view"]
        rates = set(v.w) | {s for n in v.nbrs for s in n.w}
        syms = set(ex["u"].free_symbols) | {s for e in ex.get("states", {}).values()
                                            for s in e.free_symbols}
        out[m] = not (syms & rates)
    return out


def analyse_case(path: str | Path, design: Any = None, progress: Any = None) -> CaseOutcome:
    """Compute everything for one case file (module docstring)."""
    from formsync_design.analysis.l2design import budget_bound, design_l2_gains
    from formsync_design.analysis.l2gain import (
        certify_gamma,
        certify_l2_box,
        harmonic_steady_bound,
    )
    from formsync_design.certify.engine import certify_box
    from formsync_design.derive.agent import agent_conditions
    from formsync_design.derive.linearize import linearize_agents
    from formsync_design.sim.agents import AgentFormation, AgentOptions
    from formsync_design.sim.formation import Gains
    from formsync_design.sim.l2measure import (
        SIGNALS,
        harmonic_samples,
        measured_l2_gain,
        random_disturbance,
    )
    from formsync_design.sim.sensors import RateSensors
    from formsync_design.spec.loader import load_design
    from formsync_design.verify.agentcase import load_agent_case

    say = progress or (lambda msg: None)
    case = load_agent_case(path, design=design)
    d = case.design
    cl = _claims(case)
    g = case.graph()
    g.require(d.decl.graphs, by=d.name)
    degrees = sorted({len(g.receives_from(i)) for i in range(g.n)})
    say(f"{case.name}: nonlinear storage, measured quantities, filter")
    storage = certify_box(agent_conditions(d, g), {k: r for k, r in d.decl.default_ranges().items()
                                                   if k in d.decl.family_gains})
    rate_free = _rate_free(d, degrees)
    tf_text, tf_ok = _filter_transfer(d)
    say(f"{case.name}: linearisation and certified L2 gain")
    lin = linearize_agents(d, g, case.inertias)
    gains = case.gains.as_dict()
    gamma = certify_gamma(lin, gains)
    gamma_sdp = certify_gamma(lin, gains, method="sdp") if lin.nx <= 36 else None
    say(f"{case.name}: gain design within {cl['torque_budget']} N m")
    des = design_l2_gains(d, lin, cl["torque_budget"], grid=5)
    box = refute = None
    if "box" in cl:
        say(f"{case.name}: gain-box certificates")
        bx = {k: tuple(v) for k, v in dict(cl["box"]).items()}
        box = certify_l2_box(lin, bx, cl["box_gamma"], max_pieces=4)
        refute = certify_l2_box(lin, bx, cl["refute_gamma"], max_pieces=1)
    tb = float(budget_bound(d, lin, gains))
    dist = case.formation().disturbance
    assert dist is not None  # AgentFormation fills in "none"
    zb = harmonic_steady_bound(gamma.gamma, dist.harmonic)
    sbound = math.degrees(2 * math.asin(min(1.0, zb)))  # |e_i| <= |z|: angle 2 asin |e_i|

    tail = float(cl.get("tail_fraction", 0.2))
    opt = case.options
    f = case.formation()
    n = case.n
    say(f"{case.name}: simulations")
    runs: dict[str, Run] = {}
    runs["nodist"] = _run("no disturbance", d, "none used", case.formation(disturbance="none"),
                          opt, tail)
    fail = {int(cl["failed_gyro"]): float(cl.get("failed_at", 0.0))}
    seed = int(cl.get("gyro_seed", 0))
    gyros = {
        "perfect": RateSensors.of(n),
        "noisy": RateSensors.of(n, bias=float(cl.get("gyro_bias", 0.0)),
                                noise_std=float(cl.get("gyro_noise", 0.0)), seed=seed),
        "failed": RateSensors.of(n, failed=fail),
    }
    qs = []
    for key, sen in gyros.items():
        r = _run(f"disturbance, {key} gyro", d, key, f, opt, tail, sensors=sen)
        runs[f"of_{key}"] = r
        qs.append(r.quaternions)
    same = max(float(np.abs(q - qs[0]).max()) for q in qs)
    cmp_design = load_design(cl["comparison_design"])
    cf = AgentFormation(g.__class__(g.n, g.arcs, (), g.name), case.inertias, case.attitudes,
                        case.rates, Gains(dict(cl["comparison_gains"])), f.disturbance)
    copt = AgentOptions(tf=float(cl.get("comparison_tf", 200.0)), output_step=opt.output_step,
                        step=float(cl.get("comparison_step", 0.01)),
                        switch=str(cl.get("comparison_switch", "sat")),
                        phi=float(cl.get("comparison_phi", 0.01)), angle_tol=opt.angle_tol,
                        rate_tol=opt.rate_tol)
    for key, sen in gyros.items():
        runs[f"cmp_{key}"] = _run(f"controller (4), {key} gyro", cmp_design, key, cf, copt, tail,
                                  sensors=sen)
    say(f"{case.name}: measured L2 gains")
    h = opt.step
    l2tf = float(cl.get("l2_tf", 400.0))
    lopt = AgentOptions(tf=l2tf, output_step=opt.output_step, step=h)
    steps = int(round(l2tf / h))
    rest = AgentFormation(g, case.inertias, np.tile([0.0, 0.0, 0.0, 1.0], (n, 1)),
                          np.zeros((n, 3)), case.gains, None, case.reference)
    from formsync_design.sim.agents import simulate_agents

    rng = np.random.default_rng(int(cl.get("l2_seed", 0)))
    rms = float(cl.get("l2_rms", 1e-3))
    l2: list[tuple[str, float]] = []
    w_max = 4 * max(gamma.peak_frequency, 0.05) if math.isfinite(gamma.peak_frequency) else 1.0
    for _ in range(int(cl.get("l2_signals", 4))):
        for kind in SIGNALS:
            u = random_disturbance(rng, kind, steps, n, h, rms=rms, w_max=w_max)
            l2.append((kind, measured_l2_gain(simulate_agents(d, rest, lopt, torque_input=u), u, h)))
    u = harmonic_samples(f.disturbance, steps, h)
    l2.append(("paper", measured_l2_gain(simulate_agents(d, rest, lopt, torque_input=u), u, h)))
    A, B, C = lin.standard({k: float(v) for k, v in gains.items()})
    w = gamma.peak_frequency if math.isfinite(gamma.peak_frequency) else 0.0
    M = C @ np.linalg.solve(1j * w * np.eye(A.shape[0]) - A, B)
    vdir = np.linalg.svd(M)[2][0].conj()
    tt = np.arange(steps) * h
    u = np.real(np.exp(1j * w * tt)[:, None] * vdir[None, :]).reshape(steps, n, 3)
    u *= rms / float(np.sqrt(np.mean(u**2)))
    l2.append(("worst-case sine", measured_l2_gain(simulate_agents(d, rest, lopt, torque_input=u),
                                                   u, h)))
    scope = None
    if "scope_angles" in cl:
        from formsync_design.verify.large_angle import scope_study

        say(f"{case.name}: large initial attitudes (global or local?)")
        angles = [float(a) for a in cl["scope_angles"]]
        signs = tuple(int(x) for x in cl.get("scope_signs", [1, -1]))
        scope = scope_study(d, case.formation(disturbance="none"), opt, angles, signs,
                            seed=int(cl.get("scope_seed", 0)), tf=cl.get("scope_tf"))
    say(f"{case.name}: the theorem's graph class on graph families")
    from formsync_design.verify.theoremcheck import check_theorem

    theorem = check_theorem(case)
    out = CaseOutcome(name=case.name, path=str(path), case=case, storage=storage,
                      rate_free=rate_free, measured=tuple(d.decl.measured), filter_tf=tf_text,
                      filter_ok=tf_ok, linearisation=lin, gamma=gamma, gamma_sdp=gamma_sdp,
                      design=des, box=box, refute=refute, torque_bound=tb, runs=runs,
                      identical_gyros=same, l2=l2, steady_bound_deg=sbound, scope=scope,
                      theorem=theorem)
    out.claims.extend(judge(out))
    return out


def judge(o: CaseOutcome) -> list[Claim]:
    """The claims' verdicts for one case, every one computed from the outcome."""
    cl = o.case.claims
    bound = o.steady_bound_deg
    out = []
    rate_free = all(o.rate_free.values())
    no_rate = rate_free and "rate" not in o.measured and "neighbour-rate" not in o.measured \
        and o.identical_gyros == 0.0
    out.append(Claim("no_rate", "the controller uses no angular-velocity measurement",
                     "abstract ('in absence of angular velocity feedback')",
                     "holds" if no_rate else "fails",
                     f"MEASURED = {list(o.measured)} (checked at load); the law's symbols contain "
                     f"no rate for in-degrees {sorted(o.rate_free)}: {rate_free}; the runs with a "
                     f"perfect, a biased and noisy, and a failed gyro differ by "
                     f"{o.identical_gyros:.3g} (bit for bit identical: {o.identical_gyros == 0.0})"))
    r0 = o.runs["nodist"]
    stable = (str(o.storage.status) == "certified" and o.gamma.certified
              and r0.convergence_time is not None)
    out.append(Claim("asymptotic", "asymptotically stable without external disturbance",
                     "abstract (findings), Lyapunov analysis",
                     "holds" if stable else ("fails" if r0.convergence_time is None
                                             and o.gamma.certified else "undecided"),
                     f"nonlinear storage V' = -k_d |y|^2 certified on the design's gain ranges: "
                     f"{o.storage.status}; linearisation exponentially stable (certified storage "
                     f"P > 0 with A^T P + P A < 0): {o.gamma.certified}; the nonlinear formation "
                     f"from the case's initial state converges (<= {o.case.options.angle_tol:g} deg,"
                     f" {o.case.options.rate_tol:g} rad/s) at "
                     + (f"{r0.convergence_time:.1f} s" if r0.convergence_time is not None
                        else "never within the horizon")))
    rd = o.runs["of_perfect"]
    tailref = rd.tail_reference_deg if rd.tail_reference_deg is not None else math.inf
    uub = o.gamma.certified and tailref <= bound
    out.append(Claim("uub", "uniformly ultimately bounded under disturbance when the sufficient "
                     "(L2) condition holds", "abstract (findings)",
                     "holds" if uub else ("fails" if o.gamma.certified else "undecided"),
                     f"L2 condition certified at the case's gains with gamma = "
                     f"{float(o.gamma.gamma):.4g}: {o.gamma.certified}; steady-state error to "
                     f"the command {tailref:.3g} deg, within the bound {bound:.3g} deg that gamma "
                     f"implies for the linearisation under this disturbance "
                     f"(2 asin(gamma sum_nu |U_nu|)); attitude disagreement "
                     f"{rd.tail_attitude_deg:.3g} deg"))
    gmax = max(v for _, v in o.l2)
    att = o.gamma.certified and gmax <= float(o.gamma.gamma)
    out.append(Claim("l2", "L2-gain disturbance attenuation: the measured gain from the "
                     "disturbance torques to the attitude errors never exceeds gamma",
                     "abstract ('L2-gain disturbance attenuation')",
                     "holds" if att else ("fails" if o.gamma.certified else "undecided"),
                     f"{len(o.l2)} measured gains from rest, largest {gmax:.4g} "
                     f"({max(o.l2, key=lambda x: x[1])[0]}), certified gamma "
                     f"{float(o.gamma.gamma):.4g} (numerical norm {o.gamma.hinf:.4g})"))
    rf = o.runs["of_failed"]
    cf = o.runs["cmp_failed"]
    fb = rf.tail_reference_deg is not None and rf.tail_reference_deg <= bound
    out.append(Claim("fallback", "a fall-back when the angular-velocity sensors fail",
                     "abstract (practical implications)", "holds" if fb else "fails",
                     f"gyro of S/C{cl['failed_gyro']} failed: this design's steady-state error "
                     f"{rf.tail_reference_deg:.3g} deg (bound {bound:.3g} deg, unchanged from the perfect "
                     f"gyro); controller (4) on the same "
                     f"failure: {cf.status}, steady-state attitude disagreement "
                     f"{cf.tail_attitude_deg:.3g} deg (perfect gyro: "
                     f"{o.runs['cmp_perfect'].tail_attitude_deg:.3g} deg)"))
    dec = set(o.measured) <= {"attitude", "neighbour-attitude", "reference"}
    out.append(Claim("decentralised", "decentralised: each spacecraft uses its own attitude, its "
                     "neighbours' attitudes and the command only", "abstract (originality)",
                     "holds" if dec and rate_free else "fails",
                     f"MEASURED = {list(o.measured)}, checked symbolically by the loader"))
    if o.theorem is not None:
        from formsync_design.verify.theoremcheck import theorem_claim

        text, measured, verdict, rule = theorem_claim(o.theorem)
        out.append(Claim("theorem", text, "the design's GRAPHS (its theorem's class)", verdict,
                         f"{measured}; {rule}"))
    return out


def verify_lv2012(req: VerifyRequest) -> int:
    """Run ``formsync verify`` on an lv2012 case (exit status: :mod:`formsync_design.verify.kinds`)."""
    from formsync_design.verify.lv2012_report import outcome_json, write_lv2012_report
    from formsync_design.verify.output import display_path

    main = analyse_case(req.path, design=req.design, progress=req.progress)
    outcomes = [main]
    small = main.case.claims.get("small_case")
    if small is not None:
        sp_ = Path(req.path).parent / str(small)
        if not sp_.is_file():
            raise InputError(f"expected [claims] small_case to name a case file next to "
                             f"{display_path(req.path)}, received {small!r}")
        outcomes.append(analyse_case(sp_, design=req.design, progress=req.progress))
    req.progress("write report")
    cmd = req.command()
    md, figs = write_lv2012_report(outcomes, req.out, Path(req.path).stem,
                                   display_path(req.path), cmd)
    claims = [c for o in outcomes for c in o.claims]
    if req.format == "json":
        sys.stdout.write(outcome_json(outcomes) + "\n")
    else:
        sys.stdout.write(f"wrote {md} ({len(figs)} figures)\n")
        for o in outcomes:
            for c in o.claims:
                sys.stdout.write(f"  {o.name:14s} {c.verdict:10s} {c.text}\n")
    if req.strict and not all(c.verdict == "holds" for c in claims):
        return 1
    return 0
