"""The report sections of the tracking form (:mod:`formsync_design.verify.engine_tracking`)
that :mod:`formsync_design.verify.engine_report` writes in place of the agent form's: the
scenarios table, the certificates (LQR evidence, the attitude law's derivation and box
certificate), the scope of every simulated run, the figures and their JSON tables.  Every
number is computed in the run; the format is fixed (a rerun is byte-identical)."""

from __future__ import annotations

from typing import Any

from formsync_design.gains import json_number

__all__ = ["scenario_section", "certificate_section", "evidence_section", "figures",
           "json_tables"]


def _cell(text: Any) -> str:
    return " ".join(str(text).split()).replace("|", "\\|")


def _g(x: Any, digits: int = 4) -> str:
    return f"{float(x):.{digits}g}"


def _over(s: Any) -> str:
    return "; ".join(f"{t}: " + ", ".join(f"{k} = {v}" for k, v in sorted(d.items()))
                     for t, d in sorted(s.overrides.items())) or "none"


def scenario_section(case: Any) -> list[str]:
    """``## Scenarios``: every scenario's overrides and run settings."""
    L = ["## Scenarios", "",
         "Each scenario is the base case with the overrides shown, simulated once over tf: "
         "one control sample per sample period, the PWM pulses of every sample integrated "
         "inside it (RK4 sub-steps with the exact average thrust of every pulse).  The "
         "steady state of the steady-state metrics is t >= steady_from.", "",
         "| scenario | description | overrides | tf (s) | sample (s) | allocation | minimum "
         "pulse (ms) | rounding carried | phi_r reading | steady_from (s) |",
         "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for s in case.scenarios:
        o = s.case.options
        L.append(f"| {s.name} | {_cell(s.description) or '-'} | {_cell(_over(s))} | {o.tf:g} | "
                 f"{o.sample_period:g} | {o.allocation} | {o.min_pulse * 1e3:g} | "
                 f"{'yes' if o.carry else 'no'} | {o.reading} | {s.case.steady_from:g} |")
    return L


def certificate_section(ver: Any) -> list[str]:
    """``## Certificates``: the orbit loop's LQR evidence and the attitude law's derivation
    and box certificate of the base case (:mod:`formsync_design.verify.metrics_tracking`)."""
    from formsync_design.verify.metrics_tracking import certificates

    case = ver.case.tracking
    oc, ac, der = certificates(ver.results, case)
    mg = oc.margins
    L = ["## Certificates", "", "Of the base case (`formsync_design/analysis/tracking.py`, "
         "`formsync_design/derive/tracking.py`).", "", "### Orbit: LQR on the CW model", "",
         f"- Riccati residual {_g(oc.riccati_residual, 3)} (relative); closed-loop "
         f"eigenvalues in Re < {_g(oc.max_real_part)} 1/s [numerical].",
         f"- Guaranteed margins of an LQR with diagonal R (gain in [1/2, inf), phase +-60 deg "
         f"per channel): **{mg.status}**; return difference >= {_g(mg.min_return_difference)} "
         f"on the frequency grid, worst real part {_g(mg.worst_gain_real_part)} over the gain "
         f"vertices and {_g(mg.worst_phase_real_part)} over the phase vertices; common gain "
         f"reduction to {_g(mg.gain_margin_low)} and common phase {_g(mg.phase_margin_deg)} deg "
         "keep the loop stable [numerical].",
         f"- Sampled loop (zero-order hold at {case.options.sample_period:g} s, no PWM): "
         f"spectral radius {oc.sampled_spectral_radius:.6f} (< 1: stable; floating point, "
         "without the PWM quantization) [numerical].", "",
         "### Attitude: the tracking law", "",
         f"- Derived (SymPy, any symmetric inertia, any reference rates): along the closed "
         f"loop with the law's inertia equal to the plant's, `V' = {der.vdot}`; the claim "
         f"`V' = -w^T K_d w` **{'holds' if der.nominal_holds else 'fails'}** exactly; with "
         "V >= 0 and the MRP short set this gives the literature's tracking result "
         "(Barbalat: w_sd -> 0 and sigma_sd -> 0) [certificate].",
         f"- With a mismatched inertia the derivative gains `w^T[w_s x dJ w_s + dJ (a_d - "
         f"w x w_d)]`, dJ = J_law - J (derived: **{'matches' if der.mismatch_matches else 'differs'}**) "
         "[certificate].",
         f"- Box certificate (linearized error dynamics, exact re-check at {ac.vertices} "
         f"vertices): **{ac.status}** for k_p in [{_g(ac.box['k_p'][0])}, "
         f"{_g(ac.box['k_p'][1])}] N m, "
         + ", ".join(f"K_d,{i + 1} in [{_g(lo)}, {_g(hi)}]" for i, (lo, hi) in enumerate(ac.box["K_d"]))
         + " N m s, plant inertia "
         + ", ".join(f"J_{i + 1} in [{_g(lo)}, {_g(hi)}]" for i, (lo, hi) in enumerate(ac.box["J"]))
         + " kg m^2 (the law keeps the case's J) and every reference with |w_di,k| <= "
         + ", ".join(_g(v, 3) for v in ac.box["W"]) + " rad/s, |w_di,k'| <= "
         + ", ".join(_g(v, 3) for v in ac.box["A"])
         + f" rad/s^2 ({_g(case.certificate['rate_margin'])} x the maxima of the case's "
         f"reference): V = x^T P x with p = ({', '.join(_g(v) for v in ac.p)}) decreases at "
         f"rate 2 alpha, alpha = {_g(ac.alpha)} 1/s; margin mu = {_g(ac.mu)} against the bound "
         f"{_g(ac.n_bound)} on |N|_F of the reference-rate terms.  The mismatch leaves a "
         f"forcing |d| <= {_g(ac.forcing_bound, 3)} N m: bounded errors, not convergence to "
         "zero.  Scope: local (first order in the errors), the continuous loop without the "
         "sampling and the PWM [certificate]."]
    if ac.reason:
        L.append(f"- Reason: {_cell(ac.reason)}.")
    return L + [""]


def evidence_section(ver: Any) -> list[str]:
    """``## Scope of the simulation evidence``: every simulated run."""
    L = ["## Scope of the simulation evidence", "",
         "Every scenario a metric read is one simulated run of the truth model: the nonlinear "
         "relative orbit dynamics about the circular target orbit and the rigid-body attitude "
         "(MRP with shadow switch), no disturbance, the PWM pulses of every sample integrated "
         "inside it.", ""]
    for name in ver.results.simulated:
        o = ver.case.scenario(name).case.options
        L.append(f"- {name}: {o.tf:g} s, {o.samples} samples of {o.sample_period:g} s with "
                 f"{o.substeps} RK4 sub-steps each, allocation {o.allocation}, minimum pulse "
                 f"{o.min_pulse * 1e3:g} ms, rounding error "
                 f"{'carried' if o.carry else 'not carried'}, phi_r reading {o.reading} "
                 "[evidence]")
    if not ver.results.simulated:
        L.append("- no simulation")
    return L + [""]


def figures(ver: Any) -> dict[str, Any]:
    """The first scenario's run figures (``<scenario>-<figure>``), the transition into the
    plane of every scenario that changes only the phi_r reading, and the cumulative fuel of
    every scenario that changes only the allocation (beside the first scenario)."""
    from formsync_design.sim.tracking_figures import (
        flyaround_figures,
        fuel_figure,
        transition_figure,
    )

    res = ver.results
    if not res.simulated:
        return {}
    first = ver.case.scenarios[0]
    out = {f"{first.name}-{k}": f for k, f in
           flyaround_figures(res.run("chaser", first.name)).items()}
    only = {s.name: s.overrides.get("simulation", {}) for s in ver.case.scenarios
            if s.name in res.simulated and set(s.overrides) <= {"simulation"}}
    o = first.case.options
    elev = {f"{o.reading} ({first.name})": res.series[first.name]["elevation"]}
    fuel = {f"{o.allocation} ({first.name})": res.series[first.name]["fuel"]}
    for name, sim in only.items():
        if name == first.name:
            continue
        if set(sim) == {"reading"}:
            elev[f"{sim['reading']} ({name})"] = res.series[name]["elevation"]
        if set(sim) == {"allocation"}:
            fuel[f"{sim['allocation']} ({name})"] = res.series[name]["fuel"]
    out["transition"] = transition_figure(elev)
    out["fuel"] = fuel_figure(fuel)
    return out


def json_tables(ver: Any) -> dict[str, Any]:
    """The form's tables of the JSON document: formations, scenarios, certificates."""
    from formsync_design.verify.metrics_tracking import certificates

    oc, ac, der = certificates(ver.results, ver.case.tracking)
    return {
        "formations": [{"name": "chaser", "graph": "-", "n": 1, "source": "one spacecraft"}],
        "scenarios": [{"name": s.name, "overrides": s.overrides,
                       "tf": json_number(s.case.options.tf),
                       "allocation": s.case.options.allocation} for s in ver.case.scenarios],
        "certificates": [{"orbit": oc.to_dict(), "attitude": ac.to_dict(),
                          "derivation": der.to_dict()}],
    }

