"""Verification of a published design: re-derive, certify, simulate, judge the claims.

A case file (``verification/liang2016.toml``) holds the published simulation
case and a ``[claims]`` table::

    [claims]
    topologies = ["ring:8", ...]          # candidate graphs to verify over
    topology_note = "why these"
    saturation_torque_limit = 1.0         # N m per axis, for the saturation claim
    tail_fraction = 0.2                   # steady state = the last 20 % of the horizon
    phi_sweep = [...]                     # boundary layers for the sensitivity study
    torque_limit_sweep = [...]            # torque limits (N m; 0 = unlimited)

    [claims.items.KEY]
    text = "what the paper claims"
    paper = "where / how it says it"
    quantity = "convergence_time"         # one of QUANTITIES
    op = "<="                             # <=, <, >=, >, ==
    value = 150.0
    unit = "s"
    note = "how the claim is read"

Each claim is measured on every candidate topology; its verdict is ``holds``
(on all), ``fails`` (on all) or ``depends on topology``.
"""

from __future__ import annotations

import json
import math
import operator
from dataclasses import dataclass, field, replace
from fractions import Fraction
from pathlib import Path
from typing import Any

import numpy as np

from formsync_design.errors import InputError

__all__ = [
    "QUANTITIES",
    "ClaimSpec",
    "ClaimResult",
    "TopologyRun",
    "SensitivityRow",
    "VerificationResult",
    "parse_claims",
    "chatter_end_time",
    "verify_case",
    "write_verification_report",
]

#: Quantities a claim can be about (name -> description, unit).
QUANTITIES: dict[str, tuple[str, str]] = {
    "convergence_time": ("first time after which Q_m <= q_tol and Omega_m <= omega_tol to the end "
                         "(inf if never)", "s"),
    "tail_omega_m": ("max Omega_m over the steady-state tail", "rad/s"),
    "tail_q_m": ("max Q_m over the steady-state tail", "-"),
    "final_abs_rate": ("max_i |omega_i| at the end (absolute body rates)", "rad/s"),
    "theta_pd": ("1 if every Theta_i > 0 is certified at the paper's gains (derived conditions)", "-"),
    "pi_pd": ("1 if Pi > 0 is certified at the paper's gains (derived conditions)", "-"),
    "kv_ratio": ("min_i K_vi / K_vi* (K_vi* from the derivation and the disturbance bound)", "-"),
    "saturation_end_time": ("last time any torque component is at the saturation limit "
                            "(run with saturation_torque_limit)", "s"),
    "chatter_end_time": ("last time the torque chatters (3+ direction reversals of a torque "
                         "component within 1 s)", "s"),
}

_OPS = {"<=": operator.le, "<": operator.lt, ">=": operator.ge, ">": operator.gt,
        "==": operator.eq}


@dataclass(frozen=True)
class ClaimSpec:
    """One checkable claim (from the case file)."""

    key: str
    text: str
    paper: str
    quantity: str
    op: str
    value: float
    unit: str = ""
    note: str = ""

    def check(self, measured: float | None) -> bool:
        if measured is None or (isinstance(measured, float) and math.isnan(measured)):
            return False
        return bool(_OPS[self.op](measured, self.value))


@dataclass(frozen=True)
class ClaimResult:
    """A claim with its measured values per topology and the verdict."""

    spec: ClaimSpec
    measured: dict[str, float | None]
    holds_on: dict[str, bool]
    verdict: str
    reason: str

    def to_dict(self) -> dict[str, Any]:
        s = self.spec
        return {
            "key": s.key, "text": s.text, "paper": s.paper, "quantity": s.quantity,
            "criterion": f"{s.quantity} {s.op} {s.value:g} {s.unit}".strip(),
            "measured": {k: _jsonable(v) for k, v in self.measured.items()},
            "holds_on": self.holds_on, "verdict": self.verdict, "reason": self.reason,
        }


@dataclass(frozen=True)
class TopologyRun:
    """Certification and simulation of the case on one candidate topology."""

    graph: str
    lambda_max: float
    max_degree: int
    derived_status: str
    derived_margin: float | None
    paper_status: str
    paper_margin: float | None
    theta_certified: bool
    pi_certified: bool
    sim: dict
    sat_sim: dict
    quantities: dict[str, float | None]


@dataclass(frozen=True)
class SensitivityRow:
    """One run of the sensitivity study."""

    parameter: str
    value: float | None
    convergence_time: float | None
    tail_q_m: float
    tail_omega_m: float
    final_abs_rate: float
    chatter_end_time: float | None
    chatter_reversals_tail: int
    saturation_end_time: float | None
    status: str
    message: str


@dataclass(frozen=True)
class VerificationResult:
    """Everything :func:`verify_case` found."""

    case_name: str
    case_path: str
    topologies: tuple[TopologyRun, ...]
    claims: tuple[ClaimResult, ...]
    sensitivity: tuple[SensitivityRow, ...]
    kv_required: tuple[float, ...]
    ubar: tuple[float, ...]
    assumptions: tuple[str, ...]
    topology_note: str
    derivation_report: str
    derivation_verdicts: tuple[tuple[str, str], ...]
    saturation_torque_limit: float = 0.0
    default_sim: Any = field(default=None, repr=False, compare=False)
    kv_check: Any = field(default=None, repr=False, compare=False)

    @property
    def all_hold(self) -> bool:
        return all(c.verdict == "holds" for c in self.claims)

    def to_dict(self) -> dict[str, Any]:
        return {
            "case": self.case_name,
            "topologies": [
                {"graph": t.graph, "lambda_max_L": t.lambda_max, "max_degree": t.max_degree,
                 "certification": {"derived": t.derived_status, "derived_margin": t.derived_margin,
                                   "paper": t.paper_status, "paper_margin": t.paper_margin},
                 "simulation": t.sim, "quantities": {k: _jsonable(v) for k, v in t.quantities.items()}}
                for t in self.topologies
            ],
            "claims": [c.to_dict() for c in self.claims],
            "sensitivity": [r.__dict__ for r in self.sensitivity],
            "kv_required": list(self.kv_required), "ubar": list(self.ubar),
            "assumptions": list(self.assumptions),
            "derivation_verdicts": [{"key": k, "verdict": v} for k, v in self.derivation_verdicts],
            "all_claims_hold": self.all_hold,
        }


def _jsonable(v: Any) -> Any:
    if v is None:
        return None
    if isinstance(v, float) and math.isinf(v):
        return "inf"
    return v


# ---------------------------------------------------------------------------
# claims parsing
# ---------------------------------------------------------------------------
def parse_claims(table: dict, path: str = "<case>") -> tuple[dict, tuple[ClaimSpec, ...]]:
    """Validate a ``[claims]`` table; return (settings, claims).

    >>> s, c = parse_claims({"topologies": ["ring:4"], "items": {"x": {"text": "t",
    ...     "paper": "p", "quantity": "tail_q_m", "op": "<=", "value": 1e-4}}})
    >>> c[0].quantity, s["topologies"]
    ('tail_q_m', ['ring:4'])
    """
    if not table:
        raise InputError(f"expected a [claims] table in {path}, received none")
    known = {"topologies", "topology_note", "saturation_torque_limit", "tail_fraction",
             "phi_sweep", "torque_limit_sweep", "items"}
    unknown = set(table) - known
    if unknown:
        raise InputError(f"expected [claims] keys {sorted(known)}, received unknown {sorted(unknown)}")
    tops = table.get("topologies")
    if not (isinstance(tops, list) and tops and all(isinstance(t, str) for t in tops)):
        raise InputError(f"expected claims.topologies = a non-empty list of graph specs, received {tops!r}")
    settings = {
        "topologies": list(tops),
        "topology_note": str(table.get("topology_note", "")),
        "saturation_torque_limit": float(table.get("saturation_torque_limit", 1.0)),
        "tail_fraction": float(table.get("tail_fraction", 0.2)),
        "phi_sweep": [float(x) for x in table.get("phi_sweep", [])],
        "torque_limit_sweep": [float(x) for x in table.get("torque_limit_sweep", [])],
    }
    if not 0 < settings["tail_fraction"] < 1:
        raise InputError(f"expected 0 < claims.tail_fraction < 1, received {settings['tail_fraction']}")
    if settings["saturation_torque_limit"] <= 0:
        raise InputError("expected a positive claims.saturation_torque_limit, received "
                         f"{settings['saturation_torque_limit']}")
    if any(x <= 0 for x in settings["phi_sweep"]):
        raise InputError(f"expected positive boundary layers in claims.phi_sweep, received {settings['phi_sweep']}")
    if any(x < 0 for x in settings["torque_limit_sweep"]):
        raise InputError("expected torque limits >= 0 (0 = unlimited) in claims.torque_limit_sweep, "
                         f"received {settings['torque_limit_sweep']}")
    items = table.get("items")
    if not isinstance(items, dict) or not items:
        raise InputError(f"expected [claims.items.NAME] tables in {path}, received none")
    out = []
    for key, it in items.items():
        if not isinstance(it, dict):
            raise InputError(f"expected a table for claims.items.{key}, received {it!r}")
        need = {"text", "paper", "quantity", "op", "value"}
        missing = need - set(it)
        if missing:
            raise InputError(f"expected keys {sorted(need)} in claims.items.{key}, missing {sorted(missing)}")
        extra = set(it) - need - {"unit", "note"}
        if extra:
            raise InputError(f"expected only {sorted(need | {'unit', 'note'})} in claims.items.{key}, "
                             f"received {sorted(extra)}")
        if it["quantity"] not in QUANTITIES:
            raise InputError(f"expected claims.items.{key}.quantity in {sorted(QUANTITIES)}, "
                             f"received {it['quantity']!r}")
        if it["op"] not in _OPS:
            raise InputError(f"expected claims.items.{key}.op in {sorted(_OPS)}, received {it['op']!r}")
        v = it["value"]
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise InputError(f"expected a finite number for claims.items.{key}.value, received {v!r}")
        out.append(ClaimSpec(key=key, text=str(it["text"]), paper=str(it["paper"]),
                             quantity=it["quantity"], op=it["op"], value=float(v),
                             unit=str(it.get("unit", QUANTITIES[it["quantity"]][1])),
                             note=str(it.get("note", ""))))
    return settings, tuple(out)


# ---------------------------------------------------------------------------
# measured quantities
# ---------------------------------------------------------------------------
def _reversals(u: np.ndarray, rel: float = 1e-3) -> np.ndarray:
    """Boolean (T, C): a direction reversal of a torque component at grid point k.

    A reversal is a sign change of consecutive increments whose sizes both
    exceed ``rel`` times the component's peak magnitude (so numerical noise
    and smooth extrema with tiny increments do not count).
    """
    du = np.diff(u, axis=0)
    thr = rel * np.maximum(np.max(np.abs(u), axis=0), 1e-300)
    big = np.abs(du) > thr
    flips = (du[1:] * du[:-1] < 0) & big[1:] & big[:-1]
    out = np.zeros_like(u, dtype=bool)
    out[1:-1] = flips
    return out


def chatter_end_time(t: np.ndarray, u: np.ndarray, window: float = 1.0, count: int = 3) -> float | None:
    """Last time at which some torque component reverses direction ``count`` or
    more times within ``window`` seconds (None if it never chatters).

    >>> t = np.arange(0, 10, 0.1)
    >>> u = np.where(t < 3, np.sign(np.sin(40 * t)), np.exp(-t))[:, None]
    >>> 2.0 < chatter_end_time(t, u) < 3.0
    True
    """
    rev = _reversals(np.asarray(u, float)).any(axis=1)
    idx = np.flatnonzero(rev)
    if idx.size < count:
        return None
    times = t[idx]
    last = None
    for k in range(count - 1, idx.size):
        if times[k] - times[k - count + 1] <= window:
            last = float(times[k])
    return last


def _tail(r: Any, frac: float) -> slice:
    n = len(r.t)
    return slice(int(math.floor(n * (1 - frac))), n)


def _sim_quantities(r: Any, frac: float) -> dict[str, float | None]:
    """Measured quantities of a run; a run stopped at the q0 singularity has
    no steady state, so every quantity is +inf (fails any upper bound)."""
    if r.status == "singular":
        return {k: math.inf for k in ("convergence_time", "tail_omega_m", "tail_q_m",
                                      "final_abs_rate", "chatter_end_time")}
    sl = _tail(r, frac)
    return {
        "convergence_time": r.convergence_time if r.convergence_time is not None else math.inf,
        "tail_omega_m": float(np.max(r.omega_m[sl])),
        "tail_q_m": float(np.max(r.q_m[sl])),
        "final_abs_rate": float(np.max(np.linalg.norm(r.final_rates, axis=1))),
        "chatter_end_time": chatter_end_time(r.t, r.u),
    }


# ---------------------------------------------------------------------------
# the verification
# ---------------------------------------------------------------------------
def verify_case(case_path: str | Path | None = None, *, progress: Any = None) -> VerificationResult:
    """Re-derive, certify, simulate and judge the claims of a case file.

    Parameters
    ----------
    case_path : path, optional
        Default: ``verification/liang2016.toml``.
    progress : callable(str), optional
        Called with a short message before each step.
    """
    from formsync_design.certify.engine import certify_box, check_kv
    from formsync_design.derive.compare import all_findings
    from formsync_design.derive.conditions import derive_conditions, paper_conditions, required_kv
    from formsync_design.derive.report import report_basename
    from formsync_design.sim.simulator import simulate
    from formsync_design.spec.loader import load_spec
    from formsync_design.verify.case import load_case

    say = progress or (lambda msg: None)
    case = load_case(case_path)
    settings, claims = parse_claims(case.claims, case.path)
    frac = settings["tail_fraction"]
    graphs = [case.graph(g) for g in settings["topologies"]]
    gains = case.gains
    box = {"K_o": Fraction(str(gains.K_o)), "K_q": Fraction(str(gains.K_q)),
           "beta": Fraction(str(gains.beta))}
    dist = case.formation(graphs[0]).disturbance
    ubar = dist.bound(case.inertias)
    kv_req = tuple(required_kv(J, float(u)) for J, u in zip(case.inertias, ubar))
    kv = check_kv(list(gains.K_v), list(case.inertias), [float(x) for x in ubar])
    kv_ratio = min(float(k) / r for k, r in zip(gains.K_v, kv_req))

    sims: dict = {}

    def run(g: Any, options: Any) -> Any:
        """Simulate once per (graph, options): the sweeps repeat the default settings."""
        key = (g.name, options)
        if key not in sims:
            sims[key] = simulate(case.formation(g), options)
        return sims[key]

    runs = []
    for g in graphs:
        say(f"certify and simulate {g.name}")
        der = certify_box(derive_conditions(g), box)
        pap = certify_box(paper_conditions(g), box)
        theta_ok = all(fm.status == "certified" for fm in der.families
                       if fm.name.startswith("Theta"))
        pi_ok = all(fm.status == "certified" for fm in der.families if fm.name == "Pi")
        r = run(g, case.options)
        rs = run(g, replace(case.options, torque_limit=settings["saturation_torque_limit"]))
        q = _sim_quantities(r, frac)
        q["theta_pd"] = 1.0 if theta_ok else 0.0
        q["pi_pd"] = 1.0 if pi_ok else 0.0
        q["kv_ratio"] = kv_ratio
        q["saturation_end_time"] = (
            math.inf if rs.status == "singular" else rs.saturation_end_time)
        runs.append(TopologyRun(
            graph=g.name, lambda_max=float(g.laplacian_spectral_radius), max_degree=max(g.degrees),
            derived_status=der.status, derived_margin=_margin(der), paper_status=pap.status,
            paper_margin=_margin(pap), theta_certified=theta_ok, pi_certified=pi_ok,
            sim=r.summary(), sat_sim=rs.summary(), quantities=q,
        ))
        if g is graphs[0]:
            default_result = r

    results = []
    for c in claims:
        measured = {t.graph: t.quantities.get(c.quantity) for t in runs}
        holds = {k: c.check(v) for k, v in measured.items()}
        if all(holds.values()):
            verdict, reason = "holds", "on every candidate topology"
        elif not any(holds.values()):
            verdict, reason = "fails", "on every candidate topology"
        else:
            ok = [k for k, v in holds.items() if v]
            bad = [k for k, v in holds.items() if not v]
            verdict = "depends on topology"
            reason = f"holds on {', '.join(ok)}; fails on {', '.join(bad)}"
        sing = [t for t in runs if (t.sat_sim if c.quantity == "saturation_end_time" else t.sim)
                ["status"] == "singular"]
        if sing:
            reason += "; runs stopped at the q0 singularity: " + "; ".join(
                f"{t.graph}: {(t.sat_sim if c.quantity == 'saturation_end_time' else t.sim)['message']}"
                for t in sing)
        results.append(ClaimResult(c, measured, holds, verdict, reason))

    # sensitivity on the first (default) topology
    sens = []
    g0 = graphs[0]
    for phi in settings["phi_sweep"]:
        say(f"sensitivity: boundary layer {phi:g}")
        r = run(g0, replace(case.options, phi=phi))
        sens.append(_sens_row("boundary_layer", phi, r, frac, None))
    for lim in settings["torque_limit_sweep"]:
        say(f"sensitivity: torque limit {lim:g}")
        r = run(g0, replace(case.options, torque_limit=lim or None))
        sens.append(_sens_row("torque_limit", lim or None, r, frac, lim or None))

    spec = load_spec()
    findings = all_findings(g0)
    return VerificationResult(
        case_name=case.name, case_path=case.path, topologies=tuple(runs), claims=tuple(results),
        sensitivity=tuple(sens), kv_required=kv_req, ubar=tuple(float(x) for x in ubar),
        assumptions=case.assumptions, topology_note=settings["topology_note"],
        derivation_report=f"{report_basename(spec, g0)}.md",
        derivation_verdicts=tuple((f.key, f.verdict) for f in findings),
        saturation_torque_limit=settings["saturation_torque_limit"],
        default_sim=default_result, kv_check=kv,
    )


def _observations(res: VerificationResult) -> list[str]:
    """Plain-language trends read off the sensitivity rows (no numbers typed in)."""
    out = []
    bl = [r for r in res.sensitivity if r.parameter == "boundary_layer" and r.status != "singular"]
    if len(bl) >= 2:
        a, b = bl[0], bl[-1]
        out.append(
            f"Widening the boundary layer from {a.value:g} to {b.value:g} changes the steady-state "
            f"relative attitude Q_m from {a.tail_q_m:.3g} to {b.tail_q_m:.3g}, the relative rate "
            f"Omega_m from {a.tail_omega_m:.3g} to {b.tail_omega_m:.3g} rad/s and the absolute "
            f"rate left at the end from {a.final_abs_rate:.3g} to {b.final_abs_rate:.3g} rad/s "
            "(inside the boundary layer the switching term no longer cancels the disturbance, "
            "so the formation keeps a common drift); chattering ends at "
            f"{_fmt(a.chatter_end_time, 's')} and {_fmt(b.chatter_end_time, 's')} respectively."
        )
    tl = [r for r in res.sensitivity if r.parameter == "torque_limit"]
    ok = [r for r in tl if r.status != "singular" and r.value is not None]
    bad = [r for r in tl if r.status == "singular"]
    if ok:
        lo = min(ok, key=lambda r: r.value)
        out.append(f"The smallest swept torque limit with which the case completes is "
                   f"{lo.value:g} N m (convergence at {_fmt(lo.convergence_time, 's')}).")
    for r in bad:
        out.append(f"Torque limit {r.value:g} N m: {r.message}.")
    return out


def _margin(res: Any) -> float | None:
    """Rigorous lower bound of min lambda_min when certified, else the (negative) hint."""
    if res.margin_lower_bound is not None:
        return float(res.margin_lower_bound)
    hints = [fm.hint for fm in res.families]
    return float(min(hints)) if hints else None


def _sens_row(param: str, value: float | None, r: Any, frac: float, limit: float | None) -> SensitivityRow:
    q = _sim_quantities(r, frac)
    sl = _tail(r, frac)
    rev = int(_reversals(r.u)[sl].sum())
    return SensitivityRow(
        parameter=param, value=value,
        convergence_time=r.convergence_time, tail_q_m=q["tail_q_m"], tail_omega_m=q["tail_omega_m"],
        final_abs_rate=q["final_abs_rate"], chatter_end_time=q["chatter_end_time"],
        chatter_reversals_tail=rev,
        saturation_end_time=r.saturation_end_time if limit and r.status != "singular" else None,
        status=r.status, message=r.message(),
    )


def _fmt(v: Any, unit: str = "") -> str:
    if v is None:
        return "never" if unit == "s" else "-"
    if isinstance(v, float) and math.isinf(v):
        return "not converged"
    if isinstance(v, float):
        return f"{v:.3g}" + (f" {unit}" if unit and unit != "-" else "")
    return str(v)


def write_verification_report(
    res: VerificationResult, out_dir: str | Path = "reports",
    command: str = "formsync verify liang2016",
) -> tuple[Path, tuple[Path, ...]]:
    """Write ``<case>-verification.md`` and its figures under ``out_dir``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from formsync_design.sim.figures import all_figures, save_figure

    default_result, kv = res.default_sim, res.kv_check
    out = Path(out_dir)
    figdir = out / "figures" / f"{res.case_name}-verification"
    figdir.mkdir(parents=True, exist_ok=True)
    figs: list[Path] = []
    for name, fig in all_figures(default_result).items():
        figs.append(save_figure(fig, figdir / f"{name}.png"))
    # metrics across topologies are in the table; sensitivity figures
    for param, xlabel in (("boundary_layer", "boundary layer phi"),
                          ("torque_limit", "torque limit (N m)")):
        rows = [r for r in res.sensitivity if r.parameter == param]
        if not rows:
            continue
        fig, ax = plt.subplots(1, 2, figsize=(9, 3.4))
        xs = [r.value if r.value is not None else float("nan") for r in rows]
        if param == "boundary_layer":
            ax[0].loglog(xs, [r.tail_q_m for r in rows], "o-", label="tail Q_m")
            ax[0].loglog(xs, [r.tail_omega_m for r in rows], "s-", label="tail Omega_m (rad/s)")
            ax[0].loglog(xs, [r.final_abs_rate for r in rows], "^-", label="final |omega_i| (rad/s)")
            ax[0].set_xlabel(xlabel)
            ax[0].set_title("steady-state accuracy")
            ax[0].legend(fontsize=7)
            ax[1].semilogx(xs, [r.chatter_end_time or 0.0 for r in rows], "o-")
            ax[1].set_xlabel(xlabel)
            ax[1].set_ylabel("chattering ends (s)")
            ax[1].set_title("chattering")
        else:
            labels = [_fmt(r.value) if r.value is not None else "none" for r in rows]
            conv = [r.convergence_time if r.convergence_time is not None else np.nan for r in rows]
            ax[0].bar(labels, conv)
            ax[0].set_xlabel(xlabel)
            ax[0].set_ylabel("convergence time (s)")
            ax[1].bar(labels, [r.saturation_end_time or 0.0 for r in rows])
            ax[1].set_xlabel(xlabel)
            ax[1].set_ylabel("saturation ends (s)")
        fig.tight_layout()
        figs.append(save_figure(fig, figdir / f"sensitivity-{param}.png"))

    L: list[str] = []
    w = L.append
    w(f"# Verification of {res.case_name}: parameters and claims")
    w("")
    w(f"Regenerate with `{command}`. Case file: `verification/{Path(res.case_path).name}`. "
      "The verification re-derives the conditions, certifies the published gains with the derived "
      "and with the printed conditions, simulates the nonlinear formation on every candidate "
      "topology, and judges each published claim.")
    w("")
    w("## Assumptions")
    w("")
    for a in res.assumptions:
        w(f"- {a}")
    w(f"- the saturation claim is judged with a per-axis torque limit of "
      f"{res.saturation_torque_limit:g} N m: the paper shows saturation but does not print its "
      "limit (see the sensitivity study for other limits)")
    w("")
    w("## Candidate topologies")
    w("")
    w(res.topology_note)
    w("")
    w("| graph | λ_max(L) | max degree | certified (derived conditions) | margin | "
      "certified (printed conditions) | simulation | convergence time |")
    w("| --- | --- | --- | --- | --- | --- | --- | --- |")
    for t in res.topologies:
        conv = (_fmt(t.sim["convergence_time"], "s") if t.sim["convergence_time"] is not None
                else f"not within {t.sim['tf']:g} s")
        w(f"| `{t.graph}` | {t.lambda_max:.4g} | {t.max_degree} | {t.derived_status} | "
          f"{_fmt(t.derived_margin)} | {t.paper_status} | {t.sim['status']} | {conv} |")
    w("")
    w("## Claims")
    w("")
    heads = " | ".join(f"`{t.graph}`" for t in res.topologies)
    w(f"| claim | paper | criterion | {heads} | verdict |")
    w("| --- | --- | --- | " + " | ".join("---" for _ in res.topologies) + " | --- |")
    for c in res.claims:
        s = c.spec
        cells = " | ".join(
            f"{_fmt(c.measured[t.graph], s.unit)} {'✓' if c.holds_on[t.graph] else '✗'}"
            for t in res.topologies)
        w(f"| {s.text} | {s.paper} | `{s.quantity} {s.op} {s.value:g}` {s.unit} | {cells} | "
          f"**{c.verdict}** |")
    w("")
    w("Reasons and readings:")
    w("")
    for c in res.claims:
        w(f"- **{c.spec.key}** ({c.verdict}: {c.reason}). {c.spec.note} "
          f"Quantity: {QUANTITIES[c.spec.quantity][0]}.")
    w("")
    w("## Disturbance bound and K_vi")
    w("")
    w("| spacecraft | ū_d (N m) | K_vi* derived | K_vi used |")
    w("| --- | --- | --- | --- |")
    for i, (u, r) in enumerate(zip(res.ubar, res.kv_required), start=1):
        w(f"| {i} | {u:.4g} | {r:.4g} | {float(kv.kv[i - 1]):g} |")
    w("")
    w("## Derivation verdicts")
    w("")
    w(f"From the derivation report [`{res.derivation_report}`]({res.derivation_report}) "
      "(paper versus derivation):")
    w("")
    for k, v in res.derivation_verdicts:
        w(f"- `{k}`: **{v}**")
    w("")
    w(f"## Figures (default topology `{res.topologies[0].graph}`, mirroring the paper's Figs. 3-6)")
    w("")
    for p in figs:
        rel = p.relative_to(out)
        w(f"![{p.stem}]({rel.as_posix()})")
        w("")
    w("## Sensitivity study")
    w("")
    w("The paper notes that widening the saturation function's boundary layer removes chattering "
      "but lowers accuracy, and that the control saturates at the start; it does not quantify "
      "either. On the default topology:")
    w("")
    w("| parameter | value | status | convergence time | tail Q_m | tail Ω_m (rad/s) | "
      "final abs. rate (rad/s) | chattering ends | reversals in tail | saturation ends |")
    w("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for r in res.sensitivity:
        val = _fmt(r.value) if r.value is not None else "none"
        if r.status == "singular":
            w(f"| {r.parameter} | {val} | singular (q0 -> 0) | - | - | - | - | - | - | - |")
            continue
        conv = _fmt(r.convergence_time, "s") if r.convergence_time is not None else "not within tf"
        sat = ("-" if r.parameter != "torque_limit" or r.value is None
               else _fmt(r.saturation_end_time, "s"))
        w(f"| {r.parameter} | {val} | {r.status} | {conv} | {_fmt(r.tail_q_m)} | "
          f"{_fmt(r.tail_omega_m)} | {_fmt(r.final_abs_rate)} | {_fmt(r.chatter_end_time, 's')} | "
          f"{r.chatter_reversals_tail} | {sat} |")
    w("")
    for line in _observations(res):
        w(f"- {line}")
    w("")
    md = out / f"{res.case_name}-verification.md"
    md.write_text("\n".join(L) + "\n")
    return md, tuple(figs)


def verification_json(res: VerificationResult) -> str:
    """The verdicts as JSON text."""
    return json.dumps(res.to_dict(), indent=2, default=str)
