"""The verifier of the fly-around case kind (``[case] kind = "flyaround"``).

:func:`verify_flyaround` simulates the case (compiled, :mod:`formsync_design.sim.tracking`),
computes every quantity of
:data:`~formsync_design.verify.tracking_claims.QUANTITIES` from the run, judges the claims, runs the
sensitivity study and the allocation comparison (pseudo-inverse shift / clip against the
minimum-fuel LP), and certifies the loop (:mod:`formsync_design.analysis.tracking`).
:func:`verify_flyaround_case` is the ``formsync verify`` entry point (registered in
:mod:`formsync_design.verify.kinds`).

The measurements, the judging rules, the claims and the result value are in
:mod:`formsync_design.verify.tracking_claims`.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from formsync_design.errors import InputError
from formsync_design.verify.kinds import VerifyRequest
from formsync_design.verify.tracking_claims import (
    FlyaroundVerification,
    diverged_time,
    judge,
    plane_normal,
    run_metrics,
)

__all__ = ["verify_flyaround", "verify_flyaround_case"]


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

    from formsync_design.analysis.tracking import attitude_certificate, orbit_certificate
    from formsync_design.derive.tracking import derive_tracking_attitude
    from formsync_design.models.pwm import rocket_fuel
    from formsync_design.models.relative_reference import printed_phi_finding
    from formsync_design.sim.tracking import simulate_flyaround
    from formsync_design.spec.loader import load_spec
    from formsync_design.verify.tracking_case import apply_variant, load_flyaround_case

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
    e = np.degrees(np.arcsin(np.clip(rho @ plane_normal(run.scenario.reference)
                                     / np.linalg.norm(rho, axis=1), -1, 1)))
    return run.t[::every].copy(), e


def verify_flyaround_case(req: VerifyRequest) -> int:
    """``formsync verify`` on a fly-around case (exit status: module docstring of
    :mod:`formsync_design.verify.kinds`)."""
    import json

    from formsync_design.verify.output import display_path
    from formsync_design.verify.tracking_report import write_flyaround_report

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
