"""The verifier of the fly-around case kind (``[case] kind = "flyaround"``).

:func:`verify_flyaround` simulates the case (compiled, :mod:`formsync_design.sim.flyaround`),
computes every quantity of :data:`QUANTITIES` from the run, judges the claims, runs the
sensitivity study and the allocation comparison (pseudo-inverse shift / clip against the
minimum-fuel LP), and certifies the loop (:mod:`formsync_design.analysis.flyaround`).
:func:`verify_flyaround_case` is the ``formsync verify`` entry point (registered in
:mod:`formsync_design.verify.kinds`).

Judging rules (every verdict computed in the run)
--------------------------------------------------
* a published number ``P`` with ``match = "rel:R"`` holds when ``|ours - P| <= R P``;
  with ``match = "factor:F"`` when ``P/F <= ours <= F P``;
* a qualitative claim holds when its quantity satisfies ``op bound``;
* the steady state is ``t >= steady_from``; per-axis maxima (the attitude error is the
  rotation-vector component ``4 atan|sigma| sigma_k/|sigma|``, the rate error
  ``omega_sd,k``);
* ``min_pulse_fraction``: the pulses fired at ``t >= 100 s`` that are exactly the minimum
  pulse, over all pulses fired then;
* ``final_plane_error_deg``: the plane fitted (SVD) to the relative positions of the last
  fly-around period against the reference plane's tilt ``alpha_rT``;
  ``final_radius_error_m``: ``max ||rho| - a|`` over that period;
* ``transition_overshoot_deg``: the elevation of ``rho`` above the fly-around plane; the
  largest rise of its magnitude above its running minimum;
* ``pointing_error_deg``: the angle between the body ``x`` axis and the line of sight to
  the target (``-rho``) at ``t >= 100 s``;
* a run whose state went non-finite (status ``diverged``) has no steady state: every
  quantity is nan and every claim judged on it fails, its rule naming the divergence time;
  ``formsync verify`` then exits 1 (a negative finding) and says ``diverged at t = ...``.
"""

from __future__ import annotations

import enum
import math
import sys
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from formsync_design.errors import InputError
from formsync_design.gains import json_number
from formsync_design.sim.flyaround import rotation_vectors
from formsync_design.verify.kinds import VerifyRequest

__all__ = ["QUANTITIES", "METRICS", "Verdict", "diverged_time", "ClaimResult", "FlyaroundVerification", "run_metrics",
           "verify_flyaround", "verify_flyaround_case", "pointing_errors"]

#: Time after which the paper says the pulses are mostly minimum pulses (s).
MIN_PULSE_AFTER = 100.0


class Verdict(enum.StrEnum):
    """A claim's verdict."""

    HOLDS = "holds"
    FAILS = "fails"


def _mrp_matrices(sigma: np.ndarray) -> np.ndarray:
    """``R(sigma)`` (body to inertial) for ``(K, 3)`` MRPs, vectorized."""
    n2 = np.einsum("ki,ki->k", sigma, sigma)
    sx = np.zeros((sigma.shape[0], 3, 3))
    sx[:, 0, 1], sx[:, 0, 2], sx[:, 1, 2] = -sigma[:, 2], sigma[:, 1], -sigma[:, 0]
    sx[:, 1, 0], sx[:, 2, 0], sx[:, 2, 1] = sigma[:, 2], -sigma[:, 1], sigma[:, 0]
    sx2 = sx @ sx
    den = ((1 + n2) ** 2)[:, None, None]
    return np.eye(3)[None] + (8 * sx2 + 4 * (1 - n2)[:, None, None] * sx) / den


def pointing_errors(run: Any) -> np.ndarray:
    """Angle (rad) between the body ``x`` axis and the line of sight to the target, per
    sample ``t_k``."""
    sc = run.scenario
    x = run.states[:-1]
    u = sc.target.argp + sc.target.nu + sc.mean_motion * run.t
    c, s = np.cos(u), np.sin(u)
    los_t = -x[:, :3] / np.linalg.norm(x[:, :3], axis=1)[:, None]
    los_i = np.stack([c * los_t[:, 0] - s * los_t[:, 1], s * los_t[:, 0] + c * los_t[:, 1],
                      los_t[:, 2]], axis=1)  # C_TI^T los_T
    r_ib = _mrp_matrices(x[:, 6:9])
    los_b = np.einsum("kji,kj->ki", r_ib, los_i)  # C_bI los_I = R^T los_I
    return np.arccos(np.clip(los_b[:, 0], -1.0, 1.0))


def _plane_normal(params: Any) -> np.ndarray:
    from formsync_design.models.flyaround import rotation_rT

    return rotation_rT(params).T @ np.array([0.0, 0.0, 1.0])  # z_r in T


def _max(a: np.ndarray) -> float:
    """``max`` of an array, nan when it is empty (a window the run does not reach)."""
    return float(np.max(a)) if np.size(a) else math.nan


#: The names :func:`run_metrics` returns, in order.
METRICS = ("rate_error_deg_s", "attitude_error_deg", "attitude_error_axis", "velocity_error_m_s",
           "position_error_m", "delta_v_m_s", "fuel_kg", "min_pulse_fraction",
           "final_plane_error_deg", "final_radius_error_m", "transition_overshoot_deg",
           "pointing_error_deg", "delta_v_net_m_s", "pulses_after_100s", "final_elevation_deg",
           "initial_elevation_deg", "shadow_switches", "raw_min_thrust_n",
           "negative_samples_fraction", "allocation_shortfall_max",
           "allocation_shortfall_after_100s", "saturated_samples", "fallback_frames")


def diverged_time(run: Any) -> float | None:
    """The time a run's state went non-finite (None: the run completed)."""
    return run.diverged_time if str(getattr(run, "status", "")) == "diverged" else None


def run_metrics(run: Any, steady_from: float) -> dict[str, float]:
    """Every quantity of :data:`QUANTITIES` and the report's further numbers for a run
    (:data:`METRICS`; all nan for a diverged run)."""
    if diverged_time(run) is not None:
        return dict.fromkeys(METRICS, math.nan)
    o = run.outputs
    sc = run.scenario
    opt = run.options
    ss = run.window(steady_from)
    rv = np.degrees(np.abs(rotation_vectors(o["sigma_sd"][ss])))
    rate = np.degrees(np.abs(o["omega_sd"][ss]))
    dx = np.abs(o["dX"][ss])
    m = sc.layout.count
    tau = o["on_time"][:, :m]
    after = run.t >= MIN_PULSE_AFTER
    fired = tau[after] > 0
    n_fired = int(fired.sum())
    is_min = np.abs(tau[after] - opt.min_pulse) <= 1e-9
    x = run.states[:-1]
    rho = x[:, :3]
    r = np.linalg.norm(rho, axis=1)
    last = run.t >= run.t[-1] - sc.reference.period
    pts = rho[last]
    normal = np.linalg.svd(pts - pts.mean(axis=0), full_matrices=False)[2][-1]
    tilt = math.degrees(math.acos(min(1.0, abs(float(normal[2])))))
    elev = np.degrees(np.abs(np.arcsin(np.clip(rho @ _plane_normal(sc.reference) / r, -1, 1))))
    overshoot = float(np.max(elev - np.minimum.accumulate(elev)))
    point = np.degrees(pointing_errors(run))
    amat = sc.layout.matrix
    short = o["wrench_cmd"] - (amat @ o["thrust_cmd"][:, :m].T).T
    saturated = int(np.sum(np.any(tau >= opt.sample_period - 1e-12, axis=1)))
    short_norm = np.abs(short).max(axis=1)
    return {
        "rate_error_deg_s": _max(rate),
        "attitude_error_deg": _max(rv),
        "attitude_error_axis": float(np.argmax(rv.max(axis=0))) if rv.size else math.nan,
        "velocity_error_m_s": _max(dx[:, 3:]),
        "position_error_m": _max(dx[:, :3]),
        "delta_v_m_s": run.delta_v,
        "fuel_kg": run.fuel,
        "min_pulse_fraction": float(is_min[fired].sum() / n_fired) if n_fired else math.nan,
        "final_plane_error_deg": abs(tilt - math.degrees(sc.reference.alpha)),
        "final_radius_error_m": float(np.max(np.abs(r[last] - sc.reference.a))),
        "transition_overshoot_deg": overshoot,
        "pointing_error_deg": _max(point[after]),
        # further numbers of the report
        "delta_v_net_m_s": run.delta_v_net,
        "pulses_after_100s": float(n_fired),
        "final_elevation_deg": float(elev[-1]),
        "initial_elevation_deg": float(elev[0]),
        "shadow_switches": float(np.sum(o["switched"])),
        "raw_min_thrust_n": float(np.min(o["raw_min"])),
        "negative_samples_fraction": float(np.mean(o["raw_min"] < 0)),
        "allocation_shortfall_max": float(short_norm.max()),
        "allocation_shortfall_after_100s": _max(short_norm[after]),
        "saturated_samples": float(saturated),
        "fallback_frames": float(np.sum(o["frame_status"] != 0)),
    }


#: Quantity name -> (unit, description): what a claim may judge.
QUANTITIES: dict[str, tuple[str, str]] = {
    "rate_error_deg_s": ("deg/s", "steady-state max per-axis attitude-rate error"),
    "attitude_error_deg": ("deg", "steady-state max per-axis attitude error"),
    "velocity_error_m_s": ("m/s", "steady-state max per-axis relative-velocity error"),
    "position_error_m": ("m", "steady-state max per-axis relative-position error"),
    "delta_v_m_s": ("m/s", "total thruster impulse / mass"),
    "fuel_kg": ("kg", "total thruster impulse / exhaust velocity"),
    "min_pulse_fraction": ("", "share of the pulses after 100 s that are minimum pulses"),
    "final_plane_error_deg": ("deg", "tilt of the last period's plane minus alpha_rT"),
    "final_radius_error_m": ("m", "max ||rho| - a| over the last period"),
    "transition_overshoot_deg": ("deg", "largest rise of the elevation above the plane"),
    "pointing_error_deg": ("deg", "max sensor-axis pointing error after 100 s"),
}


@dataclass(frozen=True)
class ClaimResult:
    """One judged claim."""

    id: str
    text: str
    quantity: str
    ours: float
    verdict: Verdict
    rule: str
    paper: float | None = None
    why: str = ""

    def to_dict(self) -> dict[str, Any]:
        return {"id": self.id, "text": self.text, "quantity": self.quantity,
                "ours": json_number(self.ours), "paper": json_number(self.paper)
                if self.paper is not None else None, "rule": self.rule,
                "verdict": str(self.verdict), "why": self.why}


def judge(case: Any, metrics: dict[str, float], diverged: float | None = None) -> list[ClaimResult]:
    """The claims of ``case`` judged on ``metrics`` (module docstring); ``diverged``: the
    time the run went non-finite, which fails every claim."""
    if diverged is not None:
        note = f"the run diverged at t = {diverged:g} s (non-finite state)"
        return [ClaimResult(c["id"], c["text"], c["quantity"], math.nan, Verdict.FAILS, note,
                            c["value"], c["why"]) for c in case.published] + [
                ClaimResult(c["id"], c["text"], c["quantity"], math.nan, Verdict.FAILS, note, None,
                            c["why"]) for c in case.qualitative]
    out = []
    for c in case.published:
        v = metrics[c["quantity"]]
        p, tol = c["value"], c["match_tol"]
        if c["match_kind"] == "rel":
            ok, rule = abs(v - p) <= tol * abs(p), f"within {tol:.0%} of the paper's"
        else:
            ok, rule = p / tol <= v <= p * tol, f"within a factor {tol:g} of the paper's"
        out.append(ClaimResult(c["id"], c["text"], c["quantity"], v,
                               Verdict.HOLDS if ok else Verdict.FAILS, rule, p, c["why"]))
    for c in case.qualitative:
        v = metrics[c["quantity"]]
        ok = bool(v <= c["bound"]) if c["op"] == "<=" else bool(v >= c["bound"])
        out.append(ClaimResult(c["id"], c["text"], c["quantity"], v,
                               Verdict.HOLDS if ok and math.isfinite(v) else Verdict.FAILS,
                               f"{c['op']} {c['bound']:g}", None, c["why"]))
    return out


@dataclass(frozen=True)
class FlyaroundVerification:
    """Everything a fly-around verification computed (for the report and JSON)."""

    case: Any
    run: Any
    metrics: dict
    claims: list
    sensitivity: list  # (label, metrics, options, scenario)
    allocation: dict  # name -> metrics (pinv-shift = base, pinv-clip, lp)
    lp_check: dict
    orbit_cert: Any
    attitude_cert: Any
    derivation: Any
    findings: dict
    series: dict = field(default_factory=dict)  # name -> (t, values): figure data of other runs

    @property
    def all_hold(self) -> bool:
        return all(c.verdict == Verdict.HOLDS for c in self.claims)

    def to_dict(self) -> dict[str, Any]:
        return {
            "case": self.case.name, "digest": self.case.digest,
            "claims": [c.to_dict() for c in self.claims],
            "metrics": {k: json_number(v) for k, v in self.metrics.items()},
            "sensitivity": [{"label": s[0], **{k: json_number(v) for k, v in s[1].items()}}
                            for s in self.sensitivity],
            "allocation": {k: {q: json_number(v) for q, v in m.items()}
                           for k, m in self.allocation.items()},
            "lp_check": {k: json_number(v) for k, v in self.lp_check.items()},
            "orbit_certificate": self.orbit_cert.to_dict(),
            "attitude_certificate": self.attitude_cert.to_dict(),
            "derivation": self.derivation.to_dict(),
            "findings": {k: json_number(v) if isinstance(v, float) else v
                         for k, v in self.findings.items()},
            "all_hold": self.all_hold,
        }


def _lp_check(run: Any, samples: int = 60) -> dict[str, float]:
    """Re-solve evenly spaced samples of the LP run with cvxpy + Clarabel (bounded LP)."""
    from formsync_design.models.allocation import BoundedLP

    lay = run.scenario.layout
    m = lay.count
    lp = BoundedLP(lay)
    idx = np.linspace(0, run.t.size - 1, samples).astype(int)
    diff = 0.0
    for k in idx:
        w = run.outputs["wrench_cmd"][k]
        ref = lp.solve(w)
        ours = float(run.outputs["thrust_cmd"][k, :m].sum())
        diff = max(diff, abs(ours - ref.fuel_thrust) / max(1.0, ref.fuel_thrust))
    return {"samples": float(samples), "max_relative_fuel_difference": diff,
            "fallbacks": float(run.lp_fallbacks)}


def verify_flyaround(path: str | Path | None = None, spec: Any = None,
                     progress: Callable[[str], None] | None = None) -> FlyaroundVerification:
    """Run the whole verification of a fly-around case (module docstring).

    ``path`` is a case file (default: the shipped ``zhang2014_flyaround``, about a minute
    and a half); the example shortens it to 160 s without a sensitivity study:

    >>> import tempfile
    >>> from pathlib import Path
    >>> from formsync_design.resources import case_file
    >>> text = case_file("zhang2014_flyaround").read_text()
    >>> text = text.replace("tf = 18000.0", "tf = 160.0").replace("steady_from = 1000.0",
    ...                                                          "steady_from = 120.0")
    >>> text = text[:text.index("[sensitivity]")] + text[text.index("[certificate]"):]
    >>> short = Path(tempfile.mkdtemp()) / "short.toml"
    >>> _ = short.write_text(text)
    >>> res = verify_flyaround(short)
    >>> [c.id for c in res.claims][:3], str(res.attitude_cert.status)
    (['rate_error', 'attitude_error', 'velocity_error'], 'certified')
    >>> res.allocation["lp"]["fuel_kg"] < res.allocation["pinv-shift"]["fuel_kg"]
    True
    """
    from dataclasses import replace

    from formsync_design.analysis.flyaround import attitude_certificate, orbit_certificate
    from formsync_design.derive.tracking import derive_tracking_attitude
    from formsync_design.models.flyaround import printed_phi_finding
    from formsync_design.models.thrusters import rocket_fuel
    from formsync_design.sim.flyaround import simulate_flyaround
    from formsync_design.spec.loader import load_spec
    from formsync_design.verify.flyaround_case import apply_variant, load_flyaround_case

    say = progress or (lambda _m: None)
    case = load_flyaround_case(path)
    if spec is not None:
        s = load_spec(spec)
        if s.decl.kind != "tracking" or s.path == "<python>":
            raise InputError(f"expected a tracking design file for the fly-around case "
                             f"{case.path}, received {s.name} (a {s.decl.kind} design"
                             f"{', built in Python' if s.path == '<python>' else ''})")
        case = replace(case, design=s.path)
    design = case.spec
    say("derive the attitude loop")
    der = derive_tracking_attitude(design)
    say(f"simulate {case.options.tf:g} s ({case.options.samples} samples)")
    run = simulate_flyaround(case.scenario, case.options, design)
    metrics = run_metrics(run, case.steady_from)
    claims = judge(case, metrics, diverged_time(run))
    series = {f"fuel:{case.options.allocation}": _cumulative_fuel(run),
              "elevation:corrected": _elevation(run)}
    alloc: dict[str, dict] = {case.options.allocation: metrics}
    lp_check: dict[str, float] = {}
    for name in ("pinv-shift", "pinv-clip", "lp"):
        if name in alloc:
            continue
        say(f"simulate with allocation {name}")
        r = simulate_flyaround(case.scenario, replace(case.options, allocation=name), design)
        alloc[name] = run_metrics(r, case.steady_from)
        series[f"fuel:{name}"] = _cumulative_fuel(r)
        if name == "lp" and diverged_time(r) is None:
            say("re-solve LP samples with cvxpy + Clarabel")
            lp_check = _lp_check(r)
        del r  # a run holds ~60 MB: keep only what the figures need
    sens = []
    for v in case.sensitivity:
        say(f"sensitivity: {v.label}")
        sc, opt = apply_variant(case, v)
        r = simulate_flyaround(sc, opt, design)
        sens.append((v.label, run_metrics(r, case.steady_from), opt, sc))
        if opt.reading == "printed":
            series["elevation:printed"] = _elevation(r)
        del r
    say("certify the orbit and attitude loops")
    oc = orbit_certificate(case)
    ac = attitude_certificate(case)
    f = printed_phi_finding(case.scenario.reference, case.options.tf)
    findings = {
        "printed_phi_span_rad": f.printed_span,
        "printed_phi_final_gap_deg": math.degrees(f.printed_final_gap),
        "rocket_fuel_of_paper_dv_kg": rocket_fuel(15.8065, case.scenario.mass,
                                                  case.options.exhaust_velocity),
        "impulse_fuel_of_paper_dv_kg": 15.8065 * case.scenario.mass
        / case.options.exhaust_velocity,
    }
    return FlyaroundVerification(case, run, metrics, claims, sens, alloc, lp_check, oc, ac, der,
                                 findings, series)


def _cumulative_fuel(run: Any, every: int = 50) -> tuple[np.ndarray, np.ndarray]:
    cum = np.cumsum(run.impulses.sum(axis=1)) / run.options.exhaust_velocity
    return run.t[::every].copy(), cum[::every].copy()


def _elevation(run: Any, every: int = 50) -> tuple[np.ndarray, np.ndarray]:
    rho = run.states[:-1:every, :3]
    e = np.degrees(np.arcsin(np.clip(rho @ _plane_normal(run.scenario.reference)
                                     / np.linalg.norm(rho, axis=1), -1, 1)))
    return run.t[::every].copy(), e


def verify_flyaround_case(req: VerifyRequest) -> int:
    """``formsync verify`` on a fly-around case (exit status: module docstring of
    :mod:`formsync_design.verify.kinds`)."""
    import json

    from formsync_design.verify.flyaround_report import write_flyaround_report
    from formsync_design.verify.output import display_path

    res = verify_flyaround(req.path, spec=req.design, progress=req.progress)
    req.progress("write the report")
    cmd = req.command()
    md, figs = write_flyaround_report(res, req.out, display_path(req.path), cmd)
    if req.format == "json":
        sys.stdout.write(json.dumps(res.to_dict(), indent=2, sort_keys=True) + "\n")
    else:
        sys.stdout.write(f"wrote {md} ({len(figs)} figures)\n")
        if diverged_time(res.run) is not None:
            sys.stdout.write(f"  the simulation {res.run.message}\n")
        for c in res.claims:
            sys.stdout.write(f"  {c.verdict:6s} {c.text}\n")
    if diverged_time(res.run) is not None or (req.strict and not res.all_hold):
        return 1
    return 0
