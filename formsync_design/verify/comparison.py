"""The ``agent-comparison`` case kind: several agent designs on one formation, a paper's
claims about them judged in the run (Ma, Dong, Ma, Wang, seed paper 002, is the shipped case
``verification/ma_so3.toml``).

The case file is an agent case (:mod:`formsync_design.verify.agentcase`: the main design, the
digraph, gains, case-1 spacecraft, simulation options) whose free-form ``[claims]`` holds::

    qa_threshold_deg, tolerance (relative, for "comparable" times), torque_spacecraft,
    torque_after_s, torque_fraction, final_angle_deg, final_rate, min_command
    [claims.paper]            label, time_to_qa (s)                    (the main design)
    [claims.compare.NAME]     design, label, time_to_qa, switch, boundary_layer, gains = {...}
    [claims.case2]            tf, spacecraft = [{euler_deg, rate}, ...]  (inertias of case 1)
    [claims.montecarlo]       runs, seed, max_euler_deg, max_rate
    [claims.near180]          angle_deg, tf, baselines = {liang2016 = {...}, pd_consensus = {...}}
    [claims.certify]          boxes = [{K1 = "lo:hi", ...}, ...], graphs = {label = spec | arcs}
    [claims.equal_torque]     hold = [gain names not scaled], rtol (optional: the comparisons
                              rerun at equal peak torque, :mod:`~formsync_design.analysis.equal_torque`)

Every verdict is computed here (:func:`run_comparison`); the report is written by
:mod:`formsync_design.verify.comparison_report`.  Verdicts: ``holds``, ``fails``,
``comparable`` / ``differs`` (a time against the paper's within / outside ``tolerance``).
"""

from __future__ import annotations

import math
import sys
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from formsync_design.analysis.equal_torque import in_order
from formsync_design.errors import InputError
from formsync_design.models.euler import jumps, pitch_yaw_roll, qa_error, quats_to_matrices
from formsync_design.sim.agents import AgentFormation, simulate_agents
from formsync_design.sim.formation import Gains
from formsync_design.verify.agentcase import AgentCase, euler321_to_quat, load_agent_case
from formsync_design.verify.kinds import VerifyRequest

__all__ = [
    "Method",
    "MethodRun",
    "Claim",
    "ComparisonResult",
    "method_list",
    "run_method",
    "run_comparison",
    "classic_run",
    "verify_comparison_case",
]


@dataclass(frozen=True)
class Method:
    """A design of the comparison: its name, loaded design, gains, switch and the paper's time."""

    key: str
    label: str
    design: Any
    gains: Gains
    switch: str = "sgn"
    phi: float = 0.01
    paper_time: float | None = None


@dataclass(frozen=True)
class MethodRun:
    """One simulated run summarised (arrays on the output grid)."""

    key: str
    label: str
    t: np.ndarray
    angles: np.ndarray          # (T, N, 3) pitch, yaw, roll (deg)
    qa: np.ndarray              # (T,) deg
    disagreement: np.ndarray    # (T,) largest principal angle (deg)
    r23: np.ndarray             # (T, N)
    torques: np.ndarray         # (T, N, 3)
    time_to_qa: float | None
    time_to_angle: float | None
    final_angle: float
    final_rate: float
    peak_torque: float
    effort: float
    orthonormality: float       # max |R^T R - I| over the run
    common_rate: float          # |mean body rate| at the end (rad/s): a common rotation
    monitors: dict[str, tuple[float, float]]
    monitor_series: dict[str, np.ndarray] = field(default_factory=dict)
    status: str = ""


@dataclass(frozen=True)
class Claim:
    key: str
    text: str
    paper: str
    measured: str
    verdict: str
    note: str = ""


@dataclass(frozen=True)
class ComparisonResult:
    case: AgentCase
    methods: tuple[Method, ...]
    case1: tuple[MethodRun, ...]
    case2: tuple[MethodRun, ...]
    montecarlo: dict[str, Any]
    near180: tuple[dict[str, Any], ...]
    baselines: tuple[dict[str, Any], ...]
    certificates: tuple[Any, ...]
    graph_runs: tuple[dict[str, Any], ...]
    derivation: Any
    claims: tuple[Claim, ...]
    settings: dict[str, Any]
    equal_torque: dict[str, Any] | None = None
    theorem: Any = None

    @property
    def all_hold(self) -> bool:
        return all(c.verdict in ("holds", "comparable") for c in self.claims)


# ---------------------------------------------------------------------------- configuration


def _table(d: Any, where: str) -> dict:
    if not isinstance(d, dict):
        raise InputError(f"expected a table [{where}] in the case file, received {d!r}")
    return d


def _num(d: Mapping[str, Any], k: str, where: str, default: Any = None) -> float:
    v = d.get(k, default)
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise InputError(f"expected a number for {where}.{k}, received {v!r}")
    return float(v)


def method_list(case: AgentCase) -> tuple[Method, ...]:
    """The main design and the ``[claims.compare]`` designs (validated)."""
    from formsync_design.spec.loader import load_design

    cl = case.claims
    paper = _table(cl.get("paper", {}), "claims.paper")
    out = [Method("main", str(paper.get("label", case.design.name)), case.design, case.gains,
                  case.options.switch, case.options.phi,
                  _num(paper, "time_to_qa", "claims.paper") if "time_to_qa" in paper else None)]
    for key, t in _table(cl.get("compare", {}), "claims.compare").items():
        t = _table(t, f"claims.compare.{key}")
        d = load_design(str(t.get("design", key)))
        if getattr(d, "form", None) != "agent":
            raise InputError(f"expected an agent design in claims.compare.{key}, received {d.name!r}")
        g = _table(t.get("gains", {}), f"claims.compare.{key}.gains")
        if set(g) != set(d.decl.controller_gains):
            raise InputError(f"expected claims.compare.{key}.gains with exactly "
                             f"{list(d.decl.controller_gains)}, received {sorted(g)}")
        out.append(Method(key, str(t.get("label", d.name)), d,
                          Gains({k: float(g[k]) for k in d.decl.controller_gains}),
                          str(t.get("switch", "sgn")), float(t.get("boundary_layer", 0.01)),
                          _num(t, "time_to_qa", f"claims.compare.{key}")
                          if "time_to_qa" in t else None))
    return tuple(out)


def _attitudes(rows: Any, where: str, n: int) -> tuple[np.ndarray, np.ndarray]:
    if not isinstance(rows, list) or len(rows) != n:
        raise InputError(f"expected {n} spacecraft in {where}, received {rows!r}"[:200])
    Q, W = [], []
    for i, r in enumerate(rows, 1):
        r = _table(r, f"{where}[{i}]")
        e, w = r.get("euler_deg"), r.get("rate", [0, 0, 0])
        if not (isinstance(e, list) and len(e) == 3 and isinstance(w, list) and len(w) == 3):
            raise InputError(f"expected euler_deg = [3] and rate = [3] in {where}[{i}], received {r!r}")
        Q.append(euler321_to_quat(*(float(x) for x in e)))
        W.append([float(x) for x in w])
    return np.array(Q), np.array(W)


# ------------------------------------------------------------------------------------ runs


def run_method(case: AgentCase, m: Method, attitudes: np.ndarray | None = None,
               rates: np.ndarray | None = None, tf: float | None = None,
               graph: Any = None, threshold: float = 1.0, series: bool = True) -> MethodRun:
    """Simulate ``m`` on the case's formation (optionally other initial conditions, horizon,
    graph) and summarise it."""
    f = case.formation(graph)
    f = AgentFormation(f.graph, f.inertias, f.attitudes if attitudes is None else attitudes,
                       f.rates if rates is None else rates, m.gains, f.disturbance)
    opt = replace(case.options, switch=m.switch, phi=m.phi, tf=tf or case.options.tf)
    r = simulate_agents(m.design, f, opt)
    R = quats_to_matrices(r.quaternions)
    A = pitch_yaw_roll(R)
    qa = qa_error(A)
    ok = qa <= threshold
    bad = np.nonzero(~ok)[0]
    tqa = None if not ok[-1] else float(r.t[0] if bad.size == 0 else r.t[bad[-1] + 1])
    orth = float(np.abs(np.einsum("...ki,...kj->...ij", R, R) - np.eye(3)).max())
    mons = {k: (float(np.nanmin(v)), float(np.nanmax(v))) for k, v in r.monitors.items()}
    return MethodRun(
        key=m.key, label=m.label, t=r.t, angles=A if series else A[-1:], qa=qa,
        disagreement=r.attitude_error, r23=R[:, :, 1, 2] if series else R[-1:, :, 1, 2],
        torques=r.torques if series else r.torques[-1:], time_to_qa=tqa,
        time_to_angle=r.time_to(threshold), final_angle=float(r.attitude_error[-1]),
        final_rate=float(r.rate_error[-1]), peak_torque=float(r.peak_torque.max()),
        effort=float(np.sum(r.effort)), orthonormality=orth,
        common_rate=float(np.linalg.norm(r.rates[-1].mean(axis=0))), monitors=mons,
        monitor_series=dict(r.monitors) if series else {}, status=str(r.status))


def _montecarlo(case: AgentCase, methods: tuple[Method, ...], cfg: Mapping[str, Any],
                threshold: float, progress: Callable[[str], None]) -> dict[str, Any]:
    runs = int(_num(cfg, "runs", "claims.montecarlo", 20))
    seed = int(_num(cfg, "seed", "claims.montecarlo", 1))
    amax = _num(cfg, "max_euler_deg", "claims.montecarlo", 60)
    wmax = _num(cfg, "max_rate", "claims.montecarlo", 0.1)
    tf = _num(cfg, "tf", "claims.montecarlo", case.options.tf)
    if not 1 <= runs <= 10_000:
        raise InputError(f"expected 1..10000 Monte-Carlo runs, received {runs}")
    rng = np.random.default_rng(seed)
    times: dict[str, list[float | None]] = {m.key: [] for m in methods}
    for k in range(runs):
        E = rng.uniform(-amax, amax, size=(case.n, 3))
        W = rng.uniform(-wmax, wmax, size=(case.n, 3))
        Q = np.array([euler321_to_quat(*e) for e in E])
        for m in methods:
            r = run_method(case, m, Q, W, tf=tf, threshold=threshold, series=False)
            times[m.key].append(r.time_to_qa)
        if (k + 1) % 10 == 0:
            progress(f"Monte-Carlo {k + 1}/{runs}")
    keys = [m.key for m in methods]
    ordered = 0
    for j in range(runs):
        if in_order([times[key][j] for key in keys]):
            ordered += 1
    return {"runs": runs, "seed": seed, "max_euler_deg": amax, "max_rate": wmax, "tf": tf,
            "times": times, "ordered": ordered}


def _near180(case: AgentCase, methods: tuple[Method, ...], cfg: Mapping[str, Any],
             threshold: float) -> tuple[dict[str, Any], ...]:
    """Spacecraft 2..N start ``angle_deg`` from spacecraft 1 (about the body axes in turn, zero
    rates); every agent method and the Lagrangian baselines (classic simulator)."""
    ang = _num(cfg, "angle_deg", "claims.near180", 175)
    tf = _num(cfg, "tf", "claims.near180", case.options.tf)
    axes = np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 0], [0, 1, 1], [1, 0, 1]], float)
    Q = [np.array([0, 0, 0, 1.0])]
    for i in range(1, case.n):
        a = axes[(i - 1) % len(axes)] / np.linalg.norm(axes[(i - 1) % len(axes)])
        h = math.radians(ang) / 2
        Q.append(np.array([*(math.sin(h) * a), math.cos(h)]))
    Qa = np.array(Q)
    W = np.zeros((case.n, 3))
    rows: list[dict[str, Any]] = []
    for m in methods:
        r = run_method(case, m, Qa, W, tf=tf, threshold=threshold, series=False)
        rows.append({"label": m.label, "status": r.status, "time": r.time_to_angle,
                     "final": r.final_angle, "peak": r.peak_torque, "effort": r.effort,
                     "note": _monitor_note(r)})
    for name, gains in _table(cfg.get("baselines", {}), "claims.near180.baselines").items():
        rows.append(_baseline(case, name, _table(gains, f"claims.near180.baselines.{name}"),
                              Qa, W, tf, threshold))
    return tuple(rows)


def _monitor_note(r: MethodRun) -> str:
    parts = []
    if "det_E" in r.monitors:
        parts.append(f"min det E {r.monitors['det_E'][0]:.3g}")
    if "cmd" in r.monitors:
        parts.append(f"min command conditioning {r.monitors['cmd'][0]:.3g}")
    if "q0_rel" in r.monitors:
        parts.append(f"min relative q0 {r.monitors['q0_rel'][0]:.3g}")
    if "sigma_norm" in r.monitors:
        parts.append(f"max |sigma| {r.monitors['sigma_norm'][1]:.3g}")
    return "; ".join(parts)


def classic_run(case: AgentCase, name: str, gains: Mapping[str, Any], Q: np.ndarray,
                W: np.ndarray, tf: float, threshold: float = 1.0) -> dict[str, Any]:
    """A Lagrangian design (``liang2016``, ``pd_consensus``) on the case's digraph through the
    classic simulator (``q0 > 0`` chosen per spacecraft, as it requires)."""
    import formsync_design as fs
    from formsync_design.models.disturbances import no_disturbance
    from formsync_design.sim.agents import attitude_disagreement
    from formsync_design.sim.formation import Formation, SimOptions

    Qp = np.where(Q[:, 3:4] < 0, -Q, Q)
    g = {k: float(v) for k, v in gains.items() if k != "switch"}
    if name == "liang2016":
        G = Gains(g["K_o"], g["K_q"], g["beta"], (g["K_v"],) * case.n)
    else:
        G = Gains(g)
    o = case.options
    f = Formation(case.graph(), case.inertias, Qp, W, G, no_disturbance(case.n))
    r = fs.simulate(f, SimOptions(tf=tf, output_step=o.output_step, step=o.step,
                                  switch=str(gains.get("switch", "sat")), phi=o.phi),
                    spec=name)
    n = case.n
    Qt = r.x[:, : 4 * n].reshape(len(r.t), n, 4)
    dis = attitude_disagreement(Qt)
    ok = dis <= threshold
    bad = np.nonzero(~ok)[0]
    t1 = None if not ok[-1] else float(r.t[0] if bad.size == 0 else r.t[bad[-1] + 1])
    U = r.u.reshape(len(r.t), n, 3)
    effort = float(np.sum(np.trapezoid(np.sum(U * U, axis=2), r.t, axis=0)))
    Wt = r.x[:, 4 * n:].reshape(len(r.t), n, 3)
    rate = float(np.linalg.norm(Wt[-1][:, None, :] - Wt[-1][None, :, :], axis=2).max())
    o_ = case.options
    status = ("converged" if dis[-1] <= o_.angle_tol and rate <= o_.rate_tol else "not-converged")
    note = (f"stopped at q0 -> 0 (spacecraft {r.singular_spacecraft}, t = {r.singular_time:g} s)"
            if r.singular_spacecraft is not None else f"min q0 {float(np.min(r.min_q0)):.3g}")
    if r.singular_spacecraft is not None:
        status = "singular"
    return {"label": name, "status": status, "time": t1, "final": float(dis[-1]),
            "peak": float(np.abs(U).max()), "effort": effort, "note": note}


def _baseline(case: AgentCase, name: str, gains: Mapping[str, Any], Q: np.ndarray,
              W: np.ndarray, tf: float, threshold: float) -> dict[str, Any]:
    if name not in ("liang2016", "pd_consensus"):
        raise InputError(f"expected baselines among ['liang2016', 'pd_consensus'], received {name!r}")
    return classic_run(case, name, gains, Q, W, tf, threshold)


def _graph_runs(case: AgentCase, main: Method, graphs: Mapping[str, Any],
                tf: float) -> tuple[dict[str, Any], ...]:
    out = []
    for label, spec in graphs.items():
        r = run_method(case, main, tf=tf, graph=_graph_spec(spec, case.n, label), series=False)
        out.append({"graph": label, "status": r.status, "final": r.final_angle,
                    "time": r.time_to_angle})
    return tuple(out)


def _graph_spec(spec: Any, n: int, label: str) -> Any:
    from formsync_design.graphs.digraph_io import digraph_from_edges

    if isinstance(spec, list):
        return digraph_from_edges([tuple(a) for a in spec], n=n, name=label)
    return spec


# ---------------------------------------------------------------------------------- claims


def _fmt(t: float | None) -> str:
    return "not reached" if t is None else f"{t:.2f} s"


def judge(res_case1: tuple[MethodRun, ...], res_case2: tuple[MethodRun, ...],
          methods: tuple[Method, ...], cl: Mapping[str, Any], n: int) -> tuple[Claim, ...]:
    """The claims table (module docstring; every number computed in the run)."""
    thr = _num(cl, "qa_threshold_deg", "claims", 1.0)
    tol = _num(cl, "tolerance", "claims", 0.25)
    fa = _num(cl, "final_angle_deg", "claims", 0.01)
    fr = _num(cl, "final_rate", "claims", 1e-4)
    sc = int(_num(cl, "torque_spacecraft", "claims", n))
    after = _num(cl, "torque_after_s", "claims", 10.0)
    frac = _num(cl, "torque_fraction", "claims", 0.01)
    cmin = _num(cl, "min_command", "claims", 0.05)
    main = res_case1[0]
    out = []
    ok = main.final_angle <= fa and main.final_rate <= fr
    out.append(Claim("consensus", "every spacecraft converges to a common attitude (case 1)",
                     "Figs. 2-4", f"final disagreement {main.final_angle:.2g} deg, rate "
                     f"{main.final_rate:.2g} rad/s at {main.t[-1]:g} s",
                     "holds" if ok else "fails", f"within {fa:g} deg and {fr:g} rad/s"))
    u = np.linalg.norm(main.torques[:, sc - 1, :], axis=1)
    late = u[main.t >= after]
    ratio = float(late.max() / u.max()) if late.size and u.max() > 0 else float("nan")
    k = np.nonzero(u > frac * u.max())[0]
    t_small = float(main.t[k[-1] + 1]) if k.size and k[-1] + 1 < len(main.t) else None
    out.append(Claim("torques_vanish", f"spacecraft {sc}'s torque converges to 0 after about "
                     f"{after:g} s", "Fig. 5", f"max |M_{sc}| after {after:g} s = {ratio:.3g} x "
                     f"its peak; below {frac:g} x peak from {_fmt(t_small)}; the formation "
                     f"keeps a common rotation of {main.common_rate:.3g} rad/s",
                     "holds" if ratio <= frac else "fails", f"'vanished' = at most {frac:g} x the peak; "
                     "no term of the law damps the common motion (A8: the command moves with the "
                     "neighbours), so the formation keeps rotating together, and keeping "
                     "bodies of different inertia in one rotation takes torque"))
    for m, r in zip(methods, res_case1):
        if m.paper_time is None:
            continue
        if r.time_to_qa is None:
            v, meas = "fails", "not reached"
        else:
            rel = (r.time_to_qa - m.paper_time) / m.paper_time
            v = "comparable" if abs(rel) <= tol else "differs"
            meas = f"{r.time_to_qa:.2f} s ({rel:+.0%})"
        out.append(Claim(f"qa_{m.key}", f"Qa reaches {thr:g} deg at {m.paper_time:g} s "
                         f"({m.label})", "Fig. 6", meas, v,
                         f"comparable within +-{tol:.0%}; initial conditions reconstructed"))
    ts = [r.time_to_qa for r in res_case1]
    ordered = in_order(ts)
    out.append(Claim("ordering", "the SO(3) design reaches Qa <= 1 deg first, then the "
                     "quaternion, then the MRP design", "Fig. 6: 4.89 < 5.15 < 9.29 s",
                     " < ".join(_fmt(t) for t in ts), "holds" if ordered else "fails",
                     "robustness over random initial conditions: sensitivity study"))
    m2 = res_case2[0]
    ok2 = m2.final_angle <= fa and m2.final_rate <= fr
    out.append(Claim("consensus_case2", "case 2 (large, far-apart attitudes) converges",
                     "Figs. 7-10", f"final disagreement {m2.final_angle:.2g} deg at {m2.t[-1]:g} s",
                     "holds" if ok2 else "fails"))
    cmd = m2.monitors.get("cmd", (float("nan"), float("nan")))[0]
    det = m2.monitors.get("det_E", (float("nan"), float("nan")))
    finite = bool(np.all(np.isfinite(m2.torques)))
    nosing = finite and cmd >= cmin
    out.append(Claim("no_singularity_case2", "no singularity in case 2 (the law stays defined)",
                     "section 4, case 2", f"command conditioning >= {cmd:.3g}; det E in "
                     f"[{det[0]:.3g}, {det[1]:.3g}]; torques finite: {finite}",
                     "holds" if nosing else "fails",
                     f"defined = command conditioning >= {cmin:g} (A1) and finite torques; E is "
                     "never inverted (A4)" + ("; det E changed sign: a law with E^-1 would have "
                                              "been undefined" if det[0] < 0 < det[1] else "")))
    ej = jumps(m2.angles.reshape(len(m2.t), -1))
    step = float(np.abs(np.diff(m2.r23, axis=0)).max())
    ok3 = bool(ej) and step < 0.5
    first = (f"first at t = {m2.t[ej[0][0]]:.2f} s (spacecraft {ej[0][1] // 3 + 1}, "
             f"{('pitch', 'yaw', 'roll')[ej[0][1] % 3]})" if ej else "none")
    out.append(Claim("r23_continuous", "Euler angles jump while R_23 evolves continuously "
                     "(case 2)", "Figs. 8, 11", f"{len(ej)} angle jumps > 90 deg between samples, "
                     f"{first}; largest R_23 step {step:.3g}", "holds" if ok3 else "fails",
                     "continuous = R_23 changes by less than 0.5 per output step"))
    return tuple(out)


# --------------------------------------------------------------------------------- driver


def run_comparison(case: AgentCase, progress: Callable[[str], None] = lambda s: None
                   ) -> ComparisonResult:
    """Every run, the certificates and the claims of a comparison case."""
    from formsync_design.certify.agentgraphs import certify_agent_graphs

    cl = case.claims
    methods = method_list(case)
    thr = _num(cl, "qa_threshold_deg", "claims", 1.0)
    progress("case 1")
    c1 = tuple(run_method(case, m, threshold=thr) for m in methods)
    c2cfg = _table(cl.get("case2", {}), "claims.case2")
    Q2, W2 = _attitudes(c2cfg.get("spacecraft"), "claims.case2.spacecraft", case.n)
    progress("case 2")
    c2 = tuple(run_method(case, m, Q2, W2, tf=_num(c2cfg, "tf", "claims.case2", case.options.tf),
                          threshold=thr) for m in methods)
    progress("Monte-Carlo")
    mc = _montecarlo(case, methods, _table(cl.get("montecarlo", {}), "claims.montecarlo"), thr,
                     progress)
    progress("near 180 deg")
    ncfg = _table(cl.get("near180", {}), "claims.near180")
    n180 = _near180(case, methods, ncfg, thr)
    progress("Lagrangian baselines, case 1")
    base = [{"label": m.label, "status": r.status, "time": r.time_to_angle, "final": r.final_angle,
             "peak": r.peak_torque, "effort": r.effort, "note": _monitor_note(r)}
            for m, r in zip(methods, c1)]
    for name, gains in _table(ncfg.get("baselines", {}), "claims.near180.baselines").items():
        base.append(_baseline(case, name, _table(gains, f"claims.near180.baselines.{name}"),
                              case.attitudes, case.rates, case.options.tf, thr))
    ccfg = _table(cl.get("certify", {}), "claims.certify")
    graphs = _table(ccfg.get("graphs", {}), "claims.certify.graphs")
    boxes = ccfg.get("boxes", [])
    if not isinstance(boxes, list) or not boxes:
        raise InputError("expected claims.certify.boxes = [{K1 = 'lo:hi', ...}, ...]")
    progress("certificates")
    certs = []
    for b in boxes:
        box = dict(_table(b, "claims.certify.boxes[]"))
        certs.append((box, certify_agent_graphs(case.design, [_graph_spec(s, case.n, k)
                                                              for k, s in graphs.items()],
                                                box, names=list(graphs))))
    progress("graph family runs")
    gr = _graph_runs(case, methods[0], graphs, _num(ccfg, "tf", "claims.certify", case.options.tf))
    from formsync_design.derive.so3_sliding import derive_sliding, det_E_factorisation, power_lemmas

    mod = case.design.module
    der = None
    if callable(mod.get("tracking_law")) and callable(mod.get("errors")):
        der = {"sliding": derive_sliding(mod["tracking_law"], mod["errors"], mod["GAINS"]),
               "det_E": det_E_factorisation(), "lemmas": power_lemmas()}
    claims = judge(c1, c2, methods, cl, case.n)
    progress("theorem checked on graph families")
    from formsync_design.verify.theoremcheck import check_theorem

    tc = check_theorem(case)
    claims += (_theorem_claim(tc),)
    settings = {"threshold": thr}
    eq = None
    if "equal_torque" in cl:
        progress("equal peak torque")
        eq = _equal_torque(case, methods, (c1, c2, mc, n180), (Q2, W2, c2cfg), ncfg, thr, progress)
    return ComparisonResult(case, methods, c1, c2, mc, n180, tuple(base), tuple(certs), gr, der,
                            claims, settings, eq, tc)


def _theorem_claim(tc: Any) -> Claim:
    """The design's theorem (its declared graph class suffices) judged by the formation
    certificate on graph families (:func:`~formsync_design.verify.theoremcheck.theorem_claim`)."""
    from formsync_design.verify.theoremcheck import theorem_claim

    text, measured, verdict, rule = theorem_claim(tc)
    return Claim("theorem", "Theorem 1: " + text, "yes (theorem)", measured, verdict, rule)


def _equal_torque(case: AgentCase, methods: tuple[Method, ...], literal: tuple[Any, ...],
                  init2: tuple[Any, ...], ncfg: Mapping[str, Any], thr: float,
                  progress: Callable[[str], None]) -> dict[str, Any]:
    """The comparisons rerun with each comparison design's gains scaled to the main design's
    peak torque on case 1 (:mod:`~formsync_design.analysis.equal_torque`)."""
    from formsync_design.analysis.equal_torque import equal_peak_scale, scaled_gains

    cfg = _table(case.claims["equal_torque"], "claims.equal_torque")
    hold = cfg.get("hold", [])
    if not isinstance(hold, list) or not all(isinstance(h, str) for h in hold):
        raise InputError(f"expected claims.equal_torque.hold a list of gain names, received {hold!r}")
    rtol = _num(cfg, "rtol", "claims.equal_torque", 1e-3)
    c1, c2, mc, n180 = literal
    Q2, W2, c2cfg = init2
    target = c1[0].peak_torque
    scaled, searches = [methods[0]], {}
    for m, r in zip(methods[1:], c1[1:]):
        def peak(c: float, m: Method = m) -> float:
            return run_method(case, replace(m, gains=scaled_gains(m.gains, c, hold)), threshold=thr,
                              series=False).peak_torque
        ep = equal_peak_scale(peak, target, rtol=rtol, start=target / r.peak_torque, step=1.1)
        searches[m.key] = ep
        scaled.append(replace(m, gains=scaled_gains(m.gains, ep.scale, hold)))
    others = tuple(scaled[1:])
    e1 = (c1[0],) + tuple(run_method(case, m, threshold=thr, series=False) for m in others)
    tf2 = _num(c2cfg, "tf", "claims.case2", case.options.tf)
    e2 = (c2[0],) + tuple(run_method(case, m, Q2, W2, tf=tf2, threshold=thr, series=False)
                          for m in others)
    emc = _montecarlo(case, others, _table(case.claims.get("montecarlo", {}), "claims.montecarlo"),
                      thr, progress)
    times = {methods[0].key: mc["times"][methods[0].key], **emc["times"]}
    ordered = sum(in_order([times[m.key][j] for m in scaled]) for j in range(mc["runs"]))
    near = _near180(case, others, {k: v for k, v in ncfg.items() if k != "baselines"}, thr)
    return {"hold": list(hold), "rtol": rtol, "target": target, "searches": searches,
            "methods": tuple(scaled), "case1": e1, "case2": e2,
            "montecarlo": {"runs": mc["runs"], "times": times, "ordered": ordered},
            "near180": (n180[0],) + near}


def verify_comparison_case(req: VerifyRequest) -> int:
    """``formsync verify`` of an ``agent-comparison`` case (exit status:
    :mod:`formsync_design.verify.kinds`)."""
    import json

    from formsync_design.verify.comparison_report import comparison_json, write_comparison_report

    case = load_agent_case(req.path, design=req.design)
    res = run_comparison(case, req.progress)
    req.progress("write report")
    cmd = req.command()
    md, figs = write_comparison_report(res, req.out, req.path.stem, cmd)
    if req.format == "json":
        sys.stdout.write(json.dumps(comparison_json(res), indent=2) + "\n")
    else:
        sys.stdout.write(f"wrote {md} ({len(figs)} figures)\n")
        for c in res.claims:
            sys.stdout.write(f"  {c.verdict:12s} {c.text}\n")
    if req.strict and not res.all_hold:
        return 1
    return 0
