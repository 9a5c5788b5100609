"""The verifier of the case kind ``selftrigger`` (``formsync verify selftrigger_mrp``): a
self-triggered design against its event-triggered and periodic variants on one formation.

The case file is an agent case (:mod:`formsync_design.verify.agentcase`) with ``[case] kind =
"selftrigger"`` and a ``[claims]`` table::

    [claims]        tail_fraction (accuracy = the largest angle to the leader over this last
                    fraction of the horizon), periods = [s, ...] (periodic sampling; the
                    period with the self-trigger's transmissions is added), moderate_ratio
                    (the largest self/event transmission ratio called "moderately above")
    [claims.box]    gain ranges to certify ("lo:hi" or a number), every controller gain
    [claims.digraph] arcs = [[i, j, a_ij], ...] with j = 0 the leader: the directed graph with a
                    spanning tree from the leader
    [claims.montecarlo] runs, seed, tf, attitude_deg (largest initial rotation from the
                    leader), rate_sigma (rad/s): seeded initial conditions and disturbance phases

Every verdict is computed in the run (:func:`judge`): ``holds``, ``fails`` or ``undecided``
(the premise the claim needs did not hold in any run), with the numbers it rests on.
"""

from __future__ import annotations

import enum
import json
import math
import sys
from dataclasses import dataclass, field, replace
from fractions import Fraction
from typing import Any

import numpy as np

from formsync_design.errors import InputError
from formsync_design.gains import json_number
from formsync_design.verify.kinds import VerifyRequest

__all__ = ["Verdict", "Claim", "SelftriggerVerification", "verify_selftrigger",
           "verify_selftrigger_case", "judge", "monte_carlo_formations"]


class Verdict(enum.StrEnum):
    """A claim's verdict."""

    HOLDS = "holds"
    FAILS = "fails"
    UNDECIDED = "undecided"


@dataclass(frozen=True)
class Claim:
    """One checkable claim: its key, the claim's text, how it is judged, the verdict and the
    evidence (a sentence with the numbers)."""

    key: str
    text: str
    rule: str
    verdict: Verdict
    evidence: str

    def to_dict(self) -> dict[str, Any]:
        return {"key": self.key, "text": self.text, "rule": self.rule,
                "verdict": str(self.verdict), "evidence": self.evidence}


@dataclass(frozen=True)
class SelftriggerVerification:
    """Everything ``formsync verify`` computed for a ``selftrigger`` case.

    ``graphs``: label -> Digraph; ``certificates``: label -> CertificationResult;
    ``runs``: label -> {scheme or ``periodic@T``: SchemeRun}; ``mc``: list of
    ``{scheme: SchemeRun}`` (self, event, periodic at equal transmissions);
    ``bound``: IntereventBound; ``delta_check``: DeltaCheck; ``iss``: label -> (predicted,
    measured) ultimate bound of ``|sigma_i - sigma_d|`` (the norm chain); ``iss_ellipsoid``:
    label -> IssEllipsoid (the invariant-ellipsoid bound from the same measured inputs);
    ``interevent_origin``: (active ratio, interval at rest, bound is the rule's floor);
    ``claims``: tuple of Claim.
    """

    case: Any
    config: dict[str, Any]
    graphs: dict[str, Any]
    certificates: dict[str, Any]
    runs: dict[str, dict[str, Any]]
    mc: list[dict[str, Any]]
    bound: Any
    delta_check: Any
    iss: dict[str, tuple[float, float]]
    reference_rate_max: float
    claims: tuple[Claim, ...] = field(default=())
    iss_ellipsoid: dict[str, Any] = field(default_factory=dict)
    interevent_origin: tuple[str, Any, bool] | None = None
    theorem: Any = None

    @property
    def all_hold(self) -> bool:
        return all(c.verdict == Verdict.HOLDS for c in self.claims)

    def to_dict(self) -> dict[str, Any]:
        from formsync_design.verify.selftrigger_cert import iss_vacuous

        return {
            "case": self.case.name, "design": self.case.design.name,
            "interevent_bound": {"formula": self.bound.formula,
                                 "value": json_number(self.bound.value)},
            "delta_disturbance_part": [json_number(v) for v in self.delta_check.required],
            "delta_covers_disturbance": self.delta_check.all_hold,
            "certificates": {k: c.to_dict() for k, c in self.certificates.items()},
            "runs": {g: {k: r.to_dict() for k, r in rs.items()} for g, rs in self.runs.items()},
            "montecarlo": [{k: r.to_dict() for k, r in rs.items()} for rs in self.mc],
            "iss": {k: {"predicted": json_number(a), "measured": json_number(b),
                        "vacuous": iss_vacuous(self.case.design, a),
                        "ellipsoid": None if k not in self.iss_ellipsoid else {
                            "certified": self.iss_ellipsoid[k].certified,
                            "sigma_bound": json_number(self.iss_ellipsoid[k].sigma_bound),
                            "z_bounds": [json_number(z) for z in self.iss_ellipsoid[k].z_bounds]}}
                    for k, (a, b) in self.iss.items()},
            "interevent_origin": None if self.interevent_origin is None else {
                "active": self.interevent_origin[0],
                "at_rest": json_number(self.interevent_origin[1]),
                "design_floor": self.interevent_origin[2]},
            "claims": [c.to_dict() for c in self.claims],
            "theorem": None if self.theorem is None else self.theorem.to_dict(),
        }


def _config(case: Any) -> dict[str, Any]:
    from formsync_design.gains import parse_number

    cl = dict(case.claims)
    allowed = {"tail_fraction", "periods", "moderate_ratio", "box", "digraph", "montecarlo"}
    extra = set(cl) - allowed
    if extra:
        raise InputError(f"expected [claims] keys among {sorted(allowed)} in {case.path}, "
                         f"received {sorted(extra)}")
    box = cl.get("box", {})
    if not isinstance(box, dict) or set(box) != set(case.design.decl.controller_gains):
        raise InputError(f"expected [claims.box] with every gain "
                         f"{list(case.design.decl.controller_gains)} in {case.path}, received "
                         f"{sorted(box) if isinstance(box, dict) else box!r}")
    mc = dict(cl.get("montecarlo", {}))
    mkeys = {"runs", "seed", "tf", "attitude_deg", "rate_sigma"}
    if set(mc) != mkeys:
        raise InputError(f"expected [claims.montecarlo] keys {sorted(mkeys)} in {case.path}, "
                         f"received {sorted(mc)}")
    if not isinstance(mc["runs"], int) or not 1 <= mc["runs"] <= 200:
        raise InputError(f"expected claims.montecarlo.runs in 1..200, received {mc['runs']!r}")
    dg = cl.get("digraph", {})
    if not isinstance(dg, dict) or not isinstance(dg.get("arcs"), list):
        raise InputError(f"expected [claims.digraph] arcs = [[i, j, a_ij], ...] in {case.path}, "
                         f"received {dg!r}")
    periods = cl.get("periods", [])
    if not (isinstance(periods, list) and periods
            and all(isinstance(p, (int, float)) and p > 0 for p in periods)):
        raise InputError(f"expected claims.periods = [positive seconds, ...], received {periods!r}")
    return {
        "tail": float(parse_number(cl.get("tail_fraction", 0.2), "claims.tail_fraction")),
        "periods": sorted(float(p) for p in periods),
        "moderate_ratio": float(parse_number(cl.get("moderate_ratio", 2), "claims.moderate_ratio")),
        "box": {k: str(v) for k, v in box.items()},
        "digraph": dg,
        "mc": {"runs": mc["runs"], "seed": int(mc["seed"]), "tf": float(mc["tf"]),
               "attitude_deg": float(mc["attitude_deg"]), "rate_sigma": float(mc["rate_sigma"])},
    }


def monte_carlo_formations(case: Any, graph: Any, runs: int, seed: int, attitude_deg: float,
                           rate_sigma: float) -> list[Any]:
    """Seeded formations: each spacecraft rotated from the leader's initial attitude by an
    angle uniform in ``[0, attitude_deg]`` about a uniform axis, rates ``N(0, rate_sigma^2)``
    per axis, the disturbance's oscillating phases uniform (one generator, in this order).

    >>> from formsync_design.resources import case_file
    >>> from formsync_design.verify.agentcase import load_agent_case
    >>> c = load_agent_case(case_file("selftrigger_mrp"))
    >>> fs = monte_carlo_formations(c, c.graph(), 2, 7, 60.0, 0.01)
    >>> len(fs), bool(np.allclose(np.linalg.norm(fs[1].attitudes, axis=1), 1))
    (2, True)
    """
    rng = np.random.default_rng(seed)
    base = case.formation(graph)
    q_ref = np.asarray(case.reference.attitude if case.reference else (0, 0, 0, 1), float)
    out = []
    for _ in range(runs):
        Q = np.empty((case.n, 4))
        for i in range(case.n):
            ax = rng.normal(size=3)
            ax /= np.linalg.norm(ax)
            ang = math.radians(attitude_deg) * rng.random()
            Q[i] = _qmul(q_ref, np.concatenate([math.sin(ang / 2) * ax, [math.cos(ang / 2)]]))
            if Q[i, 3] < 0:
                Q[i] *= -1
        W = rate_sigma * rng.normal(size=(case.n, 3))
        assert base.disturbance is not None
        out.append(replace(base, attitudes=Q, rates=W, disturbance=base.disturbance.with_phases(rng)))
    return out


def _qmul(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Hamilton product in the ``(q1, q2, q3, q0)`` order."""
    pv, p0, qv, q0 = p[:3], p[3], q[:3], q[3]
    return np.concatenate([p0 * qv + q0 * pv + np.cross(pv, qv), [p0 * q0 - pv @ qv]])


def _eq_period(run: Any, tf: float) -> float:
    k = max(1, int(round(float(np.mean(run.transmissions)))))
    return tf / k


def verify_selftrigger(case: Any, progress: Any = None) -> SelftriggerVerification:
    """Certify, simulate and judge a ``selftrigger`` case (module docstring)."""
    from formsync_design.graphs.digraph_io import digraph_from_edges
    from formsync_design.graphs.theorem import check_theorem_graph
    from formsync_design.sim.agent_sampled import reference_trajectory
    from formsync_design.verify.selftrigger_cert import (
        certify_design,
        disturbance_delta,
        interevent_bound,
        interevent_origin,
        iss_ellipsoid,
        iss_prediction,
    )
    from formsync_design.verify.selftrigger_runs import run_scheme, scheme_designs

    say = progress or (lambda s: None)
    cfg = _config(case)
    design = case.design
    designs = scheme_designs(design)
    try:
        dg = digraph_from_edges([tuple(a) for a in cfg["digraph"]["arcs"]], n=case.n,
                                name=f"{case.name}-digraph")
    except (ValueError, TypeError) as e:
        raise InputError(f"expected claims.digraph.arcs [[i, j, a_ij], ...] in {case.path}: {e}") from None
    graphs = {"nominal": case.graph(), "digraph": dg}
    for g in graphs.values():
        check_theorem_graph(g, design.decl.graphs, design=design.name)
    gains = {k: v for k, v in case.gains.as_dict().items()}
    fr = {k: Fraction(v) for k, v in gains.items()}
    bound = interevent_bound(design, fr)
    certs = {}
    for label, g in graphs.items():
        say(f"certify {label}")
        certs[label] = certify_design(design, g, cfg["box"])
    f0 = case.formation()
    D = f0.graph.adjacency.sum(axis=1) + f0.graph.pinning_matrix.diagonal()
    assert f0.disturbance is not None
    delta_check = disturbance_delta(fr["delta"], case.inertias, f0.disturbance.bound(case.inertias), D)
    opt = case.options
    ref = reference_trajectory(case.reference, opt.tf)
    wmax = max(float(np.linalg.norm(ref(t)[1])) for t in np.linspace(0, opt.tf, 2001))
    runs: dict[str, dict[str, Any]] = {}
    for label, g in graphs.items():
        f = case.formation(g)
        rs: dict[str, Any] = {}
        for scheme in ("self-triggered", "event"):
            say(f"simulate {label} {scheme}")
            rs[scheme] = run_scheme(designs, f, opt, scheme, tail=cfg["tail"])
        t_eq = _eq_period(rs["self-triggered"], opt.tf)
        rs["periodic-equal"] = run_scheme(designs, f, opt, "periodic", period=t_eq, tail=cfg["tail"])
        if label == "nominal":
            for T in cfg["periods"]:
                say(f"simulate {label} periodic {T:g} s")
                rs[f"periodic@{T:g}"] = run_scheme(designs, f, opt, "periodic", period=T,
                                                   tail=cfg["tail"])
        runs[label] = rs
    mc_cfg = cfg["mc"]
    mc_opt = replace(opt, tf=mc_cfg["tf"])
    mc: list[dict[str, Any]] = []
    forms = monte_carlo_formations(case, graphs["nominal"], mc_cfg["runs"], mc_cfg["seed"],
                                   mc_cfg["attitude_deg"], mc_cfg["rate_sigma"])
    for k, f in enumerate(forms):
        say(f"monte-carlo run {k + 1}/{len(forms)}")
        rs = {s: run_scheme(designs, f, mc_opt, s, tail=cfg["tail"]) for s in ("self-triggered", "event")}
        rs["periodic-equal"] = run_scheme(designs, f, mc_opt, "periodic",
                                          period=_eq_period(rs["self-triggered"], mc_opt.tf),
                                          tail=cfg["tail"])
        mc.append(rs)
    iss: dict[str, tuple[float, float]] = {}
    ell: dict[str, Any] = {}
    for label, g in graphs.items():
        fam = next((fm for fm in certs[label].families if fm.name == "reaching"), None)
        if fam is None or fam.lower is None:
            continue
        run = runs[label]["self-triggered"]
        pred = iss_prediction(design, g, {k: float(v) for k, v in gains.items()},
                              float(fam.lower), run.c_norm, run.staleness, run.delta_norm)
        iss[label] = (pred, run.tail_sigma_error)
        say(f"invariant-ellipsoid bound {label}")
        ell[label] = iss_ellipsoid(design, g, {k: float(v) for k, v in gains.items()},
                                   run.c_norm / math.sqrt(case.n), run.staleness, run.delta_norm)
    res = SelftriggerVerification(case=case, config=cfg, graphs=graphs, certificates=certs,
                                  runs=runs, mc=mc, bound=bound, delta_check=delta_check,
                                  iss=iss, reference_rate_max=wmax, iss_ellipsoid=ell,
                                  interevent_origin=interevent_origin(bound, fr))
    say("the theorem's graph class on graph families")
    from formsync_design.verify.theoremcheck import check_theorem

    res = replace(res, theorem=check_theorem(case))
    return replace(res, claims=judge(res))


def _pairs(res: SelftriggerVerification) -> list[tuple[str, dict[str, Any]]]:
    out = [(f"{g} case", rs) for g, rs in res.runs.items()]
    out += [(f"Monte-Carlo run {k + 1}", rs) for k, rs in enumerate(res.mc)]
    return out


def judge(res: SelftriggerVerification) -> tuple[Claim, ...]:
    """The verdicts (rules written in each claim's ``rule``)."""
    pairs = _pairs(res)
    tau = float(res.bound.value)
    tol = 1e-9 * max(1.0, tau)
    claims: list[Claim] = []
    # 1. no continuous monitoring
    ok = all(np.array_equal(rs["self-triggered"].evaluations, rs["self-triggered"].transmissions)
             for _, rs in pairs)
    ev = sum(int(rs["event"].evaluations.sum()) for _, rs in pairs)
    evt = sum(rs["event"].total_transmissions for _, rs in pairs)
    st = sum(rs["self-triggered"].total_transmissions for _, rs in pairs)
    claims.append(Claim(
        "no_continuous_monitoring", "the self-triggered scheme needs no continuous monitoring",
        "holds iff in every run each spacecraft evaluates its trigger function exactly once per "
        "own broadcast (the next time is computed then; nothing is evaluated in between)",
        Verdict.HOLDS if ok else Verdict.FAILS,
        f"self-triggered: {st} evaluations for {st} broadcasts in {len(pairs)} runs; the "
        f"event-triggered variant evaluated its trigger {ev} times for {evt} broadcasts"))
    # 2. no Zeno
    worst = min(min(rs["self-triggered"].interevent_min for _, rs in pairs), math.inf)
    ev_in = [rs["event"] for _, rs in pairs if rs["event"].f_ratio <= 1]
    ev_worst = min((r.interevent_min for r in ev_in), default=math.nan)
    ok = tau > 0 and worst >= tau - tol and (not ev_in or ev_worst >= tau - tol)
    claims.append(Claim(
        "no_zeno", "no Zeno behaviour",
        "holds iff the certified lower bound tau_min > 0 and no measured inter-event time (every "
        "self-triggered run; every event-triggered run where |f_i| <= delta held) is below it",
        Verdict.HOLDS if ok else Verdict.FAILS,
        f"tau_min = {res.bound.formula} = {tau:.6g} s; smallest measured: self-triggered "
        f"{worst:.6g} s, event-triggered {ev_worst:.6g} s ({len(ev_in)} of {len(pairs)} event runs "
        "inside the delta assumption)"))
    # 3. fewer computations
    rat = [int(rs["event"].evaluations.sum()) / max(1, int(rs["self-triggered"].evaluations.sum()))
           for _, rs in pairs]
    ok = all(r > 1 for r in rat)
    claims.append(Claim(
        "fewer_computations", "fewer computations than event-triggering",
        "holds iff in every run the self-triggered scheme evaluates its trigger fewer times than "
        "the event-triggered one (whose count is the exact integrator's evaluations, a lower bound "
        "of any continuous or digital monitor's)",
        Verdict.HOLDS if ok else Verdict.FAILS,
        f"event/self trigger evaluations: {min(rat):.3g} to {max(rat):.3g}"))
    # 4. trigger rate moderately above event-triggering
    R = [rs["self-triggered"].total_transmissions / max(1, rs["event"].total_transmissions)
         for _, rs in pairs]
    lim = res.config["moderate_ratio"]
    ok = all(1 < r <= lim for r in R)
    claims.append(Claim(
        "moderate_rate", "a trigger rate moderately above event-triggering",
        f"holds iff in every run 1 < (self-triggered / event-triggered transmissions) <= {lim:g} "
        "(the case's reading of 'moderately')",
        Verdict.HOLDS if ok else Verdict.FAILS,
        f"transmission ratio {min(R):.3g} to {max(R):.3g}"))
    # 5. better performance than event-triggering
    acc = [(rs["self-triggered"].tail_angle_deg, rs["event"].tail_angle_deg) for _, rs in pairs]
    ok = all(a < b for a, b in acc)
    claims.append(Claim(
        "better_than_event", "better control performance than event-triggering",
        "holds iff in every run the self-triggered scheme's accuracy (largest angle to the leader "
        "over the tail) is better than the event-triggered one's",
        Verdict.HOLDS if ok else Verdict.FAILS,
        "self/event tail accuracy ratio " + _range([a / b for a, b in acc])))
    # 6. better accuracy than periodic at equal transmissions
    acc = [(rs["self-triggered"].tail_angle_deg, rs["periodic-equal"].tail_angle_deg) for _, rs in pairs]
    ok = all(a < b for a, b in acc)
    wins = sum(a < b for a, b in acc)
    claims.append(Claim(
        "better_than_periodic", "better accuracy than periodic sampling at equal transmissions",
        "holds iff in every run the self-triggered accuracy is better than periodic sampling's "
        "with the period giving the same transmissions per spacecraft",
        Verdict.HOLDS if ok else Verdict.FAILS,
        f"better in {wins} of {len(acc)} runs; self/periodic tail accuracy ratio "
        + _range([a / b for a, b in acc])))
    if res.theorem is not None:
        from formsync_design.verify.theoremcheck import theorem_claim

        text, measured, verdict, rule = theorem_claim(res.theorem)
        claims.append(Claim("theorem", text, rule, Verdict(verdict), measured))
    return tuple(claims)


def _range(v: list[float]) -> str:
    return f"{min(v):.3g} to {max(v):.3g}" if v else "none"


def verify_selftrigger_case(req: VerifyRequest) -> int:
    """``formsync verify`` on a ``selftrigger`` case (exit status: :mod:`~formsync_design.verify.kinds`)."""

    from formsync_design.verify.agentcase import load_agent_case
    from formsync_design.verify.output import display_path
    from formsync_design.verify.selftrigger_report import write_selftrigger_report

    case = load_agent_case(req.path, design=req.design)
    res = verify_selftrigger(case, progress=req.progress)
    req.progress("write report")
    cmd = req.command()
    md, figs = write_selftrigger_report(res, req.out, req.path.stem, display_path(req.path), cmd)
    if req.format == "json":
        sys.stdout.write(json.dumps(res.to_dict(), indent=1, sort_keys=True) + "\n")
    else:
        sys.stdout.write(f"wrote {md} ({len(figs)} figures)\n")
        for c in res.claims:
            sys.stdout.write(f"  {c.verdict:10s} {c.text}\n")
    return 1 if req.strict and not res.all_hold else 0
